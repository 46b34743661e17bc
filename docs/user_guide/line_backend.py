"""A backend of your own: every curve a straight line, fitted with the parameters."""

import numpy as np
from scipy.optimize import least_squares

from sklearn_pycc import CCRegressor
from sklearn_pycc.estimators.backend import Backend, FitResult


class Line:
    """A fitted straight line (a class rather than a lambda, so that models pickle)."""

    def __init__(self, slope: float, offset: float) -> None:
        self.slope, self.offset = float(slope), float(offset)

    def __call__(self, x):
        """The line at ``x`` (a float or an array)."""
        return self.offset + self.slope * np.asarray(x, dtype=float)


class LineBackend(Backend):
    """Every curve ``offset + slope * x``; everything by ``scipy.optimize.least_squares``."""

    def fit(self, problem):
        """The lines' slopes and offsets and the free parameters, by one least squares."""
        names, curves = problem.free_params, problem.free_functions
        held = [f for f in curves if problem.constraints[f]]
        if held:
            raise ValueError(f"LineBackend holds no constraints, and {held[0]} has some")
        weights = problem.residual_weights()

        def unpack(theta):
            params = dict(zip(names, theta))
            pairs = theta[len(names):].reshape(-1, 2)
            return params, {f: Line(*pair) for f, pair in zip(curves, pairs)}

        def residual(theta):
            params, functions = unpack(theta)
            return (problem.residual_values(params, functions) * weights).ravel()

        start = np.concatenate([np.ones(len(names)), np.zeros(2 * len(curves))])
        solution = least_squares(residual, start)
        params, functions = unpack(solution.x)
        functions.update({f: Line(0.0, 0.0) for f in problem.zeroed})
        return FitResult(functions, params, {"cost_": float(solution.cost)})

    def n_numbers(self, problem, result, name):
        """A slope and an offset per curve (for the information criteria)."""
        return 2


class LineCCRegressor(CCRegressor):
    """The estimator: the shared hyperparameters, and the backend they describe."""

    def _make_backend(self):
        return LineBackend()
