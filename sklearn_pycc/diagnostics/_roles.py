"""The physical role of each state in a skeleton: positions, velocities, couplings."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from ..quantities import is_mechanical, state_quantities
from ..skeleton import Skeleton
from ..skeleton.nodes import Symbol

__all__ = ["EquationRoles", "equation_roles", "kinematic_states"]


@dataclass(frozen=True)
class EquationRoles:
    """What an equation's effects may act through.

    Attributes
    ----------
    index : int
        Position of the equation.
    derivative : str
        The derivative it determines (``"x2_dot"``).
    position, velocity : str
        The state standing for the position and for the velocity. In a
        second-order pair ``x1_dot = x2`` they are ``x1`` and ``x2``; in a
        first-order equation both are its own state.
    others : tuple of (str, int or None)
        Other positions of a multi-degree-of-freedom system with the index
        of their acceleration equation (None when they have none).
    second_order : bool
        Whether the equation is the acceleration of a position-velocity pair.
    position_quantity, velocity_quantity : str or None
        What the position and the velocity measure
        (:func:`~sklearn_pycc.quantities.state_quantities`; a first-order
        state's own quantity for both; None: not known).
    mechanical : bool
        Whether the equation may have mechanical effects: a pair of a
        mechanical position and velocity, or a first-order state that the
        user says is mechanical (a velocity).
    partners : tuple of (str, int)
        The skeleton's other first-order states that are not mechanical, which
        a first-order state of that kind may interact with (a reaction between
        two species), with the index of their equation; empty for a mechanical
        equation.
    links : tuple of (str, int)
        Those of the partners a path may join the state to: of the same
        quantity, or either of an unknown one (two temperatures, two levels).
    """

    index: int
    derivative: str
    position: str
    velocity: str
    others: tuple[tuple[str, int | None], ...]
    second_order: bool
    position_quantity: str | None = "position"
    velocity_quantity: str | None = "velocity"
    mechanical: bool = True
    partners: tuple[tuple[str, int], ...] = ()
    links: tuple[tuple[str, int], ...] = ()

    def quantity_of(self, acts_through: str) -> str | None:
        """The quantity of the variable an effect acting through ``acts_through`` reads."""
        if acts_through in ("velocity", "position_velocity"):
            return self.velocity_quantity
        return self.position_quantity


def kinematic_states(skeleton: Skeleton) -> dict[str, str]:
    """``velocity -> position`` for every equation ``position_dot = velocity``."""
    out = {}
    for eq in skeleton.parsed:
        rhs = eq.rhs
        if (eq.explicit and isinstance(rhs, Symbol) and rhs.name in skeleton.states
                and rhs.name != eq.state and rhs.name not in out):
            out[rhs.name] = eq.state
    return out


def equation_roles(skeleton: Skeleton, quantities: Mapping[str, str] | None = None,
                   units: Mapping[str, str] | None = None) -> list[EquationRoles]:
    """Roles of every equation that can miss a physical effect.

    Kinematic equations (``x1_dot = x2``) define a velocity and are left out.
    ``quantities`` and ``units`` say what states measure (see
    :func:`~sklearn_pycc.quantities.state_quantities`).
    """
    measures = state_quantities(skeleton, quantities, units)
    position_of = kinematic_states(skeleton)
    positions = set(position_of.values())
    acceleration_of = {}
    for eq in skeleton.parsed:
        if eq.state in position_of:
            acceleration_of[position_of[eq.state]] = eq.index
    first_order = [(eq.state, eq.index) for eq in skeleton.parsed
                   if eq.state not in positions and eq.state not in position_of
                   and not is_mechanical(measures[eq.state])]
    out = []
    for eq in skeleton.parsed:
        state = eq.state
        if state in positions:
            continue  # kinematic: position_dot = velocity
        if state in position_of:
            own = position_of[state]
            others = tuple((p, acceleration_of.get(p)) for p in sorted(positions - {own}))
            pair = (measures[own], measures[state])
            out.append(EquationRoles(eq.index, eq.derivative, own, state, others, True, *pair,
                                     mechanical=all(map(is_mechanical, pair))))
        else:
            mechanical = is_mechanical(measures[state])
            partners = () if mechanical else tuple(p for p in first_order if p[0] != state)
            links = tuple(p for p in partners if None in (measures[p[0]], measures[state])
                          or measures[p[0]] == measures[state])
            out.append(EquationRoles(eq.index, eq.derivative, state, state, (), False,
                                     measures[state], measures[state], mechanical=mechanical,
                                     partners=partners, links=links))
    return out
