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

import warnings
from dataclasses import replace

import numpy as np

from ...skeleton.nodes import Symbol
from ..numbers import Numbers
from ..problem import FitResult, Problem
from .kalman import NOISE_LOG_RANGE, fit_filter, likeliest_noises
from .noises import NoiseLayout, check_process_noise

__all__ = ["WINDOW", "filter_plan", "filter_stage", "noisy_states", "smoothing_level"]

#: samples per filtered segment: long against the states' memory under the process noise
WINDOW = 200


def noisy_states(problem: Problem) -> NoiseLayout:
    """Which states a process noise enters, and which intensities are fitted.

    By default every state but a kinematic identity, each with its own
    intensity; the estimator's ``process_noise`` (``problem.process_noise``)
    holds some at given values or shares one among several.
    """
    states = list(problem.skeleton.states)
    default = []
    for eq in problem.skeleton.parsed:
        if not eq.dynamic:
            continue
        identity = isinstance(eq.rhs, Symbol) and eq.rhs.name in states
        if not identity:
            default.append(states.index(eq.state))
    return check_process_noise(problem.process_noise, states, default)


def filter_plan(problem: Problem, system, *, whole: bool):
    """The segments the filter runs over, substeps chosen for ``system``.

    Segments of :data:`WINDOW` samples, or each experiment whole (``whole``).
    A state nobody measured starts where ``system`` simulates it through
    the record.
    """
    from ..output_error.hidden import hidden_trajectories
    from ..output_error.shooting import ShootingPlan

    longest = max(e.n_samples for e in problem.experiments) - 1
    window = longest if whole else int(min(WINDOW, longest))
    hidden = hidden_trajectories(problem, system) if problem.hidden else None
    plan = ShootingPlan(problem, max(window, 2), hidden=hidden)
    plan.choose_substeps(system, plan.columns())
    return plan


def smoothing_level(problem: Problem, plan) -> np.ndarray:
    """Per measured state, what the differentiation's smoothing took off the record.

    The measurement noise's first guess: at least a thousandth of the state's scale.
    """
    return np.array([
        max(float(np.std(problem.measured[s] - problem.smoothed.get(s, problem.measured[s]))),
            1e-3 * plan.scale[j])
        for s, j in zip(plan.measured, plan.measured_index)])


def filter_stage(problem: Problem, numbers: Numbers, *, iterations: int = 100) -> FitResult:
    """Refine a fit, written as ``numbers``, by the filter's likelihood.

    Returns the fit the refined numbers make, with the attributes
    ``process_noise_`` (state -> intensity: the standard deviation of the
    state's random increment over one unit of time), ``measurement_noise_``
    (measured state -> standard deviation), ``covariance_`` (of the labelled
    numbers, from the likelihood's curvature; absent where it is not
    positive definite) and ``filter_`` (``nll``, ``iterations``,
    ``converged``, ``window``, ``segments``, ``held``: the
    curves kept as the start drew them).
    """
    theta0 = np.clip(numbers.theta0, numbers.low, numbers.high)
    start = numbers.system_for(theta0)
    plan = filter_plan(problem, start, whole=bool(problem.hidden))
    noisy = noisy_states(problem)
    mi = plan.measured_index
    # the noises start at the likeliest of a grid about the level the differentiation's
    # smoothing took off the record (the output error would also hold the disturbances'
    # wander: another basin)
    process0, measurement0, _ = likeliest_noises(plan, start, noisy,
                                                 smoothing_level(problem, plan))
    theta, q, r, info = fit_filter(plan, numbers.system_for, theta0, process0, measurement0,
                                   noisy=noisy, bounds=(numbers.low, numbers.high),
                                   typical=numbers.typical, max_iterations=iterations)
    states = list(plan.states)
    duration = max(float(e.t[-1] - e.t[0]) for e in problem.experiments)
    _warn_at_range_ends(states, q, noisy, list(plan.measured), r,
                        scale=np.asarray(plan.scale, dtype=float), duration=duration,
                        measured_index=list(mi))
    result = numbers.result_for(theta)
    attributes = {k: v for k, v in result.attributes.items() if k != "covariance_"}
    attributes.update({
        "process_noise_": {states[j]: float(q[j]) for j in range(len(states))},
        "measurement_noise_": {plan.measured[j]: float(r[j]) for j in range(len(mi))},
        "filter_": {"nll": info["nll"], "iterations": info["iterations"],
                    "converged": info["converged"], "window": plan.window,
                    "segments": plan.n_segments,
                    "held": list(numbers.held)},
    })
    covariance = numbers.covariance(info["covariance"])
    if covariance is not None:
        attributes["covariance_"] = covariance
    return replace(result, attributes=attributes)


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
