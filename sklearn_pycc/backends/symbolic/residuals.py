"""The residuals of a skeleton's equations as functions of its curves, for symbolic fitting."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ...exceptions import SkeletonError
from ...fitting.problem import Problem, active_residuals
from ...skeleton.compiler import compile_expression
from ...skeleton.nodes import Unknown, walk

__all__ = ["CurveResiduals"]


class CurveResiduals:
    """Weighted residuals of the active equations for given curves and parameters.

    Each residual is compiled once per set of parameter values (the
    compiler folds them in); curves are read through proxies, so trying
    another curve costs no compilation.
    """

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.slots, self.env = problem.environment()
        self.nodes, self.weights = active_residuals(problem)
        self.n = problem.data.n_samples
        self._functions: Mapping = {}
        self._proxies = {name: self._proxy(name) for name in problem.skeleton.functions}
        self._key: tuple | None = None
        self._compiled: list = []

    def _proxy(self, name: str):
        return lambda x: self._functions[name](x)

    def _closures(self, params: Mapping) -> list:
        values = {**self.problem.fixed_params, **params}
        key = tuple(sorted(values.items()))
        if key != self._key:
            self._compiled = [compile_expression(node, self.slots, values, self._proxies)
                              for node in self.nodes]
            self._key = key
        return self._compiled

    def equation(self, k: int, functions: Mapping, params: Mapping) -> np.ndarray:
        """The weighted residual of active equation ``k`` on every sample."""
        closure = self._closures(params)[k]
        self._functions = functions
        with np.errstate(all="ignore"):
            out = closure(self.env)
        return self.weights[k] * np.broadcast_to(np.asarray(out, dtype=float), (self.n,))

    def __call__(self, functions: Mapping, params: Mapping) -> np.ndarray:
        """Every active equation's weighted residual, one after the other."""
        return np.concatenate([self.equation(k, functions, params)
                               for k in range(len(self.nodes))])

    def loss(self, functions: Mapping, params: Mapping) -> float:
        """The mean squared residual (inf where it is not finite)."""
        r = self(functions, params)
        value = float(np.mean(r * r))
        return value if np.isfinite(value) else np.inf

    def argument(self, node, params: Mapping, functions: Mapping) -> np.ndarray:
        """The expression ``node`` (a curve's argument) on every sample."""
        values = {**self.problem.fixed_params, **params}
        with np.errstate(all="ignore"):
            out = compile_expression(node, self.slots, values, functions)(self.env)
        return np.broadcast_to(np.asarray(out, dtype=float), (self.n,))

    def isolated(self, name: str, functions: Mapping, params: Mapping):
        """``(argument, target, weight)`` samples for the curve ``name``.

        For each equation applying the curve, the value the curve would need
        for that equation's residual to vanish, given everything else (a
        Gauss-Newton step, exact when the curve enters linearly), weighted by
        the squared sensitivity of the residual to the curve.
        """
        current = functions[name]

        def bumped(x):
            return current(x) + 1.0

        xs, targets, weights = [], [], []
        for k, node in enumerate(self.nodes):
            uses = [sub for sub in walk(node) if isinstance(sub, Unknown) and sub.name == name]
            if not uses:
                continue
            if len(uses) > 1:
                eq = self.problem.equations[self.problem.active[k]]
                raise SkeletonError(
                    f"SymbolicCCRegressor isolates each curve in each equation, but {name} "
                    f"appears {len(uses)} times here", equation=eq.index,
                    position=max(uses[1].pos, 0), text=eq.text)
            r0 = self.equation(k, functions, params)
            r1 = self.equation(k, {**functions, name: bumped}, params)
            slope = r1 - r0
            x = self.argument(uses[0].arg, params, functions)
            usable = np.isfinite(slope) & np.isfinite(r0) & np.isfinite(x) & (
                np.abs(slope) > 1e-12 * max(float(np.nanmax(np.abs(slope))), 1e-300))
            xs.append(x[usable])
            targets.append(current(x[usable]) - r0[usable] / slope[usable])
            weights.append(slope[usable] ** 2)
        return np.concatenate(xs), np.concatenate(targets), np.concatenate(weights)
