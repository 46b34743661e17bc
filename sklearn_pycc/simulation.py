"""Forward simulation of a compiled right-hand side.

The right-hand side is compiled once (see :mod:`sklearn_pycc.skeleton.compiler`)
into a function of Python floats; this module drives a SciPy ODE solver step
by step so that divergence is caught where it happens and the partial
trajectory can be returned with the error.
"""

from __future__ import annotations

import bisect
import math
import numbers
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import integrate

from .exceptions import SimulationError

__all__ = ["DEFAULT_MAX_STEPS", "Diverged", "InputSignals", "check_time_grid", "integrate_system"]

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


class Diverged(ArithmeticError):
    """Raised inside a right-hand side that produced a non-finite value."""


class _Sampled:
    """Piecewise-linear interpolation of a signal sampled on a time grid (fast on scalars)."""

    __slots__ = ("last", "n", "t", "t_list", "v", "v_list")

    def __init__(self, t: np.ndarray, values: np.ndarray) -> None:
        self.t, self.v = t, values
        self.t_list, self.v_list = t.tolist(), values.tolist()
        self.n = len(self.t_list)

    def __call__(self, t):
        if not isinstance(t, float):
            return np.interp(t, self.t, self.v)
        ts = self.t_list
        i = bisect.bisect_right(ts, t)
        if i <= 0:
            return self.v_list[0]
        if i >= self.n:
            return self.v_list[-1]
        t0, t1 = ts[i - 1], ts[i]
        v0 = self.v_list[i - 1]
        return v0 + (self.v_list[i] - v0) * (t - t0) / (t1 - t0)


def _constant(value: float) -> Callable:
    def signal(t):
        if isinstance(t, float):
            return value
        return np.full(np.shape(t), value)

    return signal


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
    """

    def __init__(self, names: Sequence[str], inputs: Mapping | None, t: np.ndarray) -> None:
        inputs = {} if inputs is None else inputs
        if not isinstance(inputs, Mapping):
            raise TypeError(
                "inputs must be a dict mapping input names to signals, "
                f"got {type(inputs).__name__}"
            )
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
            self.signals.append(self._signal(name, inputs[name], t))

    @staticmethod
    def _signal(name: str, value, t: np.ndarray) -> Callable:
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
        return _Sampled(np.asarray(t, dtype=float), values)

    def at(self, t: float) -> list[float]:
        """Values of every input at the scalar time ``t``."""
        return [float(s(t)) for s in self.signals]

    def on(self, t: np.ndarray) -> list[np.ndarray]:
        """Values of every input on the time array ``t``."""
        out = []
        for s in self.signals:
            v = s(t)
            v = np.broadcast_to(np.asarray(v, dtype=float), np.shape(t))
            out.append(np.array(v, dtype=float))
        return out


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
    rtol: float = 1e-6,
    atol: float = 1e-8,
    max_steps: int | None = DEFAULT_MAX_STEPS,
    **options,
) -> pd.DataFrame:
    """Integrate ``y' = fun(t, y)`` and sample it on ``t``.

    ``fun`` may raise :class:`Diverged` (or any ``ArithmeticError`` or
    ``ValueError`` from :mod:`math`) when the state leaves the domain of the
    model; that, a non-finite state, a solver failure, or more than
    ``max_steps`` solver steps (a model chattering on a discontinuity, or
    stuck at a singularity) raises :class:`~sklearn_pycc.SimulationError`
    carrying the partial trajectory. ``max_steps=None`` removes the limit.

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
    frame = pd.DataFrame(out, columns=list(names))
    frame.insert(0, "t", t)
    return frame
