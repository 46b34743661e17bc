"""More moves than "add": a term replaced by a better law of the same role, a superfluous term
removed, a self-excited oscillation explained by its state, asymmetric effects.

Records are position only with default settings, as a lab would log them.
"""

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, Skeleton, datasets, diagnose, effects
from sklearn_pycc.diagnostics._data import read_measurements
from sklearn_pycc.diagnostics._physics import implausible_terms

PENDULUM_BASE = ["x1_dot = x2", "x2_dot = F - a1 x2 - a2 x1"]


def pendulum(seed=0, release=2.0, omega=1.3, n=3000, end=60.0, snr=40.0):
    """A forced pendulum released from a large angle, its angle measured with noise."""
    rng = np.random.default_rng(seed)

    def force(t):
        return 0.5 * np.cos(omega * t)

    t = np.linspace(0.0, end, n)
    solution = solve_ivp(lambda s, y: [y[1], force(s) - 0.3 * y[1] - 9.0 * np.sin(y[0])],
                         (0.0, end), [release, 0.0], t_eval=t, rtol=1e-10, atol=1e-10)
    angle = solution.y[0]
    angle = angle + rng.normal(0.0, np.sqrt(np.mean(angle**2)) * 10 ** (-snr / 20), n)
    return pd.DataFrame({"t": t, "x1": angle, "F": force(t)})


# -- the skeleton's own operation -------------------------------------------------------
def test_remove_term_takes_out_one_term_and_the_constraints_only_it_used():
    sk = Skeleton(["x1_dot = x2", "x2_dot = F - a1 x2 - a3 sin(x1) - f1(x2)"],
                  ["a3 >= 0", "f1 odd"])
    reduced = sk.remove_term("x2_dot", "sin(x1) a3")
    assert reduced.equations[1] == "x2_dot = F - a1*x2 - f1(x2)"
    assert [str(c) for c in reduced.constraints] == ["f1 odd"]
    assert sk.equations[1] == "x2_dot = F - a1 x2 - a3 sin(x1) - f1(x2)"  # unchanged
    assert Skeleton(["x1_dot = -a1 x1 + a2"]).remove_term(0, "a1 x1").equations == \
        ("x1_dot = a2",)
    assert Skeleton(["x1_dot = -a1 x1"]).remove_term(0, "a1 x1").equations == ("x1_dot = 0",)
    with pytest.raises(ValueError, match=r"has no term 'a2 x2'.*'F', 'a1\*x2'"):
        sk.remove_term(1, "a2 x2")


# -- replace ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pendulum_loop():
    loop = HypothesisLoop(PolyCCRegressor(equations=PENDULUM_BASE), pendulum())
    return loop.run(max_rounds=4)


@pytest.mark.slow
def test_a_pendulum_is_named_by_replacing_the_linear_spring(pendulum_loop):
    first = pendulum_loop.rounds[0].added
    assert (first.effect, first.move, first.replaces) == ("pendulum", "replace", ("a2*x1",))
    assert "a2" not in first.equations.params  # the spring's coefficient went with it
    assert str(first).startswith("replace 'a2*x1' in x2_dot by '- a3*sin(x1)'")
    ranking = pendulum_loop.rounds[0].diagnosis.ranking
    assert ranking.loc[ranking.index[0], "move"] == "replace"
    assert set(ranking["move"]) <= {"add", "replace", "remove"}
    assert "Better physics: pendulum" in pendulum_loop.rounds[0].diagnosis.summary()
    # the loop then stops with the true skeleton, its numbers within a percent
    assert pendulum_loop.stopped and len(pendulum_loop.rounds) == 2
    final = pendulum_loop.model
    assert final.skeleton_.equations[1] == "x2_dot = F - a1*x2 - a3*sin(x1)"
    assert abs(final.params_["a3"] / 9.0 - 1) < 0.01
    assert abs(final.params_["a1"] / 0.3 - 1) < 0.03


@pytest.mark.slow
def test_the_replaced_pendulum_simulates_a_fresh_record_as_the_true_skeleton_does(
        pendulum_loop):
    fresh = pendulum(seed=7, release=1.5, omega=2.1)
    truth = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F - a1 x2 - a2 sin(x1)"])
    truth.fit(pendulum())
    t = fresh["t"].to_numpy()

    def error(model):
        simulated = model.simulate(t, [1.5, 0.0], inputs={"F": fresh["F"].to_numpy()})
        return float(np.sqrt(np.mean((simulated["x1"].to_numpy() - fresh["x1"]) ** 2)))

    assert error(pendulum_loop.model) <= 2 * error(truth)
    assert error(pendulum_loop.rounds[0].model) > 10 * error(truth)


# -- remove -------------------------------------------------------------------------------
@pytest.mark.slow
def test_a_spurious_term_is_removed_and_a_real_one_is_kept():
    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], noise=40.0,
                                            noise_columns=["x1"], random_state=1,
                                            return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    spurious = [truth.parametric_equations[0], truth.parametric_equations[1] + " - a4 x1^2 x2"]
    report = diagnose(PolyCCRegressor(equations=spurious).fit(X), X)
    best = report.best
    assert (best.move, best.effect, best.replaces) == (
        "remove", "position_dependent_damping", ("a4*x1^2*x2",))
    assert "a4" not in best.equations.params and "a3" in best.equations.params
    assert best.held_out.confirmed and best.held_out.change() <= 0
    assert "Superfluous term: 'a4*x1^2*x2'" in report.summary()
    # the true skeleton: nothing to add, swap or take out
    complete = diagnose(PolyCCRegressor(equations=truth.parametric_equations).fit(X), X)
    assert complete.best is None
    removals = complete.ranking[complete.ranking.move == "remove"]
    assert set(removals.effect) >= {"viscous_damping", "linear_stiffness", "cubic_stiffness"}


def test_a_loop_does_not_go_round_in_circles():
    from sklearn_pycc.diagnostics.loop import _structure

    a = Skeleton(["x1_dot = x2", "x2_dot = F - a1 x2 - a2 x1"])
    b = Skeleton(["x1_dot = x2", "x2_dot = F - a1 x2 - a7 x1"])
    c = Skeleton(["x1_dot = x2", "x2_dot = F - a1 x2 + a2 x1"])
    assert _structure(a) == _structure(b) != _structure(c)
    # a term's factors in another order are the same term; another power is not
    d = Skeleton(["x1_dot = x2", "x2_dot = F - x1 a5 - x2 a1"])
    e = Skeleton(["x1_dot = x2", "x2_dot = F - a1 x2 - a2 x1^3"])
    assert _structure(d) == _structure(a) != _structure(e)


# -- a limit cycle before an unmeasured drive -------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("snr", [40.0, 30.0])
def test_a_self_excited_oscillator_is_named_by_its_state_not_a_drive(snr):
    frame = datasets.make_van_der_pol(n_samples=3000, noise=snr, noise_columns=["x1"],
                                      random_state=0, mu=0.8)
    X = frame[["t", "x1", "F_ext"]]
    loop = HypothesisLoop(PolyCCRegressor(
        equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]), X).run(max_rounds=4)
    added = [r.added.effect for r in loop.rounds if r.added is not None]
    assert added == ["position_dependent_damping"]
    assert loop.stopped
    params = loop.model.params_
    # x'' = F + 0.8 (1 - x^2) x' - x: negative linear damping, limited by x^2 x'
    assert abs(params["a1"] / -0.8 - 1) < 0.05 and abs(params["a3"] / 0.8 - 1) < 0.05
    assert abs(params["a2"] - 1) < 0.03
    assert loop.rounds[-1].diagnosis.implausible == []


def test_negative_damping_is_plausible_only_when_the_amplitude_limits_it():
    frame = datasets.make_van_der_pol(n_samples=2000, mu=0.8)
    X, y = frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]
    limited = PolyCCRegressor(equations=[
        "x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^2 x2"]).fit(X, y)
    assert limited.params_["a1"] < 0 < limited.params_["a3"]
    data = read_measurements(limited.skeleton_, X, y, "auto", True)
    assert implausible_terms(limited, data) == []
    # the same negative damping with no amplitude to limit it feeds energy in
    linear = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"],
                             constraints=["a1 <= -0.5"]).fit(X, y)
    found = implausible_terms(linear, read_measurements(linear.skeleton_, X, y, "auto", True))
    assert [item.role for item in found] == ["dissipation", "dissipation"]
    # and an x^2 x' term that feeds energy in at large amplitude is no limit
    runaway = limited.set_params(constraints=["0 <= a1 <= 0.1", "a3 <= -0.5"]).fit(X, y)
    found = implausible_terms(runaway, read_measurements(runaway.skeleton_, X, y, "auto", True))
    assert any("large amplitude" in item.reason for item in found)


# -- asymmetric effects -----------------------------------------------------------------
def test_asymmetric_effects_are_tried_only_beside_their_symmetric_partner():
    for name, partner in [("asymmetric_viscous_damping", "viscous_damping"),
                          ("asymmetric_coulomb_friction", "coulomb_friction"),
                          ("asymmetric_stiffness", "linear_stiffness")]:
        assert partner in effects.get(name).requires
    frame = datasets.make_oscillator(hidden=[], random_state=0)
    X, y = frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]
    without = diagnose(PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2"])
                       .fit(X, y), X, y, held_out=False, n_bootstrap=0)
    tried = set(without.ranking.effect)
    assert "asymmetric_viscous_damping" in tried and "asymmetric_stiffness" not in tried


@pytest.mark.parametrize("name", ["asymmetric_viscous_damping", "asymmetric_coulomb_friction",
                                  "asymmetric_stiffness"])
def test_an_asymmetric_variant_is_even_so_its_partner_differs_on_each_side(name):
    # beside an odd law (k x), an even term (a |x|) makes it k + a on one side and k - a on
    # the other; an odd one (x |x|) would change both sides alike
    effect = effects.get(name)
    variable = {"velocity": "v", "position": "x"}[effect.acts_through]
    term = Skeleton([f"x1_dot = {effect.term_for(**{variable: 'x1'})}"])
    z = np.linspace(0.1, 2.0, 7)
    system = term.compile(params=dict.fromkeys(term.params, 1.5))
    rates = system.evaluate({"x1": np.concatenate([z, -z])}, 14)[:, 0]
    assert np.allclose(rates[:7], rates[7:]) and not np.allclose(rates, 0.0)


@pytest.mark.slow
def test_asymmetric_viscous_friction_is_named_on_a_positioning_axis():
    frame = datasets.make_positioning_axis(random_state=0, viscous=(10.0, 6.0))
    loop = HypothesisLoop(PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = a1 F - a2 x2"]),
                          frame).run(max_rounds=6)
    added = [r.added.effect for r in loop.rounds if r.added is not None]
    assert "asymmetric_viscous_damping" in added and loop.stopped
    params = loop.model.params_
    asym = next(a for a in params if f"{a}*abs(x2)" in loop.model.skeleton_.equations[1])
    mass = 1 / params["a1"]
    forward, backward = mass * (params["a2"] + params[asym]), mass * (params["a2"] - params[asym])
    assert abs(forward / 10.0 - 1) < 0.03 and abs(backward / 6.0 - 1) < 0.03


def test_the_positioning_axis_takes_a_viscous_coefficient_per_direction():
    _, truth = datasets.make_positioning_axis(n_samples=2000, t_span=(0, 1.999),
                                              viscous=(10.0, 6.0), random_state=0,
                                              return_truth=True)
    assert truth.params["a6"] == pytest.approx(1.0) and truth.params["a2"] == pytest.approx(4.0)
    assert truth.hidden[-1] == "asymmetric_viscous_damping"
    with pytest.raises(ValueError, match="viscous must be a number or a pair"):
        datasets.make_positioning_axis(viscous=(1.0, 2.0, 3.0))


# -- candidates are independent fits: n_jobs changes nothing but the time ----------------
@pytest.mark.slow
def test_diagnose_and_compare_skeletons_give_the_same_answer_for_any_n_jobs():
    from sklearn_pycc import compare_skeletons

    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], noise=40.0,
                                            noise_columns=["x1"], random_state=0,
                                            return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    model = PolyCCRegressor(equations=truth.base_equations).fit(X)
    one = diagnose(model, X, n_bootstrap=0)
    two = diagnose(model, X, n_bootstrap=0, n_jobs=2)
    assert str(one.best) == str(two.best) and one.best.move == "add"
    pd.testing.assert_frame_equal(one.ranking, two.ranking)
    assert one.best.held_out.after == two.best.held_out.after
    skeletons = {"linear": truth.base_equations, "true": truth.parametric_equations,
                 "pendulum": ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 sin(x1)"]}
    tables = [compare_skeletons(skeletons, X, n_jobs=n).drop(columns="fit_time")
              for n in (None, 2)]
    pd.testing.assert_frame_equal(*tables)
    assert tables[0].attrs == tables[1].attrs
    with pytest.raises(ValueError, match="n_jobs must be None or a non-zero integer"):
        diagnose(model, X, n_jobs=0)


# -- errors per measured state, with units --------------------------------------------------
@pytest.mark.slow
def test_errors_are_reported_per_measured_state_with_their_units():
    from sklearn_pycc import compare_skeletons

    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], noise=40.0,
                                            noise_columns=["x1"], random_state=0,
                                            return_truth=True)
    X = frame[["t", "x1", "F_ext"]].copy()
    X.attrs["units"] = {"x1": "m", "F_ext": "N"}
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), X,
                          units={"t": "s"}, n_bootstrap=0).run(max_rounds=3)
    table = loop.table()
    assert table.attrs["units"] == {"x1": "m", "F_ext": "N", "t": "s"}
    assert {"x1_rmse", "x1_nrmse"} <= set(table.columns) and "x2_rmse" not in table.columns
    assert table["x1_rmse"].iloc[-1] < table["x1_rmse"].iloc[0] / 10
    report = loop.rounds[0].diagnosis
    assert report.measured == ["x1"] and report.trajectories.loc["x1", "unit"] == "m"
    words = report.summary()
    assert "m (NRMSE" in words and "x2: fit" in words and "not measured" in words
    assert "x1 RMSE" in loop.summary() and " m (NRMSE" in loop.summary()
    fig = report.plot()["trajectories"]
    labels = {ax.get_ylabel() for ax in fig.axes} | {ax.get_xlabel() for ax in fig.axes}
    assert "x1 [m]" in labels and "t [s]" in labels
    table = compare_skeletons({"linear": truth.base_equations}, X, held_out=False)
    assert table.attrs["units"]["x1"] == "m" and "x1_simulation_rmse" in table.columns
    with pytest.raises(ValueError, match="names 'x9', which is neither a column"):
        diagnose(loop.model, X, units={"x9": "m"})
    with pytest.raises(TypeError, match=r"units\['x1'\] must be a string"):
        diagnose(loop.model, X, units={"x1": 3})


# -- the final model by simulation when it pays ------------------------------------------
@pytest.mark.slow
def test_the_loop_refines_its_last_skeleton_by_output_error_when_that_simulates_better():
    frame, truth = datasets.make_resonator(n_samples=4000, noise=65.0, samples_per_period=10,
                                           random_state=0, return_truth=True)
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), frame,
                          n_bootstrap=0).run(max_rounds=3)  # refined by default
    last = loop.rounds[-1].model
    assert loop.stopped and last.fit_mode_ == "equation"
    refinement = loop.refinement
    assert refinement.adopted and refinement.after < refinement.before
    # the loop's answer has one name: loop.model (final_model says the same)
    assert loop.model is refinement.model and loop.model.fit_mode_ == "simulation"
    assert loop.final_model is loop.model and loop.model.skeleton_ == last.skeleton_
    assert "refined by output error" in loop.summary()
    assert "The loop's answer (loop.model): round" in loop.summary()
    assert loop.table()["answer"].tolist()[-1] == "loop.model: refitted by output error"
    # asked not to, the loop keeps its last round's model
    plain = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), frame,
                           n_bootstrap=0).run(max_rounds=3, refine=False)
    assert plain.refinement is None and plain.model is plain.rounds[-1].model
    assert plain.final_model is plain.model
    assert plain.table()["answer"].tolist()[-1] == "loop.model"
    # a model already fitted by output error is its own refinement
    noisy = datasets.make_pendulum(random_state=0, noise=35.0)
    loop = HypothesisLoop(PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = -a1 x2 - a2 x1"]),
                          noisy, n_bootstrap=0).run(max_rounds=1)
    assert loop.model.fit_mode_ == "simulation"
    assert loop.refine() is None and loop.final_model is loop.model
    assert "round 0's model (fitted by output error already)" in loop.summary()
