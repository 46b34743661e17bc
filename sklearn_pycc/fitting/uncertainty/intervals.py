"""How sure a fitted model is: standard errors, intervals, curve and simulation bands.

:class:`IntervalsMixin` gives every estimator the same questions to ask.
They are answered from refits on resamples when the fit made them
(``n_bootstrap``: the ``bootstrap_`` members), else by the fitted
``covariance_`` of the parameters and the backend's
:meth:`~.backend.Backend.curve_sd` (the standard deviation of a curve at
given points) and :meth:`~.backend.Backend.draws` (models drawn from the
estimate's distribution). A fit with neither says so when asked, rather
than return numbers that mean nothing.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import numpy as np
import pandas as pd
from scipy.stats import norm
from scipy.stats import t as student
from sklearn.utils.validation import check_is_fitted

from ..._utils.randomness import seeds
from ...exceptions import SimulationError
from .covariance import DeferredCovariance

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


def _quantile(level: float, members: int | None = None) -> float:
    """The quantile of a two-sided interval of ``level``.

    Normal for a covariance; Student's with ``members - 1`` degrees of
    freedom for a standard deviation read from ``members`` refits, so that a
    handful of refits does not pass for a precise estimate of the spread.
    """
    if members is None:
        return float(norm.ppf(0.5 + 0.5 * level))
    return float(student.ppf(0.5 + 0.5 * level, members - 1))


class IntervalsMixin:
    """Uncertainty of a fitted characteristic-curve model (its backend in ``backend_``)."""

    @property
    def covariance_(self) -> pd.DataFrame:
        """Covariance of the fitted parameters (and curve coefficients) by name.

        Only after a fit that estimated one (equation error, no
        ``n_bootstrap``; or output error with unmeasured states, linearised
        at the whole-record fit, where the measurements see every
        direction, kept beside the refits when there are some); its
        expensive part, the long-run covariance of the per-sample scores,
        is worked out when it is first read.
        """
        try:
            value = self.__dict__["_covariance"]
        except KeyError:
            raise AttributeError(f"{type(self).__name__} has no covariance_") from None
        if isinstance(value, DeferredCovariance):
            value = self.__dict__["_covariance"] = value.resolve()
        return value

    @covariance_.setter
    def covariance_(self, value) -> None:
        self.__dict__["_covariance"] = value

    def _no_uncertainty(self, what: str) -> ValueError:
        if getattr(self, "fit_mode_", None) == "filter":
            # the filter refuses refits on resamples: its uncertainty is the likelihood's
            hint = ("the curvature of the filter's likelihood was not positive definite (a "
                    "noise at the end of its range, a parameter the record does not fix); "
                    "hold that noise with process_noise, or fit by output error with "
                    "n_bootstrap=100")
        elif "n_bootstrap" in self.get_params(deep=False):
            hint = "fit it with n_bootstrap=100 (refits on resamples)"
        else:
            hint = ("use a backend that takes n_bootstrap, or PolyCCRegressor fitted by "
                    "equation error (the covariance of its least-squares estimate)")
        return ValueError(f"{type(self).__name__} has no estimate of how uncertain its {what} "
                          f"are: {hint}")

    def _members(self) -> list | None:
        """The refits on resamples, when the fit made them."""
        return getattr(self, "bootstrap_", None) or None

    # -- parameters ------------------------------------------------------------------
    @property
    def params_std_(self) -> dict[str, float]:
        """Standard error of each fitted parameter ``{"a1": 0.002, ...}``.

        The spread of the refits on resamples when the fit made them
        (``n_bootstrap``), else from the fitted ``covariance_``; 0 for a
        parameter the gauge pinned, NaN when there is neither. Both account
        for residuals correlated in time (blocks of samples; Newey-West), so
        they hold for coloured noise and smoothed derivatives.
        """
        check_is_fitted(self, "params_")
        members = self._members()
        if members is not None:
            table = self.bootstrap_params_
            return {name: float(table[name].std(ddof=1)) if name in table else 0.0
                    for name in self.params_}
        cov = getattr(self, "covariance_", None)
        out = {}
        for name in self.params_:
            if cov is None:
                out[name] = math.nan
            elif name in cov.index:
                out[name] = math.sqrt(max(float(cov.loc[name, name]), 0.0))
            else:  # pinned by the gauge: known exactly
                out[name] = 0.0
        if cov is None and out:  # NaN, said with what would give an estimate
            warnings.warn(f"params_std_ is NaN: {self._no_uncertainty('parameters')}",
                          UserWarning, stacklevel=2)
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
        members = self._members()
        z = _quantile(check_level(level), None if members is None else len(members))
        with warnings.catch_warnings():  # a missing estimate is refused below, in words
            warnings.simplefilter("ignore", UserWarning)
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
        members = self._members()
        if members is not None:
            with np.errstate(all="ignore"):
                stack = np.stack([np.broadcast_to(np.asarray(m.functions[name](x), dtype=float),
                                                  x.shape) for m in members])
            sd = np.nanstd(stack, axis=0, ddof=1)
            if not self.backend_.bands_beyond_data:
                lo, hi = self.curve_ranges_[name]
                sd = np.where((x < lo) | (x > hi), np.nan, sd)
            z = _quantile(level, len(members))
        else:
            sd = self.backend_.curve_sd(self, name, x)
            z = _quantile(level)
        if sd is None:
            raise self._no_uncertainty("curves")
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
        rng = np.random.default_rng(next(seeds(random_state)))
        members = self._members()
        if members is not None:  # the refits themselves
            picked = (range(len(members)) if n_draws >= len(members)
                      else np.sort(rng.choice(len(members), int(n_draws), replace=False)))
            draws = [(members[k].functions, {**self.params_, **members[k].params})
                     for k in picked]
        else:
            draws = self.backend_.draws(self, int(n_draws), rng)
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
