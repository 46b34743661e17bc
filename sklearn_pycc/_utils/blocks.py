"""Time series in blocks: runs of an experiment, their correlation length, block resamples.

Samples of a record are correlated in time (coloured noise, smoothed
derivatives), so both the covariance of an estimate (Newey-West) and its
resamples (the moving-block bootstrap) work with stretches of consecutive
samples as long as that correlation. This module measures the length from
the data and draws the blocks; the estimators' intervals and the
diagnosis's stability share it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["MIN_EXPERIMENTS", "bandwidth", "block_length", "draw_blocks", "plug_in_lag",
           "segments"]

#: whole experiments are drawn, rather than blocks within each, when a record has at
#: least this many
MIN_EXPERIMENTS = 10

#: the AR(1) coefficient of a column is read as at most this (a random walk has
#: no finite long-run variance)
_MAX_RHO = 0.98


def segments(n: int, groups: np.ndarray | None) -> list[slice]:
    """Runs of consecutive rows with the same group label (one run without labels)."""
    if groups is None or n == 0:
        return [slice(0, n)]
    groups = np.asarray(groups)
    starts = np.flatnonzero(np.r_[True, groups[1:] != groups[:-1]])
    ends = np.r_[starts[1:], n]
    return [slice(int(a), int(b)) for a, b in zip(starts, ends)]


def bandwidth(scores: np.ndarray, runs: list[slice]) -> int:
    """Newey-West lag by Andrews' AR(1) plug-in rule for the Bartlett kernel.

    Each column is read as an AR(1) process within each run; ``alpha``
    weighs the columns' ``rho`` by their innovation variance, and the lag is
    ``1.1447 (alpha n)^(1/3)``, at most half the longest run.
    """
    n, p = scores.shape
    # sums over every run of s_t s_t, s_t s_(t-1) and s_(t-1) s_(t-1), per column
    now_now, now_before, before_before, count = np.zeros(p), np.zeros(p), np.zeros(p), 0
    for s in runs:
        block = scores[s]
        if len(block) <= 2:
            continue
        now_now += np.einsum("ij,ij->j", block[1:], block[1:])
        before_before += np.einsum("ij,ij->j", block[:-1], block[:-1])
        now_before += np.einsum("ij,ij->j", block[1:], block[:-1])
        count += len(block) - 1
    longest = max(s.stop - s.start for s in runs)
    return plug_in_lag(now_now, now_before, before_before, count, n, longest=longest)


def plug_in_lag(now_now: np.ndarray, now_before: np.ndarray, before_before: np.ndarray,
                count: int, n: int, *, longest: int) -> int:
    """Andrews' AR(1) plug-in lag from sums over ``count`` pairs of samples.

    ``now_now``, ``now_before`` and ``before_before`` hold each column's sums of
    ``s_t s_t``, ``s_t s_(t-1)`` and ``s_(t-1) s_(t-1)``; ``n`` is the number of
    samples and ``longest`` the longest run (the lag is at most half of it).
    """
    usable = before_before > 0
    if not usable.any() or count == 0:
        return 0
    rho = np.clip(now_before[usable] / before_before[usable], -_MAX_RHO, _MAX_RHO)
    # the AR(1) innovations' variance: sum (s_t - rho s_(t-1))^2 / count
    var = (now_now[usable] - 2 * rho * now_before[usable]
           + rho**2 * before_before[usable]) / count
    top = np.sum(4 * rho**2 * var**2 / ((1 - rho) ** 6 * (1 + rho) ** 2))
    bottom = np.sum(var**2 / (1 - rho) ** 4)
    if not bottom > 0:
        return 0
    lag = 1.1447 * (top / bottom * n) ** (1.0 / 3.0)
    return int(min(np.ceil(lag), longest // 2))


def block_length(residuals: np.ndarray, runs: list[slice], min_block: int = 2) -> int:
    """Samples per block of a moving-block bootstrap of these residuals.

    Twice the residuals' Newey-West lag plus one (so a block holds their
    correlation), at least the cube root of the record's length and
    ``min_block``, at most the longest run.
    """
    residuals = np.asarray(residuals, dtype=float)
    residuals = residuals.reshape(len(residuals), -1)
    lengths = [s.stop - s.start for s in runs]
    cube_root = math.ceil(sum(lengths) ** (1.0 / 3.0))
    lag = bandwidth(residuals, runs)
    return int(min(max(2 * lag + 1, cube_root, min_block), max(lengths)))


def draw_blocks(rng: np.random.Generator, experiments: list[np.ndarray],
                block: int) -> list[np.ndarray]:
    """One moving-block resample: blocks of rows drawn within each experiment.

    Each experiment gets as many rows as it has, in blocks of ``block``
    consecutive rows (the last one cut to fit) starting anywhere in it.
    """
    blocks = []
    for rows in experiments:
        size = min(block, len(rows))
        count = math.ceil(len(rows) / size)
        starts = rng.integers(0, len(rows) - size + 1, count)
        taken = 0
        for start in starts:
            length = min(size, len(rows) - taken)
            if length >= 1:
                blocks.append(rows[start:start + length])
            taken += length
    return blocks
