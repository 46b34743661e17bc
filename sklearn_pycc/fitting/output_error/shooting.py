"""Output-error fitting by multiple shooting, shared by the backends.

Each experiment is cut into segments of ``window`` samples. Every segment
starts from its own initial state (a free variable) and is integrated by a
fixed-step fourth-order Runge-Kutta scheme, all segments at once as numpy
arrays. The objective compares the simulated states with the measured ones
and joins consecutive segments by continuity; short segments keep a chaotic
or badly started model from running away, while continuity makes the whole
record one trajectory.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping

import numpy as np
from scipy import sparse
from scipy.optimize import least_squares

from ...measurements.columns import TIME
from ...measurements.noise import slow_memory
from ...simulation.windows import Windows
from ...skeleton.system import CompiledSystem, stack_systems
from ..problem import Problem
from .noise_model import whitening_matrix
from .whole_record import state_bounds

__all__ = ["ShootingPlan", "check_iterations", "fit_shooting"]

#: weight of a continuity defect relative to a measurement residual (both scaled)
CONTINUITY_WEIGHT = 10.0
#: the largest rows x columns^2 of a Jacobian handed to the optimiser dense (its SVD)
DENSE_WORK = 5e7
#: most samples (rows x steps) the Jacobian's bumped simulations take in one pass
STACKED_SAMPLES = 1_000_000
#: the search ends where a step lowers the cost by less than this share of what one
#: standard error of a parameter is worth (about ``cost / n_residuals``): closer is noise
COST_RESOLUTION = 0.001


def check_iterations(iterations) -> int:
    """The ``shooting_iterations`` hyperparameter, checked."""
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) \
            or iterations < 1:
        raise ValueError(f"shooting_iterations must be a positive integer, got {iterations!r}")
    return int(iterations)


class ShootingPlan(Windows):
    """Segments of every experiment with their measurements, for multiple shooting.

    Parameters
    ----------
    problem : Problem
        With ``experiments`` (times), ``measured`` and ``smoothed`` states.
    window : int
        Samples per segment (steps between its first and last sample).
    hidden : dict, optional
        Unmeasured state -> a guess of its values on every row of the
        record, where its segments start from (only their starts are fitted
        to, by continuity: no measurement of it enters the residuals).
    """

    def __init__(self, problem: Problem, window: int,
                 hidden: Mapping[str, np.ndarray] | None = None) -> None:
        if isinstance(window, bool) or int(window) != window or window < 2:
            raise ValueError(f"shooting_window must be an integer of at least 2, got {window!r}")
        skeleton = problem.skeleton
        states = list(skeleton.states)
        starts = {**problem.smoothed, **dict(hidden or {})}
        unknown = [s for s in states if s not in starts]
        if unknown:
            raise ValueError(f"fit_mode='simulation' needs every state's values to start from; "
                             f"X has no column {unknown[0]!r}")
        for experiment in problem.experiments:
            if experiment.n_samples < 2:
                raise ValueError(f"fit_mode='simulation' needs at least 2 samples per "
                                 f"experiment; there is 1{experiment.where or ' in the data'}")
        inputs = [name for name in skeleton.inputs if name != TIME]
        signals = {name: problem.signals[name] for name in inputs}
        super().__init__(states, inputs, TIME in skeleton.variables,
                         [(e.rows, e.t) for e in problem.experiments], starts,
                         signals=signals, window=int(window), hold=problem.input_hold)
        self._starts, self._inputs = starts, signals
        self._times = np.zeros(len(next(iter(starts.values()))))
        for e in problem.experiments:
            self._times[e.rows] = e.t
        self.measured = [s for s in self.states if s in problem.measured]
        #: each state's hard limits, where a window may start
        self.limits = state_bounds(skeleton)
        # a segment's last sample is fitted by the next segment's start
        own = self.valid.copy()
        own[np.flatnonzero(self.successor), self.steps[self.successor]] = False
        self.own = own
        self.measured_index = [self.states.index(s) for s in self.measured]
        self.targets = np.stack([problem.measured[s][self.rows] for s in self.measured],
                                axis=-1)
        #: each segment's start variance per state, for the filter (None: the states' spread)
        self.start_variance = None
        #: the starts the user gave (``problem.initial_state``): every experiment's first
        #: segment starts there, and output error holds them (``(K, n_states)``)
        self.held_start = np.zeros(self.initial.shape, dtype=bool)
        first = self.first_segments()
        for state, (mean, _) in getattr(problem, "initial_state", {}).items():
            j = self.states.index(state)
            self.initial[first, j] = mean
            self.held_start[first, j] = True
        #: the filter that whitens the measurement residuals (``problem.whitening``), or None
        self.whitening = None
        taps = getattr(problem, "whitening", None)
        if taps:
            segment = np.broadcast_to(np.arange(self.n_segments)[:, None], own.shape)[own]
            self.whitening = whitening_matrix([taps[s] for s in self.measured],
                                              self.segment_experiment[segment])

    def segments(self, keep: np.ndarray) -> ShootingPlan:
        """A copy holding only the segments ``keep``, their samples and targets.

        The whitening (a filter over the whole record's residuals) is not
        carried over: the copy has none.
        """
        part = super().segments(keep)
        for name in ("own", "targets", "start_variance", "held_start"):
            value = getattr(self, name)
            if value is not None:
                setattr(part, name, value[np.asarray(keep, dtype=int)])
        part.whitening = None
        return part

    def columns(self) -> dict[str, np.ndarray]:
        """Every state (measured, smoothed or guessed), input and ``t`` on every row."""
        return {**self._starts, **self._inputs, TIME: self._times}

    # -- residuals ---------------------------------------------------------------
    def output_errors(self, states: np.ndarray) -> np.ndarray:
        """Scaled differences of the measured states, one row per fitted sample (in time order)."""
        sim = states[:, :, self.measured_index]
        return ((sim - self.targets) / self.scale[self.measured_index])[self.own]

    def residuals(self, states: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Scaled measurement residuals, then weighted continuity defects."""
        meas = self.output_errors(states).ravel()
        if self.whitening is not None:
            meas = self.whitening @ meas
        ends = states[np.arange(self.n_segments), self.steps]
        k = np.flatnonzero(self.successor)
        defects = CONTINUITY_WEIGHT * (ends[k] - start[k + 1]) / self.scale
        return np.concatenate([meas, defects.ravel()])

    def output_nrmse(self, states: np.ndarray) -> float:
        """Normalised RMSE of the measured states along the segments."""
        return float(np.sqrt(np.mean(self.output_errors(states) ** 2)))

    def jacobian(self, sens_theta: list[np.ndarray], sens_start: list[np.ndarray]):
        """Jacobian of :meth:`residuals` from trajectory sensitivities.

        ``sens_theta[i]`` and ``sens_start[q]`` are ``(K, L + 1, n_states)``
        derivatives of the trajectories with respect to parameter ``i`` and
        to the initial value of state ``q`` (of each segment's own start).
        """
        K, n = self.n_segments, len(self.states)
        p = len(sens_theta)
        mi = self.measured_index
        seg_of = np.broadcast_to(np.arange(K)[:, None], self.own.shape)[self.own]
        n_meas = int(self.own.sum())
        rows_meas = np.arange(n_meas * len(mi)).reshape(n_meas, len(mi))
        k_cont = np.flatnonzero(self.successor)
        rows_cont = n_meas * len(mi) + np.arange(len(k_cont) * n).reshape(len(k_cont), n)
        n_rows = n_meas * len(mi) + len(k_cont) * n
        r, c, v = [], [], []
        inv = 1.0 / self.scale
        for i, sens in enumerate(sens_theta):
            block = (sens[:, :, mi] * inv[mi])[self.own]
            r.append(rows_meas.ravel())
            c.append(np.full(rows_meas.size, i))
            v.append(block.ravel())
            ends = sens[k_cont, self.steps[k_cont]] * inv * CONTINUITY_WEIGHT
            r.append(rows_cont.ravel())
            c.append(np.full(rows_cont.size, i))
            v.append(ends.ravel())
        for q, sens in enumerate(sens_start):
            block = (sens[:, :, mi] * inv[mi])[self.own]
            cols = p + seg_of * n + q
            r.append(rows_meas.ravel())
            c.append(np.repeat(cols, len(mi)))
            v.append(block.ravel())
            ends = sens[k_cont, self.steps[k_cont]] * inv * CONTINUITY_WEIGHT
            r.append(rows_cont.ravel())
            c.append(np.repeat(p + k_cont * n + q, n))
            v.append(ends.ravel())
        # the defect's own dependence on the next segment's start
        r.append(rows_cont.ravel())
        c.append((p + (k_cont + 1)[:, None] * n + np.arange(n)).ravel())
        v.append(np.tile(-CONTINUITY_WEIGHT * inv, len(k_cont)))
        shape = (n_rows, p + K * n)
        J = sparse.coo_matrix((np.concatenate(v), (np.concatenate(r), np.concatenate(c))),
                              shape=shape).tocsr()
        if self.whitening is not None:
            J = sparse.vstack([self.whitening @ J[:n_meas * len(mi)], J[n_meas * len(mi):]],
                              format="csr")
        # a dense Jacobian makes each step an SVD (rows x columns^2): only where that is
        # cheap; a long record's block-sparse one is solved by LSMR at linear cost
        return J.toarray() if shape[0] * shape[1] ** 2 <= DENSE_WORK else J


def _side_by_side(plan: ShootingPlan, systems: list, starts: list) -> list | None:
    """Every system simulated from its starts, side by side in blocks of the windows.

    One pass of numpy calls integrates many variants of a system (the
    Jacobian's bumps) at about the cost of one: its cost is in the calls,
    not in the rows. Blocks are kept to :data:`STACKED_SAMPLES` samples a
    pass. None where the systems cannot be stacked (they differ in more
    than their numbers).
    """
    K, L = plan.n_segments, plan.n_steps
    per_pass = max(1, STACKED_SAMPLES // (K * (L + 1)))
    out = []
    for first in range(0, len(systems), per_pass):
        chunk = slice(first, first + per_pass)
        stacked = stack_systems(systems[chunk], K)
        if stacked is None:
            return None
        copies = len(systems[chunk])
        states, _ = plan.simulate(stacked, np.concatenate(starts[chunk]), copies=copies)
        out.extend(states.reshape(copies, K, L + 1, -1))
    return out


def fit_shooting(plan: ShootingPlan, system_for: Callable[[np.ndarray], CompiledSystem],
                 theta0: np.ndarray, max_iterations: int,
                 bounds: tuple[np.ndarray, np.ndarray] | None = None, *,
                 limit_starts: bool = True) -> tuple[np.ndarray, dict]:
    """Minimise the output error over the parameters and the segments' initial states.

    Parameters
    ----------
    plan : ShootingPlan
        Segments and measurements.
    system_for : callable
        Parameter vector -> compiled system.
    theta0 : ndarray
        Starting parameters (the equation-error fit).
    max_iterations : int
        Most Jacobian evaluations.
    bounds : (ndarray, ndarray), optional
        Least and largest value of each parameter (``-inf``/``inf`` open);
        ``theta0`` must lie within them, and so does the result.
    limit_starts : bool, default=True
        Keep the segments' starts within the states' hard limits; without,
        only their first guesses are (each step of the simulation holds the
        states within them, and the solver moves more freely).

    Returns
    -------
    theta : ndarray
        The parameters of the best trajectory found (``theta0`` if nothing
        improved on it).
    info : dict
        ``segments``, ``substeps``, ``iterations``, ``nrmse_before``,
        ``nrmse_after``, ``slow_memory`` (the output errors' wander at the
        record's slowest frequencies, :func:`~sklearn_pycc.measurements.noise.slow_memory`),
        ``max_defect`` (largest continuity jump in units of
        each state's RMS), ``diverged`` (segments that escaped at the end)
        and ``initial_states`` (every state at the start of each experiment,
        ``(n_experiments, n_states)``).
    """
    p, K, n = len(theta0), plan.n_segments, len(plan.states)
    start0 = plan.initial.copy()
    free = ~plan.held_start  # a start the user gave is held
    cache: dict = {}

    def unpack(z):
        start = start0.copy()
        start[free] = z[p:]
        return z[:p], start

    def run(z):
        key = z.tobytes()
        if key not in cache:
            theta, start = unpack(z)
            cache.clear()
            cache[key] = plan.simulate(system_for(theta), start)
        return cache[key]

    def fun(z):
        states, _ = run(z)
        return plan.residuals(states, unpack(z)[1])

    def jac(z):
        theta, start = unpack(z)
        system = system_for(theta)
        # forward differences: each parameter bumped, then each state's starts
        systems, starts, steps = [system], [start], []
        for i in range(p):
            # a share of the parameter itself: the same in any unit of time
            steps.append(1.5e-8 * (abs(theta[i]) or 1.0))
            bumped = theta.copy()
            bumped[i] += steps[-1]
            systems.append(system_for(bumped))
            starts.append(start)
        for q in range(n):
            steps.append(1.5e-8 * np.maximum(np.abs(start[:, q]), plan.scale[q])[:, None, None])
            bumped = start.copy()
            bumped[:, q] += steps[-1][:, 0, 0]
            systems.append(system)
            starts.append(bumped)
        trajectories = _side_by_side(plan, systems, starts)
        if trajectories is None:  # one simulation per bump
            trajectories = [run(z)[0]] + [plan.simulate(s, x0)[0]
                                          for s, x0 in zip(systems[1:], starts[1:])]
        base = trajectories[0]
        sens = [(bumped - base) / step for bumped, step in zip(trajectories[1:], steps)]
        J = plan.jacobian(sens[:p], sens[p:])
        return J if free.all() else J[:, np.r_[np.arange(p), p + np.flatnonzero(free.ravel())]]

    # a window starts within the states' hard limits (a tank holds no more than its rim)
    low_s, high_s = plan.limits
    start0 = np.clip(start0, low_s, high_s)
    if not limit_starts:
        low_s, high_s = np.full(n, -np.inf), np.full(n, np.inf)
    z0 = np.concatenate([np.asarray(theta0, dtype=float), start0[free]])
    if bounds is None:
        bounds = (np.full(p, -np.inf), np.full(p, np.inf))
    z_bounds = (np.concatenate([bounds[0], np.broadcast_to(low_s, (K, n))[free]]),
                np.concatenate([bounds[1], np.broadcast_to(high_s, (K, n))[free]]))
    before_states, _ = run(z0)
    before = plan.output_nrmse(before_states)
    residuals0 = plan.residuals(before_states, start0)
    cost0 = 0.5 * float(np.sum(residuals0**2))
    # a relative fall in the cost below 1/n of it moves the parameters by less than one
    # standard error, so the search stops once a step gains a small share of that
    ftol = max(COST_RESOLUTION / max(residuals0.size, 1), 1e-10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        solution = least_squares(fun, z0, jac=jac, method="trf", x_scale="jac",
                                 bounds=z_bounds, max_nfev=int(max_iterations), ftol=ftol,
                                 xtol=1e-10, gtol=1e-10)
    z = solution.x if solution.cost <= cost0 else z0
    if bounds is not None:
        z = np.clip(z, *z_bounds)
    states, escaped = run(z)
    theta, start = unpack(z)
    ends = states[np.arange(K), plan.steps]
    k = np.flatnonzero(plan.successor)
    defect = float(np.max(np.abs(ends[k] - start[k + 1]) / plan.scale)) if k.size else 0.0
    firsts = [int(np.flatnonzero(plan.segment_experiment == e)[0])
              for e in range(int(plan.segment_experiment.max()) + 1)]
    info = {
        "segments": K,
        "window": plan.window,
        "substeps": plan.substeps,
        "iterations": int(solution.nfev),
        "nrmse_before": before,
        "nrmse_after": plan.output_nrmse(states),
        "slow_memory": slow_memory(plan.output_errors(states)),
        "max_defect": defect,
        "diverged": int(escaped.sum()),
        # a start beyond a fitted limit simulates as one at it
        "initial_states": system_for(theta).clip(start[firsts].copy()),
    }
    return theta, info
