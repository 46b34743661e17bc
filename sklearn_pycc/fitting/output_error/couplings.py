"""Rates that carry a state toward another: ``a1 (W1 - T1)`` in the equation of ``T1``.

Heat between a room and its walls, water between two tanks joined by a
pipe, a species diffusing between compartments: wherever a term
``a (y - x)`` moves the state ``x`` toward ``y``, its rate ``a`` is positive
in every field. A fit that makes it negative has a state driven away from
the other, a flow against its gradient: a minimum of the fit, not of
physics. The fit of a skeleton with unmeasured states tries such rates held
positive as another start where its first estimate turns one negative, and
warns where the answer keeps one.
"""

from __future__ import annotations

from collections.abc import Iterator

from ...skeleton.nodes import BinOp, Neg, Node, Param, Symbol

__all__ = ["coupling_rates"]


def _terms(node: Node, sign: int = 1) -> Iterator[tuple[int, Node]]:
    """The terms of a sum, each with its sign."""
    if isinstance(node, BinOp) and node.op in "+-":
        yield from _terms(node.left, sign)
        yield from _terms(node.right, sign if node.op == "+" else -sign)
    elif isinstance(node, Neg):
        yield from _terms(node.operand, -sign)
    else:
        yield sign, node


def _coupling(sign: int, term: Node, state: str) -> tuple[str, str] | None:
    """``(rate, other)`` where ``term`` (of that sign) moves ``state`` toward ``other``."""
    if not (isinstance(term, BinOp) and term.op == "*"):
        return None
    for rate, difference in ((term.left, term.right), (term.right, term.left)):
        signed = sign
        if isinstance(rate, Neg):  # -a3 (x2 - x1)
            signed, rate = -sign, rate.operand
        if not (isinstance(rate, Param) and isinstance(difference, BinOp)
                and difference.op == "-" and isinstance(difference.left, Symbol)
                and isinstance(difference.right, Symbol)):
            continue
        to, own = ((difference.left.name, difference.right.name) if signed > 0
                   else (difference.right.name, difference.left.name))
        if own == state and to != state:
            return rate.name, to
    return None


def coupling_rates(equations) -> dict[str, tuple[str, str, str]]:
    """Each rate of a term ``a (y - x)`` in the equation of ``x``: ``(derivative, x, y)``.

    ``equations`` are a skeleton's explicit dynamic equations (a rate that
    appears in several such terms is listed at its first).
    """
    found: dict[str, tuple[str, str, str]] = {}
    for eq in equations:
        if not eq.explicit:
            continue
        for sign, term in _terms(eq.expression):
            coupling = _coupling(sign, term, eq.state)
            if coupling is not None and coupling[0] not in found:
                found[coupling[0]] = (eq.derivative, eq.state, coupling[1])
    return found
