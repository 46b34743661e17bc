"""The decision rules of a diagnosis: which refitted candidate, if any, is named.

The pipeline (:mod:`.diagnose`) screens and refits candidates; here they are
ordered, the eligible ones judged (first on the whole record's output error,
then on held-out folds), a simpler rival preferred when it does as well, a
superfluous term removed, a free curve confirmed and given a formula, and the
chosen one written as a :class:`~.report.Suggestion`.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
from scipy.stats import f as f_law

from ..exceptions import SkeletonError
from ..fitting.fingerprint import fitted_on
from ..measurements.noise import read_frame_noise
from ..measurements.record import Record
from ..skeleton import Bound, Skeleton
from ._candidates import TIE, Candidate, extend, refit_candidates, start_values
from ._data import TIME
from ._held_out import held_out_check
from ._likelihood_judge import removal_check
from ._open_curves import OpenCurve, formula_candidates
from ._refit import prepared
from ._trajectories import Horizon
from .report import Suggestion

__all__ = ["decide_addition", "decide_open", "decide_removal", "eligible_candidates",
           "formula_for", "group_of", "open_gain", "ordered_candidates", "residual_memory",
           "score_of", "significant_under_push", "simulates_better", "suggestion_for",
           "whole_record_error"]

#: a candidate whose simulation error is at most this share of the model's is worth a
#: held-out check even when it removes little of the derivative residual
SIMULATION_GAIN = 0.5
#: how many candidates are checked on held-out data, best first, until one is confirmed
N_HELD_OUT = 2
#: what a move between two states acts through: the best of them is checked beside the
#: first N_HELD_OUT
BETWEEN_STATES = ("link", "interaction")
#: a simpler effect whose held-out error is within this share of a confirmed leader's
#: (same equation and variable) is named instead
PARSIMONY = 0.05
#: least relative fall of the whole record's output error that an effect must bring before
#: the held-out folds judge it (a model fitted by output error): folds fitted on short
#: blocks can favour a term that one trajectory through the whole record does not
WHOLE_RECORD_GAIN = 0.01
#: how many times what its numbers would take out of the noise alone a candidate must take
#: out of the whole record's output error (see :func:`chance_fall`)
CHANCE_Z = 3.0
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


#: least relative fall of the held-out error that confirms a free curve: it brings many
#: more numbers than a catalogue term, and is tried only once none of those helped
OPEN_GAIN = 0.05
#: free curves checked on held-out data, best first
N_OPEN = 2


def group_of(c: Candidate) -> int:
    if c.refit is not None and c.plausible:
        return 0
    if c.refit is not None:
        return 1
    return 2


def score_of(c: Candidate) -> float:
    return -c.delta_bic if c.refit is not None else -c.screen_bic


def ordered_candidates(candidates: list[Candidate]) -> list[Candidate]:
    """Best first: plausible refits, then the others, then those only screened.

    Within a group, a candidate whose score is within :data:`TIE` of the
    leader's and that has fewer parameters goes first: when another effect
    is still missing, a more flexible term (Stribeck for Coulomb) soaks up
    part of that other effect's residual, and the information criterion
    alone would reward it. Of those with as many, one that keeps the
    user's terms goes before one that replaces them: a replacement confirmed
    is checked against the same effect beside those terms anyway
    (:func:`_preferred`), and the user's terms are what they know. Then a
    law the state's field knows by name (a diode's current on a voltage)
    goes before a shape it does not (a power law).
    """
    finite = [c for c in candidates if math.isfinite(score_of(c))]
    remaining = sorted(finite, key=lambda c: (group_of(c), -score_of(c)))
    out = []
    while remaining:
        lead = remaining[0]
        margin = max(TIE[0] * abs(score_of(lead)), TIE[1])
        close = [c for c in remaining
                 if group_of(c) == group_of(lead) and score_of(lead) - score_of(c) <= margin]
        pick = min(close, key=lambda c: (c.n_change, c.move == "replace", not _named(c),
                                         -score_of(c)))
        out.append(pick)
        remaining.remove(pick)
    return out


def _named(c: Candidate) -> bool:
    """Whether the field of the state ``c`` acts on names its effect."""
    roles = getattr(c, "roles", None)  # a move judged without roles names nothing
    return roles is not None and roles.position_quantity in dict(c.effect.names)


def eligible_candidates(ordered: list[Candidate], min_improvement: float, bic_threshold: float,
              simulation_rmse: float, memory: np.ndarray | None = None) -> list[Candidate]:
    """Plausible refits that clear the BIC and help the derivatives or the simulation.

    ``memory`` (a model fitted by its Kalman filter: the record is pushed by
    disturbances) holds each equation's residual memory
    (:func:`residual_memory`); a candidate that removes less than
    ``min_improvement`` is then eligible where what it removes is
    significant (:func:`significant_under_push`).
    """
    out = []
    for c in ordered:
        if group_of(c) != 0 or c.delta_bic > -bic_threshold:
            continue
        if c.removed >= min_improvement or simulates_better(c, simulation_rmse) or (
                memory is not None and significant_under_push(c, memory)):
            out.append(c)
    return out


#: significance at which an effect that removes little of a pushed record's derivative
#: residual is still worth judging by the filter's held-out likelihood: a random push fills
#: the residual, and a real effect it hides (a light asymmetric damping) removes a few
#: percent of it where min_improvement asks ten
PUSHED_P = 1e-3


def significant_under_push(c: Candidate, memory: np.ndarray) -> bool:
    """Whether the share of the residual ``c`` removes is significant, samples counted by memory.

    An F test of the ``c.n_change`` numbers it adds on ``n / memory``
    independent samples: the push, low-passed by the differentiation, leaves
    a residual whose neighbouring samples are far from independent.
    """
    if c.after_squares is None or not c.equations or not math.isfinite(c.removed):
        return False
    k = max(int(c.n_change), 1)
    n_eff = len(c.after_squares) / max(float(np.max(memory[c.equations])), 1.0)
    if n_eff <= k + 2 or c.removed <= 0:
        return False
    statistic = (c.removed / k) / max((1.0 - c.removed) / (n_eff - k - 1), 1e-300)
    return float(f_law.sf(statistic, k, n_eff - k - 1)) <= PUSHED_P


def residual_memory(residuals: np.ndarray) -> np.ndarray:
    """How many samples one independent sample of each residual column is worth.

    The integrated autocorrelation time ``1 + 2 sum_k rho_k``, summed up to
    the first lag whose autocorrelation is not positive (and at most 500
    lags): 1 for white residuals, ``(1 + pole) / (1 - pole)`` for AR(1).
    """
    residuals = np.asarray(residuals, dtype=float)
    out = np.ones(residuals.shape[1])
    for j in range(residuals.shape[1]):
        e = residuals[:, j][np.isfinite(residuals[:, j])]
        e = e - e.mean()
        total = float(e @ e)
        if len(e) < 8 or total <= 0:
            continue
        spectrum = np.abs(np.fft.rfft(e, 2 * len(e))) ** 2
        rho = np.fft.irfft(spectrum)[1:min(len(e) // 2, 500)] / total
        stop = np.flatnonzero(rho <= 0)
        rho = rho[:stop[0]] if stop.size else rho
        out[j] = 1.0 + 2.0 * float(np.sum(rho))
    return out


def simulates_better(c: Candidate, simulation_rmse: float) -> bool:
    return (math.isfinite(c.simulation_rmse) and math.isfinite(simulation_rmse)
            and c.simulation_rmse <= SIMULATION_GAIN * simulation_rmse)


def decide_addition(eligible: list[Candidate], model, data: Record, horizon: Horizon | None,
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
    # on a mechanical equation how the input is read is tried after the state's own
    # physics: a missing damping shifts the phase of a forced response, which a delay of
    # the input imitates
    eligible = sorted(eligible, key=lambda c: c.effect.acts_through == "input"
                      and (c.roles.second_order or c.roles.mechanical))

    def check(c: Candidate) -> bool:
        if output_error and record is not None and _short_of_whole_record(
                c, model, record, cache,
                **_whole_record_gain(c, model, record, WHOLE_RECORD_GAIN, cache=cache)):
            return False
        c.held_out = held_out_check(model, c.refit, data, horizon, equations,
                                    max_steps=steps, output_error=output_error, cache=cache,
                                    n_jobs=n_jobs, every_fold=c.effect.acts_through == "time")
        if not c.held_out.confirmed:
            c.note = "; ".join(filter(None, [c.note, str(c.held_out)]))
        return c.held_out.confirmed

    per_number = _per_number(model, record) if output_error and record is not None else None
    for c in eligible[:N_HELD_OUT]:
        if check(c):
            return _preferred(c, eligible, check, per_number)
    # on a network the missing effect is often a path or a reaction between two states, which
    # coloured noise ranks below laws of one state's own value (a tank's outflow beside the
    # orifice that joins it to the next): the best of those is checked too
    between = next((c for c in eligible[N_HELD_OUT:]
                    if c.effect.acts_through in BETWEEN_STATES), None)
    if between is not None and check(between):
        return _preferred(between, eligible, check, per_number)
    return None


def chance_fall(c: Candidate, model, record: pd.DataFrame, cache: dict | None = None) -> float:
    """The fall of the whole record's output error a candidate must beat.

    ``k`` numbers fitted to noise take about ``k`` independent samples' worth
    out of its sum of squares, a relative ``k memory / n`` of ``n`` samples
    whose noise has that memory (:attr:`SignalNoise.memory
    <sklearn_pycc.measurements.SignalNoise.memory>`; 1 for white noise), and
    half of that out of its root: the ``k`` numbers a candidate adds must
    take out :data:`CHANCE_Z` times as much. Coloured noise wanders slowly,
    and a term that follows its wander is no physics: a free curve of many
    numbers, a drift or a periodic force of free frequency, which follows
    anything slow, or a catalogue law (a dead zone beside a real Coulomb
    friction took 1.1 % out of a record whose noise has a memory of 20
    samples). For a force of time and a free curve the memory is at least
    that of the slow wander the model leaves in its own output errors
    through the whole record
    (:func:`~sklearn_pycc.measurements.noise.slow_memory`): a sensor's drift
    lies below the signal's band, where the noise read from the record
    cannot show it; a slow force and a slow drift of the sensor look alike
    there, and a free curve's many numbers find a way to follow it (a free
    friction curve took 25 % out of a record whose sensor drifted, and
    raised the held-out error 2.3 times). ``cache`` as for
    :func:`whole_record_error`. 0 for a candidate that adds no number, or a
    record without time.
    """
    return _chance(c, model, record, cache)[0]


def _chance(c: Candidate, model, record: pd.DataFrame,
            cache: dict | None) -> tuple[float, str]:
    """:func:`chance_fall`, and what its memory was read from, in words."""
    per_number = _per_number(model, record)
    if not per_number or c.n_change <= 0:
        return 0.0, ""
    source = "this record's noise"
    if c.effect.acts_through == "time" or c.move == "open":
        wander = _chance_share(_whole_record(model, record, cache)[1], record)
        if wander > per_number:
            per_number, source = wander, ("the slow wander the model leaves through the "
                                          "record (a sensor's drift, a slow force)")
    return c.n_change * per_number, source


def _per_number(model, record: pd.DataFrame) -> float:
    """:func:`chance_fall` of one number on the record's noise (0 without time or states)."""
    states = [s for s in getattr(model, "measured_states_", ()) if s in record.columns]
    if TIME not in record.columns or not states:
        return 0.0
    memory = max(reading.memory for reading in read_frame_noise(record, states).values())
    return _chance_share(memory, record)


def _chance_share(memory: float, record: pd.DataFrame) -> float:
    """:data:`CHANCE_Z` times what one number takes out of the root error of such noise."""
    return CHANCE_Z * memory / (2.0 * len(record))


def _whole_record_gain(c: Candidate, model, record: pd.DataFrame, floor: float, *,
                       cache: dict | None = None) -> dict:
    """``gain`` and ``why`` of :func:`_short_of_whole_record`: ``floor``, or chance where more."""
    chance, source = _chance(c, model, record, cache)
    if chance <= floor:
        return {"gain": floor}
    what = ("a free curve" if c.move == "open" else "a force of time"
            if c.effect.acts_through == "time" else f"an effect of {c.n_change} "
            f"number{'s' if c.n_change > 1 else ''}")
    return {"gain": chance, "why": f"{what} must lower it by {100 * chance:.1f} %, "
            f"{CHANCE_Z:g} times what its numbers would take out of {source}"}


def _short_of_whole_record(c: Candidate, model, record: pd.DataFrame, cache: dict, *,
                           gain: float = WHOLE_RECORD_GAIN, why: str = "") -> bool:
    """Whether ``c`` lowers the whole ``record``'s output error by less than it must.

    Both skeletons fitted by output error to the measured record, ends
    included (:func:`whole_record_error`); ``c`` must lower its error by
    ``gain``, as said in its note where it does not (with ``why``). One
    fit that spares the held-out folds' several, and a guard against
    folds fitted on short blocks that favour a term one trajectory through
    the whole record does not.
    """
    asked = c.whole_record is not None  # judged before: its note says so already
    if not asked:
        c.whole_record = whole_record_error(c.refit, record)
    before, after = whole_record_error(model, record, cache), c.whole_record
    if after <= (1 - gain) * before:
        return False
    if asked:
        return True
    c.note = "; ".join(filter(None, [c.note, (
        f"not confirmed by the whole record: its output error goes from {before:.4g} to "
        f"{after:.4g} of its spread ({100 * (after / before - 1):+.1f} %)"
        + (f", and {why}" if why else ""))]))
    return True


def _preferred(c: Candidate, eligible: list[Candidate], check,
               per_number: float | None = None) -> Candidate:
    """The candidate to name once held-out data confirmed ``c`` (``check`` judges others).

    ``c`` itself, the same effect beside the terms it would replace, a
    simpler effect that does as well, or a rival that does clearly better.
    ``per_number`` (a model fitted by output error) is the fall of the whole
    record's error one number takes out by chance (:func:`chance_fall`).
    """
    # a term the user wrote goes only where the data its fit did not see favour
    # dropping it: the same effect added beside it is checked too, and kept unless
    # the replacement does clearly better (a light viscous damping under a
    # quadratic drag costs a noisy record little, and a fresh one much), or the
    # term earns nothing through the whole record
    beside = _beside(c, eligible)
    if beside is not None and check(beside):
        crit = c.held_out.criterion
        if c.held_out.after[crit] > (1 - PARSIMONY) * beside.held_out.after[crit] \
                and not _earns_nothing(beside, c, per_number):
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
        why = _rival_wins(rival, c)
        if why:
            rival.note = "; ".join(filter(None, [rival.note,
                                                 f"preferred to {c.effect.name} ({why})"]))
            return rival
    return c


def _earns_nothing(beside: Candidate, replacement: Candidate,
                   per_number: float | None) -> bool:
    """Whether the user's terms ``beside`` keeps bring nothing the ``replacement`` lacks.

    Both confirmed on held-out data, the replacement's held-out error no
    higher, and its whole-record output error (the model fitted by output
    error) within what the kept terms' numbers would take out by chance:
    the larger model holds the smaller, so the terms it keeps earn that
    much at least if they are real. Its note says so.
    """
    if per_number is None:
        return False
    crit = replacement.held_out.criterion
    whole = replacement.whole_record, beside.whole_record
    if not all(w is not None and math.isfinite(w) for w in whole) \
            or replacement.held_out.after[crit] > beside.held_out.after[crit]:
        return False
    kept = max(beside.n_change - replacement.n_change, 1)
    if whole[0] > (1 + kept * per_number) * whole[1]:
        return False
    replacement.note = "; ".join(filter(None, [replacement.note, (
        f"preferred to keeping '{' + '.join(replacement.replaces)}' beside it: the whole "
        f"record's output error is {whole[0]:.4g} without and {whole[1]:.4g} with, and the "
        f"held-out {crit} error {replacement.held_out.after[crit]:.3g} against "
        f"{beside.held_out.after[crit]:.3g}")]))
    return True


def _rival_wins(rival: Candidate, leader: Candidate) -> str:
    """Why ``rival`` is to be named rather than ``leader``, both confirmed; empty if not.

    By the held-out error, lower by :data:`PARSIMONY`, unless one trajectory
    through the whole record says otherwise. A rival that refines the leader's
    law (it :attr:`~sklearn_pycc.effects.Effect.replaces` it: Stribeck's
    friction Coulomb's) also wins by that whole record's output error, lower by
    as much (both known when the model was fitted by output error), unless the
    held-out error is higher by as much: windows restarted from noisy states
    cannot see the detail the refinement adds (the breakaway peak at low
    speed, on a coloured record), and one trajectory through the whole record
    can. An unrelated shape does not win so: through the whole record a
    flexible shape also stands in for another effect still missing (a dead
    zone for the cubic spring, while a quadratic drag is missing), which the
    held-out windows do not let it do.
    """
    crit = leader.held_out.criterion
    held_out = rival.held_out.after[crit], leader.held_out.after[crit]
    whole = rival.whole_record, leader.whole_record
    known = all(w is not None and math.isfinite(w) for w in whole)
    refines = leader.effect.name in rival.effect.replaces
    if known and refines and whole[0] <= (1 - PARSIMONY) * whole[1] \
            and held_out[0] <= (1 + PARSIMONY) * held_out[1]:
        return f"whole-record output error {whole[0]:.4g} against {whole[1]:.4g}"
    if held_out[0] <= (1 - PARSIMONY) * held_out[1] and not (known and whole[0] > whole[1]):
        return f"held-out {crit} error {held_out[0]:.3g} against {held_out[1]:.3g}"
    if known and held_out[0] <= (1 - PARSIMONY) * held_out[1]:
        leader.note = "; ".join(filter(None, [leader.note, (
            f"preferred to {rival.effect.name}, which the held-out {crit} error favours "
            f"({held_out[0]:.3g} against {held_out[1]:.3g}): the whole record's output "
            f"error does not ({whole[0]:.4g} against {whole[1]:.4g})")]))
    return ""


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
    margin = max(TIE[0] * abs(score_of(leader)), TIE[1])
    for other in eligible:
        if (other is not leader and other.held_out is None
                and other.effect.name != leader.effect.name  # another shape, not a move
                and (other.roles.index, other.variable) == (leader.roles.index,
                                                            leader.variable)
                and other.n_change >= leader.n_change
                and (score_of(leader) - score_of(other) <= margin
                     or simulates_better(other, leader.simulation_rmse))):
            return other
    return None


def decide_removal(removals: list[Candidate], model, data: Record,
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
    release decays, is often what shows it). On a model fitted by its
    filter (process noise recognised), the filter's held-out likelihood
    judges the removal instead (:func:`~._likelihood_judge.removal_check`).
    """
    output_error = getattr(model, "fit_mode_", "equation") == "simulation"
    for c in sorted((c for c in removals if group_of(c) == 0 and c.delta_bic < 0),
                    key=lambda c: c.delta_bic):
        if not held_out:
            return c if c.delta_bic <= -REMOVAL_BIC else None
        if getattr(model, "fit_mode_", None) == "filter":
            # a push fills the derivatives and wanders the simulations: the filter judges
            c.likelihood = removal_check(model, c.refit, data, n_removed=-c.n_change,
                                         n_jobs=n_jobs)
            if c.likelihood.confirmed:
                return c
            c.note = "; ".join(filter(None, [c.note, str(c.likelihood)]))
            return None
        if output_error and record is not None:
            with_it = whole_record_error(model, record, cache)
            without = whole_record_error(c.refit, record)
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


def whole_record_error(model, record: pd.DataFrame, cache: dict | None = None) -> float:
    """The output error (normalised) of ``model``'s skeleton fitted by it to ``record``.

    The measured record as given, ends included (the diagnosis leaves out
    where its derivative filters settle, and a release often decays there).
    Inf where that fit fails; ``cache`` keeps it under ``"whole_record"``
    (the model's own, asked for again by each check).
    """
    return _whole_record(model, record, cache)[0]


def _whole_record(model, record: pd.DataFrame, cache: dict | None = None) -> tuple[float, float]:
    """:func:`whole_record_error`, and the slow memory of that fit's output errors.

    The memory (:func:`~sklearn_pycc.measurements.noise.slow_memory`) is 1
    where the fit failed or its backend does not say.
    """
    if cache is not None and "whole_record" in cache:
        return cache["whole_record"]
    if getattr(model, "fit_mode_", None) == "simulation" and fitted_on(model, record):
        info = model.shooting_  # it was fitted so on this very record
    else:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                info = prepared(model, fit_mode="simulation").fit(record).shooting_
        except Exception:  # a skeleton the record cannot fit this way is no answer
            info = {}
    out = (float(info.get("nrmse_after", math.inf)), float(info.get("slow_memory", 1.0)))
    if cache is not None:
        cache["whole_record"] = out
    return out


def open_gain(c: Candidate, model, record: pd.DataFrame, cache: dict | None = None) -> float:
    """Least relative fall of the error a free curve must bring: :data:`OPEN_GAIN`, or chance.

    On a model fitted by output error, :func:`chance_fall` where that is
    more (its many numbers on coloured noise, or where the model's errors
    wander slowly through the record).
    """
    if getattr(model, "fit_mode_", "equation") != "simulation":
        return OPEN_GAIN
    return max(OPEN_GAIN, chance_fall(c, model, record, cache))


def decide_open(eligible: list[Candidate], model, data: Record,
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
        if output_error and record is not None and _short_of_whole_record(
                c, model, record, cache,
                **_whole_record_gain(c, model, record, OPEN_GAIN, cache=cache)):
            continue
        c.held_out = held_out_check(model, c.refit, data, horizon, equations, max_steps=steps,
                                    output_error=output_error, cache=cache, n_jobs=n_jobs,
                                    gain=OPEN_GAIN)
        if c.held_out.confirmed:
            return c
        c.note = "; ".join(filter(None, [c.note, str(c.held_out)]))
    return None


def formula_for(chosen: Candidate, skeleton: Skeleton, model, data: Record,
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
    refit_candidates(formulas, model, data, residuals, rss_before, baseline=baseline,
                     n_jobs=n_jobs)
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


def suggestion_for(c: Candidate, base: Skeleton, model, formula: Candidate | None = None,
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
    also: dict = {}
    for k, text in c.added:
        if k != c.roles.index:
            eq = derivative[k]
            also[eq] = f"{also[eq]} + ({text})" if eq in also else text
    replaced_in: dict = {}
    for k, text in c.removals:
        replaced_in.setdefault(derivative[k], []).append(text)
    if set(replaced_in) <= {c.roles.derivative}:
        replaced_in = {}
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
        effect=c.effect.name, equation=c.roles.derivative,
        description=c.effect.description + _stoichiometry(c, skeleton),
        variable=c.variable, term=c.term, equations=skeleton, move=c.move,
        replaces=c.replaces,
        # a candidate the filter chose among those only screened starts where the screen put it
        param_init={a: float(v) for a, v in (
            c.refit.params_ if c.refit is not None else start_values(model, c)).items()},
        curve_term=curve_term, curve_constraints=curve_constraints, also=also,
        error_removed=float(c.removed), delta_bic=float(c.delta_bic),
        simulation_rmse=float(c.simulation_rmse), held_out=c.held_out,
        bounds=tuple(str(x) for x in skeleton.constraints
                     if isinstance(x, Bound) and x not in base.constraints),
        intervals=intervals, settings={} if c.refit is None else _settings(c.refit, model),
        called=c.effect.called(c.roles.quantity_of(c.effect.acts_through)),
        replaced_in={eq: tuple(terms) for eq, terms in replaced_in.items()},
        likelihood=c.likelihood)


def _stoichiometry(c: Candidate, skeleton) -> str:
    """``"; at one rate ..., the stoichiometry of A + B -> C"`` for a balanced reaction."""
    if not c.balanced:
        return ""
    states = [skeleton.parsed[k].state for k, _ in c.additions]
    formed = " + ".join(states[2:]) or "what is not measured"
    return (f"; at one rate in every balance it enters, the stoichiometry of "
            f"{states[0]} + {states[1]} -> {formed}")


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
