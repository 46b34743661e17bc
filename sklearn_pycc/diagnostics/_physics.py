"""Whole-model plausibility: every fitted term against the physical role the skeleton gives it.

A refit can lower the residual by letting terms cancel each other: a
negative viscous coefficient (energy fed in) offset by a large Stribeck term,
a spring that pushes away held back by a cubic one. Such a model fits the
record and is wrong. In the acceleration equation of a position-velocity
pair (``x1_dot = x2``, ``x2_dot = ...``) the roles are:

*dissipation*
    each term of the velocity alone removes energy (it opposes the
    velocity on average), and so do all of them together;
*stiffness*
    the terms of the position alone together pull back across the range
    the record covers (a softening cubic beside a linear spring is fine, a
    net spring that pushes away is not);
*gain*
    a term of the inputs alone has the sign it is written with (``a1 F``
    pushes along ``F``);
*inertia*
    in an equation written ``a1 x2_dot = ...`` the coefficient of the
    derivative has the sign it is written with.

Terms too small to matter (below :data:`SIGNIFICANT` of the derivative's RMS)
are not judged.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

from ..measurements.record import Record
from ..skeleton.compiler import compile_expression
from ..skeleton.nodes import (
    Neg,
    Node,
    Number,
    Param,
    Symbol,
    Unknown,
    product_factors,
    signed_terms,
    walk,
)
from ..skeleton.printer import to_text
from ._data import TIME
from ._roles import EquationRoles, equation_roles

__all__ = ["Implausibility", "implausible_terms"]

#: terms whose RMS along the record is below this share of the derivative's RMS are not judged
SIGNIFICANT = 0.01
#: a friction term may feed in this share of the power the friction terms exchange in all
#: (an estimate of a coefficient that is truly zero scatters around it)
INJECTION_TOLERANCE = 0.05


@dataclass(frozen=True)
class Implausibility:
    """A fitted term (or group of terms) that contradicts its physical role.

    Attributes
    ----------
    equation : str
        The derivative of the equation (``"x2_dot"``).
    role : str
        ``"dissipation"``, ``"stiffness"``, ``"gain"`` or ``"inertia"``.
    reason : str
        What is wrong, in words, with the fitted values.
    """

    equation: str
    role: str
    reason: str

    def __str__(self) -> str:
        return f"{self.equation}: {self.reason}"


@dataclass
class _Term:
    sign: float
    node: Node
    values: np.ndarray
    # even in the velocity (``a abs(v)``): an asymmetry of the friction, no dissipation itself
    even: bool = False

    def text(self, params) -> str:
        """The term as written, with the fitted values of its parameters."""
        names = sorted({n.name for n in walk(self.node) if isinstance(n, Param)})
        values = ", ".join(f"{a} = {params[a]:.4g}" for a in names if a in params)
        body = f"{'-' if self.sign < 0 else '+'} {to_text(self.node)}"
        return f"{body}' ({values})" if values else f"{body}'"


def _symbols(node: Node) -> set[str]:
    return {n.name for n in walk(node) if isinstance(n, Symbol)}


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(values**2))) if values.size else 0.0


def _evaluate(node: Node, slots, env, params, functions, *, n: int) -> np.ndarray:
    with np.errstate(all="ignore"):
        values = compile_expression(node, slots, params, functions)(env)
    return np.broadcast_to(np.asarray(values, dtype=float), (n,))


def _inertia(eq, params) -> tuple[float, float] | None:
    """``(fitted, as written)`` coefficient of the derivative of ``a x_dot = ...``; None else."""
    factors = product_factors(eq.lhs)
    if not any(isinstance(f, Symbol) and f.name == eq.derivative for f in factors):
        return None
    rest = [f for f in factors if not (isinstance(f, Symbol) and f.name == eq.derivative)]
    if not all(isinstance(f, (Param, Number)) for f in rest):
        return None
    sign = -1.0 if sum(isinstance(n, Neg) for n in walk(eq.lhs)) % 2 else 1.0
    fitted = sign * float(np.prod([params[f.name] if isinstance(f, Param) else f.value
                                   for f in rest]))
    written = sign * float(np.prod([1.0 if isinstance(f, Param) else f.value for f in rest]))
    return fitted, written


def implausible_terms(model, data: Record,
                      skip: Collection[tuple[int, Node]] = ()) -> list[Implausibility]:
    """Terms of a fitted model that contradict their physical role on ``data``.

    Parameters
    ----------
    model : CCRegressor
        A fitted model.
    data : Record
        The rows the terms are evaluated on.
    skip : collection of (int, Node)
        ``(equation index, term)`` pairs judged elsewhere (a candidate's
        own term): left out of the per-term checks, kept in the sums.

    Returns
    -------
    list of Implausibility
        Empty when every judged term plays its role.
    """
    skeleton = model.skeleton_
    params, functions = model.params_, model.functions_
    slots, env = data.environment([eq.rhs for eq in skeleton.parsed])
    inputs = {name for name in skeleton.inputs if name != TIME}
    out: list[Implausibility] = []
    for roles in equation_roles(skeleton):
        eq = skeleton.parsed[roles.index]
        scale = 1.0
        if not eq.explicit:
            inertia = _inertia(eq, params)
            if inertia is None:
                continue
            fitted, written = inertia
            if fitted * written <= 0:
                out.append(Implausibility(eq.derivative, "inertia", (
                    f"the coefficient of {eq.derivative} is {fitted:.4g}, of the opposite "
                    "sign to the one written: the inertia (mass) must keep that sign")))
                continue
            scale = fitted
        n = data.n_samples
        terms = [_Term(sign, node, sign * _evaluate(node, slots, env, params, functions, n=n)
                       / scale) for sign, node in signed_terms(eq.rhs)]
        if roles.second_order:
            mirrored = list(env)
            mirrored[slots[roles.velocity]] = -data.columns[roles.velocity]
            for term in terms:
                if _symbols(term.node) == {roles.velocity}:
                    back = term.sign * _evaluate(term.node, slots, mirrored, params, functions,
                                                 n=n) / scale
                    term.even = bool(np.any(term.values)) and np.allclose(
                        back, term.values, rtol=1e-9, atol=1e-12 * _rms(term.values))
        size = _rms(data.derivatives[:, roles.index])
        skipped = {node for k, node in skip if k == roles.index}
        out.extend(_check_equation(roles, eq.derivative, terms, skipped, size, data=data,
                                   inputs=inputs,
                                   params=params, slots=slots))
    return out


def _check_equation(roles: EquationRoles, derivative: str, terms: list[_Term], skipped,
                    size: float, *, data: Record, inputs: set[str], params,
                    slots) -> list[Implausibility]:
    out = []
    significant = SIGNIFICANT * size
    friction, springs, excitation = [], [], []
    for term in terms:
        symbols = _symbols(term.node)
        if roles.second_order and symbols == {roles.velocity}:
            friction.append(term)
        elif roles.second_order and symbols == {roles.position, roles.velocity}:
            excitation.append(term)
        elif roles.second_order and symbols == {roles.position}:
            springs.append(term)
        elif symbols and symbols <= inputs and term.node not in skipped:
            why = _gain(term, params, data)
            if why and _rms(term.values) > significant:
                out.append(Implausibility(derivative, "gain", why))
    if friction:
        out.extend(_dissipation(derivative, friction, skipped, data.columns[roles.velocity],
                                significant, params=params, excitation=excitation,
                                position=data.columns[roles.position]))
    if springs:
        why = _stiffness(springs, data.columns[roles.position], significant, roles.position)
        if why:
            out.append(Implausibility(derivative, "stiffness", why))
    return out


def _gain(term: _Term, params, data: Record) -> str:
    if any(isinstance(n, Unknown) for n in walk(term.node)):
        return ""
    ones = {name: 1.0 for name in params}
    slots, env = data.environment([term.node])
    written = term.sign * _evaluate(term.node, slots, env, ones, {}, n=data.n_samples)
    if float(np.mean(term.values * written)) > 0:
        return ""
    return (f"the input term '{term.text(params)} pushes against the sign it is written "
            "with: a gain must keep it")


#: share of the samples, by distance from the middle of the position's range, on which a
#: self-excited oscillator's damping must remove energy
LARGE_AMPLITUDE = 0.25


def _dissipation(derivative: str, friction: list[_Term], skipped, velocity: np.ndarray,
                 significant: float, *, params, excitation: list[_Term] = (),
                 position: np.ndarray | None = None) -> list[Implausibility]:
    """Friction terms that feed energy in.

    Beside a damping that depends on the position too (``x^2 v``, van der
    Pol's), friction of the velocity alone may feed energy in at small
    amplitude: that is a self-excited oscillator, whose amplitude the
    state explains. The damping as a whole must then remove energy at
    large amplitude and not feed it in over the record.
    """
    if excitation and position is not None:
        return _self_excited(derivative, [*friction, *excitation], velocity, position,
                             significant)
    out = []
    powers = [float(np.mean(term.values * velocity)) for term in friction]
    exchanged = sum(abs(p) for p in powers)
    for term, power in zip(friction, powers):
        if term.node in skipped or term.even or power <= INJECTION_TOLERANCE * exchanged:
            continue
        if _rms(term.values) > significant:
            out.append(Implausibility(derivative, "dissipation", (
                f"the friction term '{term.text(params)} feeds energy in (it pushes along "
                "the velocity): dissipation must remove energy")))
    total = np.sum([term.values for term in friction], axis=0)
    if sum(powers) > 0 and _rms(total) > significant:
        out.append(Implausibility(derivative, "dissipation", (
            "the forces of the velocity together feed energy in: the friction of the "
            "model accelerates the motion")))
    return out


def _self_excited(derivative: str, damping: list[_Term], velocity: np.ndarray,
                  position: np.ndarray, significant: float) -> list[Implausibility]:
    total = np.sum([term.values for term in damping], axis=0)
    if _rms(total) <= significant:
        return []
    power = total * velocity
    exchanged = sum(abs(float(np.mean(term.values * velocity))) for term in damping)
    distance = np.abs(position - np.median(position))
    large = distance >= np.quantile(distance, 1.0 - LARGE_AMPLITUDE)
    if float(np.mean(power[large])) < 0 and \
            float(np.mean(power)) <= INJECTION_TOLERANCE * exchanged:
        return []
    return [Implausibility(derivative, "dissipation", (
        "the damping forces together feed energy in at large amplitude or over the record: "
        "a self-excited oscillation must be limited by its damping"))]


def _stiffness(springs: list[_Term], position: np.ndarray, significant: float,
               name: str) -> str:
    total = np.sum([term.values for term in springs], axis=0)
    if _rms(total) <= significant:
        return ""
    low, high = int(np.argmin(position)), int(np.argmax(position))
    span = float(position[high] - position[low])
    if span <= 0:
        return ""
    slope = float(total[high] - total[low]) / span
    if slope < 0:
        return ""
    return (f"the forces of the position together push away from the middle of the range "
            f"(net stiffness {-slope:.4g} over {name} from {position[low]:.4g} to "
            f"{position[high]:.4g}): a spring must pull back")
