"""Linear bases for characteristic curves and the fitted curve objects.

A basis maps the curve's own argument ``x`` to ``u = (x - center) / half_width``
on ``[-1, 1]`` and expands in orthogonal polynomials of ``u``. With a parity
constraint the map has no shift (``center = 0``, symmetric range) and only
odd or even degrees are used, so ``f(-x) = -f(x)`` (or ``f(x)``) holds exactly
in ``x`` itself.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.polynomial import chebyshev, legendre
from numpy.polynomial import polynomial as power
from scipy.special import comb

from ...skeleton.curves import Curve

__all__ = ["BASES", "PolyBasis", "PolyCurve"]

#: name -> (vandermonde(u, degree), to_power_series(coefficients))
BASES = {
    "legendre": (legendre.legvander, legendre.leg2poly),
    "chebyshev": (chebyshev.chebvander, chebyshev.cheb2poly),
    "power": (power.polyvander, lambda c: np.asarray(c, dtype=float)),
}


@lru_cache(maxsize=64)
def _to_power(kind: str, degree: int) -> np.ndarray:
    """Matrix mapping basis coefficients to power-series coefficients."""
    convert = BASES[kind][1]
    out = np.zeros((degree + 1, degree + 1))
    for k in range(degree + 1):
        unit = np.zeros(degree + 1)
        unit[k] = 1.0
        series = np.asarray(convert(unit), dtype=float)
        out[: len(series), k] = series
    out.setflags(write=False)
    return out


def _recurrence(kind: str, u: np.ndarray, degree: int) -> np.ndarray:
    """Polynomials of degree ``0..degree`` at ``u``, one row each (contiguous rows)."""
    out = np.empty((degree + 1, u.shape[0]))
    out[0] = 1.0
    if degree == 0:
        return out
    out[1] = u
    for k in range(2, degree + 1):
        if kind == "legendre":
            # k P_k = (2k - 1) u P_{k-1} - (k - 1) P_{k-2}
            np.multiply(out[k - 1], u, out=out[k])
            out[k] *= (2 * k - 1) / k
            out[k] -= ((k - 1) / k) * out[k - 2]
        elif kind == "chebyshev":
            np.multiply(out[k - 1], u, out=out[k])
            out[k] *= 2.0
            out[k] -= out[k - 2]
        else:
            np.multiply(out[k - 1], u, out=out[k])
    return out


class PolyBasis:
    """Polynomial basis of one curve over the range of its argument.

    Parameters
    ----------
    lo, hi : float
        Range of the argument on the training data.
    degree : int
        Highest polynomial degree.
    parity : {None, "odd", "even"}
        Keep only odd or even degrees (exact symmetry about ``x = 0``).
    kind : {"legendre", "chebyshev", "power"}
        Polynomial family in the scaled variable.
    """

    def __init__(self, lo: float, hi: float, degree: int, parity: str | None = None,
                 kind: str = "legendre") -> None:
        if parity is None:
            center = 0.5 * (lo + hi)
            half = 0.5 * (hi - lo)
        else:
            center = 0.0
            half = max(abs(lo), abs(hi))
        if not np.isfinite(half) or half <= 0:
            half = max(1.0, abs(center))
        self.lo, self.hi = float(lo), float(hi)
        self.center, self.half = float(center), float(half)
        self.degree = int(degree)
        self.parity = parity
        self.kind = kind
        degrees = np.arange(self.degree + 1)
        if parity == "odd":
            degrees = degrees[degrees % 2 == 1]
        elif parity == "even":
            degrees = degrees[degrees % 2 == 0]
        self.degrees = degrees

    @property
    def size(self) -> int:
        """Number of coefficients."""
        return len(self.degrees)

    def design(self, x: np.ndarray) -> np.ndarray:
        """Basis functions evaluated at ``x``: shape ``(len(x), size)``, column-major."""
        u = (np.asarray(x, dtype=float) - self.center) / self.half
        if not len(self.degrees):
            return np.empty((u.shape[0], 0))
        rows = _recurrence(self.kind, u, self.degree)
        # odd, even or all degrees: a strided view, no copy
        step = 1 if self.parity is None else 2
        return rows[int(self.degrees[0])::step].T

    def bernstein(self, degree: int) -> np.ndarray:
        """Matrix mapping coefficients to Bernstein coefficients of ``degree`` (>= the basis's).

        The Bernstein form is over the basis's interval ``center -+ half``
        (which holds the data's range): when its coefficients do not
        decrease, the curve does not decrease anywhere on that interval.
        """
        m = max(int(degree), self.degree)
        k = np.arange(m + 1)
        s = 0.5 * (1.0 - np.cos(np.pi * (2 * k + 1) / (2 * (m + 1))))  # Chebyshev nodes in [0, 1]
        bernstein = comb(m, k)[None, :] * s[:, None] ** k * (1.0 - s[:, None]) ** (m - k)
        values = self.design(self.center + self.half * (2.0 * s - 1.0))
        return np.linalg.solve(bernstein, values)

    def to_power(self) -> np.ndarray:
        """Matrix mapping coefficients to the power series in ``u``: ``(degree + 1, size)``."""
        return _to_power(self.kind, self.degree)[:, self.degrees]

    def curve(self, coefficients: np.ndarray, extrapolation: str | None = None) -> PolyCurve:
        """The fitted curve for ``coefficients`` (one per basis function)."""
        series = self.to_power() @ np.asarray(coefficients)
        return PolyCurve(series, self.center, self.half, (self.lo, self.hi), extrapolation)


#: share of a curve's domain, at each end, whose mean slope a linear extrapolation continues
EDGE = 0.2


class PolyCurve(Curve):
    """A fitted polynomial curve, evaluated by Horner's rule.

    Works on floats (fast, for ODE right-hand sides) and on numpy arrays.

    Attributes
    ----------
    series : ndarray
        Power-series coefficients in the scaled variable ``u``.
    center, half : float
        ``u = (x - center) / half``.
    domain : tuple of float
        Argument range seen in training.
    extrapolation : {None, "linear"}
        Beyond ``domain``: the polynomial itself (None), or the straight line
        that continues its value at the nearer end with its mean slope over
        the outer :data:`EDGE` of the domain (``"linear"``: a degree-7
        polynomial grows like ``x^7`` out there, and its slope at the very
        end, where few data hold it, is the least certain thing about it).
    """

    def __init__(self, series: np.ndarray, center: float, half: float,
                 domain: tuple[float, float], extrapolation: str | None = None) -> None:
        if extrapolation not in (None, "linear"):
            raise ValueError(f"extrapolation must be None or 'linear', got {extrapolation!r}")
        self.series = np.asarray(series, dtype=float)
        self.center = float(center)
        self.half = float(half)
        self.domain = (float(domain[0]), float(domain[1]))
        self.extrapolation = extrapolation
        self._coefs = [float(c) for c in self.series[::-1]]
        self._inv = 1.0 / self.half
        if extrapolation == "linear":
            lo, hi = self.domain
            step = EDGE * (hi - lo) or 1.0
            self._edges = tuple(
                (edge, self._horner(edge),
                 (self._horner(edge) - self._horner(inner)) / (edge - inner))
                for edge, inner in ((lo, lo + step), (hi, hi - step)))

    def _horner(self, x):
        u = (x - self.center) * self._inv
        coefs = self._coefs
        acc = coefs[0]
        for c in coefs[1:]:
            acc = acc * u + c
        return acc

    def scalar(self, x: float) -> float:
        """The curve at one float: Horner's rule on floats, the right-hand side's fast path."""
        if self.extrapolation == "linear":
            (lo, f_lo, s_lo), (hi, f_hi, s_hi) = self._edges
            if x < lo:
                return f_lo + s_lo * (x - lo)
            if x > hi:
                return f_hi + s_hi * (x - hi)
        u = (x - self.center) * self._inv
        acc = 0.0
        for c in self._coefs:
            acc = acc * u + c
        return acc

    def __call__(self, x):
        """The curve at ``x``, continued beyond its domain as ``extrapolation`` says."""
        acc = self._horner(x)
        if self.extrapolation == "linear":
            (lo, f_lo, s_lo), (hi, f_hi, s_hi) = self._edges
            if isinstance(x, np.ndarray):
                acc = np.where(x < lo, f_lo + s_lo * (x - lo),
                               np.where(x > hi, f_hi + s_hi * (x - hi), acc))
            elif x < lo:
                acc = f_lo + s_lo * (x - lo)
            elif x > hi:
                acc = f_hi + s_hi * (x - hi)
        if isinstance(x, np.ndarray) and not isinstance(acc, np.ndarray):
            return np.full(x.shape, acc)
        return acc

    @classmethod
    def stack(cls, curves, rows: int) -> Curve | None:
        """Curves of one basis (the same centre, scale, domain and degree) evaluated at once.

        Horner's rule runs with one coefficient per row: the numbers each
        block gets are those its own curve gives. None where the curves do
        not share their basis.
        """
        first = curves[0]
        same = all(c.center == first.center and c.half == first.half
                   and c.domain == first.domain and c.extrapolation == first.extrapolation
                   and c.series.shape == first.series.shape for c in curves)
        return _StackedPolyCurve(curves, rows) if same else None

    def polynomial(self) -> np.polynomial.Polynomial:
        """The curve as a power series in its own argument ``x``."""
        u = np.polynomial.Polynomial([-self.center / self.half, 1.0 / self.half])
        return np.polynomial.Polynomial(self.series)(u)

    def to_sympy(self, variable):
        """The polynomial in ``variable``."""
        import sympy

        return sum((sympy.Float(float(c)) * variable**k
                    for k, c in enumerate(self.polynomial().coef)), sympy.Integer(0))

    @property
    def n_numbers(self) -> int:
        """Coefficients of the series."""
        return int(self.series.size)

    def __getstate__(self) -> dict:
        return {"series": self.series, "center": self.center, "half": self.half,
                "domain": self.domain, "extrapolation": self.extrapolation}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["series"], state["center"], state["half"], state["domain"],
                      state.get("extrapolation"))

    def __repr__(self) -> str:
        extra = "" if self.extrapolation is None else f", extrapolation={self.extrapolation!r}"
        return f"PolyCurve(degree={len(self.series) - 1}, domain={self.domain}{extra})"


class _StackedPolyCurve(Curve):
    """Polynomial curves of one basis side by side (:meth:`PolyCurve.stack`), on arrays."""

    def __init__(self, curves, rows: int) -> None:
        first = curves[0]
        self.domain, self.extrapolation = first.domain, first.extrapolation
        self._center, self._inv = first.center, first._inv
        self._coefs = [np.repeat([c._coefs[k] for c in curves], rows)
                       for k in range(len(first._coefs))]
        if self.extrapolation == "linear":
            self._edges = tuple(
                (first._edges[end][0],
                 np.repeat([c._edges[end][1] for c in curves], rows),
                 np.repeat([c._edges[end][2] for c in curves], rows))
                for end in (0, 1))

    def __call__(self, x):
        u = (x - self._center) * self._inv
        acc = self._coefs[0]
        for c in self._coefs[1:]:
            acc = acc * u + c
        if self.extrapolation == "linear":
            (lo, f_lo, s_lo), (hi, f_hi, s_hi) = self._edges
            acc = np.where(x < lo, f_lo + s_lo * (x - lo),
                           np.where(x > hi, f_hi + s_hi * (x - hi), acc))
        return acc
