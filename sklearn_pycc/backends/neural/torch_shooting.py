"""Multiple shooting through a differentiable Runge-Kutta integrator in torch.

The neural backend's output-error fit: the trained curve networks and
parameters, and every segment's initial state, are moved by L-BFGS so that
the states integrated over each shooting segment match the measured ones,
with continuity between consecutive segments as a penalty. The segments
and their inputs come from :class:`~sklearn_pycc.fitting.output_error.shooting.ShootingPlan`.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import torch

from ...fitting.output_error.shooting import CONTINUITY_WEIGHT, ShootingPlan
from ...skeleton.equations import TIME
from .lbfgs import CompactLBFGS
from .torch_expr import compile_torch

__all__ = ["shoot_module"]


def _tensor(values, like: torch.Tensor) -> torch.Tensor:
    return torch.as_tensor(np.asarray(values, dtype=float), dtype=like.dtype, device=like.device)


class _Integrator:
    """Batched RK4 over the plan's segments with the module's right-hand side."""

    def __init__(self, plan: ShootingPlan, problem, module, like: torch.Tensor) -> None:
        names = [*plan.states, *plan.inputs] + ([TIME] if plan.uses_time else [])
        slots = {name: i for i, name in enumerate(names)}
        fixed = problem.fixed_params
        self.rhs = []
        for eq in problem.dynamic:
            if not eq.solvable or eq.derivatives_used():
                raise ValueError(
                    f"fit_mode='simulation' needs every equation solved for its derivative; "
                    f"equation {eq.index} ('{eq.text}') is implicit or reads another derivative")
            self.rhs.append(compile_torch(eq.expression, slots, module.curves, module.params,
                                          fixed))
        self.plan = plan
        fine, ends = plan.fine_signals(), plan.fine_signals(left=True)
        self.signals = [_tensor(fine[name], like) for name in names[len(plan.states):]]
        # the later stages of a step read a held input's value before it steps
        self.lefts = self.signals if ends is fine else [
            _tensor(ends[name], like) for name in names[len(plan.states):]]
        self.h = _tensor(plan.h / plan.substeps, like)
        self.bound = _tensor(plan.bound, like)
        self.n_states = len(plan.states)

    def _f(self, x: torch.Tensor, column: int, left: bool = False) -> torch.Tensor:
        cols = [*x.unbind(1), *[s[:, column] for s in (self.lefts if left else self.signals)]]
        out = []
        for fn in self.rhs:
            value = fn(cols)
            if not isinstance(value, torch.Tensor) or value.ndim == 0:
                value = torch.as_tensor(value, dtype=x.dtype, device=x.device).expand(x.shape[0])
            out.append(value)
        return torch.stack(out, dim=1)

    def __call__(self, start: torch.Tensor) -> torch.Tensor:
        plan = self.plan
        m = plan.substeps
        x = start
        out = [x]
        for i in range(plan.n_steps):
            h = self.h[:, i:i + 1]
            for j in range(m):
                c = 2 * (i * m + j)
                k1 = self._f(x, c)
                k2 = self._f(x + 0.5 * h * k1, c + 1, True)
                k3 = self._f(x + 0.5 * h * k2, c + 1, True)
                k4 = self._f(x + h * k3, c + 2, True)
                x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
                # a diverging trial stays finite and far off: a large loss, not a crash
                x = torch.clamp(torch.nan_to_num(x), -self.bound, self.bound)
            out.append(x)
        return torch.stack(out, dim=1)


def shoot_module(plan: ShootingPlan, problem, module, iterations: int,
                 like: torch.Tensor) -> dict:
    """Refine ``module`` (curve networks and parameters) by output error, in place.

    Returns the summary dict of
    :func:`~sklearn_pycc.fitting.output_error.shooting.fit_shooting`. When the
    optimisation ends worse than it started (or not finite), the module is
    put back as it was.
    """
    integrate = _Integrator(plan, problem, module, like)
    K = plan.n_segments
    start = torch.nn.Parameter(_tensor(plan.initial, like))
    # a start the user gave is held: read from the plan, so no gradient moves it
    held = torch.as_tensor(plan.held_start, device=like.device)
    given = _tensor(plan.initial, like)
    targets = _tensor(plan.targets, like)
    own = torch.as_tensor(plan.own, device=like.device)
    scale = _tensor(plan.scale, like)
    measured = list(plan.measured_index)
    steps = torch.as_tensor(plan.steps, device=like.device)
    links = torch.as_tensor(np.flatnonzero(plan.successor), device=like.device)
    n_terms = int(plan.own.sum()) * len(measured)

    def loss_parts():
        begin = torch.where(held, given, start)
        states = integrate(begin)
        sim = states[:, :, measured]
        err = ((sim - targets) / scale[measured])[own]
        ends = states[torch.arange(K, device=like.device), steps]
        defects = CONTINUITY_WEIGHT * (ends[links] - begin[links + 1]) / scale
        return (err.pow(2).sum() + defects.pow(2).sum()) / n_terms, states, defects

    variables = [*module.parameters(), start]
    saved = copy.deepcopy(module.state_dict())
    with torch.no_grad():
        first, states0, _ = loss_parts()
    before = _nrmse(plan, states0)
    optimizer = CompactLBFGS(variables, lr=1.0, max_iter=int(iterations),
                                  max_eval=int(iterations * 5 // 4) + 1, history_size=20,
                                  line_search_fn="strong_wolfe", tolerance_grad=1e-9,
                                  tolerance_change=1e-12)
    evaluations = 0

    def closure():
        nonlocal evaluations
        evaluations += 1
        optimizer.zero_grad()
        loss, _, _ = loss_parts()
        loss.backward()
        return loss

    module.train()
    optimizer.step(closure)
    with torch.no_grad():
        final, states, defects = loss_parts()
    worse = not math.isfinite(float(final)) or float(final) > float(first)
    if worse:
        module.load_state_dict(saved)
        with torch.no_grad():
            start.copy_(_tensor(plan.initial, like))
            final, states, defects = loss_parts()
    escaped = (states.abs() >= 0.999 * integrate.bound).any(dim=2).any(dim=1)
    return {
        "segments": K,
        "window": plan.window,
        "substeps": plan.substeps,
        "iterations": evaluations,
        "nrmse_before": before,
        "nrmse_after": _nrmse(plan, states),
        "max_defect": float(defects.abs().max()) / CONTINUITY_WEIGHT if links.numel() else 0.0,
        "diverged": int(escaped.sum()),
        "reverted": worse,
    }


def _nrmse(plan: ShootingPlan, states: torch.Tensor) -> float:
    return plan.output_nrmse(states.detach().cpu().double().numpy())
