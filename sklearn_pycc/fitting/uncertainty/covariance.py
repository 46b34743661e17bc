"""Covariance of least-squares estimates from time series: the sandwich with Newey-West.

The residuals of a fit to a record are correlated in time: the noise may
be coloured, and estimated derivatives are smoothed by a filter. The usual
``sigma^2 (J^T J)^-1`` then understates the spread of the estimates, often
by several times. The sandwich ``B^-1 S B^-1``, with ``B = J^T J`` and
``S`` the long-run covariance of the per-sample scores ``g_t = J_t^T r_t``,
does not assume independent samples. ``S`` is estimated by Newey and West's
Bartlett-weighted sum of the scores' autocovariances up to a lag chosen from
the scores' own autocorrelation (Andrews' AR(1) plug-in), never across the
boundary of two experiments. The weighted sum is the Gram matrix of the
scores' moving sums, so its cost grows with the record, not with the record
times the lag.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.linalg import null_space

from ..._utils.blocks import bandwidth, plug_in_lag, segments

__all__ = ["DeferredCovariance", "Sandwich", "long_run_covariance", "sandwich",
           "sandwich_covariance"]

#: up to this lag the weighted autocovariances are summed directly; beyond, by convolution
_DIRECT_LAGS = 16


def long_run_covariance(scores: np.ndarray, groups: np.ndarray | None = None,
                        lag: int | None = None,
                        prewhiten: bool = True) -> tuple[np.ndarray, int]:
    """Newey-West estimate of ``sum_t sum_s E[g_t g_s^T]`` and the lag it used.

    Parameters
    ----------
    scores : ndarray of shape (n_samples, p)
        Per-sample scores, in time order.
    groups : array-like of shape (n_samples,), optional
        Experiment of each sample: no lag crosses from one to the next.
    lag : int, optional
        The truncation lag (by default from :func:`bandwidth`).
    prewhiten : bool, default=True
        Take out a first-order vector autoregression of the scores first and
        put it back after (Andrews and Monahan): the kernel estimate of
        strongly correlated scores is biased low, that of their innovations
        is not.
    """
    scores = np.asarray(scores, dtype=float)
    n, p = scores.shape
    runs = segments(n, groups)
    if not prewhiten:
        return _bartlett(scores, runs, lag)
    # the scores' autocovariances, Gamma_l = sum_t s_t s_(t-l)^T within runs; those of the
    # innovations e_t = s_t - A s_(t-1) follow from them (up to a few samples at the
    # start of each run), so the scores are read once per lag and never copied
    gammas = _autocovariances(scores, runs, 2)
    A = _bounded(gammas[1] @ np.linalg.pinv(gammas[0], hermitian=True))

    def innovation(step: int) -> np.ndarray:
        before = gammas[1].T if step == 0 else gammas[step - 1]
        return (gammas[step] - gammas[step + 1] @ A.T - A @ before
                + A @ gammas[step] @ A.T)

    if lag is None:
        e0, e1 = np.diag(innovation(0)), np.diag(innovation(1))
        pairs = sum(s.stop - s.start - 1 for s in runs)
        lag = plug_in_lag(e0, e1, e0, pairs, n, longest=max(s.stop - s.start for s in runs))
    if lag > _DIRECT_LAGS:  # many lags: the innovations themselves, convolved
        innovations = np.empty_like(scores)
        for s in runs:
            block, out = scores[s], innovations[s]
            out[:1] = block[:1]
            np.matmul(block[:-1], A.T, out=out[1:])
            np.subtract(block[1:], out[1:], out=out[1:])
        meat, lag = _bartlett(innovations, runs, lag)
    else:
        gammas = _autocovariances(scores, runs, lag + 1, gammas)
        meat = innovation(0)
        for step in range(1, lag + 1):
            part = innovation(step)
            meat = meat + (1.0 - step / (lag + 1.0)) * (part + part.T)
        meat = 0.5 * (meat + meat.T)
    recolour = np.linalg.inv(np.eye(p) - A)
    return recolour @ meat @ recolour.T, int(lag)


def _autocovariances(scores: np.ndarray, runs: list[slice], top: int,
                     known: list | None = None) -> list[np.ndarray]:
    """``Gamma_l`` for ``l = 0 .. top`` (those in ``known`` kept), summed over runs."""
    p = scores.shape[1]
    out = list(known or [])
    for step in range(len(out), top + 1):
        gamma = np.zeros((p, p))
        for s in runs:
            block = scores[s]
            if len(block) > step:
                gamma += block[step:].T @ block[:len(block) - step]
        out.append(gamma)
    return out


def _bounded(A: np.ndarray) -> np.ndarray:
    """``A`` with its singular values held below :data:`_MAX_AR`."""
    U, sigma, Vt = np.linalg.svd(A)
    return (U * np.minimum(sigma, _MAX_AR)) @ Vt


#: singular values of the prewhitening autoregression are held below this (Andrews and
#: Monahan's bound: a unit root would make the recolouring explode)
_MAX_AR = 0.97


def _bartlett(scores: np.ndarray, runs: list[slice], lag: int | None) -> tuple[np.ndarray, int]:
    """Bartlett-weighted sum of the autocovariances of ``scores`` within runs."""
    p = scores.shape[1]
    if lag is None:
        lag = bandwidth(scores, runs)
    if lag < 1:
        return scores.T @ scores, 0
    meat = np.zeros((p, p))
    weights = 1.0 - np.arange(lag + 1) / (lag + 1.0)
    for s in runs:
        block = scores[s]
        if lag <= _DIRECT_LAGS:  # a few lags: their weighted products directly
            meat += block.T @ block
            for step in range(1, min(lag, len(block) - 1) + 1):
                product = block[step:].T @ block[:-step]
                meat += weights[step] * (product + product.T)
            continue
        meat += _triangle_sum(block, lag)
    return 0.5 * (meat + meat.T), int(lag)


def _triangle_sum(block: np.ndarray, lag: int) -> np.ndarray:
    """``sum_t sum_s (1 - |t - s| / (lag + 1))_+ b_t b_s^T`` by moving sums.

    Every window of ``lag + 1`` consecutive rows (those that hang over
    either end included) holds a pair ``t, s`` that far apart
    ``lag + 1 - |t - s|`` times, so the Bartlett-weighted sum is the Gram
    matrix of the windows' sums over ``lag + 1``: two passes over the block
    whatever the lag.
    """
    m, p = block.shape
    running = np.zeros((m + 1, p), order="F")  # column by column: cumsum runs contiguous
    np.cumsum(block, axis=0, out=running[1:])
    if lag >= m:  # every window hangs over an end
        ends = np.arange(m + lag)
        sums = running[np.minimum(ends + 1, m)] - running[np.maximum(ends - lag, 0)]
        return (sums.T @ sums) / (lag + 1.0)
    head = running[1:lag + 1]  # windows that start before the block
    middle = running[lag + 1:] - running[:m - lag]
    tail = running[m] - running[m - lag:m]  # windows that end after it
    gram = head.T @ head + middle.T @ middle + tail.T @ tail
    return gram / (lag + 1.0)


class Sandwich:
    """The parts of a sandwich covariance known at the estimate; the long-run part on demand.

    The bread ``(J^T J)^-1`` is a cheap by-product of the fit; the per-sample
    scores and the Newey-West estimate of their long-run covariance are the
    expensive part, worked out by :meth:`covariance` when a standard error or
    a band is first asked for (``J`` and ``r`` are kept until then).
    """

    def __init__(self, J: np.ndarray | None, r: np.ndarray | None, n_samples: int,
                 bread: np.ndarray, N: np.ndarray | None, *, groups: np.ndarray | None) -> None:
        self.J, self.r, self.n_samples = J, r, n_samples
        self.bread, self.N, self.groups = bread, N, groups

    def scores(self) -> np.ndarray:
        """Per-sample scores, summed over equations, in the free directions."""
        J, r, n = self.J, self.r, self.n_samples
        k, p = J.shape[0] // n, J.shape[1]
        if k > 1:  # (sample, equation, column) views of J and r, whatever their memory order
            if J.flags.f_contiguous:
                weighted = np.einsum("tkp,tk->tp", J.reshape((n, k, p), order="F"),
                                     r.reshape((n, k), order="F"))
            else:
                weighted = np.einsum("ktp,kt->tp", J.reshape(k, n, p), r.reshape(k, n))
        else:
            weighted = J * r[:, None]
        return weighted if self.N is None else weighted @ self.N

    def covariance(self) -> tuple[np.ndarray, int]:
        """``(cov, lag)``: the covariance of the estimate and the Newey-West lag used."""
        if self.J is None:  # the constraints fix every direction
            p = self.bread.shape[0]
            return np.zeros((p, p)), 0
        scores = self.scores()
        meat, lag = long_run_covariance(scores, self.groups)
        dof = self.n_samples / max(self.n_samples - scores.shape[1], 1)
        cov = dof * self.bread @ meat @ self.bread
        if self.N is not None:
            cov = self.N @ cov @ self.N.T
        return 0.5 * (cov + cov.T), lag


def sandwich(J: np.ndarray, r: np.ndarray, n_samples: int, groups: np.ndarray | None = None,
             constraints: np.ndarray | None = None, *, gram: np.ndarray | None = None) -> Sandwich:
    """The parts of the covariance of the least-squares estimate behind ``J`` and ``r``.

    Parameters
    ----------
    J : ndarray of shape (k * n_samples, p)
        Jacobian of the (weighted) residuals at the estimate, rows stacked
        by equation: ``k`` blocks of ``n_samples`` rows in time order. Kept,
        not copied: it must not change until the covariance is worked out.
    r : ndarray of shape (k * n_samples,)
        The residuals there.
    n_samples : int
        Samples per block: the scores of a sample sum over its equations.
    groups : array-like of shape (n_samples,), optional
        Experiment of each sample.
    constraints : ndarray of shape (m, p), optional
        Rows ``c`` with ``c . x`` held fixed by the fit (point values, active
        bounds): the estimate moves only in their null space.
    gram : ndarray of shape (p, p), optional
        ``J^T J`` when the fit has it already.
    """
    J = np.asarray(J, dtype=float)
    r = np.asarray(r, dtype=float)
    p = J.shape[1]
    unconstrained = constraints is None or not len(constraints)
    N = None if unconstrained else null_space(constraints)
    if N is not None and N.shape[1] == 0:
        return Sandwich(None, None, n_samples, np.zeros((p, p)), None, groups=groups)
    if gram is None:
        gram = J.T @ J
    if N is not None:
        gram = N.T @ gram @ N
    bread = np.linalg.pinv(gram, rcond=1e-12, hermitian=True)
    return Sandwich(J, r, n_samples, bread, N, groups=groups)


def sandwich_covariance(J: np.ndarray, r: np.ndarray, n_samples: int,
                        groups: np.ndarray | None = None,
                        constraints: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Covariance of the least-squares estimate behind ``J`` and ``r``, and the lag used.

    The arguments are :func:`sandwich`'s.

    Returns
    -------
    cov : ndarray of shape (p, p)
    lag : int
    """
    return sandwich(J, r, n_samples, groups, constraints).covariance()


class DeferredCovariance:
    """A covariance table, by name, worked out from a :class:`Sandwich` when first read.

    ``transform`` maps the sandwich's coordinates to those named by
    ``names`` (a basis's coefficients to a power series, say). The table's
    ``attrs["lag"]`` is the Newey-West lag.
    """

    def __init__(self, parts: Sandwich, transform: np.ndarray | None, names: list[str]) -> None:
        self.parts, self.transform, self.names = parts, transform, list(names)

    def resolve(self) -> pd.DataFrame:
        """The table itself."""
        cov, lag = self.parts.covariance()
        if self.transform is not None:
            cov = self.transform @ cov @ self.transform.T
        frame = pd.DataFrame(cov, index=self.names, columns=self.names)
        frame.attrs["lag"] = lag
        return frame
