"""Equality-constrained linear least squares with rank diagnostics."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LstsqResult", "constrained_lstsq"]


@dataclass
class LstsqResult:
    """Solution of ``min ||A x + b||`` subject to ``C x = d``.

    Attributes
    ----------
    x : ndarray
        Solution (minimum norm in the directions the data leave free).
    null_directions : ndarray
        Columns: directions of ``x`` the data cannot determine (rank deficiency).
    residual : ndarray
        ``A x + b``.
    """

    x: np.ndarray
    null_directions: np.ndarray
    residual: np.ndarray


def constrained_lstsq(A: np.ndarray, b: np.ndarray, C: np.ndarray | None = None,
                      d: np.ndarray | None = None, alpha: float = 0.0,
                      rtol: float | None = None) -> LstsqResult:
    """Solve ``min ||A x + b||^2 + alpha ||x||^2`` subject to ``C x = d`` exactly.

    The equality constraints are eliminated with a null-space basis of ``C``;
    columns are scaled to unit norm before the SVD-based solve.
    """
    p = A.shape[1]
    if C is not None and len(C):
        U, s, Vt = np.linalg.svd(C, full_matrices=True)
        tol = max(C.shape) * np.finfo(float).eps * (s[0] if s.size else 0.0)
        r = int((s > tol).sum())
        x0 = Vt[:r].T @ ((U[:, :r].T @ d) / s[:r])
        N = Vt[r:].T
    else:
        x0 = np.zeros(p)
        N = None
    rhs = -(b + A @ x0) if x0.any() else -b
    M = A if N is None else A @ N
    if M.shape[1] == 0:
        x = x0
        return LstsqResult(x, np.zeros((p, 0)), A @ x + b)
    norms = np.sqrt(np.einsum("ij,ij->j", M, M))
    norms[norms == 0] = 1.0
    Ms = M / norms
    if alpha > 0:
        Ms = np.vstack([Ms, np.sqrt(alpha) * np.diag(1.0 / norms)])
        rhs = np.concatenate([rhs, np.zeros(M.shape[1])])
    rcond = rtol if rtol is not None else max(Ms.shape) * np.finfo(float).eps
    z, _, rank, _sv = np.linalg.lstsq(Ms, rhs, rcond=rcond)
    z = z / norms
    x = x0 + (z if N is None else N @ z)
    if rank < Ms.shape[1]:
        _, _, Vt_m = np.linalg.svd(Ms, full_matrices=False)
        null_z = Vt_m[rank:].T / norms[:, None]
        null = null_z if N is None else N @ null_z
    else:
        null = np.zeros((p, 0))
    return LstsqResult(x, null, A @ x + b)
