"""Unmeasured states: whether the measurements can see them, and where to start them.

A state no sensor reads is fitted by output error on the measured states,
its value at the start of each experiment a fitted number. Before that
stage it needs a trajectory to start the shooting windows from: the
starting model is simulated over each experiment from the hidden states'
equilibrium with the first sample (or from zero when there is none).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ...skeleton.nodes import Symbol, walk
from ..problem import Problem
from ..uncertainty.covariance import sandwich_covariance
from .projected_start import projected_start
from .whole_record import ESCAPED, WholeRecord, state_bounds, within_limits, zero_curves

__all__ = ["START_FACTORS", "along_hidden_scale", "check_visible", "hidden_trajectories",
           "initial_table", "limit_start", "opened_limits", "rate_span", "rates_on", "ratio_start",
           "rescaled", "scale_family", "scaled_start", "settled_error", "single_shooting",
           "start_factors",
           "starting_params", "unseen_directions", "whole_record_covariance"]


def _reads(skeleton) -> dict[str, set[str]]:
    """State or static output -> the states its equation's right-hand side reads."""
    states = set(skeleton.states)
    equations = [*skeleton.parsed, *(eq for eq in skeleton.algebraic if eq.output is not None)]
    return {eq.state or eq.output:
            {n.name for n in walk(eq.expression) if isinstance(n, Symbol)} & states
            for eq in equations}


def check_visible(skeleton, hidden: Sequence[str]) -> None:
    """Refuse an unmeasured state that nothing measured depends on, naming it and why.

    A hidden state is seen when a measured state's equation or a static
    output's (a sensor's reading: ``acc = ...``) reads it, or reads another
    hidden state that is seen.
    """
    reads = _reads(skeleton)
    measured = [s for s in skeleton.states if s not in hidden] + list(skeleton.outputs)
    if not measured:
        raise ValueError(f"no state of the skeleton is measured ({', '.join(hidden)} have no "
                         "column in X) and it has no static output (a sensor's equation such "
                         "as 'y = a1 x1'): there is nothing to fit the model to")
    seen: set[str] = set()
    frontier = list(measured)
    while frontier:
        state = frontier.pop()
        for other in reads.get(state, ()):
            if other in hidden and other not in seen:
                seen.add(other)
                frontier.append(other)
    for state in hidden:
        if state not in seen:
            readers = [s for s, r in reads.items() if state in r and s != state]
            why = (f"only the equations of {', '.join(readers)} read it, and they are "
                   "unmeasured too" if readers else "no other equation reads it")
            raise ValueError(
                f"{state} is not measured and cannot be seen from the measurements: {why}. "
                f"Nothing measured ({', '.join(measured)}) depends on it, so its equation "
                "cannot be fitted; measure it, or leave its equation out")


def starting_params(problem: Problem, param_init: Mapping[str, float] | None) -> dict:
    """The free parameters' starting values: ``param_init``, else 1 (moved into the bounds)."""
    given = problem.starting_values(param_init)
    out = {}
    for name in problem.free_params:
        low, high = problem.bounds.get(name, (-np.inf, np.inf))
        # param_init was checked against the bounds: only the default may need moving
        out[name] = float(np.clip(given.get(name, 1.0), low, high))
    return out


def hidden_trajectories(problem: Problem, system) -> dict[str, np.ndarray]:
    """Each hidden state on every row of the record, simulated by ``system``.

    Every experiment starts at its first sample, the hidden states at
    :func:`equilibrium` there, and is integrated whole (the measured states
    run free too: only the hidden ones are kept). Past an escape a value
    keeps the last finite one.
    """
    whole = WholeRecord(problem)
    first = whole.first_states(system)
    whole.choose_substeps(system, first)
    windows = whole.windows
    with np.errstate(all="ignore"):
        simulated, _ = windows.simulate(system, first)
    n = whole.n_rows
    out = {}
    for s in problem.hidden:
        q = whole.states.index(s)
        values = np.zeros(n)
        for k in range(windows.n_segments):
            valid = windows.valid[k]
            path = pd.Series(simulated[k, valid, q]).where(np.isfinite(simulated[k, valid, q]))
            values[windows.rows[k, valid]] = path.ffill().fillna(first[k, q]).to_numpy()
        out[s] = values
    return out


def initial_table(problem: Problem, first: np.ndarray, states: Sequence[str]) -> pd.DataFrame:
    """The hidden states at the start of each experiment, one row per experiment.

    ``first`` holds every state at the start of each experiment, in the
    order of ``states``.
    """
    columns = [list(states).index(s) for s in problem.hidden]
    index = pd.Index([k if e.label is None else e.label
                      for k, e in enumerate(problem.experiments)], name="experiment")
    return pd.DataFrame(np.asarray(first, dtype=float)[:, columns], index=index,
                        columns=list(problem.hidden))


#: common factors of the starting parameters tried before output error (param_init aside),
#: for a record sampled every time unit over a thousand: :func:`start_factors` moves them
#: to the record's own time scales
START_FACTORS = 10.0 ** np.arange(-4.0, 2.01, 0.5)


def rate_span(problem: Problem) -> tuple[float, float] | None:
    """Powers of ten of the slowest and the fastest rate the record can show, in its time unit.

    A tenth of one over its longest experiment, and one over its median
    sampling step (a state faster than that settles within a sample); None
    for a record with fewer than two times. Grids laid from the slow end in
    steps of a fixed size sit at the same places whatever the unit of time.
    """
    timed = [e for e in problem.experiments if e.n_samples > 1]
    steps = np.concatenate([np.diff(e.t) for e in timed]) if timed else np.zeros(0)
    steps = steps[steps > 0]
    if not steps.size:
        return None
    longest = max(float(e.t[-1] - e.t[0]) for e in timed)
    return float(np.log10(0.1 / longest)), float(np.log10(1.0 / float(np.median(steps))))


def start_factors(problem: Problem) -> np.ndarray:
    """Common factors of the default start, spanning the rates the record can show.

    The default start (every parameter 1) runs at one per time unit, so
    the factors follow the unit the time is written in: half decades from
    the slow end of :func:`rate_span` to half a decade past its fast end.
    """
    span = rate_span(problem)
    if span is None:
        return START_FACTORS
    slow, fast = span
    return 10.0 ** (slow + np.arange(0.0, fast - slow + 0.51, 0.5))


#: common factors of the multiple-shooting estimate tried before the whole-record pass
RESCALE_FACTORS = 10.0 ** (np.arange(-10, 11) / 10)

#: the share of each experiment's first rows a start is not judged on: there a wrongly
#: guessed initial value of an unmeasured state still shows
SETTLING = 0.25


def _scaled(problem: Problem, params: Mapping[str, float], free: Sequence[str],
            factor: float) -> dict[str, float] | None:
    """``params`` with ``free`` scaled by ``factor``; None where that leaves their bounds."""
    trial = {a: (v * factor if a in free else v) for a, v in params.items()}
    low_high = [problem.bounds.get(a, (-np.inf, np.inf)) for a in trial]
    if any(not lo <= v <= hi for v, (lo, hi) in zip(trial.values(), low_high)):
        return None
    return trial


def settled_error(whole: WholeRecord, problem: Problem, params: Mapping[str, float],
                   first: np.ndarray | None = None) -> tuple[float, np.ndarray | None]:
    """How well ``params`` simulate the record past each experiment's first rows.

    Every experiment starts from ``first`` (by default at rest with its
    first sample); returns the RMS of the scaled errors, ``inf`` where the
    model cannot be integrated, and the initial states used.
    """
    system = problem.skeleton.compile(zero_curves(problem), {**problem.fixed_params, **params})
    if first is None:
        first = whole.first_states(system)
    try:
        whole.choose_substeps(system, first)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return np.inf, None
    return float(np.sqrt(np.mean(whole.errors(system, first, skip=SETTLING) ** 2))), first


def scaled_start(problem: Problem, params: Mapping[str, float],
                 given: Sequence[str]) -> dict[str, float]:
    """The starting parameters with those not ``given`` scaled by the best common factor.

    An unmeasured state leaves no equation error to start from, and the
    default start (every parameter 1) may run the model on another time
    scale than the record's. Each factor of :func:`start_factors` is tried
    on the parameters ``param_init`` did not give, by simulating every
    experiment whole from rest; the factor of the smallest error wins.
    """
    limits = problem.skeleton.limit_params
    free = [a for a in params if a not in given and a not in limits]
    open_ends = opened_limits(problem, [a for a in params if a in limits and a not in given])
    params = {**params, **open_ends}  # a limit to fit waits for the time scale
    if not free:
        return limit_start(problem, params, given)
    whole = WholeRecord(problem)
    best, best_error = dict(params), np.inf
    for factor in start_factors(problem):
        trial = _scaled(problem, params, free, factor)
        error = np.inf if trial is None else settled_error(whole, problem, trial)[0]
        if error < best_error:
            best, best_error = trial, error
    return limit_start(problem, best, given)


def ratio_start(problem: Problem, params: Mapping[str, float],
                given: Sequence[str]) -> dict[str, float] | None:
    """A second start, for the ratios :func:`scaled_start` leaves at their defaults.

    :func:`~sklearn_pycc.fitting.output_error.projected_start.projected_start` from
    ``params`` (the default start, with the limits to fit where :func:`scaled_start` put them),
    each point judged as :func:`scaled_start` judges its factors; None
    where the skeleton has no linear parameters to project out.
    """
    whole = WholeRecord(problem)
    span = rate_span(problem)
    # whole decades over the rates the record can show (the default start is 1 each)
    grid = None if span is None else span[0] + np.arange(0.0, span[1] - span[0] + 0.01)
    found = projected_start(problem, params, given,
                            lambda trial: settled_error(whole, problem, trial)[0], grid=grid)
    return None if found is None else found[0]


#: where a limit to fit starts before its own start is chosen (no state reaches it)
OPEN_LIMIT = 1e12

def opened_limits(problem: Problem, names: Sequence[str]) -> dict[str, float]:
    """The limits to fit ``names`` put out of the states' reach (within their bounds).

    An upper end at :data:`OPEN_LIMIT`, a lower one at ``-OPEN_LIMIT``.
    """
    limits = problem.skeleton.limit_params
    return {a: float(np.clip(-OPEN_LIMIT if limits[a][1] == "low" else OPEN_LIMIT,
                             *problem.bounds.get(a, (-np.inf, np.inf)))) for a in names}


#: quantiles of a state, simulated without its limit, where a limit to fit may start
LIMIT_QUANTILES = (0.3, 0.5, 0.7, 0.8, 0.9, 0.95)


def limit_start(problem: Problem, params: Mapping[str, float],
                given: Sequence[str]) -> dict[str, float]:
    """The starting value of each limit to fit on an unmeasured state (``x1 <= a5``).

    The limit's parameter moves the fit only where the state reaches it: a
    start above everything the state does would stay there. The model is
    simulated with the limit open, and the limit is tried at quantiles of
    the state's course (:data:`LIMIT_QUANTILES`) and just beyond its
    extreme; the value whose simulation follows the record best (past each
    experiment's first rows) is the start. Limits are chosen one at a time;
    a measured state's starts at the smoothed state's extreme.
    """
    params = dict(params)
    limits = problem.skeleton.limit_params
    chosen = [a for a in params if a in limits and a not in given]
    if not chosen:
        return params
    whole = WholeRecord(problem)
    for name in chosen:
        state, side = limits[name]
        if state in problem.measured:  # it shows where it stops
            values = np.asarray(problem.smoothed.get(state, problem.measured[state]))
            params[name] = float(values.max() if side == "high" else values.min())
            continue
        system = problem.skeleton.compile(zero_curves(problem),
                                          {**problem.fixed_params, **params})
        course = hidden_trajectories(problem, system)[state]
        course = course[np.isfinite(course)]
        if course.size == 0:
            continue
        spread = float(np.ptp(course)) or 1.0
        levels = np.quantile(course, LIMIT_QUANTILES if side == "high"
                             else 1 - np.asarray(LIMIT_QUANTILES))
        beyond = course.max() + 0.1 * spread if side == "high" else course.min() - 0.1 * spread
        best, best_error = params[name], np.inf
        for level in [*levels, beyond]:
            trial = _scaled(problem, {**params, name: float(level)}, (), 1.0)
            error = np.inf if trial is None else settled_error(whole, problem, trial)[0]
            if error < best_error:
                best, best_error = float(level), error
        params[name] = best
    return params


def rescaled(problem: Problem, params: Mapping[str, float],
             first: np.ndarray) -> tuple[dict[str, float], np.ndarray] | None:
    """The best common rescaling of the multiple-shooting estimate, if one simulates better.

    Multiple shooting fits each window's shape, and with an unmeasured
    state it can settle on about the right ratios of the parameters on the
    wrong time scale (a cascade three times too slow, its upper tank
    started empty); single shooting from there creeps along a valley. Each
    factor of :data:`RESCALE_FACTORS` times every free parameter is judged
    by whole-record simulation past the first rows, the experiments started
    at rest and from the estimate's initial states ``first`` (within the
    states' limits); None when no factor but 1 does best.
    """
    whole = WholeRecord(problem)
    names = [a for a in params if a not in problem.skeleton.limit_params]  # rates, not levels
    given = np.clip(first, *state_bounds(problem.skeleton))
    best, best_error = None, np.inf
    for factor in RESCALE_FACTORS:
        trial = _scaled(problem, params, names, factor)
        if trial is None:
            continue
        for first_guess in (None, given):
            error, used = settled_error(whole, problem, trial, first_guess)
            if error < best_error:
                best, best_error = (None if factor == 1 else (trial, used)), error
    return best


#: relative fall of the whole-record cost below which single shooting stops: a parameter
#: moved by its standard error changes the cost of n samples by about 1/n of itself, far
#: more than this on any record up to 10^5 samples (the last steps along a slow valley
#: took seconds and moved nothing the record can tell)
WHOLE_RECORD_FTOL = 1e-6


def single_shooting(problem: Problem, params: Mapping[str, float], first: np.ndarray,
                    substeps: int, max_iterations: int, *,
                    max_evaluations: int | None = None
                    ) -> tuple[dict, np.ndarray, float, list[str]]:
    """Polish the parameters and each experiment's initial state by whole-record simulation.

    Multiple shooting (the stage before) joins its windows only up to a
    weighted defect, which an unmeasured state can use to absorb what the
    model misses; simulating every experiment whole from its initial state
    makes the trajectory exact. Only the free parameters and the initial
    states are unknowns (a skeleton with unmeasured states has no curves).
    At most ``max_iterations`` times the unknowns plus one evaluations of the
    record, or ``max_evaluations`` where given (a start polished on trial).

    Returns
    -------
    params : dict
    first : ndarray of shape (n_experiments, n_states)
    nrmse : float
        Normalised RMSE of the measured states along the whole record.
    unseen : list of str
        Directions of the parameters and initial states that the
        measurements do not see (:func:`unseen_directions`), in words.
    """
    whole = WholeRecord(problem)
    whole.windows.substeps = int(substeps)
    names, residuals, low, high = whole.unknowns(first.shape)
    p = len(names)
    z0 = np.clip(whole.packed([float(params[a]) for a in names], first), low, high)
    # least squares bumps each unknown by a share of itself (diff_step), the same in any
    # unit, and one at 0 by a share of 1; a start a hair from 0 (a state guessed at rest,
    # 1e-19) would be bumped by nothing the record can see, and stay there: it starts at 0
    sizes = np.r_[np.zeros(p), whole.packed([], _state_sizes(whole, problem, params, first))]
    z0 = np.where(np.abs(z0) < 1e-9 * sizes, 0.0, z0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        solution = least_squares(residuals, z0, bounds=(low, high), x_scale="jac",
                                 diff_step=1.5e-8,
                                 max_nfev=(int(max_iterations) * (len(z0) + 1)
                                           if max_evaluations is None
                                           else int(max_evaluations)),
                                 ftol=WHOLE_RECORD_FTOL)
    z = solution.x if solution.cost <= 0.5 * float(np.sum(residuals(z0) ** 2)) else z0
    # a start beyond a fitted limit (x1(0) above a rim a5) simulates as one at it: say so
    fitted = problem.skeleton.compile(zero_curves(problem),
                                      {**problem.fixed_params, **dict(zip(names, z[:p]))})
    z = whole.packed(z[:p], within_limits(fitted, whole.first_of(z[p:], first.shape)))
    error = residuals(z)
    free = whole.free(first.shape)
    labels = names + [f"{s}(0)" if first.shape[0] == 1 else f"{s}(0) of experiment {e}"
                      for e in range(first.shape[0]) for q, s in enumerate(whole.states)
                      if free[e, q]]
    # where the model escapes, the errors are held at a cap that no unknown moves
    escaped = bool(np.any(error == ESCAPED))
    unseen = [] if escaped else unseen_directions(solution.jac, z, labels, problem.hidden)
    return (dict(zip(names, z[:p].tolist())), whole.first_of(z[p:], first.shape),
            float(np.sqrt(np.mean(error ** 2))), unseen)


def _state_sizes(whole: WholeRecord, problem: Problem, params: Mapping[str, float],
                 first: np.ndarray) -> np.ndarray:
    """Each state's RMS along the record simulated from ``first``, per experiment's start.

    Shaped like ``first``; 0 where the simulation gives no finite value.
    """
    system = problem.skeleton.compile(zero_curves(problem), {**problem.fixed_params, **params})
    try:
        with np.errstate(all="ignore"):
            course = whole.course(system, np.asarray(first, dtype=float))
    except (ValueError, ArithmeticError):
        return np.zeros(np.shape(first))
    sizes = [float(np.sqrt(np.nanmean(np.asarray(course[s], dtype=float) ** 2)))
             for s in whole.states]
    sizes = np.where(np.isfinite(sizes), sizes, 0.0)
    return np.broadcast_to(sizes, np.shape(first)).copy()


#: shares of the record an unmeasured state below its known limit is moved, along its
#: scale's family, to spend at the limit (each move then polished)
LIMIT_SHARES = (0.02, 0.05, 0.15)

#: a family of parameters leaves the measured states unchanged when its first-order
#: residual is below this share of the equations' rates
FAMILY_TOLERANCE = 1e-6


def rates_on(problem: Problem, values: Mapping[str, float],
             columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """Every state's rate, then every static output, at ``columns``' rows under ``values``.

    ``columns`` holds every state, input and ``t`` (a course on the
    record's rows); the free parameters are ``values``, the fixed ones the
    problem's. NaN where the model cannot be evaluated.
    """
    system = problem.skeleton.compile(zero_curves(problem), {**problem.fixed_params, **values})
    n = len(columns["t"])
    with np.errstate(all="ignore"):
        derivatives = system.evaluate(columns, n, hold=False)
        static = system.evaluate_outputs(columns, n) if system.outputs else np.zeros((n, 0))
    return np.concatenate([derivatives, static], axis=1)


def scale_family(problem: Problem, params: Mapping[str, float], state: str,
                 course: Mapping[str, np.ndarray]) -> dict[str, float] | None:
    """The powers ``k`` with which ``state -> c state``, ``a -> a c^k`` keeps what is measured.

    Linearised at ``c = 1`` on ``course`` (every state, input and ``t`` on
    the record's rows): the measured states' rates and the static outputs
    unchanged, the other unmeasured states' too, ``state``'s rate times
    ``c``. Solved by least squares over the rows; None where no powers of
    the free parameters (limits aside) do it to :data:`FAMILY_TOLERANCE`
    (the state's scale is then seen, or moved otherwise).
    """
    skeleton = problem.skeleton
    names = [a for a in problem.free_params if a not in skeleton.limit_params]
    if not names:
        return None
    q = list(skeleton.states).index(state)
    base = rates_on(problem, params, course)
    step = 1e-6
    design = []
    for a in names:  # d rates / d log a
        up, down = dict(params), dict(params)
        up[a], down[a] = params[a] * (1 + step), params[a] * (1 - step)
        design.append((rates_on(problem, up, course) - rates_on(problem, down, course))
                      / (2 * step))
    up, down = dict(course), dict(course)
    up[state], down[state] = course[state] * (1 + step), course[state] * (1 - step)
    # d rates / d log state
    moved = (rates_on(problem, params, up) - rates_on(problem, params, down)) / (2 * step)
    target = np.zeros_like(base)
    target[:, q] = base[:, q]
    b = target - moved
    scale = np.nanstd(base, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    A = np.stack([d / scale for d in design], axis=-1).reshape(-1, len(names))
    b = (b / scale).ravel()
    keep = np.isfinite(b) & np.all(np.isfinite(A), axis=1)
    if keep.sum() <= len(names):
        return None
    powers = np.linalg.lstsq(A[keep], b[keep], rcond=None)[0]
    residual = float(np.sqrt(np.mean((A[keep] @ powers - b[keep]) ** 2)))
    if not residual < FAMILY_TOLERANCE:
        return None
    return dict(zip(names, powers.tolist()))


def along_hidden_scale(problem: Problem, params: Mapping[str, float], first: np.ndarray,
                       substeps: int, max_iterations: int
                       ) -> tuple[dict, np.ndarray, float, list[str]] | None:
    """A better whole-record fit found by moving an unmeasured state's scale, if there is one.

    Where an unmeasured state's scale is free but for a limit at a known
    level (a tank of unknown cross-section with a known rim), a fit can end
    with the state running below its limit, on the family that the limit
    alone should pick from. Each such state, at its limit on almost no row,
    is moved along that family (:func:`scale_family`: the measured states
    stay as they are while it does not reach the limit) until it spends each
    share of :data:`LIMIT_SHARES` of the record there, each experiment's
    initial value with it, and each move is polished by
    :func:`single_shooting`. Returns the best polished fit where it beats
    the fit, else None.
    """
    skeleton = problem.skeleton
    limited = [s for s in problem.hidden
               if any(not isinstance(end, str) and np.isfinite(end)
                      for end in skeleton.limits.get(s, (-np.inf, np.inf)))]
    if not limited:
        return None
    whole = WholeRecord(problem)
    whole.windows.substeps = int(substeps)
    system = skeleton.compile(zero_curves(problem), {**problem.fixed_params, **params})
    course = whole.course(system, first)
    low, high = state_bounds(skeleton)
    fitted = float(np.sqrt(np.mean(whole.errors(system, first) ** 2)))
    best = None
    for state in limited:
        q = whole.states.index(state)
        values = course[state][np.isfinite(course[state])]
        # a limit at zero stays where it is when the state is rescaled: only the others
        ends = [end for end in (low[q], high[q]) if np.isfinite(end) and end != 0]
        reached = [np.mean(values >= end if end == high[q] else values <= end)
                   for end in ends]
        if not values.size or not ends or max(reached) > LIMIT_SHARES[0] / 2:
            continue  # the limit is reached: it holds the scale
        powers = scale_family(problem, params, state, course)
        if powers is None:
            continue
        for share in LIMIT_SHARES:
            # the factor that puts that share of the course beyond each end
            levels = [np.quantile(values, 1 - share if end == high[q] else share)
                      for end in ends]
            factors = [end / level for end, level in zip(ends, levels)
                       if level != 0 and end / level > 0]
            for c in factors:
                trial = {a: (v * c ** powers[a] if a in powers else v)
                         for a, v in params.items()}
                if any(not lo <= trial[a] <= hi for a, (lo, hi) in problem.bounds.items()
                       if a in trial):
                    continue
                start = first.copy()
                start[:, q] = np.clip(first[:, q] * c, low[q], high[q])
                found = single_shooting(problem, trial, start, substeps, max_iterations)
                if found[2] < (fitted if best is None else best[2]):
                    best = found
    return best


#: relative step of the central differences behind a whole-record fit's covariance: a
#: state limit's events are located, and the solver's steps chosen, to tolerances that a
#: smaller step turns into noise in the Jacobian (at 1e-5, the slow lower tank's draw 6
#: read a1 to 0.24 % where refits on redrawn noise spread it by 3 to 4 %; 1e-4 and 1e-3
#: both read 3.4-3.5 %)
COVARIANCE_STEP = 1e-3


def whole_record_covariance(problem: Problem, params: Mapping[str, float], first: np.ndarray,
                            substeps: int) -> pd.DataFrame | None:
    """Covariance of the free parameters of a whole-record fit, the initial states marginalised.

    The least-squares sandwich of the simulation errors (Newey-West over
    each experiment's samples, so coloured measurement noise widens it) in
    the parameters and every experiment's initial state, linearised at the
    fit by central differences (:data:`COVARIANCE_STEP`); an unknown on its
    bound is held there. Call it only where the measurements see every
    direction (no ``unseen`` from :func:`single_shooting`): otherwise the
    estimate is one of many and no spread describes it.

    Returns
    -------
    DataFrame or None
        Indexed by the free parameters; None when there are none or the
        model escapes near the fit.
    """
    if not problem.free_params:
        return None
    whole = WholeRecord(problem)
    whole.windows.substeps = int(substeps)
    names, residuals, low, high = whole.unknowns(first.shape)
    p = len(names)
    z = whole.packed([float(params[a]) for a in names], first)
    steps = COVARIANCE_STEP * np.where(z != 0, np.abs(z), 1.0)
    # an unknown a step from its bound is held there (the fit could not move it across)
    held = [np.eye(z.size)[j] for j in range(z.size)
            if z[j] - steps[j] < low[j] or z[j] + steps[j] > high[j]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = residuals(z)
        columns = []
        for j, h in enumerate(steps):
            up, down = z.copy(), z.copy()
            up[j] += h
            down[j] -= h
            ahead, behind = residuals(up), residuals(down)
            if np.any(ahead == ESCAPED) or np.any(behind == ESCAPED):
                return None  # the model escapes beside the fit: no linearisation holds
            columns.append((ahead - behind) / (2 * h))
    J = np.column_stack(columns)
    if np.any(r == ESCAPED) or not np.all(np.isfinite(J)):
        return None
    per_experiment = whole.windows.valid.sum(axis=1)
    n, m = int(per_experiment.sum()), whole.targets.shape[-1]
    # rows come sample by sample (each sample's outputs together); the sandwich reads them
    # output by output, each block in time order
    order = np.arange(n * m).reshape(n, m).T.ravel()
    groups = np.repeat(np.arange(len(per_experiment)), per_experiment)
    # unknowns of very different sizes (a rate of 0.02, a level of 10): each column to unit
    # length, so that the pseudo-inverse drops only what the data truly leave unseen
    norms = np.linalg.norm(J, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    cov, lag = sandwich_covariance(J[order] / norms, r[order], n, groups,
                                   np.array(held) if held else None)
    cov = cov / np.outer(norms, norms)
    frame = pd.DataFrame(cov[:p, :p], index=names, columns=names)
    frame.attrs["lag"] = lag
    return frame


#: a direction of the parameters (in relative terms) along which the measurements change
#: less than this share of the most they change along any is not seen by them
UNSEEN = 1e-6


def unseen_directions(jacobian: np.ndarray, z: np.ndarray, labels: Sequence[str],
                      hidden: Sequence[str]) -> list[str]:
    """Directions of the unknowns that the measured states do not see, in words.

    The Jacobian of the measured states' errors with respect to the
    unknowns, each column scaled to unit norm: a singular value below
    :data:`UNSEEN` times the largest is a direction the data cannot fix,
    such as the scale of an unmeasured state that free parameters absorb.
    It is told as relative changes (``c`` to some power) of the unknowns it
    moves.
    """
    J = np.asarray(jacobian, dtype=float)
    if not np.all(np.isfinite(J)) or J.shape[0] < J.shape[1]:
        return []
    norms = np.linalg.norm(J, axis=0)
    blind = norms == 0  # an unknown nothing measured responds to at all
    norms[blind] = 1.0
    _, sigma, Vt = np.linalg.svd(J / norms, full_matrices=False)
    out = []
    for k in np.flatnonzero(sigma < UNSEEN * sigma[0]):
        step = Vt[k] / norms  # the change of each unknown along the direction
        sizes = np.abs(np.asarray(z, dtype=float))
        moved = np.abs(Vt[k]) > 0.05 * np.abs(Vt[k]).max()
        if np.any(moved & (sizes == 0)):  # no relative change to tell: name them
            out.append(f"{' and '.join(labels[j] for j in np.flatnonzero(moved))} together")
            continue
        relative = np.where(sizes > 0, step / np.where(sizes > 0, sizes, 1.0), 0.0)
        involved = np.flatnonzero(np.abs(relative) > 0.05 * np.abs(relative).max())
        anchor = next((j for j in involved
                       if any(labels[j].startswith(f"{s}(0)") for s in hidden)), involved[0])
        powers = relative / relative[anchor]
        moves = [f"{labels[j]} by " + ("c" if abs(powers[j] - 1) < 1e-3
                                        else f"c^{powers[j]:.3g}") for j in involved]
        listed = ", ".join(moves[:-1]) + " and " + moves[-1] if len(moves) > 1 else moves[0]
        out.append(f"scaling {listed} (any c > 0) leaves every measured state as it is")
    return out
