"""One-dimensional symbolic regression engines: a list of candidate expressions per search.

Every engine answers :meth:`Engine.search` with the candidates of its
Pareto front (accuracy against size), each a SymPy expression of
:data:`~sklearn_pycc.backends.symbolic.curves.VARIABLE`. ``"operon"`` (pyoperon, C++, offline)
is the default; ``"pysr"`` needs Julia and is imported only when chosen.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy

from .curves import VARIABLE

__all__ = ["BINARY_OPERATORS", "ENGINES", "UNARY_OPERATORS", "Candidate", "make_engine"]

#: binary operators in the paper's (PySR's) spelling -> operon's symbol
BINARY_OPERATORS = {"+": "add", "-": "sub", "*": "mul", "/": "div", "^": "pow"}
#: unary operators offered by every engine -> operon's symbol
UNARY_OPERATORS = {name: name for name in (
    "tanh", "sin", "cos", "exp", "log", "sqrt", "abs", "square", "sinh", "cosh", "atan",
    "tan")}


@dataclass
class Candidate:
    """One expression found by a search."""

    expression: sympy.Expr
    complexity: int
    loss: float


class Engine:
    """A symbolic regression engine for one-dimensional data."""

    name = ""

    def search(self, x: np.ndarray, y: np.ndarray, *, binary, unary, maxsize: int,
               population_size: int, generations: int, options: dict,
               seed: int) -> list[Candidate]:
        """Candidates ``y ~ g(x)`` of increasing complexity."""
        raise NotImplementedError


# -- operon ---------------------------------------------------------------------------
def _operon():
    try:
        import pyoperon  # noqa: F401
        from pyoperon.sklearn import SymbolicRegressor
    except ImportError as exc:
        raise ImportError(
            "engine='operon' needs pyoperon: pip install 'sklearn-pycc[symbolic]' "
            f"(or pip install pyoperon); importing it failed with: {exc}") from None
    return SymbolicRegressor


def _unary_sympy(kind: str):
    table = {
        "Exp": sympy.exp, "Log": sympy.log, "Sin": sympy.sin, "Cos": sympy.cos,
        "Tan": sympy.tan, "Tanh": sympy.tanh, "Sinh": sympy.sinh, "Cosh": sympy.cosh,
        "Sqrt": sympy.sqrt, "Abs": sympy.Abs, "Atan": sympy.atan, "Asin": sympy.asin,
        "Acos": sympy.acos, "Square": lambda a: a ** 2, "Logabs": lambda a: sympy.log(
            sympy.Abs(a)), "Sqrtabs": lambda a: sympy.sqrt(sympy.Abs(a)),
        "Log1p": lambda a: sympy.log(1 + a), "Cbrt": lambda a: sympy.sign(a) * sympy.Abs(
            a) ** sympy.Rational(1, 3),
    }
    return table.get(kind)


def operon_to_sympy(tree) -> sympy.Expr:
    """The SymPy expression of an operon tree of one variable.

    Operon stores a tree in postfix order; the child nearest to its parent
    is the left operand, and a variable node carries a weight.
    """
    nodes = list(tree.Nodes)

    def build(i: int) -> sympy.Expr:
        node = nodes[i]
        kind = str(node.Type).split(".")[-1]
        if node.IsConstant:
            return sympy.Float(float(node.Value))
        if node.IsVariable:
            return sympy.Float(float(node.Value)) * VARIABLE
        children, j = [], i - 1
        for _ in range(node.Arity):
            children.append(build(j))
            j -= nodes[j].Length + 1
        if kind == "Add":
            return sympy.Add(*children)
        if kind == "Mul":
            return sympy.Mul(*children)
        if kind == "Sub":
            return -children[0] if len(children) == 1 else children[0] - sympy.Add(
                *children[1:])
        if kind == "Div":
            return 1 / children[0] if len(children) == 1 else children[0] / sympy.Mul(
                *children[1:])
        if kind == "Pow":
            return children[0] ** children[1]
        if kind == "Aq":
            return children[0] / sympy.sqrt(1 + children[1] ** 2)
        unary = _unary_sympy(kind)
        if unary is None or len(children) != 1:
            raise ValueError(f"operon returned a {kind} node, which has no SymPy translation")
        return unary(children[0])

    return build(len(nodes) - 1)


class OperonEngine(Engine):
    """Multi-objective genetic programming with local constant fitting (pyoperon)."""

    name = "operon"

    def search(self, x, y, *, binary, unary, maxsize, population_size, generations, options,
               seed):
        regressor_class = _operon()
        symbols = [BINARY_OPERATORS[b] for b in binary] + [UNARY_OPERATORS[u] for u in unary]
        settings = {
            "allowed_symbols": ",".join([*symbols, "constant", "variable"]),
            "max_length": int(maxsize),
            "population_size": int(population_size),
            "generations": int(generations),
            "optimizer_iterations": 10,
            "objectives": ["r2", "length"],
            "n_threads": 1,
            "random_state": int(seed),
        }
        settings.update(options)
        regressor = regressor_class(**settings)
        regressor.fit(np.asarray(x, dtype=float)[:, None], np.asarray(y, dtype=float))
        out = []
        for entry in regressor.pareto_front_:
            try:
                expression = operon_to_sympy(entry["tree"])
            except ValueError:
                continue
            loss = float(entry["mean_squared_error"])
            if np.isfinite(loss) and expression.is_finite is not False:
                out.append(Candidate(expression, int(entry["length"]), loss))
        return out


# -- PySR -----------------------------------------------------------------------------
class PySREngine(Engine):
    """PySR (SymbolicRegression.jl); needs a working Julia installation."""

    name = "pysr"

    def search(self, x, y, *, binary, unary, maxsize, population_size, generations, options,
               seed):
        try:
            from pysr import PySRRegressor
        except Exception as exc:
            raise ImportError(
                "engine='pysr' could not start PySR and its Julia backend "
                f"({type(exc).__name__}: {exc}). Install it with "
                "pip install 'sklearn-pycc[pysr]' on a machine that can install Julia, or "
                "use the offline default engine='operon'") from None
        settings = {
            "binary_operators": list(binary), "unary_operators": list(unary),
            "maxsize": int(maxsize), "population_size": int(population_size),
            "niterations": int(generations), "random_state": int(seed),
            "deterministic": True, "parallelism": "serial", "verbosity": 0,
            "progress": False,
        }
        settings.update(options)
        regressor = PySRRegressor(**settings)
        regressor.fit(np.asarray(x, dtype=float)[:, None], np.asarray(y, dtype=float),
                      variable_names=["x"])
        out = []
        for _, row in regressor.equations_.iterrows():
            expression = row["sympy_format"]
            expression = expression.xreplace({s: VARIABLE for s in expression.free_symbols
                                              if s.name == "x"})
            out.append(Candidate(expression, int(row["complexity"]), float(row["loss"])))
        return out


ENGINES = {"operon": OperonEngine, "pysr": PySREngine}


def make_engine(name: str) -> Engine:
    """The engine called ``name``."""
    if name not in ENGINES:
        raise ValueError(f"engine must be one of {sorted(ENGINES)}, got {name!r}")
    return ENGINES[name]()
