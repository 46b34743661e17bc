"""Write expression trees back as skeleton-language text."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from ..simulation.delays import read_delayed
from .nodes import Apply, BinOp, Neg, Node, Number, Param, Symbol, Unknown

__all__ = ["format_number", "to_text"]

_PRECEDENCE = {"+": 1, "-": 1, "*": 2, "/": 2, "neg": 3, "^": 4}


def format_number(value: float, precision: int = 6) -> str:
    """Shortest readable form of ``value`` with ``precision`` significant digits."""
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    return f"{value:.{precision}g}"


def to_text(
    node: Node,
    params: Mapping[str, float] | None = None,
    precision: int = 6,
    curve: Callable[[str, str], str] | None = None,
) -> str:
    """Render ``node`` as text, substituting parameter values when given.

    Parameters
    ----------
    node : Node
        Expression tree.
    params : mapping, optional
        Parameter values to write instead of their names.
    precision : int
        Significant digits of substituted numbers.
    curve : callable, optional
        ``curve(name, argument_text)`` returning the text of a curve
        application; defaults to ``name(argument)``.
    """

    def render(n: Node) -> tuple[str, int]:
        if isinstance(n, Number):
            text = format_number(n.value, precision)
            return text, (3 if text.startswith("-") else 5)
        if isinstance(n, Symbol):
            read = read_delayed(n.name) if params is not None else None
            if read is not None and not isinstance(read[1], str):
                # a fitted delay is written as the parameters are
                return f"{read[0]}(t - {format_number(read[1], precision)})", 5
            return n.name, 5
        if isinstance(n, Param):
            if params is not None and n.name in params:
                text = format_number(float(params[n.name]), precision)
                return text, (3 if text.startswith("-") else 5)
            return n.name, 5
        if isinstance(n, Unknown):
            arg = render(n.arg)[0]
            return (curve(n.name, arg) if curve else f"{n.name}({arg})"), 5
        if isinstance(n, Apply):
            return f"{n.func}({render(n.arg)[0]})", 5
        if isinstance(n, Neg):
            text, prec = render(n.operand)
            if prec <= _PRECEDENCE["neg"]:
                text = f"({text})"
            return f"-{text}", _PRECEDENCE["neg"]
        if isinstance(n, BinOp):
            prec = _PRECEDENCE[n.op]
            left, lp = render(n.left)
            right, rp = render(n.right)
            if n.op == "*" and left in ("1", "-1"):
                # a parameter fitted or pinned to +-1 multiplies nothing
                if left == "1":
                    return right, rp
                neg = _PRECEDENCE["neg"]
                return (f"-{right}" if rp > neg else f"-({right})"), neg
            if n.op == "^":
                if lp <= prec:
                    left = f"({left})"
                if rp < prec:
                    right = f"({right})"
                return f"{left}^{right}", prec
            if lp < prec:
                left = f"({left})"
            if rp < prec or (rp == prec and n.op in "-/"):
                right = f"({right})"
            if n.op == "*":
                return f"{left}*{right}", prec
            if n.op in "+-" and right.startswith("-"):
                return f"{left} {'+' if n.op == '-' else '-'} {right[1:]}", prec
            return f"{left} {n.op} {right}", prec
        raise TypeError(f"cannot render {n!r}")

    return render(node)[0]
