"""What a characteristic curve offers: the one protocol every backend's curves follow.

The skeleton's compiler reads curves through it (arrays, and floats for ODE
right-hand sides), and a fitted model through it writes, converts and counts
them. A plain callable handed over in the middle of a fit is wrapped by
:func:`as_curve`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

__all__ = ["Curve", "FunctionCurve", "as_curve"]


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
