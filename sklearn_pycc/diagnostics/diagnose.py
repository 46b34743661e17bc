"""Compare a fitted model with measurements, find where it fails and what effect is missing."""

from __future__ import annotations

import math
import warnings
from dataclasses import fields
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils._param_validation import Interval, validate_params
from sklearn.utils.validation import check_is_fitted

from .._utils.randomness import check_seed_source
from ..exceptions import SkeletonError
from ..fitting.fingerprint import fitted_on
from ..measurements.measurement import unwrap
from ..measurements.reconstruct import unmeasured_states
from ..measurements.record import Record
from ..simulation.integration import judged_step_limit
from ..skeleton import Bound, Skeleton
from ._candidates import (
    TIE,
    Candidate,
    enumerate_candidates,
    enumerate_moves,
    extend,
    refit_candidate,
    screen_candidates,
)
from ._data import TIME, check_units, read_measurements
from ._detection import detection_limits
from ._failures import (
    ResidualMap,
    explaining_variables,
    residual_map,
    worst_windows,
)
from ._held_out import held_out_check
from ._metrics import error_table_row, rmse
from ._open_curves import OpenCurve, formula_candidates, open_candidates, probes
from ._physics import implausible_terms
from ._refit import prepared
from ._roles import EquationRoles, equation_roles
from ._stability import Stability, selection_stability
from ._trajectories import Divergence, Horizon, horizon_of, simulate_against
from .report import Diagnosis, Suggestion

__all__ = ["Diagnosis", "Suggestion", "diagnose"]

_RANKING_COLUMNS = [
    "equation", "move", "variable", "effect", "score", "suggested_term", "curve_term", "n_params",
    "error_removed", "delta_bic", "rmse_before", "rmse_after", "simulation_rmse",
    "held_out_change", "held_out_wins", "stability", "plausible", "refit", "explained", "note",
]
#: a candidate whose simulation error is at most this share of the model's is worth a
#: held-out check even when it removes little of the derivative residual
SIMULATION_GAIN = 0.5
#: how many candidates are checked on held-out data, best first, until one is confirmed
N_HELD_OUT = 2
#: a simpler effect whose held-out error is within this share of a confirmed leader's
#: (same equation and variable) is named instead
PARSIMONY = 0.05
#: least relative fall of the whole record's output error that an effect must bring before
#: the held-out folds judge it (a model fitted by output error): folds fitted on short
#: blocks can favour a term that one trajectory through the whole record does not
WHOLE_RECORD_GAIN = 0.01
#: most relative rise of the whole record's output error that a removal may bring (a model
#: fitted by output error): a removal is a step to a simpler skeleton that a later round
#: may complete (a viscous term that stood in for a falling damping), so only a clear
#: rise blocks it (a light damping under a quadratic drag raised it 18 %)
REMOVAL_WHOLE_RECORD = 0.1
#: least fall of the BIC that removes a term when nothing is held out
REMOVAL_BIC = 2.0
#: removals refitted, the least costly first, and the most a removal may raise the residual
#: before the refit (a term the model needs raises it far more)
N_REMOVE = 2
REMOVAL_SCREEN = 0.5
#: a removal needs a model that predicts held-out derivatives within this share of their
#: spread: where noise swamps them, every fitted term is biased, and a simulation may do
#: better without a real term (a light damping fitted too large)
REMOVAL_SKILL = 0.5


@validate_params({
    "n_refit": [Interval(Integral, 0, None, closed="left")],
    "min_improvement": [Interval(Real, 0, 1, closed="left")],
    "bic_threshold": [Real],
    "simulate": ["boolean"],
    "max_steps": [Interval(Integral, 1, None, closed="left"), None],
    "held_out": ["boolean"],
    "n_bootstrap": [Integral],
    "n_jobs": [Integral, None],
    "units": [dict, None],
    "open_curves": ["boolean"],
}, prefer_skip_nested_validation=False)  # the model's refits validate their own settings
def diagnose(model, X, y=None, *, n_refit: int = 5, min_improvement: float = 0.1,
             bic_threshold: float = 10.0, simulate: bool = True,
             max_steps: int | None = None, horizon="auto",
             held_out: bool = True, n_bootstrap: int = 100,
             random_state=0, n_jobs: int | None = None, units=None,
             open_curves: bool = True) -> Diagnosis:
    """Compare a fitted model with measurements and name the physical effect it lacks.

    The diagnosis has three parts:

    *compare*
        derivative residuals per equation, and the model simulated from each
        experiment's measured initial state with its measured inputs, against
        the measured states (RMSE, normalised RMSE, R², fit %);
    *where it fails*
        the time windows with the largest error, residual maps over position
        x velocity, and for each equation the share of the residual variance
        each variable explains (states, inputs, differences of positions,
        ``x^2 v`` for oscillators, time);
    *which effect is missing*
        every effect of :mod:`sklearn_pycc.effects` that can enter a
        non-kinematic equation (through its velocity, position, both, the
        difference to another position, time, or as a constant) and that the
        skeleton cannot already represent is fitted to the residual; the
        ``n_refit`` most promising are refitted inside the extended skeleton
        with a clone of ``model``, ranked by the change of the Bayesian
        information criterion of the derivative residual, and checked for
        plausibility: the added term must play its physical role (a friction
        term must remove energy; a term many times larger than the
        derivative it explains is absurd), and so must every other term of
        the refitted model (see :attr:`Diagnosis.implausible`). A plausible
        refit that lowers the BIC by more than ``bic_threshold`` and removes
        at least ``min_improvement`` of the residual (or simulates clearly
        better) is then checked on data its fit did not see: the model with
        and without it is fitted without each fold (the experiments, or
        three folds of interleaved blocks in time) and compared on it, by the horizon-limited
        simulation error (the derivatives' when there is no time). The
        first of the two leading candidates that lowers the held-out error
        becomes :attr:`Diagnosis.best` (or a simpler effect through the same
        variable that does within 5 % as well held out). Replacements of a
        term by an effect of the same role compete alike; when nothing is to
        add or swap, a term whose removal loses nothing held out is
        suggested for removal. When the catalogue is exhausted, each role's
        terms give way to a free curve (``open_curves``): one that lowers
        the held-out error by 5 % or more means something outside the
        catalogue is missing, and the symbolic engine proposes a formula
        for it. Otherwise nothing is missing. A refit is judged on what it changes: terms the model
        itself already puts against their role do not condemn it. On long
        records with coloured noise the BIC alone calls almost any term
        significant; the held-out check does not.

    A model whose skeleton has states ``X`` neither measures nor lets be
    reconstructed (a tank's level no sensor reads) is judged by simulating
    each experiment whole from :meth:`estimate_initial_state
    <sklearn_pycc.PolyCCRegressor.estimate_initial_state>` and comparing what
    is measured; the candidates are a hard limit on each state that has
    none (``overflow``), refitted by output error and confirmed on each half
    of the record (``held_out``), and the diagnosis is an
    ``UnmeasuredDiagnosis`` (a :class:`Diagnosis` without derivatives,
    residual maps or resamples: ``horizon``, ``n_refit``, ``n_bootstrap``,
    ``open_curves``, ``simulate``, ``max_steps`` and ``n_jobs`` do not apply).

    Parameters
    ----------
    model : CCRegressor
        A fitted model of any backend; it is not modified.
    X : DataFrame
        Measured states and inputs by name; ``t`` to simulate, ``trajectory``
        to separate experiments.
    y : DataFrame or array, optional
        Measured derivatives ``NAME_dot``. When None they are read from
        ``X`` if present there, else estimated from the states by a
        Savitzky-Golay derivative within each experiment.
    n_refit : int, default=5
        How many candidate effects are refitted inside the extended skeleton
        (each refit costs one fit of ``model``).
    min_improvement : float, default=0.1
        Least share of the residual an effect must remove to be suggested.
    bic_threshold : float, default=10.0
        Least decrease of the BIC an effect must bring (10 is "very strong
        evidence").
    simulate : bool, default=True
        Simulate the model and the leading candidates (needs ``t``).
    max_steps : int, optional
        Solver step limit per whole-experiment simulation (``horizon=None``);
        default 50 per sample plus 10000. A simulation stopped by it (or
        diverging) is reported as a failure, as is a window of the horizon
        that leaves the states' range.
    horizon : "auto", float or None, default="auto"
        Simulate windows of this time, each restarted from the measured
        (estimated) state, and pool their errors: the open-loop simulation
        of an integrator drifts, a lightly damped phase slips and chaos
        separates over a whole record, whatever the model. ``"auto"``
        chooses it from the model and the record (two periods of its
        oscillation, or three time constants; see :attr:`Diagnosis.horizon`),
        and the same horizon judges every candidate; None simulates whole
        experiments.
    held_out : bool, default=True
        Confirm the leading candidates on held-out folds before one is
        suggested (each check costs two fits per fold; refits are by output
        error when ``model`` was fitted so). False decides on the in-sample
        criteria alone.
    n_bootstrap : int, default=100
        Resamples of the record on which the choice is made again, for the
        ``stability`` column of the ranking and the summary's "wins in 97 of
        100 resamples". Each resample draws blocks of consecutive samples
        within each experiment (whole experiments when there are ten or
        more), and the diagnosis's rules choose among the same refits from
        their residuals on the resampled rows: no refits, so it costs
        little. A suggestion that wins few resamples rests on a margin the
        noise could undo. 0 leaves the column NaN.
    random_state : int, RandomState, Generator or None, default=0
        Seeds the resamples (fixed by default, so that the same record
        gives the same report).
    units : dict of str -> str, optional
        Units of the columns (``{"x1": "m", "F": "N"}``), merged over
        ``X.attrs["units"]``; they label the tables, the summary and the
        figures.
    open_curves : bool, default=True
        Before saying nothing is missing, replace the terms of each role (a
        second-order equation's restoring force ``f(x)``, its friction
        ``f(v)``, its damping ``g(x) v``; a first-order equation's
        dependence on its state) by a free curve fitted with ``model``'s
        backend, and suggest it (``move="open"``, with
        :attr:`Suggestion.curve` and :attr:`Suggestion.formula`) when it
        lowers the held-out error clearly.
    n_jobs : int or None, default=None
        Refit the candidates in parallel with joblib (None: one at a time;
        -1: every core; a ``joblib.parallel_backend("dask")`` context sends
        them to a cluster). The report does not depend on it.

    Returns
    -------
    Diagnosis

    Raises
    ------
    NotFittedError
        If ``model`` is not fitted.
    ValueError
        If ``X`` lacks a column of the skeleton or holds non-finite values.

    Examples
    --------
    >>> from sklearn_pycc import PolyCCRegressor, datasets, diagnose
    >>> frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], return_truth=True)
    >>> model = PolyCCRegressor(equations=truth.base_equations)
    >>> model = model.fit(frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]])
    >>> report = diagnose(model, frame)
    >>> report.best.effect, report.best.equation
    ('cubic_stiffness', 'x2_dot')
    """
    _check_settings(bic_threshold, n_bootstrap, random_state, n_jobs)
    check_is_fitted(model, "skeleton_")
    skeleton = model.skeleton_
    record = X  # a Measurement keeps the derivatives it has estimated for the next use
    X, y, measurement = unwrap(X, y, who="diagnose")
    if measurement is not None and units is None:
        units = measurement.units or None
    units = check_units(units, X, skeleton)
    # states neither measured nor reconstructed by a kinematic equation from a measured one
    hidden = [] if not isinstance(X, pd.DataFrame) else unmeasured_states(
        skeleton, {c: X[c] for c in X.columns if X[c].notna().any()})
    if hidden:
        from ._unmeasured import diagnose_unmeasured

        if TIME not in X.columns:
            raise ValueError(f"{', '.join(hidden)} not measured: the diagnosis simulates the "
                             "model, and X has no time column 't'")
        return diagnose_unmeasured(model, X, min_improvement=min_improvement,
                                   bic_threshold=bic_threshold, held_out=held_out,
                                   units=units, notes=[], measurement=measurement)
    settings = model.get_params()
    data = read_measurements(skeleton, record, None if measurement is not None else y,
                             settings.get("differentiation", "auto"),
                             bool(settings.get("smooth_states", True)))
    states, derivs = skeleton.states, skeleton.derivatives
    notes = []
    if data.estimated:
        notes.append(f"y was not given: the derivatives were estimated ({data.source}).")

    predicted = data.predict(model)
    residuals = data.derivatives - predicted
    derivative_table = pd.DataFrame(
        [error_table_row(data.derivatives[:, j], predicted[:, j]) for j in range(len(derivs))],
        index=pd.Index(derivs, name="equation"))

    # -- simulation ---------------------------------------------------------------
    steps = max_steps or judged_step_limit(data.n_samples)
    run_simulation = simulate and data.has_time
    window = horizon_of(model, data, horizon) if run_simulation else None
    if simulate and not run_simulation:
        notes.append("X has no time column 't': the model was not simulated.")
    measured_states = np.column_stack([data.columns[s] for s in states])
    simulated, divergences, trajectory_table, simulation_frame = _simulated_record(
        model, data, window, steps, measured_states, units=units, notes=notes)
    simulation_rmse = math.nan if simulated is None else rmse(measured_states, simulated)

    # -- where it fails -----------------------------------------------------------------
    roles = equation_roles(skeleton)
    explained, variables = explaining_variables(residuals, roles, data, states,
                                                skeleton.inputs)
    spread = np.std(measured_states, axis=0)
    spread[spread == 0] = 1.0
    sim_error = (None if simulated is None
                 else np.mean(((simulated - measured_states) / spread) ** 2, axis=1))
    target_spread = np.std(data.derivatives, axis=0)
    target_spread[target_spread == 0] = 1.0
    failing = [r.index for r in roles] or list(range(len(derivs)))
    deriv_error = np.mean((residuals[:, failing] / target_spread[failing]) ** 2, axis=1)
    windows = worst_windows(data, sim_error, deriv_error, divergences)
    maps = {r.derivative: _map_of(r, residuals, data, skeleton.inputs) for r in roles}
    maps = {k: v for k, v in maps.items() if v is not None}

    # -- which effect is missing -------------------------------------------------------
    candidates = enumerate_candidates(skeleton, roles, data.has_time)
    candidates += enumerate_moves(skeleton, roles, data.has_time)
    for candidate in candidates:
        extend(skeleton, candidate)
    screen_candidates(candidates, data, residuals, states, model=model)
    rss_before = np.sum(residuals**2, axis=0)
    screened = sorted((c for c in candidates if math.isfinite(c.screen_bic)
                       and c.move != "remove"), key=lambda c: c.screen_bic)
    removals = sorted((c for c in candidates if c.move == "remove"),
                      key=lambda c: c.screen_bic)
    implausible = implausible_terms(model, data)
    baseline = frozenset((item.equation, item.role) for item in implausible)
    leaders = _leaders(screened, n_refit)
    _refit_all(leaders, model, data, residuals, rss_before, baseline=baseline, n_jobs=n_jobs)
    refitted = [c for c in leaders if c.refit is not None]
    if run_simulation:
        _simulate_leaders(refitted, data, measured_states, window, steps,
                          base_divergences=divergences)
    ordered = _ordered([c for c in candidates if c.move != "remove"])
    eligible = _eligible(ordered, min_improvement, bic_threshold, simulation_rmse)
    judge = window if run_simulation else None
    cache: dict = {}  # the model's own held-out errors, by fold, for every check
    chosen = _decide(eligible, model, data, judge, failing, steps=steps, n_jobs=n_jobs,
                     cache=cache, record=X) \
        if held_out else (eligible[0] if eligible else None)
    if chosen is None:
        # nothing to add or swap in: is a term of the skeleton superfluous?
        _refit_all([c for c in removals if c.screen_removed > -REMOVAL_SCREEN][:N_REMOVE],
                   model, data, residuals, rss_before, baseline=baseline, n_jobs=n_jobs)
        chosen = _decide_removal(removals, model, data, judge, steps, held_out=held_out,
                                 n_jobs=n_jobs,
                                 record=X, cache=cache)
    ordered += _ordered(removals)
    formula, opened = None, []
    if chosen is None and open_curves:
        # the catalogue is exhausted: would a free curve in place of a role's terms do better?
        opened = open_candidates(skeleton, roles)
        for candidate in opened:
            extend(skeleton, candidate)
        _refit_all(opened, model, data, residuals, rss_before, baseline=baseline, n_jobs=n_jobs)
        if run_simulation:
            _simulate_leaders([c for c in opened if c.refit is not None], data,
                              measured_states, window, steps, base_divergences=divergences)
        opened = _ordered(opened)
        # a curve that does not simulate the record itself clearly better will not do so
        # on data it has not seen: spare the held-out fits
        promising = [c for c in _eligible(opened, min_improvement, bic_threshold,
                                          simulation_rmse)
                     if not run_simulation or not math.isfinite(simulation_rmse)
                     or c.simulation_rmse <= (1 - OPEN_GAIN) * simulation_rmse]
        chosen = _decide_open(promising, model, data, judge, failing, steps=steps,
                              held_out=held_out, n_jobs=n_jobs,
                              cache=cache, record=X)
        if chosen is not None:
            formula = _formula(chosen, skeleton, model, data, residuals, rss_before=rss_before,
                               baseline=baseline,
                               horizon=judge, equations=failing, steps=steps, held_out=held_out,
                               n_jobs=n_jobs, cache=cache)
        candidates += opened
        ordered += opened
    if chosen is not None:
        ordered.remove(chosen)
        ordered.insert(0, chosen)
    stability = _stability(ordered, residuals, data, min_improvement, bic_threshold,
                           simulation_rmse=simulation_rmse, n_resamples=int(n_bootstrap),
                           random_state=random_state)
    ranking = _ranking(ordered, explained, stability)
    tried = probes(opened, model, chosen, formula)
    best = None if chosen is None else _suggestion(chosen, skeleton, model, formula, tried)
    measured = [s for s in states if s in X.columns]
    detection = {} if best is not None or trajectory_table.empty else detection_limits(
        X, measured, {s: float(trajectory_table.loc[s, "rmse"]) for s in measured},
        data.n_samples)
    return Diagnosis(model, derivative_table, trajectory_table, simulation_frame,
                     pd.DataFrame(residuals, columns=derivs), divergences, windows, explained,
                     maps, ranking, best, simulation_rmse, notes, window, implausible,
                     units, measured, tried, candidates, data,
                     variables, stability, len(X) - data.n_samples, detection)



def _check_settings(bic_threshold, n_bootstrap, random_state, n_jobs) -> None:
    """What :func:`diagnose`'s ``validate_params`` cannot say of its settings."""
    if not math.isfinite(bic_threshold):
        raise ValueError(f"bic_threshold must be a finite number, got {bic_threshold!r}")
    if isinstance(n_bootstrap, bool) or n_bootstrap < 0 or n_bootstrap == 1 \
            or n_bootstrap > MAX_RESAMPLES:
        raise ValueError("n_bootstrap must be 0 (no resamples) or an integer from 2 to "
                         f"{MAX_RESAMPLES:,}, got {n_bootstrap!r}")
    check_seed_source(random_state)
    if n_jobs == 0 or isinstance(n_jobs, bool):
        raise ValueError(f"n_jobs must be None or a non-zero integer, got {n_jobs!r}")


def _simulated_record(model, data: Record, window: Horizon | None, steps: int,
                      measured_states: np.ndarray, *, units: dict, notes: list[str]):
    """The model simulated against the record over ``window`` (None: not simulated).

    Returns ``(simulated, divergences, trajectory_table, simulation_frame)``;
    the simulation's warnings go to ``notes``.
    """
    trajectory_table = pd.DataFrame(columns=["rmse", "nrmse", "r2", "fit_percent"])
    if window is None:
        return None, [], trajectory_table, pd.DataFrame()
    simulated, divergences, warned = simulate_against(model, data, window, max_steps=steps)
    notes.extend(warned)
    if simulated is None:
        return None, divergences, trajectory_table, pd.DataFrame()
    states = model.skeleton_.states
    trajectory_table = pd.DataFrame(
        [error_table_row(measured_states[:, j], simulated[:, j])
         for j in range(len(states))], index=pd.Index(states, name="state"))
    trajectory_table["unit"] = [units.get(s, "") for s in states]
    columns = {TIME: data.columns[TIME]}
    if "trajectory" in data.X.columns:
        columns["trajectory"] = data.X["trajectory"].to_numpy()
    for j, s in enumerate(states):
        columns[s] = measured_states[:, j]
        columns[f"{s}_sim"] = simulated[:, j]
    return simulated, divergences, trajectory_table, pd.DataFrame(columns)


def _refitted(model, candidate: Candidate, data: Record, residuals: np.ndarray,
              rss_before: np.ndarray, *, baseline: frozenset) -> Candidate:
    refit_candidate(model, candidate, data, residuals, rss_before, baseline=baseline)
    return candidate


def _refit_all(candidates: list[Candidate], model, data: Record, residuals: np.ndarray,
               rss_before: np.ndarray, *, baseline: frozenset, n_jobs: int | None) -> None:
    """Refit ``candidates`` in place, in parallel when ``n_jobs`` asks for it.

    A worker process refits a copy; its findings are written back onto the
    candidate the diagnosis holds.
    """
    if n_jobs is None or n_jobs == 1 or len(candidates) < 2:
        for candidate in candidates:
            refit_candidate(model, candidate, data, residuals, rss_before, baseline=baseline)
        return
    from joblib import Parallel, delayed

    done = Parallel(n_jobs=n_jobs)(
        delayed(_refitted)(model, c, data, residuals, rss_before, baseline=baseline)
        for c in candidates)
    for candidate, result in zip(candidates, done):
        if result is not candidate:
            for item in fields(Candidate):
                setattr(candidate, item.name, getattr(result, item.name))


#: most resamples a diagnosis draws (each is a pass over the refits' residuals)
MAX_RESAMPLES = 100_000
#: replacements refitted beside the ``n_refit`` additions
N_REPLACE = 2


def _leaders(screened: list[Candidate], n_refit: int) -> list[Candidate]:
    """The candidates worth a refit, best screened first.

    ``n_refit`` additions and :data:`N_REPLACE` replacements, each of a
    different effect in its equation (a coupling or a drift reached through
    several variables takes one slot).
    """
    out, seen = [], set()
    quota = {"add": n_refit, "replace": min(N_REPLACE, n_refit)}
    for c in screened:
        key = (c.move, c.effect.name, c.roles.index)
        if quota[c.move] and key not in seen:
            out.append(c)
            seen.add(key)
            quota[c.move] -= 1
    return out


def _stability(ordered: list[Candidate], residuals: np.ndarray, data: Record,
               min_improvement: float, bic_threshold: float, *, simulation_rmse: float,
               n_resamples: int, random_state) -> Stability | None:
    """The choice made again on resamples of the record (None without resamples)."""
    if n_resamples == 0:
        return None
    contenders = [c for c in ordered if _group(c) == 0 and c.after_squares is not None
                  and c.move != "remove"
                  and (c.held_out is None or c.held_out.confirmed)
                  and (c.move != "open" or c.held_out is not None)]
    better = {c.key for c in contenders if _simulates_better(c, simulation_rmse)}
    return selection_stability(contenders, residuals, data.derivatives,
                               [rows for _, rows in data.experiment_rows],
                               (bic_threshold, min_improvement), tie=TIE, simulates_better=better,
                               n_resamples=n_resamples,
                               random_state=random_state)


def _simulates_better(c: Candidate, simulation_rmse: float) -> bool:
    return (math.isfinite(c.simulation_rmse) and math.isfinite(simulation_rmse)
            and c.simulation_rmse <= SIMULATION_GAIN * simulation_rmse)


def _map_of(roles: EquationRoles, residuals, data: Record, inputs) -> ResidualMap | None:
    columns = data.columns
    if roles.second_order:
        x, y = roles.position, roles.velocity
    elif inputs:
        x, y = roles.position, inputs[0]
    elif data.has_time:
        x, y = TIME, roles.position
    else:
        return None
    return residual_map(roles.derivative, residuals[:, roles.index], x, columns[x], y,
                        y=columns[y])


def _simulate_leaders(refitted: list[Candidate], data: Record, measured: np.ndarray,
                      horizon: Horizon, steps: int, *, base_divergences: list[Divergence],
                      count: int = 3) -> None:
    """Simulate the leading plausible refits; a new divergence makes a candidate implausible."""
    leaders = sorted((c for c in refitted if c.plausible), key=lambda c: c.delta_bic)[:count]
    for candidate in leaders:
        simulated, divergences, _ = simulate_against(candidate.refit, data, horizon,
                                                     max_steps=steps)
        candidate.simulation_rmse = rmse(measured, simulated)
        if divergences and not base_divergences:
            candidate.plausible = False
            candidate.note = f"the refitted model's simulation fails: {divergences[0]}"


def _group(c: Candidate) -> int:
    if c.refit is not None and c.plausible:
        return 0
    if c.refit is not None:
        return 1
    return 2


def _score(c: Candidate) -> float:
    return -c.delta_bic if c.refit is not None else -c.screen_bic


def _ordered(candidates: list[Candidate]) -> list[Candidate]:
    """Best first: plausible refits, then the others, then those only screened.

    Within a group, a candidate whose score is within :data:`TIE` of the
    leader's and that has fewer parameters goes first: when another effect
    is still missing, a more flexible term (Stribeck for Coulomb) soaks up
    part of that other effect's residual, and the information criterion
    alone would reward it.
    """
    finite = [c for c in candidates if math.isfinite(_score(c))]
    remaining = sorted(finite, key=lambda c: (_group(c), -_score(c)))
    out = []
    while remaining:
        lead = remaining[0]
        margin = max(TIE[0] * abs(_score(lead)), TIE[1])
        close = [c for c in remaining
                 if _group(c) == _group(lead) and _score(lead) - _score(c) <= margin]
        pick = min(close, key=lambda c: (c.n_change, -_score(c)))
        out.append(pick)
        remaining.remove(pick)
    return out


def _ranking(ordered: list[Candidate], explained: pd.DataFrame,
             stability: Stability | None) -> pd.DataFrame:
    lookup = {(e, v): f for e, v, f in explained[
        ["equation", "variable", "fraction"]].itertuples(index=False)}
    rows = []
    for c in ordered:
        refit = c.refit is not None
        rows.append({
            "equation": c.roles.derivative,
            "move": c.move,
            "variable": c.variable,
            "effect": c.effect.name,
            "score": _score(c),
            "suggested_term": c.term,
            "curve_term": c.curve_term,
            "n_params": c.n_change,
            "error_removed": c.removed if refit else c.screen_removed,
            "delta_bic": c.delta_bic if refit else c.screen_bic,
            "rmse_before": c.rmse_before,
            "rmse_after": c.rmse_after,
            "simulation_rmse": c.simulation_rmse,
            "held_out_change": math.nan if c.held_out is None else c.held_out.change(),
            "held_out_wins": (None if c.held_out is None
                              else f"{c.held_out.wins} of {c.held_out.n_folds}"),
            "stability": math.nan if stability is None else stability.share(c),
            "plausible": bool(c.plausible) if refit else None,
            "refit": refit,
            "explained": lookup.get((c.roles.derivative, c.variable), math.nan),
            "note": c.note or ("" if refit else "screened on the residual only"),
        })
    return pd.DataFrame(rows, columns=_RANKING_COLUMNS)


def _eligible(ordered: list[Candidate], min_improvement: float, bic_threshold: float,
              simulation_rmse: float) -> list[Candidate]:
    """Plausible refits that clear the BIC and help the derivatives or the simulation."""
    out = []
    for c in ordered:
        if _group(c) != 0 or c.delta_bic > -bic_threshold:
            continue
        if c.removed >= min_improvement or _simulates_better(c, simulation_rmse):
            out.append(c)
    return out


def _decide(eligible: list[Candidate], model, data: Record, horizon: Horizon | None,
            equations: list[int], *, steps: int, n_jobs: int | None = None,
            cache: dict | None = None, record: pd.DataFrame | None = None) -> Candidate | None:
    """The first eligible candidate that held-out data confirm, or None.

    ``cache`` keeps the model's own held-out errors by fold for later checks.
    When the model was fitted by output error, a candidate must first lower
    the output error of the whole measured ``record`` (:func:`_short_of_whole_record`),
    and only then is it held out.
    """
    output_error = getattr(model, "fit_mode_", "equation") == "simulation"
    cache = {} if cache is None else cache

    def check(c: Candidate) -> bool:
        if output_error and record is not None \
                and _short_of_whole_record(c, model, record, cache):
            return False
        c.held_out = held_out_check(model, c.refit, data, horizon, equations,
                                    max_steps=steps, output_error=output_error, cache=cache,
                                    n_jobs=n_jobs)
        if not c.held_out.confirmed:
            c.note = "; ".join(filter(None, [c.note, str(c.held_out)]))
        return c.held_out.confirmed

    for c in eligible[:N_HELD_OUT]:
        if check(c):
            return _preferred(c, eligible, check)
    return None


def _short_of_whole_record(c: Candidate, model, record: pd.DataFrame, cache: dict, *,
                           gain: float = WHOLE_RECORD_GAIN) -> bool:
    """Whether ``c`` lowers the whole ``record``'s output error by less than it must.

    Both skeletons fitted by output error to the measured record, ends
    included (:func:`_whole_record`); ``c`` must lower its error by
    ``gain``, as said in its note where it does not. One
    fit that spares the held-out folds' several, and a guard against
    folds fitted on short blocks that favour a term one trajectory through
    the whole record does not.
    """
    asked = c.whole_record is not None  # judged before: its note says so already
    if not asked:
        c.whole_record = _whole_record(c.refit, record)
    before, after = _whole_record(model, record, cache), c.whole_record
    if after <= (1 - gain) * before:
        return False
    if asked:
        return True
    c.note = "; ".join(filter(None, [c.note, (
        f"not confirmed by the whole record: its output error goes from {before:.4g} to "
        f"{after:.4g} of its spread ({100 * (after / before - 1):+.1f} %)")]))
    return True


def _preferred(c: Candidate, eligible: list[Candidate], check) -> Candidate:
    """The candidate to name once held-out data confirmed ``c`` (``check`` judges others).

    ``c`` itself, the same effect beside the terms it would replace, a
    simpler effect that does as well, or a rival that does clearly better.
    """
    # a term the user wrote goes only where the data its fit did not see favour
    # dropping it: the same effect added beside it is checked too, and kept unless
    # the replacement does clearly better (a light viscous damping under a
    # quadratic drag costs a noisy record little, and a fresh one much)
    beside = _beside(c, eligible)
    if beside is not None and check(beside):
        crit = c.held_out.criterion
        if c.held_out.after[crit] > (1 - PARSIMONY) * beside.held_out.after[crit]:
            beside.note = "; ".join(filter(None, [beside.note, (
                f"preferred to replacing '{' + '.join(c.replaces)}' (held-out {crit} "
                f"error {c.held_out.after[crit]:.3g} without it against "
                f"{beside.held_out.after[crit]:.3g} with it)")]))
            c = beside
    # a simpler effect through the same variable that does as well on held-out data
    # is preferred: a flexible term (Stribeck for Coulomb) also soaks up some of
    # another missing effect (not the same effect in place of the user's terms)
    simpler = [o for o in eligible if o is not c and o.held_out is None
               and o.n_change < c.n_change
               and (o.roles.index, o.variable) == (c.roles.index, c.variable)
               and not (o.move == "replace" and o.effect.name == c.effect.name)]
    if simpler and check(simpler[0]):
        crit = c.held_out.criterion
        if simpler[0].held_out.after[crit] <= (1 + PARSIMONY) * c.held_out.after[crit]:
            simpler[0].note = (f"preferred to {c.effect.name} (more parameters, held-out "
                               f"{crit} error {c.held_out.after[crit]:.3g} against "
                               f"{simpler[0].held_out.after[crit]:.3g})")
            return simpler[0]
    # a rival the derivatives could not tell from it (its score within TIE), or one
    # that simulates the record clearly better, is judged on the measured signals the
    # fits did not see: estimated derivatives of a noisy, coloured or long record can
    # rank shapes by their own errors
    rival = _close_rival(c, eligible)
    if rival is not None and check(rival):
        crit = c.held_out.criterion
        if rival.held_out.after[crit] <= (1 - PARSIMONY) * c.held_out.after[crit]:
            rival.note = "; ".join(filter(None, [rival.note, (
                f"preferred to {c.effect.name} (held-out "
                f"{crit} error {rival.held_out.after[crit]:.3g} against "
                f"{c.held_out.after[crit]:.3g})")]))
            return rival
    return c


def _beside(replacement: Candidate, eligible: list[Candidate]) -> Candidate | None:
    """The same effect added beside the terms ``replacement`` would take out, or None."""
    if replacement.move != "replace":
        return None
    return next((o for o in eligible if o.move == "add" and o.held_out is None
                 and o.effect.name == replacement.effect.name
                 and (o.roles.index, o.variable) == (replacement.roles.index,
                                                     replacement.variable)), None)


def _close_rival(leader: Candidate, eligible: list[Candidate]) -> Candidate | None:
    """The best unchecked other effect through the same variable that may be the better one.

    One the derivatives score within ``TIE`` of the leader, or one that
    simulates the record clearly better (its simulation error at most
    ``SIMULATION_GAIN`` of the leader's): on a long or coloured record the
    derivatives' score can favour a shape the measured signals reject.
    """
    margin = max(TIE[0] * abs(_score(leader)), TIE[1])
    for other in eligible:
        if (other is not leader and other.held_out is None
                and other.effect.name != leader.effect.name  # another shape, not a move
                and (other.roles.index, other.variable) == (leader.roles.index,
                                                            leader.variable)
                and other.n_change >= leader.n_change
                and (_score(leader) - _score(other) <= margin
                     or _simulates_better(other, leader.simulation_rmse))):
            return other
    return None


def _decide_removal(removals: list[Candidate], model, data: Record,
                    horizon: Horizon | None, steps: int, *, held_out: bool,
                    n_jobs: int | None = None, record: pd.DataFrame | None = None,
                    cache: dict | None = None) -> Candidate | None:
    """The first superfluous term: its removal lowers the BIC and no held-out error.

    A removal is never decided on the derivatives alone when the record can
    be held out: a small real term (a light damping) costs the residual
    little, and only data its fit did not see tell it from a spurious one.
    Nor is one made that an output-error fit of the whole record rejects
    (its error raised by more than :data:`REMOVAL_WHOLE_RECORD`, both
    skeletons fitted to the measured ``record``, ends included, when the
    model was fitted so): where the measurement noise dominates the
    held-out errors, windows
    restarted from the noisy states cannot see what a light damping does,
    and one trajectory through the whole record can (its start, where a
    release decays, is often what shows it).
    """
    output_error = getattr(model, "fit_mode_", "equation") == "simulation"
    for c in sorted((c for c in removals if _group(c) == 0 and c.delta_bic < 0),
                    key=lambda c: c.delta_bic):
        if not held_out:
            return c if c.delta_bic <= -REMOVAL_BIC else None
        if output_error and record is not None:
            with_it = _whole_record(model, record, cache)
            without = _whole_record(c.refit, record)
        else:
            with_it = without = math.nan
        if without > (1 + REMOVAL_WHOLE_RECORD) * with_it:
            c.note = "; ".join(filter(None, [c.note, (
                f"not removed: the output error of the whole record rises from "
                f"{with_it:.3g} to {without:.3g} of its spread without it")]))
            return None
        c.held_out = held_out_check(model, c.refit, data, horizon, c.equations,
                                    max_steps=steps, output_error=output_error,
                                    rule="no_loss", n_jobs=n_jobs)
        noise = c.held_out.before.get("derivatives", 0.0)
        if c.held_out.confirmed and noise < REMOVAL_SKILL:
            return c
        c.note = "; ".join(filter(None, [c.note, str(c.held_out)]))
        if c.held_out.confirmed:
            c.note += (f"; not removed: the model predicts held-out derivatives no better "
                       f"than {noise:.2g} of their spread, so its fitted terms are biased by "
                       "the noise and their removal proves nothing")
        return None  # the least costly removal failed: the others cost more
    return None


def _whole_record(model, record: pd.DataFrame, cache: dict | None = None) -> float:
    """The output error (normalised) of ``model``'s skeleton fitted by it to ``record``.

    The measured record as given, ends included (the diagnosis leaves out
    where its derivative filters settle, and a release often decays there).
    Inf where that fit fails; ``cache`` keeps the value under
    ``"whole_record"`` (the model's own, asked for again by each check).
    """
    if cache is not None and "whole_record" in cache:
        return cache["whole_record"]
    if getattr(model, "fit_mode_", None) == "simulation" and fitted_on(model, record):
        # it was fitted so on this very record
        error = float(model.shooting_.get("nrmse_after", math.inf))
        if cache is not None:
            cache["whole_record"] = error
        return error
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fitted = prepared(model, fit_mode="simulation").fit(record)
    except Exception:  # a skeleton the record cannot fit this way is no answer
        error = math.inf
    else:
        error = float(fitted.shooting_.get("nrmse_after", math.inf))
    if cache is not None:
        cache["whole_record"] = error
    return error


#: least relative fall of the held-out error that confirms a free curve: it brings many
#: more numbers than a catalogue term, and is tried only once none of those helped
OPEN_GAIN = 0.05
#: free curves checked on held-out data, best first
N_OPEN = 2


def _decide_open(eligible: list[Candidate], model, data: Record,
                 horizon: Horizon | None, equations: list[int], *, steps: int, held_out: bool,
                 n_jobs: int | None = None, cache: dict | None = None,
                 record: pd.DataFrame | None = None) -> Candidate | None:
    """The first free curve that lowers the held-out error clearly, or None.

    When the model was fitted by output error, the curve must first lower
    the output error of the whole measured ``record`` by as much as it must
    lower the held-out error (:data:`OPEN_GAIN`, :func:`_short_of_whole_record`):
    the data a fit saw favour its own many numbers more, never less, and a
    curve short of that on the whole record is not worth its folds.
    """
    if not held_out:
        return eligible[0] if eligible else None
    output_error = getattr(model, "fit_mode_", "equation") == "simulation"
    cache = {} if cache is None else cache
    for c in eligible[:N_OPEN]:
        if output_error and record is not None \
                and _short_of_whole_record(c, model, record, cache, gain=OPEN_GAIN):
            continue
        c.held_out = held_out_check(model, c.refit, data, horizon, equations, max_steps=steps,
                                    output_error=output_error, cache=cache, n_jobs=n_jobs,
                                    gain=OPEN_GAIN)
        if c.held_out.confirmed:
            return c
        c.note = "; ".join(filter(None, [c.note, str(c.held_out)]))
    return None


def _formula(chosen: Candidate, skeleton: Skeleton, model, data: Record,
             residuals: np.ndarray, *, rss_before: np.ndarray, baseline: frozenset,
             horizon: Horizon | None, equations: list[int], steps: int, held_out: bool,
             n_jobs: int | None, cache: dict | None = None) -> Candidate | None:
    """The symbolic engine's formula for the chosen free curve, refitted and judged.

    Of the formulas found, the plausible refit with the lowest BIC is
    checked on held-out data.
    """
    formulas = []
    for formula in formula_candidates(chosen):
        try:
            extend(skeleton, formula)
        except (SkeletonError, ValueError):
            continue
        formulas.append(formula)
    _refit_all(formulas, model, data, residuals, rss_before, baseline=baseline, n_jobs=n_jobs)
    fitted = [f for f in formulas if f.refit is not None and math.isfinite(f.delta_bic)]
    if not fitted:
        return None
    formula = min(fitted, key=lambda f: (not f.plausible, f.delta_bic))
    if formula.plausible and held_out:
        output_error = getattr(model, "fit_mode_", "equation") == "simulation"
        formula.held_out = held_out_check(model, formula.refit, data, horizon, equations,
                                          max_steps=steps, output_error=output_error,
                                          n_jobs=n_jobs, cache=cache)
    return formula




def _adopted(formula: Candidate | None) -> bool:
    """Whether the formula takes the free curve's place in the suggested skeleton."""
    return (formula is not None and formula.refit is not None and bool(formula.plausible)
            and (formula.held_out is None or formula.held_out.confirmed))


def _suggestion(c: Candidate, base: Skeleton, model, formula: Candidate | None = None,
                tried: list[OpenCurve] = ()) -> Suggestion:
    if c.move == "open":
        probe = next(p for p in tried if p.confirmed)
        return _open_suggestion(c, model, formula, probe.curve)
    skeleton = c.extended
    curve_term, curve_constraints = None, ()
    if c.curve_term is not None:
        k = c.roles.index
        start = base
        for j, text in c.removals:
            start = start.remove_term(j, text)
        curved = start.add_term(k, c.curve_term, constraints=list(c.effect.curve_constraints))
        curve_term = curved.equations[k][len(start.equations[k]) + 3:]
        new = [x for x in curved.constraints if x not in start.constraints]
        curve_constraints = tuple(str(x) for x in new)
    derivative = {eq.index: eq.derivative for eq in skeleton.parsed}
    also = {derivative[k]: text for k, text in c.added if k != c.roles.index}
    intervals = {}
    # what the refit's backend knows of its own uncertainty, without resampling; only for
    # a model fitted by equation error, as the refit is (an output-error model's
    # equation-error refit is biased by the very noise that chose output error)
    if getattr(model, "fit_mode_", "equation") == "equation":
        try:
            found = c.refit.params_interval(0.95)
            intervals = {a: found[a] for a in c.new_params if a in found}
        except (ValueError, AttributeError):
            intervals = {}
    return Suggestion(
        effect=c.effect.name, description=c.effect.description, equation=c.roles.derivative,
        variable=c.variable, term=c.term, equations=skeleton, move=c.move,
        replaces=c.replaces,
        param_init={a: float(v) for a, v in c.refit.params_.items()},
        curve_term=curve_term, curve_constraints=curve_constraints, also=also,
        error_removed=float(c.removed), delta_bic=float(c.delta_bic),
        simulation_rmse=float(c.simulation_rmse), held_out=c.held_out,
        bounds=tuple(str(x) for x in skeleton.constraints
                     if isinstance(x, Bound) and x not in base.constraints),
        intervals=intervals, settings=_settings(c.refit, model))


def _settings(refit, model) -> dict:
    """The hyperparameters ``refit`` was fitted with that differ from ``model``'s.

    Not ``n_bootstrap``: the diagnosis refits without resamples, and the
    model it suggests keeps the user's.
    """
    own = model.get_params(deep=False)
    return {k: v for k, v in refit.get_params(deep=False).items()
            if k not in ("equations", "constraints", "param_init", "n_bootstrap")
            and own.get(k) != v}


def _open_suggestion(c: Candidate, model, formula: Candidate | None,
                     frame: pd.DataFrame) -> Suggestion:
    """A free curve, or the formula proposed for it, in place of a role's terms."""
    lead = formula if _adopted(formula) else c
    return Suggestion(
        effect=c.effect.name, description=c.effect.description, equation=c.roles.derivative,
        variable=c.variable, term=lead.term, equations=lead.extended, move="open",
        replaces=c.replaces,
        param_init={a: float(v) for a, v in lead.refit.params_.items()},
        curve_term=c.term, curve_constraints=(), also={},
        error_removed=float(lead.removed), delta_bic=float(lead.delta_bic),
        simulation_rmse=float(c.simulation_rmse), held_out=c.held_out,
        bounds=(), formula=None if formula is None else formula.term,
        formula_held_out=None if formula is None else formula.held_out, curve=frame,
        settings=_settings(lead.refit, model))
