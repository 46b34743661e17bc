"""The states a model fitted by its Kalman filter reads from a record: :class:`FilteringMixin`."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from scipy.stats import norm
from sklearn.utils.validation import check_is_fitted

from ..fitting.filter.kalman import kalman_pass, rk4_step, smoothed
from ..fitting.filter.stage import filter_plan
from ..fitting.uncertainty.intervals import check_level
from ..measurements.columns import TIME

__all__ = ["FilteringMixin"]

#: parameter draws the smoothed states are pooled over, and their seed (the same bands on
#: every call)
PARAMETER_DRAWS = 30
PARAMETER_SEED = 0


class FilteringMixin:
    """What a model fitted with ``fit_mode="filter"`` reads from a record.

    A mixin of :class:`~sklearn_pycc.estimators.base.CCRegressor`. The host
    class gives ``_system()`` (the compiled right-hand side) and
    ``_problem_of(X)`` (the fitting problem a record makes, read by a
    clone: the model itself learns nothing).
    """

    def _filtered(self, X, what: str, draws: list | None = None, *, keep: bool = True):
        """The plan of ``X`` (one segment per experiment) and the filter's pass through it."""
        if not hasattr(self, "params_") and what == "log_likelihood":
            system, plan, q, r = self._given_model(X)
        else:
            check_is_fitted(self, "params_")
            if getattr(self, "fit_mode_", None) != "filter":
                raise ValueError(f"{what} needs a model fitted with fit_mode='filter' (its "
                                 f"process noise); this one was fitted with "
                                 f"fit_mode={getattr(self, 'fit_mode_', None)!r}")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                problem = self._problem_of(X)
            system = self._system()
            plan = filter_plan(problem, system, whole=True)  # one segment per experiment
            q = [self.process_noise_[s] for s in plan.states]
            r = [self.measurement_noise_[s] for s in plan.measured]
        systems = [system, *(draws or [])]
        run = kalman_pass(plan, systems, np.tile(q, (len(systems), 1)),
                          np.tile(r, (len(systems), 1)), keep=keep)
        return plan, run

    def _given_model(self, X):
        """``(system, plan, q, r)`` of an unfitted model whose every number is given.

        Raises
        ------
        NotFittedError
            Naming what is still to be fitted: a parameter, a curve, a
            process or a measurement noise.
        """
        from sklearn.exceptions import NotFittedError

        from ..fitting.filter.stage import noisy_states

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem = self._problem_of(X)
        unknown = [*problem.free_params, *problem.skeleton.functions]
        system = None if unknown else problem.skeleton.compile({}, problem.fixed_params)
        plan = filter_plan(problem, system, whole=True) if system is not None else None
        measured = [s for s in problem.skeleton.states if s in problem.measured]
        layout = noisy_states(problem, measured)
        held = dict(layout.measurement_held)
        states = list(problem.skeleton.states)
        unknown += [*(f"the process noise of {', '.join(states[j] for j in group)}"
                      for group in layout.groups),
                    *(f"the measurement noise of {name}" for j, name in enumerate(measured)
                      if j not in held)]
        if unknown:
            raise NotFittedError(
                f"This {type(self).__name__} instance is not fitted yet, and log_likelihood "
                f"can evaluate an unfitted model only where every number is given: "
                f"{', '.join(unknown)} {'is' if len(unknown) == 1 else 'are'} not (give the "
                f"numbers in the equations, process_noise and measurement_noise, or fit)")
        return system, plan, layout.intensities([]), layout.measurement([])

    def _parameter_draws(self) -> list:
        """Systems of numbers drawn from ``covariance_`` (the same on every call)."""
        cov = getattr(self, "covariance_", None)
        if cov is None or not len(cov):
            return []
        names = list(cov.index)
        rng = np.random.default_rng(PARAMETER_SEED)
        if any(name not in self.params_ for name in names):  # a curve's numbers: its backend's
            drawn = self.backend_.draws(self, PARAMETER_DRAWS, rng) or []
            return [self.skeleton_.compile(functions, params) for functions, params in drawn]
        values, vectors = np.linalg.eigh(cov.to_numpy())
        root = vectors * np.sqrt(np.clip(values, 0.0, None))
        centre = np.array([self.params_[a] for a in names])
        bounds = self.skeleton_.bounds
        low = np.array([bounds.get(a, (-np.inf, np.inf))[0] for a in names])
        high = np.array([bounds.get(a, (-np.inf, np.inf))[1] for a in names])
        draws = np.clip(centre + rng.standard_normal((PARAMETER_DRAWS, len(names))) @ root.T,
                        low, high)
        return [self.skeleton_.compile(self.functions_, {**self.params_, **dict(zip(names, d))})
                for d in draws]

    def smooth(self, X, *, level: float = 0.95) -> pd.DataFrame:
        """The states given the whole record, measured or not, with bands.

        The fitted skeleton's extended Kalman filter runs through each
        experiment of ``X`` and back (Rauch-Tung-Striebel), under the fitted
        process and measurement noises: each state is estimated from every
        sample, before and after it. A state nobody measured (a velocity
        from a position, an upper tank's level) is read as well as the record
        and the model allow. The bands hold the parameters' uncertainty too:
        the states are smoothed under parameters drawn from ``covariance_``,
        all filtered side by side, and pooled.

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
            ``<state>_upper``: one row per row of ``X``, in its order, each
            within the state's hard limits.

        Raises
        ------
        ValueError
            When the model was not fitted with ``fit_mode="filter"``.
        """
        z = float(norm.ppf(0.5 + check_level(level) / 2))
        plan, run = self._filtered(X, "smooth", self._parameter_draws())
        states = list(plan.states)
        means, covs = smoothed(run)
        # pooled over the parameters' draws: the states' spread given each, and theirs
        variances = np.diagonal(covs, axis1=-2, axis2=-1)
        pooled_mean = means.mean(axis=0)
        pooled_var = variances.mean(axis=0) + (means.var(axis=0) if len(means) > 1 else 0.0)
        n_rows = len(plan.columns()[states[0]])  # every row of X
        out = {TIME: plan.columns()[TIME]}
        valid = plan.valid
        rows = plan.rows[valid]
        limits = self._system().limits
        for j, s in enumerate(states):
            mean = np.full(n_rows, np.nan)
            sd = np.full(n_rows, np.nan)
            mean[rows] = pooled_mean[valid][:, j]
            sd[rows] = np.sqrt(np.maximum(pooled_var[valid][:, j], 0.0))
            # a state and its band stay within the state's hard limits (a tank's rim)
            low, high = limits.get(s, (-np.inf, np.inf))
            out[s], out[f"{s}_lower"], out[f"{s}_upper"] = (
                np.clip(v, low, high) for v in (mean, mean - z * sd, mean + z * sd))
        index = X.index if isinstance(X, pd.DataFrame) and len(X.index) == n_rows else None
        return pd.DataFrame(out, index=index)

    def innovations(self, X) -> pd.DataFrame:
        """The filter's one-step prediction errors of each measured state, and their spread.

        The fitted skeleton's extended Kalman filter runs through each
        experiment of ``X``; at each sample the measured states are compared
        with what the filter predicted from the samples before. Where the
        model and its noises are right, these errors divided by their
        predicted standard deviations are white with unit variance, and
        unrelated to the states and inputs
        (:func:`~sklearn_pycc.diagnostics.check_innovations` tests that).

        Parameters
        ----------
        X : DataFrame
            The record, with ``t`` and the inputs, as in ``fit``.

        Returns
        -------
        DataFrame
            ``t``, ``trajectory`` (the experiment, from 0) and, per measured
            state, the error ``<state>`` (measured minus predicted) and its
            predicted standard deviation ``<state>_sd``; one row per sample
            the filter used, in the order of ``X``.

        Raises
        ------
        ValueError
            When the model was not fitted with ``fit_mode="filter"``.
        """
        plan, run = self._filtered(X, "innovations", keep=False)
        used = np.flatnonzero(plan.own.ravel())
        rows = plan.rows.ravel()[used]
        order = np.argsort(rows, kind="stable")
        segment = np.broadcast_to(np.arange(plan.n_segments)[:, None], plan.own.shape)
        out = {TIME: plan.columns()[TIME][rows[order]],
               "trajectory": segment.ravel()[used][order]}
        for j, name in enumerate(plan.measured):
            out[name] = run.innovations[0, order, j]
            out[f"{name}_sd"] = np.sqrt(run.variances[0, order, j])
        frame = pd.DataFrame(out)
        if isinstance(X, pd.DataFrame) and len(X.index) == len(plan.columns()[TIME]):
            frame.index = X.index[rows[order]]
        return frame

    def log_likelihood(self, X) -> float:
        """The log-likelihood of the measured samples of ``X`` under the fitted model and noises.

        The fitted skeleton's extended Kalman filter runs through each
        experiment of ``X``; its one-step predictions give each sample's
        probability. On a record the model was not fitted on, the larger
        the better: it judges candidate skeletons where disturbances make
        their simulations wander. An unfitted model whose every number is
        given (in the equations, ``process_noise`` and ``measurement_noise``)
        is evaluated as it stands, nothing fitted.

        Parameters
        ----------
        X : DataFrame
            The record, with ``t`` and the inputs, as in ``fit``.

        Returns
        -------
        float
            The sum over the measured samples (``-inf`` where the filter
            diverged).

        Raises
        ------
        ValueError
            When the model was not fitted with ``fit_mode="filter"``.
        NotFittedError
            When it is not fitted and some number is not given (each named).
        """
        _, run = self._filtered(X, "log_likelihood", keep=False)
        return -float(run.nll[0])

    def predict_ahead(self, X, *, steps: int = 1) -> pd.DataFrame:
        """Each sample's states predicted ``steps`` samples earlier by the filtered model.

        The fitted skeleton's extended Kalman filter runs through each
        experiment of ``X``; from its estimate at each sample the model is
        integrated ``steps`` samples ahead with the measured inputs. One step
        ahead, the measured states' errors are the filter's innovations,
        white where the model is right; further ahead they show how far the
        model can be trusted to forecast.

        Parameters
        ----------
        X : DataFrame
            The record, with ``t`` and the inputs, as in ``fit``.
        steps : int, default=1
            How many samples ahead.

        Returns
        -------
        DataFrame
            ``t`` and each state: one row per row of ``X``, in its order; NaN
            for the first ``steps`` samples of each experiment (nothing
            predicted them).

        Raises
        ------
        ValueError
            When the model was not fitted with ``fit_mode="filter"``, or
            ``steps`` is not a positive integer.
        """
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
            raise ValueError(f"steps must be a positive integer, got {steps!r}")
        plan, run = self._filtered(X, "predict_ahead")
        system = self._system()
        states = list(plan.states)
        m = plan.substeps
        fine, ends = plan.fine_signals(), plan.fine_signals(left=True)
        signals = [name for name in fine if name in system.slots]
        n_rows = len(plan.columns()[states[0]])  # every row of X
        predicted = np.full((n_rows, len(states)), np.nan)
        for k in range(plan.n_segments):
            starts = np.arange(0, plan.steps[k] + 1 - steps)
            if not len(starts):
                continue
            z = run.means[0, k, starts].copy()
            evaluate = system.batch_rhs(len(starts), signals)

            def rhs(x, column, source, k=k, evaluate=evaluate):
                return evaluate(x, [source[name][k, column] for name in signals])

            with np.errstate(all="ignore"):
                for j in range(steps):
                    i = starts + j
                    h = plan.h[k, i][:, None] / m
                    for sub in range(m):
                        z = rk4_step(rhs, z, h, 2 * (i * m + sub), right=fine, left=ends)
                        if system.limits:
                            system.clip(z)
            predicted[plan.rows[k, starts + steps]] = z
        out = pd.DataFrame(predicted, columns=states)
        out.insert(0, TIME, plan.columns()[TIME])
        if isinstance(X, pd.DataFrame) and len(X.index) == n_rows:
            out.index = X.index
        return out
