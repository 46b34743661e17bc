"""The hypothesis loop: diagnose a fitted model, name the missing effect, watch the error fall.

Data have known hidden effects; "noisy" means 1 % noise (40 dB) on every
measured column (states and derivatives).
"""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import KFold

from sklearn_pycc import (
    HypothesisLoop,
    NeuralCCRegressor,
    PolyCCRegressor,
    Skeleton,
    compare_skeletons,
    datasets,
    diagnose,
    effects,
)
from sklearn_pycc.diagnostics import Diagnosis

NOISE = 40.0  # dB: noise of 1 % of each column's RMS
SINGLE = ["coulomb_friction", "cubic_stiffness", "quadratic_drag", "position_dependent_damping"]


def measured(columns):
    return [c for c in columns if c != "t" and c != "F_ext"]


def oscillator(hidden, noise=NOISE, **options):
    frame, truth = datasets.make_oscillator(
        hidden=hidden, noise=noise, noise_columns=["x1", "x2", "x1_dot", "x2_dot"],
        random_state=0, return_truth=True, **options)
    return frame, truth


def xy(frame):
    y_cols = [c for c in frame.columns if c.endswith("_dot")]
    return frame[[c for c in frame.columns if c not in y_cols]], frame[y_cols]


def loop(frame, equations, estimator=None, rounds=3):
    """Fit, diagnose, add the best effect, refit ... until nothing is missing."""
    X, y = xy(frame)
    found, reports = [], []
    for _ in range(rounds):
        model = (estimator or PolyCCRegressor()).set_params(equations=equations,
                                                           constraints=None)
        report = diagnose(model.fit(X, y), X, y)
        reports.append(report)
        if report.best is None:
            break
        found.append((report.best.effect, report.best.equation))
        equations = report.best.equations
    return found, reports


@pytest.fixture(scope="module", params=[
    NOISE, pytest.param(None, marks=pytest.mark.slow)], ids=["noisy", "noise-free"])
def noise(request):
    return request.param


@pytest.mark.slow
@pytest.mark.parametrize("effect", SINGLE)
def test_the_hidden_effect_is_named_and_the_error_falls(effect, noise):
    frame, truth = oscillator([effect], noise=noise)
    found, reports = loop(frame, truth.base_equations)
    assert found == [(effect, "x2_dot")]
    ratio = reports[0].simulation_rmse / reports[1].simulation_rmse
    assert ratio >= (10 if noise else 1000)
    assert reports[1].best is None  # nothing else is missing


@pytest.mark.slow
def test_stick_slip_two_rounds(noise):
    frame, truth = datasets.make_stick_slip(
        noise=noise, noise_columns=["x1", "x2", "x1_dot", "x2_dot"], random_state=0,
        return_truth=True)
    found, reports = loop(frame, truth.base_equations, rounds=4)
    assert found == [("coulomb_friction", "x2_dot"), ("cubic_stiffness", "x2_dot")]
    assert len(reports) == 3 and reports[-1].best is None
    errors = [r.simulation_rmse for r in reports]
    assert errors[0] > errors[1] > errors[2]
    assert errors[0] / errors[2] >= (10 if noise else 1000)


@pytest.mark.slow
def test_nonlinear_coupling_between_two_masses(noise):
    states = ["x1", "x2", "x3", "x4"]
    frame, truth = datasets.make_two_dof(
        coupling_cubic=1.0, y0=(2.0, -1.0, 0.0, 0.0), amplitude=0.3, noise=noise,
        noise_columns=[*states, *(s + "_dot" for s in states)], random_state=0,
        return_truth=True)
    found, reports = loop(frame, truth.base_equations)
    assert [effect for effect, _ in found] == ["coupling"]
    best = reports[0].best
    assert best.equation == "x3_dot" and best.variable == "x1 - x2"
    # the spring acts on both masses, each with its own coefficient
    assert best.also == {"x4_dot": "a8*(x2 - x1)^3"}
    assert reports[0].simulation_rmse / reports[1].simulation_rmse >= (10 if noise else 1000)


def test_quadratic_drag_outranks_coulomb_friction_held_to_its_bounds():
    frame, truth = oscillator(["quadratic_drag"])
    X, y = xy(frame)
    report = diagnose(PolyCCRegressor(equations=truth.base_equations).fit(X, y), X, y,
                      n_refit=12)
    ranking = report.ranking.reset_index(drop=True)
    drag = ranking.index[ranking.effect == "quadratic_drag"][0]
    coulomb = ranking.index[ranking.effect == "coulomb_friction"][0]
    assert drag == 0 and coulomb > drag
    assert report.best.bounds == ("a3 >= 0",)
    assert "(within a3 >= 0)" in report.summary()
    # a Coulomb level is not negative: the term can lower the error only by removing
    # energy, never by feeding it in as an unbounded fit would
    candidate = next(c for c in report.candidates if c.effect.name == "coulomb_friction")
    level, steepness = candidate.screen_params.values()  # fitted to the residual
    assert level >= 0 and steepness >= 0
    if candidate.refit is not None:
        level, steepness = (candidate.refit.params_[a] for a in candidate.new_params)
        assert level >= 0 and steepness >= 0
    assert "feeds energy in" not in ranking.loc[coulomb, "note"]


@pytest.mark.slow
@pytest.mark.parametrize("effect", SINGLE)
def test_a_complete_model_has_nothing_missing(effect, noise):
    frame, truth = oscillator([effect], noise=noise)
    X, y = xy(frame)
    model = PolyCCRegressor(equations=truth.parametric_equations).fit(X, y)
    report = diagnose(model, X, y)
    assert report.best is None
    assert "Missing effect: nothing" in report.summary()


def test_linear_data_leave_the_linear_model_alone(noise):
    frame, truth = oscillator([], noise=noise)
    X, y = xy(frame)
    report = diagnose(PolyCCRegressor(equations=truth.base_equations).fit(X, y), X, y)
    assert report.best is None
    assert not report.ranking.empty  # effects were tried, none was invented


@pytest.mark.slow
def test_the_loop_works_with_the_neural_backend():
    frame, _ = oscillator(["coulomb_friction", "cubic_stiffness"])
    X, y = xy(frame)
    hybrid = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a1 x1"]
    model = NeuralCCRegressor(equations=hybrid, constraints=["f1 odd"], random_state=0)
    report = diagnose(model.fit(X, y), X, y, n_refit=2)
    # friction is the network's; what the skeleton lacks is the cubic spring
    assert (report.best.effect, report.best.equation) == ("cubic_stiffness", "x2_dot")
    assert report.best.curve_term == "f2(x1)"
    refit = NeuralCCRegressor(equations=report.best.equations, random_state=0).fit(X, y)
    after = diagnose(refit, X, y, n_refit=2)
    assert report.simulation_rmse / after.simulation_rmse >= 10


# -- what a report holds ------------------------------------------------------------
@pytest.fixture(scope="module")
def coulomb_report():
    frame, truth = oscillator(["coulomb_friction"])
    X, y = xy(frame)
    model = PolyCCRegressor(equations=truth.base_equations).fit(X, y)
    return model, X, y, diagnose(model, X, y)


def test_report_compares_derivatives_and_trajectories(coulomb_report):
    _, X, y, report = coulomb_report
    assert isinstance(report, Diagnosis)
    assert list(report.derivatives.index) == ["x1_dot", "x2_dot"]
    assert set(report.derivatives.columns) == {"rmse", "nrmse", "r2", "fit_percent"}
    # the kinematic equation is fine, the acceleration is not
    assert report.derivatives.loc["x1_dot", "r2"] > 0.99
    assert report.derivatives.loc["x2_dot", "r2"] < 0.9
    assert list(report.trajectories.index) == ["x1", "x2"]
    assert (report.trajectories.fit_percent < 60).all()
    assert list(report.simulation.columns) == ["t", "x1", "x1_sim", "x2", "x2_sim"]
    np.testing.assert_allclose(report.residuals["x2_dot"],
                               y["x2_dot"] - report.model.predict(X)[:, 1])


def test_report_says_where_it_fails(coulomb_report):
    _, _, _, report = coulomb_report
    explained = report.explained[report.explained.equation == "x2_dot"]
    assert explained.variable.iloc[0] == "x2"  # friction acts through the velocity
    assert explained.fraction.iloc[0] > 0.9
    assert {"x1", "x2", "F_ext", "t", "x1^2 x2"} <= set(explained.variable)
    assert len(report.windows) == 3
    assert (report.windows.end > report.windows.start).all()
    residual_map = report.maps["x2_dot"]
    assert (residual_map.x, residual_map.y) == ("x1", "x2")
    assert residual_map.count.sum() == len(report.residuals)
    # friction opposes motion: the residual is negative where the velocity is positive
    frame = residual_map.to_frame()
    fast = frame.loc[frame.index > 0.5].to_numpy()
    assert np.nanmean(fast) < 0


def test_report_names_the_effect_in_plain_words(coulomb_report):
    report = coulomb_report[-1]
    best = report.best
    assert best.effect == "coulomb_friction" and best.variable == "x2"
    assert best.term == "a3*tanh(a4*x2)"
    assert best.equations == Skeleton(
        ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3*tanh(a4*x2)"],
        ["a3 >= 0", "a4 >= 0"])
    assert best.bounds == ("a3 >= 0", "a4 >= 0")
    assert (best.curve_term, best.curve_constraints) == ("f1(x2)", ("f1 odd",))
    assert best.param_init["a3"] == pytest.approx(0.3, rel=0.05)
    text = report.summary()
    for words in ("x2_dot", "coulomb_friction", "a3*tanh(a4*x2)", "Where it fails",
                  "explained best by x2", "fit report.best.equations"):
        assert words in text
    assert set(report.ranking.columns) >= {"equation", "variable", "effect", "score",
                                           "suggested_term"}
    assert report.ranking.iloc[0].effect == "coulomb_friction"
    assert "coulomb_friction" in repr(report)


def test_a_clear_suggestion_is_stable_and_its_parameters_have_intervals(coulomb_report):
    report = coulomb_report[-1]
    stability = report.ranking.set_index("effect")["stability"]
    assert stability["coulomb_friction"] >= 0.95
    assert stability.drop("coulomb_friction").sum() <= 0.05
    low, high = report.best.intervals["a3"]
    assert low < 0.3 < high and high - low < 0.05
    assert set(report.best.intervals) == {"a3", "a4"}
    text = report.summary()
    assert "coulomb_friction wins in" in text and "of 100 resamples" in text
    assert "Its parameters, with 95 % intervals: a3 = " in text


def stability_case(level):
    """Coulomb friction of ``level`` on a linear oscillator, noisy accelerations."""
    frame, truth = datasets.make_oscillator(
        hidden={"coulomb_friction": {"a1": level, "a2": 20.0}}, noise=30,
        noise_columns=["x2_dot"], random_state=0, return_truth=True)
    X, y = frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]
    return PolyCCRegressor(equations=truth.base_equations).fit(X, y), X, y


@pytest.mark.slow
def test_a_suggestion_near_the_threshold_reports_low_stability():
    # the friction removes about as much of the residual as min_improvement asks
    model, X, y = stability_case(0.015)
    report = diagnose(model, X, y, simulate=False, n_refit=3)
    assert report.best is not None and report.best.error_removed < 0.11
    chosen = report.ranking.iloc[0]
    assert chosen.stability < 0.5
    assert "nothing is missing in" in report.summary()
    # the same random_state gives the same figure, another a different draw
    again = diagnose(model, X, y, simulate=False, n_refit=3)
    assert again.ranking.iloc[0].stability == chosen.stability
    other = diagnose(model, X, y, simulate=False, n_refit=3, random_state=5)
    assert abs(other.ranking.iloc[0].stability - chosen.stability) < 0.25
    none = diagnose(model, X, y, simulate=False, n_refit=3, n_bootstrap=0)
    assert none.ranking.stability.isna().all()
    assert "Stability" not in none.summary()
    for wrong in (-1, 1):
        with pytest.raises(ValueError, match="n_bootstrap must be 0"):
            diagnose(model, X, y, n_bootstrap=wrong)


def test_diagnose_leaves_the_model_and_data_alone(coulomb_report):
    model, X, y, _ = coulomb_report
    params, state = dict(model.params_), model.get_params()
    X_before, y_before = X.copy(), y.copy()
    diagnose(model, X, y, n_refit=1)
    assert model.params_ == params and model.get_params() == state
    pd.testing.assert_frame_equal(X, X_before)
    pd.testing.assert_frame_equal(y, y_before)


def test_plot_returns_the_three_figures(coulomb_report):
    import matplotlib.pyplot as plt

    _, _, _, report = coulomb_report
    figures = report.plot()
    assert set(figures) == {"trajectories", "residual", "map"}
    try:
        for fig in figures.values():
            assert fig.axes
        lines = {line.get_label(): line for line in figures["residual"].axes[0].lines}
        # the suggested term alone, as refitted, over the residual it has to explain
        acting = lines["- a3*tanh(a4*x2), as refitted"].get_ydata()
        residual = lines["residual, the other terms as refitted"].get_ydata()
        assert np.std(residual - acting) < 0.2 * np.std(residual)
        x = figures["residual"].axes[0].lines[1].get_xdata()
        assert np.all(np.diff(acting[np.argsort(x)]) <= 1e-12)  # one curve of x2, no loops
    finally:
        for fig in figures.values():
            plt.close(fig)


# -- measurements as they come ----------------------------------------------------------
def test_several_experiments_are_simulated_separately():
    parts = []
    for k, y0 in enumerate([(3.0, 0.0), (-2.0, 1.0)]):
        frame, truth = oscillator(["cubic_stiffness"], y0=y0, n_samples=800)
        parts.append(frame.assign(trajectory=f"run{k}"))
    frame = pd.concat(parts, ignore_index=True)
    X, y = xy(frame)
    model = PolyCCRegressor(equations=truth.base_equations).fit(X, y)
    report = diagnose(model, X, y)
    assert report.best.effect == "cubic_stiffness"
    assert list(report.simulation.trajectory.unique()) == ["run0", "run1"]
    # each experiment starts from its own measured state
    second = report.simulation[report.simulation.trajectory == "run1"].iloc[0]
    assert second.x1_sim == pytest.approx(frame.x1[800])
    assert set(report.windows.trajectory) <= {"run0", "run1"}


@pytest.mark.slow
def test_derivatives_are_read_from_x_or_estimated():
    frame, truth = oscillator(["coulomb_friction"], noise=None)
    X, y = xy(frame)
    model = PolyCCRegressor(equations=truth.base_equations).fit(X, y)
    from_columns = diagnose(model, frame)  # the NAME_dot columns of X
    assert from_columns.best.effect == "coulomb_friction" and not from_columns.notes
    estimated = diagnose(model, X)
    assert estimated.best.effect == "coulomb_friction"
    assert "estimated" in estimated.notes[0]


def test_a_registered_effect_is_tried():
    mine = effects.Effect("magnetic_spring", "force of a permanent magnet", "position",
                          "a1 {x} / (1 + {x}^2)", "f1({x})", ("f1 odd",))
    frame, truth = oscillator(["cubic_stiffness"])
    X, y = xy(frame)
    model = PolyCCRegressor(equations=truth.base_equations).fit(X, y)
    effects.register(mine)
    try:
        report = diagnose(model, X, y)
    finally:
        effects.unregister("magnetic_spring")
    assert "magnetic_spring" in set(report.ranking.effect)
    assert report.best.effect == "cubic_stiffness"


# -- bad input ---------------------------------------------------------------------------
def test_unfitted_model_raises_not_fitted():
    frame, truth = oscillator([])
    with pytest.raises(NotFittedError):
        diagnose(PolyCCRegressor(equations=truth.base_equations), *xy(frame))


def test_missing_columns_are_named(coulomb_report):
    model, X, y, _ = coulomb_report
    with pytest.raises(ValueError, match="X has no column 'F_ext', which the skeleton uses"):
        diagnose(model, X.drop(columns="F_ext"), y)
    with pytest.raises(ValueError, match="missing \\['x2_dot'\\]"):
        diagnose(model, X, y[["x1_dot"]])
    with pytest.raises(TypeError, match="DataFrame"):
        diagnose(model, X.to_numpy(), y)
    with pytest.raises(ValueError, match="n_refit"):
        diagnose(model, X, y, n_refit=-1)
    bad = X.copy()
    bad.loc[5, "x1"] = np.nan
    with pytest.raises(ValueError, match="X column 'x1' contains NaN at row 5"):
        diagnose(model, bad, y)


def _blowing_up():
    """``x1' = x1^2`` fitted, and measurements from a larger start (blow-up at t = 0.5)."""
    t = np.linspace(0.0, 0.5, 200)
    train = pd.DataFrame({"t": t, "x1": 1.0 / (1.0 - t)})
    model = PolyCCRegressor(equations=["x1_dot = a1 x1^2"])
    model.fit(train, (train.x1**2).rename("x1_dot"))
    t = np.linspace(0.0, 0.9, 300)
    return model, t, pd.DataFrame({"t": t, "x1": 2.0 * np.exp(t)})


def test_a_diverging_simulation_is_reported_not_raised():
    model, _, test = _blowing_up()
    report = diagnose(model, test, test.x1.rename("x1_dot"), horizon=None)
    assert len(report.divergences) == 1
    assert report.divergences[0].t_reached == pytest.approx(0.5, abs=0.02)
    assert report.windows.iloc[0].note.startswith("simulation diverged")
    assert np.isinf(report.windows.iloc[0].simulation_nrmse)
    assert report.simulation.x1_sim.iloc[-1] != report.simulation.x1_sim.iloc[-1]  # NaN
    assert "FAILURE" in report.summary()


def test_a_window_diverging_within_its_horizon_is_reported():
    model, t, test = _blowing_up()
    report = diagnose(model, test, test.x1.rename("x1_dot"), horizon=0.3)
    assert report.horizon.time == pytest.approx(0.3, abs=t[1])  # a whole number of steps
    # restarted from the measured x1 = 2 exp(t0), a window blows up 1 / (2 exp(t0))
    # later: only the one from t0 = 0.6 does so within 0.3, near t = 0.87
    assert len(report.divergences) == 1
    assert report.divergences[0].t_reached == pytest.approx(0.87, abs=0.02)
    assert "windows of the horizon left the states' range" in report.divergences[0].reason
    assert report.simulation.x1_sim.iloc[-1] != report.simulation.x1_sim.iloc[-1]  # NaN
    assert "FAILURE" in report.summary() and "windows of 0.301" in report.summary()
    with pytest.raises(ValueError, match="horizon must be 'auto', None or a positive time"):
        diagnose(model, test, test.x1.rename("x1_dot"), horizon=-1.0)


@pytest.mark.slow
def test_a_slow_drift_is_named_a_drift_not_a_forcing():
    t = np.linspace(0, 66, 1321)
    truth = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 t"])
    force = 0.5 * np.cos(1.3 * t)
    sim = truth.simulate(t, [0.0, 0.0], params={"a1": 0.2, "a2": 1.0, "a3": 0.01},
                         inputs={"F_ext": force}, return_derivatives=True)
    X = pd.DataFrame({"t": t, "x1": sim.x1, "x2": sim.x2, "F_ext": force})
    y = sim[["x1_dot", "x2_dot"]]
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
    report = diagnose(model.fit(X, y), X, y)
    assert report.best.effect == "drift"
    # a cosine slow enough to be a ramp fits as well, but the record cannot tell it
    forcing = report.ranking.set_index("effect").loc["periodic_forcing"]
    assert not forcing.plausible and "cannot tell it from a slow drift" in forcing.note


def test_a_chattering_simulation_is_stopped(coulomb_report):
    model, X, y, _ = coulomb_report
    report = diagnose(model, X, y, max_steps=5, n_refit=0, horizon=None)
    assert report.divergences and "steps" in report.divergences[0].reason


# -- compare_skeletons ------------------------------------------------------------------
def test_compare_skeletons_shows_the_error_falling():
    import matplotlib.pyplot as plt

    from sklearn_pycc.plotting import plot_comparison

    frame, truth = oscillator(["coulomb_friction", "cubic_stiffness"])
    X, y = xy(frame)
    linear = Skeleton(truth.base_equations)
    plus_coulomb = linear.add_term("x2", effects.get("coulomb_friction").term_for(v="x2"))
    both = plus_coulomb.add_term("x2", effects.get("cubic_stiffness").term_for(x="x1"))
    table = compare_skeletons({"linear": linear, "+coulomb": plus_coulomb, "+cubic": both},
                              X, y, estimator=PolyCCRegressor(), cv=KFold(3))
    assert list(table.index) == ["linear", "+coulomb", "+cubic"]
    assert list(table.n_params) == [2, 4, 5]
    assert table.simulation_rmse.is_monotonic_decreasing
    assert table.derivative_rmse.is_monotonic_decreasing
    assert table.bic.is_monotonic_decreasing
    assert table.simulation_rmse.iloc[0] / table.simulation_rmse.iloc[-1] > 10
    assert table.cv_score.iloc[-1] > table.cv_score.iloc[0]
    fig = plot_comparison(table)
    try:
        assert len(fig.axes) == 2
    finally:
        plt.close(fig)


def test_compare_skeletons_takes_lists_and_rejects_a_single_skeleton():
    frame, truth = oscillator([])
    X, y = xy(frame)
    table = compare_skeletons([truth.base_equations], X, y, simulate=False)
    assert list(table.index) == ["skeleton 1"]
    assert np.isnan(table.simulation_rmse.iloc[0])
    with pytest.raises(TypeError, match="several skeletons"):
        compare_skeletons(Skeleton(truth.base_equations), X, y)


# -- accuracy study across noise draws (make test-slow) ------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("seed", range(1, 6))
@pytest.mark.parametrize("effect", SINGLE)
def test_the_right_effect_across_noise_draws(effect, seed):
    frame, truth = datasets.make_oscillator(
        hidden=[effect], noise=NOISE, noise_columns=["x1", "x2", "x1_dot", "x2_dot"],
        random_state=seed, return_truth=True)
    found, reports = loop(frame, truth.base_equations)
    assert found == [(effect, "x2_dot")]
    assert reports[0].simulation_rmse / reports[1].simulation_rmse >= 10


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(1, 6))
def test_stick_slip_two_rounds_across_noise_draws(seed):
    frame, truth = datasets.make_stick_slip(
        noise=NOISE, noise_columns=["x1", "x2", "x1_dot", "x2_dot"], random_state=seed,
        return_truth=True)
    found, reports = loop(frame, truth.base_equations, rounds=4)
    assert [effect for effect, _ in found] == ["coulomb_friction", "cubic_stiffness"]
    assert reports[0].simulation_rmse / reports[-1].simulation_rmse >= 10


@pytest.mark.slow
def test_the_diagnosis_refits_without_resamples_and_the_loop_keeps_the_users(monkeypatch):
    # a model fitted with n_bootstrap: each candidate's refit and held-out fit is judged by
    # its errors alone (it made n_bootstrap refits each, 6 times the time with 10), while
    # each round's model of the loop keeps the refits the user asked for
    from sklearn_pycc.estimators.base import CCRegressor

    frame = datasets.make_oscillator(noise=NOISE, random_state=0)
    fitted_with_resamples = []
    bootstrap = CCRegressor._bootstrap

    def counted(self, *args, **kwargs):
        fitted_with_resamples.append(self)
        return bootstrap(self, *args, **kwargs)

    monkeypatch.setattr(CCRegressor, "_bootstrap", counted)
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"],
                            n_bootstrap=4, random_state=0)
    # (the loop's n_bootstrap is the diagnosis's stability check, not the estimator's)
    loop = HypothesisLoop(model, frame, n_bootstrap=0).run(max_rounds=2, refine=False)
    assert loop.rounds[0].added.effect == "coulomb_friction"
    assert "n_bootstrap" not in loop.rounds[0].added.settings
    assert len(fitted_with_resamples) == len(loop.rounds)
    for r in loop.rounds:
        assert r.model.n_bootstrap == 4 and len(r.model.bootstrap_) >= 2


def test_an_unmeasured_periodic_force_is_named_when_every_fold_shows_it():
    # a harmonic push nobody measured, beside the measured force: it acts through the whole
    # record, so it lowers the held-out error in every fold
    t = np.linspace(0.0, 60.0, 3000)
    force = 0.5 * np.cos(1.3 * t)
    truth = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 + a3 sin(0.4 t)"])
    x = truth.simulate(t, [0.0, 0.0], params={"a1": 0.2, "a2": 1.0, "a3": 0.3},
                       inputs={"F_ext": force})["x1"].to_numpy()
    rng = np.random.default_rng(0)
    X = pd.DataFrame({"t": t, "x1": x + 0.01 * np.std(x) * rng.standard_normal(len(t)),
                      "F_ext": force})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
        report = diagnose(model.fit(X), X)
    assert report.best.effect == "periodic_forcing"
    held_out = report.best.held_out
    assert held_out.every_fold and held_out.wins == held_out.n_folds


def test_a_candidate_must_beat_what_its_numbers_take_out_of_the_noise():
    from types import SimpleNamespace

    from sklearn_pycc.diagnostics._decide import CHANCE_Z, WHOLE_RECORD_GAIN, chance_fall

    frame = datasets.make_oscillator(n_samples=3000, t_span=(0.0, 60.0), random_state=0)
    white = datasets.add_sensor_noise(frame, ["x1"], snr=30.0, random_state=0)
    coloured = datasets.add_sensor_noise(frame, ["x1"], snr=30.0, pole=0.9, random_state=0)
    model = SimpleNamespace(measured_states_=["x1"])
    forcing = SimpleNamespace(effect=effects.get("periodic_forcing"), n_change=3)
    # three numbers take about three independent samples' worth of the noise's squares
    assert chance_fall(forcing, model, white) == pytest.approx(CHANCE_Z * 3 / 6000, rel=0.2)
    assert chance_fall(forcing, model, white) < WHOLE_RECORD_GAIN
    # AR(1) noise of pole 0.9 is worth (1 + 0.9)/(1 - 0.9) = 19 times fewer samples
    assert 12 * chance_fall(forcing, model, white) < chance_fall(forcing, model, coloured) \
        < 25 * chance_fall(forcing, model, white)
    # so is a catalogue law, by its own numbers; a move that adds none is not
    friction = SimpleNamespace(effect=effects.get("coulomb_friction"), n_change=2, move="add")
    assert chance_fall(friction, model, coloured) == pytest.approx(
        2 / 3 * chance_fall(forcing, model, coloured))
    swap = SimpleNamespace(effect=effects.get("pendulum"), n_change=0, move="replace")
    assert chance_fall(swap, model, coloured) == 0.0
    # a free curve of seven numbers is held to the same account
    curve = SimpleNamespace(effect=effects.get("coulomb_friction"), n_change=7, move="open")
    assert chance_fall(curve, model, coloured) == pytest.approx(
        7 / 3 * chance_fall(forcing, model, coloured))


def test_a_force_of_time_must_beat_the_slow_wander_the_model_leaves():
    # a sensor's slow drift lies below the signal's band: the noise read from the record
    # cannot show it, the model's output errors through the whole record do
    from types import SimpleNamespace

    from sklearn_pycc.diagnostics._decide import chance_fall

    frame = datasets.make_oscillator(n_samples=3000, t_span=(0.0, 60.0), hidden=(),
                                     random_state=0)
    forcing = SimpleNamespace(effect=effects.get("periodic_forcing"), n_change=3, move="add")
    curve = SimpleNamespace(effect=effects.get("coulomb_friction"), n_change=7, move="open")
    falls = {}
    for drift in (0.0, 0.02):
        record = datasets.add_sensor_noise(frame, ["x1"], snr=40.0, pole=0.9, drift=drift,
                                           random_state=1)[["t", "x1", "F_ext"]]
        model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"],
                                fit_mode="simulation").fit(record)
        assert model.shooting_["slow_memory"] >= 1.0
        falls[drift] = (chance_fall(forcing, model, record, {}),
                        chance_fall(curve, model, record, {}))
    # the drift makes a periodic force of free frequency take out far more by chance
    assert falls[0.02][0] > 4 * falls[0.0][0]
    # and a free curve's many numbers
    assert falls[0.02][1] > 4 * falls[0.0][1]


def test_close_candidates_go_fewest_numbers_first_then_those_keeping_the_users_terms():
    from types import SimpleNamespace

    from sklearn_pycc.diagnostics._decide import ordered_candidates

    def candidate(name, move, n_change, delta_bic):
        return SimpleNamespace(name=name, move=move, n_change=n_change, delta_bic=delta_bic,
                               screen_bic=delta_bic, refit=object(), plausible=True)

    # the derivatives' scores within 2 % of each other: the information criterion alone
    # cannot tell a saturating spring from a pendulum's, nor add from replace
    ranked = ordered_candidates([
        candidate("saturation beside the spring", "add", 2, -3335.0),
        candidate("saturation for the spring", "replace", 1, -3343.0),
        candidate("pendulum", "add", 1, -3329.0),
        candidate("cubic stiffness", "add", 1, -3000.0),  # clearly behind
    ])
    assert [c.name for c in ranked] == ["pendulum", "saturation for the spring",
                                        "saturation beside the spring", "cubic stiffness"]
    # a clearly better replacement still goes first
    ranked = ordered_candidates([candidate("pendulum", "add", 1, -3000.0),
                                 candidate("saturation for the spring", "replace", 1, -3343.0)])
    assert ranked[0].name == "saturation for the spring"


def test_a_users_term_that_earns_nothing_through_the_record_is_not_kept_beside():
    from types import SimpleNamespace

    from sklearn_pycc.diagnostics._decide import _earns_nothing

    def candidate(held_out, whole, n_change, replaces=()):
        return SimpleNamespace(held_out=SimpleNamespace(criterion="simulation",
                                                        after={"simulation": held_out}),
                               whole_record=whole, n_change=n_change, replaces=replaces,
                               note="")

    per_number = 3 * 19 / 6000  # one number's chance share on AR(1) 0.9 noise, 3,000 samples
    # a pendulum in place of a spring the record does not have: the same error without it
    beside = candidate(0.229, 0.029794, 1)
    replacement = candidate(0.220, 0.029793, 0, ("a2*x1",))
    assert _earns_nothing(beside, replacement, per_number)
    assert "preferred to keeping 'a2*x1' beside it" in replacement.note
    # a light real damping under a quadratic drag: the whole record needs it
    assert not _earns_nothing(candidate(0.229, 0.0250, 1), candidate(0.220, 0.0298, 0),
                              per_number)
    # held out, the replacement must do no worse; unknown whole-record errors say nothing
    assert not _earns_nothing(candidate(0.210, 0.029794, 1), candidate(0.220, 0.029793, 0),
                              per_number)
    assert not _earns_nothing(beside, candidate(0.220, None, 0), per_number)
    assert not _earns_nothing(beside, candidate(0.220, 0.029793, 0), None)
