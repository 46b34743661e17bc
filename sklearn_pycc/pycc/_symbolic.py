"""Symbolic curves in the shapes the published package returns.

The published package returns, for each curve found by symbolic
regression, a PySR model and (after post-processing) a dict
``{"expr", "func", "pysr_model"}``. Here the same answers come from our
own search, whichever engine ran: :class:`ParetoModel` is the search's
Pareto front, answering what scripts call on a PySR model, and
:class:`SymbolicEntry` is the fitted curve, callable like any curve and
subscriptable like the published dict.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
import sympy

from ..backends.symbolic.curves import VARIABLE
from ..skeleton.curves import Curve

__all__ = ["ExpressionFunction", "ParetoModel", "SymbolicEntry", "symbolic_entries"]

#: the variable PySR writes a one-feature expression in
FEATURE = sympy.Symbol("x0")
#: columns of :attr:`ParetoModel.equations_`
COLUMNS = ("complexity", "loss", "score", "equation", "sympy_format", "lambda_format")


class ExpressionFunction:
    """A SymPy expression of ``x0`` as a numpy function (PySR's ``lambda_format``).

    Parameters
    ----------
    expression : sympy.Expr
        The expression, in ``x0``.
    """

    def __init__(self, expression: sympy.Expr) -> None:
        self.expression = expression
        self._function: Callable | None = None

    def __call__(self, X) -> np.ndarray:
        """The expression on ``X``: an array of ``x0`` values, or its one column."""
        x = _feature(X)
        if self._function is None:
            self._function = sympy.lambdify(FEATURE, self.expression, modules="numpy")
        with np.errstate(all="ignore"):
            out = self._function(x)
        return np.array(np.broadcast_to(np.asarray(out, dtype=float), x.shape))

    def __getstate__(self) -> dict:
        return {"expression": self.expression, "_function": None}

    def __repr__(self) -> str:
        return f"ExpressionFunction(x0 -> {self.expression})"


def _feature(X) -> np.ndarray:
    """The one feature of ``X``: a 1-D array, or the column of an ``(n, 1)`` array."""
    x = np.asarray(X, dtype=float)
    if x.ndim == 2:
        if x.shape[1] != 1:
            raise ValueError(f"the curve has one argument, but X has {x.shape[1]} columns")
        return x[:, 0]
    return x


def _front(table: pd.DataFrame) -> pd.DataFrame:
    """The rows no simpler row beats (lowest loss per complexity), the chosen one kept."""
    ordered = table.sort_values(["complexity", "loss"], kind="stable", ignore_index=True)
    keep, lowest = [], np.inf
    for k, row in ordered.iterrows():
        if row["loss"] < lowest or row["chosen"]:
            keep.append(k)
            lowest = min(lowest, row["loss"])
    return ordered.loc[keep].reset_index(drop=True)


def _scores(complexity: np.ndarray, loss: np.ndarray) -> np.ndarray:
    """PySR's score: the fall of log-loss per unit of added complexity (0 for the first)."""
    tiny = np.finfo(float).tiny
    log_loss = np.log(np.maximum(loss, tiny))
    out = np.zeros(len(loss))
    for k in range(1, len(loss)):
        step = complexity[k] - complexity[k - 1]
        out[k] = -(log_loss[k] - log_loss[k - 1]) / step if step > 0 else 0.0
    return out


class ParetoModel:
    """The symbolic search's Pareto front for one curve, answering as a PySR model.

    Built from the candidates our search kept (``pareto_`` of
    :class:`~sklearn_pycc.SymbolicCCRegressor` or of
    :func:`~sklearn_pycc.to_symbolic`), whichever engine ran. Expressions are
    written in ``x0``, as PySR names a single feature.

    Parameters
    ----------
    name : str
        The curve (``"f1"``).
    curve : Curve
        The fitted curve: the chosen expression after the final joint
        refinement of its numbers.
    table : DataFrame, optional
        The search's candidates: ``complexity``, ``expression`` (SymPy, in
        the curves' variable), ``chosen`` and ``loss`` (the model's loss with
        the candidate in place) or ``error`` (RMS distance to the curve the
        search was fitted to; its square is the loss). None when the curve
        was not searched (pinned to zero).

    Attributes
    ----------
    equations_ : DataFrame
        One row per expression of the front, by complexity: ``complexity``,
        ``loss``, ``score`` (fall of log-loss per unit of complexity),
        ``equation`` (text), ``sympy_format`` and ``lambda_format`` (a
        numpy callable of ``x0``). The chosen row holds the expression as
        finally refined; its loss is the search's.
    best_index_ : int
        Row of ``equations_`` the fit chose.
    """

    def __init__(self, name: str, curve: Curve, table: pd.DataFrame | None = None) -> None:
        self.name = name
        final = curve.to_sympy(FEATURE)
        final = sympy.Integer(0) if final is None else final
        if table is None or table.empty:
            rows = pd.DataFrame({"complexity": [_complexity(final)], "loss": [np.nan],
                                 "chosen": [True], "expression": [final]})
        else:
            loss = table["loss"] if "loss" in table else np.square(table["error"])
            rows = pd.DataFrame({"complexity": table["complexity"].astype(int),
                                 "loss": np.asarray(loss, dtype=float),
                                 "chosen": table["chosen"].astype(bool),
                                 "expression": [e.xreplace({VARIABLE: FEATURE})
                                                for e in table["expression"]]})
            rows = _front(rows)
        best = int(np.flatnonzero(rows["chosen"].to_numpy())[0])
        expressions = list(rows["expression"])
        expressions[best] = final
        functions = [ExpressionFunction(e) for e in expressions]
        functions[best] = _CurveFunction(curve)
        complexity = rows["complexity"].to_numpy()
        loss = rows["loss"].to_numpy(dtype=float)
        self.equations_ = pd.DataFrame({
            "complexity": complexity, "loss": loss, "score": _scores(complexity, loss),
            "equation": [str(e) for e in expressions], "sympy_format": expressions,
            "lambda_format": functions})
        self.best_index_ = best

    def get_best(self) -> pd.Series:
        """The chosen row of :attr:`equations_` (``equation``, ``sympy_format``, ...)."""
        return self.equations_.iloc[self.best_index_]

    def _row(self, index: int | None) -> pd.Series:
        if index is None:
            return self.get_best()
        return self.equations_.iloc[int(index)]

    def sympy(self, index: int | None = None) -> sympy.Expr:
        """The chosen expression (or that of row ``index``) as SymPy, in ``x0``."""
        return self._row(index)["sympy_format"]

    def latex(self, index: int | None = None) -> str:
        """The chosen expression (or that of row ``index``) as LaTeX."""
        return sympy.latex(self.sympy(index))

    def predict(self, X, index: int | None = None) -> np.ndarray:
        """The chosen expression (or that of row ``index``) on ``X`` (values of ``x0``)."""
        return self._row(index)["lambda_format"](X)

    def __repr__(self) -> str:
        table = self.equations_[["complexity", "loss", "score", "equation"]].copy()
        marks = [">>>>" if k == self.best_index_ else "" for k in range(len(table))]
        table.insert(0, "pick", marks)
        return (f"ParetoModel({self.name}: best {self.get_best()['equation']})\n"
                f"{table.to_string(index=False)}")

    __str__ = __repr__


class _CurveFunction:
    """The fitted curve as PySR's ``lambda_format`` (of ``x0``, or one column of ``X``)."""

    def __init__(self, curve: Curve) -> None:
        self.curve = curve

    def __call__(self, X) -> np.ndarray:
        x = _feature(X)
        return np.array(np.broadcast_to(np.asarray(self.curve(x), dtype=float), x.shape))

    def __repr__(self) -> str:
        return f"ExpressionFunction(x0 -> {self.curve.to_sympy(FEATURE)})"


def _complexity(expression: sympy.Expr) -> int:
    """Nodes of the expression tree."""
    return int(sympy.count_ops(expression, visual=False)) + len(
        expression.atoms(sympy.Symbol, sympy.Number))


class SymbolicEntry(Curve):
    """One curve found by symbolic regression: a curve and the published dict in one.

    It is called like any fitted curve (``entry(x)``; the simulation reads
    it through the :class:`~sklearn_pycc.skeleton.curves.Curve` protocol)
    and answers the keys of the published package's entries:
    ``entry["expr"]`` (text), ``entry["func"]`` (the curve, a numpy
    callable), ``entry["sympy"]`` (the SymPy expression) and
    ``entry["pysr_model"]`` (a :class:`ParetoModel`).

    Parameters
    ----------
    curve : Curve
        The fitted curve.
    expression : sympy.Expr
        The curve written in its argument (``x2`` for ``f1(x2)``).
    pysr_model : ParetoModel
        The search's Pareto front.
    """

    KEYS = ("expr", "func", "sympy", "pysr_model")

    def __init__(self, curve: Curve, expression: sympy.Expr, pysr_model: ParetoModel) -> None:
        self.curve = curve
        self.expression = expression
        self.pysr_model = pysr_model
        self.domain = curve.domain
        self.extrapolation = curve.extrapolation

    def __call__(self, x):
        """The curve on a numpy array."""
        return self.curve(x)

    def scalar(self, x: float) -> float:
        """The curve at one float (the fast path of ODE right-hand sides)."""
        return self.curve.scalar(x)

    def text(self, variable: str, precision: int = 6) -> str:
        """The expression as text, written in ``variable``."""
        return self.curve.text(variable, precision)

    def to_sympy(self, variable):
        """The expression written in ``variable``."""
        return self.curve.to_sympy(variable)

    @property
    def n_numbers(self) -> int:
        """Fitted numbers of the expression."""
        return self.curve.n_numbers

    def __getitem__(self, key: str):
        if key == "expr":
            return str(self.expression)
        if key == "func":
            return self.curve
        if key == "sympy":
            return self.expression
        if key == "pysr_model":
            return self.pysr_model
        raise KeyError(f"{key!r}: a symbolic curve answers {', '.join(map(repr, self.KEYS))}")

    def __contains__(self, key) -> bool:
        return key in self.KEYS

    def keys(self) -> tuple[str, ...]:
        """The keys of the published dict: ``expr``, ``func``, ``sympy``, ``pysr_model``."""
        return self.KEYS

    def get(self, key: str, default=None):
        """``self[key]``, or ``default`` for another key."""
        return self[key] if key in self.KEYS else default

    def items(self) -> list[tuple[str, object]]:
        """``(key, value)`` pairs of the published dict."""
        return [(key, self[key]) for key in self.KEYS]

    def __repr__(self) -> str:
        return f"SymbolicEntry({self.expression})"


def symbolic_entries(estimator) -> dict[str, SymbolicEntry]:
    """``{name: SymbolicEntry}`` for every curve of a fitted symbolic model.

    Parameters
    ----------
    estimator : SymbolicCCRegressor
        Fitted (by ``fit`` or by :func:`~sklearn_pycc.to_symbolic`).
    """
    pareto = getattr(estimator, "pareto_", {}) or {}
    out = {}
    for name in estimator.skeleton_.functions:
        curve = estimator.functions_[name]
        model = ParetoModel(name, curve, pareto.get(name))
        out[name] = SymbolicEntry(curve, estimator.expressions_[name], model)
    return out
