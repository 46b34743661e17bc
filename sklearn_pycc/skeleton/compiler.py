"""Compile expression trees into plain Python/numpy closures.

An expression is compiled once, with the values of its parameters and the
callables of its curves baked in, into a closure ``fn(env)`` where ``env`` is
a sequence indexed by variable slot. Constant sub-expressions are folded at
compile time. A parameter given as an array (array mode only) holds one value
per row instead: systems that differ only in their numbers are then evaluated
side by side as one (see :func:`~.system.stack_systems`). Two modes exist:

``"array"``
    ``env`` holds numpy arrays; elementary functions are numpy ufuncs.
``"scalar"``
    ``env`` holds Python floats; elementary functions come from :mod:`math`,
    which is several times faster on scalars. Domain errors (``log(-1)``,
    overflow, division by zero) raise instead of returning NaN; the
    simulator turns them into :class:`~sklearn_pycc.SimulationError`.

No text is evaluated: the input is a tree built by our own parser.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Mapping

import numpy as np

from .curves import as_curve
from .functions import ELEMENTARY
from .nodes import Apply, BinOp, Neg, Node, Number, Param, Symbol, Unknown

__all__ = ["compile_expression", "constant_value", "degree_in", "fold"]

Compiled = Callable[[object], object]


def _scalar_pow(base: float, exponent: float) -> float:
    return math.pow(base, exponent)


def _array_pow(base, exponent):
    return np.power(base, exponent)


def _folded(op, left: float, right: float) -> float:
    """A constant part of an expression, worked out once as numpy would at run time.

    Parameter values may make it infinite or undefined (``a2^a1`` with
    ``a1 = -1024``, ``a1/a2`` with ``a2 = 0``): it is then inf or nan, for the
    simulation or the fit to report, not an exception while compiling.
    """
    with np.errstate(all="ignore"):
        return float(op(np.float64(left), np.float64(right)))


def constant_value(node: Node, params: Mapping[str, object]) -> float | None:
    """The value of a number or of a parameter of one value; None for anything else."""
    if isinstance(node, Number):
        return node.value
    if isinstance(node, Param):
        value = params[node.name]
        return None if isinstance(value, np.ndarray) else float(value)
    return None


def fold(op: str, left: float, right: float) -> float:
    """``left op right`` (``op`` one of ``+ - * / ^``) of two constants, as compiled."""
    return _folded(np.power if op == "^" else _BINARY[op], left, right)


def _int_power(fn: Compiled, n: int, scalar: bool) -> Compiled:
    if n == 0:
        return lambda env: 1.0
    if n == 1:
        return fn
    if n == 2:
        def square(env):
            v = fn(env)
            return v * v
        return square
    if n == 3:
        def cube(env):
            v = fn(env)
            return v * v * v
        return cube
    if scalar:
        return lambda env: math.pow(fn(env), n)
    return lambda env: fn(env) ** n


_BINARY = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv}

# closures applying the operator inline (one call fewer per node than operator.*,
# which matters in an ODE right-hand side called thousands of times)
_FUSED = {
    "+": lambda f, g: lambda env: f(env) + g(env),
    "-": lambda f, g: lambda env: f(env) - g(env),
    "*": lambda f, g: lambda env: f(env) * g(env),
    "/": lambda f, g: lambda env: f(env) / g(env),
}

# the same with a constant on the right (c), or on the left
_FUSED_CONSTANT = {
    "+": lambda f, c: lambda env: f(env) + c,
    "-": lambda f, c: lambda env: f(env) - c,
    "*": lambda f, c: lambda env: f(env) * c,
    "/": lambda f, c: lambda env: f(env) / c,
}
_CONSTANT_FUSED = {
    "+": lambda c, g: lambda env: c + g(env),
    "-": lambda c, g: lambda env: c - g(env),
    "*": lambda c, g: lambda env: c * g(env),
    "/": lambda c, g: lambda env: c / g(env),
}

# a variable read straight from its slot i (no closure call for the leaf)
_VARIABLE_CONSTANT = {
    "+": lambda i, c: lambda env: env[i] + c,
    "-": lambda i, c: lambda env: env[i] - c,
    "*": lambda i, c: lambda env: env[i] * c,
    "/": lambda i, c: lambda env: env[i] / c,
}
_CONSTANT_VARIABLE = {
    "+": lambda c, i: lambda env: c + env[i],
    "-": lambda c, i: lambda env: c - env[i],
    "*": lambda c, i: lambda env: c * env[i],
    "/": lambda c, i: lambda env: c / env[i],
}
_VARIABLES = {
    "+": lambda i, j: lambda env: env[i] + env[j],
    "-": lambda i, j: lambda env: env[i] - env[j],
    "*": lambda i, j: lambda env: env[i] * env[j],
    "/": lambda i, j: lambda env: env[i] / env[j],
}


class _Compiler:
    def __init__(self, slots, params, functions, mode):
        if mode not in ("array", "scalar"):
            raise ValueError(f"mode must be 'array' or 'scalar', got {mode!r}")
        self.slots = slots
        self.params = params
        self.functions = functions
        self.scalar = mode == "scalar"

    def constant(self, node: Node) -> float | None:
        """Return the value of ``node`` if it needs no data, else None."""
        return constant_value(node, self.params)

    def compile(self, node: Node) -> tuple[Compiled, float | None]:
        """Return ``(closure, constant_value_or_None)``."""
        const = self.constant(node)
        if const is not None:
            return (lambda env, c=const: c), const
        if isinstance(node, Symbol):
            i = self.slots[node.name]
            return (lambda env: env[i]), None
        if isinstance(node, Param):  # one value per row (stacked variants of a system)
            values = self.params[node.name]
            return (lambda env: values), None
        if isinstance(node, Neg):
            fn, c = self.compile(node.operand)
            if c is not None:
                return (lambda env, v=-c: v), -c
            return (lambda env: -fn(env)), None
        if isinstance(node, Apply):
            vector, scalar = ELEMENTARY[node.func].numpy, ELEMENTARY[node.func].math
            func = scalar if self.scalar else vector
            fn, c = self.compile(node.arg)
            if c is not None:
                value = float(scalar(c))
                return (lambda env, v=value: v), value
            if isinstance(node.arg, Symbol):
                i = self.slots[node.arg.name]
                return (lambda env: func(env[i])), None
            return (lambda env: func(fn(env))), None
        if isinstance(node, Unknown):
            curve = self.functions[node.name]
            fn, c = self.compile(node.arg)
            if self.scalar:  # the float -> float fast path of ODE right-hand sides
                fast = as_curve(curve).float_path()
                if isinstance(node.arg, Symbol):
                    i = self.slots[node.arg.name]
                    return (lambda env: fast(env[i])), None
                return (lambda env: fast(fn(env))), None
            return (lambda env: curve(fn(env))), None
        if isinstance(node, BinOp):
            return self.binop(node)
        raise TypeError(f"cannot compile node {node!r}")

    def binop(self, node: BinOp) -> tuple[Compiled, float | None]:
        left, lc = self.compile(node.left)
        right, rc = self.compile(node.right)
        if node.op == "^":
            if lc is not None and rc is not None:
                value = _folded(np.power, lc, rc)
                return (lambda env, v=value: v), value
            if rc is not None and float(rc).is_integer() and 0 <= rc <= 64:
                return _int_power(left, int(rc), self.scalar), None
            power = _scalar_pow if self.scalar else _array_pow
            if rc is not None:
                return (lambda env, r=rc: power(left(env), r)), None
            return (lambda env: power(left(env), right(env))), None
        op = _BINARY[node.op]
        if lc is not None and rc is not None:
            value = _folded(op, lc, rc)
            return (lambda env, v=value: v), value
        i = self.slots[node.left.name] if isinstance(node.left, Symbol) else None
        j = self.slots[node.right.name] if isinstance(node.right, Symbol) else None
        if rc is not None:
            if node.op == "*" and rc == 1.0:
                return left, None
            if node.op in "+-" and rc == 0.0:
                return left, None
            if i is not None:
                return _VARIABLE_CONSTANT[node.op](i, rc), None
            return _FUSED_CONSTANT[node.op](left, rc), None
        if lc is not None:
            if node.op == "*" and lc == 1.0:
                return right, None
            if node.op == "+" and lc == 0.0:
                return right, None
            if j is not None:
                return _CONSTANT_VARIABLE[node.op](lc, j), None
            return _CONSTANT_FUSED[node.op](lc, right), None
        if i is not None and j is not None:
            return _VARIABLES[node.op](i, j), None
        return _FUSED[node.op](left, right), None


def compile_expression(
    node: Node,
    slots: Mapping[str, int],
    params: Mapping[str, float] | None = None,
    functions: Mapping[str, Callable] | None = None,
    mode: str = "array",
) -> Compiled:
    """Compile ``node`` into a closure of the variable environment.

    Parameters
    ----------
    node : Node
        Expression tree from the parser.
    slots : mapping
        Variable name -> index into the environment sequence.
    params : mapping, optional
        Values of the ``a`` parameters the expression uses: floats, or (array
        mode) arrays of one value per row.
    functions : mapping, optional
        Callables of the ``f`` curves the expression uses.
    mode : {"array", "scalar"}
        Evaluate on numpy arrays or on Python floats (see module docstring).

    Returns
    -------
    callable
        ``fn(env)`` returning the value of the expression.
    """
    compiler = _Compiler(slots, params or {}, functions or {}, mode)
    fn, _ = compiler.compile(node)
    return fn


def degree_in(node: Node, name: str) -> int | None:
    """Polynomial degree of ``node`` in the variable ``name``; None if not polynomial."""
    if isinstance(node, Symbol):
        return 1 if node.name == name else 0
    if isinstance(node, (Number, Param)):
        return 0
    if isinstance(node, Neg):
        return degree_in(node.operand, name)
    if isinstance(node, (Apply, Unknown)):
        return 0 if degree_in(node.arg, name) == 0 else None
    if isinstance(node, BinOp):
        left, right = degree_in(node.left, name), degree_in(node.right, name)
        if left is None or right is None:
            return None
        if node.op in "+-":
            return max(left, right)
        if node.op == "*":
            return left + right
        if node.op == "/":
            return left if right == 0 else None
        if node.op == "^":
            if right != 0:
                return None
            if left == 0:
                return 0
            if isinstance(node.right, Number) and float(node.right.value).is_integer() \
                    and node.right.value >= 0:
                return left * int(node.right.value)
            return None
    return None
