"""The catalogue of physical effects and adding their terms to a skeleton."""

import numpy as np
import pytest
from conftest import split

from sklearn_pycc import PolyCCRegressor, Skeleton, effects
from sklearn_pycc.diagnostics.effects import ACTS_THROUGH, Effect

DESIGN_NAMES = [
    "viscous_damping", "coulomb_friction", "stribeck_friction", "quadratic_drag",
    "linear_stiffness", "cubic_stiffness", "saturation", "dead_zone", "pendulum",
    "position_dependent_damping", "coupling", "offset", "periodic_forcing",
]
LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
VARIABLES = {"velocity": {"v": "x2"}, "position": {"x": "x1"},
             "position_velocity": {"x": "x1", "v": "x2"}, "difference": {"u": "x1 - x3"},
             "time": {}, "none": {}}


def test_catalogue_has_every_effect_of_the_design():
    assert set(DESIGN_NAMES) <= set(effects.names())
    for effect in effects.catalogue():
        assert effect.description and effect.acts_through in ACTS_THROUGH


@pytest.mark.parametrize("name", DESIGN_NAMES)
def test_every_term_extends_a_skeleton_with_fresh_parameters(name):
    effect = effects.get(name)
    variables = VARIABLES[effect.acts_through]
    extended = Skeleton(LINEAR).add_term("x2", effect.term_for(**variables))
    new = [a for a in extended.params if a not in ("a1", "a2")]
    assert new and new[0] == "a3"
    if effect.curve is not None:
        curve = Skeleton(LINEAR).add_term("x2", effect.curve_for(**variables),
                                          constraints=list(effect.curve_constraints))
        assert curve.functions == ["f1"]


def test_difference_is_parenthesised():
    term = effects.get("coupling").term_for(u="x1 - x2")
    assert term == "a1 (x1 - x2)^3"


def test_added_coulomb_term_is_fitted_on_stick_slip(stick_slip):
    frame, truth = stick_slip
    X, y = split(frame)
    base = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"])
    extended = base.add_term("x2", effects.get("coulomb_friction").term_for(v="x2"))
    before = PolyCCRegressor(equations=base).fit(X, y)
    after = PolyCCRegressor(equations=extended).fit(X, y)
    assert after.params_["a4"] == pytest.approx(truth.params["a2"], rel=0.05)
    assert after.params_["a5"] == pytest.approx(truth.params["a3"], rel=0.05)
    assert after.score(X, y) > before.score(X, y)
    ok, _ = effects.get("coulomb_friction").is_plausible(
        after.params_["a4"] * np.tanh(after.params_["a5"] * frame["x2"]), frame["x2"])
    assert ok


def test_dissipative_rule_rejects_a_term_that_feeds_energy():
    v = np.linspace(-1, 1, 101)
    drag = effects.get("quadratic_drag")
    assert drag.is_plausible(0.3 * v * np.abs(v), v) == (True, "")
    ok, why = drag.is_plausible(-0.3 * v * np.abs(v), v)
    assert not ok and "remove energy" in why
    assert effects.get("cubic_stiffness").is_plausible(-v**3) == (True, "")
    with pytest.raises(ValueError, match="give the velocity"):
        drag.is_plausible(v)


def test_register_and_unregister_a_user_effect():
    mine = Effect("magnetic_spring", "force of a permanent magnet", "position",
                  "a1 {x} / (1 + a2 {x}^2)", "f1({x})", ("f1 odd",))
    try:
        effects.register(mine)
        assert effects.get("magnetic_spring") is mine
        with pytest.raises(ValueError, match="already registered"):
            effects.register(mine)
        effects.register(mine, replace=True)
    finally:
        effects.unregister("magnetic_spring")
    assert "magnetic_spring" not in effects.names()
    with pytest.raises(KeyError, match="no effect named 'magnetic_spring'"):
        effects.get("magnetic_spring")


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"term": "a1 {v}"}, r"uses \{v\}"),
    ({"term": "a1 sign({x}"}, "not valid skeleton text"),
    ({"acts_through": "force"}, "acts_through must be one of"),
    ({"plausibility": "conservative"}, "plausibility must be one of"),
    ({"name": "two words"}, "must be an identifier"),
])
def test_bad_effects_are_rejected(kwargs, match):
    spec = {"name": "bad", "description": "d", "acts_through": "position", "term": "a1 {x}",
            **kwargs}
    with pytest.raises(ValueError, match=match):
        Effect(**spec)


def test_term_for_names_missing_and_extra_variables():
    friction = effects.get("coulomb_friction")
    with pytest.raises(ValueError, match=r"give v=\.\.\."):
        friction.term_for()
    with pytest.raises(ValueError, match=r"does not use x=\.\.\."):
        friction.term_for(v="x2", x="x1")
