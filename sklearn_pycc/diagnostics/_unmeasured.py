"""The diagnosis of a model with unmeasured states: judged by simulating what is measured.

No derivative of a state that no sensor reads can be estimated, and no
window of a simulation can restart from it: each experiment is simulated
whole from the state :meth:`~sklearn_pycc.CCRegressor.estimate_initial_state`
finds on its first samples, and the measured states and sensor readings are
compared with the record. The candidates are hard limits on each state that
has none (``overflow``: a tank's rim, an end stop), each refitted by output
error from the diagnosed model's parameters (and from the default start too
where that takes little of the error) and kept when it lowers the
simulation error in the record (by the BIC) and, by at least
:data:`LIMIT_GAIN`, on data its fit did not see (each half of the record, or
each experiment, predicted by the fit to the rest).
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from ..exceptions import SimulationError
from ..fitting.fingerprint import fit_fingerprint
from ..measurements.experiments import TIME, TRAJECTORY, split_experiments
from ..measurements.measurement import Measurement
from ..measurements.reconstruct import unmeasured_states
from ..model_selection._scoring import pooled_nrmse
from ._decide import residual_memory, suggestion_for
from ._held_out import HeldOut
from ._metrics import error_table_row
from ._refit import prepared
from ._unmeasured_moves import (
    TRIAL_ITERATIONS,
    MoveTrial,
    law_trials,
    special_case,
    thinned,
)
from .report import Diagnosis, Suggestion

__all__ = ["UnmeasuredDiagnosis", "diagnose_unmeasured"]

#: the least share of the held-out simulation error a limit must remove: a limit at the
#: extreme a state reached clips a peak or two wherever it is put, and on coloured noise
#: that can lower the error by a per cent or two; a missing rim changes the course itself
LIMIT_GAIN = 0.05

#: BIC changes within this of each other are one: the record cannot tell the moves apart
TIE = 0.1

#: the catalogue's name and physics of a hard limit on a state
OVERFLOW = ("overflow", "the state stops at a limit it cannot pass (a tank's rim, an end stop): "
            "beyond it the flow spills or the motion stops")


@dataclass
class LimitTrial:
    """One limit tried: the refitted model and its simulation errors."""

    state: str
    term: str
    refit: object | None
    nrmse: float
    delta_bic: float
    removed: float
    held_out: HeldOut | None = None
    failure: str = ""


def _starts_line(starts: pd.DataFrame | None) -> str:
    """Which start of the output-error fit was kept, and where the others ended, in words."""
    if starts is None or not len(starts) or not starts["kept"].any():
        return ""
    kept = starts[starts["kept"]].iloc[0]
    others = starts[~starts["kept"]]
    text = (f"The fit tried {len(starts)} start{'s' * (len(starts) > 1)}; "
            f"'{kept.start}' was kept (NRMSE {kept.nrmse:.3g})")
    if len(others):
        text += "; the others ended at NRMSE " + ", ".join(
            f"{row.nrmse:.3g}" + (" (on trial)" if row.polished == "trial" else "")
            for row in others.itertuples())
    return text + "."


@dataclass(repr=False)
class UnmeasuredDiagnosis(Diagnosis):
    """A :class:`Diagnosis` of a model with unmeasured states (see :func:`diagnose`).

    :attr:`trajectories` holds what is measured (states and sensor
    readings) simulated whole from each experiment's estimated initial
    state; :attr:`simulation` every state simulated, the unmeasured ones
    without a measured column; :attr:`hidden` names the unmeasured states
    and :attr:`ranking` the limits tried.
    """

    hidden: list = field(default_factory=list)

    def summary(self) -> str:
        """The diagnosis in plain words."""
        model = self.model
        lines = [f"Model ({type(model).__name__}, {model.n_parameters_} fitted numbers) "
                 f"against {len(self.simulation)} samples; {', '.join(self.hidden)} not "
                 "measured:"]
        lines.extend(f"    {text}" for text in model.equations())
        lines.append("")
        lines.append("Simulation of each experiment whole, from the initial state estimated "
                     "on its first samples, with the measured inputs:")
        for name, row in self.trajectories.iterrows():
            unit = f" {self.units[name]}" if self.units.get(name) else ""
            lines.append(f"    {name}: fit {row.fit_percent:.1f} %, RMSE {row.rmse:.4g}{unit} "
                         f"(NRMSE {row.nrmse:.3g})")
        for d in self.divergences:
            lines.append(f"    FAILURE: {d}")
        starts = _starts_line(getattr(model, "starts_", None))
        if starts:
            lines.append(starts)
        lines.append("")
        if self.best is None:
            rows = list(self.ranking.itertuples())
            # those refitted to the whole record, or that failed; the others fell on trial
            judged = [r for r in rows if np.isfinite(r.error_removed)
                      or (isinstance(r.failure, str) and r.failure)]
            dropped = len(rows) - len(judged)
            lines.append("Nothing is missing among the limits and laws tried: " + (
                "; ".join(f"'{r.suggested_term}' {self._why(r)}" for r in judged)
                or "every state has its limits")
                + (f"; {dropped} more fell behind on trial (ranking)" if dropped else "")
                + ".")
        else:
            best = self.best
            lines.append(f"Missing effect: {best.effect} of {best.variable} ({best.description})"
                         f": {best.action()}; the simulation error falls "
                         f"{100 * best.error_removed:.0f} % (delta BIC {best.delta_bic:.1f}).")
            if best.held_out is not None:
                lines.append(f"    held out: {best.held_out}")
        if self.notes:
            lines.append("")
            lines.extend(f"Note: {note}" for note in self.notes)
        return "\n".join(lines)

    @staticmethod
    def _why(row) -> str:
        if isinstance(row.failure, str) and row.failure:
            return f"could not be fitted ({row.failure})"
        held = row.held_out_change
        return (f"removes {100 * row.error_removed:.0f} % of the simulation error"
                + ("" if not np.isfinite(held) else f", held out {100 * held:+.1f} %"))

    def plot(self) -> dict:
        """Figures of the diagnosis: ``{"simulation": figure}`` (empty if it escaped).

        Each measured signal against its simulation, and the unmeasured
        states as simulated, one panel each.
        """
        from .._utils.figures import pyplot
        from ..plotting import label_axis

        plt = pyplot()
        frame = self.simulation
        names = [c[:-4] for c in frame.columns if c.endswith("_sim")]
        if not names:  # the model escaped: nothing simulated to draw
            return {}
        fig, axes = plt.subplots(len(names), 1, sharex=True, squeeze=False,
                                 figsize=(8, 2.2 * len(names)))
        for ax, name in zip(axes[:, 0], names):
            if name in frame.columns:
                ax.plot(frame[TIME], frame[name], ".", ms=2, color="0.5", label="measured")
            ax.plot(frame[TIME], frame[f"{name}_sim"], lw=1,
                    label="simulated" + (" (not measured)" if name in self.hidden else ""))
            label_axis(ax, "y", name, self.units)
            # above the panel, where no sample lies under it
            ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=2, fontsize="small",
                      frameon=False, borderaxespad=0.1)
        label_axis(axes[-1, 0], "x", TIME, self.units)
        fig.tight_layout()
        return {"simulation": fig}


def _experiments(X: pd.DataFrame):
    trajectory = X[TRAJECTORY].to_numpy() if TRAJECTORY in X.columns else None
    return split_experiments(len(X), X[TIME].to_numpy(dtype=float), trajectory)


def simulate_record(model, X: pd.DataFrame) -> pd.DataFrame:
    """Every state and sensor reading, each experiment simulated whole from its estimate.

    Raises :class:`SimulationError` where the model escapes.
    """
    skeleton = model.skeleton_
    inputs = [name for name in skeleton.inputs if name != TIME]
    parts = []
    for experiment in _experiments(X):
        part = X.iloc[experiment.rows]
        y0 = model.estimate_initial_state(part)
        simulated = model.simulate(experiment.t, y0,
                                   inputs={n: part[n].to_numpy(dtype=float) for n in inputs})
        parts.append(simulated.set_index(part.index))
    return pd.concat(parts)


def _compared(model, X: pd.DataFrame) -> list[str]:
    skeleton = model.skeleton_
    return [name for name in [*skeleton.states, *skeleton.outputs]
            if name in X.columns and X[name].notna().any()]


def _nrmse(model, X: pd.DataFrame) -> float:
    """The simulation scorer's normalised RMSE of what ``X`` measures (inf: it escaped)."""
    from ..model_selection import make_simulation_scorer

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return make_simulation_scorer().nrmse(model, X)
    except (SimulationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return math.inf


def _fresh_param(skeleton) -> str:
    numbers = [int(re.sub(r"\D", "", a)) for a in skeleton.params] or [0]
    return f"a{max(numbers) + 1}"


def _refit(model, X: pd.DataFrame, skeleton, init: dict, **settings):
    """``model`` refitted with ``skeleton`` from the starting values ``init``.

    The input hold an ``"auto"`` model chose is kept: ``init`` was fitted
    with it, and a limit's search from there stays on that course. The
    refit is judged by its errors alone, so it makes no refits on resamples.
    ``settings`` are more parameters of the estimator (a trial's iterations).
    """
    estimator = prepared(model, equations=skeleton, param_init=init, hold_as_fitted=True,
                         **settings)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return estimator.fit(X)


def _halves(X: pd.DataFrame) -> list[tuple[pd.DataFrame, pd.DataFrame, str]]:
    """Held-out folds: each experiment left out (two or more), else each half left out."""
    experiments = _experiments(X)
    if len(experiments) >= 2:
        folds = []
        for k, e in enumerate(experiments):
            rest = np.setdiff1d(np.arange(len(X)), e.rows)
            folds.append((X.iloc[rest], X.iloc[e.rows], f"experiment {k}"))
        return folds
    middle = len(X) // 2
    first, second = X.iloc[:middle], X.iloc[middle:]
    return [(first, second, "second half"), (second, first, "first half")]


def _fold_errors(model, X: pd.DataFrame, measurement: Measurement | None) -> dict:
    """The held-out errors of ``model`` on ``X``'s folds, kept with the record.

    A limit found is the loop's next model; the fits of that model to each
    fold were the limit's held-out check, so the next round, diagnosing the
    same ``measurement``, reuses them. They are kept by what the model was
    fitted on and with (:func:`~sklearn_pycc.fitting.fingerprint.fit_fingerprint`);
    a record given as a frame keeps nothing.
    """
    if measurement is None:
        return {}
    return measurement.estimated(("held-out fold errors", fit_fingerprint(model, X)), dict)


def _held_out_error(model, X: pd.DataFrame, spreads: dict[str, float]) -> float:
    """The simulation error of what ``X`` measures, in units of each signal's ``spreads``.

    Each experiment is simulated whole from its estimated initial state;
    the root of the mean square over every measured sample (``inf``: the
    model escaped).
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulated = simulate_record(model, X)
        return pooled_nrmse([(X, simulated)], list(spreads), spreads)
    except (SimulationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return math.inf


def _held_out(model, trial_skeleton, X: pd.DataFrame, init: dict, cache: dict
              ) -> tuple[HeldOut, dict]:
    """The model with and without the limit, each fitted without a fold, judged on it.

    Every fold's error is in units of the whole record's spread of each
    measured signal (a fold where a tank sits at its rim has little spread
    of its own, and its errors, a few hundredths of a centimetre either way,
    would weigh as much as a fold that shows the limit). The limit is
    confirmed where it lowers the pooled error by :data:`LIMIT_GAIN` and
    raises no fold's by as much in most folds. ``cache`` keeps the model's
    own held-out errors for the next limit. Returns the verdict and the
    trial's error on each fold.
    """
    spreads = {name: float(np.nanstd(X[name].to_numpy(dtype=float))) or 1.0
               for name in _compared(model, X)}
    before, after = [], []
    folds = _halves(X)
    for k, (train, test, _) in enumerate(folds):
        if k not in cache:
            base = _refit(model, train, model.skeleton_, dict(model.params_))
            cache[k] = _held_out_error(base, test, spreads)
        trial = _refit(model, train, trial_skeleton, init)
        before.append(cache[k])
        after.append(_held_out_error(trial, test, spreads))
    pooled_before = float(np.sqrt(np.mean(np.square(before))))
    pooled_after = float(np.sqrt(np.mean(np.square(after))))
    wins = sum(a < b for a, b in zip(after, before))
    lost = sum(not a <= b + LIMIT_GAIN * pooled_before for a, b in zip(after, before))
    confirmed = bool(np.isfinite(pooled_after) and pooled_after
                     <= (1 - LIMIT_GAIN) * pooled_before and 2 * lost < len(folds))
    words = ("each experiment predicted by the fit to the others" if len(folds) > 2
             or folds[0][2].startswith("experiment") else
             "each half of the record predicted by the fit to the other half")
    return (HeldOut(words, "simulation", {"simulation": pooled_before},
                    {"simulation": pooled_after}, wins, len(folds), confirmed),
            dict(enumerate(after)))


def diagnose_unmeasured(model, X: pd.DataFrame, *, min_improvement: float,
                        bic_threshold: float, held_out: bool, units: dict,
                        notes: list[str], measurement: Measurement | None = None,
                        quantities=None) -> UnmeasuredDiagnosis:
    """Diagnose a model whose skeleton has states ``X`` does not measure (see module)."""
    skeleton = model.skeleton_
    hidden = unmeasured_states(skeleton, {c: X[c] for c in X.columns if X[c].notna().any()})
    compared = _compared(model, X)
    notes.append(
        f"{', '.join(hidden)} not measured: each experiment is simulated whole from the "
        "initial state estimated on its first samples (no window restarts from a state no "
        f"sensor reads), and the model is judged on {', '.join(compared)}.")
    divergences = []
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulated = simulate_record(model, X)
    except SimulationError as error:
        simulated = None
        divergences.append(str(error))
    rows, frame = [], pd.DataFrame({TIME: X[TIME].to_numpy(dtype=float)})
    if simulated is not None:
        for name in compared:
            truth = X[name].to_numpy(dtype=float)
            rows.append(error_table_row(truth, simulated[name].to_numpy(dtype=float)))
        for name in skeleton.states + list(skeleton.outputs):
            if name in X.columns:
                frame[name] = X[name].to_numpy(dtype=float)
            frame[f"{name}_sim"] = simulated[name].to_numpy(dtype=float)
    trajectories = pd.DataFrame(rows, index=pd.Index(compared if rows else [], name="state"))
    trajectories["unit"] = [units.get(s, "") for s in trajectories.index]
    # the simulation scorer's error, on the simulation drawn above
    pairs = [] if simulated is None else [(X.iloc[e.rows], simulated.iloc[e.rows])
                                          for e in _experiments(X) if e.n_samples >= 2]
    base = pooled_nrmse(pairs, compared) if pairs else math.inf
    n = sum(int(X[name].notna().sum()) for name in compared)

    trials = []
    limits = skeleton.limits
    # the least share of the error a limit must take to be judged further
    bar = LIMIT_GAIN if held_out else max(LIMIT_GAIN, min_improvement)
    for state in skeleton.states:
        high = limits.get(state, (-math.inf, math.inf))[1]
        if isinstance(high, str) or math.isfinite(high):
            continue  # it has its upper limit
        name = _fresh_param(skeleton)
        term = f"{state} <= {name}"
        extended = skeleton.with_constraints([term])
        try:
            refit, error = _limit_refit(model, X, extended, base, bar)
        except (ValueError, SimulationError, ArithmeticError, np.linalg.LinAlgError) as error:
            trials.append(LimitTrial(state, term, None, math.nan, math.nan, math.nan,
                                     failure=str(error)))
            continue
        # against a model that escapes (base inf) neither share nor BIC has a meaning
        comparable = math.isfinite(error) and math.isfinite(base) and base > 0
        removed = 1 - error / base if comparable else math.nan
        delta = (2 * n * math.log(error / base) + math.log(n)
                 if comparable and error > 0 else math.nan)
        trials.append(LimitTrial(state, term, refit, error, delta, removed))
    # laws in place of the skeleton's terms, in the equations of every state
    course = None
    if simulated is not None:
        course = simulated.reset_index(drop=True).copy()
        for name in skeleton.inputs:
            if name != TIME and name in X.columns:
                course[name] = X[name].to_numpy(dtype=float)
    if quantities is None:
        quantities = model.get_params().get("quantities")
    moves = law_trials(model, X, course, base=base, n=n, quantities=quantities,
                       units=units, nrmse=_nrmse)
    measured = {eq.index for eq in skeleton.parsed if eq.state not in hidden}
    _counted_by_memory([*trials, *moves], X, compared, n)
    trials = _simplest_first([*trials, *moves], bic_threshold, measured)
    best, cache = None, dict(_fold_errors(model, X, measurement))
    for trial in trials:
        # the error includes the noise, which no limit removes: a small share of it may be
        # all a real limit can take; data the fit did not see decide then
        if not (math.isfinite(trial.delta_bic) and trial.delta_bic < -bic_threshold) \
                or (trial.removed < min_improvement and not held_out):
            continue
        errors = {}
        if held_out:
            trial.held_out, errors = _held_out(model, trial.refit.skeleton_, X,
                                               dict(trial.refit.params_), cache)
            if not trial.held_out.confirmed:
                continue
            _fold_errors(trial.refit, X, measurement).update(errors)
        trial.refit = _as_asked(model, trial.refit, X)
        _fold_errors(trial.refit, X, measurement).update(errors)
        best = (_move_suggestion(trial, model) if isinstance(trial, MoveTrial)
                else _limit_suggestion(trial))
        break
    ranking = pd.DataFrame([_ranking_row(t) for t in trials],
                           columns=["equation", "variable", "effect", "move", "suggested_term",
                                    "simulation_nrmse", "delta_bic", "error_removed",
                                    "held_out_change", "failure"])
    diagnosis = UnmeasuredDiagnosis(
        model, pd.DataFrame(columns=["rmse", "nrmse", "r2", "fit_percent"]), trajectories,
        frame, pd.DataFrame(), divergences, pd.DataFrame(), pd.DataFrame(), {}, ranking, best,
        float(np.sqrt(np.mean(trajectories["rmse"] ** 2))) if rows else math.nan, notes,
        None, [], units, [s for s in skeleton.states if s not in hidden], hidden=hidden)
    return diagnosis


def _counted_by_memory(trials: list, X: pd.DataFrame, compared: list[str], n: int) -> None:
    """The trials' BIC with the record's samples counted by the memory of its noise.

    The BIC counts every sample as independent; a sensor whose noise is
    correlated in time (a correlation time of ten samples) gives far fewer
    independent ones, and a drift or a source fitted to that noise's slow
    swings lowers the error by a few per cent, which ``n`` samples make
    significant. The memory (:func:`~sklearn_pycc.diagnostics._decide.residual_memory`)
    is read from what each refitted model leaves of the record (the largest
    over the measured signals): the noise alone where a move is right, more
    where it is not. The least over the trials is the noise's, and counts
    for all of them alike (each trial's own would reorder moves whose
    errors differ by less than the memory's scatter).
    """
    scored = [t for t in trials
              if t.refit is not None and math.isfinite(t.delta_bic) and t.removed > 0]
    memories = []
    for trial in scored:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                simulated = simulate_record(trial.refit, X)
        except (SimulationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
            continue
        left = np.column_stack([X[name].to_numpy(dtype=float)
                                - simulated[name].to_numpy(dtype=float) for name in compared])
        memories.append(float(np.max(residual_memory(left))))
    if not memories:
        return
    n_eff = max(n / max(min(memories), 1.0), 2.0)
    for trial in scored:
        k = trial.candidate.n_change if isinstance(trial, MoveTrial) else 1
        trial.delta_bic = 2 * n_eff * math.log(1 - trial.removed) + k * math.log(n_eff)


def _simplest_first(trials: list, margin: float, measured: set[int]) -> list:
    """Trials by their BIC, each effect's special case before it unless it loses by ``margin``.

    A drift ``a1 + a2 t`` takes at least the error a constant load ``a1``
    takes; on noise correlated in time its one more number is cheap in the
    BIC. The simpler is named unless the general one is better by the
    margin a suggestion must clear anyway. Of one effect in two equations
    that the record cannot tell apart (a load on a room's air or on its
    unmeasured walls: the walls' level absorbs the difference), the one in
    the ``measured`` states' equations comes first: BIC within :data:`TIE`
    of the best of their group are one, a general effect held back to its
    special case's BIC ranking just after it.
    """
    def finite(trial) -> bool:
        return math.isfinite(trial.delta_bic)

    # a general effect ranks where its special case does unless it beats it by the margin
    rank = {id(t): t.delta_bic for t in trials}
    held_back = set()
    for simple in [t for t in trials if isinstance(t, MoveTrial) and finite(t)]:
        for general in trials:
            if (general is not simple and isinstance(general, MoveTrial) and finite(general)
                    and special_case(simple.candidate, general.candidate)
                    and simple.delta_bic - margin < general.delta_bic < simple.delta_bic):
                rank[id(general)] = simple.delta_bic
                held_back.add(id(general))

    # BIC within TIE of the best of their group are one
    group, first = {}, None
    for trial in sorted(filter(finite, trials), key=lambda t: rank[id(t)]):
        if first is None or rank[id(trial)] > first + TIE:
            first = rank[id(trial)]
        group[id(trial)] = first

    def key(trial) -> tuple:
        if not finite(trial):
            return True, 0.0, False, False, 0.0
        inside = isinstance(trial, MoveTrial) and not (
            {k for k, _ in trial.candidate.additions} <= measured)
        # of one group, the measured equation's first, and the special case before its general
        return False, group[id(trial)], inside, id(trial) in held_back, rank[id(trial)]

    return sorted(trials, key=key)


def _limit_refit(model, X: pd.DataFrame, extended, base: float,
                 bar: float) -> tuple[object, float]:
    """The model refitted with a limit added, and its simulation error.

    Tried first (a few iterations on every k-th row, as the laws are) from
    the model's parameters. Where that takes less than ``bar`` of the
    model's error on trial, the search may have stayed on the course the
    limitless model found (with an unmeasured state's scale free, that
    course may never reach any level a rim could sit at): the skeleton is
    then also tried from the backend's default start (under the model's
    input hold), and the better of the two is refitted to the whole record
    from where its trial ended; a failure of that second trial leaves the
    first.
    """
    rows = thinned(X)
    trial = _refit(model, rows, extended, dict(model.params_),
                   shooting_iterations=TRIAL_ITERATIONS)
    before = float(getattr(model, "shooting_", {}).get("nrmse_whole", math.nan))
    after = float(trial.shooting_.get("nrmse_whole", math.nan))
    if not (math.isfinite(before) and before > 0 and after <= (1 - bar) * before):
        try:
            fresh = _refit(model, rows, extended, {}, shooting_iterations=TRIAL_ITERATIONS)
        except Exception:  # the first trial stands, whatever this one meets
            fresh = None
        if fresh is not None and fresh.shooting_.get("nrmse_whole", math.inf) < after:
            trial = fresh
    refit = _refit(model, X, extended, dict(trial.params_))
    return refit, _nrmse(refit, X)


def _as_asked(model, refit, X: pd.DataFrame):
    """``refit`` with the refits on resamples the diagnosed model was given.

    The trial refits make none (they are judged by their errors alone); the
    limit suggested is the loop's next model, fitted again here, from its
    own parameters, with the model's ``n_bootstrap``. Its held-out fits
    carry over.
    """
    wanted = model.get_params().get("n_bootstrap")
    if not wanted or refit.get_params().get("n_bootstrap"):
        return refit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        again = prepared(refit, param_init=refit.params_, n_bootstrap=wanted).fit(X)
    return again


def _ranking_row(trial: LimitTrial | MoveTrial) -> dict:
    """A limit or a law tried, as a row of the diagnosis's ranking."""
    held = math.nan if trial.held_out is None else trial.held_out.change()
    if isinstance(trial, MoveTrial):
        c = trial.candidate
        return {"equation": c.roles.derivative, "variable": c.variable, "effect": c.effect.name,
                "move": c.move, "suggested_term": c.term if c.extended is not None else "",
                "simulation_nrmse": trial.nrmse, "delta_bic": trial.delta_bic,
                "error_removed": trial.removed, "held_out_change": held,
                "failure": trial.failure}
    return {"equation": f"{trial.state}_dot", "variable": trial.state, "effect": OVERFLOW[0],
            "move": "limit", "suggested_term": trial.term, "simulation_nrmse": trial.nrmse,
            "delta_bic": trial.delta_bic, "error_removed": trial.removed,
            "held_out_change": held, "failure": trial.failure}


def _move_suggestion(trial: MoveTrial, model) -> Suggestion:
    """A law in place of terms of the skeleton, fitted by output error to the whole record."""
    c = trial.candidate
    c.refit, c.removed, c.delta_bic = trial.refit, trial.removed, trial.delta_bic
    c.simulation_rmse, c.held_out = trial.nrmse, trial.held_out
    return replace(suggestion_for(c, model.skeleton_, model), refit=trial.refit)


def _limit_suggestion(trial: LimitTrial) -> Suggestion:
    skeleton = trial.refit.skeleton_
    return Suggestion(
        effect=OVERFLOW[0], description=OVERFLOW[1], equation=f"{trial.state}_dot",
        variable=trial.state, term=trial.term, equations=skeleton,
        param_init={a: float(v) for a, v in trial.refit.params_.items()}, curve_term=None,
        curve_constraints=(), also={}, error_removed=float(trial.removed),
        delta_bic=float(trial.delta_bic), simulation_rmse=float(trial.nrmse),
        held_out=trial.held_out, move="limit", refit=trial.refit)
