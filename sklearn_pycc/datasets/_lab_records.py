"""Simulated laboratory records: what a real rig hands over, not an ideal simulation.

The generators of :mod:`sklearn_pycc.datasets` return exact states. Real
records are different: a position axis runs in closed loop with a sampled
controller and an incremental encoder (quantised positions, a force that
jumps at every sample), a fast oscillator is sampled at a handful of samples
per period, a camera drops frames. These generators make such records, with
the true parameters in their truth, to test that methods work on them.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp
from sklearn.utils import Bunch

from ._generation import (
    add_noise,
    check_n_samples,
    check_noise,
    check_noise_columns,
    check_random_state,
    check_real,
    check_t_span,
)

__all__ = ["make_pendulum", "make_positioning_axis", "make_resonator"]


def positive(name: str, value, *, minimum: float = 0.0) -> float:
    value = check_real(name, value)
    if value <= minimum:
        raise ValueError(f"{name} must be greater than {minimum:g}, got {value!r}")
    return value


def _fraction(name: str, value) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not 0 <= value < 1:
        raise ValueError(f"{name} must be a number in [0, 1), got {value!r}")
    return float(value)


def _drop(frame: pd.DataFrame, fraction: float, rng: np.random.Generator) -> pd.DataFrame:
    """Remove a share of the rows at random (never the first or the last)."""
    if fraction == 0:
        return frame
    n = len(frame)
    k = round(fraction * (n - 2))
    gone = rng.choice(np.arange(1, n - 1), size=k, replace=False)
    keep = np.setdiff1d(np.arange(n), gone)
    return frame.iloc[keep].reset_index(drop=True)


def _sweep_reference(t: np.ndarray, stroke: float, rng: np.random.Generator) -> np.ndarray:
    """A smooth random reference: a multisine of 0.1 to 2 Hz scaled to the stroke."""
    u = multisine(rng, (0.1, 2.0), 1.0, t[-1] - t[0] + (t[1] - t[0]), 20)
    values = u(t - t[0])
    return stroke * values / np.max(np.abs(values))


def _viscous_pair(viscous) -> tuple[float, float]:
    """``viscous`` as (forward, backward) coefficients."""
    try:
        values = np.atleast_1d(np.asarray(viscous, dtype=float))
    except (TypeError, ValueError):
        values = np.array([np.nan])
    if isinstance(viscous, (str, bool)) or values.shape not in ((1,), (2,)) \
            or not np.isfinite(values).all():
        raise ValueError("viscous must be a number or a pair of numbers (forward, "
                         f"backward), got {viscous!r}")
    return float(values[0]), float(values[-1])


def _reference(t: np.ndarray, stroke: float, rng: np.random.Generator) -> np.ndarray:
    """Point-to-point moves: smooth fifth-order profiles between random targets, with dwells."""
    ref = np.zeros_like(t)
    now, here = t[0], 0.0
    while now < t[-1]:
        target = rng.uniform(-stroke, stroke)
        duration = rng.uniform(0.25, 0.6)
        dwell = rng.uniform(0.2, 0.8)
        inside = (t >= now) & (t < now + duration)
        s = (t[inside] - now) / duration
        ref[inside] = here + (target - here) * (10 * s**3 - 15 * s**4 + 6 * s**5)
        after = t >= now + duration
        ref[after] = target
        now, here = now + duration + dwell, target
    return ref


def make_positioning_axis(
    n_samples: int = 25_000,
    t_span: tuple[float, float] = (0.0, 24.999),
    *,
    noise: float | None = None,
    noise_columns=("x1",),
    y0=(0.0, 0.0),
    mass: float = 2.0,
    viscous: float = 8.0,
    coulomb: float = 3.0,
    offset: float = 1.0,
    gain: float = 20.0,
    saturation: float = 10.0,
    bandwidth: float = 8.0,
    stroke: float = 0.1,
    encoder_step: float = 2e-5,
    coulomb_velocity: float = 1e-3,
    reference: str = "sweep",
    random_state=None,
    return_truth: bool = False,
):
    """A linear positioning axis under a sampled PD position controller, read by an encoder.

    The plant is a mass with viscous and (smoothed) Coulomb friction and a
    constant force offset (gravity on a tilted axis, a cable), driven by a
    motor force ``gain * voltage``:

    ``mass x'' = gain sat(v) - viscous x' - coulomb tanh(x' / coulomb_velocity) - offset``.

    At every sample the controller reads the quantised encoder
    position and sets the voltage ``v = kp (r - x) - kd x'_est`` (velocity
    from encoder differences through a first-order filter), saturated at
    ``saturation`` and held until the next sample; ``r`` is a random sweep or
    random point-to-point moves (``reference``). The record holds what a lab
    would log: ``t``, the encoder position ``x1`` and the applied force ``F``
    (``gain sat(v)``); no velocity, no acceleration.

    Parameters
    ----------
    n_samples : int, default=25000
        Samples; with ``t_span`` they set the controller and logging rate
        (1 kHz by default).
    t_span : tuple of float, default=(0, 24.999)
        Start and end time in seconds.
    noise : float or None, default=None
        White noise at this signal-to-noise ratio (dB) on top of the
        encoder's rounding, on ``noise_columns``.
    noise_columns : sequence of str, default=("x1",)
        Columns the noise goes to (``x1``, ``F``).
    y0 : tuple of float, default=(0, 0)
        Initial position and velocity.
    mass, viscous, coulomb, offset : float
        The plant (kg, N s/m, N, N). ``viscous`` may be a pair: the
        coefficients when moving forward and backward (a worn guide).
    gain : float, default=20.0
        Motor force per volt.
    saturation : float, default=10.0
        Largest voltage.
    bandwidth : float, default=8.0
        Closed-loop natural frequency in Hz the controller gains are tuned for.
    stroke : float, default=0.1
        The reference stays within ``[-stroke, stroke]``.
    encoder_step : float, default=2e-5
        Position quantum (``1e-4`` of the range by default); 0 for none.
    coulomb_velocity : float, default=1e-3
        Velocity scale of the smoothed Coulomb friction.
    reference : {"sweep", "moves"}, default="sweep"
        What the axis is told to follow: a smooth random multisine between
        0.1 and 2 Hz (an identification run), or point-to-point moves with
        dwells (a production cycle; at rest the Coulomb friction is only
        bounded, not determined, so dwells carry no information on it).
    random_state : int, Generator or None
        Seeds the reference and the noise.
    return_truth : bool, default=False
        Also return a Bunch with the skeleton, its parameters (``a1 = gain /
        mass`` per volt is folded: ``a1 = 1 / mass`` per newton), the
        physical values and the exact velocity and acceleration.

    Returns
    -------
    frame : DataFrame
        ``t``, ``x1``, ``F``.
    truth : Bunch
        Only with ``return_truth``.

    Raises
    ------
    ValueError
        For a setting out of its range, named.
    """
    n = check_n_samples(n_samples)
    start, end = check_t_span(t_span)
    fs = (n - 1) / (end - start)
    noise = check_noise(noise)
    noisy = check_noise_columns(noise_columns, ["t", "x1", "F"], ["x1"])
    m = positive("mass", mass)
    forward, backward = _viscous_pair(viscous)
    # viscous friction c v + d |v|: forward + backward over 2, and half their difference
    c, d = (forward + backward) / 2, (forward - backward) / 2
    fc, f0 = float(coulomb), float(offset)
    k_motor = positive("gain", gain)
    v_max = positive("saturation", saturation)
    eps = positive("coulomb_velocity", coulomb_velocity)
    q = float(encoder_step)
    rng = check_random_state(random_state)
    h = 1.0 / fs
    t = start + np.arange(n) * h
    if reference not in ("sweep", "moves"):
        raise ValueError(f"reference must be 'sweep' or 'moves', got {reference!r}")
    make_reference = _sweep_reference if reference == "sweep" else _reference
    r = make_reference(t, positive("stroke", stroke), rng)
    wn = 2 * math.pi * positive("bandwidth", bandwidth)
    kp, kd = m * wn**2 / k_motor, 2 * 0.7 * wn * m / k_motor
    alpha = math.exp(-2 * math.pi * 200.0 * h)  # 200 Hz filter on the encoder velocity

    tanh = math.tanh

    def accel(v, force):
        return (force - c * v - d * abs(v) - fc * tanh(v / eps) - f0) / m

    substeps = 8
    dt = h / substeps
    x, v = (float(value) for value in y0)
    reading_before = round(x / q) * q if q > 0 else x
    xs, vs, forces, accels = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    velocity_est = 0.0
    for i in range(n):
        reading = round(x / q) * q if q > 0 else x
        velocity_est = alpha * velocity_est + (1 - alpha) * (reading - reading_before) / h
        reading_before = reading
        volts = min(v_max, max(-v_max, kp * (r[i] - reading) - kd * velocity_est))
        force = k_motor * volts
        xs[i], vs[i], forces[i] = reading, v, force
        accels[i] = accel(v, force)
        for _ in range(substeps):  # RK4 with the force held over the sample
            a1 = accel(v, force)
            va = v + 0.5 * dt * a1
            a2 = accel(va, force)
            vb = v + 0.5 * dt * a2
            a3 = accel(vb, force)
            vc = v + dt * a3
            a4 = accel(vc, force)
            x += dt * (v + 2 * va + 2 * vb + vc) / 6
            v += dt * (a1 + 2 * a2 + 2 * a3 + a4) / 6
    frame = pd.DataFrame({"t": t, "x1": xs, "F": forces})
    if noise is not None and noisy:
        frame = add_noise(frame, noise, noisy, rng)
    if not return_truth:
        return frame
    equations = ["x1_dot = x2", "x2_dot = a1 F - a2 x2 - a3 tanh(a4 x2) - a5"]
    params = {"a1": 1 / m, "a2": c / m, "a3": fc / m, "a4": 1 / eps, "a5": f0 / m}
    hidden = ["coulomb_friction", "offset"]
    physical = {"mass": m, "viscous": c, "coulomb": fc, "offset": f0}
    if d:
        equations[1] += " - a6 abs(x2)"
        params["a6"] = d / m
        hidden.append("asymmetric_viscous_damping")
        physical.update(viscous=(forward, backward))
    truth = Bunch(equations=equations, params=params, physical=physical,
                  base_equations=["x1_dot = x2", "x2_dot = a1 F - a2 x2"], hidden=hidden,
                  velocity=vs, acceleration=accels, reference=r)
    return frame, truth


class Multisine:
    """A sum of sines ``sum_l A sin(omega_l t + phase_l)`` (picklable, vectorised over t)."""

    def __init__(self, omegas: np.ndarray, phases: np.ndarray, line_amplitude: float) -> None:
        self.omegas = np.asarray(omegas, dtype=float)
        self.phases = np.asarray(phases, dtype=float)
        self.line_amplitude = float(line_amplitude)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        out = np.zeros(t.shape)
        for omega, phase in zip(self.omegas, self.phases):
            out += np.sin(omega * t + phase)
        return self.line_amplitude * out if out.ndim else float(self.line_amplitude * out)


def multisine(rng: np.random.Generator, band: tuple[float, float], amplitude: float,
               period: float, components: int) -> Multisine:
    """A random-phase multisine on harmonics of ``1 / period`` within ``band`` (Hz)."""
    base = 1.0 / period
    lines = np.arange(max(1, math.ceil(band[0] / base)), math.floor(band[1] / base) + 1)
    if len(lines) > components:
        lines = np.sort(rng.choice(lines, size=components, replace=False))
    phases = rng.uniform(0, 2 * math.pi, size=len(lines))
    return Multisine(2 * math.pi * base * lines, phases, amplitude * math.sqrt(2.0 / len(lines)))


def _duffing_rk4(h: float, n: int, u: Multisine, g: float, c: float, *, k: float, k3: float,
                 substeps: int, y0, start: float) -> tuple[np.ndarray, np.ndarray]:
    """``x'' = g u - c x' - k x - k3 x^3`` from ``y0`` by RK4 at ``h / substeps`` (u exact)."""
    dt = h / substeps
    forcing = (g * u(start + np.arange(2 * substeps * (n - 1) + 1) * (dt / 2))).tolist()
    x, v = (float(value) for value in y0)
    xs, vs = [x] * n, [v] * n
    j = 0
    for i in range(1, n):
        for _ in range(substeps):
            f0, f1, f2 = forcing[j], forcing[j + 1], forcing[j + 2]
            a1 = f0 - c * v - k * x - k3 * x * x * x
            xa, va = x + 0.5 * dt * v, v + 0.5 * dt * a1
            a2 = f1 - c * va - k * xa - k3 * xa * xa * xa
            xb, vb = x + 0.5 * dt * va, v + 0.5 * dt * a2
            a3 = f1 - c * vb - k * xb - k3 * xb * xb * xb
            xc, vc = x + dt * vb, v + dt * a3
            a4 = f2 - c * vc - k * xc - k3 * xc * xc * xc
            x += dt * (v + 2 * va + 2 * vb + vc) / 6
            v += dt * (a1 + 2 * a2 + 2 * a3 + a4) / 6
            j += 2
        xs[i], vs[i] = x, v
    return np.array(xs), np.array(vs)


def make_resonator(
    n_samples: int = 20_000,
    t_span: tuple[float, float] | None = None,
    *,
    noise: float | None = 60.0,
    noise_columns=("x1",),
    y0=(0.0, 0.0),
    samples_per_period: float | None = None,
    natural_frequency: float = 61.6,
    damping_ratio: float = 0.02,
    hardening: float = 0.05,
    input_gain: float = 1.0,
    amplitude: float = 1.0,
    band: tuple[float, float] = (0.5, 1.5),
    drop_fraction: float = 0.0,
    random_state=None,
    return_truth: bool = False,
):
    """A lightly damped hardening oscillator sampled at a few samples per period.

    An electronic Duffing oscillator, ``x'' + c x' + k x + k3 x^3 = g u``,
    driven by a random-phase multisine ``u`` whose lines lie in ``band``
    times the natural frequency, and logged at ``samples_per_period``
    samples per period of its resonance. Only the output ``x1`` (with white
    noise at ``noise`` dB) and the input ``u`` are recorded.

    Parameters
    ----------
    n_samples : int, default=20000
        Samples, before any are dropped.
    t_span : tuple of float, optional
        Start and end time; default from ``samples_per_period``.
    noise : float or None, default=60.0
        Signal-to-noise ratio in dB of the white noise on ``noise_columns``;
        None for none.
    noise_columns : sequence of str, default=("x1",)
        Noisy columns (``x1``, ``u``).
    y0 : tuple of float, default=(0, 0)
        Initial position and velocity.
    samples_per_period : float, optional
        Sampling rate over the natural frequency, 10 by default; give this
        or ``t_span``, not both.
    natural_frequency : float, default=61.6
        ``sqrt(k) / (2 pi)`` in Hz.
    damping_ratio : float, default=0.02
        ``c / (2 sqrt(k))``.
    hardening : float, default=0.05
        ``k3 x_rms^2 / k`` with ``x_rms`` the RMS of the linear response: the
        default makes the cubic force about a fifth of the linear one.
    input_gain : float, default=1.0
        ``g``.
    amplitude : float, default=1.0
        RMS of the multisine, in units of ``k / g`` times 0.02 (so that
        the default response is a few percent of a unit).
    band : tuple of float, default=(0.5, 1.5)
        The multisine's band relative to the natural frequency.
    drop_fraction : float, default=0.0
        Share of samples dropped at random (a logger missing frames).
    random_state : int, Generator or None
        Seeds the multisine phases and lines, the noise and the drops.
    return_truth : bool, default=False
        Also return a Bunch with the skeleton (``x2_dot = a1 u - a2 x2 -
        a3 x1 - a4 x1^3``), its parameters, the input callable and the exact
        states on the kept samples.

    Returns
    -------
    frame : DataFrame
        ``t``, ``x1``, ``u``.
    truth : Bunch
        Only with ``return_truth``.

    Raises
    ------
    ValueError
        For a setting out of its range, named.
    """
    n = check_n_samples(n_samples)
    f_n = positive("natural_frequency", natural_frequency)
    if t_span is not None and samples_per_period is not None:
        raise ValueError("give t_span or samples_per_period, not both")
    if t_span is None:
        per = positive("samples_per_period", 10.0 if samples_per_period is None
                        else samples_per_period, minimum=2.0)
        start = 0.0
    else:
        start, end = check_t_span(t_span)
        per = (n - 1) / (end - start) / f_n
    noise = check_noise(noise)
    noisy = check_noise_columns(noise_columns, ["t", "x1", "u"], ["x1"])
    zeta = positive("damping_ratio", damping_ratio)
    g = positive("input_gain", input_gain)
    drop = _fraction("drop_fraction", drop_fraction)
    rng = check_random_state(random_state)
    k = (2 * math.pi * f_n) ** 2
    c = 2 * zeta * math.sqrt(k)
    h = 1.0 / (per * f_n)
    t = start + np.arange(n) * h
    level = positive("amplitude", amplitude) * 0.02 * k / g
    u = multisine(rng, (band[0] * f_n, band[1] * f_n), level, t[-1] + h, 64)
    # the linear response's rms sets the cubic coefficient
    gains = g / np.abs(k - u.omegas**2 + 1j * c * u.omegas)
    x_rms = u.line_amplitude * float(np.sqrt(np.sum(gains**2) / 2))
    k3 = float(hardening) * k / x_rms**2

    x1, x2 = _duffing_rk4(h, n, u, g, c, k=k, k3=k3, substeps=16, y0=y0, start=start)
    frame = pd.DataFrame({"t": t, "x1": x1, "u": u(t)})
    if noise is not None and noisy:
        frame = add_noise(frame, noise, noisy, rng)
    states = pd.DataFrame({"x1": x1, "x2": x2})
    if drop:
        frame = _drop(frame.assign(_x1=x1, _x2=x2), drop, rng)
        states = frame[["_x1", "_x2"]].set_axis(["x1", "x2"], axis=1)
        frame = frame[["t", "x1", "u"]]
    if not return_truth:
        return frame
    truth = Bunch(equations=["x1_dot = x2", "x2_dot = a1 u - a2 x2 - a3 x1 - a4 x1^3"],
                  base_equations=["x1_dot = x2", "x2_dot = a1 u - a2 x2 - a3 x1"],
                  params={"a1": g, "a2": c, "a3": k, "a4": k3}, input=u,
                  hidden=["cubic_stiffness"], states=states)
    return frame, truth


def make_pendulum(
    n_samples: int = 1800,
    t_span: tuple[float, float] = (0.0, 59.97),
    *,
    noise: float | None = 45.0,
    noise_columns=("x1",),
    y0=(2.0, 0.0),
    natural_frequency: float = 0.5,
    damping_ratio: float = 0.005,
    pixel: float = 2e-3,
    drop_fraction: float = 0.03,
    random_state=None,
    return_truth: bool = False,
):
    """A free, lightly damped pendulum released at a large angle and filmed by a camera.

    ``x'' = -c x' - w0^2 sin(x)``: the angle ``x1`` is read from each frame
    (rounded to the angle one ``pixel`` subtends, with white noise at
    ``noise`` dB), and the camera drops a share of its frames. Only ``t``
    and ``x1`` are recorded. At the default release of 2 rad the restoring
    torque is 45 % below the linear one at the turning points.

    Parameters
    ----------
    n_samples : int, default=1800
        Frames, before any are dropped (30 frames per second by default).
    t_span : tuple of float, default=(0, 59.97)
        Start and end time in seconds.
    noise : float or None, default=45.0
        Signal-to-noise ratio in dB of the tracking noise; None for none.
    noise_columns : sequence of str, default=("x1",)
        Noisy columns (only ``x1`` is measured).
    y0 : tuple of float, default=(2.0, 0.0)
        Initial angle (rad) and angular velocity.
    natural_frequency : float, default=0.5
        ``w0 / (2 pi)`` in Hz, at small amplitude.
    damping_ratio : float, default=0.005
        ``c / (2 w0)``.
    pixel : float, default=2e-3
        Angle quantum of the tracking in rad; 0 for none.
    drop_fraction : float, default=0.03
        Share of frames dropped at random.
    random_state : int, Generator or None
        Seeds the noise and the drops.
    return_truth : bool, default=False
        Also return a Bunch with the skeleton (``x2_dot = -a1 x2 - a2
        sin(x1)``), its parameters, the linear skeleton a study starts from
        and the exact states on the kept frames.

    Returns
    -------
    frame : DataFrame
        ``t``, ``x1``.
    truth : Bunch
        Only with ``return_truth``.

    Raises
    ------
    ValueError
        For a setting out of its range, named.
    """
    n = check_n_samples(n_samples)
    start, end = check_t_span(t_span)
    noise = check_noise(noise)
    noisy = check_noise_columns(noise_columns, ["t", "x1"], ["x1"])
    w0 = 2 * math.pi * positive("natural_frequency", natural_frequency)
    c = 2 * positive("damping_ratio", damping_ratio) * w0
    q = check_real("pixel", pixel)
    if q < 0:
        raise ValueError(f"pixel must be non-negative, got {pixel!r}")
    drop = _fraction("drop_fraction", drop_fraction)
    rng = check_random_state(random_state)
    t = np.linspace(start, end, n)

    def rhs(_, y):
        return [y[1], -c * y[1] - w0**2 * math.sin(y[0])]

    start_state = np.asarray(y0, dtype=float).ravel()
    if start_state.shape != (2,) or not np.isfinite(start_state).all():
        raise ValueError(f"y0 must be two finite numbers (angle, angular velocity), got {y0!r}")
    solution = solve_ivp(rhs, (start, end), list(start_state), method="DOP853",
                         t_eval=t, rtol=1e-11, atol=1e-12)
    if not solution.success:  # pragma: no cover - a pendulum does not diverge
        raise ValueError(f"the pendulum could not be simulated: {solution.message}")
    x1, x2 = solution.y
    reading = np.round(x1 / q) * q if q > 0 else x1.copy()
    frame = pd.DataFrame({"t": t, "x1": reading})
    if noise is not None and noisy:
        frame = add_noise(frame, noise, noisy, rng)
    frame = _drop(frame.assign(_x1=x1, _x2=x2), drop, rng)
    states = frame[["_x1", "_x2"]].set_axis(["x1", "x2"], axis=1)
    frame = frame[["t", "x1"]]
    if not return_truth:
        return frame
    truth = Bunch(equations=["x1_dot = x2", "x2_dot = -a1 x2 - a2 sin(x1)"],
                  base_equations=["x1_dot = x2", "x2_dot = -a1 x2 - a2 x1"],
                  params={"a1": c, "a2": w0**2}, hidden=["pendulum"], states=states)
    return frame, truth
