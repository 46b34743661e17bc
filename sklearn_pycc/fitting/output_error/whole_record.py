"""Every experiment simulated whole from its initial state, and what that needs.

:class:`WholeRecord` compares such simulations with the measured record (the
output error of a single-shooting fit, the course of hidden states);
:func:`equilibrium` rests hidden states at a sample; :func:`state_bounds`
reads the states' hard limits a simulation holds them within.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from ...simulation.windows import Windows
from ...skeleton.curves import ZeroCurve
from ..problem import Problem

__all__ = ["ESCAPED", "WholeRecord", "check_initial_stretch", "equilibrium", "sensor_readings",
           "state_bounds", "within_limits", "zero_curves"]


def state_bounds(skeleton) -> tuple[np.ndarray, np.ndarray]:
    """Each state's hard limits (``-inf``/``inf`` where it has none), in state order.

    An end still to fit (``x1 <= a5``) is open here: the simulation holds
    the state within the fitted value.
    """
    limits = skeleton.limits

    def number(end, open_end: float) -> float:
        return open_end if isinstance(end, str) else float(end)

    low = np.array([number(limits.get(s, (-np.inf, np.inf))[0], -np.inf)
                    for s in skeleton.states])
    high = np.array([number(limits.get(s, (-np.inf, np.inf))[1], np.inf)
                     for s in skeleton.states])
    return low, high


def equilibrium(system, hidden: Sequence[str], values: Mapping[str, float]) -> dict:
    """Hidden states at rest with the others at ``values`` (least squares; zeros if it fails).

    ``values`` gives every measured state, input and ``t`` at one instant.
    """
    states = list(system.states)
    index = [states.index(s) for s in hidden]

    def rates(z: np.ndarray) -> np.ndarray:
        point = {name: np.array([float(v)]) for name, v in values.items()}
        point.update({s: np.array([float(v)]) for s, v in zip(hidden, z)})
        with np.errstate(all="ignore"):
            out = np.asarray(system.evaluate(point, 1), dtype=float)[0, index]
        return np.where(np.isfinite(out), out, 1e6)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            # the rates over how fast they change with the states: a number of states, the
            # same whatever the unit of time (a rate per second is 3600 times one per hour,
            # and the solver's tolerances are absolute)
            z0 = np.ones(len(hidden))
            r0 = rates(z0)
            slopes = [np.abs(rates(z0 + 1e-6 * np.eye(len(hidden))[j]) - r0) / 1e-6
                      for j in range(len(hidden))]
            scale = float(np.max(slopes)) if len(hidden) else 1.0
            scale = scale if np.isfinite(scale) and 0 < scale < 1e6 else 1.0
            solution = least_squares(lambda z: rates(z) / scale, z0, max_nfev=200)
            z = solution.x
            if np.all(np.isfinite(z)) and np.all(np.abs(rates(z)) / scale
                                                 < 1e-6 * (1 + np.abs(z))):
                return dict(zip(hidden, z.tolist()))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            pass
    return dict.fromkeys(hidden, 0.0)


#: the scaled error of a sample where the simulation has escaped
ESCAPED = 1e3


class WholeRecord:
    """Every experiment simulated whole from its initial state, against what was measured.

    The measured states, and the static outputs (a sensor's reading)
    computed from the simulated states, are compared with the record.
    """

    def __init__(self, problem: Problem) -> None:
        skeleton = problem.skeleton
        self.problem = problem
        self.states = list(skeleton.states)
        self.inputs = [name for name in skeleton.inputs if name != "t"]
        measured = [s for s in self.states if s in problem.measured]
        self.index = [self.states.index(s) for s in measured]
        self.outputs = list(problem.observed)
        n = len(next(iter({**problem.measured, **problem.observed}.values())))
        self.windows = Windows(self.states, self.inputs, "t" in skeleton.variables,
                               [(e.rows, e.t) for e in problem.experiments],
                               {s: np.zeros(n) for s in self.states},
                               signals={name: problem.signals[name] for name in self.inputs},
                               window=max(e.n_samples for e in problem.experiments),
                               merge_tail=False,
                               hold=problem.input_hold)
        read = [problem.measured[s] for s in measured] + [problem.observed[o]
                                                         for o in self.outputs]
        rows = self.windows.rows
        self.targets = np.stack([values[rows] for values in read], axis=-1)
        self.scale = np.array([np.sqrt(np.mean(values ** 2)) or 1.0 for values in read])
        times = np.zeros(n)
        for experiment in problem.experiments:
            times[experiment.rows] = experiment.t
        self.n_rows, self.times = n, times
        self.drive = {name: problem.signals[name][rows] for name in self.inputs}
        self.drive["t"] = times[rows]
        #: state index -> the start the user gave it (``problem.initial_state``): every
        #: experiment starts there, and no fit moves it
        self.held = {self.states.index(state): mean
                     for state, (mean, _) in getattr(problem, "initial_state", {}).items()}

    def given(self, first: np.ndarray) -> np.ndarray:
        """``first`` (each experiment's initial state) with the starts the user gave (a copy)."""
        first = np.array(first, dtype=float)
        for q, mean in self.held.items():
            first[..., q] = mean
        return first

    def free(self, first_shape: tuple[int, int]) -> np.ndarray:
        """Which entries of each experiment's initial state a fit moves (not given)."""
        free = np.ones(first_shape, dtype=bool)
        free[:, list(self.held)] = False
        return free

    def packed(self, values, first: np.ndarray) -> np.ndarray:
        """The unknowns of :meth:`unknowns`: ``values`` (the free parameters), the free starts."""
        first = np.asarray(first, dtype=float)
        return np.r_[np.asarray(values, dtype=float), first[self.free(first.shape)]]

    def first_of(self, tail: np.ndarray, first_shape: tuple[int, int]) -> np.ndarray:
        """Each experiment's initial state from the unknowns' free starts ``tail``."""
        first = self.given(np.zeros(first_shape))
        first[self.free(first_shape)] = tail
        return first

    def errors(self, system, first: np.ndarray, skip: float = 0.0) -> np.ndarray:
        """Scaled errors of what was measured on every row (large where the model escapes).

        ``skip`` leaves out that share of each experiment's first rows. A
        start the user gave stands for ``first``'s.
        """
        first = within_limits(system, self.given(first))
        with np.errstate(all="ignore"):
            simulated, _ = self.windows.simulate(system, first)
            compared = simulated[:, :, self.index]
            if self.outputs:
                compared = np.concatenate([compared, self.outputs_of(system, simulated)],
                                          axis=-1)
        valid = self.windows.valid
        if skip:
            steps = np.arange(valid.shape[1])
            valid = valid & (steps >= skip * valid.sum(axis=1, keepdims=True))
        error = ((compared - self.targets) / self.scale)[valid]
        return np.where(np.isfinite(error), error, ESCAPED).ravel()

    def course(self, system, first: np.ndarray) -> dict[str, np.ndarray]:
        """Every state simulated from ``first``, the inputs and ``t``, on the record's rows.

        A row no experiment simulates is NaN.
        """
        first = within_limits(system, self.given(first))
        with np.errstate(all="ignore"):
            simulated, _ = self.windows.simulate(system, first)
        windows = self.windows
        out = {name: np.asarray(self.problem.signals[name], dtype=float)
               for name in self.inputs}
        out["t"] = self.times
        for q, name in enumerate(self.states):
            values = np.full(self.n_rows, np.nan)
            for k in range(windows.n_segments):
                valid = windows.valid[k]
                values[windows.rows[k, valid]] = simulated[k, valid, q]
            out[name] = values
        return out

    def unknowns(self, first_shape: tuple[int, int]):
        """``(names, residuals, low, high)`` of a fit of the free parameters and initial states.

        ``residuals(z)`` are the scaled errors (:meth:`errors`) with ``z``
        the free parameters then each experiment's initial state but the
        starts the user gave (:meth:`packed`); ``low`` and ``high`` bound
        ``z`` (an experiment starts within the states' hard limits).
        """
        problem = self.problem
        names = list(problem.free_params)
        p = len(names)
        functions = zero_curves(problem)

        def residuals(z: np.ndarray) -> np.ndarray:
            values = {**problem.fixed_params, **dict(zip(names, z[:p]))}
            return self.errors(problem.skeleton.compile(functions, values),
                               self.first_of(z[p:], first_shape))

        bounds = problem.bounds
        low_s, high_s = state_bounds(problem.skeleton)
        free = self.free(first_shape)
        low = np.r_[[bounds.get(a, (-np.inf, np.inf))[0] for a in names],
                    np.broadcast_to(low_s, first_shape)[free]]
        high = np.r_[[bounds.get(a, (-np.inf, np.inf))[1] for a in names],
                     np.broadcast_to(high_s, first_shape)[free]]
        return names, residuals, low, high

    def outputs_of(self, system, simulated: np.ndarray) -> np.ndarray:
        """The static outputs along simulated states ``(K, L + 1, n_states)``."""
        shape = simulated.shape[:2]
        data = {s: simulated[:, :, q].ravel() for q, s in enumerate(self.states)}
        data.update({name: values.ravel() for name, values in self.drive.items()})
        return sensor_readings(system, data, self.outputs).reshape(*shape, len(self.outputs))


    def first_states(self, system) -> np.ndarray:
        """Each experiment's first sample, the hidden states at rest with it."""
        problem = self.problem
        first = np.empty((len(problem.experiments), len(self.states)))
        for e, experiment in enumerate(problem.experiments):
            row = int(experiment.rows[0])
            point = {s: problem.smoothed[s][row] for s in self.states if s in problem.smoothed}
            point.update({name: problem.signals[name][row] for name in self.inputs})
            point["t"] = float(experiment.t[0])
            given = {self.states[q]: mean for q, mean in self.held.items()}
            point.update(given)
            point.update(equilibrium(system, [s for s in problem.hidden if s not in given],
                                     point))
            first[e] = [point[s] for s in self.states]
        return within_limits(system, np.clip(first, *state_bounds(problem.skeleton)))

    def choose_substeps(self, system, first: np.ndarray) -> None:
        """RK4 substeps for ``system`` near the experiments' first states."""
        columns = {s: np.full(1, first[0, q]) for q, s in enumerate(self.states)}
        row = int(self.problem.experiments[0].rows[0])
        columns.update({name: self.problem.signals[name][row:row + 1] for name in self.inputs})
        columns["t"] = np.array([float(self.problem.experiments[0].t[0])])
        self.windows.choose_substeps(system, columns)


def within_limits(system, states: np.ndarray) -> np.ndarray:
    """States ``(..., n_states)`` moved onto the limits of ``system`` they lie beyond (a copy).

    Every simulation starts within the limits the model holds its states in,
    an end to fit at its value in ``system``.
    """
    return system.clip(np.array(states, dtype=float))


def check_initial_stretch(t: np.ndarray, drive: Mapping[str, np.ndarray],
                          unknown: Sequence[str]) -> None:
    """Refuse a stretch of record an initial state cannot be estimated on, saying why.

    The record's first row holds its first time: the times must increase.
    The states ``unknown`` (not in the record) are fitted by simulating the
    model over the stretch, which needs two rows or more, finite times and
    finite inputs ``drive``.

    Raises
    ------
    ValueError
        Naming the row, the column and the problem.
    """
    which = f"{', '.join(unknown)} (not in X)"
    if unknown and len(t) < 2:
        raise ValueError(f"X has a single row: {which} can only be estimated by simulating "
                         "the model over two rows or more against the states X holds; give "
                         "more rows of the record")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size and (unknown or bad[0] == 0):
        raise ValueError(f"X's time column 't' is NaN or infinite at row {bad[0]}: drop or "
                         "fill that row")
    steps = np.diff(t)
    if steps.size and np.all(steps < 0):
        raise ValueError(f"X's times run backwards (t falls from {t[0]:.6g} to {t[-1]:.6g}): "
                         "the state is estimated at the record's first time, and a record is "
                         "simulated forward; sort it by 't'")
    bad = np.flatnonzero(~(steps > 0))
    if bad.size and unknown:
        k = int(bad[0]) + 1
        raise ValueError(f"X's times do not increase at row {k} (t = {t[k - 1]:.6g}, then "
                         f"{t[k]:.6g}): sort the record by 't' and drop repeated times")
    for name, values in drive.items() if unknown else ():
        bad = np.flatnonzero(~np.isfinite(np.asarray(values, dtype=float)))
        if bad.size:
            raise ValueError(f"X's input {name!r} is NaN or infinite at row {bad[0]} (t = "
                             f"{t[bad[0]]:.6g}): {which} is estimated by simulating the model "
                             "through the rows; fill or drop that row")


def sensor_readings(system, data: Mapping[str, np.ndarray], outputs: Sequence[str]) -> np.ndarray:
    """The static outputs ``outputs`` on columns of every state, input and ``t``.

    Returns an array ``(n, len(outputs))`` (a static equation reads no
    derivative: the skeleton refuses one that does).
    """
    values = system.evaluate_outputs(data, len(data["t"]))
    return values[:, [list(system.outputs).index(o) for o in outputs]]


def zero_curves(problem: Problem) -> dict:
    """A zero curve for each curve the problem leaves out (``problem.zeroed``)."""
    return {name: ZeroCurve() for name in problem.zeroed}
