"""Fitting the delay of an input read late (``u(t - a5)``): a profile over delays.

A delay moves the data an equation reads, not a number inside it, so it is
fitted outside the backend: the skeleton is fitted with each delay of a grid
as a number (every backend fits that as it fits any skeleton), the fits are
compared by their error, and the best grid point is refined between its
neighbours by a parabola. Each delay is searched in turn, the others held.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping

import numpy as np

from ..fitting.problem import FitResult, Problem
from ..skeleton import Skeleton

__all__ = ["DELAY_SAMPLES", "fit_delays", "fit_error", "refine_delays"]

#: the default longest delay tried, in sampling intervals (a bound ``a5 <= ...`` widens it)
DELAY_SAMPLES = 60
#: most delays a profile tries (beyond, the grid is coarser than one sample)
GRID_POINTS = 121


def _sampling_interval(t: np.ndarray) -> float:
    steps = np.diff(np.asarray(t, dtype=float))
    steps = steps[steps > 0]
    if steps.size == 0:
        raise ValueError("a delay is fitted from the time column 't', which does not advance")
    return float(np.median(steps))


def _grid(low: float, high: float, dt: float) -> np.ndarray:
    if not math.isfinite(high):
        high = low + DELAY_SAMPLES * dt
    if high <= low:
        return np.array([low])
    count = min(GRID_POINTS, round((high - low) / dt) + 1)
    return np.linspace(low, high, max(count, 2))


def _vertex(grid: np.ndarray, costs: np.ndarray, k: int) -> float:
    """The minimum of the parabola through the best grid point and its neighbours."""
    if k == 0 or k == len(grid) - 1 or not np.isfinite(costs[k - 1:k + 2]).all():
        return float(grid[k])
    c0, c1, c2 = costs[k - 1:k + 2]
    curvature = c0 - 2 * c1 + c2
    if curvature <= 0:
        return float(grid[k])
    step = grid[k + 1] - grid[k]
    return float(grid[k] + 0.5 * step * (c0 - c2) / curvature)


def fit_delays(skeleton: Skeleton, t: np.ndarray,
               cost_at: Callable[[Mapping[str, float]], float]) -> dict[str, float]:
    """The delays of ``skeleton`` (:attr:`~Skeleton.delay_params`) that fit best.

    Parameters
    ----------
    skeleton : Skeleton
        The user's skeleton, with its delays' bounds.
    t : ndarray
        The record's time column (its sampling interval sets the grid).
    cost_at : callable
        Delays by parameter -> the error of the skeleton fitted with them
        (inf where that fit fails).

    Returns
    -------
    dict
        Parameter -> fitted delay, in the time units of ``t``.
    """
    dt = _sampling_interval(t)
    bounds = skeleton.bounds
    values = {name: bounds[name][0] for name in skeleton.delay_params}
    for name in skeleton.delay_params:
        low, high = bounds[name]
        grid = _grid(low, high, dt)
        costs = np.array([_cost(cost_at, {**values, name: float(d)}) for d in grid])
        if not np.isfinite(costs).any():
            raise ValueError(f"no delay {name} from {grid[0]:g} to {grid[-1]:g} gives a fit "
                             "with a finite error")
        k = int(np.nanargmin(np.where(np.isfinite(costs), costs, np.nan)))
        values[name] = float(np.clip(_vertex(grid, costs, k), low, high))
    return values


def refine_delays(skeleton: Skeleton, t: np.ndarray, values: Mapping[str, float],
                  refine_at: Callable[[Mapping[str, float]], float]) -> dict[str, float]:
    """Each delay of ``values`` searched again within a sampling interval, in halves.

    ``refine_at`` is the error of the fit the estimator makes in the end (by
    output error). Derivatives estimated from a record smear a held input's
    steps over a sample; a simulation that holds the input does not.
    """
    dt = _sampling_interval(t)
    bounds = skeleton.bounds
    values = dict(values)
    for name in skeleton.delay_params:
        low, high = bounds[name]
        near = np.unique(np.clip(values[name] + dt * np.array([-1.0, -0.5, 0.0, 0.5, 1.0]),
                                 low, high))
        costs = np.array([_cost(refine_at, {**values, name: float(d)}) for d in near])
        if np.isfinite(costs).any():
            k = int(np.nanargmin(np.where(np.isfinite(costs), costs, np.nan)))
            values[name] = float(np.clip(_vertex(near, costs, k), low, high))
    return values


def _cost(cost_at, values: Mapping[str, float]) -> float:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cost = float(cost_at(values))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return math.inf
    return cost if math.isfinite(cost) else math.inf


def fit_error(problem: Problem, result: FitResult) -> float:
    """The error a fit leaves.

    Its output error, or else each target's squared error over its variance,
    summed.
    """
    shooting = result.attributes.get("shooting_")
    if shooting is not None and "nrmse_after" in shooting:
        return float(shooting["nrmse_after"])
    params = {**problem.fixed_params, **{k: float(v) for k, v in result.params.items()}}
    system = problem.skeleton.compile(result.functions, params)
    columns, n = problem.data.columns, problem.data.n_samples
    with np.errstate(all="ignore"):
        predicted = np.hstack([system.evaluate(columns, n), system.evaluate_outputs(columns, n)])
    target = np.asarray(problem.y, dtype=float)[:, :predicted.shape[1]]
    spread = np.var(target, axis=0)
    spread[spread == 0] = 1.0
    return float(np.sum(np.mean((predicted - target) ** 2, axis=0) / spread))
