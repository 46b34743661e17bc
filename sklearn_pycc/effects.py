"""The catalogue of physical effects a skeleton may be missing.

Each :class:`Effect` has a stable name, a one-line physical description,
the kind of variable it acts through, its term in the skeleton language
(parameters ``a1, a2, ...`` are renumbered when the term is added with
:meth:`~sklearn_pycc.Skeleton.add_term`), the free-curve alternative, and a
plausibility rule. Terms are written as they are *subtracted* from an
acceleration (``x2_dot = F_ext - ... - term``), the way forces opposing
motion appear in a skeleton. Dry friction is written with ``tanh(a {v})``
rather than ``sign({v})``: a discontinuous force makes an ODE solver chatter
wherever the motion sticks, and the smoothing scale is fitted like any
other parameter.

Placeholders in the templates:

``{x}``
    a position (a state whose derivative is another state),
``{v}``
    a velocity,
``{u}``
    a difference of positions (the stretch of a coupling between masses),
``{s}``
    a first-order state's own value (a level, a temperature, a
    concentration, a voltage): the term is its own rate of loss (outflow,
    consumption, decay).
``{r}``
    with ``{s}``, another first-order state the state's rate depends on: the
    term is an interaction of the two (a reaction between two species, a
    predator's catch of its prey). Each such effect is tried with ``{s}`` the
    equation's own state and the other state, and the other way round.
``{s}`` and ``{r}`` of a link (``acts_through="link"``)
    two first-order states of one quantity joined by a path: the term is
    the flow from ``{s}`` to ``{r}`` (heat through a wall or a door, water
    through a pipe or an orifice, current through a resistor), subtracted
    from the equation of ``{s}`` and, with its own coefficient (the two
    capacities differ), added to that of ``{r}``: what leaves one enters the
    other. Each pair of states is tried once, whether the skeleton joins them
    yet or not.
``{i}``
    an input the skeleton reads: an effect acting through it changes how
    the skeleton's own terms read the input rather than adding a term. Its
    term is what takes the input's place in them: ``{i}(t - a1)`` reads it
    late (a transport delay), ``a1 tanh({i}/a1)`` levels it off (an
    actuator's saturation). One that changes the input's shape is tried
    only on states that are not mechanical: on a forced mechanical record
    friction and springs take the same shapes.

Time is ``t`` itself. Users add their own effects with :func:`register`.

Effects know their field. A mechanical effect (``field="mechanics"``) enters
only the equations of mechanical states: a position and velocity pair, or a
first-order state the user says is a velocity. A first-order state of
another or unknown kind gets the effects that act through ``{s}``, and
:meth:`Effect.called` names each in the words of the state's quantity (the
square-root law is "Torricelli outflow" on a level, "orifice flow" on a
pressure, "square-root law" when the quantity is not known).

Examples
--------
>>> from sklearn_pycc import effects
>>> effects.get("coulomb_friction").term_for(v="x2")
'a1 tanh(a2 x2)'
>>> "quadratic_drag" in effects.names()
True
>>> effects.get("square_root_outflow").called("level")
'Torricelli outflow'
"""

from __future__ import annotations

import string
from dataclasses import dataclass

import numpy as np

from .exceptions import SkeletonError
from .quantities import QUANTITIES, is_mechanical
from .skeleton.constraints import Bound, parse_constraints
from .skeleton.nodes import Param, walk
from .skeleton.parser import parse_expression

__all__ = ["ACTS_THROUGH", "PLAUSIBILITY", "Effect", "catalogue", "get", "names", "register",
           "unregister"]

#: kind of variable an effect acts through -> the placeholders its term uses
ACTS_THROUGH: dict[str, tuple[str, ...]] = {
    "velocity": ("v",),
    "position": ("x",),
    "position_velocity": ("x", "v"),
    "difference": ("u",),
    "state": ("s",),
    "interaction": ("s", "r"),
    "link": ("s", "r"),
    "input": ("i",),
    "time": (),
    "none": (),
}

#: the fields an effect may belong to ("any": every field, named in plain words)
FIELDS = ("mechanics", "process", "thermal", "electrical", "kinetics", "any")

#: plausibility rules
PLAUSIBILITY: dict[str, str] = {
    "dissipative": "removes energy: the subtracted term has the sign of the velocity on "
                   "average (sum of term * velocity > 0)",
    "restoring": "pulls back toward equilibrium: the subtracted term has the sign of the "
                 "displacement on average (sum of term * position > 0)",
    "draining": "takes away what is stored: the subtracted term has the sign of the state "
                "on average (an outflow, a consumption, a decay; sum of term * state > 0)",
    "any": "no sign requirement",
}

_SAMPLE = {"x": "x1", "v": "x2", "u": "x1 - x3", "s": "x1", "r": "x2", "i": "u"}


@dataclass(frozen=True)
class Effect:
    """One physical effect of the catalogue.

    Parameters
    ----------
    name : str
        Stable identifier, e.g. ``"coulomb_friction"``.
    description : str
        One line of physics.
    acts_through : str
        A key of :data:`ACTS_THROUGH`.
    term : str
        Parametric term with placeholders (``"a1 sign({v})"``).
    curve : str or None
        Free-curve alternative (``"f1({v})"``), None when the effect has no
        one-dimensional curve form.
    curve_constraints : tuple of str
        Constraints of that curve, written with its own name (``("f1 odd",)``).
    plausibility : str
        A key of :data:`PLAUSIBILITY`.
    bounds : tuple of str
        Bounds of the term's parameters that its physics implies, written
        with the term's own names (``("a1 >= 0",)``: a Coulomb level is not
        negative); a diagnosis fits the term within them.
    requires : tuple of str
        Catalogue effects of which the equation must already hold one for
        this effect to be tried (an asymmetry of the viscous friction needs
        the viscous friction); empty when it can enter any equation.
    replaces : tuple of str
        Catalogue effects whose term this one may take the place of, in the
        same role (a pendulum's sine for a linear spring, Stribeck's law for
        Coulomb friction): a diagnosis then tries the swap as well as the
        addition.
    field : str, optional
        A key of :data:`FIELDS`: ``"mechanics"`` for an effect that only a
        mechanical state can have (friction, springs, drag), another field
        for a law of that field, ``"any"`` for a shape any state can have.
        By default ``"mechanics"`` for an effect acting through a position,
        a velocity or a difference of positions, else ``"any"``.
    names : tuple of (str, str)
        ``(quantity, name)`` pairs: what the effect is called on a state of
        that quantity (``("level", "Torricelli outflow")``), each quantity one
        of :data:`sklearn_pycc.quantities.QUANTITIES`.
    shape : str
        The effect's shape in plain words (``"square-root law"``): its name on
        a state whose quantity is not known, or of another field. Empty: the
        catalogue name in words.
    generalises : tuple of str
        Catalogue effects this one holds as a special case or a limit (a
        drift ``a1 + a2 t`` holds the offset ``a1``; a saturating reaction,
        far from saturation, mass action): where both take an error alike, a
        diagnosis names the simpler, and it screens this one only where the
        simpler takes some of the error.
    """

    name: str
    description: str
    acts_through: str
    term: str
    curve: str | None = None
    curve_constraints: tuple[str, ...] = ()
    plausibility: str = "any"
    bounds: tuple[str, ...] = ()
    requires: tuple[str, ...] = ()
    replaces: tuple[str, ...] = ()
    field: str | None = None
    names: tuple[tuple[str, str], ...] = ()
    shape: str = ""
    generalises: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"an effect name must be an identifier, got {self.name!r}")
        if self.acts_through not in ACTS_THROUGH:
            raise ValueError(f"effect {self.name!r}: acts_through must be one of "
                             f"{sorted(ACTS_THROUGH)}, got {self.acts_through!r}")
        if self.field is None:  # by the place it acts through
            object.__setattr__(self, "field", "mechanics" if self.acts_through in
                               MECHANICAL_PLACES else "any")
        if self.field not in FIELDS:
            raise ValueError(f"effect {self.name!r}: field must be one of {list(FIELDS)}, got "
                             f"{self.field!r}")
        if self.field != "mechanics" and self.acts_through in MECHANICAL_PLACES:
            raise ValueError(f"effect {self.name!r} acts through a {self.acts_through}, which "
                             "only a mechanical state has: give it field='mechanics'")
        if self.field == "mechanics" and self.acts_through in FIRST_ORDER_PLACES:
            raise ValueError(f"effect {self.name!r}: an effect acting through a first-order "
                             "state's own value ({s}) belongs to a field other than mechanics")
        for pair in self.names:
            if not (isinstance(pair, tuple) and len(pair) == 2
                    and all(isinstance(p, str) and p for p in pair)):
                raise ValueError(f"effect {self.name!r}: names must be (quantity, name) pairs "
                                 f"of strings, got {pair!r}")
            if pair[0] not in QUANTITIES:
                raise ValueError(f"effect {self.name!r}: names gives a name for {pair[0]!r}, "
                                 f"which is none of the known quantities: "
                                 f"{', '.join(QUANTITIES)}")
        if self.plausibility not in PLAUSIBILITY:
            raise ValueError(f"effect {self.name!r}: plausibility must be one of "
                             f"{sorted(PLAUSIBILITY)}, got {self.plausibility!r}")
        allowed = set(ACTS_THROUGH[self.acts_through])
        for label, template in (("term", self.term), ("curve", self.curve)):
            if template is None:
                continue
            used = {field for _, field, _, _ in string.Formatter().parse(template) if field}
            if used - allowed:
                raise ValueError(
                    f"effect {self.name!r}: the {label} uses {{{sorted(used - allowed)[0]}}}, "
                    f"but an effect acting through {self.acts_through!r} has "
                    f"{', '.join('{' + p + '}' for p in sorted(allowed)) or 'no placeholders'}")
            try:
                parse_expression(template.format(**_SAMPLE), kind=f"effect {self.name} {label}")
            except SkeletonError as exc:
                raise ValueError(f"effect {self.name!r}: its {label} is not valid skeleton "
                                 f"text: {exc}") from exc
        if self.acts_through == "input" and (self.curve is not None or "{i}" not in self.term):
            raise ValueError(f"effect {self.name!r}: an effect acting through an input is how "
                             "the skeleton's terms read it ('{i}(t - a1)', 'a1 tanh({i}/a1)'), "
                             "without a curve")
        if self.curve_constraints:
            parse_constraints(list(self.curve_constraints))
        if self.bounds:
            params = {n.name for n in walk(parse_expression(self.term.format(**_SAMPLE),
                                                            kind="term"))
                      if isinstance(n, Param)}
            for bound in parse_constraints(list(self.bounds)):
                if not isinstance(bound, Bound) or bound.param not in params:
                    raise ValueError(f"effect {self.name!r}: bounds must bound parameters of "
                                     f"its term ({', '.join(sorted(params))}), got "
                                     f"{str(bound)!r}")

    @property
    def quantities(self) -> tuple[str, ...]:
        """The quantities of the states the effect applies to.

        A mechanical effect: the mechanical ones (on a position and velocity
        pair of other quantities, a charge and a current, it is tried by its
        shape). A law of a first-order state's own rate: the quantities of
        its field that are not mechanical (all of those for ``"any"``; a
        state of unknown quantity gets it too), and so for any other effect
        of one field (a valve's characteristic: the process quantities). Any
        other effect: every quantity.
        """
        if self.field == "mechanics":
            return tuple(q for q in QUANTITIES if is_mechanical(q))
        if self.acts_through in FIRST_ORDER_PLACES or self.field != "any":
            return tuple(q for q, field in QUANTITIES.items() if not is_mechanical(q)
                         and self.field in ("any", field))
        return tuple(QUANTITIES)

    def called(self, quantity: str | None = None) -> str:
        """What the effect is called on a state of ``quantity`` (None: not known).

        Its name for that quantity when it has one (``"Torricelli outflow"``
        on a level); a mechanical effect on a mechanical state is called by
        its catalogue name in words (``"coulomb friction"``); otherwise its
        shape in plain words (``"square-root law"``; the catalogue name in
        words for an effect registered without a shape).
        """
        named = dict(self.names)
        if quantity in named:
            return named[quantity]
        if (self.field == "mechanics" and is_mechanical(quantity)) or not self.shape:
            return self.name.replace("_", " ")
        return self.shape

    def _fill(self, template: str, variables: dict[str, str]) -> str:
        needed = ACTS_THROUGH[self.acts_through]
        missing = [p for p in needed if p not in variables]
        if missing:
            raise ValueError(f"effect {self.name!r} acts through {self.acts_through}: give "
                             f"{', '.join(f'{p}=...' for p in missing)}")
        extra = [p for p in variables if p not in needed]
        if extra:
            raise ValueError(f"effect {self.name!r} does not use {extra[0]}=...")
        values = {p: f"({variables[p]})" if p == "u" else variables[p] for p in needed}
        return template.format(**values)

    def term_for(self, **variables: str) -> str:
        """The parametric term for concrete variables: ``term_for(v="x2")``."""
        return self._fill(self.term, variables)

    def curve_for(self, **variables: str) -> str | None:
        """The free-curve alternative for concrete variables, or None."""
        return None if self.curve is None else self._fill(self.curve, variables)

    def is_plausible(self, contribution, velocity=None, position=None) -> tuple[bool, str]:
        """Check the fitted term against the effect's plausibility rule.

        Parameters
        ----------
        contribution : array-like
            Values of the fitted term (as subtracted from the acceleration)
            along the data.
        velocity : array-like, optional
            The velocity of the same equation (needed by ``"dissipative"``).
        position : array-like, optional
            The position of the same equation (needed by ``"restoring"``),
            or a first-order state's own value (by ``"draining"``).

        Returns
        -------
        (bool, str)
            Whether it is plausible, and why not.
        """
        if self.plausibility == "any":
            return True, ""
        against, label, failure = _RULES[self.plausibility]
        reference = velocity if against == "velocity" else position
        if reference is None:
            raise ValueError(f"effect {self.name!r} is {self.plausibility}: give the {against}")
        against = "state" if self.plausibility == "draining" else against
        contribution = np.asarray(contribution, dtype=float)
        mean = float(np.mean(contribution * np.asarray(reference, dtype=float)))
        if mean > 0:
            return True, ""
        if not np.any(contribution):
            return False, (f"the fitted {self.name} term vanishes: the data ask for the sign "
                           "its physics excludes (it is held at its bound)")
        return False, (f"{self.called()} must {label}, but the fitted term {failure} "
                       f"(mean term * {against} = {mean:.3g} <= 0)")


#: rule -> (variable the term is multiplied by, what it must do, what it did instead)
_RULES = {
    "dissipative": ("velocity", "remove energy", "feeds energy in"),
    "restoring": ("position", "pull back toward equilibrium", "pushes away from it"),
    "draining": ("position", "take away what is stored", "adds to it"),
}

#: the places only a mechanical state has
MECHANICAL_PLACES = ("velocity", "position", "position_velocity", "difference")
#: the places of first-order states' own laws: their value, an interaction of two, a link
FIRST_ORDER_PLACES = ("state", "interaction", "link")


_CATALOGUE: dict[str, Effect] = {}


def register(effect: Effect, replace: bool = False) -> Effect:
    """Add an effect to the catalogue (``replace=True`` to overwrite a name)."""
    if not isinstance(effect, Effect):
        raise TypeError(f"register expects an Effect, got {type(effect).__name__}")
    if effect.name in _CATALOGUE and not replace:
        raise ValueError(f"an effect named {effect.name!r} is already registered; pass "
                         "replace=True to overwrite it")
    _CATALOGUE[effect.name] = effect
    return effect


def unregister(name: str) -> Effect:
    """Remove an effect from the catalogue and return it."""
    try:
        return _CATALOGUE.pop(name)
    except KeyError:
        raise KeyError(f"no effect named {name!r}; the catalogue has {names()}") from None


def get(name: str) -> Effect:
    """The effect called ``name``."""
    try:
        return _CATALOGUE[name]
    except KeyError:
        raise KeyError(f"no effect named {name!r}; the catalogue has {names()}") from None


def names() -> list[str]:
    """Names of every registered effect, in registration order."""
    return list(_CATALOGUE)


def catalogue() -> list[Effect]:
    """Every registered effect, in registration order."""
    return list(_CATALOGUE.values())


_POSITIVE = ("a1 >= 0",)
for _effect in (
    Effect("viscous_damping", "force proportional to velocity (a dashpot, a fluid film)",
           "velocity", "a1 {v}", "f1({v})", ("f1 odd",), "dissipative", _POSITIVE,
           shape="linear law of the rate"),
    Effect("coulomb_friction", "dry friction of constant level opposing the sliding "
           "direction, smoothed at zero speed", "velocity", "a1 tanh(a2 {v})", "f1({v})",
           ("f1 odd",), "dissipative", ("a1 >= 0", "a2 >= 0"),
           shape="sign-like (tanh) law of the rate"),
    Effect("stribeck_friction", "dry friction that is higher at breakaway and falls with "
           "speed", "velocity", "(a1 + a2 exp(-({v}/a3)^2)) tanh(a4 {v})", "f1({v})",
           ("f1 odd",), "dissipative", ("a1 >= 0", "a2 >= 0", "a4 >= 0"),
           replaces=("coulomb_friction",),
           shape="sign-like law of the rate, peaked near zero"),
    Effect("quadratic_drag", "drag growing with the square of speed (turbulent flow)",
           "velocity", "a1 {v} abs({v})", "f1({v})", ("f1 odd",), "dissipative", _POSITIVE,
           replaces=("viscous_damping",),
           shape="signed square law of the rate"),
    Effect("linear_stiffness", "spring force proportional to displacement", "position",
           "a1 {x}", "f1({x})", ("f1(0)=0",),
           shape="linear law"),
    Effect("cubic_stiffness", "hardening or softening spring (Duffing term)", "position",
           "a1 {x}^3", "f1({x})", ("f1 odd",),
           shape="cubic law"),
    Effect("saturation", "restoring force that levels off at large displacement", "position",
           "a1 tanh(a2 {x})", "f1({x})", ("f1 odd", "f1 increasing"), "restoring",
           ("a1 >= 0", "a2 >= 0"), replaces=("linear_stiffness",),
           shape="saturating (tanh) law"),
    Effect("dead_zone", "no force within a clearance, linear beyond it (backlash)",
           "position", "a1 ({x} - a2 sign({x})) (1 + sign(abs({x}) - a2))/2", "f1({x})",
           ("f1 odd", "f1 increasing"), "restoring", ("a1 >= 0", "a2 >= 0"),
           replaces=("linear_stiffness",),
           shape="dead zone"),
    Effect("pendulum", "gravity torque on a swinging arm, sine of the angle", "position",
           "a1 sin({x})", "f1({x})", ("f1 odd",), "restoring", _POSITIVE,
           replaces=("linear_stiffness",),
           shape="sine law"),
    Effect("position_dependent_damping", "damping that grows with displacement "
           "(van der Pol, Lienard)", "position_velocity", "a1 {x}^2 {v}", None, (),
           "dissipative", _POSITIVE,
           names=(("charge", "van der Pol damping"), ("current", "van der Pol damping"),
                  ("voltage", "van der Pol damping")),
           shape="damping growing with the square of the state"),
    Effect("linear_coupling", "linear spring between two masses", "difference", "a1 {u}",
           "f1({u})", ("f1(0)=0",),
           shape="linear coupling"),
    Effect("coupling", "nonlinear (cubic) spring between two masses", "difference",
           "a1 {u}^3", "f1({u})", ("f1 odd",),
           shape="cubic coupling"),
    Effect("asymmetric_viscous_damping", "viscous friction of a different coefficient in "
           "each direction of motion (a worn guide, a seal); added beside viscous damping",
           "velocity", "a1 abs({v})", "f1({v})", requires=("viscous_damping",),
           shape="one-sided linear law of the rate"),
    Effect("asymmetric_coulomb_friction", "dry friction of a different level in each "
           "direction of motion; added beside Coulomb friction", "velocity",
           "a1 tanh(a2 {v})^2", "f1({v})", bounds=("a2 >= 0",),
           requires=("coulomb_friction", "stribeck_friction"),
           shape="one-sided sign-like law of the rate"),
    Effect("asymmetric_stiffness", "a spring stiffer on one side than on the other (an "
           "even term |x|: beside a linear spring k x, a stiffness k + a on one side and "
           "k - a on the other); added beside a linear spring", "position", "a1 abs({x})",
           "f1({x})", requires=("linear_stiffness",),
           shape="one-sided linear law"),
    Effect("falling_damping", "damping concentrated near the equilibrium that falls away "
           "with displacement (an eddy-current brake at the centre)", "position_velocity",
           "a1 exp(-a2 {x}^2) {v}", None, (), "dissipative", ("a1 >= 0", "a2 >= 0"),
           shape="damping falling away from zero"),
    Effect("transport_delay", "an input acts late: it travels down a pipe, a belt or a line "
           "(or through a sensor and a controller) before it reaches the state", "input",
           "{i}(t - a1)",
           names=(("level", "transport delay"), ("volume", "transport delay"),
                  ("flow", "transport delay"), ("pressure", "transport delay"),
                  ("temperature", "transport delay"), ("heat", "transport delay"),
                  ("concentration", "transport delay"), ("amount", "transport delay"),
                  ("position", "actuator delay"), ("velocity", "actuator delay"),
                  ("angle", "actuator delay"), ("angular_velocity", "actuator delay"),
                  ("voltage", "signal delay"), ("current", "signal delay"),
                  ("population", "maturation delay")),
           shape="dead time"),
    Effect("input_saturation", "an actuator gives no more than its limit: the input's effect "
           "levels off (a pump at full speed, a valve wide open, a heater at full power, an "
           "amplifier at its rails)", "input", "a1 tanh({i}/a1)", bounds=("a1 >= 0",),
           names=(("level", "pump or valve saturation"), ("volume", "pump or valve saturation"),
                  ("flow", "pump or valve saturation"), ("pressure", "pump or valve saturation"),
                  ("temperature", "heater saturation"), ("heat", "heater saturation"),
                  ("voltage", "amplifier saturation"), ("current", "amplifier saturation")),
           shape="input saturation"),
    Effect("input_dead_zone", "an actuator does nothing until its input passes a threshold "
           "(a valve's dead band, a motor's breakaway voltage)", "input",
           "({i} - a1 sign({i})) (1 + sign(abs({i}) - a1))/2", bounds=("a1 >= 0",),
           names=(("temperature", "heater dead band"), ("heat", "heater dead band"),
                  ("level", "valve dead band"), ("volume", "valve dead band"),
                  ("flow", "valve dead band"), ("pressure", "valve dead band"),
                  ("voltage", "amplifier dead zone"), ("current", "amplifier dead zone")),
           shape="input dead zone"),
    Effect("valve_characteristic", "a valve passes a flow that is a power of its opening, "
           "not proportional to it (above 1 an equal-percentage valve, opening slowly at "
           "first; below 1 a quick-opening one)", "input", "abs({i})^a1 sign({i})",
           bounds=("a1 >= 0",), field="process",
           names=(("level", "valve characteristic"), ("volume", "valve characteristic"),
                  ("flow", "valve characteristic"), ("pressure", "valve characteristic")),
           shape="power law of the input"),
    Effect("offset", "constant force or bias (gravity on a slope, sensor offset)", "none",
           "a1", names=(("level", "constant inflow or leak"),
                        ("volume", "constant inflow or leak"),
                        ("temperature", "constant heat load"),
                        ("concentration", "constant feed or production"),
                        ("voltage", "constant bias current"),
                        ("current", "constant bias voltage"),
                        ("population", "constant immigration or harvest")),
           shape="constant source or bias"),
    Effect("periodic_forcing", "unmeasured harmonic excitation", "time",
           "a1 cos(a2 t) + a3 sin(a2 t)", bounds=("a2 >= 0",),
           names=(("temperature", "daily or periodic heat load"),),
           shape="unmeasured periodic input"),
    Effect("drift", "force or bias changing steadily over the record (a warming sensor, "
           "a creeping load)", "time", "a1 + a2 t", shape="slow drift of a source or bias",
           generalises=("offset",)),
    # a first-order state's own rate of loss: outflow, consumption, decay
    Effect("linear_rate", "loss proportional to what is stored (a linear outflow, a "
           "first-order decay, Newton's cooling)", "state", "a1 {s}", "f1({s})",
           ("f1(0)=0",), "draining",
           names=(("level", "linear outflow"), ("volume", "linear outflow"),
                  ("pressure", "linear (laminar) outflow"), ("temperature", "Newton cooling"),
                  ("concentration", "first-order decay"), ("voltage", "resistive discharge"),
                  ("current", "resistive loss"), ("population", "linear mortality")),
           shape="linear law"),
    Effect("square_root_outflow", "outflow growing with the square root of what is stored "
           "(Torricelli's law of a free orifice)", "state", "a1 sqrt(abs({s}))", "f1({s})",
           ("f1(0)=0", "f1 increasing"), "draining", _POSITIVE, replaces=("linear_rate",),
           field="process",
           names=(("level", "Torricelli outflow"), ("volume", "Torricelli outflow"),
                  ("pressure", "orifice flow")),
           shape="square-root law"),
    Effect("saturating_rate", "rate that grows in proportion at small amounts and levels off "
           "at large ones (Michaelis-Menten, Monod, Langmuir)", "state",
           "a1 {s}/(a2 + abs({s}))",
           "f1({s})", ("f1(0)=0", "f1 increasing"), "draining", ("a1 >= 0", "a2 >= 0"),
           replaces=("linear_rate",), field="kinetics",
           names=(("concentration", "Michaelis-Menten saturation"),
                  ("population", "Monod saturation"), ("amount", "Langmuir saturation")),
           shape="saturating law"),
    Effect("power_law_outflow", "loss growing with a fitted power of what is stored (a weir's "
           "h^1.5, a reaction of fitted order)", "state", "a1 abs({s})^a2", "f1({s})",
           ("f1(0)=0", "f1 increasing"), "draining", ("a1 >= 0", "a2 >= 0"),
           replaces=("linear_rate", "square_root_outflow"),
           names=(("level", "weir outflow (power law)"), ("volume", "weir outflow (power law)"),
                  ("pressure", "power-law orifice flow"),
                  ("concentration", "power-law kinetics (fitted reaction order)")),
           shape="power law"),
    Effect("hill_rate", "rate that is slow at small amounts, rises steeply and levels off "
           "(cooperative binding, a Hill function of order 2)", "state",
           "a1 {s}^2/(a2 + {s}^2)", "f1({s})", ("f1(0)=0",), "draining",
           ("a1 >= 0", "a2 >= 0"), replaces=("linear_rate",), field="kinetics",
           names=(("concentration", "Hill kinetics (cooperative, order 2)"),
                  ("population", "Holling type III predation")),
           shape="sigmoidal (Hill) law"),
    Effect("quadratic_rate", "loss growing with the square of what is stored (a second-order "
           "reaction, crowding)", "state", "a1 {s} abs({s})", "f1({s})", ("f1(0)=0",),
           "draining", _POSITIVE, field="kinetics",
           names=(("concentration", "second-order reaction"),
                  ("population", "logistic crowding")),
           shape="square law"),
    Effect("exponential_rate", "rate growing exponentially with the state (a diode's "
           "current, an Arrhenius-like rate)", "state", "a1 (exp(a2 {s}) - 1)", "f1({s})",
           ("f1(0)=0", "f1 increasing"), "draining", ("a1 >= 0", "a2 >= 0"),
           names=(("voltage", "diode current (Shockley)"),
                  ("temperature", "Arrhenius-like rate")),
           shape="exponential law"),
    Effect("radiation", "loss growing with the fourth power of the temperature "
           "(Stefan-Boltzmann)", "state", "a1 {s}^4", "f1({s})", (), "any", _POSITIVE,
           field="thermal", names=(("temperature", "radiation (Stefan-Boltzmann)"),),
           shape="fourth-power law"),
    # two first-order states acting on each other: {s} and {r}, one of them the
    # equation's own state
    Effect("mass_action", "a rate proportional to the product of two amounts (the law of "
           "mass action: a reaction A + B, a predator's catch, an infection)", "interaction",
           "a1 {s} {r}", field="kinetics",
           names=(("concentration", "mass-action reaction (A + B)"),
                  ("amount", "mass-action reaction (A + B)"),
                  ("population", "predation (mass action, Lotka-Volterra)")),
           shape="product of two states"),
    Effect("saturating_interaction", "a rate on the product of two amounts that levels off as "
           "the first grows (a predator's saturating catch, Holling type II; a reaction "
           "limited by its catalyst)", "interaction", "a1 {s} {r}/(a2 + abs({s}))",
           bounds=("a2 >= 0",), replaces=("mass_action",), field="kinetics",
           generalises=("mass_action",),
           names=(("concentration", "saturating reaction (Michaelis-Menten in a reactant)"),
                  ("amount", "saturating reaction (Michaelis-Menten in a reactant)"),
                  ("population", "Holling type II predation")),
           shape="product saturating in one state"),
    # a path between two first-order states of one quantity: the flow from {s} to {r}
    Effect("linear_link", "a flow between two states in proportion to their difference "
           "(heat conducted through a wall or an open door, water through a pipe, current "
           "through a resistor, transfer between compartments)", "link", "a1 ({s} - {r})",
           bounds=_POSITIVE,
           names=(("temperature", "heat path (conduction)"), ("level", "pipe between tanks"),
                  ("volume", "pipe between tanks"), ("pressure", "laminar flow path"),
                  ("voltage", "resistor between nodes"),
                  ("concentration", "exchange between compartments"),
                  ("amount", "exchange between compartments")),
           shape="linear path between two states"),
    Effect("orifice_link", "a flow between two levels or pressures through an orifice, growing "
           "with the square root of their difference (Torricelli's law between two tanks)",
           "link", "a1 sign({s} - {r}) sqrt(abs({s} - {r}))", bounds=_POSITIVE,
           replaces=("linear_link",), field="process",
           names=(("level", "orifice between tanks (Torricelli)"),
                  ("volume", "orifice between tanks (Torricelli)"),
                  ("pressure", "orifice flow between two pressures")),
           shape="square-root path between two states"),
    Effect("diode_link", "a current from one node to another through a diode, growing "
           "exponentially with their voltage difference one way and nearly nil the other "
           "(Shockley)", "link", "a1 (exp(a2 ({s} - {r})) - 1)", bounds=("a1 >= 0", "a2 >= 0"),
           field="electrical", names=(("voltage", "diode between nodes (Shockley)"),),
           shape="exponential path between two states"),
    Effect("radiation_link", "heat radiated between two surfaces, growing with the "
           "difference of the fourth powers of their temperatures (Stefan-Boltzmann; "
           "temperatures absolute)", "link", "a1 ({s}^4 - {r}^4)", bounds=_POSITIVE,
           replaces=("linear_link",), field="thermal",
           names=(("temperature", "radiation between surfaces (Stefan-Boltzmann)"),),
           shape="fourth-power path between two states"),
):
    register(_effect)
del _effect, _POSITIVE
