"""Covariance of least-squares estimates from time series: the sandwich with Newey-West.

The residuals of a fit to a record are correlated in time: the noise may
be coloured, and estimated derivatives are smoothed by a filter. The usual
``sigma^2 (J^T J)^-1`` then understates the spread of the estimates, often
by several times. The sandwich ``B^-1 S B^-1``, with ``B = J^T J`` and
``S`` the long-run covariance of the per-sample scores ``g_t = J_t^T r_t``,
does not assume independent samples. ``S`` is estimated by Newey and West's
Bartlett-weighted sum of the scores' autocovariances up to a lag chosen from
the scores' own autocorrelation (Andrews' AR(1) plug-in), never across the
boundary of two experiments. The weighted sum is one convolution of each
score column with the Bartlett window, so its cost grows with the record,
not with the record times the lag.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import null_space
from scipy.signal import oaconvolve

__all__ = ["bandwidth", "long_run_covariance", "sandwich_covariance"]

#: the AR(1) coefficient of a score column is read as at most this (a random walk has
#: no finite long-run variance)
_MAX_RHO = 0.98
#: up to this lag the weighted autocovariances are summed directly; beyond, by convolution
_DIRECT_LAGS = 16


def _segments(n: int, groups: np.ndarray | None) -> list[slice]:
    """Runs of consecutive rows with the same group label."""
    if groups is None or n == 0:
        return [slice(0, n)]
    groups = np.asarray(groups)
    starts = np.flatnonzero(np.r_[True, groups[1:] != groups[:-1]])
    ends = np.r_[starts[1:], n]
    return [slice(int(a), int(b)) for a, b in zip(starts, ends)]


def bandwidth(scores: np.ndarray, segments: list[slice]) -> int:
    """Newey-West lag by Andrews' AR(1) plug-in rule for the Bartlett kernel.

    Each score column is read as an AR(1) process within each segment;
    ``alpha`` weighs the columns' ``rho`` by their innovation variance, and
    the lag is ``1.1447 (alpha n)^(1/3)``, at most half the longest segment.
    """
    n, p = scores.shape
    # sums over every segment of s_t s_t, s_t s_(t-1) and s_(t-1) s_(t-1), per column
    now_now, now_before, before_before, count = np.zeros(p), np.zeros(p), np.zeros(p), 0
    for s in segments:
        block = scores[s]
        if len(block) <= 2:
            continue
        squares = block * block
        now_now += squares[1:].sum(axis=0)
        before_before += squares[:-1].sum(axis=0)
        now_before += np.einsum("ij,ij->j", block[1:], block[:-1])
        count += len(block) - 1
    usable = before_before > 0
    if not usable.any():
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
    longest = max(s.stop - s.start for s in segments)
    return int(min(np.ceil(lag), longest // 2))


def long_run_covariance(scores: np.ndarray, groups: np.ndarray | None = None,
                        lag: int | None = None) -> tuple[np.ndarray, int]:
    """Newey-West estimate of ``sum_t sum_s E[g_t g_s^T]`` and the lag it used.

    Parameters
    ----------
    scores : ndarray of shape (n_samples, p)
        Per-sample scores, in time order.
    groups : array-like of shape (n_samples,), optional
        Experiment of each sample: no lag crosses from one to the next.
    lag : int, optional
        The truncation lag (by default from :func:`bandwidth`).
    """
    scores = np.asarray(scores, dtype=float)
    n, p = scores.shape
    segments = _segments(n, groups)
    if lag is None:
        lag = bandwidth(scores, segments)
    if lag < 1:
        return scores.T @ scores, 0
    meat = np.zeros((p, p))
    if lag <= _DIRECT_LAGS:  # a few lags: their products directly
        for s in segments:
            block = scores[s]
            meat += block.T @ block
            for lag_l in range(1, min(lag, len(block) - 1) + 1):
                product = block[lag_l:].T @ block[:-lag_l]
                meat += (1.0 - lag_l / (lag + 1.0)) * (product + product.T)
        return meat, int(lag)
    window = 1.0 - np.abs(np.arange(-lag, lag + 1)) / (lag + 1.0)
    for s in segments:
        block = scores[s]
        smoothed = oaconvolve(block, window[:, None], mode="same", axes=0)
        meat += block.T @ smoothed
    return 0.5 * (meat + meat.T), int(lag)


def sandwich_covariance(J: np.ndarray, r: np.ndarray, n_samples: int,
                        groups: np.ndarray | None = None,
                        constraints: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Covariance of the least-squares estimate behind ``J`` and ``r``, and the lag used.

    Parameters
    ----------
    J : ndarray of shape (k * n_samples, p)
        Jacobian of the (weighted) residuals at the estimate, rows stacked
        by equation: ``k`` blocks of ``n_samples`` rows in time order.
    r : ndarray of shape (k * n_samples,)
        The residuals there.
    n_samples : int
        Samples per block: the scores of a sample sum over its equations.
    groups : array-like of shape (n_samples,), optional
        Experiment of each sample.
    constraints : ndarray of shape (m, p), optional
        Rows ``c`` with ``c . x`` held fixed by the fit (point values, active
        bounds): the estimate moves only in their null space.

    Returns
    -------
    cov : ndarray of shape (p, p)
    lag : int
    """
    J = np.asarray(J, dtype=float)
    r = np.asarray(r, dtype=float)
    p = J.shape[1]
    k = J.shape[0] // n_samples
    N = np.eye(p) if constraints is None or not len(constraints) else null_space(constraints)
    if N.shape[1] == 0:
        return np.zeros((p, p)), 0
    Jn = J @ N
    scores = (Jn * r[:, None]).reshape(k, n_samples, N.shape[1]).sum(axis=0)
    meat, lag = long_run_covariance(scores, groups)
    bread = np.linalg.pinv(Jn.T @ Jn, rcond=1e-12, hermitian=True)
    dof = n_samples / max(n_samples - N.shape[1], 1)
    cov_free = dof * bread @ meat @ bread
    cov = N @ cov_free @ N.T
    return 0.5 * (cov + cov.T), lag
