"""Score a fitted model by simulating it against measured trajectories."""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions, validate_params
from sklearn.utils.validation import check_is_fitted

from ..exceptions import SimulationError
from ..measurements import read_record
from ..measurements.differentiation import DIFFERENTIATION_METHODS, Differentiator
from ..measurements.experiments import TIME, TRAJECTORY, split_experiments
from ..measurements.measurement import unwrap
from ..measurements.reconstruct import unmeasured_states
from ..simulation.windows import Horizon, choose_horizon, simulate_rows

__all__ = ["SimulationScorer", "make_simulation_scorer"]


class SimulationScorer:
    """Negative normalised RMSE of the states simulated per experiment.

    Use :func:`make_simulation_scorer` to build one; it is a scikit-learn
    scorer: ``scorer(estimator, X, y=None) -> float``, greater is better.
    """

    def __init__(self, states: Sequence[str] | None = None, differentiation=None,
                 rtol: float = 1e-6, atol: float = 1e-8, max_steps: int = 200_000, *,
                 horizon="auto") -> None:
        self.states = None if states is None else list(states)
        self.differentiation = differentiation
        self.rtol = rtol
        self.atol = atol
        self.max_steps = max_steps
        self.horizon = horizon

    def __repr__(self) -> str:
        return f"make_simulation_scorer(states={self.states!r}, horizon={self.horizon!r})"

    def __call__(self, estimator, X, y=None) -> float:
        """Simulate ``estimator`` on each experiment of ``X``; return ``-NRMSE``.

        ``y`` is ignored (derivatives are not used). A model whose
        simulation diverges on any experiment scores ``-inf``.
        """
        return -self.nrmse(estimator, X)

    def nrmse(self, estimator, X) -> float:
        """Normalised RMSE of the compared states, pooled over experiments.

        Each state's errors are divided by its standard deviation within
        the experiment; the result is the root of their mean square.
        """
        check_is_fitted(estimator, "skeleton_")
        skeleton = estimator.skeleton_
        source = X  # a Measurement keeps the derivatives it has estimated
        given, _, _ = unwrap(X, who="the simulation scorer")
        if not isinstance(given, pd.DataFrame):
            raise TypeError("the simulation scorer needs X as a DataFrame with a 't' column "
                            f"and the measured states, got {type(X).__name__}")
        if TIME not in given.columns:
            raise ValueError("the simulation scorer needs the time column 't' in X")
        present = {str(c) for c in given.columns if not given[c].isna().all()}
        if unmeasured_states(skeleton, present):
            return self._nrmse_unmeasured(estimator, given, present)
        compared = self._compared(skeleton, given)
        spec = self.differentiation
        settings = estimator.get_params()
        if spec is None:
            spec = settings.get("differentiation", "auto")
        record = read_record(skeleton, source, None, differentiation=spec,
                             smooth=bool(settings.get("smooth_states", True)),
                             need_time="the simulation scorer needs the time column 't' in X")
        simulated = self._simulated(estimator, record)
        if simulated is None:  # a simulation diverged, or windows of the horizon escaped
            return float("inf")
        total, count = 0.0, 0
        for experiment in record.experiments:
            rows = experiment.rows
            if len(rows) < 2:
                continue
            for state in compared:
                truth = record.measured[state][rows]
                spread = float(np.std(truth)) or 1.0
                err = (simulated[rows, skeleton.states.index(state)] - truth) / spread
                total += float(err @ err)
                count += len(err)
        if count == 0:
            raise ValueError("no experiment in X has two samples to simulate")
        return float(np.sqrt(total / count))

    def _nrmse_unmeasured(self, estimator, X: pd.DataFrame, present: set[str]) -> float:
        """The score of a record that lacks states: each experiment simulated whole.

        No window can restart from a state no sensor reads: each experiment
        starts from the state :meth:`estimate_initial_state` finds on its
        first samples, and the measured states and outputs are compared.
        """
        skeleton = estimator.skeleton_
        sensed = [o for o in skeleton.outputs if o in present]
        compared = ([s for s in skeleton.states if s in present] + sensed
                    if self.states is None else self._compared(skeleton, X))
        if not compared:
            raise ValueError(f"X holds none of the model's states {skeleton.states}"
                             + (f" nor its outputs {skeleton.outputs}" if skeleton.outputs
                                else ""))
        inputs = [name for name in skeleton.inputs if name != TIME]
        trajectory = X[TRAJECTORY].to_numpy() if TRAJECTORY in X.columns else None
        experiments = split_experiments(len(X), X[TIME].to_numpy(dtype=float), trajectory)
        pairs = []
        for experiment in experiments:
            if experiment.n_samples < 2:
                continue
            part = X.iloc[experiment.rows]
            try:
                y0 = estimator.estimate_initial_state(part)
                simulated = estimator.simulate(
                    experiment.t, y0, inputs={name: part[name].to_numpy(dtype=float)
                                              for name in inputs},
                    rtol=self.rtol, atol=self.atol, max_steps=self.max_steps)
            except SimulationError:
                return float("inf")
            pairs.append((part, simulated))
        return pooled_nrmse(pairs, compared)

    def _simulated(self, estimator, record) -> np.ndarray | None:
        """The model simulated on every row (the diagnosis's loop); None if it diverged."""
        skeleton = estimator.skeleton_
        inputs = [name for name in skeleton.inputs if name != TIME]
        columns = {**{s: record.smoothed[s] for s in skeleton.states},
                   **{name: record.columns[name] for name in inputs},
                   TIME: record.columns[TIME]}
        experiments = [(e.label, e.rows, e.t) for e in record.experiments]
        horizon = Horizon(None, None, "whole experiments")
        if self.horizon is not None:
            system = skeleton.compile(estimator.functions_, estimator.params_)
            horizon = choose_horizon(system, skeleton.states, columns,
                                     [(rows, t) for _, rows, t in experiments], self.horizon)
        simulated, stops, _ = simulate_rows(estimator, columns, record.signals, experiments,
                                            horizon, n_samples=record.n_samples,
                                            max_steps=self.max_steps,
                                            rtol=self.rtol, atol=self.atol,
                                            capture_warnings=False)
        return None if stops else simulated

    def _compared(self, skeleton, X) -> list[str]:
        if self.states is None:
            compared = [s for s in skeleton.states if s in X.columns]
            if not compared:
                raise ValueError(f"X holds none of the model's states {skeleton.states}")
            return compared
        for state in self.states:
            if state not in skeleton.states:
                raise ValueError(f"the scorer compares {state!r}, which is not a state of the "
                                 f"model ({skeleton.states})")
            if state not in X.columns:
                raise ValueError(f"the scorer compares {state!r}, but X has no such column")
        return list(self.states)


@validate_params({
    "states": [list, tuple, None],
    "differentiation": [StrOptions(set(DIFFERENTIATION_METHODS)), dict, Differentiator,
                        HasMethods(["d"]), callable, None],
    "rtol": [Interval(Real, 0, None, closed="neither")],
    "atol": [Interval(Real, 0, None, closed="neither")],
    "max_steps": [Interval(Integral, 1, None, closed="left")],
    "horizon": [StrOptions({"auto"}), Interval(Real, 0, None, closed="neither"), None],
}, prefer_skip_nested_validation=True)
def make_simulation_scorer(states: Sequence[str] | None = None, *, differentiation=None,
                           rtol: float = 1e-6, atol: float = 1e-8,
                           max_steps: int = 200_000, horizon="auto") -> SimulationScorer:
    """A scorer that simulates a fitted model per experiment and compares the states.

    Each experiment of ``X`` (``trajectory`` column) is simulated from its
    own initial state with its own measured inputs; the score is minus the
    normalised RMSE of the states (greater is better), for ``scoring=`` in
    ``GridSearchCV`` and ``cross_validate``.

    Parameters
    ----------
    states : list of str, optional
        States to compare; default every state that is a column of ``X``.
    differentiation : str, dict or callable, optional
        How initial states are estimated (smoothed, and unmeasured
        kinematic states reconstructed); default the estimator's own
        ``differentiation``.
    rtol, atol : float
        Solver tolerances.
    max_steps : int, default=200000
        Solver step budget per experiment; a model that needs more is
        treated as diverged.
    horizon : "auto", float or None, default="auto"
        Simulate windows of this time, each restarted from the measured
        (estimated) state, and pool their errors (see
        :func:`~sklearn_pycc.diagnose`): a whole-record simulation of an
        integrator, a lightly damped or a chaotic system scores every
        candidate alike. ``"auto"`` chooses it per model from its dynamics;
        None simulates whole experiments.

    Returns
    -------
    SimulationScorer
        ``scorer(estimator, X, y=None) -> -NRMSE``; ``-inf`` when a
        simulation diverges.

    Examples
    --------
    >>> from sklearn.model_selection import cross_val_score
    >>> from sklearn_pycc import PolyCCRegressor, datasets
    >>> from sklearn_pycc.model_selection import ExperimentSplit, make_simulation_scorer
    >>> X = datasets.make_experiments(datasets.make_duffing, 3, n_samples=200,
    ...                               t_span=(0, 10))
    >>> model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
    ...                         degree=3, fit_mode="simulation")
    >>> positions = X[["t", "trajectory", "x1", "F_ext"]]
    >>> scores = cross_val_score(model, positions, cv=ExperimentSplit(),
    ...                          scoring=make_simulation_scorer(), error_score="raise")
    >>> bool((scores > -0.1).all())
    True
    """
    return SimulationScorer(states, differentiation, rtol, atol, max_steps, horizon=horizon)


def pooled_nrmse(pairs, compared, spreads=None) -> float:
    """The NRMSE of ``compared`` over experiments ``(measured, simulated)`` frames.

    Each signal's errors are divided by its standard deviation within the
    experiment, or by ``spreads[name]`` where given (missing samples
    skipped); the result is the root of their mean square over every
    experiment, ``inf`` where a simulation is not finite.
    """
    total, count = 0.0, 0
    for part, simulated in pairs:
        for name in compared:
            truth = part[name].to_numpy(dtype=float)
            spread = (spreads[name] if spreads is not None
                      else float(np.nanstd(truth)) or 1.0)
            err = (simulated[name].to_numpy() - truth) / spread
            err = err[np.isfinite(truth)]
            if not np.all(np.isfinite(err)):
                return float("inf")
            total += float(err @ err)
            count += len(err)
    if count == 0:
        raise ValueError("no experiment in X has two samples to simulate")
    return float(np.sqrt(total / count))
