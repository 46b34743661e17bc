"""Curves as interpolated tables: the seed paper's ``Interp`` simulation.

An :class:`InterpolatedCurve` holds a curve's values on a grid and
interpolates them piecewise-cubically (monotone cubic, PCHIP, by default),
continuing linearly beyond the table. :class:`InterpolatedCCRegressor`
fits another backend and tabulates its curves; :func:`to_interpolated`
(in :mod:`.conversion`) converts an already fitted model.
"""

from __future__ import annotations

import warnings
from bisect import bisect_right
from collections.abc import Mapping
from numbers import Integral

import numpy as np
import pandas as pd
from scipy.interpolate import Akima1DInterpolator, CubicSpline, PchipInterpolator
from sklearn.base import _fit_context, clone
from sklearn.utils._param_validation import Interval, StrOptions

from ..exceptions import GaugeWarning
from ..fitting.problem import gauge_skeleton
from ..skeleton.curves import Curve, ZeroCurve
from .backend import Backend, FitResult, Problem
from .base import OUTPUT_ERROR_SETTINGS, CCRegressor, backend_of
from .poly import PolyCCRegressor

__all__ = ["INTERPOLATIONS", "InterpolatedCCRegressor", "InterpolatedCurve", "TableBackend",
           "sample_curve", "tabulate"]

_CUBIC = {"pchip": PchipInterpolator, "akima": Akima1DInterpolator, "cubic": CubicSpline}
#: interpolation methods of a table
INTERPOLATIONS = ("pchip", "akima", "cubic", "linear")


def check_method(method: str) -> str:
    """``method`` if it is one of :data:`INTERPOLATIONS`, else a clear error."""
    if method not in INTERPOLATIONS:
        raise ValueError(f"method must be one of {INTERPOLATIONS}, got {method!r}")
    return method


class InterpolatedCurve(Curve):
    """A curve interpolated from a table of values.

    Inside the table the curve is the chosen piecewise polynomial; beyond it
    the curve continues along the tangent at the nearest end (a cubic
    extrapolated freely can turn away fast and make a simulation diverge).
    Evaluation is a ``searchsorted`` and a Horner step in numpy.

    Parameters
    ----------
    x, y : array-like of shape (n,)
        The table: at least two points with ``x`` strictly increasing.
    method : {"pchip", "akima", "cubic", "linear"}, default="pchip"
        Monotone cubic (PCHIP: monotone data stay monotone, no overshoot),
        Akima, a not-a-knot cubic spline, or straight lines.
    name : str, default="curve"
        The curve's name, used in error messages.
    """

    extrapolation = "linear"

    def __init__(self, x, y, method: str = "pchip", name: str = "curve") -> None:
        check_method(method)
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if x.ndim != 1 or y.shape != x.shape:
            raise ValueError(f"the table of {name} needs x and y of one same length, got "
                             f"shapes {x.shape} and {y.shape}")
        if x.size < 2:
            raise ValueError(f"the table of {name} has {x.size} point(s); at least 2 are needed")
        for label, values in (("x", x), ("y", y)):
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                raise ValueError(f"the table of {name} has a non-finite {label} at position "
                                 f"{bad[0]} ({values[bad[0]]})")
        steps = np.flatnonzero(np.diff(x) <= 0)
        if steps.size:
            k = int(steps[0]) + 1
            raise ValueError(f"the table of {name} must have x strictly increasing, but x at "
                             f"position {k} ({x[k]:.6g}) does not exceed the one before "
                             f"({x[k - 1]:.6g})")
        self.x = x
        self.y = y
        self.method = method
        self.domain = (float(x[0]), float(x[-1]))
        if method == "linear":
            slopes = np.diff(y) / np.diff(x)
            self._coefficients = np.vstack([slopes, y[:-1]])
        else:
            self._coefficients = np.asarray(_CUBIC[method](x, y).c)
        self._end_slopes = (self._slope(0, 0.0), self._slope(x.size - 2, x[-1] - x[-2]))
        # plain Python copies for the float -> float path of ODE right-hand sides
        self._knot_list = x.tolist()
        self._end_values = (float(y[0]), float(y[-1]))
        self._piece_list = self._coefficients.T.tolist()

    def _slope(self, piece: int, dx: float) -> float:
        c = self._coefficients[:, piece]
        order = c.size - 1
        return float(sum(c[k] * (order - k) * dx ** (order - k - 1) for k in range(order)))

    def __call__(self, x):
        """The curve at ``x`` (array or scalar)."""
        x = np.asarray(x, dtype=float)
        knots, c = self.x, self._coefficients
        piece = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, knots.size - 2)
        dx = x - knots[piece]
        out = c[0, piece]
        for row in c[1:]:
            out = out * dx + row[piece]
        below, above = x < knots[0], x > knots[-1]
        out = np.where(below, self.y[0] + self._end_slopes[0] * (x - knots[0]), out)
        out = np.where(above, self.y[-1] + self._end_slopes[1] * (x - knots[-1]), out)
        return out if out.ndim else float(out)

    def scalar(self, x: float) -> float:
        """The curve at one float, in plain Python (for ODE right-hand sides)."""
        knots = self._knot_list
        if x < knots[0]:
            return self._end_values[0] + self._end_slopes[0] * (x - knots[0])
        if x > knots[-1]:
            return self._end_values[1] + self._end_slopes[1] * (x - knots[-1])
        piece = min(bisect_right(knots, x) - 1, len(knots) - 2)
        dx = x - knots[piece]
        out = 0.0
        for c in self._piece_list[piece]:
            out = out * dx + c
        return out

    @property
    def n_numbers(self) -> int:
        """Values of the table."""
        return int(self.x.size)

    def text(self, variable: str, precision: int = 6) -> str:
        """A description of the table as a function of ``variable``."""
        lo, hi = self.domain
        return (f"{self.method}({variable}; {self.x.size} points on "
                f"[{lo:.{precision}g}, {hi:.{precision}g}])")

    def __repr__(self) -> str:
        return f"InterpolatedCurve(method={self.method!r}, n_points={self.x.size})"


def sample_curve(curve, lo: float, hi: float, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """``curve`` on ``n_points`` evenly spaced over ``[lo, hi]``.

    A range that never varied is widened to a unit interval around it.
    """
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    x = np.linspace(lo, hi, int(n_points))
    return x, np.array(np.broadcast_to(np.asarray(curve(x), dtype=float), x.shape))


def tabulate(curve, lo: float, hi: float, n_points: int, method: str, *,
             name: str = "curve"):
    """``curve`` sampled on ``n_points`` over ``[lo, hi]`` and interpolated.

    A zero curve stays one.
    """
    if isinstance(curve, ZeroCurve):
        return curve
    return InterpolatedCurve(*sample_curve(curve, lo, hi, n_points), method, name)


def check_n_points(n_points) -> int:
    """``n_points`` if it is an integer of at least 2, else a clear error."""
    if not isinstance(n_points, Integral) or isinstance(n_points, bool) or n_points < 2:
        raise ValueError(f"n_points must be an integer of at least 2, got {n_points!r}")
    return int(n_points)


class TableBackend(Backend):
    """Another backend's curves, tabulated over the range of their arguments.

    Parameters
    ----------
    inner : Backend
        The backend that fits the curves first.
    n_points : int
        Points of each table.
    method : {"pchip", "akima", "cubic", "linear"}
        How a table is interpolated (see :class:`InterpolatedCurve`).
    """

    settings = ("inner", "n_points", "method")

    def reseeded(self, seed: int) -> TableBackend:
        """A copy whose inner backend draws its randomness from ``seed``."""
        twin = super().reseeded(seed)
        twin.inner = self.inner.reseeded(seed)
        return twin

    def tabulated(self, functions: Mapping, ranges: Mapping[str, tuple[float, float]]) -> dict:
        """``functions`` with each curve that has a range tabulated over it."""
        return {name: (tabulate(curve, *ranges[name], self.n_points, self.method, name=name)
                       if name in ranges else curve)
                for name, curve in functions.items()}

    def fit(self, problem: Problem) -> FitResult:
        """The inner backend's fit, each curve tabulated where the data put its argument."""
        result = self.inner.fit(problem)
        params = {**problem.fixed_params, **result.params}
        ranges = {}
        for name in problem.free_functions:
            values = problem.argument_values(name, params, result.functions)
            values = values[np.isfinite(values)]
            if values.size:
                ranges[name] = (float(values.min()), float(values.max()))
        return FitResult(self.tabulated(result.functions, ranges), dict(result.params))


class InterpolatedCCRegressor(CCRegressor):
    """Characteristic curves as interpolated tables (the paper's ``Interp``).

    Fits ``estimator`` on the skeleton, then replaces each of its curves by
    an interpolant of its values on ``n_points`` over the range of the
    curve's argument in the data. The tables are what the model keeps:
    it predicts and simulates from them, and they are easy to hand to a
    simulator that takes lookup tables. Convert an already fitted model with
    :func:`sklearn_pycc.to_interpolated`.

    Parameters
    ----------
    equations, constraints, gauge, differentiation, smooth_states, equation_weights, quantities
        See :class:`CCRegressor`. They override the ``estimator``'s own.
    estimator : CCRegressor, optional
        The backend whose fitted curves are tabulated (not modified; a
        clone is fitted). Default ``PolyCCRegressor()``.
    n_points : int, default=200
        Points of each table.
    method : {"pchip", "akima", "cubic", "linear"}, default="pchip"
        How the table is interpolated (see :class:`InterpolatedCurve`).

    Attributes
    ----------
    estimator_ : CCRegressor
        The fitted clone of ``estimator`` (absent after
        :func:`~sklearn_pycc.to_interpolated`).
    tables_ : dict of str -> DataFrame
        Each curve's table, columns ``x`` and the curve's name.
    """

    _parameter_constraints: dict = {
        **{k: v for k, v in CCRegressor._parameter_constraints.items()
         if k not in OUTPUT_ERROR_SETTINGS},
        "estimator": [CCRegressor, None],
        "n_points": [Interval(Integral, 2, None, closed="left")],
        "method": [StrOptions(set(INTERPOLATIONS))],
    }

    def __init__(self, *, equations=None, constraints=None, estimator=None, n_points: int = 200,
                 method: str = "pchip", gauge: str = "auto", differentiation="auto",
                 smooth_states: bool = True, equation_weights=None,
                 quantities: Mapping[str, str] | None = None) -> None:
        super().__init__(equations=equations, constraints=constraints, gauge=gauge,
                         differentiation=differentiation, smooth_states=smooth_states,
                         equation_weights=equation_weights, quantities=quantities)
        self.estimator = estimator
        self.n_points = n_points
        self.method = method

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Fit a clone of ``estimator`` through its public ``fit``, then tabulate its curves.

        The clone takes this estimator's skeleton, constraints, gauge and
        differentiation, and keeps its own fit mode: a neural or polynomial
        backend with ``fit_mode="simulation"`` runs its output-error stage
        before its curves are tabulated.

        Parameters
        ----------
        X, y
            As for :meth:`CCRegressor.fit`.

        Returns
        -------
        self : InterpolatedCCRegressor
            The fitted estimator.
        """
        self._reset_fitted()
        fitted = PolyCCRegressor() if self.estimator is None else clone(self.estimator)
        fitted.set_params(equations=self.__dict__.get("equations"),
                           constraints=self.constraints, gauge=self.gauge,
                           differentiation=self.differentiation,
                           smooth_states=self.smooth_states,
                           equation_weights=self.equation_weights)
        fitted.fit(X, y)
        backend = self._make_backend()
        tables = backend.tabulated(fitted.functions_, fitted.curve_ranges_)
        with warnings.catch_warnings():  # the fitted's fit has said it already
            warnings.simplefilter("ignore", GaugeWarning)
            _, fixed, _, _ = gauge_skeleton(fitted.skeleton_, fitted.gauge)
        n_parameters = len([a for a in fitted.skeleton_.params if a not in fixed]) + sum(
            t.x.size for t in tables.values() if isinstance(t, InterpolatedCurve))
        self._adopt(fitted, tables, fitted.params_, n_parameters, {"estimator_": fitted})
        return self

    def _make_backend(self) -> TableBackend:
        inner = backend_of(PolyCCRegressor() if self.estimator is None else self.estimator)
        return TableBackend(inner=inner, n_points=self.n_points, method=self.method)

    @property
    def tables_(self) -> dict:
        """Each curve's table, columns ``x`` and the curve's name."""
        out = {}
        for name, curve in self.functions_.items():
            if isinstance(curve, InterpolatedCurve):
                out[name] = pd.DataFrame({"x": curve.x, name: curve.y})
        return out
