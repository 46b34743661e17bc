"""Equality-constrained linear least squares with rank diagnostics."""

from __future__ import annotations

import numpy as np

__all__ = ["LstsqResult", "constrained_lstsq"]


class LstsqResult:
    """Solution of ``min ||A x + b||`` subject to ``C x = d``.

    Attributes
    ----------
    x : ndarray
        Solution (minimum norm in the directions the data leave free).
    null_directions : ndarray
        Columns: directions of ``x`` the data cannot determine (rank deficiency).
    """

    def __init__(self, x, null_directions, M, z, rhs) -> None:
        self.x = x
        self.null_directions = null_directions
        self._system = (M, z, rhs)
        self._residual = None

    @property
    def residual(self) -> np.ndarray:
        """``A x + b`` (computed from the reduced, scaled system)."""
        if self._residual is None:
            M, z, rhs = self._system
            self._residual = (M @ z - rhs) if M.shape[1] else -rhs
        return self._residual

    @property
    def cost(self) -> float:
        """``||A x + b||^2``."""
        r = self.residual
        return float(r @ r)


def constrained_lstsq(A: np.ndarray, b: np.ndarray, C: np.ndarray | None = None,
                      d: np.ndarray | None = None, alpha: float = 0.0,
                      rtol: float | None = None, overwrite_a: bool = False) -> LstsqResult:
    """Solve ``min ||A x + b||^2 + alpha ||x||^2`` subject to ``C x = d`` exactly.

    The equality constraints are eliminated with a null-space basis of ``C``;
    columns are scaled to unit norm before the SVD-based solve. ``b`` is
    not modified; ``A`` is scaled in place when ``overwrite_a``.
    """
    p = A.shape[1]
    if C is not None and len(C):
        U, s, Vt = np.linalg.svd(C, full_matrices=True)
        tol = max(C.shape) * np.finfo(float).eps * (s[0] if s.size else 0.0)
        r = int((s > tol).sum())
        x0 = Vt[:r].T @ ((U[:, :r].T @ d) / s[:r])
        N = Vt[r:].T
        M = A @ N
        rhs = -(b + A @ x0)
    else:
        x0 = None
        N = None
        M = A if overwrite_a else A.copy()
        rhs = -b
    if M.shape[1] == 0:
        x = x0 if x0 is not None else np.zeros(p)
        return LstsqResult(x, np.zeros((p, 0)), M, np.zeros(0), rhs)
    norms = np.sqrt(np.einsum("ij,ij->j", M, M))
    norms[norms == 0] = 1.0
    M /= norms
    solve_M, solve_rhs = M, rhs
    if alpha > 0:
        solve_M = np.vstack([M, np.sqrt(alpha) * np.diag(1.0 / norms)])
        solve_rhs = np.concatenate([rhs, np.zeros(M.shape[1])])
    rcond = rtol if rtol is not None else max(solve_M.shape) * np.finfo(float).eps
    z_scaled, _, rank, _ = np.linalg.lstsq(solve_M, solve_rhs, rcond=rcond)
    z = z_scaled / norms
    x = z if N is None else x0 + N @ z
    if rank < M.shape[1]:
        _, _, Vt_m = np.linalg.svd(solve_M, full_matrices=False)
        null_z = Vt_m[rank:].T / norms[:, None]
        null = null_z if N is None else N @ null_z
    else:
        null = np.zeros((p, 0))
    return LstsqResult(x, null, M, z_scaled, rhs)
