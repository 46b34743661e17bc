"""Held-out evidence: whether an added effect predicts rows its fit has not seen.

On a long record with coloured noise, an information criterion that assumes
white residuals calls almost any extra term significant. The decision to add
an effect rests instead on rows the fit did not see: the record is split
into folds (its experiments, or interleaved blocks in time when there is one),
the model with and without the effect is fitted on the other folds, and both
are judged on the held-out one, by their horizon-limited simulation (the
criterion that decides when the record has time) and by their derivatives.
A fold's simulation error counts at most as much as the signals' spread (what
their mean would predict): a model fitted on a few short blocks can oscillate
or swell on the blocks it did not see, and how far it then strays must not
outweigh the other folds' evidence.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from joblib import Parallel, delayed

from ..measurements.record import Record
from ._data import thin
from ._refit import fit_rows, prepared
from ._trajectories import Horizon, simulate_against

__all__ = ["HeldOut", "fold_labels", "held_out_blocks", "held_out_check", "make_folds"]

#: folds of a single-experiment record
FOLDS = 3
#: at most this many interleaved blocks in time per fold
CHUNKS_PER_FOLD = 4
#: fewest samples of a block in time
MIN_CHUNK = 50
#: at most this many folds when the record has several experiments
MAX_FOLDS = 5
#: least relative fall of the pooled held-out error that confirms an effect (and most the
#: other criterion may rise)
HELD_OUT_GAIN = 0.01
#: the most a fold's normalised mean squared simulation error counts for: a model whose
#: simulation strays further than the signals' spread on a fold is no better there than
#: their mean (a fit that failed counts as infinite)
USELESS = 1.0
#: least absolute fall of the deciding error, in units of the signals' spread: a model that
#: already follows held-out data to a thousandth of their spread misses nothing that matters
#: (on a clean record, a term can still fit the differentiation's own error)
HELD_OUT_FLOOR = 1e-3


@dataclass
class HeldOut:
    """The held-out comparison of a model with and without an effect.

    Attributes
    ----------
    folds : str
        How the record was split, in words.
    criterion : str
        ``"simulation"`` (horizon-limited simulation error, when the record
        has time) or ``"derivatives"``: the one that decides.
    before, after : dict
        Pooled held-out error by criterion (``"simulation"``,
        ``"derivatives"``), normalised by each signal's spread, without and
        with the effect: the root of the folds' mean squared errors
        (weighted by the folds' sizes), the simulation's each capped at
        :data:`USELESS`.
    wins : int
        Folds in which the effect lowered the deciding error.
    n_folds : int
        Number of folds.
    confirmed : bool
        Whether the effect lowered the pooled deciding error by at least
        :data:`HELD_OUT_GAIN` (and by :data:`HELD_OUT_FLOOR` of the signals'
        spread), won in most folds (in every fold with :attr:`every_fold`),
        and raised no other criterion's error by as much (a term that simulates a little better
        but predicts the derivatives worse fits an artefact: the
        differentiation's error on a clean record, for instance).
    every_fold : bool
        Whether the effect had to lower the deciding error in every fold
        (a force of time alone; see :func:`held_out_check`).
    stopped : bool
        Whether the folds left were not fitted because no outcome of theirs
        could have confirmed it (folds fitted one after another): the pooled
        errors are then those of the folds fitted.
    """

    folds: str
    criterion: str
    before: dict[str, float] = field(default_factory=dict)
    after: dict[str, float] = field(default_factory=dict)
    wins: int = 0
    n_folds: int = 0
    confirmed: bool = False
    every_fold: bool = False
    stopped: bool = False

    def change(self, criterion: str | None = None) -> float:
        """Relative change of the pooled held-out error (negative: the effect helps)."""
        name = criterion or self.criterion
        before, after = self.before.get(name, math.nan), self.after.get(name, math.nan)
        return after / before - 1.0 if before > 0 else math.nan

    def __str__(self) -> str:
        if self.criterion not in self.before:
            return f"held out ({self.folds}): the model could not be refitted without any fold"
        parts = []
        for name in (self.criterion, *(n for n in self.before if n != self.criterion)):
            parts.append(f"{name} error {self.before[name]:.3g} -> {self.after[name]:.3g} "
                         f"({100 * self.change(name):+.1f} %)")
        verdict = "confirmed" if self.confirmed else "not confirmed"
        if self.every_fold and not self.confirmed and self.wins < self.n_folds:
            verdict += " (a force of time alone must lower it in every fold)"
        left = " (the folds left were not fitted: none could confirm it)" if self.stopped else ""
        return (f"held out ({self.folds}): {'; '.join(parts)}; lower in {self.wins} of "
                f"{self.n_folds} folds: {verdict} by the {self.criterion} error{left}")


def make_folds(data: Record) -> tuple[str, list[np.ndarray]]:
    """Row positions of each held-out fold, and the split in words.

    Several experiments are folds of their own (at most :data:`MAX_FOLDS`,
    neighbours merged). A single experiment is cut into contiguous chunks,
    dealt to :data:`FOLDS` folds in turn (up to :data:`CHUNKS_PER_FOLD`
    chunks each, of at least :data:`MIN_CHUNK` samples when the record is long
    enough): each fold then
    covers the whole record, so that a free decay or a slow sweep is not
    judged by extrapolation, while its chunks stay far longer than the
    noise's correlation. Simulation windows end with their chunk.
    """
    groups = [rows for _, rows in data.experiment_rows if len(rows)]
    if len(groups) >= 2:
        bins = np.array_split(np.arange(len(groups)), min(len(groups), MAX_FOLDS))
        folds = [np.concatenate([groups[i] for i in part]) for part in bins]
        return f"{len(folds)} folds of {len(groups)} experiments", folds
    rows = groups[0]
    per_fold = int(np.clip(len(rows) // (FOLDS * MIN_CHUNK), 1, CHUNKS_PER_FOLD))
    chunks = np.array_split(rows, FOLDS * per_fold)
    folds = [np.concatenate(chunks[i::FOLDS]) for i in range(FOLDS)]
    if per_fold == 1:
        return f"{FOLDS} blocks in time", folds
    return f"{FOLDS} folds of {per_fold} interleaved blocks in time", folds


def fold_labels(data: Record, held: np.ndarray) -> np.ndarray:
    """Experiment labels that keep the training rows on either side of a held-out block apart."""
    base = np.empty(data.n_samples, dtype=object)
    for label, rows in data.experiment_rows:
        base[rows] = "" if label is None else str(label)
    gap = np.zeros(data.n_samples, dtype=int)
    gap[held] = 1
    piece = np.cumsum(gap)  # changes across every held-out row
    return np.array([f"{b}#{p}" for b, p in zip(base, piece)], dtype=object)


def held_out_blocks(data: Record, held: np.ndarray) -> np.ndarray:
    """Experiment labels of the rows ``held`` (in order): one per block of consecutive rows."""
    base = np.empty(data.n_samples, dtype=object)
    for label, rows in data.experiment_rows:
        base[rows] = "" if label is None else str(label)
    held = np.asarray(held)
    starts = np.ones(len(held), dtype=int)
    starts[1:] = (np.diff(held) != 1) | (base[held[1:]] != base[held[:-1]])
    return np.array([f"{b}#{k}" for b, k in zip(base[held], np.cumsum(starts))], dtype=object)


def _fit(estimator, data: Record, train: np.ndarray, labels: np.ndarray,
         output_error: bool):
    if not output_error:  # an equation fit needs no neighbours (an output-error one does)
        train = thin(train)
    # judged by its errors alone: no refits on resamples
    estimator = prepared(estimator, fit_mode="simulation" if output_error else "equation")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit_rows(estimator, data, train, pieces=labels if data.has_time else None)


def _errors(model, test: Record, spreads, horizon: Horizon | None,
            steps: int, *, equations) -> dict[str, float]:
    """Normalised mean squared errors of ``model`` on the held-out rows."""
    out = {}
    if horizon is not None:
        states = model.skeleton_.states
        measured = np.column_stack([test.columns[s] for s in states])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulated, _, _ = simulate_against(model, test, horizon, max_steps=steps)
        error = ((simulated - measured) / spreads["states"]) ** 2
        out["simulation"] = float(np.mean(np.where(np.isfinite(error), error, 1.0)))
    predicted = test.predict(model)[:, equations]
    error = ((predicted - test.derivatives[:, equations]) / spreads["derivatives"]) ** 2
    out["derivatives"] = float(np.mean(np.where(np.isfinite(error), error, 1.0)))
    return out


def _fold_errors(base, extended, data: Record, held: np.ndarray, spreads, *,
                 horizon: Horizon | None, max_steps: int, equations, output_error: bool):
    """Held-out errors on one fold of ``base`` and ``extended``, each refitted without it.

    Either is None when it was not asked for (``base`` None) or failed.
    """
    train = np.setdiff1d(np.arange(data.n_samples), held)
    labels = fold_labels(data, held)
    test = data.subset(held)
    out = []
    for model in (base, extended):
        if model is None:
            out.append(None)
            continue
        try:
            out.append(_errors(_fit(model, data, train, labels, output_error), test, spreads,
                               horizon, max_steps, equations=equations))
        except Exception:  # a fold a model cannot be fitted on is a finding, not a crash
            out.append(None)
    return tuple(out)


def _capped(errors: dict[str, float]) -> dict[str, float]:
    """A fold's errors as they are pooled: the simulation's at most :data:`USELESS`."""
    return {name: error if error == math.inf or name != "simulation"
            else min(error, USELESS) for name, error in errors.items()}


def held_out_check(base, extended, data: Record, horizon: Horizon | None,
                   equations: list[int], *, max_steps: int, output_error: bool = False,
                   cache: dict | None = None, rule: str = "gain",
                   n_jobs: int | None = None, gain: float = HELD_OUT_GAIN,
                   every_fold: bool = False) -> HeldOut:
    """Fit ``base`` and ``extended`` without each fold and compare them on it.

    Parameters
    ----------
    base, extended : CCRegressor
        Fitted models without and with the effect (cloned, never modified).
    data : Record
    horizon : Horizon or None
        The diagnosis's horizon; None to judge by the derivatives alone.
    equations : list of int
        The equations whose derivatives are compared.
    max_steps : int
        Solver step limit of a whole-experiment simulation.
    output_error : bool
        Refit by output error (``fit_mode="simulation"``) rather than on
        the derivatives.
    cache : dict, optional
        Held-out errors of ``base`` by fold, filled and reused across
        candidates.
    rule : {"gain", "no_loss"}, default="gain"
        What confirms ``extended``: a clear fall of the held-out error (an
        effect worth adding), or no rise of it, in most folds and pooled (a
        term worth removing: ``extended`` is then the smaller model).
    n_jobs : int or None, default=None
        Fit the folds in parallel with joblib. Fitted one after another
        (None or 1), the folds left are not fitted once the effect has lost
        in too many to be confirmed (:attr:`HeldOut.stopped`); the verdict
        is the same either way.
    gain : float, default=HELD_OUT_GAIN
        Least relative fall of the pooled deciding error that confirms
        ``extended`` under ``rule="gain"``.
    every_fold : bool, default=False
        Under ``rule="gain"``, confirm only an effect that lowers the
        deciding error in every fold, not in most: for a force of time alone
        (a drift, an unmeasured periodic force), which acts through the
        whole record where it is real, while the slow wander of coloured
        noise, or one fold's fit of the model without it gone astray, helps
        it in some folds only.
    """
    description, folds = make_folds(data)
    criterion = "simulation" if horizon is not None else "derivatives"
    states = base.skeleton_.states
    spreads = {"states": np.std(np.column_stack([data.columns[s] for s in states]), axis=0),
               "derivatives": np.std(data.derivatives[:, equations], axis=0)}
    for value in spreads.values():
        value[value == 0] = 1.0
    result = HeldOut(description, criterion, every_fold=every_fold and rule == "gain")
    totals = {"before": {}, "after": {}}
    cache = {} if cache is None else cache
    keys = [(i, tuple(equations)) for i in range(len(folds))]
    jobs = [delayed(_fold_errors)(base if key not in cache else None, extended, data, held,
                                  spreads, horizon=horizon, max_steps=max_steps,
                                  equations=equations, output_error=output_error)
            for key, held in zip(keys, folds)]
    # one after another, lazily: the folds left are not fitted once they cannot confirm it
    lazy = n_jobs in (None, 1)
    outcomes = jobs and (Parallel(n_jobs=n_jobs)(jobs) if not lazy
                         else (job[0](*job[1], **job[2]) for job in jobs))
    # losses beyond which no majority (or, for a force of time, no clean sweep) is left
    allowed = 0 if result.every_fold else (len(folds) + 1) // 2 - 1
    n = 0
    for i, (held, key, (before, after)) in enumerate(zip(folds, keys, outcomes)):
        if key not in cache:
            cache[key] = before
        if cache[key] is None:
            continue
        if after is None:  # a fold the effect cannot be fitted on counts against it
            after = {name: math.inf for name in cache[key]}
        before, after = _capped(cache[key]), _capped(after)
        weight = len(held)
        n += weight
        result.n_folds += 1
        for name in before:
            totals["before"][name] = totals["before"].get(name, 0.0) + weight * before[name]
            totals["after"][name] = totals["after"].get(name, 0.0) + weight * after[name]
        result.wins += int(after[criterion] < before[criterion])
        if lazy and result.n_folds - result.wins > allowed and i < len(folds) - 1:
            result.stopped = True
            break
    if not n:
        return result
    result.before = {k: math.sqrt(v / n) for k, v in totals["before"].items()}
    result.after = {k: math.sqrt(v / n) for k, v in totals["after"].items()}
    others = [result.change(name) for name in result.before if name != criterion]
    fall = result.before[criterion] - result.after[criterion]
    if rule == "no_loss":
        result.confirmed = bool(result.change() <= 0.0 and 2 * result.wins > result.n_folds
                                and all(change < HELD_OUT_GAIN for change in others))
        return result
    most = result.wins == result.n_folds if every_fold else 2 * result.wins > result.n_folds
    result.confirmed = bool(result.change() <= -gain and fall >= HELD_OUT_FLOOR and most
                            and all(change < HELD_OUT_GAIN for change in others))
    return result


def pooled_errors(model, data, equations: list[int], horizon, max_steps: int):
    """Errors of ``model`` refitted without each fold, on that fold, pooled over folds."""
    description, folds = make_folds(data)
    states = model.skeleton_.states
    spreads = {"states": np.std(np.column_stack([data.columns[s] for s in states]), axis=0),
               "derivatives": np.std(data.derivatives[:, equations], axis=0)}
    for value in spreads.values():
        value[value == 0] = 1.0
    output_error = getattr(model, "fit_mode_", "equation") == "simulation"
    everything = np.arange(data.n_samples)
    totals: dict[str, float] = {}
    count = 0
    for held in folds:
        train = np.setdiff1d(everything, held)
        try:
            fitted = _fit(model, data, train, fold_labels(data, held), output_error)
            errors = _errors(fitted, data.subset(held), spreads, horizon, max_steps,
                             equations=equations)
        except Exception:  # a fold the skeleton cannot be fitted on counts as a failure
            errors = {"derivatives": math.inf}
            if horizon is not None:
                errors["simulation"] = math.inf
        for name, value in errors.items():
            totals[name] = totals.get(name, 0.0) + len(held) * value
        count += len(held)
    names = {"derivatives": "held_out_nrmse", "simulation": "held_out_simulation_nrmse"}
    return description, {names[k]: math.sqrt(v / count) for k, v in totals.items()}
