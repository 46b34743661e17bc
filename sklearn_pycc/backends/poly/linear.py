"""Write a skeleton's residuals as affine functions of its linear unknowns.

The polynomial backend fits curves expanded in a linear basis. Each
equation residual ``lhs - rhs`` is evaluated on the data as
``b + sum_k A_k theta_k`` where ``theta_k`` are the curve coefficients and
the parameters that enter linearly. Parameters that cannot enter linearly
(``a3`` in ``tanh(a3 x2)``, or one factor of ``a1 a2 x``) are *nonlinear*:
they are held at given values here and optimised outside (variable
projection).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ...exceptions import SkeletonError
from ...skeleton.equations import unknown_names
from ...skeleton.functions import ELEMENTARY
from ...skeleton.nodes import Apply, BinOp, Neg, Node, Number, Param, Symbol, Unknown, walk

__all__ = ["Affine", "NotAffine", "linearize", "split_parameters"]


class NotAffine(Exception):
    """A sub-expression is not affine in the linear unknowns."""

    def __init__(self, movable: set[str], node: Node, reason: str) -> None:
        super().__init__(reason)
        self.movable = movable
        self.node = node
        self.reason = reason


class Affine:
    """``const + sum(blocks[name] @ theta[name])`` on ``n`` samples.

    A block is kept as a list of ``(factor, array)`` terms, ``factor`` a
    scalar or a per-sample vector, so that sums and scalings cost nothing
    until :meth:`write` adds them once into the final design matrix.
    """

    __slots__ = ("blocks", "const")

    def __init__(self, const, blocks: dict[str, list] | None = None) -> None:
        self.const = const
        self.blocks = blocks or {}

    def scaled(self, factor) -> Affine:
        """The form times ``factor``."""
        blocks = {k: [(f * factor, a) for f, a in terms] for k, terms in self.blocks.items()}
        return Affine(self.const * factor, blocks)

    def plus(self, other: Affine, sign: float = 1.0) -> Affine:
        """The form plus ``sign`` times ``other``."""
        blocks = dict(self.blocks)
        for k, terms in other.blocks.items():
            moved = terms if sign == 1.0 else [(sign * f, a) for f, a in terms]
            blocks[k] = blocks[k] + moved if k in blocks else moved
        return Affine(self.const + sign * other.const, blocks)

    def write(self, name: str, out: np.ndarray, weight: float) -> None:
        """Add ``weight`` times the block of ``name`` into ``out`` (rows x block columns)."""
        for k, (factor, array) in enumerate(self.blocks[name]):
            f = np.asarray(factor, dtype=float) * weight
            f = f if f.ndim == 0 else f[:, None]
            if k == 0:
                np.multiply(array, f, out=out)  # ``out`` is a fresh slice of zeros
            else:
                out += array * f


def _degree(node: Node, linear: set[str]) -> int:
    """Degree in the linear unknowns; raises NotAffine naming parameters to move out."""
    if isinstance(node, (Number, Symbol)):
        return 0
    if isinstance(node, Param):
        return 1 if node.name in linear else 0
    if isinstance(node, Neg):
        return _degree(node.operand, linear)
    if isinstance(node, (Apply, Unknown)):
        curves, params = unknown_names(node.arg)
        if curves:
            raise NotAffine(set(), node, f"the curve {sorted(curves)[0]} appears inside the "
                            f"argument of {getattr(node, 'name', getattr(node, 'func', ''))}")
        if params & linear and _degree(node.arg, linear) > 0:
            raise NotAffine(params & linear, node, "parameter inside a function argument")
        return 1 if isinstance(node, Unknown) else 0
    if isinstance(node, BinOp):
        left, right = _degree(node.left, linear), _degree(node.right, linear)
        if node.op in "+-":
            return max(left, right)
        if node.op == "*":
            if left + right <= 1:
                return left + right
            lc, lp = unknown_names(node.left)
            rc, rp = unknown_names(node.right)
            if not lc:
                raise NotAffine(lp & linear, node, "product of unknowns")
            if not rc:
                raise NotAffine(rp & linear, node, "product of unknowns")
            raise NotAffine(set(), node, "a product of two unknown curves")
        side = node.right
        if right == 0 and (node.op == "/" or left == 0):
            return left
        curves, params = unknown_names(side if node.op == "/" else node)
        if curves:
            raise NotAffine(set(), node, f"the curve {sorted(curves)[0]} appears in a "
                            f"{'denominator' if node.op == '/' else 'power'}")
        return 0 if not (params & linear) else _raise(params & linear, node)
    raise TypeError(f"unexpected node {node!r}")


def _raise(params: set[str], node: Node) -> int:
    raise NotAffine(params, node, "parameter in a denominator or exponent")


def split_parameters(residuals: list[tuple[int, str, Node]], params: list[str],
                     backend: str) -> tuple[list[str], list[str]]:
    """Split the free parameters into linear and nonlinear ones.

    Parameters
    ----------
    residuals : list of (index, text, Node)
        Equation index, text and residual tree.
    params : list of str
        The free parameters.
    backend : str
        Estimator name for error messages.

    Raises
    ------
    SkeletonError
        When a curve enters nonlinearly (inside another function, a
        denominator, a power, or multiplied by another curve), which a
        linear-basis backend cannot fit.
    """
    linear = set(params)
    for index, text, node in residuals:
        while True:
            try:
                _degree(node, linear)
                break
            except NotAffine as exc:
                if not exc.movable:
                    raise SkeletonError(
                        f"{backend} needs every curve to enter linearly, but here {exc.reason}",
                        equation=index, position=max(exc.node.pos, 0)
                        if hasattr(exc.node, "pos") else 0, text=text) from None
                linear -= exc.movable
    return [a for a in params if a in linear], [a for a in params if a not in linear]


def linearize(node: Node, data: Mapping[str, np.ndarray], n: int, values: Mapping[str, float],
              bases: Mapping, *, linear: set[str], zeroed: set[str]) -> Affine:
    """Evaluate ``node`` as an :class:`Affine` form.

    Parameters
    ----------
    node : Node
        Residual tree.
    data : mapping
        Column name -> array of length ``n``.
    values : mapping
        Values of the parameters held fixed (nonlinear and gauge-pinned).
    bases : mapping
        Curve name -> basis with a ``design(x)`` method.
    linear : set
        Names of the linear parameters.
    zeroed : set
        Curves pinned to zero.
    """

    def go(n_: Node) -> Affine:
        if isinstance(n_, Number):
            return Affine(n_.value)
        if isinstance(n_, Symbol):
            return Affine(data[n_.name])
        if isinstance(n_, Param):
            if n_.name in linear:
                return Affine(0.0, {n_.name: [(1.0, np.ones((n, 1)))]})
            return Affine(values[n_.name])
        if isinstance(n_, Neg):
            return go(n_.operand).scaled(-1.0)
        if isinstance(n_, Unknown):
            if n_.name in zeroed:
                return Affine(0.0)
            arg = np.broadcast_to(np.asarray(go(n_.arg).const, dtype=float), (n,))
            return Affine(0.0, {n_.name: [(1.0, bases[n_.name].design(arg))]})
        if isinstance(n_, Apply):
            return Affine(ELEMENTARY[n_.func].numpy(go(n_.arg).const))
        left, right = go(n_.left), go(n_.right)
        if n_.op == "+":
            return left.plus(right)
        if n_.op == "-":
            return left.plus(right, -1.0)
        if n_.op == "*":
            if not left.blocks:
                return right.scaled(np.broadcast_to(left.const, (n,)) if np.ndim(left.const)
                                    else left.const)
            return left.scaled(np.broadcast_to(right.const, (n,)) if np.ndim(right.const)
                               else right.const)
        if n_.op == "/":
            inv = 1.0 / right.const
            return left.scaled(np.broadcast_to(inv, (n,)) if np.ndim(inv) else inv)
        return Affine(np.power(left.const, right.const))

    with np.errstate(all="ignore"):
        return go(node)


def curve_arguments(node: Node, data: Mapping[str, np.ndarray], n: int,
                    values: Mapping[str, float]) -> dict[str, list[np.ndarray]]:
    """Values of every curve argument in ``node`` (arguments hold no linear unknowns)."""
    out: dict[str, list[np.ndarray]] = {}
    for sub in walk(node):
        if isinstance(sub, Unknown):
            form = linearize(sub.arg, data, n, values, {}, linear=set(), zeroed=set())
            out.setdefault(sub.name, []).append(
                np.broadcast_to(np.asarray(form.const, dtype=float), (n,)))
    return out
