"""Records of the kind a process plant logs: slow, sampled every few seconds, half unmeasured.

A stirred tank heated through a pipe is the other: the heater's power
reaches the tank a transport delay late.

A cascade of two tanks is the classic case. A pump fills the upper tank,
which drains through an orifice into the lower one, which drains out;
each level follows Torricelli's law, and each tank overflows at its rim.
The plant logs the pump voltage and the lower level every few seconds; the
upper level has no sensor.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from sklearn.utils import Bunch

from ._generation import (
    add_noise,
    check_n_samples,
    check_noise,
    check_noise_columns,
    check_random_state,
    check_t_span,
)
from ._lab_records import multisine, positive

__all__ = ["HeldInput", "make_heated_tank", "make_two_tanks"]

#: integration substeps per sample (the levels clip at the rims once per substep)
_SUBSTEPS = 40


class HeldInput:
    """A signal held constant between samples (zero-order hold): picklable, vectorised.

    Parameters
    ----------
    t : ndarray
        The instants at which a new value is applied, increasing.
    values : ndarray
        The value applied from each instant until the next.
    """

    def __init__(self, t: np.ndarray, values: np.ndarray) -> None:
        self.t = np.asarray(t, dtype=float)
        self.values = np.asarray(values, dtype=float)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 1)
        out = self.values[k]
        return out if out.ndim else float(out)


def _levels(u: np.ndarray, h: float, y0, a: tuple, rims) -> np.ndarray:
    """Both levels at the samples: RK4 substeps, each level held within [0, its rim]."""
    a1, a2, a3, a4 = (float(v) for v in a)
    top1, top2 = float(rims[0]), float(rims[1])
    dt = h / _SUBSTEPS
    sqrt = math.sqrt

    def slope(x1: float, x2: float, v: float) -> tuple[float, float]:
        r1 = sqrt(x1) if x1 > 0 else 0.0
        r2 = sqrt(x2) if x2 > 0 else 0.0
        return a1 * v - a2 * r1, a3 * r1 - a4 * r2

    out = np.empty((len(u), 2))
    x1, x2 = float(y0[0]), float(y0[1])
    for k, v in enumerate(np.asarray(u, dtype=float).tolist()):
        out[k] = x1, x2
        for _ in range(_SUBSTEPS):
            p1, q1 = slope(x1, x2, v)
            p2, q2 = slope(x1 + 0.5 * dt * p1, x2 + 0.5 * dt * q1, v)
            p3, q3 = slope(x1 + 0.5 * dt * p2, x2 + 0.5 * dt * q2, v)
            p4, q4 = slope(x1 + dt * p3, x2 + dt * q3, v)
            # beyond the rim the water spills: the level stays at it
            x1 = min(max(x1 + dt / 6.0 * (p1 + 2 * p2 + 2 * p3 + p4), 0.0), top1)
            x2 = min(max(x2 + dt / 6.0 * (q1 + 2 * q2 + 2 * q3 + q4), 0.0), top2)
    return out


def make_two_tanks(
    n_samples: int = 1024,
    t_span: tuple[float, float] | None = None,
    *,
    noise: float | None = 40.0,
    noise_columns=("x2",),
    measured=("x2",),
    y0=None,
    params=None,
    rims: tuple[float, float] = (12.0, 13.0),
    pump: tuple[float, float] = (3.0, 10.0),
    periods: tuple[float, float] = (60.0, 1200.0),
    random_state=None,
    return_truth: bool = False,
):
    """A cascade of two tanks logged every few seconds, the upper level unmeasured.

    Torricelli's law for each tank, with the pump voltage ``u`` in::

        x1_dot = a1 u - a2 sqrt(x1)          (upper level, cm)
        x2_dot = a3 sqrt(x1) - a4 sqrt(x2)   (lower level, cm)

    Each tank overflows at its rim (``rims``, in cm): the level stays there
    while more flows in than out, the rest spills away. The pump voltage is a
    random-phase multisine of periods within ``periods`` (seconds), clipped
    to ``pump`` and held between samples (zero-order hold, as a controller
    writes it). The time constants are minutes, against a sample every
    4 seconds by default. Only the levels ``measured`` are logged, the
    ``noise_columns`` among them with white noise at ``noise`` dB; the
    initial levels are drawn at random.

    Parameters
    ----------
    n_samples : int, default=1024
        Samples logged.
    t_span : tuple of float, optional
        Time of the first and the last sample in seconds; by default one
        sample every 4 s from 0.
    noise : float or None, default=40.0
        Signal-to-noise ratio in dB of the level sensors; None for none.
    noise_columns : sequence of str, default=("x2",)
        The noisy columns, among those logged (the levels and ``u``).
    measured : sequence of str, default=("x2",)
        The levels logged, among ``x1`` and ``x2``.
    y0 : tuple of float, optional
        Initial levels in cm; by default drawn uniformly in [2, 10].
    params : dict, optional
        ``a1`` to ``a4``; by default ``a1 = 0.02`` (cm/s per volt), ``a2 =
        0.04``, ``a3 = 0.05``, ``a4 = 0.045`` (cm^0.5/s): the lower tank has
        0.8 times the upper one's cross-section.
    rims : tuple of float, default=(12, 13)
        Heights at which the upper and the lower tank overflow, in cm.
    pump : tuple of float, default=(3, 10)
        Least and largest pump voltage.
    periods : tuple of float, default=(60, 1200)
        Shortest and longest period of the multisine, in seconds.
    random_state : int, Generator or None
        Seeds the input, the initial levels and the noise.
    return_truth : bool, default=False
        Also return a Bunch with the skeleton, its parameters, the rims,
        the input (a :class:`HeldInput`) and the exact levels.

    Returns
    -------
    frame : DataFrame
        ``t``, ``u`` and the ``measured`` levels.
    truth : Bunch
        Only with ``return_truth``: ``equations``, ``params``, ``rims``,
        ``input``, ``states`` (both levels, exact), ``y0`` and
        ``overflowing`` (the share of samples at which each tank is at its rim).

    Raises
    ------
    ValueError
        For a setting out of its range, named.

    Examples
    --------
    >>> from sklearn_pycc import datasets
    >>> frame = datasets.make_two_tanks(random_state=0)
    >>> list(frame.columns), len(frame), float(frame.t[1] - frame.t[0])
    (['t', 'u', 'x2'], 1024, 4.0)
    """
    n = check_n_samples(n_samples)
    start_time, end_time = (0.0, 4.0 * (n - 1)) if t_span is None else check_t_span(t_span)
    h = (end_time - start_time) / max(n - 1, 1)
    noise = check_noise(noise)
    measured = list(measured)
    odd = [name for name in measured if name not in ("x1", "x2")]
    if odd or not measured or len(set(measured)) != len(measured):
        raise ValueError(f"measured must name some of 'x1' and 'x2' once each, got {measured!r}")
    noisy = check_noise_columns(noise_columns, ["t", "u", *measured], measured)
    values = {"a1": 0.02, "a2": 0.04, "a3": 0.05, "a4": 0.045}
    if params is not None:
        unknown = [name for name in params if name not in values]
        if unknown:
            raise ValueError(f"params names {unknown[0]!r}; the tanks have a1, a2, a3 and a4")
        values.update({name: positive(name, value) for name, value in params.items()})
    rim = np.array([positive("rims[0]", rims[0]), positive("rims[1]", rims[1])])
    low, high = float(pump[0]), float(pump[1])
    if not 0 <= low < high:
        raise ValueError(f"pump must be (least, largest) voltage with 0 <= least < largest, "
                         f"got {pump!r}")
    short, long = positive("periods[0]", periods[0]), positive("periods[1]", periods[1])
    if not short < long:
        raise ValueError(f"periods must be (shortest, longest), got {periods!r}")
    rng = check_random_state(random_state)
    t = start_time + np.arange(n) * h
    wave = multisine(rng, (1.0 / long, 1.0 / short), 1.0, max(n * h, long), 32)(t)
    spread = float(np.max(np.abs(wave))) or 1.0
    # the multisine's peaks reach a little beyond the pump's range, where it clips
    u = np.clip(0.5 * (low + high) + 0.6 * (high - low) * wave / spread, low, high)
    start = (rng.uniform(2.0, 10.0, size=2) if y0 is None
             else np.array([float(v) for v in y0]))
    if start.shape != (2,) or not np.all(np.isfinite(start)) or np.any(start < 0):
        raise ValueError(f"y0 must be two non-negative levels, got {y0!r}")
    a = (values["a1"], values["a2"], values["a3"], values["a4"])
    levels = _levels(u, h, np.minimum(start, rim), a, rim)
    frame = pd.DataFrame({"t": t, "u": u, **{name: levels[:, int(name[1]) - 1]
                                             for name in measured}})
    if noise is not None and noisy:
        frame = add_noise(frame, noise, noisy, rng)
    if not return_truth:
        return frame
    at_rim = np.isclose(levels, rim[None, :], rtol=0.0, atol=1e-9)
    truth = Bunch(equations=["x1_dot = a1 u - a2 sqrt(x1)",
                             "x2_dot = a3 sqrt(x1) - a4 sqrt(x2)"],
                  params=dict(values), rims={"x1": float(rim[0]), "x2": float(rim[1])},
                  input=HeldInput(t, u), states=pd.DataFrame(levels, columns=["x1", "x2"]),
                  y0=tuple(float(v) for v in np.minimum(start, rim)),
                  overflowing={"x1": float(at_rim[:, 0].mean()),
                               "x2": float(at_rim[:, 1].mean())})
    return frame, truth


def make_heated_tank(
    n_samples: int = 2000,
    t_span: tuple[float, float] | None = None,
    *,
    delay_samples: int = 6,
    noise: float | None = 40.0,
    noise_columns=("x1",),
    params=None,
    switches: int = 40,
    power: tuple[float, float] = (0.0, 10.0),
    y0: float = 2.0,
    random_state=None,
    return_truth: bool = False,
):
    """A stirred tank heated through a pipe: the heater's power arrives a delay late.

    The tank's temperature above its surroundings, ``x1`` (K), follows the
    heater power ``u`` (kW) read ``delay_samples`` samples late (the hot
    water travels down the pipe) and loses heat to the surroundings::

        x1_dot = a1 u(t - delay) - a2 x1

    The heater is switched between random levels within ``power`` at
    ``switches`` random sampling instants and held between them. The
    temperature is logged every half second (by default) with white noise at
    ``noise`` dB (colour it with :func:`add_sensor_noise`).

    Parameters
    ----------
    n_samples : int, default=2000
        Samples logged.
    t_span : tuple of float, optional
        Time of the first and the last sample in seconds; by default one
        sample every 0.5 s from 0.
    delay_samples : int, default=6
        The transport delay, in samples (0: none).
    noise : float or None, default=40.0
        Signal-to-noise ratio in dB of the sensors; None for none.
    noise_columns : sequence of str, default=("x1",)
        The noisy columns, among ``x1`` and ``u``.
    params : dict, optional
        ``a1`` (K/s per kW) and ``a2`` (1/s); by default 0.05 and 0.1.
    switches : int, default=40
        Times the heater power changes.
    power : tuple of float, default=(0, 10)
        Least and largest heater power.
    y0 : float, default=2.0
        Temperature above the surroundings at the start (the heater has
        been at its first level before it).
    random_state : int, Generator or None
        Seeds the switching and the noise.
    return_truth : bool, default=False
        Also return a Bunch with the skeleton, its parameters, the delay in
        seconds and the exact temperature.

    Raises
    ------
    ValueError
        For a setting out of its range, named.

    Returns
    -------
    frame : DataFrame
        ``t``, ``u`` and ``x1``.
    truth : Bunch
        Only with ``return_truth``: ``equations``, ``params`` (``a5`` is the
        delay in seconds), ``delay``, ``states`` (exact) and ``y0``.

    Examples
    --------
    >>> from sklearn_pycc import datasets
    >>> frame, truth = datasets.make_heated_tank(random_state=0, return_truth=True)
    >>> list(frame.columns), truth.equations, truth.delay
    (['t', 'u', 'x1'], ['x1_dot = a1 u(t - a5) - a2 x1'], 3.0)
    """
    n = check_n_samples(n_samples)
    start_time, end_time = (0.0, 0.5 * (n - 1)) if t_span is None else check_t_span(t_span)
    h = (end_time - start_time) / max(n - 1, 1)
    if isinstance(delay_samples, bool) or not isinstance(delay_samples, (int, np.integer)) \
            or not 0 <= delay_samples < n:
        raise ValueError(f"delay_samples must be a whole number of samples from 0 to "
                         f"n_samples - 1, got {delay_samples!r}")
    if isinstance(switches, bool) or not isinstance(switches, (int, np.integer)) \
            or switches < 0:
        raise ValueError(f"switches must be a whole number at least 0, got {switches!r}")
    noise = check_noise(noise)
    noisy = check_noise_columns(noise_columns, ["t", "u", "x1"], ["x1"])
    values = {"a1": 0.05, "a2": 0.1}
    if params is not None:
        unknown = [name for name in params if name not in values]
        if unknown:
            raise ValueError(f"params names {unknown[0]!r}; the tank has a1 and a2")
        values.update({name: positive(name, value) for name, value in params.items()})
    low, high = float(power[0]), float(power[1])
    if not 0 <= low < high:
        raise ValueError(f"power must be (least, largest) with 0 <= least < largest, "
                         f"got {power!r}")
    rng = check_random_state(random_state)
    t = start_time + np.arange(n) * h
    instants = np.sort(rng.integers(1, n, size=int(switches)))
    levels = rng.uniform(low, high, size=int(switches) + 1)
    u = levels[np.searchsorted(instants, np.arange(n), side="right")]
    # the heater's power as the tank receives it: read delay_samples late, its first
    # level before the record began
    late = np.concatenate([np.full(int(delay_samples), u[0]), u[:n - int(delay_samples)]])
    a1, a2 = values["a1"], values["a2"]
    # exact between samples: the received power is held there
    decay = math.exp(-a2 * h)
    x = np.empty(n)
    x[0] = float(y0)
    for k in range(n - 1):
        steady = a1 * late[k] / a2
        x[k + 1] = steady + (x[k] - steady) * decay
    frame = pd.DataFrame({"t": t, "u": u, "x1": x})
    if noise is not None and noisy:
        frame = add_noise(frame, noise, noisy, rng)
    if not return_truth:
        return frame
    delay = float(delay_samples * h)
    truth = Bunch(equations=["x1_dot = a1 u(t - a5) - a2 x1"],
                  params={**values, "a5": delay}, delay=delay,
                  states=pd.DataFrame({"x1": x}), y0=(float(y0),))
    return frame, truth
