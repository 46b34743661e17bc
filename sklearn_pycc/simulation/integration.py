"""Forward simulation of a compiled right-hand side.

The right-hand side is compiled once (see :mod:`sklearn_pycc.skeleton.compiler`)
into a function of Python floats; this module drives a SciPy ODE solver step
by step so that divergence is caught where it happens and the partial
trajectory can be returned with the error.
"""

from __future__ import annotations

import bisect
import contextlib
import math
import numbers
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import integrate

from .._utils.bandlimited import bandlimited_slopes
from ..exceptions import SimulationError
from .delays import delayed_column, read_delayed

__all__ = ["DEFAULT_MAX_STEPS", "INPUT_HOLDS", "STEP_BUDGET", "Diverged", "InputSignals",
           "check_hold", "check_time_grid", "fitted_hold", "given_hold", "integrate_sampled",
           "integrate_system", "judged_step_limit", "progress_bar", "requested_hold",
           "sampled_step_limit"]

_SOLVERS = {
    "LSODA": integrate.LSODA,
    "RK45": integrate.RK45,
    "RK23": integrate.RK23,
    "DOP853": integrate.DOP853,
    "Radau": integrate.Radau,
    "BDF": integrate.BDF,
}


#: default limit on solver steps in one simulation (see :func:`integrate_system`)
DEFAULT_MAX_STEPS = 500_000
#: the most steps the sampled-input integrator takes by default, however long the record
#: (20 to 70 microseconds a step: a few minutes on one core); a longer record is simulated
#: in pieces, or with an explicit ``max_steps``
STEP_BUDGET = 5_000_000


def judged_step_limit(n_samples: int) -> int:
    """Steps a diagnosis or a comparison allows one simulation of a record of ``n_samples``.

    Fifty a sample and a margin, so that a diverging candidate is given up
    quickly, and never more than :data:`STEP_BUDGET`.
    """
    return min(STEP_BUDGET, 50 * int(n_samples) + 10_000)


def sampled_step_limit(n_samples: int) -> int:
    """Default ``max_steps`` of :func:`integrate_sampled` for a record of ``n_samples``.

    Fifty steps a sample (a long record earns its steps), at least
    :data:`DEFAULT_MAX_STEPS` and at most :data:`STEP_BUDGET`, so that a
    model chattering on a long record is stopped in minutes, not hours.
    """
    return min(STEP_BUDGET, max(DEFAULT_MAX_STEPS, 50 * int(n_samples)))


class Diverged(ArithmeticError):
    """Raised inside a right-hand side that produced a non-finite value."""


#: how a sampled input is held between its samples
INPUT_HOLDS = ("bandlimited", "foh", "zoh")


def given_hold(estimator) -> str:
    """An estimator's ``input_hold``, ``"auto"`` read as band-limited until a fit chooses."""
    hold = getattr(estimator, "input_hold", "auto")
    return "bandlimited" if hold == "auto" else hold


def fitted_hold(model) -> str:
    """The input hold a fitted model used (``input_hold_``), else the one it was given."""
    return getattr(model, "input_hold_", None) or given_hold(model)


def requested_hold(model, input_hold) -> str:
    """The hold a call on ``model`` asks for: ``"auto"`` is the one it was fitted with.

    Raises
    ------
    ValueError
        For anything but ``"auto"`` or one of :data:`INPUT_HOLDS`, naming them.
    """
    if isinstance(input_hold, str) and input_hold == "auto":
        return fitted_hold(model)
    check_hold(input_hold, allowed=("auto", *INPUT_HOLDS))
    return input_hold


def check_hold(hold, allowed: Sequence[str] = INPUT_HOLDS) -> None:
    """Refuse an input hold that is not one of ``allowed``, naming them."""
    if not isinstance(hold, str) or hold not in allowed:
        raise ValueError(f"input_hold must be one of {', '.join(map(repr, allowed))}, "
                         f"got {hold!r}")


class _Sampled:
    """A signal sampled on a time grid, held between samples (fast on scalars).

    ``"bandlimited"`` reads the samples as a signal band-limited below the
    Nyquist frequency (a measured, anti-aliased record; a generator's
    output): cubic Hermite pieces whose slopes at the samples are those of
    the band-limited signal. ``"foh"`` (first-order hold) joins the samples
    by straight lines; ``"zoh"`` (zero-order hold) keeps each sample's
    value until the next one, as a digital-to-analogue converter does.
    Inside a known sample interval (:meth:`within`) no search is needed,
    and a zero-order hold keeps the interval's value up to its right end.
    """

    __slots__ = ("d_list", "hold", "n", "slopes", "t", "t_list", "v", "v_list")

    def __init__(self, t: np.ndarray, values: np.ndarray, hold: str = "bandlimited") -> None:
        self.t, self.v = t, values
        self.t_list, self.v_list = t.tolist(), values.tolist()
        self.n = len(self.t_list)
        self.hold = hold
        self.slopes = bandlimited_slopes(t, values) if hold == "bandlimited" else None
        self.d_list = None if self.slopes is None else self.slopes.tolist()

    def __call__(self, t):
        if not isinstance(t, float):
            if self.hold == "zoh":
                index = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, self.n - 1)
                return self.v[index]
            if self.hold == "bandlimited" and self.n > 1:
                return self._hermite(np.asarray(t, dtype=float))
            return np.interp(t, self.t, self.v)
        i = bisect.bisect_right(self.t_list, t)
        if i <= 0:
            return self.v_list[0]
        if i >= self.n:
            return self.v_list[-1]
        return self.within(i - 1, t)

    def within(self, i: int, t: float) -> float:
        """The value at ``t`` inside the interval from sample ``i`` to sample ``i + 1``."""
        v0 = self.v_list[i]
        if self.hold == "zoh":
            return v0
        t0 = self.t_list[i]
        width = self.t_list[i + 1] - t0
        s = (t - t0) / width
        v1 = self.v_list[i + 1]
        if self.d_list is None:
            return v0 + (v1 - v0) * s
        # cubic Hermite: values and band-limited slopes at both ends
        d0, d1 = self.d_list[i] * width, self.d_list[i + 1] * width
        return v0 + s * (d0 + s * (3 * (v1 - v0) - 2 * d0 - d1 + s * (2 * (v0 - v1) + d0 + d1)))

    def _hermite(self, t: np.ndarray) -> np.ndarray:
        inside = np.clip(t, self.t[0], self.t[-1])
        i = np.clip(np.searchsorted(self.t, inside, side="right") - 1, 0, self.n - 2)
        t0, width = self.t[i], self.t[i + 1] - self.t[i]
        s = (inside - t0) / width
        v0, v1 = self.v[i], self.v[i + 1]
        d0, d1 = self.slopes[i] * width, self.slopes[i + 1] * width
        return v0 + s * (d0 + s * (3 * (v1 - v0) - 2 * d0 - d1 + s * (2 * (v0 - v1) + d0 + d1)))


def _ignoring_interval(signal: Callable) -> Callable[[int, float], float]:
    def read(_: int, t: float) -> float:
        return float(signal(t))

    return read


def _constant(value: float) -> Callable:
    def signal(t):
        if isinstance(t, float):
            return value
        return np.full(np.shape(t), value)

    return signal


def _with_delayed(names: Sequence[str], inputs: Mapping, t: np.ndarray) -> dict:
    """``inputs`` with each input read late (``u(t - 0.3)``) made from its signal ``u``.

    An array is read late on the grid ``t`` as a fit reads it (linear
    between samples, its first value before them), a callable at ``t - 0.3``,
    a constant as itself. The signals read late are not themselves inputs
    of the system: they are taken out once used.
    """
    out = dict(inputs)
    sources = set()
    for name in names:
        read = read_delayed(name)
        if read is None or name in inputs or read[0] not in inputs:
            continue
        signal, delay = read
        sources.add(signal)
        value = inputs[signal]
        if callable(value):
            out[name] = (lambda f, d: lambda s: f(s - d))(value, float(delay))
        elif value is None or isinstance(value, (str, bytes)) or np.isscalar(value):
            out[name] = value
        else:
            values = np.asarray(value, dtype=float)
            if values.ndim != 1 or len(values) != len(t):
                raise ValueError(
                    f"input {signal!r}: an array input must be sampled on t "
                    f"(length {len(t)}), got shape {values.shape}")
            out[name] = delayed_column(values, np.asarray(t, dtype=float), float(delay))
    for signal in sources - set(names):
        del out[signal]
    return out


class InputSignals:
    """Validated input signals of a simulation.

    Parameters
    ----------
    names : sequence of str
        The inputs the system needs, in slot order.
    inputs : mapping, optional
        Name -> callable of ``t``, array sampled on ``t``, or a constant.
    t : ndarray
        The output time grid (arrays are sampled on it).
    hold : {"bandlimited", "foh", "zoh"}, default="bandlimited"
        How an array input is held between its samples.
    """

    def __init__(self, names: Sequence[str], inputs: Mapping | None, t: np.ndarray,
                 hold: str = "bandlimited") -> None:
        check_hold(hold)
        self.hold = hold
        #: sample interval the integrator is in (None: search for it)
        self.interval: int | None = None
        inputs = {} if inputs is None else inputs
        if not isinstance(inputs, Mapping):
            raise TypeError(
                "inputs must be a dict mapping input names to signals, "
                f"got {type(inputs).__name__}"
            )
        inputs = _with_delayed(names, inputs, t)
        unknown = [k for k in inputs if k not in names]
        if unknown:
            have = ", ".join(map(repr, names)) if names else "none"
            raise ValueError(
                f"unknown input {unknown[0]!r} given to simulate; the skeleton's inputs are {have}"
            )
        missing = [k for k in names if k not in inputs]
        if missing:
            raise ValueError(
                f"simulate needs the input {missing[0]!r}: pass inputs={{{missing[0]!r}: ...}} "
                "with a callable of t, an array sampled on t, or a constant"
            )
        self.names = list(names)
        self.signals: list[Callable] = []
        for name in self.names:
            self.signals.append(self._signal(name, inputs[name], t, hold))
        # readers inside a known sample interval, fixed once
        self._within = [s.within if isinstance(s, _Sampled) else _ignoring_interval(s)
                        for s in self.signals]

    @property
    def sampled(self) -> bool:
        """Whether some input is an array sampled on the time grid."""
        return any(isinstance(s, _Sampled) for s in self.signals)

    @staticmethod
    def _signal(name: str, value, t: np.ndarray, hold: str) -> Callable:
        if callable(value):
            probe = np.asarray(value(float(t[0])), dtype=float)
            if probe.size != 1:
                raise ValueError(
                    f"input {name!r}: the callable must return one value per time, "
                    f"got shape {probe.shape} at t={t[0]:g}"
                )
            if not np.isfinite(probe).all():
                raise ValueError(f"input {name!r} is not finite at t={t[0]:g}")
            return value
        if value is None or isinstance(value, (str, bytes)):
            raise ValueError(
                f"input {name!r} is {value!r}: give a callable of t, an array sampled on t, "
                "or a number")
        if np.isscalar(value):
            value = float(value)
            if not math.isfinite(value):
                raise ValueError(f"input {name!r} is not finite")
            return _constant(value)
        values = np.asarray(value, dtype=float)
        if values.ndim != 1 or len(values) != len(t):
            raise ValueError(
                f"input {name!r}: an array input must be sampled on t "
                f"(length {len(t)}), got shape {values.shape}"
            )
        if not np.isfinite(values).all():
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise ValueError(f"input {name!r} is not finite at position {bad}")
        return _Sampled(np.asarray(t, dtype=float), values, hold)

    def at(self, t: float) -> list[float]:
        """Values of every input at the scalar time ``t`` (inside :attr:`interval` when set)."""
        i = self.interval
        if i is None:
            return [float(s(t)) for s in self.signals]
        return [read(i, t) for read in self._within]

    def on(self, t: np.ndarray) -> list[np.ndarray]:
        """Values of every input on the time array ``t``."""
        out = []
        for s in self.signals:
            v = s(t)
            v = np.broadcast_to(np.asarray(v, dtype=float), np.shape(t))
            out.append(np.array(v, dtype=float))
        return out


def _positive(name: str, value, *, allow_zero: bool = False, allow_inf: bool = False) -> None:
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and not (
        math.isnan(value) or (math.isinf(value) and not allow_inf))
    if ok:
        ok = value >= 0 if allow_zero else value > 0
    if not ok:
        wanted = "non-negative" if allow_zero else "positive"
        raise ValueError(f"the solver option {name} must be a {wanted} number, got {value!r}")


def check_solver_options(rtol, atol, options: Mapping) -> None:
    """Refuse tolerances and step options that no solver can use, naming the option."""
    _positive("rtol", rtol)
    atol_values = np.atleast_1d(np.asarray(atol, dtype=object))
    for value in atol_values:
        _positive("atol", value, allow_zero=True)
    if "max_step" in options:
        _positive("max_step", options["max_step"], allow_inf=True)
    if "first_step" in options and options["first_step"] is not None:
        _positive("first_step", options["first_step"])
    if "min_step" in options:
        _positive("min_step", options["min_step"], allow_zero=True)


def check_time_grid(t) -> np.ndarray:
    """Validate the output time grid of a simulation."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 2:
        raise ValueError(f"t must be a 1-D array of at least two times, got shape {t.shape}")
    if not np.isfinite(t).all():
        raise ValueError("t contains NaN or infinity")
    steps = np.diff(t)
    if (steps <= 0).any():
        bad = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise ValueError(
            f"t must be strictly increasing; t[{bad}]={t[bad]:g} follows "
            f"t[{bad - 1}]={t[bad - 1]:g}"
        )
    return t


def integrate_system(
    fun: Callable[[float, np.ndarray], Sequence[float]],
    t: np.ndarray,
    y0: np.ndarray,
    names: Sequence[str],
    method: str = "LSODA",
    *,
    rtol: float = 1e-6,
    atol: float = 1e-8,
    max_steps: int | None = DEFAULT_MAX_STEPS,
    progress: Callable[[int], None] | None = None,
    **options,
) -> pd.DataFrame:
    """Integrate ``y' = fun(t, y)`` and sample it on ``t``.

    ``fun`` may raise :class:`Diverged` (or any ``ArithmeticError`` or
    ``ValueError`` from :mod:`math`) when the state leaves the domain of the
    model; that, a non-finite state, a solver failure, or more than
    ``max_steps`` solver steps (a model chattering on a discontinuity, or
    stuck at a singularity) raises :class:`~sklearn_pycc.SimulationError`
    carrying the partial trajectory. ``max_steps=None`` removes the limit.
    ``progress(k)`` is called as output samples are reached.

    Returns
    -------
    pandas.DataFrame
        Columns ``t`` and ``names``.
    """
    if method not in _SOLVERS:
        raise ValueError(f"unknown solver method {method!r}; choose one of {sorted(_SOLVERS)}")
    if max_steps is not None and (not isinstance(max_steps, numbers.Integral)
                                  or isinstance(max_steps, bool) or max_steps < 1):
        raise ValueError(f"max_steps must be a positive integer or None, got {max_steps!r}")
    n = len(t)
    out = np.empty((n, len(y0)))
    out[0] = y0
    k = 1

    def partial(reason: str, t_reached: float) -> SimulationError:
        frame = pd.DataFrame(out[:k], columns=list(names))
        frame.insert(0, "t", t[:k])
        return SimulationError(reason, t_reached=t_reached, partial=frame)

    try:
        solver = _SOLVERS[method](fun, float(t[0]), y0, float(t[-1]), rtol=rtol, atol=atol,
                                  **options)
    except (ArithmeticError, ValueError) as exc:
        raise partial(f"the model cannot be evaluated at the initial state: {exc}",
                      float(t[0])) from exc
    last_t = float(t[0])
    steps = 0
    while k < n:
        if max_steps is not None and steps >= max_steps:
            raise partial(f"the solver took {steps} steps and reached only t={last_t:.6g} "
                          f"of {float(t[-1]):.6g}: the model may chatter on a discontinuity "
                          "or approach a singularity (raise max_steps to go on)", last_t)
        steps += 1
        try:
            message = solver.step()
        except (ArithmeticError, ValueError) as exc:
            reason = str(exc) or type(exc).__name__
            raise partial(f"the simulation diverged: {reason}", last_t) from exc
        if solver.status == "failed":
            raise partial(f"the solver failed: {message}", last_t)
        if not np.isfinite(solver.y).all():
            raise partial("the simulation diverged: the state is no longer finite", last_t)
        last_t = float(solver.t)
        j = int(np.searchsorted(t, last_t, side="right"))
        if solver.status == "finished":
            j = n
        if j > k:
            values = solver.dense_output()(t[k:j])
            out[k:j] = values.T
            k = j
            if progress is not None:
                progress(k - 1)
    frame = pd.DataFrame(out, columns=list(names))
    frame.insert(0, "t", t)
    return frame


@contextlib.contextmanager
def progress_bar(n_samples: int, show: bool):
    """A ``progress(k)`` callback drawing a tqdm bar over ``n_samples`` (None when not shown)."""
    if not show:
        yield None
        return
    from tqdm.auto import tqdm

    bar = tqdm(total=n_samples - 1, unit="sample", desc="simulate")

    def progress(reached: int) -> None:
        bar.update(reached - bar.n)

    try:
        yield progress
    finally:
        bar.close()


# Dormand-Prince 5(4): nodes, stage weights, fifth-order weights and the error weights
# (fifth minus embedded fourth order; the last one for the first-same-as-last stage)
_C2, _C3, _C4, _C5 = 1 / 5, 3 / 10, 4 / 5, 8 / 9
_A21 = 1 / 5
_A31, _A32 = 3 / 40, 9 / 40
_A41, _A42, _A43 = 44 / 45, -56 / 15, 32 / 9
_A51, _A52, _A53, _A54 = 19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729
_A61, _A62, _A63, _A64, _A65 = 9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656
_B1, _B3, _B4, _B5, _B6 = 35 / 384, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84
_E1, _E3, _E4, _E5, _E6, _E7 = (71 / 57600, -71 / 16695, 71 / 1920, -17253 / 339200,
                                22 / 525, -1 / 40)


#: explicit steps within one sample interval after which it is finished implicitly
STIFF_STEPS = 16


def _stiff_interval(fun, start: float, end: float, y: list, rtol: float, *, atol: float,
                    budget: float) -> tuple[list, int]:
    """Integrate one sample interval with LSODA; return the state at its end and the steps."""
    solver = integrate.LSODA(lambda time, state: fun(time, state.tolist()), start,
                             np.array(y), end, rtol=rtol, atol=atol)
    used = 0
    while solver.status == "running":
        if used >= budget:
            raise Diverged(f"the model is stiff and needed more than the step limit by "
                           f"t={solver.t:.6g}")
        message = solver.step()
        used += 1
        if solver.status == "failed":
            raise Diverged(f"the implicit solver failed: {message}")
    if not np.isfinite(solver.y).all():
        raise Diverged("the state is no longer finite")
    return solver.y.tolist(), used


def _too_long(n_samples: int, max_steps: int) -> str:
    """Why a record of ``n_samples`` cannot be simulated within ``max_steps``, and what to do."""
    return (f"a record of {n_samples:,} samples needs at least one solver step per sample, "
            f"more than the step limit of {max_steps:,} (by default at most "
            f"STEP_BUDGET={STEP_BUDGET:,} steps, a few minutes on one core, however long the "
            "record): simulate it in pieces of fewer samples, each starting (y0) from the "
            "states of the last row of the piece before, or pass a larger max_steps (None "
            "removes the limit)")


def integrate_sampled(
    fun: Callable[[float, list], Sequence[float]],
    t: np.ndarray,
    y0: np.ndarray,
    names: Sequence[str],
    signals: InputSignals,
    *,
    rtol: float = 1e-6,
    atol: float = 1e-8,
    max_steps: int | None = DEFAULT_MAX_STEPS,
    progress: Callable[[int], None] | None = None,
) -> pd.DataFrame:
    """Integrate ``y' = fun(t, y)`` driven by sampled inputs, sample interval by interval.

    An adaptive Dormand-Prince 5(4) method whose steps end on every sample
    time, so that each step sees the input held smoothly (a zero-order hold
    jumps, a first-order hold kinks, only at samples) and no step straddles
    a jump. The step size carries over from one interval to the next: the
    solver is not restarted at samples, and a slow model takes one step per
    sample. An interval that needs more than ``STIFF_STEPS`` explicit steps
    (a stiff stretch, such as a steep friction law near zero velocity) is
    finished by LSODA. ``fun`` takes the state as a list of floats (see
    :meth:`~sklearn_pycc.skeleton.system.CompiledSystem.make_rhs`). Errors
    and limits are those of :func:`integrate_system`; ``progress(k)`` is
    called as samples are reached. Every sample takes a step at least, so a
    record of more samples than ``max_steps`` is refused before the first
    step (its :class:`~sklearn_pycc.SimulationError` says how to simulate it
    in pieces).
    """
    if max_steps is not None and (not isinstance(max_steps, numbers.Integral)
                                  or isinstance(max_steps, bool) or max_steps < 1):
        raise ValueError(f"max_steps must be a positive integer or None, got {max_steps!r}")
    n, m = len(t), len(y0)
    times = t.tolist()
    out = np.empty((n, m))
    out[0] = y0
    y = [float(v) for v in y0]
    reached, steps = 0, 0
    limit = math.inf if max_steps is None else max_steps
    every = max(1, n // 100)
    # a zero-order hold jumps at every sample: the first stage is evaluated anew there
    jumps = signals.hold == "zoh"

    def partial(reason: str, t_reached: float) -> SimulationError:
        frame = pd.DataFrame(out[:reached + 1], columns=list(names))
        frame.insert(0, "t", t[:reached + 1])
        return SimulationError(reason, t_reached=t_reached, partial=frame)

    if n - 1 > limit:
        raise partial(_too_long(n, max_steps), times[0])
    h = times[1] - times[0]
    try:
        signals.interval = 0
        k1 = list(fun(times[0], y))
        for i in range(n - 1):
            signals.interval = i
            now, end = times[i], times[i + 1]
            if jumps and i:
                k1 = list(fun(now, y))
            here = 0
            while now < end:
                if here == STIFF_STEPS:
                    # stability, not accuracy, limits the step: finish this interval with
                    # an implicit method (the input is held as in the explicit steps)
                    y, used = _stiff_interval(fun, now, end, y, rtol, atol=atol,
                                              budget=limit - steps)
                    steps += used
                    now, k1 = end, list(fun(end, y))
                    break
                here += 1
                if steps >= limit:
                    raise partial(
                        f"the solver took {steps} steps and reached only t={now:.6g} of "
                        f"{times[-1]:.6g}: the model may chatter on a discontinuity or be "
                        "stiff (raise max_steps, or pass method='LSODA')", now)
                steps += 1
                last = end - now <= h * (1 + 1e-12)
                s = end - now if last else h
                k2 = fun(now + _C2 * s, [a + s * _A21 * b for a, b in zip(y, k1)])
                k3 = fun(now + _C3 * s, [a + s * (_A31 * b + _A32 * c)
                                         for a, b, c in zip(y, k1, k2)])
                k4 = fun(now + _C4 * s, [a + s * (_A41 * b + _A42 * c + _A43 * d)
                                         for a, b, c, d in zip(y, k1, k2, k3)])
                k5 = fun(now + _C5 * s, [a + s * (_A51 * b + _A52 * c + _A53 * d + _A54 * e)
                                         for a, b, c, d, e in zip(y, k1, k2, k3, k4)])
                k6 = fun(now + s, [a + s * (_A61 * b + _A62 * c + _A63 * d + _A64 * e + _A65 * f)
                                   for a, b, c, d, e, f in zip(y, k1, k2, k3, k4, k5)])
                new = [a + s * (_B1 * b + _B3 * d + _B4 * e + _B5 * f + _B6 * g)
                       for a, b, d, e, f, g in zip(y, k1, k3, k4, k5, k6)]
                k7 = fun(now + s, new)
                total = 0.0
                for a, z, b, d, e, f, g, w in zip(y, new, k1, k3, k4, k5, k6, k7):
                    err = s * (_E1 * b + _E3 * d + _E4 * e + _E5 * f + _E6 * g + _E7 * w) / (
                        atol + rtol * max(abs(a), abs(z)))
                    total += err * err
                error = math.sqrt(total / m)
                if not math.isfinite(error):
                    raise Diverged("the state is no longer finite")
                factor = 5.0 if error == 0 else min(5.0, max(0.2, 0.9 * error ** -0.2))
                if error <= 1.0:
                    now = end if last else now + s
                    y, k1 = new, list(k7)  # first same as last
                    # a step cut short to land on a sample does not shrink the next one
                    h = max(h, s * factor) if last else s * factor
                else:
                    h = s * factor
            out[i + 1] = y
            reached = i + 1
            if progress is not None and (reached % every == 0 or reached == n - 1):
                progress(reached)
    except (ArithmeticError, ValueError) as exc:
        reason = str(exc) or type(exc).__name__
        raise partial(f"the simulation diverged: {reason}", times[reached]) from exc
    finally:
        signals.interval = None
    frame = pd.DataFrame(out, columns=list(names))
    frame.insert(0, "t", t)
    return frame
