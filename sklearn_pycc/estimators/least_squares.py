"""A small backend in one file: everything fitted jointly by scipy's ``least_squares``.

Each curve is a short power series in its argument scaled to ``[-1, 1]``; its
coefficients and every free parameter form one vector, refined from zero
curves and unit parameters by trust-region least squares on the weighted
equation residuals. Nonlinear parameters (``a2 tanh(a3 x2)``) and curves
inside other functions need nothing special. It is the backend to read when
writing one of your own; :class:`~sklearn_pycc.PolyCCRegressor` is the one to
use: faster, exact constraints, any degree, uncertainty and output error.
"""

from __future__ import annotations

from collections.abc import Mapping
from numbers import Integral

import numpy as np
from scipy.optimize import least_squares
from sklearn.utils._param_validation import Interval

from ..backends.poly.basis import PolyCurve
from ..skeleton.curves import ZeroCurve
from .backend import Backend, FitResult, Problem
from .base import OUTPUT_ERROR_SETTINGS, CCRegressor

__all__ = ["MAX_NUMBERS", "LeastSquaresBackend", "LeastSquaresCCRegressor"]

#: most numbers (coefficients and free parameters) one fit may have: its Jacobian by finite
#: differences evaluates every equation once per number and step (240 numbers: about 4 s)
MAX_NUMBERS = 240


class LeastSquaresBackend(Backend):
    """Power-series curves and parameters, all by ``scipy.optimize.least_squares``.

    Parameters
    ----------
    degree : int
        Degree of every curve's power series.
    param_init : dict or None
        Starting values of parameters (the others start from 1, moved
        within their bounds).
    max_nfev : int
        Most residual evaluations.
    """

    settings = ("degree", "param_init", "max_nfev")

    def fit(self, problem: Problem) -> FitResult:
        """One least-squares problem over every coefficient and free parameter."""
        names = problem.free_params
        init = problem.starting_values(self.param_init)
        low = np.array([problem.bounds.get(a, (-np.inf, np.inf))[0] for a in names])
        high = np.array([problem.bounds.get(a, (-np.inf, np.inf))[1] for a in names])
        start = np.clip([init.get(a, 1.0) for a in names], low, high)
        values = {**problem.fixed_params, **dict(zip(names, start))}
        curves = [_Series.for_curve(problem, name, values, int(self.degree))
                  for name in problem.free_functions]
        sizes = [len(curve.powers) for curve in curves]
        _check_size(len(names) + sum(sizes), len(curves))
        weights = problem.residual_weights()

        def unpack(theta: np.ndarray) -> tuple[dict, dict]:
            params = dict(zip(names, theta[:len(names)]))
            functions, offset = {}, len(names)
            for curve, size in zip(curves, sizes):
                functions[curve.name] = curve.fitted(theta[offset:offset + size])
                offset += size
            return params, functions

        def residual(theta: np.ndarray) -> np.ndarray:
            params, functions = unpack(theta)
            r = (problem.residual_values(params, functions) * weights).ravel()
            return np.where(np.isfinite(r), r, 1e150)

        theta0 = np.concatenate([start, np.zeros(sum(sizes))])
        free = np.full(sum(sizes), np.inf)
        solution = least_squares(residual, theta0, bounds=(np.r_[low, -free], np.r_[high, free]),
                                 x_scale="jac", max_nfev=int(self.max_nfev))
        theta = solution.x
        theta[:len(names)] = np.clip(theta[:len(names)], low, high)
        params, functions = unpack(theta)
        functions.update({name: ZeroCurve() for name in problem.zeroed})
        return FitResult(functions, {a: float(v) for a, v in params.items()},
                         {"cost_": float(solution.cost), "nfev_": int(solution.nfev)})

    def n_numbers(self, problem: Problem, result: FitResult, name: str) -> int:
        """The coefficients the series was free in."""
        return len(_powers(problem.parity(name), bool(problem.points(name)), int(self.degree)))


def _check_size(numbers: int, n_curves: int) -> None:
    """Refuse a fit whose finite-difference Jacobian would take minutes, saying what to do."""
    if numbers > MAX_NUMBERS:
        raise ValueError(
            f"LeastSquaresBackend would fit {numbers} numbers ({n_curves} curves' coefficients "
            f"and the free parameters), more than its {MAX_NUMBERS}: its Jacobian by finite "
            "differences evaluates every equation once per number and step, so its time grows "
            "with the square of their count (minutes here). Use PolyCCRegressor, which solves "
            "curves that enter linearly in one linear least-squares problem (200 curves in "
            "seconds), or a lower degree, or fewer curves")


def _powers(parity: str | None, pinned: bool, degree: int) -> list[int]:
    """The powers a curve's series is free in (the constant is set by a point value)."""
    powers = range(1 if pinned else 0, degree + 1)
    if parity == "odd":
        return [p for p in powers if p % 2 == 1]
    if parity == "even":
        return [p for p in powers if p % 2 == 0]
    return list(powers)


class _Series:
    """One curve's power series: which powers are free, and its exact point value."""

    def __init__(self, name: str, center: float, half: float, domain: tuple[float, float],
                 powers: list[int], *, point: tuple[float, float] | None) -> None:
        self.name, self.center, self.half, self.domain = name, center, half, domain
        self.powers, self.point = powers, point

    @classmethod
    def for_curve(cls, problem: Problem, name: str, values: Mapping, degree: int) -> _Series:
        if problem.monotone(name) is not None:
            raise ValueError(f"{name} must be monotone, which LeastSquaresBackend cannot "
                             "hold: use PolyCCRegressor")
        points = problem.points(name)
        if len(points) > 1:
            raise ValueError(f"{name} has {len(points)} point values; LeastSquaresBackend "
                             "holds one: use PolyCCRegressor")
        parity = problem.parity(name)
        if parity == "odd" and points and points[0] != (0.0, 0.0):
            raise ValueError(f"{name} is odd and has a point value away from 0, which "
                             "LeastSquaresBackend cannot hold: use PolyCCRegressor")
        x = problem.argument_values(name, values, {})
        lo, hi = (float(x.min()), float(x.max())) if x.size else (-1.0, 1.0)
        if parity is not None:  # symmetric about zero
            center, half = 0.0, max(abs(lo), abs(hi))
        else:
            center, half = (lo + hi) / 2, (hi - lo) / 2
        half = half if np.isfinite(half) and half > 0 else 1.0
        return cls(name, center, half, (lo, hi), _powers(parity, bool(points), degree),
                   point=points[0] if points else None)

    def fitted(self, coefficients: np.ndarray) -> PolyCurve:
        series = np.zeros(max(self.powers, default=0) + 1)
        series[self.powers] = coefficients
        if self.point is not None:  # shifted so that it passes through the point exactly
            at, value = self.point
            u = (at - self.center) / self.half
            series[0] += value - float(np.polynomial.polynomial.polyval(u, series))
        return PolyCurve(series, self.center, self.half, self.domain)


class LeastSquaresCCRegressor(CCRegressor):
    """Characteristic curves as short power series, everything fitted by ``least_squares``.

    The backend of :mod:`sklearn_pycc.estimators.least_squares`, written to
    show what a backend needs (one file: :class:`LeastSquaresBackend` and
    this estimator). Odd and even curves and one point value per curve are
    held exactly; monotone curves are not supported.

    Parameters
    ----------
    equations, constraints, gauge, differentiation, smooth_states, equation_weights, quantities
        See :class:`~sklearn_pycc.CCRegressor`.
    degree : int, default=3
        Degree of every curve's power series.
    param_init : dict, optional
        Starting values of parameters.
    max_nfev : int, default=2000
        Most residual evaluations.

    At most :data:`MAX_NUMBERS` (240) numbers are fitted, every curve's
    coefficients and the free parameters together: the Jacobian by finite
    differences makes the time grow with the square of their count, and a
    larger fit is refused with that reason.

    Attributes
    ----------
    cost_ : float
        Half the final sum of squares of the weighted residuals.
    nfev_ : int
        Residual evaluations spent.
    """

    _parameter_constraints: dict = {
        **{k: v for k, v in CCRegressor._parameter_constraints.items()
           if k not in OUTPUT_ERROR_SETTINGS},
        "degree": [Interval(Integral, 0, 15, closed="both")],
        "param_init": [dict, None],
        "max_nfev": [Interval(Integral, 1, None, closed="left")],
    }

    def __init__(self, *, equations=None, constraints=None, degree: int = 3,
                 param_init: Mapping | None = None, max_nfev: int = 2000,
                 gauge: str = "auto", differentiation="auto", smooth_states: bool = True,
                 equation_weights=None, quantities: Mapping[str, str] | None = None) -> None:
        super().__init__(equations=equations, constraints=constraints, gauge=gauge,
                         differentiation=differentiation, smooth_states=smooth_states,
                         fit_mode="equation", equation_weights=equation_weights,
                         quantities=quantities)
        self.degree = degree
        self.param_init = param_init
        self.max_nfev = max_nfev

    def _make_backend(self) -> LeastSquaresBackend:
        return LeastSquaresBackend(**self._backend_settings(LeastSquaresBackend))
