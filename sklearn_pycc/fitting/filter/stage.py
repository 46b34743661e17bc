"""``fit_mode="filter"``: an output-error fit refined by the extended Kalman filter's likelihood.

The skeleton is read as a stochastic differential equation: every state whose
equation is more than a kinematic identity (``x1_dot = x2`` is exact) is
pushed by its own white noise, whose intensity is fitted with the
numbers the backend writes the fit as (:meth:`Backend.numbers`: the
parameters, and a polynomial curve's coefficients) and the measurement noise
of each measured state. The output-error fit gives the start, and the
noises start at the likeliest of a grid filtered in one pass. The numbers'
covariance comes from the likelihood's curvature.

A state nobody measured starts where the output-error model simulates it,
and each experiment is then filtered whole (one segment): restarted at
every segment, its scale would drift, a direction the measured states
barely see.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import replace

import numpy as np

from ..._utils.progress import Progress, duration
from ...skeleton.nodes import Symbol
from ..numbers import Numbers
from ..problem import FitResult, Problem
from .noises import NoiseLayout, check_measurement_noise, check_process_noise
from .search import GRID_VARIANTS, NOISE_LOG_RANGE, fit_filter, likeliest_noises

__all__ = ["WINDOW", "filter_plan", "filter_stage", "noisy_states", "rounding_floor",
           "search_segments", "smoothing_level"]

#: samples per filtered segment: long against the states' memory under the process noise
WINDOW = 200
#: the largest ``h |lambda|`` of a filter's Runge-Kutta substep: each step's transition is
#: then within 5e-5 of the exact one (a linear skeleton's likelihood within 0.05 of the exact
#: discrete Kalman filter's on a thousand samples, at any sampling)
RATE_STEP = 0.35


def noisy_states(problem: Problem, measured: list[str] | None = None) -> NoiseLayout:
    """Which states a process noise enters, and which intensities are fitted.

    By default every state but a kinematic identity, each with its own
    intensity; the estimator's ``process_noise`` (``problem.process_noise``)
    holds some at given values or shares one among several. With
    ``measured`` (the filter's order), the layout also holds the
    measurement noises the estimator's ``measurement_noise`` gives.
    """
    states = list(problem.skeleton.states)
    default = []
    for eq in problem.skeleton.parsed:
        if not eq.dynamic:
            continue
        identity = isinstance(eq.rhs, Symbol) and eq.rhs.name in states
        if not identity:
            default.append(states.index(eq.state))
    layout = check_process_noise(problem.process_noise, states, default)
    if measured is None:
        return layout
    held = check_measurement_noise(problem.measurement_noise, states, measured)
    return replace(layout, measurement_held=held)


def filter_plan(problem: Problem, system, *, whole: bool):
    """The segments the filter runs over, substeps chosen for ``system``.

    Segments of :data:`WINDOW` samples, or each experiment whole (``whole``).
    A state nobody measured starts where ``system`` simulates it through
    the record; a state the user gave an initial state starts each
    experiment there, with its variance (``problem.initial_state``); a
    missing sample (``problem.missing``) is a missing target.
    """
    from ..output_error.hidden import hidden_trajectories
    from ..output_error.shooting import ShootingPlan

    longest = max(e.n_samples for e in problem.experiments) - 1
    window = longest if whole else int(min(WINDOW, longest))
    hidden = hidden_trajectories(problem, system) if problem.hidden else None
    plan = ShootingPlan(problem, max(window, 2), hidden=hidden)
    plan.choose_substeps(system, plan.columns(), largest_rate_step=RATE_STEP)
    for j, state in enumerate(plan.measured):
        if state in problem.missing:
            plan.targets[..., j][problem.missing[state][plan.rows]] = np.nan
    # each experiment starts at its first sample as measured (not as smoothed) with the
    # spread of the measured samples (their mean square), or where the user said (the plan
    # holds the mean: ShootingPlan.held_start)
    first = plan.first_segments()
    plan.start_variance = np.tile(np.asarray(plan.scale, dtype=float) ** 2,
                                  (plan.n_segments, 1))
    for j, state in zip(plan.measured_index, plan.measured):
        values = problem.measured[state]
        if not plan.held_start[first[0], j]:
            plan.initial[first, j] = values[plan.rows[first, 0]]
        seen = values[~problem.missing[state]] if state in problem.missing else values
        spread = float(np.mean(seen**2))
        if spread > 0:  # a state at 0 throughout keeps a unit spread (the plan's scale)
            plan.start_variance[first, j] = spread
    for state, (_, variance) in problem.initial_state.items():
        plan.start_variance[first, plan.states.index(state)] = variance
    return plan


#: a record of more samples than this, filtered in segments, is searched over a share of them
SEARCH_SHARE_ABOVE = 150_000
#: about how many samples that share holds
SEARCH_SHARE = 50_000


def search_segments(plan) -> np.ndarray | None:
    """The segments a long record's search runs over, or None (the whole record).

    A record filtered in segments (:data:`WINDOW` samples each) whose
    segments hold over :data:`SEARCH_SHARE_ABOVE` samples is searched over
    segments spread evenly through it, about :data:`SEARCH_SHARE` samples
    in all: every experiment's first segment, and every k-th of the rest.
    Its optimum is within a few of the whole record's standard errors of
    the whole record's, which one Newton step on the whole record then
    closes (:func:`~sklearn_pycc.fitting.filter.search.fit_filter`).
    """
    used = int(plan.own.sum())
    if used <= SEARCH_SHARE_ABOVE or plan.n_segments < 2:
        return None
    every = max(round(used / SEARCH_SHARE), 2)
    keep = set(plan.first_segments().tolist()) | set(range(0, plan.n_segments, every))
    if 2 * len(keep) > plan.n_segments:  # hardly a share: the whole record is searched
        return None
    return np.array(sorted(keep))


def rounding_floor(problem: Problem, measured: list[str]) -> np.ndarray:
    """Per measured state, the noise its rounding alone makes: ``step / sqrt(12)``, or 0.

    A quantised sensor (an encoder's counts, an ADC's least bit) reads no
    finer than its step; the filter's measurement noise is searched no
    lower (left free, it can fall orders of magnitude below, the filter
    then following every sample). Missing samples are left out of the
    reading.
    """
    from ...measurements.spectral import find_quantum

    floors = []
    for state in measured:
        values = problem.measured[state]
        if state in problem.missing:
            values = values[~problem.missing[state]]
        quantum = find_quantum(values)
        floors.append(0.0 if quantum is None else float(np.sqrt(quantum.noise_variance)))
    return np.array(floors)


def smoothing_level(problem: Problem, plan) -> np.ndarray:
    """Per measured state, what the differentiation's smoothing took off the record.

    The measurement noise's first guess: at least a thousandth of the state's scale.
    """
    return np.array([
        max(float(np.std(problem.measured[s] - problem.smoothed.get(s, problem.measured[s]))),
            1e-3 * plan.scale[j])
        for s, j in zip(plan.measured, plan.measured_index)])


def filter_stage(problem: Problem, numbers: Numbers, *, iterations: int = 100,
                 verbose: int = 0) -> FitResult:
    """Refine a fit, written as ``numbers``, by the filter's likelihood.

    Returns the fit the refined numbers make, with the attributes
    ``process_noise_`` (state -> intensity: the standard deviation of the
    state's random increment over one unit of time), ``measurement_noise_``
    (measured state -> standard deviation), their standard errors
    ``process_noise_std_`` and ``measurement_noise_std_``, ``covariance_`` (of the labelled
    numbers, from the likelihood's curvature; absent where it is not
    positive definite) and ``filter_`` (``nll``, ``iterations``,
    ``converged``, ``window``, ``segments``, ``searched_segments``: those
    the search ran over, ``held``: the curves kept as the start drew them).
    On a long record (over :data:`SEARCH_SHARE_ABOVE` samples in segments)
    the grid and the search run over an even share of the segments
    (:func:`search_segments`), and the whole record then gives one Newton
    step and the curvature. ``verbose`` shows the search's
    passes; a search that will take minutes says so at its start.
    """
    theta0 = np.clip(numbers.theta0, numbers.low, numbers.high)
    start = numbers.system_for(theta0)
    plan = filter_plan(problem, start, whole=bool(problem.hidden))
    noisy = noisy_states(problem, list(plan.measured))
    mi = plan.measured_index
    # the noises start at the likeliest of a grid about the level the differentiation's
    # smoothing took off the record (the output error would also hold the disturbances'
    # wander: another basin)
    began = time.perf_counter()
    floor = rounding_floor(problem, list(plan.measured))
    level = smoothing_level(problem, plan)
    share = search_segments(plan)
    searched = plan if share is None else plan.segments(share)
    process0, measurement0, _ = likeliest_noises(searched, start, noisy,
                                                 np.maximum(level, floor))
    d = len(theta0) + noisy.n_fitted + len(mi) - len(noisy.measurement_held)
    _say_how_long(time.perf_counter() - began, d, n_samples=int(plan.own.sum()),
                  share=float(searched.own.sum()) / max(float(plan.own.sum()), 1.0),
                  verbose=verbose)
    with Progress("fit_mode='filter'", verbose).bar(None, "pass", "filter") as step:
        theta, q, r, info = fit_filter(searched, numbers.system_for, theta0, process0,
                                       measurement0, noisy=noisy,
                                       bounds=(numbers.low, numbers.high),
                                       typical=numbers.typical, max_iterations=iterations,
                                       step=step, measurement_floor=floor,
                                       whole=None if share is None else plan)
    states = list(plan.states)
    longest = max(float(e.t[-1] - e.t[0]) for e in problem.experiments)
    _warn_at_range_ends(states, q, noisy, list(plan.measured), r,
                        scale=np.asarray(plan.scale, dtype=float), duration=longest,
                        measured_index=list(mi))
    _warn_worse_simulation(problem, plan, (start, numbers.system_for(theta)),
                           q=q, r=r, level=level)
    result = numbers.result_for(theta)
    attributes = {k: v for k, v in result.attributes.items() if k != "covariance_"}
    q_std, r_std = _noise_errors(noisy, q, r, info["search_covariance"], len(theta))
    attributes.update({
        "process_noise_": {states[j]: float(q[j]) for j in range(len(states))},
        "measurement_noise_": {plan.measured[j]: float(r[j]) for j in range(len(mi))},
        "process_noise_std_": {states[j]: float(q_std[j]) for j in range(len(states))},
        "measurement_noise_std_": {plan.measured[j]: float(r_std[j]) for j in range(len(mi))},
        "filter_": {"nll": info["nll"], "iterations": info["iterations"],
                    "converged": info["converged"], "window": plan.window,
                    "segments": plan.n_segments,
                    "searched_segments": searched.n_segments,
                    "held": list(numbers.held)},
    })
    covariance = numbers.covariance(info["covariance"])
    if covariance is not None:
        attributes["covariance_"] = covariance
    return replace(result, attributes=attributes)


#: passes of the filter a search typically takes (its iterations and the curvature's)
TYPICAL_PASSES = 45
#: a filter fit expected to take longer than this (seconds) says so at its start
LONG_FIT = 60.0


def _say_how_long(grid_seconds: float, d: int, *, n_samples: int, share: float,
                  verbose: int) -> None:
    """Warn, unless ``verbose``, where the search will take minutes.

    The grid of noises filtered :data:`GRID_VARIANTS` variants side by
    side in ``grid_seconds`` over a ``share`` of the record; each of the
    search's passes filters ``2 d + 1`` (a number's central differences),
    about :data:`TYPICAL_PASSES` of them, and where the share is not the
    whole record, the whole record's Newton step filters ``2 d + 2`` more.
    """
    variant = grid_seconds / GRID_VARIANTS
    expected = variant * (2 * d + 1) * TYPICAL_PASSES
    if share < 1.0:
        expected += variant / share * (2 * d + 2)
    if expected > LONG_FIT and not verbose:
        warnings.warn(f"the filter's fit of {n_samples:,} samples and {d} numbers will take "
                      f"about {duration(expected)} (one pass of the filter through the record "
                      f"per step of its search); verbose=1 shows its progress",
                      UserWarning, stacklevel=4)


def _noise_errors(layout: NoiseLayout, q: np.ndarray, r: np.ndarray, covariance,
                  p: int) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors of every state's process noise and every measured state's noise.

    The search moves each fitted noise's logarithm; the curvature's
    covariance of those gives a noise's error as its value times its
    logarithm's (to first order). A held noise, or a state not pushed, has
    none (0); where the curvature gave no covariance, a fitted noise's error
    is NaN.
    """
    g = layout.n_fitted
    q_std, r_std = np.zeros(len(q)), np.zeros(len(r))
    log_sd = (np.full(len(layout.measurement_fitted_of(r)) + g, np.nan) if covariance is None
              else np.sqrt(np.maximum(np.diag(covariance)[p:], 0.0)))
    for k, group in enumerate(layout.groups):
        q_std[list(group)] = q[group[0]] * log_sd[k]
    held = dict(layout.measurement_held)
    free = [j for j in range(len(r)) if j not in held]
    r_std[free] = r[free] * log_sd[g:]
    return q_std, r_std


#: how much worse (relative normalised RMSE) the filtered model may simulate the record than
#: its output-error start before a warning says so
WORSE_SIMULATION = 1.1
#: a fitted measurement noise below this share of the level the record shows has collapsed
COLLAPSED_NOISE = 0.3


def simulation_error(problem: Problem, plan, system) -> float:
    """Normalised RMSE of the measured states, each experiment simulated whole from its start.

    Each experiment starts where the filter starts it (``plan.initial``);
    missing samples are left out.
    """
    from ..output_error.whole_record import WholeRecord

    whole = WholeRecord(problem)
    first = np.asarray(plan.initial, dtype=float)[plan.first_segments()]
    whole.choose_substeps(system, first)
    errors = whole.errors(system, first).reshape(-1, len(whole.index) + len(whole.outputs))
    rows = whole.windows.rows[whole.windows.valid]
    seen = np.ones(errors.shape, dtype=bool)
    measured = [s for s in whole.states if s in problem.measured]
    for j, state in enumerate(measured):
        if state in problem.missing:
            seen[:, j] = ~problem.missing[state][rows]
    return float(np.sqrt(np.mean(errors[seen] ** 2)))


def _warn_worse_simulation(problem: Problem, plan, systems, *, q: np.ndarray, r: np.ndarray,
                           level: np.ndarray) -> None:
    """Warn where the filtered model simulates the record worse than its output-error start.

    The filter fits one-step predictions: a process noise lets them follow
    the record where the model's own course drifts, and a measurement noise
    driven below what the record shows makes the filter follow every
    sample. The warning gives both errors and, where it applies, the
    collapsed measurement noise beside the level the record shows.
    """
    before, after = (simulation_error(problem, plan, system) for system in systems)
    if not after > WORSE_SIMULATION * before:
        return
    states = list(plan.states)
    pushed = ", ".join(f"{states[j]}: {q[j]:.3g}" for j in range(len(states)) if q[j] > 0)
    collapsed = [f"{name}: {value:.3g} against {shown:.3g}"
                 for name, value, shown in zip(plan.measured, r, level)
                 if value < COLLAPSED_NOISE * shown]
    why = (f"; the measurement noise it fitted is far below what the record shows "
           f"({'; '.join(collapsed)}), so the filter follows every sample and the model's own "
           f"course matters little to its likelihood (hold it with measurement_noise)"
           if collapsed else "")
    warnings.warn(f"the filter's model simulates the record worse than the output-error fit it "
                  f"started from (normalised RMSE {after:.3g} against {before:.3g}): the filter "
                  f"fits one-step predictions, which the process noise ({pushed or 'none'}) "
                  f"lets follow the record where the model's course drifts{why}. For a model "
                  f"that simulates, fit by output error (fit_mode='simulation')",
                  UserWarning, stacklevel=3)


#: a fitted noise whose effect over the record is below this share of its state's scale is
#: at the search's floor (it starts no lower than 1e-12, and a flat likelihood leaves it there)
NEGLIGIBLE_NOISE = 1e-6


def _warn_at_range_ends(states: list[str], q: np.ndarray, layout: NoiseLayout,
                        measured: list[str], r: np.ndarray, *, scale: np.ndarray,
                        duration: float, measured_index: list[int]) -> None:
    """Warn of each fitted noise the search left at an end of its range.

    At the floor: a process noise whose wander over the record
    (``q sqrt(duration)``), or a measurement noise, below
    :data:`NEGLIGIBLE_NOISE` of its state's scale; the record cannot tell it
    from none. At the ceiling: the search's largest intensity, a noise that
    swamps the states. Its value, its standard error and the bands built on
    it (``smooth``, ``predict_ahead``) are then not to be trusted.
    """
    high = np.exp(NOISE_LOG_RANGE[1] - 0.5)
    root = np.sqrt(max(duration, 0.0))
    fitted = [(f"the process noise of {', '.join(states[j] for j in group)}", q[group[0]],
               q[group[0]] * root / max(min(scale[j] for j in group), 1e-300))
              for group in layout.groups]
    fitted += [(f"the measurement noise of {name}", value, value / max(scale[j], 1e-300))
               for name, value, j in zip(measured, r, measured_index)]
    ends = [f"{what} ({value:.3g}, at the {'ceiling' if value >= high else 'floor'})"
            for what, value, share in fitted if value >= high or share < NEGLIGIBLE_NOISE]
    if ends:
        warnings.warn(f"the filter's search ended at an end of its range for {'; '.join(ends)}: "
                      "the record cannot tell such a noise from none (or from one that "
                      "swamps the states); its value and the bands smooth and predict_ahead "
                      "draw with it are not to be trusted (hold it with process_noise, or "
                      "fit by output error)", UserWarning, stacklevel=2)
