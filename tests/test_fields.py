"""Effects named in the words of the user's field: what each state measures decides.

A tank's level is not a mass on a spring: the loop must never call its
outflow "Stribeck friction". These tests walk the whole catalogue over every
quantity a state may measure, and diagnose first-order records of a tank
and of a substrate from the skeleton a scientist of that field writes first.
"""

import warnings

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, Skeleton, diagnose, effects
from sklearn_pycc.diagnostics._candidates import enumerate_candidates, enumerate_moves, extend
from sklearn_pycc.diagnostics._roles import equation_roles
from sklearn_pycc.quantities import MECHANICAL, QUANTITIES, state_quantities

NOT_MECHANICAL = [q for q in QUANTITIES if q not in MECHANICAL]
#: words that only a mechanical effect may be called by
MECHANICAL_WORDS = ("friction", "spring", "stiffness", "drag", "pendulum", "force", "mass",
                    "stribeck", "duffing", "dashpot")


def _mechanical(called: str) -> bool:
    """Whether a name speaks of mechanics (a chemist's "mass action" is no mass)."""
    words = called.lower().replace("mass-action", "").replace("mass action", "")
    return any(word in words for word in MECHANICAL_WORDS)
OUTFLOW = ["x1_dot = a1 u - a2 x1"]
OSCILLATOR = ["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1"]


def _tried(equations, quantities=None, units=None):
    skeleton = Skeleton(equations)
    roles = equation_roles(skeleton, quantities, units)
    found = enumerate_candidates(skeleton, roles, True) + enumerate_moves(skeleton, roles, True)
    return [(c.effect, c.effect.called(c.roles.quantity_of(c.effect.acts_through)))
            for c in found]


@pytest.mark.parametrize("quantity", [None, *NOT_MECHANICAL])
def test_no_mechanical_effect_is_tried_on_a_first_order_state_that_is_not_mechanical(quantity):
    tried = _tried(OUTFLOW, None if quantity is None else {"x1": quantity})
    assert tried
    assert not [e.name for e, _ in tried if e.field == "mechanics"]
    for _, called in tried:
        assert not _mechanical(called), called


def test_a_first_order_state_said_to_be_a_velocity_has_the_mechanical_catalogue():
    tried = {e.name for e, _ in _tried(OUTFLOW, {"x1": "velocity"})}
    assert {"coulomb_friction", "quadratic_drag"} <= tried
    assert not tried & {"square_root_outflow", "saturating_rate", "linear_rate"}
    # and an oscillator by its structure alone
    named = dict((e.name, called) for e, called in _tried(OSCILLATOR))
    assert named["coulomb_friction"] == "coulomb friction"
    assert "square_root_outflow" not in named


def test_every_effect_of_the_catalogue_avoids_mechanical_words_off_mechanics():
    for effect in effects.catalogue():
        for quantity in [None, *NOT_MECHANICAL]:
            called = effect.called(quantity)
            assert called, (effect.name, quantity)
            assert not _mechanical(called), (effect.name, quantity, called)
        if effect.field == "mechanics":
            assert effect.called("velocity") == effect.name.replace("_", " ")


def test_a_circuit_written_as_a_pair_gets_shapes_not_mechanical_names():
    # q_dot = i, i_dot = ...: structurally a position and a velocity, said to be electrical
    tried = _tried(OSCILLATOR, {"x1": "charge", "x2": "current"})
    names = {e.name: called for e, called in tried}
    assert names["cubic_stiffness"] == "cubic law"
    assert names["coulomb_friction"] == "sign-like (tanh) law of the rate"
    assert names["position_dependent_damping"] == "van der Pol damping"


def test_the_field_s_own_laws_enter_only_states_of_that_field_or_of_unknown_quantity():
    assert "square_root_outflow" in {e.name for e, _ in _tried(OUTFLOW, {"x1": "level"})}
    assert "square_root_outflow" in {e.name for e, _ in _tried(OUTFLOW)}
    assert "square_root_outflow" not in {e.name for e, _ in
                                         _tried(OUTFLOW, {"x1": "concentration"})}
    assert "radiation" in {e.name for e, _ in _tried(OUTFLOW, units={"x1": "K"})}
    assert "radiation" not in {e.name for e, _ in _tried(OUTFLOW, {"x1": "voltage"})}
    # the user's linear outflow is read as the field's term, and the square root may take
    # its place
    moves = [(e.name, called) for e, called in _tried(OUTFLOW, {"x1": "level"})]
    assert ("linear_rate", "linear outflow") in moves


def test_what_a_state_measures_comes_from_the_user_the_units_then_the_structure():
    tank = Skeleton(OUTFLOW)
    assert state_quantities(tank) == {"x1": None}
    assert state_quantities(tank, units={"x1": "m"}) == {"x1": "level"}
    assert state_quantities(tank, units={"x1": "mol/l"}) == {"x1": "concentration"}
    assert state_quantities(tank, {"x1": "voltage"}, {"x1": "m"}) == {"x1": "voltage"}
    pair = Skeleton(OSCILLATOR)
    assert state_quantities(pair) == {"x1": "position", "x2": "velocity"}
    assert state_quantities(pair, units={"x1": "rad"})["x1"] == "angle"
    with pytest.raises(ValueError, match="'x9', which is not a state"):
        state_quantities(tank, {"x9": "level"})
    with pytest.raises(ValueError, match="'height', which is none of the known quantities"):
        state_quantities(tank, {"x1": "height"})
    with pytest.raises(TypeError, match="quantities must be a dict"):
        state_quantities(tank, ["level"])


def test_an_effect_declares_a_field_that_agrees_with_where_it_acts():
    assert effects.Effect("mine", "a magnet", "position", "a1 {x}^5").field == "mechanics"
    assert effects.Effect("mine", "a source", "none", "a1").field == "any"
    with pytest.raises(ValueError, match="only a mechanical state has"):
        effects.Effect("mine", "a law", "velocity", "a1 {v}", field="process")
    with pytest.raises(ValueError, match="belongs to a field other than mechanics"):
        effects.Effect("mine", "a law", "state", "a1 {s}", field="mechanics")
    with pytest.raises(ValueError, match="field must be one of"):
        effects.Effect("mine", "a law", "state", "a1 {s}", field="astrology")
    with pytest.raises(ValueError, match=r"\(quantity, name\) pairs"):
        effects.Effect("mine", "a law", "state", "a1 {s}", names=(("level",),))
    with pytest.raises(ValueError, match="'height', which is none of the known quantities"):
        effects.Effect("mine", "a law", "state", "a1 {s}", names=(("height", "a weir"),))
    ok, why = effects.get("square_root_outflow").is_plausible(-np.ones(5), position=np.ones(5))
    assert not ok and "take away what is stored" in why and "state" in why


def _first_order_record(truth, params, *, seed, dt, hold, low, high, y0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 1200 * dt, dt)
    u = np.repeat(rng.uniform(low, high, size=len(t) // hold + 1), hold)[:len(t)]
    x = Skeleton([truth]).simulate(t, [y0], params=params, inputs={"u": u})["x1"].to_numpy()
    return pd.DataFrame({"t": t, "x1": x + 0.01 * np.std(x) * rng.standard_normal(len(t)),
                         "u": u})


@pytest.fixture(scope="module")
def tank():
    X = _first_order_record("x1_dot = a1 u - a2 sqrt(x1)", {"a1": 0.5, "a2": 0.4}, seed=0,
                            dt=0.5, hold=80, low=0.2, high=1.0, y0=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return X, PolyCCRegressor(equations=OUTFLOW).fit(X)


@pytest.mark.parametrize(("settings", "called"), [
    ({"quantities": {"x1": "level"}}, "Torricelli outflow"),
    ({"units": {"x1": "m"}}, "Torricelli outflow"),
    ({"quantities": {"x1": "pressure"}}, "orifice flow"),
    ({}, "square-root law"),
])
def test_a_tank_draining_through_an_orifice_is_named_as_its_field_says(tank, settings, called):
    X, model = tank
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = diagnose(model, X, n_bootstrap=0, **settings)
    assert report.best.effect == "square_root_outflow"
    assert report.best.called == called
    assert f"Missing effect: {called} (square_root_outflow)" in report.summary()
    assert "friction" not in report.summary()


@pytest.mark.parametrize(("truth", "start", "quantity", "record", "named"), [
    # a balance: the feed and the consumption are both far larger than the derivative
    (("x1_dot = u - a1 x1/(a2 + x1)", {"a1": 2.0, "a2": 1.0}), "x1_dot = u - a1 x1",
     "concentration", {"dt": 0.25, "low": 0.1, "high": 1.6, "y0": 0.5},
     ("saturating_rate", "Michaelis-Menten saturation")),
    # growth and crowding both far larger than the derivative near the carrying capacity
    (("x1_dot = a1 x1 - a2 x1^2 - a3 u", {"a1": 0.8, "a2": 0.4, "a3": 0.5}),
     "x1_dot = a1 x1 - a3 u", "population", {"dt": 0.1, "low": 0.0, "high": 0.4, "y0": 1.0},
     ("quadratic_rate", "logistic crowding")),
], ids=["substrate", "population"])
def test_a_balance_of_large_rates_is_named_as_its_field_says(truth, start, quantity, record,
                                                             named):
    X = _first_order_record(*truth, seed=0, hold=120, **record)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=[start]).fit(X)
        report = diagnose(model, X, n_bootstrap=0, quantities={"x1": quantity})
    assert (report.best.effect, report.best.called) == named
    assert report.best.held_out.confirmed


def test_the_choice_s_stability_and_figures_speak_the_field_s_words(tank):
    from sklearn_pycc.plotting import _move_label

    X, model = tank
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = diagnose(model, X, n_bootstrap=20, quantities={"x1": "level"})
    # added beside the linear outflow or in its place, the resamples' winner is the same law
    won = int(report.summary().split("square_root_outflow wins in ")[1].split(" of ")[0])
    assert won >= 15
    assert _move_label(report.best) in ("+Torricelli outflow", "Torricelli outflow for a2*x1")
    title = report.plot()["residual"]._suptitle.get_text()
    assert "Torricelli outflow" in title


def test_the_estimator_says_what_its_states_measure(tank):
    X, _ = tank
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OUTFLOW, quantities={"x1": "level"}).fit(X)
        report = diagnose(model, X, n_bootstrap=0)
        assert report.best.called == "Torricelli outflow"
        # the diagnosis's own argument speaks over the model's
        assert diagnose(model, X, n_bootstrap=0,
                        quantities={"x1": "pressure"}).best.called == "orifice flow"
    with pytest.raises(ValueError, match="'x9', which is not a state"):
        PolyCCRegressor(equations=OUTFLOW, quantities={"x9": "level"}).fit(X)
    with pytest.raises(ValueError, match="'height', which is none of the known quantities"):
        PolyCCRegressor(equations=OUTFLOW, quantities={"x1": "height"}).fit(X)


def test_an_effect_says_which_quantities_it_applies_to():
    assert set(effects.get("coulomb_friction").quantities) == MECHANICAL
    torricelli = effects.get("square_root_outflow").quantities
    assert "level" in torricelli and "concentration" not in torricelli
    assert not set(effects.get("linear_rate").quantities) & MECHANICAL
    assert set(effects.get("offset").quantities) == set(QUANTITIES)


# -- two first-order states acting on each other -------------------------------------------
def _interactions(equations, quantity="population"):
    skeleton = Skeleton(equations)
    roles = equation_roles(skeleton, dict.fromkeys(skeleton.states, quantity))
    found = enumerate_candidates(skeleton, roles, True) + enumerate_moves(skeleton, roles, True)
    return [c for c in found if c.effect.acts_through == "interaction"]


def test_two_species_are_tried_reacting_in_one_equation_or_in_both():
    tried = {(c.effect.name, c.move, tuple(c.additions))
             for c in _interactions(["x1_dot = u - a1 x1", "x2_dot = a2 - a1 x2"],
                                    "concentration")}
    product = "a1 x1 x2"
    assert ("mass_action", "add", ((0, product),)) in tried
    assert ("mass_action", "add", ((0, product), (1, product))) in tried
    # the saturation levels off in either species
    for s, r in (("x1", "x2"), ("x2", "x1")):
        term = f"a1 {s} {r}/(a2 + abs({s}))"
        assert ("saturating_interaction", "add", ((0, term), (1, term))) in tried
    # a product is tried once however its states are ordered
    assert sum(c[0] == "mass_action" and len(c[2]) == 2 for c in tried) == 1


def test_a_predators_catch_written_in_both_equations_is_replaced_in_both():
    moves = [c for c in _interactions(["x1_dot = a1 x1 - a2 x1 x2", "x2_dot = a3 x1 x2 - a4 x2"])
             if c.move == "replace" and len(c.removals) == 2]
    assert moves and all(c.effect.name == "saturating_interaction" for c in moves)
    prey_saturating = next(c for c in moves if c.variable == "x1 x2")
    assert prey_saturating.removals == [(0, "a2*x1*x2"), (1, "a3*x1*x2")]
    assert prey_saturating.removed_params == ["a2", "a3"]
    assert prey_saturating.effect.called("population") == "Holling type II predation"


def test_no_interaction_is_tried_on_mechanical_states():
    assert _interactions(["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1", "x3_dot = - a3 x3"],
                         "position") == []
    # a first-order state next to a mechanical pair has no partner there
    skeleton = Skeleton(["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1", "x3_dot = - a3 x3"])
    roles = equation_roles(skeleton, {"x3": "temperature"})
    assert [r.partners for r in roles] == [(), ()]


def test_a_storage_s_outflow_law_replaces_its_own_term_and_the_next_storage_s_inflow():
    skeleton = Skeleton(["x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 x2"], ["a2 >= 0"])
    roles = equation_roles(skeleton, {"x1": "level", "x2": "level"})
    joint = [c for c in enumerate_moves(skeleton, roles, True)
             if c.effect.name == "square_root_outflow" and len(c.additions) == 2]
    assert [c.removals for c in joint] == [[(0, "a2*x1"), (1, "a2*x1")]]
    extend(skeleton, joint[0])
    # what the upper tank loses the lower one gains, each with a coefficient of its own
    assert joint[0].extended.equations == ("x1_dot = a1*u - a4*sqrt(abs(x1))",
                                           "x2_dot = -a3*x2 + a5*sqrt(abs(x1))")
    assert joint[0].extended.bounds["a5"] == (0.0, np.inf)


def test_a_storage_s_inflow_is_read_by_the_law_of_the_storage_it_comes_from():
    skeleton = Skeleton(["x1_dot = a1 u - a4 sqrt(abs(x1))", "x2_dot = a2 x1 - a3 x2"])
    roles = equation_roles(skeleton, {"x1": "level", "x2": "level"})
    inflows = {c.effect.name: c for c in enumerate_moves(skeleton, roles, True)
               if c.roles.index == 1 and c.variable == "x1" and c.move == "replace"}
    assert "square_root_outflow" in inflows and "saturating_rate" in inflows
    torricelli = inflows["square_root_outflow"]
    extend(skeleton, torricelli)
    assert torricelli.extended.equations[1] == "x2_dot = -a3*x2 + a5*sqrt(abs(x1))"
    assert torricelli.effect.called("level") == "Torricelli outflow"


def test_storages_built_alike_are_tried_draining_alike_down_the_chain():
    skeleton = Skeleton(["x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 x2",
                         "x3_dot = a3 x2 - a4 x3"])
    roles = equation_roles(skeleton, dict.fromkeys(skeleton.states, "level"))
    chains = {len(c.additions): c for c in enumerate_moves(skeleton, roles, True)
              if c.effect.name == "square_root_outflow" and c.roles.index == 0}
    # the upper tank alone, with the next one's inflow, with its outflow, ... to the last
    assert sorted(chains) == [1, 2, 3, 4, 5]
    whole = chains[5]
    assert whole.removals == [(0, "a2*x1"), (1, "a2*x1"), (1, "a3*x2"), (2, "a3*x2"),
                              (2, "a4*x3")]
    assert whole.removed_params == ["a2", "a3", "a4"]
    extend(skeleton, whole)
    assert whole.extended.equations == (
        "x1_dot = a1*u - a5*sqrt(abs(x1))",
        "x2_dot = a6*sqrt(abs(x1)) - a7*sqrt(abs(x2))",
        "x3_dot = a8*sqrt(abs(x2)) - a9*sqrt(abs(x3))")
    # a chain whose next storage drains by another law stops at its inflow
    mixed = Skeleton(["x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 sqrt(abs(x2))"])
    roles = equation_roles(mixed, dict.fromkeys(mixed.states, "level"))
    assert max(len(c.additions) for c in enumerate_moves(mixed, roles, True)
               if c.effect.name == "square_root_outflow" and c.roles.index == 0) == 2


@pytest.fixture(scope="module")
def cascade():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 600.0, 0.5)
    u = np.repeat(rng.uniform(0.2, 1.0, size=len(t) // 80 + 1), 80)[:len(t)]
    truth = ["x1_dot = a1 u - a2 sqrt(abs(x1))", "x2_dot = a2 sqrt(abs(x1)) - a3 sqrt(abs(x2))"]
    states = Skeleton(truth).simulate(t, [1.0, 1.0], params={"a1": 0.5, "a2": 0.4, "a3": 0.3},
                                      inputs={"u": u})
    X = pd.DataFrame({"t": t, "u": u})
    for s in ("x1", "x2"):
        x = states[s].to_numpy()
        X[s] = x + 0.01 * np.std(x) * rng.standard_normal(len(t))
    return X


def test_a_cascade_of_tanks_is_told_both_drain_by_torricelli_s_law(cascade):
    start = ["x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 x2"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=start, quantities={"x1": "level", "x2": "level"})
        report = diagnose(model.fit(cascade), cascade)
    best = report.best
    assert best.effect == "square_root_outflow" and best.called == "Torricelli outflow"
    assert best.replaced_in == {"x1_dot": ("a2*x1",), "x2_dot": ("a2*x1", "a3*x2")}
    assert best.action() == (
        "replace 'a2*x1' in x1_dot by '- a4*sqrt(abs(x1))', and 'a2*x1' and 'a3*x2' in x2_dot "
        "by '+ a5*sqrt(abs(x1)) - a6*sqrt(abs(x2))'")
    assert best.equations.equations[1] == "x2_dot = a5*sqrt(abs(x1)) - a6*sqrt(abs(x2))"
    assert best.held_out.confirmed
    assert "in place of 'a2*x1' in x1_dot and 'a2*x1 + a3*x2' in x2_dot" in report.summary()
    # the residual figure says what the move takes out of each equation
    import matplotlib.pyplot as plt

    figure = report.plot()["residual"]
    labels = [t.get_text() for ax in figure.axes if ax.get_legend()
              for t in ax.get_legend().get_texts()]
    plt.close("all")
    assert "- a4*sqrt(abs(x1)) in place of a2*x1, as refitted" in labels
    assert "change the suggestion makes here, as refitted" in labels
