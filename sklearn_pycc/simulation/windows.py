"""Stretches of a record simulated side by side, each from its own starting state.

A record is cut into windows of a few samples; every window starts from the
state measured (or estimated) at its first sample and is integrated by a
fixed-step fourth-order Runge-Kutta scheme, all windows at once as numpy
arrays. The output-error fit (multiple shooting) and the horizon-limited
comparison of a model with measurements are built on it: a long record
simulated this way costs a few hundred vectorised steps, not a Python call
per step.
"""

from __future__ import annotations

import contextlib
import copy
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from numbers import Real

import numpy as np

from ..exceptions import SimulationError
from .float_steps import float_integrator
from .integration import Diverged, InputSignals, fitted_hold

__all__ = ["Divergence", "Horizon", "Windows", "choose_horizon", "jacobian_eigenvalues",
           "simulate_rows", "simulate_windows"]

#: the fourth-order Runge-Kutta scheme is stable for h * |lambda| below about 2.8
RK4_STABLE = 2.5
#: largest ``h * omega`` per substep for an oscillation (RK4's damping then stays below
#: 1e-6 per substep, and its phase error below 1e-5)
RK4_PHASE = 0.25
MAX_SUBSTEPS = 64
#: samples of the data whose Jacobian's eigenvalues are looked at
EIGEN_SAMPLES = 500
#: a window whose state leaves this many state ranges is stopped (diverged)
ESCAPE = 1e3
#: the time column's name
TIME = "t"
#: periods of the model's oscillation a window of ``horizon="auto"`` spans
HORIZON_PERIODS = 2.0
#: time constants of the model's dominant decay a window spans, when it does not oscillate
HORIZON_TIME_CONSTANTS = 3.0
#: fewest samples in a window of ``horizon="auto"``
MIN_HORIZON_SAMPLES = 10


def jacobian_eigenvalues(system, data: Mapping[str, np.ndarray], states: Sequence[str],
                         scale: np.ndarray) -> np.ndarray:
    """Eigenvalues of the right-hand side's Jacobian at up to 500 samples of the data.

    Returns
    -------
    ndarray of complex, shape (n_points, n_states)
        Finite differences, each state bumped by a millionth of its ``scale``;
        of the equations' rates, without a state limit's hold (whose jump
        would read as an infinitely fast mode where a state sits on its limit).
    """
    n = len(next(iter(v for v in data.values() if np.ndim(v))))
    rows = np.unique(np.linspace(0, n - 1, min(n, EIGEN_SAMPLES)).astype(int))
    sample = {name: np.asarray(values)[rows] if np.ndim(values) else values
              for name, values in data.items()}
    m = len(rows)
    base = system.evaluate(sample, m, hold=False)
    jacobian = np.empty((m, len(states), len(states)))
    for q, state in enumerate(states):
        delta = 1e-6 * scale[q]
        bumped = dict(sample)
        bumped[state] = sample[state] + delta
        jacobian[:, :, q] = (system.evaluate(bumped, m, hold=False) - base) / delta
    jacobian = np.nan_to_num(jacobian, nan=0.0, posinf=0.0, neginf=0.0)
    return np.linalg.eigvals(jacobian)


class Windows:
    """Windows of every experiment, laid out as arrays for batched integration.

    Parameters
    ----------
    states : list of str
        The system's states, in equation order.
    inputs : list of str
        Its inputs (without ``t``).
    uses_time : bool
        Whether the right-hand side reads ``t``.
    experiments : sequence of (rows, t)
        Row positions of each experiment in the columns, and its times.
    starts : dict
        State -> values on every row (each window starts from its first row's).
    signals : dict
        Input -> values on every row (read between samples as band-limited).
    window : int
        Steps per window (samples between its first and last).
    merge_tail : bool, default=True
        A last window shorter than half of ``window`` joins the one before it.
    hold : {"bandlimited", "foh", "zoh"}, default="bandlimited"
        How the inputs are read between samples (see ``simulate``'s
        ``input_hold``).
    """

    def __init__(self, states: Sequence[str], inputs: Sequence[str], uses_time: bool,
                 experiments: Sequence[tuple[np.ndarray, np.ndarray]],
                 starts: Mapping[str, np.ndarray], *, signals: Mapping[str, np.ndarray],
                 window: int, merge_tail: bool = True, hold: str = "bandlimited") -> None:
        self.states = list(states)
        self.hold = hold
        self.inputs = list(inputs)
        self.uses_time = uses_time
        self.window = window
        pieces = []  # (experiment, first, last) positions within the experiment
        for e, (rows, _) in enumerate(experiments):
            n = len(rows)
            firsts = list(range(0, max(n - 1, 1), window))
            if merge_tail and len(firsts) > 1 and n - 1 - firsts[-1] < window // 2:
                firsts.pop()
            for k, first in enumerate(firsts):
                last = firsts[k + 1] if k + 1 < len(firsts) else n - 1
                pieces.append((e, first, last))
        K = len(pieces)
        L = max([last - first for _, first, last in pieces] + [0])
        self.n_segments, self.n_steps = K, L
        self.steps = np.array([last - first for _, first, last in pieces], dtype=int)
        rows = np.zeros((K, L + 1), dtype=int)
        times = np.zeros((K, L + 1))
        valid = np.zeros((K, L + 1), dtype=bool)
        for k, (e, first, last) in enumerate(pieces):
            experiment_rows, t = experiments[e]
            span = slice(first, last + 1)
            m = last - first + 1
            rows[k, :m] = experiment_rows[span]
            rows[k, m:] = experiment_rows[last]
            times[k, :m] = t[span]
            times[k, m:] = t[last]
            valid[k, :m] = True
        self.rows, self.times, self.valid = rows, times, valid
        self.h = np.diff(times, axis=1)  # zero on padding: the state stays put
        #: whether the next window continues the same experiment
        self.successor = np.array([k + 1 < K and pieces[k + 1][0] == pieces[k][0]
                                   for k in range(K)], dtype=bool)
        self.segment_experiment = np.array([e for e, _, _ in pieces], dtype=int)
        values = np.column_stack([np.asarray(starts[s], dtype=float) for s in self.states])
        self.scale = np.sqrt(np.mean(values**2, axis=0))
        self.scale[~(self.scale > 0)] = 1.0
        self.bound = ESCAPE * np.maximum(np.abs(values).max(axis=0), self.scale)
        self.initial = values[rows[:, 0]]
        self._experiments = list(experiments)
        self._signals = {name: np.asarray(signals[name], dtype=float) for name in self.inputs}
        self._fine: dict[str, dict[str, np.ndarray]] = {}
        #: the fine signals of a window as lists of floats, for the float path
        self._floats: dict[tuple, list] = {}
        self.substeps = 1

    #: the attributes that hold one entry per segment
    PER_SEGMENT = ("rows", "times", "valid", "h", "steps", "successor", "segment_experiment",
                   "initial")

    def first_segments(self) -> np.ndarray:
        """The segments that start an experiment (each experiment's first)."""
        return np.flatnonzero(np.r_[True, ~self.successor[:-1]])

    def segments(self, keep: np.ndarray):
        """A copy holding only the segments ``keep`` (indices, in order).

        Each kept segment keeps its samples, its start and its inputs (read
        again from the whole experiment); the segment that followed it in
        the record no longer does (``successor`` still says whether one did).
        """
        keep = np.asarray(keep, dtype=int)
        part = copy.copy(self)
        for name in self.PER_SEGMENT:
            setattr(part, name, getattr(self, name)[keep])
        part.n_segments = len(keep)
        part._fine, part._floats = {}, {}
        return part

    @property
    def substeps(self) -> int:
        """Runge-Kutta steps per sample interval."""
        return self._substeps

    @substeps.setter
    def substeps(self, value: int) -> None:
        if int(value) != getattr(self, "_substeps", None):
            self._fine, self._floats = {}, {}  # the stage times move with the substeps
        self._substeps = int(value)

    # -- integration ---------------------------------------------------------
    def choose_substeps(self, system, data: Mapping[str, np.ndarray], *,
                        largest_rate_step: float | None = None) -> int:
        """Substeps per sample interval for RK4 to be stable and to follow oscillations.

        The Jacobian's eigenvalues along ``data`` decide: a real rate
        ``lambda`` needs ``h |lambda|`` below the stability limit, an
        oscillation of angular frequency ``omega`` needs ``h omega`` below
        ``RK4_PHASE`` (RK4's own damping would otherwise bias a light
        damping, and its phase error a frequency). ``largest_rate_step``,
        where given, bounds ``h |lambda|`` per substep for accuracy too, at
        the fastest rate of a typical sample (the median's: a tank's outflow
        whose rate grows without bound as it empties is not followed so
        finely everywhere).
        """
        eigenvalues = jacobian_eigenvalues(system, data, self.states, self.scale)
        h = float(self.h.max()) if self.h.size else 1.0
        rates = np.abs(eigenvalues)
        need = max(1.5 * h * float(rates.max()) / RK4_STABLE,
                   h * float(np.abs(eigenvalues.imag).max()) / RK4_PHASE,
                   h * float(np.median(rates.max(axis=1))) / largest_rate_step
                   if largest_rate_step else 0.0)
        self.substeps = int(np.clip(np.ceil(need), 1, MAX_SUBSTEPS))
        return self.substeps

    def fine_signals(self, left: bool = False) -> dict[str, np.ndarray]:
        """Inputs (and ``t``) at every Runge-Kutta stage time, ``(K, 2 L m + 1)``.

        With ``left``, each input's limit from the left: the value a stage
        at the end of a sample interval reads (a held input steps only
        after it). The same values unless ``hold="zoh"``.
        """
        key = "left" if left and self.hold == "zoh" else "right"
        if key in self._fine:
            return self._fine[key]
        m, L = self.substeps, self.n_steps
        frac = np.arange(2 * m) / (2 * m)
        fine_t = (self.times[:, :-1, None] + self.h[:, :, None] * frac).reshape(
            self.n_segments, 2 * m * L)
        fine_t = np.concatenate([fine_t, self.times[:, -1:]], axis=1)
        # a hair before each stage time: the held value of the interval it ends
        lag = 1e-9 * max(float(self.h.max()), 1e-300) if key == "left" else 0.0
        fine = {TIME: fine_t} if self.uses_time else {}
        for name, values in self._signals.items():
            out = np.empty_like(fine_t)
            for e, (rows, t) in enumerate(self._experiments):
                mine = self.segment_experiment == e
                # read between samples as simulate reads them
                held = InputSignals([name], {name: values[rows]}, t, self.hold)
                out[mine] = held.on(np.maximum(fine_t[mine] - lag, t[0]))[0]
            fine[name] = out
        self._fine[key] = fine
        return fine

    def simulate(self, system, start: np.ndarray,
                 copies: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Integrate every window from ``start`` ``(K, n_states)``.

        With ``copies``, ``start`` holds that many blocks of the K windows'
        starts, and ``system`` as many variants stacked block by block
        (:func:`~sklearn_pycc.skeleton.system.stack_systems`): every block is
        integrated over the same windows, all in one pass, and
        :attr:`escape_step` is left as it was.

        Returns
        -------
        states : ndarray of shape (copies * K, L + 1, n_states)
        escaped : ndarray of bool, shape (copies * K,)
            Windows stopped because they diverged (they stay where they were;
            :attr:`escape_step` holds the first step they left the range at).
        """
        fine, ends = self.fine_signals(), self.fine_signals(left=True)
        K, L = self.n_segments, self.n_steps
        if copies == 1 and K <= FEW_WINDOWS and all(name in fine for name in system.inputs):
            out = np.empty((K, L + 1, len(self.states)))
            escaped, self.escape_step = np.zeros(K, dtype=bool), np.full(K, L + 1)
            for k in range(K):
                out[k], escaped[k], self.escape_step[k] = self._simulate_one(
                    system, start[k], k, fine, ends)
            return out, escaped
        out, escaped, escape_step = self._simulate_side_by_side(system, start, copies, fine,
                                                                ends)
        if copies == 1:
            self.escape_step = escape_step
        return out, escaped

    def _simulate_side_by_side(self, system, start: np.ndarray, copies: int,
                               fine: Mapping[str, np.ndarray], ends: Mapping[str, np.ndarray]
                               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`simulate` on arrays of every window (of every copy): states, escapes, steps."""
        L, m = self.n_steps, self.substeps
        K = copies * self.n_segments
        out = np.empty((K, L + 1, len(self.states)))
        x = np.array(start, dtype=float)
        out[:, 0] = x
        escaped = np.zeros(K, dtype=bool)
        escape_step = np.full(K, L + 1)
        signals = [name for name in fine if name in system.slots]
        # (stage, copies * K): contiguous rows, every copy reading the same input at a stage
        columns = [np.tile(fine[name].T, (1, copies)) for name in signals]
        # the later stages of a step read a held input's value before it steps
        lefts = columns if ends is fine else [np.tile(ends[name].T, (1, copies))
                                              for name in signals]
        evaluate = system.batch_rhs(K, signals)
        steps = np.tile(self.h / m, (copies, 1))

        def rhs(state, column, source=columns):
            return evaluate(state, [values[column] for values in source])

        limited = bool(getattr(system, "limits", None))

        with np.errstate(all="ignore"):
            for i in range(L):
                h = steps[:, i, None]
                for j in range(m):
                    c = 2 * (i * m + j)
                    k1 = rhs(x, c)
                    k2 = rhs(x + 0.5 * h * k1, c + 1, lefts)
                    k3 = rhs(x + 0.5 * h * k2, c + 1, lefts)
                    k4 = rhs(x + h * k3, c + 2, lefts)
                    x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
                    if limited:
                        system.clip(x)
                bad = ~np.isfinite(x).all(axis=1) | (np.abs(x) > self.bound).any(axis=1)
                if bad.any():
                    escape_step[bad & ~escaped] = i + 1
                    escaped |= bad
                    x[bad] = out[bad, i]
                out[:, i + 1] = x
        return out, escaped, escape_step

    def _simulate_one(self, system, start: np.ndarray, k: int, fine: Mapping[str, np.ndarray],
                      ends: Mapping[str, np.ndarray]) -> tuple[np.ndarray, bool, int]:
        """Window ``k`` of :meth:`simulate`, in floats: its states, escape and escape step.

        Whole experiments are few windows: numpy's cost per call would
        outweigh the work on arrays of a few rows, so the same Runge-Kutta
        steps are taken on lists of floats with the scalar right-hand side
        (the same numbers).
        """
        L, m = self.n_steps, self.substeps
        n_stages = 2 * L * m + 1
        inputs = list(system.inputs)

        def stage_values(signals, side: str):
            if not inputs:
                return [[]] * n_stages
            key = (side, tuple(inputs), k)  # the same lists for every simulation
            if key not in self._floats:
                self._floats[key] = np.column_stack([signals[name][k]
                                                     for name in inputs]).tolist()
            return self._floats[key]

        right = stage_values(fine, "right")
        left = right if ends is fine else stage_values(ends, "left")
        if ("t", k) not in self._floats:
            self._floats["t", k] = (fine[TIME][k].tolist() if TIME in fine
                                    else [0.0] * n_stages)
        times = self._floats["t", k]
        bound = self.bound.tolist()
        steps = (self.h[k] / m).tolist()
        run = float_integrator(system)
        if run is not None:  # the same steps, generated as one function
            try:
                rows = run([float(v) for v in start], right, left, times, steps[:L], m, bound)
            except Exception:  # the general path below says what went wrong, and where
                rows = None
            if rows is not None:
                return np.array(rows), False, L + 1
        now: list = [None]
        rhs = system.make_rhs(lambda t: now[0], list_states=True)
        limited = bool(getattr(system, "limits", None))

        def f(x, c, source):
            now[0] = source[c]
            return rhs(times[c], x)

        out = np.empty((L + 1, len(self.states)))
        x = [float(v) for v in start]
        out[0] = x
        escaped, escape_step = False, L + 1
        for i in range(L):
            h = steps[i]
            try:
                for j in range(m):
                    c = 2 * (i * m + j)
                    k1 = f(x, c, right)
                    k2 = f([a + 0.5 * h * b for a, b in zip(x, k1)], c + 1, left)
                    k3 = f([a + 0.5 * h * b for a, b in zip(x, k2)], c + 1, left)
                    k4 = f([a + h * b for a, b in zip(x, k3)], c + 2, left)
                    x = [a + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
                         for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
                    if limited:
                        system.clip_values(x)
                bad = not all(math.isfinite(v) and abs(v) <= b for v, b in zip(x, bound))
            except (Diverged, ArithmeticError, ValueError):  # math's domain errors too
                bad = True
            if bad:
                if not escaped:
                    escape_step = i + 1
                escaped = True
                x = out[i].tolist()
            out[i + 1] = x
        return out, escaped, escape_step


#: at most this many windows are integrated one by one in floats rather than side by side
FEW_WINDOWS = 4


@dataclass(frozen=True)
class Horizon:
    """How far each window of a horizon-limited comparison simulates.

    Attributes
    ----------
    time : float or None
        The horizon in the time units of ``t``; None for whole experiments.
    samples : int or None
        Sample intervals per window (None for whole experiments).
    why : str
        How it was chosen, in words.
    """

    time: float | None
    samples: int | None
    why: str

    def __str__(self) -> str:
        if self.time is None:
            return self.why
        return f"windows of {self.time:.4g} ({self.samples} samples; {self.why})"


def _median_step(experiments) -> float:
    steps = [np.diff(t) for _, t in experiments if len(t) > 1]
    return float(np.median(np.concatenate(steps))) if steps else 1.0


def choose_horizon(system, states: Sequence[str], columns: Mapping[str, np.ndarray],
                   experiments: Sequence[tuple[np.ndarray, np.ndarray]],
                   horizon="auto") -> Horizon:
    """The horizon of a comparison: ``"auto"``, a time, or None (whole experiments).

    ``"auto"`` reads the model's dominant eigenvalue (largest magnitude of
    the right-hand side's Jacobian) along the record: where it oscillates,
    a window spans ``HORIZON_PERIODS`` periods, where it decays,
    ``HORIZON_TIME_CONSTANTS`` time constants; the median over the record
    is taken, and at least ``MIN_HORIZON_SAMPLES`` samples. Long enough for
    the dynamics to act, short enough that an integrator's drift, a light
    damping's phase slip or chaos does not swamp the comparison.

    Parameters
    ----------
    system : CompiledSystem
        The model.
    states : list of str
        Its states.
    columns : dict
        States, inputs and ``t`` on every row.
    experiments : sequence of (rows, t)
        Row positions and times of each experiment.
    horizon : "auto", float or None
        What the user asked for.

    Raises
    ------
    ValueError
        For a horizon that is not "auto", None or a positive time.
    """
    if horizon is None:
        return Horizon(None, None, "whole experiments")
    step = _median_step(experiments)
    longest = max(len(rows) for rows, _ in experiments) - 1
    if isinstance(horizon, str) and horizon == "auto":
        values = np.column_stack([columns[s] for s in states])
        scale = np.sqrt(np.mean(values**2, axis=0))
        scale[~(scale > 0)] = 1.0
        eigenvalues = jacobian_eigenvalues(system, columns, states, scale)
        dominant = eigenvalues[np.arange(len(eigenvalues)), np.abs(eigenvalues).argmax(axis=1)]
        dominant = dominant[np.isfinite(dominant) & (np.abs(dominant) > 0)]
        if dominant.size == 0:
            samples = max(MIN_HORIZON_SAMPLES, longest // 10)
            why = "a tenth of the record: the model has no rate of its own"
        else:
            # an oscillation is followed for periods, a decay for time constants
            oscillating = np.abs(dominant.imag) > np.abs(dominant.real)
            spans = np.where(oscillating, HORIZON_PERIODS * 2 * math.pi,
                             HORIZON_TIME_CONSTANTS) / np.abs(dominant)
            samples = max(MIN_HORIZON_SAMPLES, round(float(np.median(spans)) / step))
            why = (f"{HORIZON_PERIODS:g} periods of the model's oscillation"
                   if np.mean(oscillating) >= 0.5 else
                   f"{HORIZON_TIME_CONSTANTS:g} of the model's time constants")
    elif isinstance(horizon, Real) and not isinstance(horizon, bool) and _positive(horizon):
        span = _as_float(horizon)
        if span < 2 * step:
            raise ValueError(f"horizon {horizon!r} is shorter than two sampling steps "
                             f"({2 * step:.4g}): a window must hold at least one step to "
                             "simulate; give a longer time, 'auto' or None")
        samples = round(span / step) if math.isfinite(span) else longest
        why = "the time given"
    else:
        raise ValueError(f"horizon must be 'auto', None or a positive time, got {horizon!r}")
    if samples >= longest:
        return Horizon(None, None, f"whole experiments ({why}: longer than the record)")
    return Horizon(samples * step, int(samples), why)


def _as_float(value) -> float:
    """``value`` as a float; an integer too large for one is infinite."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _positive(value) -> bool:
    """Whether a real ``value`` is a positive number (not NaN)."""
    number = _as_float(value)
    return not math.isnan(number) and number > 0


def simulate_windows(system, states: Sequence[str], inputs: Sequence[str], uses_time: bool,
                     columns: Mapping[str, np.ndarray], *, signals: Mapping[str, np.ndarray],
                     experiments: Sequence[tuple[np.ndarray, np.ndarray]], horizon: Horizon,
                     n_samples: int, hold: str = "bandlimited"):
    """Every row predicted from the measured state one horizon (or less) before it.

    Windows of ``horizon.samples`` steps tile every experiment and are
    integrated side by side, each from the state in ``columns`` at its
    first row; a row is predicted by the window that reaches it, the first
    row of an experiment is its measured start. A window that diverges
    predicts NaN from where it left the states' range.

    Returns
    -------
    simulated : ndarray of shape (n_samples, n_states)
    escaped : dict
        Experiment index -> (time the first diverging window left the
        range, time it would have ended, diverging windows, windows) for
        experiments where some did.
    """
    windows = Windows(states, inputs, uses_time, experiments,
                      {s: columns[s] for s in states}, signals=signals, window=horizon.samples,
                      hold=hold)
    windows.choose_substeps(system, columns)
    out, escaped = windows.simulate(system, windows.initial)
    # each row once: a window's first sample is the previous window's last prediction
    own = windows.valid.copy()
    own[np.flatnonzero(windows.successor) + 1, 0] = False
    out[np.arange(windows.n_steps + 1)[None, :] >= windows.escape_step[:, None]] = np.nan
    simulated = np.full((n_samples, len(states)), np.nan)
    simulated[windows.rows[own]] = out[own]
    report = {}
    for e in np.unique(windows.segment_experiment[escaped]):
        mine = np.flatnonzero(escaped & (windows.segment_experiment == e))
        first = mine[0]
        left = min(int(windows.escape_step[first]) - 1, int(windows.steps[first]))
        report[int(e)] = (float(windows.times[first, left]),
                          float(windows.times[first, windows.steps[first]]), len(mine),
                          int(np.count_nonzero(windows.segment_experiment == e)))
    return simulated, report


@dataclass(frozen=True)
class Divergence:
    """A simulation that stopped before the end of its experiment (or whose windows escaped)."""

    trajectory: object
    t_reached: float
    t_end: float
    reason: str

    def __str__(self) -> str:
        where = "" if self.trajectory is None else f" (trajectory {self.trajectory!r})"
        return (f"the simulation stopped at t={self.t_reached:.4g} of {self.t_end:.4g}"
                f"{where}: {self.reason}")


def simulate_rows(model, columns: Mapping[str, np.ndarray], signals: Mapping[str, np.ndarray],
                  experiments: Sequence[tuple[object, np.ndarray, np.ndarray]],
                  horizon: Horizon, *, n_samples: int, max_steps: int, rtol: float = 1e-6,
                  atol: float = 1e-8,
                  capture_warnings: bool = True) -> tuple[np.ndarray, list[Divergence], list[str]]:
    """A fitted model simulated against a record, on every row.

    The one loop behind the simulation scorer and the diagnosis: whole
    experiments from their first state (``horizon.samples`` None), or
    windows of the horizon each restarted from the state at its first row
    (:func:`simulate_windows`).

    Parameters
    ----------
    model : CCRegressor
        Fitted.
    columns : dict
        The states (measured, smoothed or reconstructed: where simulations
        start), the inputs as the equations read them, and ``t``.
    signals : dict
        The inputs as measured, which drive the simulations.
    experiments : list of (label, rows, t)
    horizon : Horizon
    n_samples : int
        Rows of the record.
    max_steps, rtol, atol
        Solver settings for whole experiments.
    capture_warnings : bool, default=True
        Collect the simulations' warnings into ``warned`` rather than let
        them reach the caller.

    Returns
    -------
    simulated : ndarray of shape (n_samples, n_states)
        NaN after a divergence.
    stops : list of Divergence
        Experiments whose simulation stopped early or whose windows escaped.
    warned : list of str
        Warnings the whole-experiment simulations raised, once each.
    """
    skeleton = model.skeleton_
    states = list(skeleton.states)
    inputs = [name for name in skeleton.inputs if name != "t"]
    drive = {name: signals.get(name, columns[name]) for name in inputs}
    if horizon.samples is not None:
        system = skeleton.compile(model.functions_, model.params_)
        simulated, escaped = simulate_windows(
            system, states, inputs, "t" in skeleton.variables, columns, signals=drive,
            experiments=[(rows, t) for _, rows, t in experiments], horizon=horizon,
            n_samples=n_samples,
            hold=fitted_hold(model))
        stops = [Divergence(experiments[e][0], start, end,
                      f"{count} of {total} windows of the horizon left the states' range")
                 for e, (start, end, count, total) in escaped.items()]
        return simulated, stops, []
    simulated = np.full((n_samples, len(states)), np.nan)
    stops, warned = [], []
    limits = skeleton.limits_at(model.params_)
    for label, rows, t in experiments:
        if len(t) < 2:
            simulated[rows] = np.column_stack([columns[s][rows] for s in states])
            continue
        # a level read above its rim (another record's noise) starts at the rim
        y0 = [float(np.clip(columns[s][rows[0]], *limits.get(s, (-np.inf, np.inf))))
              for s in states]
        with warnings.catch_warnings(record=True) if capture_warnings \
                else contextlib.nullcontext([]) as caught:
            if capture_warnings:
                warnings.simplefilter("always")
            try:
                frame = model.simulate(t, y0, {name: v[rows] for name, v in drive.items()},
                                       rtol=rtol, atol=atol, max_steps=max_steps)
            except SimulationError as exc:
                frame = exc.partial
                stops.append(Divergence(label, float(exc.t_reached), float(t[-1]),
                                  str(exc.args[0]) if exc.args else str(exc)))
        for item in caught:
            if str(item.message) not in warned:
                warned.append(str(item.message))
        if frame is not None and len(frame):
            simulated[rows[:len(frame)]] = frame[states].to_numpy(dtype=float)
    return simulated, stops, warned
