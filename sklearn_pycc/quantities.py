"""What each state of a skeleton measures, so that a missing effect is named in its field's words.

A state's quantity comes from the user (``quantities={"x1": "level"}``), else
from its unit (``K`` is a temperature, ``mol/l`` a concentration), else from
the skeleton's structure: a state whose derivative is another state is a
position, and that other state a velocity. Any other state's quantity is not
known, and the effects it may miss are named by their shape in plain words
(:meth:`sklearn_pycc.effects.Effect.called`).

Examples
--------
>>> from sklearn_pycc import Skeleton
>>> from sklearn_pycc.quantities import state_quantities
>>> tank = Skeleton(["x1_dot = a1 u - a2 x1"])
>>> state_quantities(tank, {"x1": "level"})
{'x1': 'level'}
>>> state_quantities(tank, units={"x1": "K"})
{'x1': 'temperature'}
>>> state_quantities(Skeleton(["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1"]))
{'x1': 'position', 'x2': 'velocity'}
"""

from __future__ import annotations

from collections.abc import Mapping

from .skeleton import Skeleton
from .skeleton.nodes import Symbol

__all__ = ["MECHANICAL", "QUANTITIES", "UNITS", "field_of", "is_mechanical",
           "state_quantities"]

#: every quantity a state may be said to measure, and its field
QUANTITIES: dict[str, str] = {
    "position": "mechanics", "velocity": "mechanics", "angle": "mechanics",
    "angular_velocity": "mechanics",
    "level": "process", "volume": "process", "pressure": "process", "flow": "process",
    "temperature": "thermal", "heat": "thermal",
    "voltage": "electrical", "current": "electrical", "charge": "electrical",
    "flux": "electrical",
    "concentration": "kinetics", "population": "kinetics", "amount": "kinetics",
}
#: the quantities whose equations may have mechanical effects (friction, springs, drag)
MECHANICAL = frozenset(q for q, field in QUANTITIES.items() if field == "mechanics")

#: a unit -> the quantity it measures (a length is a position or a level, by the structure)
UNITS: dict[str, str] = {
    **dict.fromkeys(("K", "degC", "°C", "degF", "°F"), "temperature"),
    **dict.fromkeys(("V", "mV", "kV"), "voltage"),
    **dict.fromkeys(("A", "mA", "uA", "µA"), "current"),
    **dict.fromkeys(("mol/l", "mol/L", "mmol/l", "mmol/L", "mol/m3", "mol/m^3", "M", "mM",
                     "g/l", "g/L", "mg/l", "mg/L", "kg/m3", "kg/m^3"), "concentration"),
    **dict.fromkeys(("Pa", "kPa", "MPa", "hPa", "bar", "mbar", "psi"), "pressure"),
    **dict.fromkeys(("m3", "m^3", "l", "L", "ml", "mL"), "volume"),
    **dict.fromkeys(("m3/s", "m^3/s", "l/s", "L/s", "l/min", "L/min"), "flow"),
    **dict.fromkeys(("m/s", "mm/s", "cm/s"), "velocity"),
    **dict.fromkeys(("rad", "deg"), "angle"),
    **dict.fromkeys(("rad/s", "deg/s", "rpm"), "angular_velocity"),
    **dict.fromkeys(("J", "kJ"), "heat"),
    **dict.fromkeys(("Wb",), "flux"),
}
#: units of a length: a position in a mechanical pair, a level of a first-order state
LENGTHS = frozenset(("m", "cm", "mm", "km", "um", "µm"))


def field_of(quantity: str | None) -> str | None:
    """The field of a quantity (None when the quantity is not known)."""
    return None if quantity is None else QUANTITIES[quantity]


def is_mechanical(quantity: str | None) -> bool:
    """Whether a state of this quantity may have mechanical effects."""
    return quantity in MECHANICAL


def _pairs(skeleton: Skeleton) -> dict[str, str]:
    """``position -> velocity`` of every kinematic equation ``position_dot = velocity``."""
    out = {}
    for eq in skeleton.parsed:
        if (eq.explicit and isinstance(eq.rhs, Symbol) and eq.rhs.name in skeleton.states
                and eq.rhs.name != eq.state):
            out[eq.state] = eq.rhs.name
    return out


def _checked(quantities, skeleton: Skeleton) -> dict[str, str]:
    if quantities is None:
        return {}
    if not isinstance(quantities, Mapping):
        raise TypeError(f"quantities must be a dict of state -> quantity, got "
                        f"{type(quantities).__name__}")
    out = {}
    for state, quantity in quantities.items():
        if state not in skeleton.states:
            raise ValueError(f"quantities names {state!r}, which is not a state of the "
                             f"skeleton ({', '.join(skeleton.states)})")
        if quantity not in QUANTITIES:
            raise ValueError(f"quantities[{state!r}] is {quantity!r}, which is none of the "
                             f"known quantities: {', '.join(QUANTITIES)}")
        out[state] = quantity
    return out


def state_quantities(skeleton: Skeleton, quantities: Mapping[str, str] | None = None,
                     units: Mapping[str, str] | None = None) -> dict[str, str | None]:
    """What each state of ``skeleton`` measures (None: not known).

    Parameters
    ----------
    skeleton : Skeleton
    quantities : dict, optional
        State -> one of :data:`QUANTITIES`, as the user says it.
    units : dict, optional
        Column or state -> unit (``"K"``, ``"mol/l"``); a unit of
        :data:`UNITS` tells the quantity of a state the user did not name.

    Returns
    -------
    dict
        State -> quantity, in the skeleton's order. A state whose derivative
        is another state is a ``"position"`` (a length or an angle by its
        unit) and that state a ``"velocity"``, unless the user says
        otherwise; a first-order state measured in a length is a
        ``"level"``.

    Raises
    ------
    ValueError
        If ``quantities`` names a state the skeleton does not have or an
        unknown quantity.
    """
    given = _checked(quantities, skeleton)
    units = dict(units or {})
    pairs = _pairs(skeleton)
    velocities = set(pairs.values())
    out: dict[str, str | None] = {}
    for state in skeleton.states:
        unit = units.get(state)
        if state in given:
            out[state] = given[state]
        elif unit in UNITS:
            out[state] = UNITS[unit]
        elif state in pairs:
            out[state] = "position"
        elif state in velocities:
            out[state] = "velocity"
        elif unit in LENGTHS:
            out[state] = "level"
        else:
            out[state] = None
    return out
