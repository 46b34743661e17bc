"""Held-out likelihood: the judge of an effect on a record that process noise pushes.

Where disturbances nobody measured push the dynamics, a simulation wanders
away from the record for reasons no skeleton can fix, and a held-out
simulation error says more about the wander than about the effect. The
filter's likelihood does not wander: each held-out sample is judged by the
one-step prediction the filter makes from the samples before it. The record
is split into folds as for the simulation judge
(:func:`~._held_out.make_folds`); the model with and without the effect is
fitted by the filter (``fit_mode="filter"``) without each fold and scores
that fold's samples, each held-out block filtered on its own.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from ..exceptions import SimulationError
from ..measurements.experiments import TRAJECTORY
from ..measurements.record import Record, read_record
from ._held_out import fold_labels, held_out_blocks, make_folds
from ._refit import prepared

__all__ = ["IN_SAMPLE_ALPHA", "LikelihoodJudgement", "filter_frame", "likelihood_check",
           "reconsidered", "removal_check", "whole_record"]

#: least held-out log-likelihood an effect must add, per held-out sample and per number it
#: adds, beside a win in most folds: a record pushed by disturbances holds few independent
#: stretches, and a term with nothing to fit has gained two thousandths by chance (half the
#: completeness a loop is judged by, a hundredth per sample)
LEAST_GAIN = 5e-3
#: the least gain, as a share of :data:`LEAST_GAIN`, of an effect that raises the held-out
#: likelihood in every fold: a real effect the push hides wins each fold by a little (a
#: light asymmetric damping under a strong push, 0.0038 per sample), and a term with
#: nothing to fit rarely wins them all (a cubic spring on a pushed linear oscillator did,
#: by 0.0022 and 0.0026)
EVERY_FOLD_SHARE = 0.7
#: most held-out log-likelihood per held-out sample a removed number may cost, as a share of
#: :data:`LEAST_GAIN`: what a term with nothing to fit gains by chance (a cubic spring on a
#: pushed linear oscillator, 0.0022 to 0.0026), so a term that earns no more than that is
#: not worth its number (a linear outflow beside a tank's Torricelli law)
REMOVAL_SHARE = 0.5
#: the likelihood-ratio p-value on the whole record (family-wise: times the candidates
#: tried) at which chance is ruled out in-sample, and a held-out gain of any size in most
#: folds confirms the effect: a term with nothing to fit has a p-value near a half (a
#: spurious cubic spring on a pushed linear oscillator gained at most 2.3 in
#: log-likelihood, p = 0.03), an effect the push hid one below 1e-5
IN_SAMPLE_ALPHA = 1e-4
#: how much worse (negative log-likelihood of its own samples) a fit of a larger skeleton may
#: end than one of a skeleton it holds before it counts as failed
FIT_SLACK = 1.0


@dataclass
class LikelihoodJudgement:
    """The held-out likelihood of a model with and without an effect.

    Attributes
    ----------
    folds : str
        How the record was split, in words.
    before, after : float
        Held-out log-likelihood per sample without and with the effect
        (``-inf`` where a fold could not be fitted).
    wins : int
        Folds in which the effect raised it.
    n_folds : int
    confirmed : bool
        Whether the effect raised it by :data:`LEAST_GAIN` per added number
        and won in most folds, or by :data:`EVERY_FOLD_SHARE` of that and won
        in every fold, or at all in most folds where its likelihood-ratio test
        on the whole record ruled chance out (:data:`IN_SAMPLE_ALPHA`,
        ``in_sample``); for a removal (``removal``), whether taking the terms
        out lowered it by no more than :data:`REMOVAL_SHARE` of
        :data:`LEAST_GAIN` per removed number.
    removal : bool
        Whether ``after`` is the model without terms (:func:`removal_check`).
    failed : bool
        For a removal: whether the fit with the terms was worse than the fit
        without them on some fold's own samples (beyond :data:`FIT_SLACK`): a
        failed fit, and no removal.
    in_sample : str or None
        For an effect the filter ranked among the diagnosis's candidates
        (:func:`~._filter_search.likelihood_ratio_search`): its
        likelihood-ratio test on the whole record, in words.
    """

    folds: str
    before: float
    after: float
    wins: int
    n_folds: int
    confirmed: bool
    removal: bool = False
    failed: bool = False
    in_sample: str | None = None

    def __str__(self) -> str:
        verdict = "confirmed" if self.confirmed else "not confirmed"
        change = " without them" if self.removal else ""
        if self.failed:
            verdict += (" (the fit with them was the worse on a fold's own samples: a failed "
                        "fit)")
        return (f"held out by the filter's likelihood ({self.folds}): log-likelihood per sample "
                f"{self.before:.4g} -> {self.after:.4g}{change}; higher in {self.wins} of "
                f"{self.n_folds} folds: {verdict}")


def whole_record(model, X) -> Record:
    """The record of ``X`` with every sample, the ends too, for the filter's in-sample fits.

    The diagnosis leaves out the ends of each experiment, where the estimated
    derivatives cannot be trusted; the filter reads the measured states
    themselves, and a transient at the start (the widest swings of a record)
    often says most about an effect.
    """
    return read_record(model.skeleton_, X, trim=False, split=True, derivatives_from_X=True,
                       who="the filter's judge", hidden_ok=True)


def likelihood_check(base, extended, data: Record, *, n_added: int,
                     cache: dict | None = None, n_jobs: int | None = None,
                     in_sample_p: float | None = None,
                     nested: bool = False) -> LikelihoodJudgement:
    """Fit ``base`` and ``extended`` by the filter without each fold and score them on it.

    Parameters
    ----------
    base, extended : CCRegressor
        Models without and with the effect (cloned, never modified).
    data : Record
        The record: its time, measured states (as measured) and inputs are
        what the folds are cut from.
    n_added : int
        How many numbers the effect adds.
    cache : dict, optional
        ``base``'s held-out log-likelihood by fold, filled and reused.
    n_jobs : int, optional
        Fits run at once (joblib); one after another by default.
    in_sample_p : float, optional
        The p-value of the effect's likelihood-ratio test on the whole record,
        times the candidates tried
        (:func:`~._filter_search.likelihood_ratio_search`). Where it is at
        most :data:`IN_SAMPLE_ALPHA`, chance is ruled out in-sample and the
        held-out samples need only agree: a higher log-likelihood, in most
        folds.
    nested : bool, default=False
        Whether ``extended`` holds ``base`` (an addition: its terms at zero
        give ``base``). A fold whose fit of ``extended`` then ends worse on
        its own samples than that of ``base`` failed, and scores as ``base``
        (a fold fitted here, not one ``cache`` gives).
    """
    description, before, after, wins, n_folds, _ = _fold_scores(base, extended, data, cache,
                                                                n_jobs, nested=nested)
    judgement = LikelihoodJudgement(description, before, after, wins, n_folds, False)
    return reconsidered(judgement, n_added=n_added, in_sample_p=in_sample_p)


def reconsidered(judgement: LikelihoodJudgement, *, n_added: int,
                 in_sample_p: float | None = None) -> LikelihoodJudgement:
    """An addition's held-out scores decided again, knowing its in-sample test's p-value.

    The rule of :func:`likelihood_check`; its held-out fits are not repeated.
    """
    least = LEAST_GAIN * max(n_added, 1)
    if judgement.wins == judgement.n_folds:
        least *= EVERY_FOLD_SHARE
    if in_sample_p is not None and in_sample_p <= IN_SAMPLE_ALPHA:
        least = 0.0
    before, after = judgement.before, judgement.after
    confirmed = bool(math.isfinite(after) and after - before >= least and after > before
                     and 2 * judgement.wins > judgement.n_folds)
    return replace(judgement, confirmed=confirmed)


def removal_check(base, reduced, data: Record, *, n_removed: int,
                  n_jobs: int | None = None) -> LikelihoodJudgement:
    """Fit ``base`` and ``reduced`` (terms taken out) as :func:`likelihood_check` does.

    The removal is confirmed where the held-out log-likelihood per sample
    falls by no more than :data:`REMOVAL_SHARE` of :data:`LEAST_GAIN` per
    removed number, and no fold's fit of ``base`` failed (see
    :attr:`LikelihoodJudgement.failed`).

    Parameters
    ----------
    base, reduced : CCRegressor
        Models with and without the terms (cloned, never modified).
    data : Record
        The record, as for :func:`likelihood_check`.
    n_removed : int
        How many numbers the removal takes out.
    n_jobs : int, optional
        Fits run at once (joblib); one after another by default.

    Returns
    -------
    LikelihoodJudgement
        ``before`` with the terms, ``after`` without them, ``removal`` true.
    """
    description, before, after, wins, n_folds, training = _fold_scores(base, reduced, data,
                                                                       None, n_jobs)
    most = REMOVAL_SHARE * LEAST_GAIN * max(n_removed, 1)
    # the model with the terms holds the one without: where its fit of a fold's training
    # samples is the worse, that fit failed, and the fold says nothing against the terms
    failed = any(training[base, i] > training[reduced, i] + FIT_SLACK for i in range(n_folds))
    confirmed = bool(math.isfinite(after) and math.isfinite(before) and before - after <= most
                     and not failed)
    return LikelihoodJudgement(description, before, after, wins, n_folds, confirmed,
                               removal=True, failed=failed)


def _fold_scores(base, extended, data: Record, cache: dict | None, n_jobs: int | None, *,
                 nested: bool = False):
    """The held-out log-likelihood per sample of both models, and the folds ``extended`` won.

    Last, each fit's negative log-likelihood of its training samples, by
    ``(model, fold)`` (of the folds fitted here: ``cache`` spares some).
    Where ``extended`` holds ``base`` (``nested``: an addition), a fold
    whose fit of ``extended`` ended worse on its own samples than the fit of
    ``base`` (beyond :data:`FIT_SLACK`) failed: the terms at zero would have
    done as well, so that fold scores ``extended`` as ``base``.
    """
    description, folds = make_folds(data)
    cache = {} if cache is None else cache
    jobs = [(model, i) for i in range(len(folds))
            for model in ((base,) if i not in cache else ()) + (extended,)]
    scores = Parallel(n_jobs=n_jobs)(delayed(_held_out_likelihood)(model, data, folds[i])
                                     for model, i in jobs)
    ours, training = {}, {}
    for (model, i), (score, nll) in zip(jobs, scores):
        training[model, i] = nll
        if model is base:
            cache[i] = score
        else:
            ours[i] = score
    totals = {"before": 0.0, "after": 0.0}
    wins, count = 0, 0
    for i, held in enumerate(folds):
        before, after = cache[i], ours[i]
        if nested and (base, i) in training and math.isfinite(training[base, i]) \
                and training[extended, i] > training[base, i] + FIT_SLACK:
            after = before
        totals["before"] += before
        totals["after"] += after
        wins += int(after > before)
        count += len(held)
    return (description, totals["before"] / count, totals["after"] / count, wins,
            len(folds), training)


def _held_out_likelihood(model, data: Record, held: np.ndarray) -> tuple[float, float]:
    """The log-likelihood of the rows ``held``, ``model`` fitted by the filter without them.

    And that fit's negative log-likelihood of the rows it was fitted on
    (inf where the fit failed).
    """
    X = filter_frame(data)
    train = np.setdiff1d(np.arange(data.n_samples), held)
    fit_on = X.assign(**{TRAJECTORY: fold_labels(data, held)}).iloc[train]
    judged = X.iloc[held].assign(**{TRAJECTORY: held_out_blocks(data, held)})
    estimator = prepared(model, fit_mode="filter")
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            fitted = estimator.fit(fit_on.reset_index(drop=True))
            return (float(fitted.log_likelihood(judged.reset_index(drop=True))),
                    float(fitted.filter_["nll"]))
    except (SimulationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return -math.inf, math.inf


def filter_frame(data: Record) -> pd.DataFrame:
    """What the filter reads of ``data``: time, experiments, measured states and inputs.

    The states as measured (raw): never one the differentiation reconstructed,
    as if a sensor had read it.
    """
    return data.frame([]).assign(**data.measured, **data.signals)
