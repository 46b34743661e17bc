"""Where process noise pushes the record: the candidates ranked by the filter's likelihood ratio.

On a record that disturbances push, the estimated derivatives hold the push
and a simulation wanders with it, so the diagnosis's ranking (the derivative
residual each candidate removes) and its held-out simulations can miss an
effect the filter sees plainly. Here the diagnosis's leading candidates (its
plausible refits, then the best screened) are fitted by the filter to the
whole record, and each one's likelihood ratio
against the skeleton without it is read as a test of the numbers it adds
(twice the log-likelihood it gains, against the chi-square law of as many
degrees of freedom). The likeliest of them whose ratio is significant, the
candidates tried counted, is then held out
(:func:`~._likelihood_judge.likelihood_check`): the in-sample test and a
held-out win together confirm it.

A term with nothing to fit gains a log-likelihood of about a half in-sample
(a spurious cubic spring on a pushed linear oscillator gained at most 2.3),
where the effects the push hid gain ten to fifty.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
from joblib import Parallel, delayed
from scipy.stats import chi2

from ..exceptions import SimulationError
from ..measurements.record import Record
from ..skeleton import Skeleton
from ._candidates import Candidate, start_values
from ._decide import group_of
from ._likelihood_judge import (
    IN_SAMPLE_ALPHA,
    LikelihoodJudgement,
    filter_frame,
    likelihood_check,
    reconsidered,
)
from ._refit import prepared

__all__ = ["likelihood_ratio_search"]

#: candidates held out, likeliest first, until one is confirmed
N_JUDGED = 2
#: most candidates the filter fits to the whole record
N_TRIED = 10


def likelihood_ratio_search(model, candidates: list[Candidate], data: Record, *,
                            whole: Record | None = None,
                            judged: tuple[Skeleton, LikelihoodJudgement] | None = None,
                            n_jobs: int | None = None) -> tuple[Candidate | None, list[str]]:
    """The likeliest candidate that the filter confirms, or None; and what was found.

    Parameters
    ----------
    model : CCRegressor
        The diagnosed model (its skeleton is the one without the candidates).
    candidates : list of Candidate
        The diagnosis's candidates: those that add or replace terms are
        tried, the plausible refits first, then the best screened (at most
        :data:`N_TRIED`).
    data : Record
        The record the diagnosis read: the held-out checks cut their folds
        from it.
    whole : Record, optional
        The record with every sample, the ends of the experiments too
        (:func:`~._likelihood_judge.whole_record`), which the in-sample fits
        read (``data`` by default): a release's first swings often say most
        about an effect, and the diagnosis leaves them out for its
        derivatives. The held-out checks keep to ``data``: a block holding
        such a transient would weigh more than all the others.
    judged : (Skeleton, LikelihoodJudgement), optional
        A candidate's skeleton already held out, and that judgement: where
        the candidate is tried again, its held-out scores are read again
        (:func:`~._likelihood_judge.reconsidered`), not refitted.
    n_jobs : int, optional
        Fits run at once (joblib).

    Returns
    -------
    Candidate or None
        The confirmed candidate, its ``likelihood`` set.
    list of str
        The search in words, for the diagnosis's notes.
    """
    tried = _tried(candidates)
    if not tried:
        return None, []
    base = prepared(model, fit_mode="filter")
    fits = [(base, None)] + [(_extended(model, c), c) for c in tried]
    nll = Parallel(n_jobs=n_jobs)(delayed(_in_sample_nll)(estimator, whole or data)
                                  for estimator, _ in fits)
    if not math.isfinite(nll[0]):
        return None, ["the filter could not fit the skeleton itself to the whole record: no "
                      "candidate was ranked by its likelihood ratio"]
    # each p-value times the candidates tried: the family's chance of one spurious win
    ranked = sorted(((min(1.0, len(tried) * _p_value(nll[0] - value, c)), nll[0] - value, c)
                     for value, (_, c) in zip(nll[1:], fits[1:]) if math.isfinite(value)),
                    key=lambda item: item[0])
    significant = [(p, gain, c) for p, gain, c in ranked if p <= IN_SAMPLE_ALPHA]
    if not significant:
        best = (f"; the likeliest, {ranked[0][2].effect.name} in "
                f"{ranked[0][2].roles.derivative}, gains {ranked[0][1]:.3g} (p = "
                f"{ranked[0][0]:.2g})") if ranked else ""
        return None, [f"the filter's likelihood ratio finds none of {len(tried)} candidates "
                      f"significant (p <= {IN_SAMPLE_ALPHA:g}, {len(tried)} tried){best}"]
    notes = []
    for p, gain, c in significant[:N_JUDGED]:
        n_added = max(c.n_change, 1)
        if judged is not None and list(judged[0].equations) == list(c.extended.equations):
            judgement = reconsidered(judged[1], n_added=n_added, in_sample_p=p)
        else:
            judgement = likelihood_check(model, _extended(model, c), data, n_added=n_added,
                                         n_jobs=n_jobs, in_sample_p=p, nested=c.move == "add")
        test = (f"it gains {gain:.3g} in the filter's log-likelihood of the whole record "
                f"(likelihood ratio p = {p:.2g}, the {len(tried)} candidates tried counted)")
        words = f"{c.effect.name} in {c.roles.derivative}: {test}; {judgement}"
        notes.append(words)
        if judgement.confirmed:
            c.likelihood = replace(judgement, in_sample=test)
            c.note = "; ".join(filter(None, [c.note, words]))
            return c, notes
    return None, notes


def _tried(candidates: list[Candidate]) -> list[Candidate]:
    """The candidates the filter fits: the plausible refits, then the best screened.

    At most :data:`N_TRIED`, one per move, effect and equation, in the
    screen's order; a refit found implausible is left out.
    """
    moves = [c for c in candidates if c.move in ("add", "replace") and c.extended is not None
             and group_of(c) != 1 and math.isfinite(c.screen_bic)]
    out, seen = [], set()
    for c in sorted(moves, key=lambda c: (group_of(c), c.screen_bic)):
        key = (c.move, c.effect.name, c.roles.index)
        if key not in seen and len(out) < N_TRIED:
            out.append(c)
            seen.add(key)
    return out


def _extended(model, c: Candidate):
    """``model`` with ``c``'s skeleton, started from its refit's numbers or the screen's."""
    init = start_values(model, c)
    if c.refit is not None:
        init.update({a: v for a, v in c.refit.params_.items() if a in init})
    return prepared(model, equations=c.extended, param_init=init, fit_mode="filter")


def _p_value(gain: float, c: Candidate) -> float:
    """The likelihood-ratio p-value of a gain: a degree per number added, at least one."""
    return float(chi2.sf(2.0 * gain, max(c.n_change, 1))) if gain > 0 else 1.0


def _in_sample_nll(estimator, data: Record) -> float:
    """The filter's negative log-likelihood of the whole record, ``estimator`` fitted to it."""
    X = filter_frame(data)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            fitted = estimator.fit(X.reset_index(drop=True))
        value = float(fitted.filter_["nll"])
    except (SimulationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return math.inf
    return value if math.isfinite(value) and value < 1e100 else math.inf

