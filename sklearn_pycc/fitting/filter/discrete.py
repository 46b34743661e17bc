"""The process noise a step of the filter adds, exactly: Van Loan's integral, many at once.

Over a step of length ``h`` the linearised flow ``dx = A x dt + diag(q) dW``
adds the covariance

    Q_h = integral_0^h exp(A s) diag(q^2) exp(A' s) ds,

which :func:`step_noise` reads from one matrix exponential of the block
matrix ``[[-A, diag(q^2)], [0, A']] h`` (C. F. Van Loan, "Computing integrals
involving the matrix exponential", IEEE Trans. Automatic Control 23, 1978).
A trapezoid rule in its place (``Q h / 2`` at each end of the step) puts a
step's variance 12 % too high where the state's memory is under two steps;
the exact integral makes a linear skeleton's filter the exact discrete
Kalman filter at any sampling. A step short against the flow's rates sums
the integral's series; a long one takes the exponentials of its whole batch
by scaling, a Taylor series and squaring, in a few batched matrix products.
"""

from __future__ import annotations

import numpy as np

__all__ = ["batch_expm", "step_noise"]

#: terms of the Taylor series once a matrix is scaled to a norm of at most SCALED_NORM
TAYLOR_TERMS = 10
SCALED_NORM = 0.5
#: most halvings a matrix is scaled by (a diverged variant's matrix is not worth more)
MOST_SQUARINGS = 60


def batch_expm(M: np.ndarray) -> np.ndarray:
    """The matrix exponential of each of ``M`` ``(batch, k, k)``.

    Each matrix is halved ``s`` times until its 1-norm is at most
    :data:`SCALED_NORM`, exponentiated by :data:`TAYLOR_TERMS` terms of its
    series (a relative error near 1e-11) and squared back ``s`` times. A
    matrix that is not finite gives NaN.
    """
    M = np.asarray(M, dtype=float)
    eye = np.eye(M.shape[-1])
    with np.errstate(all="ignore"):
        norm = np.abs(M).sum(axis=-2).max(axis=-1)
        finite = np.isfinite(norm)
        s = np.ceil(np.log2(np.where(finite & (norm > 0), norm, 1.0) / SCALED_NORM))
        s = np.clip(s, 0, MOST_SQUARINGS).astype(int)
        X = M / (2.0 ** s)[:, None, None]
        E = np.broadcast_to(eye, M.shape).copy()
        for k in range(TAYLOR_TERMS, 0, -1):  # Horner: I + X/1 (I + X/2 (I + ...))
            E = eye + X @ E / k
        for j in range(int(s.max()) if len(s) else 0):
            E = np.where((j < s)[:, None, None], E @ E, E)
    E[~finite] = np.nan
    return E


def step_noise(A: np.ndarray, q2: np.ndarray, h: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The covariance the process noise adds over a step of each row, exactly for linear flows.

    Where every step is short against the flow's rates (``|A h|`` at most
    :data:`SHORT_REACH`, a finely sampled record), the trapezoid rule with
    its first end correction (Euler-Maclaurin) over the integrand
    ``g(s) = exp(A s) Q exp(A' s)``, whose ends are ``Q`` and ``F Q F'``
    and whose slopes are ``A g + g A'``: a relative error below
    ``(2 |A h|)^4 / 720`` (1e-5), at the cost of two matrix products.
    Otherwise a step with ``|A h| <= 1`` is summed as its series,
    ``Q_h = sum_k h^(k+1) / (k+1)! T_k`` with ``T_0 = diag(q^2)`` and
    ``T_k = A T_(k-1) + T_(k-1) A'``, to as many terms as the batch's
    longest step needs for a relative error below :data:`SERIES_TOLERANCE`;
    a longer one by Van Loan's exponential.

    Parameters
    ----------
    A : ndarray of shape (batch, n, n)
        The flow's Jacobian at the step's start.
    q2 : ndarray of shape (batch, n)
        The process noise's intensities squared (diagonal).
    h : ndarray of shape (batch,)
        Each row's step (0 on padding: no noise).
    F : ndarray of shape (batch, n, n)
        The step's transition (``exp(A h)`` for a linear flow).

    Returns
    -------
    ndarray of shape (batch, n, n)
        Symmetric, positive semi-definite where the step is sound.
    """
    batch, n = q2.shape
    h = np.asarray(h, dtype=float).reshape(batch)
    with np.errstate(all="ignore"):
        # a bound of every row's |A h| first (two calls), the rows' own where it is not short
        if batch and n * np.abs(A).max() * np.abs(h).max() <= SHORT_REACH:
            return _corrected_trapezoid(A, q2, h, F)  # NaN fails the test: the long way
        # T A' is bounded by the infinity norm, A T by the one norm: the larger of the two
        size = np.abs(A)
        reach = np.maximum(size.sum(axis=-2).max(axis=-1), size.sum(axis=-1).max(axis=-1)) * \
            np.abs(h)
        if batch and reach.max() <= SHORT_REACH:
            return _corrected_trapezoid(A, q2, h, F)
    short = reach <= 1.0  # NaN (a diverged variant) goes the long way, and stays NaN
    noise = np.empty((batch, n, n))
    if short.all():
        return _series(A, q2, h, float(reach.max()) if batch else 0.0)
    if short.any():
        noise[short] = _series(A[short], q2[short], h[short], float(reach[short].max()))
    noise[~short] = _van_loan(A[~short], q2[~short], h[~short])
    return noise


#: relative error the series of :func:`step_noise` stops at
SERIES_TOLERANCE = 1e-8
#: the longest step (``|A h|``, 1-norm) :func:`step_noise` integrates by the corrected
#: trapezoid rule
SHORT_REACH = 0.15


def _corrected_trapezoid(A: np.ndarray, q2: np.ndarray, h: np.ndarray,
                         F: np.ndarray) -> np.ndarray:
    """:func:`step_noise` by the trapezoid rule and its end correction, for short steps.

    With ``G = F Q F'`` and ``D = G - Q``, the rule's
    ``h/2 (Q + G) - h^2/12 ((A G + G A') - (A Q + Q A'))`` is
    ``h/2 (Q + G) - h^2/12 (A D + D A')``.
    """
    diagonal = np.arange(q2.shape[1])
    G = (F * q2[:, None, :]) @ np.swapaxes(F, -1, -2)
    D = G.copy()
    D[:, diagonal, diagonal] -= q2
    AD = A @ D
    G[:, diagonal, diagonal] += q2  # Q + G
    h = h[:, None, None]
    return h / 2.0 * G - h * h / 12.0 * (AD + np.swapaxes(AD, -1, -2))


def _series(A: np.ndarray, q2: np.ndarray, h: np.ndarray, reach: float) -> np.ndarray:
    """:func:`step_noise` by its series, for steps with ``|A h| <= reach <= 1``."""
    n = q2.shape[1]
    # the k-th term is at most (2 reach)^k / (k + 1)! of the first
    terms, size = 0, 1.0
    while size > SERIES_TOLERANCE and terms < 30:
        terms += 1
        size *= 2.0 * reach / (terms + 1)
    T = np.zeros((len(h), n, n))
    T[:, np.arange(n), np.arange(n)] = q2
    factor = h[:, None, None].copy()
    noise = T * factor
    for k in range(1, terms + 1):
        AT = A @ T
        T = AT + np.swapaxes(AT, -1, -2)
        factor *= h[:, None, None] / (k + 1)
        noise += factor * T
    return noise


def _van_loan(A: np.ndarray, q2: np.ndarray, h: np.ndarray) -> np.ndarray:
    """:func:`step_noise` by Van Loan's block exponential, for any step."""
    batch, n = q2.shape
    h = h.reshape(batch, 1, 1)
    M = np.zeros((batch, 2 * n, 2 * n))
    M[:, :n, :n] = -A * h
    M[:, np.arange(n), n + np.arange(n)] = q2 * h[:, :, 0]
    M[:, n:, n:] = np.swapaxes(A, -1, -2) * h
    E = batch_expm(M)
    noise = np.swapaxes(E[:, n:, n:], -1, -2) @ E[:, :n, n:]
    return 0.5 * (noise + np.swapaxes(noise, -1, -2))
