"""How firmly the record backs a diagnosis's choice: the choice made again on resamples.

The diagnosis ranks its refitted candidates by the change of the Bayesian
information criterion of the derivative residual, and suggests the best one
that clears the thresholds. Each resample draws blocks of consecutive samples
within each experiment (whole experiments when there are many), as long as
the residual's correlation, and the same rules choose again from the same
refits' residuals on the resampled rows: which candidate clears the
thresholds, and which of those leads (a near tie going to fewer parameters).
A candidate's stability is the share of resamples it wins. The refits are
not repeated (the cost is that of sums over blocks, not of fits), and the
held-out verdicts stand as found: a candidate the held-out check rejected
wins no resample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._utils.blocks import MIN_EXPERIMENTS, block_length, draw_blocks, segments
from .._utils.randomness import seeds
from ._candidates import Candidate, rss_floor

__all__ = ["Stability", "selection_stability"]


@dataclass
class Stability:
    """Wins of each candidate over the resamples.

    Attributes
    ----------
    wins : dict
        ``candidate.key`` -> resamples it won (a key that survives a copy or a pickle).
    nothing : int
        Resamples in which no candidate cleared the thresholds.
    n_resamples : int
    method : str
        How the resamples were drawn, in words.
    """

    wins: dict
    nothing: int
    n_resamples: int
    method: str

    def share(self, candidate: Candidate) -> float:
        """Share of the resamples ``candidate`` won."""
        if self.n_resamples == 0:
            return math.nan
        return self.wins.get(candidate.key, 0) / self.n_resamples


def selection_stability(contenders: list[Candidate], residuals: np.ndarray,
                        derivatives: np.ndarray, groups: list[np.ndarray],
                        thresholds: tuple[float, float], *, tie: tuple[float, float],
                        simulates_better: set, n_resamples: int,
                        random_state) -> Stability:
    """Re-make the diagnosis's choice among ``contenders`` on ``n_resamples`` resamples.

    Parameters
    ----------
    contenders : list of Candidate
        Plausible refits (with ``after_squares``) that the held-out check did
        not reject.
    residuals : ndarray of shape (n_samples, n_equations)
        The diagnosed model's derivative residuals.
    derivatives : ndarray of shape (n_samples, n_equations)
        The measured derivatives (for the rounding floor of a residual).
    groups : list of ndarray
        Rows of each experiment.
    thresholds : (float, float)
        ``(bic_threshold, min_improvement)`` of the diagnosis.
    tie : (float, float)
        Relative and absolute score margins of a near tie.
    simulates_better : set
        ``key`` of the candidates that clear the thresholds by their
        simulation alone (whatever the resample).
    """
    n = residuals.shape[0]
    runs = [np.asarray(rows) for rows in groups if len(rows)]
    whole = len(runs) >= MIN_EXPERIMENTS
    if whole:
        method = f"whole experiments ({len(runs)}) drawn with replacement"
        block = 0
    else:
        block = block_length(residuals, segments(n, _labels(runs, n)))
        method = (f"blocks of {block} consecutive samples drawn within each of the "
                  f"{len(runs)} experiment(s)")
    if not contenders:  # nothing can win any resample
        return Stability({}, n_resamples, n_resamples, method)
    # running sums: the residual sum of squares of a block is a difference of two
    base = _running(residuals**2)
    after = {c.key: _running(c.after_squares) for c in contenders}
    floor = rss_floor(derivatives)
    bic_threshold, min_improvement = thresholds
    rng = np.random.default_rng(next(seeds(random_state)))
    wins: dict = {}
    nothing = 0
    for _ in range(n_resamples):
        if whole:
            blocks = [runs[k] for k in rng.integers(0, len(runs), len(runs))]
        else:
            blocks = draw_blocks(rng, runs, block)
        starts = np.array([b[0] for b in blocks])
        stops = np.array([b[-1] + 1 for b in blocks])
        rss_base = (base[stops] - base[starts]).sum(axis=0)
        m = int((stops - starts).sum())
        scored = []
        for c in contenders:
            ks = c.equations
            running = after[c.key]
            before = np.maximum(rss_base[ks], floor[ks])
            now = np.maximum((running[stops] - running[starts]).sum(axis=0), floor[ks])
            delta = float(m * np.sum(np.log(now / before)) + c.n_change * math.log(m))
            removed = 1.0 - now.sum() / before.sum()
            if delta <= -bic_threshold and (removed >= min_improvement
                                            or c.key in simulates_better):
                scored.append((c, -delta))
        if not scored:
            nothing += 1
            continue
        winner = _leader(scored, tie)
        wins[winner.key] = wins.get(winner.key, 0) + 1
    return Stability(wins, nothing, n_resamples, method)


def _running(values: np.ndarray) -> np.ndarray:
    values = np.asarray(values, dtype=float).reshape(len(values), -1)
    return np.vstack([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])


def _labels(runs: list[np.ndarray], n: int) -> np.ndarray:
    labels = np.full(n, -1)
    for k, rows in enumerate(runs):
        labels[rows] = k
    return labels


def _leader(scored: list[tuple[Candidate, float]], tie: tuple[float, float]) -> Candidate:
    """The best score, a near tie going to the candidate with fewer parameters."""
    lead_score = max(score for _, score in scored)
    margin = max(tie[0] * abs(lead_score), tie[1])
    close = [(c, score) for c, score in scored if lead_score - score <= margin]
    return min(close, key=lambda item: (item[0].n_change, -item[1]))[0]
