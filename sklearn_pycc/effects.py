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
    a difference of positions (the stretch of a coupling between masses).

Time is ``t`` itself. Users add their own effects with :func:`register`.

Examples
--------
>>> from sklearn_pycc import effects
>>> effects.get("coulomb_friction").term_for(v="x2")
'a1 tanh(a2 x2)'
>>> "quadratic_drag" in effects.names()
True
"""

from __future__ import annotations

import string
from dataclasses import dataclass

import numpy as np

from .exceptions import SkeletonError
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
    "time": (),
    "none": (),
}

#: plausibility rules
PLAUSIBILITY: dict[str, str] = {
    "dissipative": "removes energy: the subtracted term has the sign of the velocity on "
                   "average (sum of term * velocity > 0)",
    "restoring": "pulls back toward equilibrium: the subtracted term has the sign of the "
                 "displacement on average (sum of term * position > 0)",
    "any": "no sign requirement",
}

_SAMPLE = {"x": "x1", "v": "x2", "u": "x1 - x3"}


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

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"an effect name must be an identifier, got {self.name!r}")
        if self.acts_through not in ACTS_THROUGH:
            raise ValueError(f"effect {self.name!r}: acts_through must be one of "
                             f"{sorted(ACTS_THROUGH)}, got {self.acts_through!r}")
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
            The position of the same equation (needed by ``"restoring"``).

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
        contribution = np.asarray(contribution, dtype=float)
        mean = float(np.mean(contribution * np.asarray(reference, dtype=float)))
        if mean > 0:
            return True, ""
        if not np.any(contribution):
            return False, (f"the fitted {self.name} term vanishes: the data ask for the sign "
                           "its physics excludes (it is held at its bound)")
        return False, (f"{self.name} must {label}, but the fitted term {failure} "
                       f"(mean term * {against} = {mean:.3g} <= 0)")


#: rule -> (variable the term is multiplied by, what it must do, what it did instead)
_RULES = {
    "dissipative": ("velocity", "remove energy", "feeds energy in"),
    "restoring": ("position", "pull back toward equilibrium", "pushes away from it"),
}


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
           "velocity", "a1 {v}", "f1({v})", ("f1 odd",), "dissipative", _POSITIVE),
    Effect("coulomb_friction", "dry friction of constant level opposing the sliding "
           "direction, smoothed at zero speed", "velocity", "a1 tanh(a2 {v})", "f1({v})",
           ("f1 odd",), "dissipative", ("a1 >= 0", "a2 >= 0")),
    Effect("stribeck_friction", "dry friction that is higher at breakaway and falls with "
           "speed", "velocity", "(a1 + a2 exp(-({v}/a3)^2)) tanh(a4 {v})", "f1({v})",
           ("f1 odd",), "dissipative", ("a1 >= 0", "a2 >= 0", "a4 >= 0"),
           replaces=("coulomb_friction",)),
    Effect("quadratic_drag", "drag growing with the square of speed (turbulent flow)",
           "velocity", "a1 {v} abs({v})", "f1({v})", ("f1 odd",), "dissipative", _POSITIVE,
           replaces=("viscous_damping",)),
    Effect("linear_stiffness", "spring force proportional to displacement", "position",
           "a1 {x}", "f1({x})", ("f1(0)=0",)),
    Effect("cubic_stiffness", "hardening or softening spring (Duffing term)", "position",
           "a1 {x}^3", "f1({x})", ("f1 odd",)),
    Effect("saturation", "restoring force that levels off at large displacement", "position",
           "a1 tanh(a2 {x})", "f1({x})", ("f1 odd", "f1 increasing"), "restoring",
           ("a1 >= 0", "a2 >= 0"), replaces=("linear_stiffness",)),
    Effect("dead_zone", "no force within a clearance, linear beyond it (backlash)",
           "position", "a1 ({x} - a2 sign({x})) (1 + sign(abs({x}) - a2))/2", "f1({x})",
           ("f1 odd", "f1 increasing"), "restoring", ("a1 >= 0", "a2 >= 0"),
           replaces=("linear_stiffness",)),
    Effect("pendulum", "gravity torque on a swinging arm, sine of the angle", "position",
           "a1 sin({x})", "f1({x})", ("f1 odd",), "restoring", _POSITIVE,
           replaces=("linear_stiffness",)),
    Effect("position_dependent_damping", "damping that grows with displacement "
           "(van der Pol, Lienard)", "position_velocity", "a1 {x}^2 {v}", None, (),
           "dissipative", _POSITIVE),
    Effect("linear_coupling", "linear spring between two masses", "difference", "a1 {u}",
           "f1({u})", ("f1(0)=0",)),
    Effect("coupling", "nonlinear (cubic) spring between two masses", "difference",
           "a1 {u}^3", "f1({u})", ("f1 odd",)),
    Effect("asymmetric_viscous_damping", "viscous friction of a different coefficient in "
           "each direction of motion (a worn guide, a seal); added beside viscous damping",
           "velocity", "a1 abs({v})", "f1({v})", requires=("viscous_damping",)),
    Effect("asymmetric_coulomb_friction", "dry friction of a different level in each "
           "direction of motion; added beside Coulomb friction", "velocity",
           "a1 tanh(a2 {v})^2", "f1({v})", bounds=("a2 >= 0",),
           requires=("coulomb_friction", "stribeck_friction")),
    Effect("asymmetric_stiffness", "a spring stiffer on one side than on the other (an "
           "even term x|x|); added beside a linear spring", "position", "a1 {x} abs({x})",
           "f1({x})", requires=("linear_stiffness",)),
    Effect("falling_damping", "damping concentrated near the equilibrium that falls away "
           "with displacement (an eddy-current brake at the centre)", "position_velocity",
           "a1 exp(-a2 {x}^2) {v}", None, (), "dissipative", ("a1 >= 0", "a2 >= 0")),
    Effect("offset", "constant force or bias (gravity on a slope, sensor offset)", "none",
           "a1"),
    Effect("periodic_forcing", "unmeasured harmonic excitation", "time",
           "a1 cos(a2 t) + a3 sin(a2 t)", bounds=("a2 >= 0",)),
    Effect("drift", "force or bias changing steadily over the record (a warming sensor, "
           "a creeping load)", "time", "a1 + a2 t"),
):
    register(_effect)
del _effect, _POSITIVE
