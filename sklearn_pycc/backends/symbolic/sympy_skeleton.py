"""Parsed skeleton trees as SymPy expressions (for printing fitted models analytically)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import sympy

from ...skeleton.functions import ELEMENTARY
from ...skeleton.nodes import Apply, BinOp, Neg, Node, Number, Param, Symbol, Unknown
from .curves import VARIABLE

__all__ = ["to_sympy"]

def _sympy_function(forms) -> Callable:
    if isinstance(forms.sympy, tuple):  # log10(x) = log(x, 10)
        name, base = forms.sympy
        return lambda a: getattr(sympy, name)(a, sympy.Integer(int(base)))
    return getattr(sympy, forms.sympy)


#: elementary function name of the skeleton language -> sympy function
_FUNCTIONS: dict[str, Callable] = {name: _sympy_function(forms)
                                   for name, forms in ELEMENTARY.items()}


def to_sympy(node: Node, params: Mapping[str, float],
             curves: Mapping[str, sympy.Expr]) -> sympy.Expr:
    """``node`` with parameters replaced by values and curves by their expressions.

    ``curves`` maps a curve's name to its expression in
    :data:`~sklearn_pycc.backends.symbolic.curves.VARIABLE`; a curve missing from it stays an
    undefined function ``f(argument)``.
    """

    def go(n: Node) -> sympy.Expr:
        if isinstance(n, Number):
            value = n.value
            return sympy.Integer(int(value)) if float(value).is_integer() else sympy.Float(value)
        if isinstance(n, Symbol):
            return sympy.Symbol(n.name)
        if isinstance(n, Param):
            return sympy.Float(params[n.name]) if n.name in params else sympy.Symbol(n.name)
        if isinstance(n, Neg):
            return -go(n.operand)
        if isinstance(n, Unknown):
            arg = go(n.arg)
            if n.name in curves:
                return curves[n.name].xreplace({VARIABLE: arg})
            return sympy.Function(n.name)(arg)
        if isinstance(n, Apply):
            return _FUNCTIONS[n.func](go(n.arg))
        if isinstance(n, BinOp):
            left, right = go(n.left), go(n.right)
            if n.op == "+":
                return left + right
            if n.op == "-":
                return left - right
            if n.op == "*":
                return left * right
            if n.op == "/":
                return left / right
            return left ** right
        raise TypeError(f"unexpected node {n!r}")

    return go(node)
