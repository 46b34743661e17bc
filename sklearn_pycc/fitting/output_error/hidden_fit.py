"""Fitting a skeleton with unmeasured states by output error, for every backend.

A skeleton whose states are not all measured has parameters only: the
backend gives a start (its ``hidden_start``), and :func:`fit_hidden` does the
rest, the same for each.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from ...exceptions import RankDeficiencyWarning, StartsWarning
from ...simulation.integration import INPUT_HOLDS
from ..problem import FitResult, Problem
from .couplings import coupling_rates
from .hidden import (
    along_hidden_scale,
    hidden_trajectories,
    initial_table,
    limit_start,
    opened_limits,
    ratio_start,
    rescaled,
    starting_params,
    whole_record_covariance,
)
from .shooting import ShootingPlan, fit_shooting
from .starts import StartContest, noise_floor
from .swapped_speeds import swapped_starts
from .whole_record import WholeRecord

__all__ = ["fit_hidden"]


def fit_hidden(problem: Problem, result: FitResult, *,
               param_init: Mapping[str, float] | None, window: int,
               iterations: int, initial: np.ndarray | None = None) -> FitResult:
    """Output error from ``result`` (a backend's ``hidden_start``), unmeasured states simulated.

    The same for every backend: a skeleton with unmeasured states has parameters only. Multiple
    shooting over the parameters and every window's start (with state limits, once holding the
    starts within them and once not), then every experiment simulated whole from each estimate
    and from each one's best common rescaling, and from a second start whose ratios between the
    parameters were found too (:func:`~sklearn_pycc.fitting.output_error.hidden.ratio_start`);
    the best whole-record fit wins. A start that ``param_init`` gives in full (a refit from a
    fitted model) gets one multiple-shooting pass and is simulated whole itself, with no
    rescaling and no second start. A limit to fit on an unmeasured state is held at its start
    through all that (where the state's scale is free, as a tank's of unknown cross-section,
    any level does as well and the scale is then fixed; where it is not, the level is found
    next), and a last whole-record pass frees it. That start is chosen on the state's course
    with the second start's parameters where there is one (the second start is searched with
    the limit open), as the ratios set the level the state runs at; else with the first's. From
    a guessed start, the fit is then polished once more with an unmeasured stage's speed and
    another's swapped
    (:func:`~sklearn_pycc.fitting.output_error.swapped_speeds.swapped_starts`: a cascade's
    second minimum) and moved along an unmeasured state's scale toward its known limit
    (:func:`~sklearn_pycc.fitting.output_error.hidden.along_hidden_scale`); the best
    whole-record fit wins. Where the problem's hold is to be chosen (``input_hold="auto"``),
    the fit is last polished under each other input hold, and the hold of the best whole-record
    fit is kept (``input_hold_``). ``initial`` gives every state at the start of each
    experiment for the given start (a fit's own), else they are found at rest.
    """
    limits = problem.skeleton.limit_params
    hidden_limits = [a for a in problem.free_params
                     if a in limits and limits[a][0] in problem.hidden]
    # a start that gives every rate (a refit from a fitted model) has its time scale
    # and its ratios; a guessed one gets a second start, its ratios found too
    init = param_init or {}
    given = list(init)
    guessed = any(a not in init and a not in limits for a in problem.free_params)

    def second_start() -> dict | None:
        defaults = {**starting_params(problem, init),
                    **{a: result.params[a] for a in limits if a in result.params}}
        # the ratios set the level an unmeasured state runs at: its limit is placed
        # on the course of the start found with them, the limit open meanwhile
        defaults.update(opened_limits(problem, [a for a in hidden_limits
                                                if a not in given]))
        found = ratio_start(problem, defaults, given)
        return None if found is None else limit_start(problem, found, given)

    # a limit on an unmeasured state is placed with the second start's ratios, found
    # first; otherwise that start is searched only where the others leave more to win
    other = second_start() if guessed and hidden_limits else None
    pinned = {a: float((result.params if other is None else other)[a])
              for a in hidden_limits}
    inner = problem if not pinned else replace(
        problem, fixed_params={**problem.fixed_params, **pinned})
    start = {a: v for a, v in result.params.items() if a not in pinned}
    others = [] if other is None else [{a: v for a, v in other.items() if a not in pinned}]
    contest, info = _multistart(inner, result.functions, start, window, iterations,
                                guessed=guessed, others=others, initial=initial)
    if guessed and not hidden_limits and not contest.settled:
        other = second_start()
        if other is not None:
            first = WholeRecord(inner).first_states(_compiled(inner, result.functions, other))
            contest.try_all([("the parameters' ratios", inner, other, first, False)])
    contest.decide()
    params, first = contest.best[0], contest.best[1]
    if pinned:  # the limits freed: one more start, polished whole
        contest = StartContest(info["substeps"], iterations, rows=contest.rows,
                               floor=contest.floor)
        contest.enter(problem, "limits freed", {**params, **pinned}, first)
    if guessed and not contest.settled:  # a cascade's stages may sit in each other's speed
        for k, (swapped, initial) in enumerate(swapped_starts(problem, contest.best[0],
                                                               contest.best[1],
                                                               info["substeps"])):
            contest.enter(problem, f"stages' speeds swapped {k + 1}", swapped, initial)
    if guessed:  # a state below a known limit its scale should have reached (at the noise
        # floor too: the measured level hardly differs, the parameters do)
        params, first = contest.best[0], contest.best[1]
        moved = along_hidden_scale(problem, params, first, info["substeps"], iterations)
        if moved is not None:
            contest.rows.append({"start": "along the hidden state's scale",
                                 "nrmse_start": np.nan, "nrmse": moved[2],
                                 "polished": "whole", "kept": False})
            contest.best, contest.problem = moved, problem
            for row in contest.rows:
                row["kept"] = row is contest.rows[-1]
    if problem.hold_chosen:  # a held pump or a smooth one: the record tells
        params, first = contest.best[0], contest.best[1]
        contest.try_all([(f"input hold {hold!r}", replace(problem, input_hold=hold), params,
                          first, True) for hold in INPUT_HOLDS if hold != problem.input_hold])
        contest.decide()
    problem = contest.problem or problem
    hold = problem.input_hold
    params, first, info["nrmse_whole"], unseen = contest.best
    disagreement = contest.disagreement()
    info.update(initial_states=first, unseen=unseen, whole_record_starts=len(contest.rows))
    if disagreement and not unseen:
        warnings.warn(f"The starts of the fit disagree: {disagreement}. The record cannot "
                      "tell the two apart; see starts_, and measure longer, with a richer "
                      "input, or write a known value into the skeleton.",
                      StartsWarning, stacklevel=6)
    if unseen:  # one warning, every direction the measurements leave free in it
        warnings.warn(
            f"{', '.join(problem.hidden)} not measured, and the measurements cannot fix "
            f"every parameter: {'; '.join(unseen)}, so only combinations of those are "
            "determined (the values found are one of many). Write a known value or ratio "
            "into the skeleton, or measure the state once.", RankDeficiencyWarning,
            stacklevel=6)
    _warn_runaway(problem, result.functions, params, first, info["substeps"])
    _warn_against_gradient(problem, params)
    table = initial_table(problem, first, problem.skeleton.states)
    attributes = {"shooting_": info, "initial_states_": table, "input_hold_": hold,
                  "starts_": contest.table()}
    covariance = None if unseen or not problem.covariance else whole_record_covariance(
        problem, params, first, info["substeps"])
    if covariance is not None:
        attributes["covariance_"] = covariance
    return FitResult(result.functions, params, attributes)


def _against_gradient(problem: Problem, params: Mapping[str, float]) -> list[str]:
    """The free rates of terms ``a (y - x)`` in the equation of ``x`` that are negative.

    Only those with no lower bound written: a bound the user set is theirs.
    """
    rates = coupling_rates(problem.dynamic)
    return [a for a in rates if a in params and params[a] < 0
            and problem.bounds.get(a, (-np.inf, np.inf))[0] == -np.inf]


def _warn_against_gradient(problem: Problem, params: Mapping[str, float]) -> None:
    """Warn, naming each, where the fit keeps a rate that drives a state away from another."""
    rates = coupling_rates(problem.dynamic)
    for a in _against_gradient(problem, params):
        derivative, state, other = rates[a]
        warnings.warn(
            f"{a} is {params[a]:.4g} in the fit: its term {a} ({other} - {state}) of "
            f"{derivative} then drives {state} away from {other}, a flow against its gradient "
            "(heat from cold to warm, water uphill), which no physical path makes. The fit may "
            f"sit in a wrong minimum (see starts_): write '{a} >= 0' into the constraints, or "
            "check the skeleton's signs.", UserWarning, stacklevel=6)


def _compiled(problem: Problem, functions: Mapping, params: Mapping[str, float]):
    return problem.skeleton.compile(functions, {**problem.fixed_params, **params})


def _multistart(problem: Problem, functions: Mapping, start: Mapping[str, float], window: int,
                iterations: int, *, guessed: bool = True,
                others: Sequence[Mapping[str, float]] = (),
                initial: np.ndarray | None = None) -> tuple[StartContest, dict]:
    """The whole-record fits of ``problem`` from ``start`` and its estimates, as a contest.

    Multiple shooting, then every experiment simulated whole from ``start``,
    from each estimate and from each of ``others`` (more starts, simulated
    whole only), polished as far as each earns (:class:`StartContest`).
    Where ``start`` was ``guessed`` (not a fitted model's parameters),
    multiple shooting runs twice with state limits (once holding the
    windows' starts within them, once not), the start's own whole-record
    pass is left to its estimates, and each estimate's best common
    rescaling is tried too. Returns the contest and the stage's summary.
    """
    names = list(problem.free_params)

    def system_for(theta: np.ndarray):
        values = {**problem.fixed_params, **dict(zip(names, theta))}
        return problem.skeleton.compile(functions, values)

    theta0 = np.array([start[a] for a in names], dtype=float)
    bounds = problem.bounds
    low = np.array([bounds.get(a, (-np.inf, np.inf))[0] for a in names])
    high = np.array([bounds.get(a, (-np.inf, np.inf))[1] for a in names])
    theta0 = np.clip(theta0, low, high)
    first_system = system_for(theta0)
    whole = WholeRecord(problem)
    first = (whole.first_states(first_system) if initial is None
             else np.asarray(initial, dtype=float))
    whole.choose_substeps(first_system, first)
    estimates = [("the start", theta0, first)]  # the start itself, simulated whole
    info = {"substeps": whole.windows.substeps}
    if any(s in problem.measured for s in problem.skeleton.states):
        plan = ShootingPlan(problem, window, hidden=hidden_trajectories(problem, first_system))
        plan.choose_substeps(first_system, plan.columns())
        # the windows' starts held within the states' limits, and left free (where a
        # state sits on its limit much of the time, either may stall); a fitted model's
        # start is refined whole as well, which stands for the second pass
        both = problem.skeleton.limits and guessed
        for limit_starts in (True, False) if both else (True,):
            theta, info = fit_shooting(plan, system_for, theta0, iterations,
                                       bounds=(low, high), limit_starts=limit_starts)
            label = "multiple shooting" + ("" if not both else
                                           " (starts within limits)" if limit_starts
                                           else " (starts free)")
            estimates.append((label, theta, info["initial_states"]))
        # a rate moving a state toward another that came out negative (heat from the walls
        # to the warmer room): once more, such rates held positive
        against = _against_gradient(problem, dict(zip(names, theta))) if guessed else []
        if against:
            low_positive = low.copy()
            low_positive[[names.index(a) for a in against]] = 0.0
            theta, more = fit_shooting(plan, system_for, np.clip(theta0, low_positive, high),
                                       iterations, bounds=(low_positive, high))
            estimates.append(("multiple shooting (couplings positive)", theta,
                              more["initial_states"]))
        if guessed:  # its multiple-shooting estimates stand for it
            estimates = estimates[1:]
    # the windows' joins are soft: a last pass simulates every experiment whole, from
    # each estimate and from its best common rescaling (multiple shooting may settle
    # on the wrong time scale); the best whole-record fit is kept
    starts, seen = [], []
    for label, theta, initial in estimates:
        theta = np.asarray(theta, dtype=float)
        if any(np.allclose(theta, other, rtol=1e-9, atol=0.0) for other in seen):
            continue  # both multiple-shooting passes may end at the same point
        seen.append(theta)
        starts.append((label, dict(zip(names, theta.tolist())), initial))
    for other in others:  # their time scale was searched with their ratios
        theta = np.clip(np.array([other[a] for a in names], dtype=float), low, high)
        starts.append(("the parameters' ratios", dict(zip(names, theta.tolist())),
                       whole.first_states(system_for(theta))))
    entries = [(label, problem, params, initial, False) for label, params, initial in starts]
    contest = StartContest(info["substeps"], iterations, floor=noise_floor(problem))
    contest.try_all(entries)
    if guessed and not contest.settled:  # multiple shooting may sit on the wrong time scale
        for label, params, initial in starts[:len(seen)]:
            other = rescaled(problem, params, initial)
            if other is not None:
                contest.try_all([(f"{label}, rescaled", problem, *other, False)])
    return contest, info


#: a hidden state runs away where its last tenth lies beyond the range of its first half by
#: more than this share of that range (and by far more than any measured state does),
#: still moving away at the end
RUNAWAY = 0.5


def _beyond(values: np.ndarray) -> tuple[float, float, float]:
    """How far the last tenth of ``values`` lies beyond the first half's range, over that range.

    With the first half's least and largest values.
    """
    early, late = values[: values.size // 2], values[-max(values.size // 10, 2):]
    low, high = float(early.min()), float(early.max())
    span = max(high - low, 1e-12 * max(abs(low), abs(high), 1.0))
    return max(float(late.max()) - high, low - float(late.min()), 0.0) / span, low, high


def _still_moving(values: np.ndarray) -> bool:
    """Whether ``values`` move away at their end at least half as fast as over the whole."""
    rows = np.arange(values.size, dtype=float)
    overall = np.polyfit(rows, values, 1)[0]
    tail = max(values.size // 10, 3)
    late = np.polyfit(rows[-tail:], values[-tail:], 1)[0]
    return bool(overall != 0 and late / overall >= 0.5)


def _warn_runaway(problem: Problem, functions: Mapping, params: Mapping[str, float],
                  first: np.ndarray, substeps: int) -> None:
    """Warn where the fit's unmeasured state runs away over the record, naming it.

    The fitted model simulates each experiment whole: an unmeasured state
    whose end lies far beyond the range of its first half and still moves
    away (a tank filling without end, a wall warming past any room), where
    no measured signal drifts alike, fits what is measured by a course no
    sensor checked.
    """
    whole = WholeRecord(problem)
    whole.windows.substeps = substeps
    try:
        course = whole.course(_compiled(problem, functions, params), first)
    except (ValueError, ArithmeticError):
        return
    seen = [np.asarray(v, dtype=float) for v in problem.measured.values()]
    drift = max([_beyond(v[np.isfinite(v)])[0] for v in seen if np.isfinite(v).sum() >= 20]
                or [0.0])
    for state in problem.hidden:
        values = np.asarray(course[state], dtype=float)
        values = values[np.isfinite(values)]
        if values.size < 20:
            continue
        ratio, low, high = _beyond(values)
        if ratio > max(RUNAWAY, 3 * drift) and _still_moving(values):
            warnings.warn(
                f"{state} (not measured) runs away in the fitted model: it ends at "
                f"{float(values[-1]):.4g}, still moving, where over the record's first half "
                f"it held {low:.4g} to {high:.4g}; no measured signal drifts so. What is "
                "measured is fitted by a course no sensor checks: check the skeleton's "
                f"equation of {state} and its parameters' signs (bounds such as 'a1 >= 0').",
                UserWarning, stacklevel=6)
