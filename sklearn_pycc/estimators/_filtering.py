"""The states a model fitted by its Kalman filter reads from a record: :class:`FilteringMixin`."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from scipy.stats import norm
from sklearn.utils.validation import check_is_fitted

from ..fitting.filter import kalman_pass, smoothed
from ..fitting.uncertainty.intervals import check_level

__all__ = ["FilteringMixin"]


class FilteringMixin:
    """What a model fitted with ``fit_mode="filter"`` reads from a record.

    A mixin of :class:`~sklearn_pycc.estimators.base.CCRegressor`. The host
    class gives ``_system()`` (the compiled right-hand side) and
    ``_problem_of(X)`` (the fitting problem a record makes, read by a
    clone: the model itself learns nothing).
    """

    def smooth(self, X, *, level: float = 0.95) -> pd.DataFrame:
        """The states given the whole record, measured or not, with bands.

        The fitted skeleton's extended Kalman filter runs through each
        experiment of ``X`` and back (Rauch-Tung-Striebel), under the fitted
        process and measurement noises: each state is estimated from every
        sample, before and after it. A state nobody measured (a velocity
        from a position) is read as well as the record and the model allow.

        Parameters
        ----------
        X : DataFrame
            The record, with ``t`` and the inputs, as in ``fit``.
        level : float, default=0.95
            Probability that a band holds the state.

        Returns
        -------
        DataFrame
            ``t`` and, per state, its estimate and ``<state>_lower``,
            ``<state>_upper``: one row per row of ``X``, in its order.

        Raises
        ------
        ValueError
            When the model was not fitted with ``fit_mode="filter"``.
        """
        check_is_fitted(self, "params_")
        if getattr(self, "fit_mode_", None) != "filter":
            raise ValueError(f"smooth needs a model fitted with fit_mode='filter' (its process "
                             f"noise); this one was fitted with "
                             f"fit_mode={getattr(self, 'fit_mode_', None)!r}")
        z = float(norm.ppf(0.5 + check_level(level) / 2))
        from ..fitting.output_error.shooting import ShootingPlan

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem = self._problem_of(X)
        longest = max(e.n_samples for e in problem.experiments)
        plan = ShootingPlan(problem, max(longest - 1, 2))  # one segment per experiment
        system = self._system()
        plan.choose_substeps(system, dict(problem.data.columns))
        states = list(plan.states)
        run = kalman_pass(plan, system, np.array([[self.process_noise_[s] for s in states]]),
                          np.array([[self.measurement_noise_[s] for s in plan.measured]]),
                          keep=True)
        means, covs = smoothed(run)
        n_rows = len(next(iter(problem.smoothed.values())))  # every row of X
        out = {"t": np.full(n_rows, np.nan)}
        valid = plan.valid
        rows = plan.rows[valid]
        out["t"][rows] = plan.times[valid]
        for j, s in enumerate(states):
            mean = np.full(n_rows, np.nan)
            sd = np.full(n_rows, np.nan)
            mean[rows] = means[0][valid][:, j]
            sd[rows] = np.sqrt(np.maximum(covs[0][valid][:, j, j], 0.0))
            out[s], out[f"{s}_lower"], out[f"{s}_upper"] = mean, mean - z * sd, mean + z * sd
        index = X.index if isinstance(X, pd.DataFrame) and len(X.index) == n_rows else None
        return pd.DataFrame(out, index=index)
