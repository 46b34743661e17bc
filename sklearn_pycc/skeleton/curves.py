"""What a characteristic curve offers: the one protocol every backend's curves follow.

The skeleton's compiler reads curves through it (arrays, and floats for ODE
right-hand sides), and a fitted model through it writes, converts and counts
them. A plain callable handed over in the middle of a fit is wrapped by
:func:`as_curve`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["Curve", "FunctionCurve", "StackedCurve", "ZeroCurve", "as_curve", "stack_curves"]


class Curve:
    """A fitted one-dimensional curve ``f(x)``.

    Subclasses implement ``__call__`` on numpy arrays and refine the rest,
    whose defaults are: ``scalar`` calls the curve on the float itself,
    ``text`` names the class, ``to_sympy`` has no closed form (None),
    ``n_numbers`` is 0, ``domain`` is the whole line and ``extrapolation``
    (a policy beyond the domain, such as ``"linear"``) is None.
    """

    #: range of the argument in training
    domain: tuple[float, float] = (-math.inf, math.inf)
    #: what the curve does beyond ``domain`` (None: nothing to watch)
    extrapolation: str | None = None

    def __call__(self, x):
        """The curve on a numpy array (elementwise)."""
        raise NotImplementedError

    def scalar(self, x: float) -> float:
        """The curve at one float: the fast path of ODE right-hand sides."""
        return float(self(x))

    def float_path(self) -> Callable[[float], float]:
        """A float -> float callable the compiled right-hand sides call (``scalar`` by default).

        Asked once per compiled system; a kind may return a closure over
        its tables, ready for the thousands of calls an integration makes.
        """
        return self.scalar

    def text(self, variable: str, precision: int = 6) -> str:
        """The curve written as a function of ``variable``."""
        return f"<{type(self).__name__}>"

    def to_sympy(self, variable):
        """The curve as a SymPy expression of ``variable``, or None without a closed form."""
        return None

    @property
    def n_numbers(self) -> int:
        """How many fitted numbers define the curve (for information criteria)."""
        return 0

    @classmethod
    def stack(cls, curves: Sequence[Curve], rows: int) -> Curve | None:
        """Curves of this kind evaluated block by block in one call, or None.

        Block ``b`` (``rows`` rows) of the argument is read by ``curves[b]``.
        A subclass whose curves differ only in their numbers may return one
        that evaluates them all at once; None leaves it to
        :class:`StackedCurve`, which calls each on its block.
        """
        return None


class StackedCurve(Curve):
    """Several curves side by side: block ``b`` (``rows`` rows) of an argument reads ``curves[b]``.

    What :func:`stack_curves` falls back on: one call per curve.
    """

    def __init__(self, curves: Sequence[Callable], rows: int) -> None:
        self.curves = list(curves)
        self.rows = int(rows)

    def __call__(self, x):
        """Each curve on its own block of ``x`` (a float is every row's argument)."""
        r = self.rows
        x = np.broadcast_to(np.asarray(x, dtype=float), (r * len(self.curves),))
        return np.concatenate([np.broadcast_to(curve(x[b * r:(b + 1) * r]), (r,))
                               for b, curve in enumerate(self.curves)])


class FunctionCurve(Curve):
    """A plain callable seen as a :class:`Curve`."""

    def __init__(self, function: Callable) -> None:
        self.function = function

    def __call__(self, x):
        """The wrapped callable on ``x``."""
        return self.function(x)

    def __repr__(self) -> str:
        return f"FunctionCurve({self.function!r})"


def as_curve(curve) -> Curve:
    """``curve`` itself when it is a :class:`Curve`, else a plain callable wrapped as one."""
    if isinstance(curve, Curve):
        return curve
    if callable(curve):
        return FunctionCurve(curve)
    raise TypeError(f"a curve must be callable on arrays, got {type(curve).__name__}")


def stack_curves(curves: Sequence[Callable], rows: int) -> Callable:
    """One curve for ``len(curves)`` blocks of ``rows`` rows, block ``b`` read by ``curves[b]``.

    The curve itself where every block has the same; the kind's own
    :meth:`Curve.stack` where it offers one; else a :class:`StackedCurve`.
    """
    first = curves[0]
    if all(curve is first for curve in curves):
        return first
    if all(type(curve) is type(first) for curve in curves) and isinstance(first, Curve):
        stacked = type(first).stack(curves, rows)
        if stacked is not None:
            return stacked
    return StackedCurve(curves, rows)


class ZeroCurve(Curve):
    """The zero function (a curve pinned to zero by the gauge)."""

    domain = (0.0, 0.0)

    def __call__(self, x):
        """Zeros shaped like ``x`` (``0.0`` for a number)."""
        if isinstance(x, np.ndarray):
            return np.zeros(x.shape)
        return 0.0

    def scalar(self, x: float) -> float:
        """``0.0``."""
        return 0.0

    def to_sympy(self, variable):
        """``0``."""
        import sympy

        return sympy.Integer(0)

    def text(self, variable: str, precision: int = 6) -> str:
        """``"0"``."""
        return "0"

    def __repr__(self) -> str:
        return "ZeroCurve()"
