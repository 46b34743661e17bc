"""Compare a fitted model with measurements, find where it fails and what effect is missing."""

from __future__ import annotations

import math
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils._param_validation import Interval, validate_params
from sklearn.utils.validation import check_is_fitted

from .._utils.randomness import check_seed_source
from ..measurements.measurement import unwrap
from ..measurements.reconstruct import unmeasured_states
from ..measurements.record import Record
from ..simulation.integration import judged_step_limit
from ._candidates import (
    TIE,
    Candidate,
    enumerate_candidates,
    enumerate_input_moves,
    enumerate_moves,
    extend,
    refit_candidates,
    screen_candidates,
)
from ._data import TIME, check_units, read_measurements
from ._decide import (
    N_REMOVE,
    REMOVAL_SCREEN,
    decide_addition,
    decide_open,
    decide_removal,
    eligible_candidates,
    formula_for,
    group_of,
    open_gain,
    ordered_candidates,
    residual_memory,
    score_of,
    simulates_better,
    suggestion_for,
)
from ._detection import above_the_noise, detection_limits
from ._failures import (
    ResidualMap,
    explaining_variables,
    residual_map,
    worst_windows,
)
from ._metrics import error_table_row, rmse
from ._open_curves import open_candidates, probes
from ._physics import implausible_terms
from ._roles import EquationRoles, equation_roles
from ._stability import Stability, selection_stability
from ._trajectories import Divergence, Horizon, horizon_of, simulate_against
from .report import Diagnosis, Suggestion

__all__ = ["Diagnosis", "Suggestion", "diagnose"]

_RANKING_COLUMNS = [
    "equation", "move", "variable", "effect", "called", "score", "suggested_term", "curve_term",
    "n_params",
    "error_removed", "delta_bic", "rmse_before", "rmse_after", "simulation_rmse",
    "held_out_change", "held_out_wins", "stability", "plausible", "refit", "explained", "note",
]


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
    "quantities": [dict, None],
}, prefer_skip_nested_validation=False)  # the model's refits validate their own settings
def diagnose(model, X, y=None, *, n_refit: int = 5, min_improvement: float = 0.1,
             bic_threshold: float = 10.0, simulate: bool = True,
             max_steps: int | None = None, horizon="auto",
             held_out: bool = True, n_bootstrap: int = 100,
             random_state=0, n_jobs: int | None = None, units=None,
             open_curves: bool = True, quantities: dict | None = None) -> Diagnosis:
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
        better; or, for a model fitted by its Kalman filter, a significant
        share, samples counted by their memory) is then checked on
        data its fit did not see: the model with
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
        Least share of the residual an effect must remove to be suggested
        (but see above for a model fitted by its Kalman filter).
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
        figures, and tell what a state measures where ``quantities`` does
        not (``K`` a temperature, ``mol/l`` a concentration).
    quantities : dict of str -> str, optional
        What each state measures (``{"x1": "level"}``; one of
        :data:`sklearn_pycc.quantities.QUANTITIES`); by default the model's
        own ``quantities`` hyperparameter. Mechanical effects
        (friction, springs, drag) enter only mechanical states; the effects
        of other states are named in their field's words
        (:attr:`Suggestion.called`). Without it the units and the structure
        decide: a state whose derivative is another state is a position and
        that state a velocity; other first-order states get the effects of
        a state's own rate (outflow, consumption, decay), named by shape.
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
                                   bic_threshold=bic_threshold, held_out=held_out, units=units,
                                   notes=[], measurement=measurement, quantities=quantities)
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
    if quantities is None:
        quantities = model.get_params().get("quantities")
    roles = equation_roles(skeleton, quantities, units)
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
    candidates = _enumerated(skeleton, roles, data.has_time)
    screen_candidates(candidates, data, residuals, states, model=model)
    rss_before = np.sum(residuals**2, axis=0)
    screened = sorted((c for c in candidates if math.isfinite(c.screen_bic)
                       and c.move != "remove"), key=lambda c: c.screen_bic)
    removals = sorted((c for c in candidates if c.move == "remove"),
                      key=lambda c: c.screen_bic)
    implausible = implausible_terms(model, data)
    baseline = frozenset((item.equation, item.role) for item in implausible)
    leaders = _leaders(screened, n_refit)
    refit_candidates(leaders, model, data, residuals, rss_before, baseline=baseline, n_jobs=n_jobs)
    refitted = [c for c in leaders if c.refit is not None]
    if run_simulation:
        _simulate_leaders(refitted, data, measured_states, window, steps,
                          base_divergences=divergences)
    ordered = ordered_candidates([c for c in candidates if c.move != "remove"])
    eligible = eligible_candidates(ordered, min_improvement, bic_threshold, simulation_rmse,
                                   _push_memory(model, residuals))
    judge = window if run_simulation else None
    cache: dict = {}  # the model's own held-out errors, by fold, for every check
    chosen = decide_addition(eligible, model, data, judge, failing, steps=steps, n_jobs=n_jobs,
                     cache=cache, record=X) \
        if held_out else (eligible[0] if eligible else None)
    if chosen is None:
        # nothing to add or swap in: is a term of the skeleton superfluous?
        refit_candidates([c for c in removals if c.screen_removed > -REMOVAL_SCREEN][:N_REMOVE],
                   model, data, residuals, rss_before, baseline=baseline, n_jobs=n_jobs)
        chosen = decide_removal(removals, model, data, judge, steps, held_out=held_out,
                                 n_jobs=n_jobs,
                                 record=X, cache=cache)
    ordered += ordered_candidates(removals)
    formula, opened = None, []
    if chosen is None and open_curves:
        # the catalogue is exhausted: would a free curve in place of a role's terms do better?
        opened = open_candidates(skeleton, roles)
        for candidate in opened:
            extend(skeleton, candidate)
        refit_candidates(opened, model, data, residuals, rss_before, baseline=baseline,
                         n_jobs=n_jobs)
        if run_simulation:
            _simulate_leaders([c for c in opened if c.refit is not None], data,
                              measured_states, window, steps, base_divergences=divergences)
        opened = ordered_candidates(opened)
        # a curve that does not simulate the record itself clearly better (by what it must
        # lower the whole record's error) will not do so on data it has not seen: spare
        # the whole record's fit and the held-out fits
        promising = eligible_candidates(opened, min_improvement, bic_threshold, simulation_rmse)
        if run_simulation and math.isfinite(simulation_rmse):
            promising = _clearly_better(promising, model, X, cache,
                                        simulation_rmse=simulation_rmse, states=states,
                                        trajectories=trajectory_table)
        chosen = decide_open(promising, model, data, judge, failing, steps=steps,
                              held_out=held_out, n_jobs=n_jobs,
                              cache=cache, record=X)
        if chosen is not None:
            formula = formula_for(chosen, skeleton, model, data, residuals, rss_before=rss_before,
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
    best = None if chosen is None else suggestion_for(chosen, skeleton, model, formula, tried)
    measured = [s for s in states if s in X.columns]
    detection = {} if best is not None or trajectory_table.empty else detection_limits(
        X, measured, {s: float(trajectory_table.loc[s, "rmse"]) for s in measured},
        data.n_samples)
    return Diagnosis(model, derivative_table, trajectory_table, simulation_frame,
                     pd.DataFrame(residuals, columns=derivs), divergences, windows, explained,
                     maps, ranking, best, simulation_rmse, notes, window, implausible,
                     units, measured, tried, candidates, data,
                     variables, stability, len(X) - data.n_samples, detection)


def _clearly_better(opened: list[Candidate], model, X, cache: dict, *, simulation_rmse: float,
                    states: list[str], trajectories: pd.DataFrame) -> list[Candidate]:
    """The free curves worth their held-out fits.

    Each must simulate the record itself better by what it must lower the
    whole record's error (:func:`open_gain`: it will not do so on data it has
    not seen otherwise), and change a measured state's simulation by its
    noise level (:func:`above_the_noise`).
    """
    better = [c for c in opened
              if c.simulation_rmse <= (1 - open_gain(c, model, X, cache)) * simulation_rmse]
    return above_the_noise(better, X, states, trajectories) if better else better


def _push_memory(model, residuals: np.ndarray) -> np.ndarray | None:
    """A model fitted by its filter (a push fills the residual): each residual's memory."""
    return residual_memory(residuals) if getattr(model, "fit_mode_", None) == "filter" else None


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


#: most resamples a diagnosis draws (each is a pass over the refits' residuals)
MAX_RESAMPLES = 100_000
#: replacements refitted beside the ``n_refit`` additions
N_REPLACE = 2


def _leaders(screened: list[Candidate], n_refit: int) -> list[Candidate]:
    """The candidates worth a refit, best screened first.

    ``n_refit`` additions, :data:`N_REPLACE` replacements of the skeleton's
    laws and as many of how it reads an input, each of a different effect in
    its equation (a coupling or a drift reached through several variables
    takes one slot). A law that replaces a path in two balances spreads what
    it takes over both, and screens below an input read in one: it keeps a
    slot of its own.
    """
    out, seen = [], set()
    quota = {"add": n_refit, "replace": min(N_REPLACE, n_refit),
             "input": min(N_REPLACE, n_refit)}
    for c in screened:
        kind = "input" if c.move == "replace" and c.effect.acts_through == "input" else c.move
        key = (c.move, c.effect.name, c.roles.index)
        if quota[kind] and key not in seen:
            out.append(c)
            seen.add(key)
            quota[kind] -= 1
    return out


def _stability(ordered: list[Candidate], residuals: np.ndarray, data: Record,
               min_improvement: float, bic_threshold: float, *, simulation_rmse: float,
               n_resamples: int, random_state) -> Stability | None:
    """The choice made again on resamples of the record (None without resamples)."""
    if n_resamples == 0:
        return None
    contenders = [c for c in ordered if group_of(c) == 0 and c.after_squares is not None
                  and c.move != "remove"
                  and (c.held_out is None or c.held_out.confirmed)
                  and (c.move != "open" or c.held_out is not None)]
    better = {c.key for c in contenders if simulates_better(c, simulation_rmse)}
    return selection_stability(contenders, residuals, data.derivatives,
                               [rows for _, rows in data.experiment_rows],
                               (bic_threshold, min_improvement), tie=TIE, simulates_better=better,
                               n_resamples=n_resamples,
                               random_state=random_state)


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


def _enumerated(skeleton, roles, has_time: bool) -> list[Candidate]:
    """Every move to try, each with its changed skeleton.

    The catalogue's additions, the replacements and removals of the
    skeleton's own terms, and (with time) its inputs read late.
    """
    candidates = enumerate_candidates(skeleton, roles, has_time)
    candidates += enumerate_moves(skeleton, roles, has_time)
    if has_time:
        candidates += enumerate_input_moves(skeleton, roles)
    for candidate in candidates:
        extend(skeleton, candidate)
    return candidates


def _simulate_leaders(refitted: list[Candidate], data: Record, measured: np.ndarray,
                      horizon: Horizon, steps: int, *, base_divergences: list[Divergence],
                      count: int = 3) -> None:
    """Simulate the leading plausible refits; a new divergence makes a candidate implausible."""
    leaders = sorted((c for c in refitted if c.plausible), key=lambda c: c.delta_bic)[:count]
    for candidate in leaders:
        simulated, divergences, _ = simulate_against(candidate.refit, data, horizon,
                                                     max_steps=steps)
        candidate.simulation_rmse = rmse(measured, simulated)
        with np.errstate(all="ignore"):
            candidate.state_rmse = np.sqrt(np.nanmean((simulated - measured) ** 2, axis=0))
        if divergences and not base_divergences:
            candidate.plausible = False
            candidate.note = f"the refitted model's simulation fails: {divergences[0]}"


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
            "called": c.effect.called(c.roles.quantity_of(c.effect.acts_through)),
            "score": score_of(c),
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


