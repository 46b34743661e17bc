"""A skeleton with known curves and parameters, compiled for evaluation."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from functools import cached_property
from operator import itemgetter

import numpy as np

from .._utils.generated import generated_function
from ..exceptions import SkeletonError
from ..simulation.integration import Diverged
from .compiler import compile_expression
from .curves import stack_curves
from .equations import TIME, Equation, evaluation_order
from .python_source import ExpressionWriter, rhs_source

__all__ = ["CompiledSystem", "stack_systems"]


class _OutsideDomain(ValueError):
    """A function of the scalar plan read a value outside its domain (``math``'s error)."""

    def __init__(self, error: ValueError, slot: int) -> None:
        super().__init__(str(error))
        self.slot = slot


def _run_plan(plan: list, env: list) -> None:
    """Evaluate a scalar plan in place: each slot explicitly, or solved where it enters linearly.

    Raises
    ------
    _OutsideDomain
        Naming the slot whose function read a value outside its domain.
    """
    slot = -1
    try:
        for slot, fn, explicit in plan:
            if explicit:
                env[slot] = fn(env)
            else:  # linear in the slot: two evaluations give its root
                env[slot] = 0.0
                e0 = fn(env)
                env[slot] = 1.0
                e1 = fn(env)
                env[slot] = -e0 / (e1 - e0)
    except ValueError as exc:  # math's domain errors
        raise _OutsideDomain(exc, slot) from exc


class CompiledSystem:
    """Right-hand side of a skeleton, compiled once with fixed curves and parameters.

    The variable environment is laid out as ``[states..., inputs..., t,
    derivatives...]``. Implicit equations, linear in the derivative they
    determine, are solved as ``d = -e(0) / (e(1) - e(0))`` where ``e`` is the
    residual with ``d`` set to 0 and 1.

    Parameters
    ----------
    equations : list of Equation
        Classified equations of a skeleton.
    states, inputs : list of str
        Slot order.
    params : mapping
        Values of every parameter.
    functions : mapping
        Callables of every curve (vectorised over numpy arrays).
    static : list of Equation, optional
        Static equations ``NAME = rhs``, whose outputs
        :meth:`evaluate_outputs` predicts from the same columns.
    limits : mapping, optional
        State -> ``(low, high)``: hard limits. At a limit the state's rate is
        held at zero while it points beyond (see :meth:`clip` for the states
        themselves).
    """

    def __init__(
        self,
        equations: list[Equation],
        states: list[str],
        inputs: list[str],
        params: Mapping[str, float],
        functions: Mapping[str, Callable],
        *,
        static: list[Equation] = (),
        limits: Mapping[str, tuple[float, float]] | None = None,
    ) -> None:
        self.states = list(states)
        #: what it was compiled from, for :func:`stack_systems`
        self._source = (equations, params, functions)
        self.limits = {s: (_end(lo), _end(hi)) for s, (lo, hi) in (limits or {}).items()}
        # (position among the states, position among the derivatives, low, high)
        self._limited = [(self.states.index(s), [eq.state for eq in equations].index(s), lo, hi)
                         for s, (lo, hi) in self.limits.items()]
        self.inputs = list(inputs)
        self.derivatives = [eq.derivative for eq in equations]
        names = [*self.states, *self.inputs, TIME, *self.derivatives]
        self.slots = {name: i for i, name in enumerate(names)}
        self.n_env = len(names)
        self._order = []
        for i in evaluation_order(equations):
            eq = equations[i]
            if not eq.solvable:
                raise SkeletonError(
                    f"cannot solve for {eq.derivative}: it does not enter the equation "
                    "linearly, so the model can be fitted as written but not simulated",
                    equation=eq.index, position=0, text=eq.text)
            self._order.append(eq)
        first = len(self.states) + len(self.inputs) + 1
        self._derivative_slots = list(range(first, first + len(self.derivatives)))
        # the state order of the output follows the equations; map to slots
        self._output_slots = [self.slots[d] for d in self.derivatives]
        self.outputs = [eq.output for eq in static]
        self._static_equations = list(static)

    # each form is compiled when first read: a fit compiles a system for every trial of
    # its numbers, and most are only simulated, by one form
    def _plan(self, mode: str) -> list:
        _, params, functions = self._source
        return [(self.slots[eq.derivative],
                 compile_expression(eq.expression, self.slots, params, functions, mode=mode),
                 eq.explicit) for eq in self._order]

    @cached_property
    def _plan_scalar(self) -> list:
        """``(slot, closure on floats, explicit)`` of each equation, in evaluation order."""
        return self._plan("scalar")

    @cached_property
    def _plan_array(self) -> list:
        """``(slot, closure on arrays, explicit)`` of each equation, in evaluation order."""
        return self._plan("array")

    @cached_property
    def _static(self) -> list:
        """The static equations' right-hand sides, compiled on arrays."""
        _, params, functions = self._source
        return [compile_expression(eq.rhs, self.slots, params, functions, mode="array")
                for eq in self._static_equations]

    def rate_statements(self) -> tuple[list[str], list[str], list, dict] | None:
        """The scalar right-hand side as Python statements over locals ``v{slot}``.

        The statements read the states, inputs and ``t`` from their slots'
        locals (``v0`` is the first state) and compute every derivative's
        in evaluation order, with the scalar plan's arithmetic (see
        :mod:`.python_source`). For a generated integrator.

        Returns
        -------
        (statements, rates, holds, namespace) or None
            ``rates`` names the locals of the derivatives in equation order;
            ``holds`` gives ``(state position, rate position)`` of each state
            with limits, hold ``k``'s ends bound as ``lo{k}`` and ``hi{k}``;
            ``namespace`` binds those and the numbers and functions the
            statements read. None where an equation must be solved for its
            derivative or the system stacks variants.
        """
        equations, params, functions = self._source
        if not all(eq.explicit for eq in equations):
            return None
        try:
            writer = ExpressionWriter(self.slots, params, functions)
        except ValueError:  # stacked variants: arrays only
            return None
        statements = []
        for eq in self._order:
            source, _ = writer.write(eq.expression)
            statements.extend(writer.lines)
            writer.lines.clear()
            statements.append(f"v{self.slots[eq.derivative]} = {source}")
        namespace = dict(writer.namespace)
        for k, (_, _, low, high) in enumerate(self._limited):
            namespace[f"lo{k}"], namespace[f"hi{k}"] = float(low), float(high)
        return (statements, [f"v{slot}" for slot in self._output_slots],
                [(q, j) for q, j, _, _ in self._limited], namespace)

    # -- vectorised evaluation ----------------------------------------------
    def _env(self, data: Mapping[str, np.ndarray]) -> list:
        """The variable environment laid out from data columns (missing slots None)."""
        env: list = [None] * self.n_env
        for name, slot in self.slots.items():
            if name in data:
                env[slot] = np.asarray(data[name], dtype=float)
        return env

    def evaluate(self, data: Mapping[str, np.ndarray], n: int, hold: bool = True) -> np.ndarray:
        """Derivatives on data columns (states, inputs, ``t``); shape ``(n, n_states)``.

        ``hold=False`` leaves the rates at a limit as the equations give them
        (a Jacobian is taken across the limit's jump otherwise).
        """
        env = self._env(data)
        with np.errstate(all="ignore"):
            for slot, fn, explicit in self._plan_array:
                if explicit:
                    env[slot] = np.broadcast_to(np.asarray(fn(env), dtype=float), (n,))
                else:
                    env[slot] = np.zeros(n)
                    e0 = np.broadcast_to(np.asarray(fn(env), dtype=float), (n,))
                    env[slot] = np.ones(n)
                    e1 = np.broadcast_to(np.asarray(fn(env), dtype=float), (n,))
                    env[slot] = -e0 / (e1 - e0)
        if not self._output_slots:
            return np.zeros((n, 0))
        rates = np.column_stack([env[s] for s in self._output_slots])
        if self._limited and hold:
            x = np.column_stack([np.broadcast_to(np.asarray(env[q], dtype=float), (n,))
                                 for q in range(len(self.states))])
            self._hold(x, rates)
        return rates

    def _hold(self, x: np.ndarray, rates: np.ndarray) -> None:
        """Zero, in place, the rates that would carry a state beyond its limit."""
        for q, j, low, high in self._limited:
            beyond = ((x[:, q] >= high) & (rates[:, j] > 0)) | (
                (x[:, q] <= low) & (rates[:, j] < 0))
            rates[beyond, j] = 0.0

    def clip(self, x: np.ndarray) -> np.ndarray:
        """States ``(..., n_states)`` held within their limits, in place.

        An integration step may overshoot a limit by its error.
        """
        for q, _, low, high in self._limited:
            np.clip(x[..., q], low, high, out=x[..., q])
        return x

    def clip_values(self, x: list[float]) -> list[float]:
        """A state as a list of floats held within its limits, in place (:meth:`clip`)."""
        for q, _, low, high in self._limited:
            x[q] = min(max(x[q], low), high)
        return x

    def batch_rhs(self, n: int, signals: list[str], *, hold: bool = True) -> Callable:
        """Return ``rhs(x, values)`` for ``n`` trajectories integrated side by side.

        ``x`` is ``(n, n_states)``; ``values`` holds an ``(n,)`` array for each
        name of ``signals`` (inputs and ``t``), in that order. The result is
        ``(n, n_states)``. What :meth:`evaluate` does, without building a
        mapping or broadcasting per call: the window integrators call it
        hundreds of thousands of times. ``hold=False`` leaves the rates at a
        limit as the equations give them (how hard the flow presses on it).
        """
        plan = self._plan_array
        n_env = self.n_env
        state_slots = list(range(len(self.states)))
        signal_slots = [self.slots[name] for name in signals]
        outputs = self._output_slots
        zeros, ones = np.zeros(n), np.ones(n)

        def rates(x: np.ndarray, values: list[np.ndarray]) -> np.ndarray:
            env: list = [None] * n_env
            for q in state_slots:
                env[q] = x[:, q]
            for slot, v in zip(signal_slots, values):
                env[slot] = v
            for slot, fn, explicit in plan:
                if explicit:
                    env[slot] = fn(env)
                else:
                    env[slot] = zeros
                    e0 = fn(env)
                    env[slot] = ones
                    e1 = fn(env)
                    env[slot] = -e0 / (e1 - e0)
            out = np.empty((n, len(outputs)))
            for j, slot in enumerate(outputs):
                out[:, j] = env[slot]  # a constant right-hand side broadcasts
            return out

        def rhs(x: np.ndarray, values: list[np.ndarray]) -> np.ndarray:
            out = rates(x, values)
            if limited:
                undefined = ~np.isfinite(out).all(axis=1)
                if undefined.any():  # sqrt of a level a step left a hair below its floor
                    held = clip(x.copy())
                    out[undefined] = rates(held, values)[undefined]
                hold(x, out)
            return out

        if not hold:
            return rates
        limited, hold, clip = bool(self._limited), self._hold, self.clip
        return rhs

    def evaluate_outputs(self, data: Mapping[str, np.ndarray], n: int) -> np.ndarray:
        """The static equations' outputs on data columns; shape ``(n, n_outputs)``."""
        env = self._env(data)
        with np.errstate(all="ignore"):
            values = [np.broadcast_to(np.asarray(fn(env), dtype=float), (n,))
                      for fn in self._static]
        return np.column_stack(values) if values else np.zeros((n, 0))

    # -- scalar right-hand side for ODE solvers ----------------------------
    def _evaluate_at_limits(self, env: list, exc: _OutsideDomain) -> None:
        """Evaluate the scalar plan again, in place, with the states held within their limits.

        A stage that a step pushes a hair beyond a limit is read as it
        stands where the equations are defined there (the sensitivities of a
        fit stay smooth), and at the limit where they are not (the square
        root of a level a hair below its floor). Raises :class:`Diverged`,
        naming the equation, where that does not help.
        """
        n = len(self.states)
        states = env[:n]
        if self.clip_values(env)[:n] == states:  # within its limits: truly outside the domain
            raise Diverged(self._outside_domain(exc, env)) from exc
        try:
            _run_plan(self._plan_scalar, env)
        except _OutsideDomain as again:
            raise Diverged(self._outside_domain(again, env)) from again

    def _outside_domain(self, exc: _OutsideDomain, env: list) -> str:
        """Words for a function evaluated outside its domain: the equation, time and states."""
        where = next(name for name, s in self.slots.items() if s == exc.slot)
        states = ", ".join(f"{name}={env[q]:.6g}" for q, name in enumerate(self.states))
        return (f"{exc} in {where} at t={env[self.slots[TIME]]:.6g} ({states}): a sqrt, log, "
                "arcsin or power reads a value outside its domain (a limit on the state, "
                "such as 'x1 >= 0', keeps it within)")

    def make_rhs(self, input_at: Callable[[float], list[float]], *,
                 list_states: bool = False) -> Callable:
        """Return ``rhs(t, y)`` for a SciPy solver; inputs come from ``input_at(t)``.

        With ``list_states`` the state ``y`` is a list of floats (the
        project's own integrators), otherwise a numpy array, read as a list
        by the same function.
        """
        if not list_states:
            on_lists = self.make_rhs(input_at, list_states=True)
            return lambda t, y: on_lists(t, y.tolist())
        to_list = list
        plan = self._plan_scalar
        outputs = self._output_slots
        pick = itemgetter(*outputs) if len(outputs) > 1 else (lambda env: (env[outputs[0]],))
        tail = [0.0] * len(self.derivatives)
        isfinite = math.isfinite
        has_inputs = bool(self.inputs)
        derivatives, states = self.derivatives, self.states

        def rhs(t, y):
            t = float(t)
            env = to_list(y)
            if has_inputs:
                env += input_at(t)
            env.append(t)
            env += tail
            try:
                _run_plan(plan, env)
            except _OutsideDomain as exc:
                self._evaluate_at_limits(env, exc)
            except ZeroDivisionError:  # say where the states were, as for a rate gone infinite
                where = ", ".join(f"{name}={x:.4g}" for name, x in zip(states, env))
                raise Diverged(f"the right-hand side ({', '.join(derivatives)}) divides by "
                               f"zero at t={t:.6g} ({where})") from None
            out = pick(env)
            # one C-level sum is finite whenever every term is (or it overflowed)
            if not isfinite(sum(out)):
                for derivative, v in zip(derivatives, out):
                    if not isfinite(v):  # say which rate, and where the states were
                        where = ", ".join(f"{name}={x:.4g}" for name, x in zip(states, env))
                        raise Diverged(f"the right-hand side of {derivative} is {v} at "
                                       f"t={t:.6g} ({where})")
            if limited:
                out = list(out)
                for q, j, low, high in limited:
                    if (env[q] >= high and out[j] > 0) or (env[q] <= low and out[j] < 0):
                        out[j] = 0.0
            return out

        limited = self._limited
        written = self.rate_statements() if list_states else None
        if written is None or not written[1]:
            return rhs
        statements, rates, holds, namespace = written
        source = rhs_source(len(states), len(self.inputs), statements, rates, holds)
        namespace = {**namespace, "input_at": input_at, "general": rhs, "isfinite": isfinite}
        # the same floats as rhs, written out as one function (rhs takes over the unusual)
        return generated_function(source, namespace, "rhs")


def _end(value) -> float | np.ndarray:
    """A limit's end: a number, or one number per row of a stacked system."""
    return float(value) if np.ndim(value) == 0 else np.asarray(value, dtype=float)


def stack_systems(systems: Sequence[CompiledSystem], rows: int, *,
                  limits_per_row: bool = False) -> CompiledSystem | None:
    """Systems that differ only in their numbers, compiled as one on ``len(systems) * rows`` rows.

    Block ``b`` of ``rows`` rows of every array the result evaluates follows
    ``systems[b]``: a parameter that differs is an array of one value per
    row, a curve that differs a stacked curve. A finite-difference Jacobian
    then integrates its bumped systems side by side, in one pass of numpy
    calls instead of one pass each.

    With ``limits_per_row``, the states' limits may differ too (an end to
    fit): an end that differs is then an array of one value per row, which
    :meth:`CompiledSystem.clip` and the held rates read row by row (the
    caller reads no end as a number).

    Returns
    -------
    CompiledSystem or None
        Array evaluation only (:meth:`CompiledSystem.batch_rhs` and friends);
        None where the systems differ in more than numbers (their equations,
        or their states' limits without ``limits_per_row``).
    """
    first = systems[0]
    equations, params, functions = first._source
    if any(s._source[0] is not equations for s in systems):
        return None
    limits = first.limits
    if any(s.limits != first.limits for s in systems):
        if not limits_per_row or any(s.limits.keys() != first.limits.keys() for s in systems):
            return None
        limits = {state: tuple(np.repeat([s.limits[state][side] for s in systems], rows)
                               for side in (0, 1)) for state in first.limits}
    stacked_params = {}
    for name, value in params.items():
        values = [s._source[1][name] for s in systems]
        same = all(v == value for v in values)
        stacked_params[name] = value if same else np.repeat(np.asarray(values, float), rows)
    stacked_functions = {name: stack_curves([s._source[2][name] for s in systems], rows)
                         for name in functions}
    return CompiledSystem(equations, first.states, first.inputs, stacked_params,
                          stacked_functions, limits=limits)
