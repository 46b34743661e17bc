"""Linear least squares with equality constraints (and inequalities), with rank diagnostics."""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve, qr, solve_triangular
from scipy.linalg import lstsq as lapack_lstsq
from scipy.optimize import nnls

__all__ = ["InfeasibleError", "LstsqResult", "bounded_lstsq", "constrained_lstsq"]


class InfeasibleError(ValueError):
    """No coefficients satisfy the equality and inequality constraints together."""


class LstsqResult:
    """Solution of ``min ||A x + b||`` subject to ``C x = d``.

    Attributes
    ----------
    x : ndarray
        Solution (minimum norm in the directions the data leave free).
    null_directions : ndarray
        Columns: directions of ``x`` the data cannot determine (rank deficiency).
    gram : ndarray or None
        ``A^T A`` when the solve formed it (None otherwise).
    """

    def __init__(self, x, null_directions, M=None, z=None, rhs=None, *,
                 residual: np.ndarray | None = None, gram: np.ndarray | None = None) -> None:
        self.x = x
        self.null_directions = null_directions
        self.gram = gram
        self._system = (M, z, rhs)
        self._residual = residual

    @property
    def residual(self) -> np.ndarray:
        """``A x + b``."""
        if self._residual is None:  # from the reduced, scaled system
            M, z, rhs = self._system
            self._residual = (M @ z - rhs) if M.shape[1] else -rhs
        return self._residual

    @property
    def cost(self) -> float:
        """``||A x + b||^2``."""
        r = self.residual
        return float(r @ r)


def constrained_lstsq(A: np.ndarray, b: np.ndarray, C: np.ndarray | None = None,
                      d: np.ndarray | None = None, alpha: float = 0.0, *,
                      rtol: float | None = None, overwrite_a: bool = False) -> LstsqResult:
    """Solve ``min ||A x + b||^2 + alpha ||x||^2`` subject to ``C x = d`` exactly.

    A well-conditioned design (the usual case) is solved through its Gram
    matrix, with the constraints eliminated there and one step of iterative
    refinement against the design itself: one pass over ``A``, which is left
    as it is. Any other design (condition number above :data:`_GRAM_COND`,
    fewer rows than unknowns, rank deficient) has the constraints eliminated
    with a null-space basis of ``C`` and its columns scaled to unit norm
    before a rank-revealing QR solve. ``b`` is never modified; on that second
    path ``A`` is scaled in place when ``overwrite_a``.
    """
    p = A.shape[1]
    quick = _through_gram(A, b, C, d, alpha)
    if quick is not None:
        return quick
    x0, N, M, rhs = _eliminate(A, b, C, d, overwrite_a)
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
    # rank-revealing QR (LAPACK gelsy): the usual choice for tall, skinny designs
    z_scaled, _, rank, _ = lapack_lstsq(solve_M, solve_rhs, cond=rcond, lapack_driver="gelsy",
                                        check_finite=False)
    z = z_scaled / norms
    x = z if N is None else x0 + N @ z
    if rank < M.shape[1]:
        null_z = _null_space(solve_M, rank) / norms[:, None]
        null = null_z if N is None else N @ null_z
    else:
        null = np.zeros((p, 0))
    return LstsqResult(x, null, M, z_scaled, rhs)


#: designs whose column-scaled condition number is below this are solved through their
#: Gram matrix (the normal equations); its square stays six orders of magnitude clear of
#: the rounding error, and one refinement step against the design recovers what the
#: squaring loses. Well below it too: every design this path takes has full rank
_GRAM_COND = 1e5


def _through_gram(A: np.ndarray, b: np.ndarray, C: np.ndarray | None, d: np.ndarray | None,
                  alpha: float) -> LstsqResult | None:
    """The normal-equation solve of :func:`constrained_lstsq`, or None where it is not safe."""
    n, p = A.shape
    if n <= p:
        return None
    gram = A.T @ A
    if not np.isfinite(gram).all():
        return None
    x0, N, _ = _constraint_basis(C, d, p)
    reduced = gram if N is None else N.T @ gram @ N
    q = reduced.shape[0]
    if q == 0:
        return None
    scale = np.sqrt(np.diag(reduced)).copy()
    if not np.all(scale > 0):
        return None
    # in the scaled unknowns w = scale * z (the design's columns at unit norm)
    H = reduced / np.outer(scale, scale)
    if alpha > 0:
        H[np.diag_indices(q)] += alpha / scale**2
    eigenvalues = np.linalg.eigvalsh(H)
    if not eigenvalues[0] > eigenvalues[-1] / _GRAM_COND**2:
        return None
    factor = cho_factor(H, check_finite=False)

    def step(r: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The change of ``z`` that zeroes the gradient at residual ``r``."""
        gradient = A.T @ r if N is None else N.T @ (A.T @ r)
        if alpha > 0:
            gradient = gradient + alpha * z
        return -cho_solve(factor, gradient / scale, check_finite=False) / scale

    def at(z: np.ndarray) -> np.ndarray:
        return z if N is None else x0 + N @ z

    z = np.zeros(q)
    for _ in range(2):  # the solve, then one refinement against the design itself
        x = at(z)
        z = z + step(A @ x + b, z)
    x = at(z)
    return LstsqResult(x, np.zeros((p, 0)), residual=A @ x + b, gram=gram)


def _pivots(C: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                  np.ndarray]:
    """``pivots, free, G, xp``: ``C x = d`` reads ``x[pivots] = xp - G x[free]``.

    One pivot coefficient is eliminated per independent constraint.
    """
    R, perm = qr(C, mode="r", pivoting=True)
    diag = np.abs(np.diag(R))
    tol = max(C.shape) * np.finfo(float).eps * (diag[0] if diag.size else 0.0)
    r = int((diag > tol).sum())
    pivots, free = perm[:r], np.sort(perm[r:])
    # least-squares pivot values (constraints are consistent by construction)
    Gp = np.linalg.lstsq(C[:, pivots], np.column_stack([C[:, free], d]), rcond=None)[0]
    return pivots, free, Gp[:, :-1], Gp[:, -1]


def _constraint_basis(C: np.ndarray | None, d: np.ndarray | None,
                      p: int) -> tuple[np.ndarray | None, np.ndarray | None, tuple]:
    """``x0, N, pivots`` with ``x = x0 + N z`` over the solutions of ``C x = d``.

    ``N = [I; -G]`` on (free; pivots), so ``A N`` changes only the columns the
    constraints involve; ``pivots`` is :func:`_pivots`'s answer. Without
    ``C``: ``None, None, ()``.
    """
    if C is None or not len(C):
        return None, None, ()
    pivots, free, G, xp = _pivots(C, d)
    x0 = np.zeros(p)
    x0[pivots] = xp
    N = np.zeros((p, len(free)))
    N[free, np.arange(len(free))] = 1.0
    N[pivots] = -G
    return x0, N, (pivots, free, G, xp)


def _null_space(M: np.ndarray, rank: int) -> np.ndarray:
    """Orthonormal columns spanning what ``M`` (of ``rank``) maps to nothing.

    A design with fewer rows than columns needs the full set of right
    singular vectors: the reduced SVD drops the very directions asked for.
    """
    _, _, Vt = np.linalg.svd(M, full_matrices=M.shape[0] < M.shape[1])
    return Vt[rank:].T


def _eliminate(A, b, C, d, overwrite_a: bool):
    """``x = x0 + N z`` over the solutions of ``C x = d``: ``(x0, N, A N, -(b + A x0))``.

    ``x0`` and ``N`` are None without constraints. ``A N`` is a new array,
    except without constraints when ``overwrite_a``: it is then ``A`` itself.
    """
    if C is None or not len(C):
        return None, None, (A if overwrite_a else A.copy()), -b
    x0, N, (pivots, free, G, xp) = _constraint_basis(C, d, A.shape[1])
    M = A[:, free]
    touched = np.flatnonzero(np.abs(G).max(axis=0) > 0)
    if touched.size:
        M[:, touched] -= A[:, pivots] @ G[:, touched]
    return x0, N, M, -(b + A[:, pivots] @ xp)


#: relative ridge that keeps the triangular factor of a rank-deficient design invertible
_RIDGE = 1e-12


def bounded_lstsq(A: np.ndarray, b: np.ndarray, C: np.ndarray | None, d: np.ndarray | None,
                  G: np.ndarray, *, h: np.ndarray, alpha: float = 0.0,
                  overwrite_a: bool = False) -> LstsqResult:
    """Solve ``min ||A x + b||^2 + alpha ||x||^2`` subject to ``C x = d`` and ``G x >= h``.

    The equalities are eliminated as in :func:`constrained_lstsq`; the
    inequalities are met exactly by the classical reduction of a least
    squares problem with linear inequalities to a least-distance problem,
    solved by non-negative least squares (Lawson and Hanson, *Solving Least
    Squares Problems*, chapter 23).

    Raises
    ------
    InfeasibleError
        If no ``x`` satisfies the constraints.
    """
    p = A.shape[1]
    x0, N, M, rhs = _eliminate(A, b, C, d, overwrite_a)
    q = M.shape[1]
    if N is not None:
        G_z, h_z = G @ N, h - G @ x0
    else:
        G_z, h_z = G, h
    if q == 0:
        x = x0 if x0 is not None else np.zeros(p)
        if np.any(G @ x < h - 1e-12 * (1 + np.abs(h))):
            raise InfeasibleError("the constraints fix every coefficient and violate a bound")
        return LstsqResult(x, np.zeros((p, 0)), M, np.zeros(0), rhs)
    norms = np.sqrt(np.einsum("ij,ij->j", M, M))
    norms[norms == 0] = 1.0
    M /= norms
    ridge = max(alpha, 0.0) / norms**2 + _RIDGE
    stacked = np.vstack([M, np.diag(np.sqrt(ridge))])
    target = np.concatenate([rhs, np.zeros(q)])
    Q, R = np.linalg.qr(stacked)
    f = Q.T @ target
    # in the scaled unknowns s = norms * z: G_z z >= h_z reads E s >= h_z
    E = G_z / norms
    K = solve_triangular(R, E.T, trans="T").T   # E R^-1
    k = h_z - K @ f
    if np.all(k <= 0):
        y = np.zeros(q)  # the unconstrained solution meets every inequality
    else:
        # least distance: min ||y|| with K y >= k, through non-negative least squares
        # (k scaled to order one: the test below reads the last residual, which is
        # -1 / (1 + ||y||^2) at the solution)
        scale = max(1.0, float(np.max(np.abs(k))))
        stackT = np.vstack([K.T, k / scale])
        e = np.zeros(q + 1)
        e[-1] = 1.0
        u, _ = nnls(stackT, e, maxiter=50 * (q + len(k) + 1))
        r = stackT @ u - e
        if abs(r[-1]) < 1e-12:
            raise InfeasibleError("no coefficients satisfy the bounds and shape constraints "
                                  "together with the skeleton's other constraints")
        y = -scale * r[:-1] / r[-1]
    s = solve_triangular(R, y + f)
    z = s / norms
    x = z if N is None else x0 + N @ z
    # the rank of the design itself (the ridge above only keeps the factor invertible)
    diag = np.abs(np.diag(qr(M, mode="r", pivoting=True)[0]))
    tol = max(M.shape) * np.finfo(float).eps * (diag[0] if diag.size else 0.0)
    rank = int(np.sum(diag > tol))
    null = np.zeros((p, 0))
    if rank < q:
        null_z = _null_space(M, rank) / norms[:, None]
        null = null_z if N is None else N @ null_z
    return LstsqResult(x, null, M, s, rhs)
