"""How sure a fitted model is: standard errors, intervals, curve and simulation bands.

:class:`IntervalsMixin` gives every estimator the same questions to ask;
a backend answers them through two hooks, :meth:`IntervalsMixin._curve_sd`
(the standard deviation of a curve at given points) and
:meth:`IntervalsMixin._draws` (models drawn from the estimate's
distribution), and through its fitted ``covariance_`` of the parameters. A
backend without them says so when asked, rather than return numbers that
mean nothing.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import numpy as np
import pandas as pd
from scipy.stats import norm
from sklearn.utils.validation import check_is_fitted

from .._random import seeds
from ..exceptions import SimulationError

__all__ = ["IntervalsMixin", "check_level"]

#: models drawn for a simulation band by default
N_DRAWS = 100


def check_level(level) -> float:
    """``level`` checked to be a probability strictly between 0 and 1."""
    if isinstance(level, bool) or not isinstance(level, (int, float, np.floating)) \
            or not 0 < level < 1:
        raise ValueError(f"level must be a probability strictly between 0 and 1 (such as "
                         f"0.95), got {level!r}")
    return float(level)


def _quantile(level: float) -> float:
    """The standard normal quantile of a two-sided interval of ``level``."""
    return float(norm.ppf(0.5 + 0.5 * level))


class IntervalsMixin:
    """Uncertainty of a fitted characteristic-curve model."""

    # -- backend hooks -------------------------------------------------------------
    def _curve_sd(self, name: str, x: np.ndarray) -> np.ndarray | None:
        """Standard deviation of the fitted curve ``name`` at ``x`` (None: not known)."""
        return None

    def _draws(self, n: int, rng: np.random.Generator) -> list[tuple[dict, dict]] | None:
        """``n`` models ``(functions, params)`` drawn from the estimate's distribution."""
        return None

    def _no_uncertainty(self, what: str) -> ValueError:
        return ValueError(
            f"{type(self).__name__} has no estimate of how uncertain its {what} are "
            "(PolyCCRegressor fitted by equation error gives one from the covariance of its "
            "least-squares estimate)")

    # -- parameters ------------------------------------------------------------------
    @property
    def params_std_(self) -> dict[str, float]:
        """Standard error of each fitted parameter ``{"a1": 0.002, ...}``.

        From the fitted ``covariance_`` (0 for a parameter the gauge pinned;
        NaN when the backend has no covariance). The covariance accounts for
        residuals correlated in time (Newey-West), so it holds for coloured
        noise and smoothed derivatives.
        """
        check_is_fitted(self, "params_")
        cov = getattr(self, "covariance_", None)
        out = {}
        for name in self.params_:
            if cov is None:
                out[name] = math.nan
            elif name in cov.index:
                out[name] = math.sqrt(max(float(cov.loc[name, name]), 0.0))
            else:  # pinned by the gauge: known exactly
                out[name] = 0.0
        return out

    def params_interval(self, level: float = 0.95) -> dict[str, tuple[float, float]]:
        """Two-sided confidence interval of each parameter at ``level``.

        Parameters
        ----------
        level : float, default=0.95
            Probability that the interval holds the parameter.

        Returns
        -------
        dict of str -> (float, float)
            ``{"a1": (low, high), ...}``: the estimate plus or minus the
            normal quantile times its standard error, cut to the parameter's
            bounds.

        Raises
        ------
        ValueError
            When the backend has no uncertainty estimate.
        """
        z = _quantile(check_level(level))
        std = self.params_std_
        if any(math.isnan(v) for v in std.values()):
            raise self._no_uncertainty("parameters")
        bounds = self.skeleton_.bounds
        out = {}
        for name, value in self.params_.items():
            low, high = bounds.get(name, (-np.inf, np.inf))
            out[name] = (float(max(value - z * std[name], low)),
                         float(min(value + z * std[name], high)))
        return out

    # -- curves ------------------------------------------------------------------------
    def _curve_band(self, name: str, x: np.ndarray, values: np.ndarray,
                    level: float) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` of the curve ``name`` at ``x`` around ``values``."""
        sd = self._curve_sd(name, x)
        if sd is None:
            raise self._no_uncertainty("curves")
        z = _quantile(level)
        return values - z * sd, values + z * sd

    # -- simulations ------------------------------------------------------------------------
    def _simulation_band(self, frame: pd.DataFrame, simulate: Callable, level: float,
                         n_draws: int, random_state) -> pd.DataFrame:
        """``frame`` with ``NAME_lower``/``NAME_upper`` from simulations of drawn models.

        ``simulate(functions, params)`` returns a frame like ``frame``. Draws
        that diverge are left out, with a warning naming their share.
        """
        if isinstance(n_draws, bool) or not isinstance(n_draws, (int, np.integer)) \
                or n_draws < 2:
            raise ValueError(f"n_draws must be an integer of at least 2, got {n_draws!r}")
        draws = self._draws(int(n_draws), np.random.default_rng(next(seeds(random_state))))
        if draws is None:
            raise self._no_uncertainty("simulations")
        names = [c for c in frame.columns if c != "t"]
        runs, failed = [], 0
        for functions, params in draws:
            try:
                runs.append(simulate(functions, params)[names].to_numpy())
            except SimulationError:
                failed += 1
        if len(runs) < 2:
            raise SimulationError(f"{failed} of {len(draws)} drawn models diverged: the "
                                  "parameters are too uncertain to simulate a band")
        if failed:
            warnings.warn(f"{failed} of {len(draws)} drawn models diverged and are left out "
                          "of the band", UserWarning, stacklevel=3)
        stack = np.stack(runs)
        lower, upper = np.quantile(stack, [0.5 - 0.5 * level, 0.5 + 0.5 * level], axis=0)
        out = frame.copy()
        for j, name in enumerate(names):
            out[f"{name}_lower"] = lower[:, j]
            out[f"{name}_upper"] = upper[:, j]
        return out
