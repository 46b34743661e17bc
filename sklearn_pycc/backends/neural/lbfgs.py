"""L-BFGS whose search direction costs a handful of tensor operations.

``torch.optim.LBFGS`` finds each direction by the two-loop recursion: two
dot products and two vector updates per stored curvature pair, some four
hundred small tensor operations per iteration with a history of one hundred.
On the small networks of a skeleton (a few hundred weights) that bookkeeping
costs as much as the networks themselves. :class:`CompactLBFGS` applies the
same inverse-Hessian approximation in its compact form (Byrd, Nocedal and
Schnabel, 1994): with the stored steps ``S`` and gradient changes ``Y`` as
the rows of two matrices,

    H g = gamma g + S^T z - gamma Y^T w,
    R w = S g,   R^T z = (D + gamma Y Y^T) w - gamma Y g,

where ``R`` is the upper triangle of ``S Y^T``, ``D`` its diagonal and
``gamma = s^T y / y^T y`` of the newest pair. ``S Y^T`` and ``Y Y^T`` are
kept up to date one row at a time. Everything else, the strong-Wolfe line
search included, is torch's.
"""

from __future__ import annotations

import torch
from torch.optim.lbfgs import _strong_wolfe

__all__ = ["CompactLBFGS"]


class _Memory:
    """The stored curvature pairs and their inner products, in a ring buffer.

    Rows of ``S`` and ``Y`` are overwritten oldest first, so nothing of size
    ``history x n_weights`` is ever copied; :attr:`order` lists the slots from
    the oldest pair to the newest, which the compact form needs.
    """

    def __init__(self, size: int, like: torch.Tensor) -> None:
        self.size = size
        self.S = like.new_zeros((size, like.numel()))
        self.Y = like.new_zeros((size, like.numel()))
        self.SY = like.new_zeros((size, size))  # s_i . y_j
        self.YY = like.new_zeros((size, size))  # y_i . y_j
        self.count = 0
        self.oldest = 0
        self.gamma = 1.0

    @property
    def order(self) -> torch.Tensor:
        """Slots from the oldest pair to the newest."""
        k = self.count
        slots = torch.arange(k, device=self.S.device)
        return slots if k < self.size else (slots + self.oldest) % self.size

    def add(self, s: torch.Tensor, y: torch.Tensor, ys: torch.Tensor) -> None:
        """Store a pair, in place of the oldest when full."""
        if self.count < self.size:
            j = self.count
            self.count += 1
        else:
            j = self.oldest
            self.oldest = (self.oldest + 1) % self.size
        self.S[j], self.Y[j] = s, y
        k = self.count
        S, Y = self.S[:k], self.Y[:k]
        self.SY[j, :k] = Y @ s
        self.SY[:k, j] = S @ y
        self.YY[j, :k] = self.YY[:k, j] = Y @ y
        self.gamma = ys / self.YY[j, j]

    def direction(self, g: torch.Tensor) -> torch.Tensor:
        """``-H g`` for the stored pairs (``-g`` when there are none)."""
        if not self.count:
            return -g
        k, order, gamma = self.count, self.order, self.gamma
        S, Y = self.S[:k], self.Y[:k]
        SY = self.SY[order][:, order]
        R = torch.triu(SY)
        sg = (S @ g)[order, None]
        yg = (Y @ g)[order, None]
        w = torch.linalg.solve_triangular(R, sg, upper=True)
        middle = torch.diag(torch.diagonal(SY)) + gamma * self.YY[order][:, order]
        z = torch.linalg.solve_triangular(R.T, middle @ w - gamma * yg, upper=False)
        # back from the oldest-first order to the slots
        coef = torch.empty((k, 2), dtype=g.dtype, device=g.device)
        coef[order] = torch.cat([z, -gamma * w], 1)
        return -(gamma * g + S.T @ coef[:, 0] + Y.T @ coef[:, 1])


class CompactLBFGS(torch.optim.LBFGS):
    """``torch.optim.LBFGS`` with the direction from the compact representation.

    Takes the same arguments and keeps the same state between calls of
    :meth:`step` (so an epoch of ``max_iter`` iterations continues where the
    previous one stopped); only ``line_search_fn="strong_wolfe"`` is offered.
    """

    def __init__(self, params, lr: float = 1.0, max_iter: int = 20,
                 max_eval: int | None = None, tolerance_grad: float = 1e-7, *,
                 tolerance_change: float = 1e-9, history_size: int = 100,
                 line_search_fn: str | None = "strong_wolfe") -> None:
        if line_search_fn != "strong_wolfe":
            raise ValueError("CompactLBFGS searches along each direction with a strong Wolfe "
                             f"line search; got line_search_fn={line_search_fn!r}")
        super().__init__(params, lr=lr, max_iter=max_iter, max_eval=max_eval,
                         tolerance_grad=tolerance_grad, tolerance_change=tolerance_change,
                         history_size=history_size, line_search_fn=line_search_fn)

    @torch.no_grad()
    def step(self, closure):
        """Run up to ``max_iter`` iterations; return the loss at the start."""
        group = self.param_groups[0]
        lr, max_iter, max_eval = group["lr"], group["max_iter"], group["max_eval"]
        tol_grad, tol_change = group["tolerance_grad"], group["tolerance_change"]
        state = self.state[self._params[0]]
        state.setdefault("func_evals", 0)
        state.setdefault("n_iter", 0)

        closure = torch.enable_grad()(closure)
        first_loss = closure()
        loss = float(first_loss)
        evals = 1
        state["func_evals"] += 1
        grad = self._gather_flat_grad()
        if grad.abs().max() <= tol_grad:
            return first_loss
        memory: _Memory = state.get("memory") or _Memory(group["history_size"], grad)
        d, t = state.get("d"), state.get("t")
        prev_grad, prev_loss = state.get("prev_flat_grad"), state.get("prev_loss")

        for n_iter in range(1, max_iter + 1):
            state["n_iter"] += 1
            if state["n_iter"] > 1:
                y = grad - prev_grad
                s = d * t
                ys = y.dot(s)
                if ys > 1e-10:
                    memory.add(s, y, ys)
            d = memory.direction(grad)
            prev_grad, prev_loss = grad.clone(memory_format=torch.contiguous_format), loss
            t = min(1.0, 1.0 / float(grad.abs().sum())) * lr if state["n_iter"] == 1 else lr
            gtd = grad.dot(d)
            if gtd > -tol_change:
                break
            start = self._clone_param()

            def along(x, step, direction):
                return self._directional_evaluate(closure, x, step, direction)

            loss, grad, t, searched = _strong_wolfe(along, start, t, d, loss, grad, gtd)
            self._add_grad(t, d)
            evals += searched
            state["func_evals"] += searched
            if (n_iter == max_iter or evals >= max_eval or grad.abs().max() <= tol_grad
                    or (d * t).abs().max() <= tol_change or abs(loss - prev_loss) < tol_change):
                break

        state.update(memory=memory, d=d, t=t, prev_flat_grad=prev_grad, prev_loss=prev_loss)
        return first_loss
