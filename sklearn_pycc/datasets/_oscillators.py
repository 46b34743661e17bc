"""Oscillators, circuits and coupled bodies with hidden curves (:mod:`sklearn_pycc.datasets`)."""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from functools import partial

import numpy as np
import pandas as pd
from sklearn.utils import Bunch

from ..skeleton import Skeleton
from ._generation import (
    add_noise,
    check_n_samples,
    check_noise,
    check_noise_columns,
    check_random_state,
    check_real,
    check_t_span,
)

__all__ = [
    "make_duffing",
    "make_experiments",
    "make_first_order",
    "make_oscillator",
    "make_stick_slip",
    "make_two_dof",
    "make_van_der_pol",
]

_RTOL = 1e-10
_ATOL = 1e-12
_TIME = "t"
_FIRST_ORDER_KINDS = ("rc", "rl")


# -- true curves and input signals (module level, so that they pickle) --------
def _linear_cubic(x, linear: float, cubic: float):
    """``linear * x + cubic * x**3``."""
    return linear * x + cubic * x**3


def _viscous_coulomb(v, damping: float, friction: float, steepness: float):
    """Viscous plus smoothed Coulomb friction ``damping * v + friction * tanh(steepness * v)``."""
    return damping * v + friction * np.tanh(steepness * v)


def _van_der_pol_damping(x, mu: float):
    """Liénard damping of the van der Pol oscillator, ``mu * (x**2 - 1)``."""
    return mu * (x * x - 1.0)


def _rc_capacitance(v):
    """Voltage-dependent capacitance ``1 + 0.5 v**2 / (1 + v**2)``, in [1, 1.5)."""
    v2 = v * v
    return 1.0 + 0.5 * v2 / (1.0 + v2)


def _rl_inductance(i):
    """Saturating inductance ``1.5 / (1 + i**2) + 0.3``, in (0.3, 1.8]."""
    return 1.5 / (1.0 + i * i) + 0.3


def _cosine(t, amplitude: float, omega: float):
    """``amplitude * cos(omega * t)``."""
    return amplitude * np.cos(omega * t)


def _sine(t, amplitude: float, omega: float):
    """``amplitude * sin(omega * t)``."""
    return amplitude * np.sin(omega * t)


# -- shared driver --------------------------------------------------------------
def _generate(
    *,
    equations: list[str],
    functions: Mapping[str, Callable],
    inputs: Mapping[str, Callable],
    y0,
    n_samples,
    t_span,
    noise,
    noise_columns,
    random_state,
    return_truth: bool,
    params: Mapping[str, float] | None = None,
    parametric_equations: list[str] | None = None,
    base_equations: list[str] | None = None,
    hidden: Sequence[str] = (),
    simulate_parametric: bool = False,
    push: tuple[str, float] | None = None,
):
    """Validate, simulate, add noise and package the result of a ``make_*`` function.

    With ``simulate_parametric`` the data come from ``parametric_equations``
    and ``params`` rather than from ``equations`` and ``functions``. With
    ``push = (input, intensity)`` an unmeasured random force is added to
    that input (:func:`_pushed`); the input's column holds it without.
    """
    n_samples = check_n_samples(n_samples)
    start, end = check_t_span(t_span)
    noise = check_noise(noise)
    skeleton = Skeleton(parametric_equations if simulate_parametric else equations)
    columns = [_TIME, *skeleton.states, *skeleton.inputs, *skeleton.derivatives]
    chosen = check_noise_columns(noise_columns, columns, skeleton.states)
    rng = check_random_state(random_state)
    try:
        y0 = tuple(float(v) for v in y0)
    except (TypeError, ValueError):
        raise ValueError(f"y0 must be a sequence of floats, got {y0!r}") from None
    if len(y0) != len(skeleton.states):
        raise ValueError(
            f"y0 must hold {len(skeleton.states)} values, one per state "
            f"({', '.join(skeleton.states)}), got {len(y0)}")
    if not all(math.isfinite(v) for v in y0):
        raise ValueError(f"y0 must hold finite values, got {y0!r}")

    t = np.linspace(start, end, n_samples)
    settings = dict(functions=None if simulate_parametric else functions,
                    params=params if simulate_parametric else None,
                    rtol=_RTOL, atol=_ATOL, return_derivatives=True)
    disturbance = None
    if push is None:
        frame = skeleton.simulate(t, y0, inputs=inputs, **settings)
    else:
        frame, disturbance = _pushed(skeleton, t, y0, inputs, push=push,
                                     random_state=random_state, settings=settings)
    frame = frame[columns].reset_index(drop=True)
    if noise is not None and chosen:
        frame = add_noise(frame, noise, chosen, rng)
    if not return_truth:
        return frame
    truth = Bunch(
        equations=list(equations),
        functions=dict(functions),
        params=dict(params or {}),
        parametric_equations=(list(parametric_equations)
                              if parametric_equations is not None else None),
        inputs=dict(inputs),
        y0=y0,
        base_equations=list(base_equations) if base_equations is not None else None,
        hidden=list(hidden),
    )
    if push is not None:
        truth.disturbance = disturbance
    return frame, truth


#: the random force's grid: this many points per sample interval, joined linearly
_PUSH_GRID = 4


def _pushed(skeleton: Skeleton, t: np.ndarray, y0, inputs: Mapping, *, push: tuple[str, float],
            random_state, settings: dict) -> tuple[pd.DataFrame, np.ndarray]:
    """Simulate with an unmeasured random force added to an input; the force at each sample.

    The force is white noise of the given intensity (its integral over one
    unit of time has that standard deviation) on a grid :data:`_PUSH_GRID`
    times finer than the samples, joined linearly; the simulation runs on
    that grid (every input read there, linearly between its points) and is
    sampled back. Its own stream of ``random_state``: an integer seed gives
    one apart from the measurement noise's.
    """
    name, intensity = push
    if isinstance(random_state, np.random.Generator):
        rng = random_state
    elif random_state is None:
        rng = np.random.default_rng()
    else:
        rng = np.random.default_rng(np.random.SeedSequence([int(random_state), 1]))
    fine = np.linspace(t[0], t[-1], _PUSH_GRID * (len(t) - 1) + 1)
    force = intensity / np.sqrt(fine[1] - fine[0]) * rng.standard_normal(fine.size)
    sampled = {k: np.broadcast_to(np.asarray(v(fine) if callable(v) else v, dtype=float),
                                  fine.shape).copy() for k, v in inputs.items()}
    sampled[name] = sampled[name] + force
    frame = skeleton.simulate(fine, y0, inputs=sampled, input_hold="foh", **settings)
    frame = frame.iloc[::_PUSH_GRID].reset_index(drop=True)
    frame[name] = frame[name] - force[::_PUSH_GRID]
    return frame, force[::_PUSH_GRID]


_SECOND_ORDER = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
#: the linear oscillator every hypothesis loop on a second-order system starts from
_LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
_LINEAR_TWO_DOF = [
    "x1_dot = x3",
    "x2_dot = x4",
    "x3_dot = F_ext - a1 x3 - a2 x1 - a3 (x1 - x2)",
    "x4_dot = - a4 x4 - a5 x2 - a6 (x2 - x1)",
]


# -- public generators ------------------------------------------------------------
def make_stick_slip(
    n_samples: int = 1000,
    t_span: tuple[float, float] = (0.0, 20.0),
    *,
    noise: float | None = None,
    noise_columns: Sequence[str] | None = None,
    random_state: int | np.random.Generator | None = None,
    alpha: float = 1.0,
    beta: float = 0.2,
    delta: float = 0.1,
    mu: float = 0.5,
    steepness: float = 500.0,
    amplitude: float = 1.0,
    omega: float = 1.0,
    y0: Sequence[float] = (0.0, 0.0),
    return_truth: bool = False,
) -> pd.DataFrame | tuple[pd.DataFrame, Bunch]:
    """Forced Duffing oscillator with stick-slip friction (the seed paper's system).

    The system is::

        x1_dot = x2
        x2_dot = F_ext - f1(x2) - f2(x1)

    with friction ``f1(v) = delta*v + mu*tanh(steepness*v)``, spring
    ``f2(x) = alpha*x + beta*x**3`` and input ``F_ext = amplitude*cos(omega*t)``.
    Its parametric form is
    ``x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1 - a5 x1^3`` with
    ``a1=delta, a2=mu, a3=steepness, a4=alpha, a5=beta``.

    Parameters
    ----------
    n_samples : int, default=1000
        Number of equally spaced samples, at least 2.
    t_span : tuple of float, default=(0.0, 20.0)
        Start and end times.
    noise : float, optional
        Signal-to-noise ratio in dB of Gaussian noise added to
        ``noise_columns``; None for noise-free data.
    noise_columns : list of str, optional
        Columns receiving noise (any column but ``t``); default the states.
    random_state : int, numpy.random.Generator or None
        Seed of the noise.
    alpha, beta : float
        Linear and cubic stiffness of the spring.
    delta : float
        Viscous damping.
    mu : float
        Coulomb friction level.
    steepness : float
        Slope of the ``tanh`` smoothing the friction at zero velocity.
    amplitude, omega : float
        Amplitude and angular frequency of the forcing.
    y0 : tuple of float, default=(0.0, 0.0)
        Initial position and velocity.
    return_truth : bool, default=False
        Also return the ground truth.

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``t, x1, x2, F_ext, x1_dot, x2_dot``; derivatives are exact.
    truth : sklearn.utils.Bunch
        Only when ``return_truth``: ``equations``, ``functions``, ``params``
        (``a1`` to ``a5``), ``parametric_equations``, ``inputs``, ``y0``,
        ``base_equations`` and ``hidden``.

    Raises
    ------
    ValueError
        If an argument is invalid; the message names it.
    SimulationError
        If the trajectory diverges.

    Examples
    --------
    >>> from sklearn_pycc.datasets import make_stick_slip
    >>> frame = make_stick_slip(n_samples=200)
    >>> list(frame.columns)
    ['t', 'x1', 'x2', 'F_ext', 'x1_dot', 'x2_dot']

    """
    alpha, beta = check_real("alpha", alpha), check_real("beta", beta)
    delta, mu = check_real("delta", delta), check_real("mu", mu)
    steepness = check_real("steepness", steepness)
    amplitude, omega = check_real("amplitude", amplitude), check_real("omega", omega)
    return _generate(
        equations=list(_SECOND_ORDER),
        functions={
            "f1": partial(_viscous_coulomb, damping=delta, friction=mu, steepness=steepness),
            "f2": partial(_linear_cubic, linear=alpha, cubic=beta),
        },
        inputs={"F_ext": partial(_cosine, amplitude=amplitude, omega=omega)},
        params={"a1": delta, "a2": mu, "a3": steepness, "a4": alpha, "a5": beta},
        parametric_equations=[
            "x1_dot = x2",
            "x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1 - a5 x1^3",
        ],
        base_equations=list(_LINEAR), hidden=("coulomb_friction", "cubic_stiffness"),
        y0=y0, n_samples=n_samples, t_span=t_span, noise=noise, noise_columns=noise_columns,
        random_state=random_state, return_truth=return_truth,
    )


def make_duffing(
    n_samples: int = 2000,
    t_span: tuple[float, float] = (0.0, 100.0),
    *,
    noise: float | None = None,
    noise_columns: Sequence[str] | None = None,
    random_state: int | np.random.Generator | None = None,
    alpha: float = -1.05,
    beta: float = 1.02,
    delta: float = 0.3,
    amplitude: float = 0.5,
    omega: float = 1.2,
    y0: Sequence[float] = (1.0, 0.0),
    return_truth: bool = False,
) -> pd.DataFrame | tuple[pd.DataFrame, Bunch]:
    """Forced Duffing oscillator, chaotic with the default values.

    The system is::

        x1_dot = x2
        x2_dot = F_ext - f1(x2) - f2(x1)

    with damping ``f1(v) = delta*v``, double-well spring
    ``f2(x) = alpha*x + beta*x**3`` and ``F_ext = amplitude*cos(omega*t)``.

    Parameters
    ----------
    n_samples : int, default=2000
        Number of equally spaced samples, at least 2.
    t_span : tuple of float, default=(0.0, 100.0)
        Start and end times.
    noise : float, optional
        Signal-to-noise ratio in dB of Gaussian noise added to
        ``noise_columns``; None for noise-free data.
    noise_columns : list of str, optional
        Columns receiving noise (any column but ``t``); default the states.
    random_state : int, numpy.random.Generator or None
        Seed of the noise.
    alpha, beta : float
        Linear and cubic stiffness (``alpha < 0`` gives two wells).
    delta : float
        Viscous damping.
    amplitude, omega : float
        Amplitude and angular frequency of the forcing.
    y0 : tuple of float, default=(1.0, 0.0)
        Initial position and velocity.
    return_truth : bool, default=False
        Also return the ground truth.

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``t, x1, x2, F_ext, x1_dot, x2_dot``; derivatives are exact.
    truth : sklearn.utils.Bunch
        Only when ``return_truth``: ``equations``, ``functions``, ``params``
        (empty), ``parametric_equations`` (None), ``inputs``, ``y0``, ``base_equations``
        and ``hidden``.

    Raises
    ------
    ValueError
        If an argument is invalid; the message names it.
    SimulationError
        If the trajectory diverges.

    """
    alpha, beta = check_real("alpha", alpha), check_real("beta", beta)
    delta = check_real("delta", delta)
    amplitude, omega = check_real("amplitude", amplitude), check_real("omega", omega)
    return _generate(
        equations=list(_SECOND_ORDER),
        functions={
            "f1": partial(_linear_cubic, linear=delta, cubic=0.0),
            "f2": partial(_linear_cubic, linear=alpha, cubic=beta),
        },
        inputs={"F_ext": partial(_cosine, amplitude=amplitude, omega=omega)},
        base_equations=list(_LINEAR), hidden=("cubic_stiffness",),
        y0=y0, n_samples=n_samples, t_span=t_span, noise=noise, noise_columns=noise_columns,
        random_state=random_state, return_truth=return_truth,
    )


def make_van_der_pol(
    n_samples: int = 2000,
    t_span: tuple[float, float] = (0.0, 60.0),
    *,
    noise: float | None = None,
    noise_columns: Sequence[str] | None = None,
    random_state: int | np.random.Generator | None = None,
    mu: float = 1.0,
    amplitude: float = 1.2,
    omega: float = 0.9,
    y0: Sequence[float] = (1.0, 0.0),
    return_truth: bool = False,
) -> pd.DataFrame | tuple[pd.DataFrame, Bunch]:
    """Forced van der Pol oscillator in Liénard form.

    The system is::

        x1_dot = x2
        x2_dot = F_ext - f1(x1) x2 - f2(x1)

    with position-dependent damping ``f1(x) = mu*(x**2 - 1)``, linear spring
    ``f2(x) = x`` and ``F_ext = amplitude*cos(omega*t)``.

    Parameters
    ----------
    n_samples : int, default=2000
        Number of equally spaced samples, at least 2.
    t_span : tuple of float, default=(0.0, 60.0)
        Start and end times.
    noise : float, optional
        Signal-to-noise ratio in dB of Gaussian noise added to
        ``noise_columns``; None for noise-free data.
    noise_columns : list of str, optional
        Columns receiving noise (any column but ``t``); default the states.
    random_state : int, numpy.random.Generator or None
        Seed of the noise.
    mu : float
        Strength of the nonlinear damping.
    amplitude, omega : float
        Amplitude and angular frequency of the forcing.
    y0 : tuple of float, default=(1.0, 0.0)
        Initial position and velocity.
    return_truth : bool, default=False
        Also return the ground truth.

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``t, x1, x2, F_ext, x1_dot, x2_dot``; derivatives are exact.
    truth : sklearn.utils.Bunch
        Only when ``return_truth``: ``equations``, ``functions``, ``params``
        (empty), ``parametric_equations`` (None), ``inputs``, ``y0``, ``base_equations``
        and ``hidden``.

    Raises
    ------
    ValueError
        If an argument is invalid; the message names it.
    SimulationError
        If the trajectory diverges.

    """
    mu = check_real("mu", mu)
    amplitude, omega = check_real("amplitude", amplitude), check_real("omega", omega)
    return _generate(
        equations=["x1_dot = x2", "x2_dot = F_ext - f1(x1) x2 - f2(x1)"],
        functions={
            "f1": partial(_van_der_pol_damping, mu=mu),
            "f2": partial(_linear_cubic, linear=1.0, cubic=0.0),
        },
        inputs={"F_ext": partial(_cosine, amplitude=amplitude, omega=omega)},
        base_equations=list(_LINEAR), hidden=("position_dependent_damping",),
        y0=y0, n_samples=n_samples, t_span=t_span, noise=noise, noise_columns=noise_columns,
        random_state=random_state, return_truth=return_truth,
    )


def make_first_order(
    n_samples: int = 1000,
    t_span: tuple[float, float] = (0.0, 20.0),
    *,
    kind: str = "rc",
    noise: float | None = None,
    noise_columns: Sequence[str] | None = None,
    random_state: int | np.random.Generator | None = None,
    amplitude: float = 1.5,
    omega: float = 0.5,
    y0: Sequence[float] = (0.0,),
    return_truth: bool = False,
) -> pd.DataFrame | tuple[pd.DataFrame, Bunch]:
    """First-order nonlinear circuit, written unsolved for the derivative.

    The skeleton is ``F_ext = f1(x1) + f2(x1) x1_dot`` with
    ``F_ext = amplitude*sin(omega*t)``; it is simulated by solving for
    ``x1_dot``.

    ``kind="rc"``
        Nonlinear RC parallel circuit driven by a current source: ``x1`` is
        the voltage, ``f1(v) = v + 0.3 v**3`` the current of the nonlinear
        conductance and ``f2(v) = 1 + 0.5 v**2 / (1 + v**2)`` the
        voltage-dependent capacitance.
    ``kind="rl"``
        Nonlinear RL series circuit driven by a voltage source: ``x1`` is the
        current, ``f1(i) = 0.8 i + 0.2 i**3`` the voltage of the nonlinear
        resistor and ``f2(i) = 1.5 / (1 + i**2) + 0.3`` the saturating
        inductance.

    Both ``f2`` are strictly positive, so the equation can always be solved.

    Parameters
    ----------
    n_samples : int, default=1000
        Number of equally spaced samples, at least 2.
    t_span : tuple of float, default=(0.0, 20.0)
        Start and end times.
    kind : {"rc", "rl"}, default="rc"
        Which circuit.
    noise : float, optional
        Signal-to-noise ratio in dB of Gaussian noise added to
        ``noise_columns``; None for noise-free data.
    noise_columns : list of str, optional
        Columns receiving noise (any column but ``t``); default the state.
    random_state : int, numpy.random.Generator or None
        Seed of the noise.
    amplitude, omega : float
        Amplitude and angular frequency of the source.
    y0 : tuple of float, default=(0.0,)
        Initial voltage (RC) or current (RL).
    return_truth : bool, default=False
        Also return the ground truth.

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``t, x1, F_ext, x1_dot``; the derivative is exact.
    truth : sklearn.utils.Bunch
        Only when ``return_truth``: ``equations``, ``functions``, ``params``
        (empty), ``parametric_equations`` (None), ``inputs``, ``y0``, ``base_equations``
        and ``hidden``.

    Raises
    ------
    ValueError
        If an argument is invalid (``kind`` included); the message names it.
    SimulationError
        If the trajectory diverges.

    """
    if kind == "rc":
        functions = {
            "f1": partial(_linear_cubic, linear=1.0, cubic=0.3),
            "f2": _rc_capacitance,
        }
    elif kind == "rl":
        functions = {
            "f1": partial(_linear_cubic, linear=0.8, cubic=0.2),
            "f2": _rl_inductance,
        }
    else:
        raise ValueError(
            f"kind must be one of {', '.join(map(repr, _FIRST_ORDER_KINDS))}, got {kind!r}")
    amplitude, omega = check_real("amplitude", amplitude), check_real("omega", omega)
    return _generate(
        equations=["F_ext = f1(x1) + f2(x1) x1_dot"],
        functions=functions,
        inputs={"F_ext": partial(_sine, amplitude=amplitude, omega=omega)},
        y0=y0, n_samples=n_samples, t_span=t_span, noise=noise, noise_columns=noise_columns,
        random_state=random_state, return_truth=return_truth,
    )


def make_two_dof(
    n_samples: int = 2000,
    t_span: tuple[float, float] = (0.0, 50.0),
    *,
    noise: float | None = None,
    noise_columns: Sequence[str] | None = None,
    random_state: int | np.random.Generator | None = None,
    amplitude: float = 1.0,
    omega: float = 0.8,
    damping1: float = 0.2,
    stiffness1: float = 1.0,
    coupling: float = 0.5,
    coupling_cubic: float = 0.3,
    damping2: float = 0.15,
    stiffness2: float = 1.2,
    y0: Sequence[float] = (0.5, -0.3, 0.0, 0.0),
    return_truth: bool = False,
) -> pd.DataFrame | tuple[pd.DataFrame, Bunch]:
    """Two oscillators joined by a nonlinear spring, the first one forced.

    The system is::

        x1_dot = x3
        x2_dot = x4
        x3_dot = F_ext - f1(x3) - f2(x1) - f3(x1 - x2)
        x4_dot = - f4(x4) - f5(x2) + f3(x1 - x2)

    with positions ``x1, x2``, velocities ``x3, x4``, dampings
    ``f1(v) = damping1*v`` and ``f4(v) = damping2*v``, springs to the ground
    ``f2(x) = stiffness1*x`` and ``f5(x) = stiffness2*x``, coupling spring
    ``f3(d) = coupling*d + coupling_cubic*d**3`` acting on both masses with
    opposite signs, and ``F_ext = amplitude*cos(omega*t)``. Every curve
    passes through the origin.

    Parameters
    ----------
    n_samples : int, default=2000
        Number of equally spaced samples, at least 2.
    t_span : tuple of float, default=(0.0, 50.0)
        Start and end times.
    noise : float, optional
        Signal-to-noise ratio in dB of Gaussian noise added to
        ``noise_columns``; None for noise-free data.
    noise_columns : list of str, optional
        Columns receiving noise (any column but ``t``); default the states.
    random_state : int, numpy.random.Generator or None
        Seed of the noise.
    amplitude, omega : float
        Amplitude and angular frequency of the force on the first mass.
    damping1, stiffness1 : float
        Damping and ground stiffness of the first mass.
    coupling, coupling_cubic : float
        Linear and cubic stiffness of the coupling spring.
    damping2, stiffness2 : float
        Damping and ground stiffness of the second mass.
    y0 : tuple of float, default=(0.5, -0.3, 0.0, 0.0)
        Initial positions and velocities ``(x1, x2, x3, x4)``.
    return_truth : bool, default=False
        Also return the ground truth.

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``t, x1, x2, x3, x4, F_ext, x1_dot, x2_dot, x3_dot, x4_dot``;
        derivatives are exact.
    truth : sklearn.utils.Bunch
        Only when ``return_truth``: ``equations``, ``functions``, ``params``
        (empty), ``parametric_equations`` (None), ``inputs``, ``y0``, ``base_equations``
        and ``hidden``.

    Raises
    ------
    ValueError
        If an argument is invalid; the message names it.
    SimulationError
        If the trajectory diverges.

    """
    amplitude, omega = check_real("amplitude", amplitude), check_real("omega", omega)
    damping1 = check_real("damping1", damping1)
    stiffness1 = check_real("stiffness1", stiffness1)
    coupling = check_real("coupling", coupling)
    coupling_cubic = check_real("coupling_cubic", coupling_cubic)
    damping2 = check_real("damping2", damping2)
    stiffness2 = check_real("stiffness2", stiffness2)
    return _generate(
        equations=[
            "x1_dot = x3",
            "x2_dot = x4",
            "x3_dot = F_ext - f1(x3) - f2(x1) - f3(x1 - x2)",
            "x4_dot = - f4(x4) - f5(x2) + f3(x1 - x2)",
        ],
        functions={
            "f1": partial(_linear_cubic, linear=damping1, cubic=0.0),
            "f2": partial(_linear_cubic, linear=stiffness1, cubic=0.0),
            "f3": partial(_linear_cubic, linear=coupling, cubic=coupling_cubic),
            "f4": partial(_linear_cubic, linear=damping2, cubic=0.0),
            "f5": partial(_linear_cubic, linear=stiffness2, cubic=0.0),
        },
        inputs={"F_ext": partial(_cosine, amplitude=amplitude, omega=omega)},
        base_equations=list(_LINEAR_TWO_DOF), hidden=("coupling",) if coupling_cubic else (),
        y0=y0, n_samples=n_samples, t_span=t_span, noise=noise, noise_columns=noise_columns,
        random_state=random_state, return_truth=return_truth,
    )


#: strengths of the effects :func:`make_oscillator` hides, by default
HIDDEN_DEFAULTS: dict[str, dict[str, float]] = {
    "viscous_damping": {"a1": 0.3},
    "coulomb_friction": {"a1": 0.3, "a2": 20.0},
    "quadratic_drag": {"a1": 0.5},
    "cubic_stiffness": {"a1": 1.0},
    "saturation": {"a1": 1.0, "a2": 1.5},
    "pendulum": {"a1": 1.0},
    "position_dependent_damping": {"a1": 0.5},
    "offset": {"a1": 0.3},
    "asymmetric_viscous_damping": {"a1": 0.05},
    "asymmetric_coulomb_friction": {"a1": 0.1, "a2": 20.0},
    "asymmetric_stiffness": {"a1": 0.3},
    "falling_damping": {"a1": 0.3, "a2": 1.0},
}


def _check_hidden(hidden) -> dict[str, dict[str, float] | None]:
    """``hidden`` as ``{effect name: parameter values or None}``, in the order given."""
    if hidden is None:
        return {}
    if isinstance(hidden, str):
        hidden = [hidden]
    if isinstance(hidden, Mapping):
        items = list(hidden.items())
    else:
        try:
            items = [(name, None) for name in hidden]
        except TypeError:
            raise ValueError(f"hidden must be an effect name, a list of names or a dict of "
                             f"name -> parameters, got {hidden!r}") from None
    out: dict[str, dict[str, float] | None] = {}
    for name, values in items:
        if not isinstance(name, str):
            raise ValueError(f"hidden names effects by their catalogue name, got {name!r}")
        if name in out:
            raise ValueError(f"hidden names {name!r} twice")
        out[name] = None if values is None else dict(values)
    return out


def make_oscillator(
    n_samples: int = 2000,
    t_span: tuple[float, float] = (0.0, 40.0),
    *,
    hidden=("coulomb_friction",),
    noise: float | None = None,
    noise_columns: Sequence[str] | None = None,
    random_state: int | np.random.Generator | None = None,
    damping: float = 0.1,
    stiffness: float = 1.0,
    amplitude: float = 0.3,
    omega: float = 0.8,
    y0: Sequence[float] = (3.0, 0.0),
    disturbance: float | None = None,
    return_truth: bool = False,
) -> pd.DataFrame | tuple[pd.DataFrame, Bunch]:
    """Forced linear oscillator with hidden physical effects from the catalogue.

    The system is the linear oscillator a hypothesis loop starts from, with
    the terms of the ``hidden`` effects (see :mod:`sklearn_pycc.effects`)
    subtracted from the acceleration::

        x1_dot = x2
        x2_dot = F_ext - damping x2 - stiffness x1 - <hidden terms>

    with ``F_ext = amplitude*cos(omega*t)``, position ``x1`` and velocity
    ``x2``. By default the oscillator is released from a large displacement
    under a weak forcing: the free decay sweeps the amplitude, which is what
    tells one damping or stiffness law from another (a single steady
    harmonic response would be matched by an equivalent linear model).

    Parameters
    ----------
    n_samples : int, default=2000
        Number of equally spaced samples, at least 2.
    t_span : tuple of float, default=(0.0, 40.0)
        Start and end times.
    hidden : str, list of str or dict, default=("coulomb_friction",)
        Catalogue names of the hidden effects, or ``{name: {"a1": ..., ...}}``
        with the values of each term's own parameters (written as in the
        catalogue's term). Names alone take the strengths of
        :data:`HIDDEN_DEFAULTS`. Effects act through the velocity, the
        position, both, or nothing (``offset``); an empty list gives the
        plain linear oscillator.
    noise : float, optional
        Signal-to-noise ratio in dB of Gaussian noise added to
        ``noise_columns`` (40 dB is noise of 1 % of the signal's RMS); None
        for noise-free data.
    noise_columns : list of str, optional
        Columns receiving noise (any column but ``t``); default the states.
    random_state : int, numpy.random.Generator or None
        Seed of the noise.
    damping, stiffness : float
        Linear damping and stiffness.
    amplitude, omega : float
        Amplitude and angular frequency of the forcing.
    y0 : tuple of float, default=(3.0, 0.0)
        Initial position and velocity.
    disturbance : float, optional
        Intensity of an unmeasured random force added to ``F_ext`` (process
        noise): white noise whose integral over one unit of time has this
        standard deviation, drawn on a grid four times finer than the
        samples and joined linearly (``random_state`` seeds it). The
        ``F_ext`` column holds the measured force alone.
    return_truth : bool, default=False
        Also return the ground truth.

    Returns
    -------
    frame : pandas.DataFrame
        Columns ``t, x1, x2, F_ext, x1_dot, x2_dot``; derivatives are exact.
    truth : sklearn.utils.Bunch
        Only when ``return_truth``: ``equations`` and
        ``parametric_equations`` (the true skeleton, linear terms ``a1 x2``
        and ``a2 x1`` first, hidden terms after them with fresh indices),
        ``params``, ``functions`` (empty), ``inputs``, ``y0``,
        ``base_equations`` (the linear skeleton), ``hidden`` (the names) and,
        with a ``disturbance``, ``disturbance`` (the random force at each sample).

    Raises
    ------
    ValueError
        If an argument is invalid, an effect is unknown, does not act
        through the velocity or position, or lacks parameter values.
    SimulationError
        If the trajectory diverges.

    Examples
    --------
    >>> from sklearn_pycc.datasets import make_oscillator
    >>> frame, truth = make_oscillator(hidden=["cubic_stiffness"], return_truth=True)
    >>> truth.parametric_equations[1]
    'x2_dot = F_ext - a1 x2 - a2 x1 - a3*x1^3'

    """
    from ..effects import get as get_effect

    damping, stiffness = check_real("damping", damping), check_real("stiffness", stiffness)
    amplitude, omega = check_real("amplitude", amplitude), check_real("omega", omega)
    skeleton = Skeleton(_LINEAR)
    params = {"a1": damping, "a2": stiffness}
    roles = {"velocity": {"v": "x2"}, "position": {"x": "x1"},
             "position_velocity": {"x": "x1", "v": "x2"}, "none": {}}
    chosen = _check_hidden(hidden)
    for name, values in chosen.items():
        try:
            effect = get_effect(name)
        except KeyError as exc:
            raise ValueError(f"hidden: {exc.args[0]}") from None
        if effect.acts_through not in roles:
            raise ValueError(
                f"hidden: {name!r} acts through {effect.acts_through!r}; a single oscillator "
                f"can hide effects acting through {', '.join(map(repr, roles))}")
        if values is None:
            if name not in HIDDEN_DEFAULTS:
                raise ValueError(
                    f"hidden: {name!r} has no default strength; give its parameters, e.g. "
                    f"hidden={{{name!r}: {{'a1': ...}}}}")
            values = HIDDEN_DEFAULTS[name]
        term = effect.term_for(**roles[effect.acts_through])
        own = Skeleton([f"z_dot = {term}"]).params
        if sorted(values) != own:
            raise ValueError(f"hidden: {name!r} has the parameters {own} (term {term!r}), "
                             f"got values for {sorted(values)}")
        extended = skeleton.add_term("x2", term)
        new = [a for a in extended.params if a not in skeleton.params]
        for a, value in zip(new, own):
            params[a] = check_real(f"hidden: {name!r} {value}", values[value])
        skeleton = extended
    intensity = None
    if disturbance is not None:
        intensity = check_real("disturbance", disturbance)
        if intensity < 0:
            raise ValueError(f"disturbance must be non-negative, got {disturbance!r}")
    return _generate(
        equations=list(skeleton.equations),
        functions={},
        inputs={"F_ext": partial(_cosine, amplitude=amplitude, omega=omega)},
        params=params, parametric_equations=list(skeleton.equations),
        base_equations=list(_LINEAR), hidden=list(chosen), simulate_parametric=True,
        y0=y0, n_samples=n_samples, t_span=t_span, noise=noise, noise_columns=noise_columns,
        random_state=random_state, return_truth=return_truth,
        push=None if intensity is None else ("F_ext", intensity),
    )


# -- several experiments in one data set ---------------------------------------
def make_experiments(
    make: Callable,
    settings: Sequence[Mapping] | int,
    *,
    random_state: int | np.random.Generator | None = None,
    return_truth: bool = False,
    **common,
) -> pd.DataFrame | tuple[pd.DataFrame, list[Bunch]]:
    """Several experiments of one system in one tidy DataFrame.

    Parameters
    ----------
    make : callable
        One of the ``make_*`` generators of this module.
    settings : list of dict or int
        Keyword arguments of each experiment (for instance different
        ``amplitude`` and ``omega`` of the forcing). An integer ``n`` gives
        ``n`` experiments whose forcing amplitude grows from 0.5 to 1.5
        times the generator's default and whose frequency falls from 1.2 to
        0.8 times it.
    random_state : int, numpy.random.Generator or None
        Seeds the noise; each experiment draws its own stream from it.
    return_truth : bool, default=False
        Also return each experiment's ground truth.
    **common
        Keyword arguments shared by every experiment (``n_samples``,
        ``t_span``, ``noise``, ``noise_columns``, ...).

    Returns
    -------
    frame : pandas.DataFrame
        The experiments one after the other, with a ``trajectory`` column
        (0, 1, ...) after ``t``; the index runs through.
    truths : list of sklearn.utils.Bunch
        Only when ``return_truth``: one per experiment.

    Raises
    ------
    ValueError
        If ``settings`` is empty, names ``random_state`` or
        ``return_truth``, or an experiment's arguments are invalid (the
        message names the experiment).

    Examples
    --------
    >>> from sklearn_pycc.datasets import make_experiments, make_stick_slip
    >>> frame = make_experiments(make_stick_slip, [{"amplitude": 0.8}, {"amplitude": 1.2}],
    ...                          n_samples=100)
    >>> frame.groupby("trajectory").size().tolist()
    [100, 100]
    """
    if not callable(make):
        raise ValueError(f"make must be a make_* generator, got {make!r}")
    if isinstance(settings, numbers.Integral) and not isinstance(settings, bool):
        settings = _varied_forcing(make, int(settings))
    settings = [dict(item) for item in settings]
    if not settings:
        raise ValueError("settings must hold at least one experiment")
    reserved = {"random_state", "return_truth"}
    for k, item in enumerate([common, *settings]):
        clash = reserved & set(item)
        if clash:
            where = "the shared arguments" if k == 0 else f"experiment {k - 1}"
            raise ValueError(f"{where} set {sorted(clash)[0]!r}; pass it to make_experiments "
                             "itself")
    streams = check_random_state(random_state).spawn(len(settings))
    frames, truths = [], []
    for k, (item, stream) in enumerate(zip(settings, streams)):
        try:
            frame, truth = make(**{**common, **item}, random_state=stream, return_truth=True)
        except (TypeError, ValueError) as error:
            raise ValueError(f"experiment {k} ({item}): {error}") from None
        frame.insert(1, "trajectory", k)
        frames.append(frame)
        truths.append(truth)
    frame = pd.concat(frames, ignore_index=True)
    return (frame, truths) if return_truth else frame


def _varied_forcing(make: Callable, n: int) -> list[dict]:
    if n < 1:
        raise ValueError(f"settings must be a positive number of experiments, got {n}")
    import inspect

    defaults = {name: p.default for name, p in inspect.signature(make).parameters.items()}
    if "amplitude" not in defaults or "omega" not in defaults:
        raise ValueError(f"{getattr(make, '__name__', make)} has no forcing amplitude and "
                         "omega to vary; give settings as a list of dicts")
    scale = np.linspace(0.5, 1.5, n) if n > 1 else np.ones(1)
    speed = np.linspace(1.2, 0.8, n) if n > 1 else np.ones(1)
    return [{"amplitude": float(defaults["amplitude"] * a), "omega": float(defaults["omega"] * w)}
            for a, w in zip(scale, speed)]
