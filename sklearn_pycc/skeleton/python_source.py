"""Expression trees written as Python statements on floats, for generated integrators.

:mod:`.compiler` turns a tree into nested closures, one Python call per
node. An integrator that calls the right-hand side hundreds of thousands of
times spends most of its time in those calls; written out as statements in
one function, the same arithmetic runs several times faster.

The statements are built from the tree our own parser made, never from the
user's text: a variable is read from a numbered local (``v3``), every number
and function (a parameter's value, ``math.sqrt``, a curve's float path) is
bound by a generated name (``k0``, ``F1``) in the namespace the source is
run in. The operations, their order and the constants folded are those of
:mod:`.compiler`'s scalar mode, so both give the same floats.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from .compiler import constant_value, fold
from .curves import as_curve
from .functions import ELEMENTARY
from .nodes import Apply, BinOp, Neg, Node, Param, Symbol, Unknown

__all__ = ["ExpressionWriter", "rhs_source"]


class ExpressionWriter:
    """Writes expressions over numbered locals as Python source, sharing one namespace.

    Parameters
    ----------
    slots : mapping
        Variable name -> its local's number (``v{number}``).
    params : mapping
        Parameter values (floats; a system of stacked variants has no source).
    functions : mapping
        Callables of the curves.

    Attributes
    ----------
    namespace : dict
        Generated name -> the number or function it stands for.
    lines : list of str
        Statements that expressions written so far rely on (integer powers
        of a sub-expression keep its value in a temporary), in order.
    """

    def __init__(self, slots: Mapping[str, int], params: Mapping[str, float],
                 functions: Mapping[str, Callable]) -> None:
        if any(isinstance(v, np.ndarray) for v in params.values()):
            raise ValueError("a system of stacked variants is evaluated on arrays only")
        self.slots = slots
        self.params = params
        self.functions = functions
        self.namespace: dict = {}
        self.lines: list[str] = []
        self._bound: dict = {}
        self._temporaries = 0

    def bind(self, value, prefix: str) -> str:
        """The generated name of a number or function (one name per distinct object)."""
        # a number by its exact text (0.0 and -0.0 are equal, yet not the same)
        key = (prefix, repr(value)) if prefix == "k" else (prefix, id(value))
        if key not in self._bound:
            name = f"{prefix}{len(self._bound)}"
            self._bound[key] = name
            self.namespace[name] = value
        return self._bound[key]

    def temporary(self, source: str) -> str:
        """A new local holding ``source``'s value (its statement appended to :attr:`lines`)."""
        name = f"w{self._temporaries}"
        self._temporaries += 1
        self.lines.append(f"{name} = {source}")
        return name

    def write(self, node: Node) -> tuple[str, float | None]:
        """``(source, constant value or None)`` of ``node``, as the scalar compiler reads it."""
        const = constant_value(node, self.params)
        if const is not None:
            return self.bind(const, "k"), const
        if isinstance(node, Symbol):
            return f"v{self.slots[node.name]}", None
        if isinstance(node, Param):
            raise ValueError(f"parameter {node.name} has no single value")
        if isinstance(node, Neg):
            inner, c = self.write(node.operand)
            if c is not None:
                return self.bind(-c, "k"), -c
            return f"(-{inner})", None
        if isinstance(node, Apply):
            scalar = ELEMENTARY[node.func].math
            inner, c = self.write(node.arg)
            if c is not None:
                value = float(scalar(c))
                return self.bind(value, "k"), value
            return f"{self.bind(scalar, 'F')}({inner})", None
        if isinstance(node, Unknown):
            inner, _ = self.write(node.arg)
            fast = as_curve(self.functions[node.name]).float_path()
            return f"{self.bind(fast, 'F')}({inner})", None
        if isinstance(node, BinOp):
            return self._binop(node)
        raise TypeError(f"cannot write node {node!r}")

    def _binop(self, node: BinOp) -> tuple[str, float | None]:
        left, lc = self.write(node.left)
        right, rc = self.write(node.right)
        if node.op == "^":
            if lc is not None and rc is not None:
                value = fold("^", lc, rc)
                return self.bind(value, "k"), value
            if rc is not None and float(rc).is_integer() and 0 <= rc <= 64:
                return self._int_power(left, int(rc)), None
            return f"{self.bind(math.pow, 'F')}({left}, {right})", None
        if lc is not None and rc is not None:
            value = fold(node.op, lc, rc)
            return self.bind(value, "k"), value
        if rc is not None and ((node.op == "*" and rc == 1.0)
                               or (node.op in "+-" and rc == 0.0)):
            return left, None
        if lc is not None and ((node.op == "*" and lc == 1.0) or (node.op == "+" and lc == 0.0)):
            return right, None
        return f"({left} {node.op} {right})", None

    def _int_power(self, base: str, n: int) -> str:
        if n == 0:
            return self.bind(1.0, "k")
        if n == 1:
            return base
        if n in (2, 3):
            value = self.temporary(base)
            return "(" + " * ".join([value] * n) + ")"
        return f"{self.bind(math.pow, 'F')}({base}, {self.bind(float(n), 'k')})"



def rhs_source(n_states: int, n_inputs: int, statements: list[str], rates: list[str],
               holds: list[tuple[int, int]]) -> str:
    """The source of ``rhs(t, y)``: the rates at ``t`` and the states ``y`` (floats), a list.

    ``statements`` compute the locals ``rates`` from the states' locals
    (``v0``...), the inputs' (read by ``input_at(t)``) and ``t``'s, as a
    compiled system lays its slots out. Hold ``k``, ``(q, j)``, zeroes rate
    ``j`` where it would carry state ``q`` beyond ``lo{k}`` or ``hi{k}``
    (numbers in the namespace). Anything out of the ordinary (a domain error, a
    division by zero, a rate not finite) is handed to ``general(t, y)``,
    which says what and where.
    """
    lines = ["def rhs(t, y):",
             "    try:",
             "        " + "".join(f"v{q}, " for q in range(n_states)) + "= y"]
    if n_inputs:
        lines.append("        " + "".join(f"v{n_states + i}, " for i in range(n_inputs))
                     + "= input_at(t)")
    lines.append(f"        v{n_states + n_inputs} = float(t)")
    lines += ["        " + line for line in statements]
    lines.append("    except (ValueError, ArithmeticError):")
    lines.append("        return general(t, y)")
    lines.append(f"    if not isfinite({' + '.join(rates)}):")
    lines.append("        return general(t, y)")
    out = [f"r{j}" for j in range(len(rates))]
    lines += [f"    {r} = {name}" for r, name in zip(out, rates)]
    for k, (q, j) in enumerate(holds):
        lines.append(f"    if (v{q} >= hi{k} and r{j} > 0) or (v{q} <= lo{k} and r{j} < 0): "
                     f"r{j} = 0.0")
    lines.append(f"    return [{', '.join(out)}]")
    return "\n".join(lines) + "\n"
