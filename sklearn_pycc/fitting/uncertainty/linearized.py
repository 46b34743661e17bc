"""Covariance of the parameters of a fit whose curves are flexible, by linearisation.

A network's curve changes, near the fitted one, mostly through its last
layer: the curve is linear in the last layer's weights, with the last hidden
layer's outputs as a basis. Read that way, a fit of the skeleton is a least
squares problem in the scalars ``a_i`` and the last layers, and its
covariance is the sandwich with Newey-West scores
(:func:`~sklearn_pycc.fitting.uncertainty.covariance.sandwich_covariance`), the same estimate the
polynomial backend gives: the curves are nuisances with many degrees of
freedom, and the scalars' standard errors account for what the curves
could absorb. Columns of the Jacobian are central differences of the
compiled residuals; point values of a curve and parameters at a bound hold
the estimate.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from ..problem import Problem, active_residuals
from .covariance import sandwich_covariance

__all__ = ["linearized_covariance"]


def linearized_covariance(problem: Problem, functions: Mapping, params: Mapping[str, float],
                          features: Mapping[str, Callable[[np.ndarray], np.ndarray]]
                          ) -> pd.DataFrame | None:
    """Covariance of the free parameters of a fit, its curves linearised in ``features``.

    Parameters
    ----------
    problem : Problem
        The fitted problem.
    functions : dict
        The fitted curves.
    params : dict
        The fitted free parameters.
    features : dict of str -> callable
        For each free curve, ``x -> (len(x), m)``: the directions in which
        the curve may change.

    Returns
    -------
    DataFrame or None
        Indexed by the free parameters (None when there are none).
    """
    free = list(problem.free_params)
    if not free:
        return None
    _, weights = active_residuals(problem)
    weights = np.asarray(weights)
    n = problem.data.n_samples

    def evaluate(values: Mapping, curves: Mapping) -> np.ndarray:
        # weighted residuals, stacked by equation
        return (problem.residual_values(values, curves) * weights).ravel(order="F")

    r = evaluate(params, functions)
    columns = []
    for name in free:
        h = 1e-6 * max(1.0, abs(params[name]))
        up, down = dict(params), dict(params)
        up[name] += h
        down[name] -= h
        columns.append((evaluate(up, functions) - evaluate(down, functions)) / (2 * h))
    points = []  # (column of the curve's first feature, its features at a point value)
    for name, basis in features.items():
        first = len(columns)
        size = basis(np.zeros(1)).shape[1]
        curve = functions[name]
        h = 1e-4 * max(1.0, float(np.max(np.abs(curve(np.linspace(*curve.domain, 9))))))
        for k in range(size):
            up = {**functions, name: _shifted(functions[name], basis, k, h)}
            down = {**functions, name: _shifted(functions[name], basis, k, -h)}
            columns.append((evaluate(params, up) - evaluate(params, down)) / (2 * h))
        points += [(first, basis(np.array([at]))[0]) for at, _ in problem.points(name)]
    J = np.column_stack(columns)
    constraints = []
    for first, values in points:
        row = np.zeros(J.shape[1])
        row[first:first + values.size] = values
        constraints.append(row)
    bounds = problem.bounds
    for j, name in enumerate(free):
        low, high = bounds.get(name, (-np.inf, np.inf))
        if np.isclose(params[name], low) or np.isclose(params[name], high):
            constraints.append(np.eye(J.shape[1])[j])
    finite = np.isfinite(r) & np.isfinite(J).all(axis=1)
    if not finite.all():  # a sample where the model is not defined says nothing
        J, r = J * finite[:, None], np.where(finite, r, 0.0)
        J = np.nan_to_num(J)
    cov, lag = sandwich_covariance(J, r, n, problem.data.trajectory,
                                   np.array(constraints) if constraints else None)
    block = cov[:len(free), :len(free)]
    frame = pd.DataFrame(block, index=free, columns=free)
    frame.attrs["lag"] = lag
    return frame


def _shifted(curve: Callable, basis: Callable, k: int, step: float) -> Callable:
    """``curve`` moved by ``step`` times its ``k``-th feature."""
    def moved(x):
        x = np.asarray(x, dtype=float)
        return curve(x) + step * basis(x.reshape(-1))[:, k].reshape(x.shape)

    return moved
