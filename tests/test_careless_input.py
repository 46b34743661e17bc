"""Careless input to the newest features: each answered with a result or a clear error."""

import io
import time

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, SimulationError, Skeleton, compare_skeletons, datasets
from sklearn_pycc.measurements import Measurement
from sklearn_pycc.simulation import integration as simulation

EQUATIONS = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
#: text that breaks matplotlib's mathtext: an even number of dollars around bad TeX
BAD_TEX = ["$\\undefinedcmd{$", "$\\frac{m}{s$"]


@pytest.fixture(scope="module")
def record():
    frame = datasets.make_oscillator(n_samples=300, hidden=["cubic_stiffness"])
    return frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]


@pytest.fixture(scope="module")
def model(record):
    X, y = record
    return PolyCCRegressor(equations=EQUATIONS).fit(X, y)


def _close(fig):
    import matplotlib.pyplot as plt

    plt.close(fig)


# -- input_hold: "auto" or a hold, nothing else ---------------------------------------------
@pytest.mark.parametrize("bad", [None, "ZOH", 5, "", ["zoh"]])
def test_simulate_refuses_a_hold_that_is_not_one(model, record, bad):
    X, _ = record
    t, u = X["t"].to_numpy(), X["F_ext"].to_numpy()
    with pytest.raises(ValueError, match="input_hold must be one of 'auto', 'bandlimited', "
                                         "'foh', 'zoh'"):
        model.simulate(t, [0.0, 0.0], {"F_ext": u}, input_hold=bad)


def test_simulate_auto_hold_is_the_fitted_one(model, record):
    X, _ = record
    t, u = X["t"].to_numpy()[:50], X["F_ext"].to_numpy()[:50]
    auto = model.simulate(t, [0.1, 0.0], {"F_ext": u})
    fitted = model.simulate(t, [0.1, 0.0], {"F_ext": u}, input_hold=model.input_hold_)
    other = model.simulate(t, [0.1, 0.0], {"F_ext": u}, input_hold="zoh")
    pd.testing.assert_frame_equal(auto, fitted)
    assert model.input_hold_ != "zoh" and not auto.equals(other)


@pytest.mark.parametrize("bad", ["ZOH", 5, "", None])
def test_estimate_initial_state_refuses_a_hold_that_is_not_one(model, record, bad):
    X, _ = record
    with pytest.raises(ValueError, match="input_hold must be one of 'auto'"):
        model.estimate_initial_state(X, input_hold=bad)


def test_skeleton_simulate_refuses_none_for_a_hold():
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(ValueError, match="input_hold must be one of 'bandlimited'"):
        Skeleton(["x1_dot = u - x1"]).simulate(t, [0.0], inputs={"u": np.sin(t)},
                                               input_hold=None)


# -- a long record ends: a result or a SimulationError, in bounded time ----------------------
def test_the_default_step_limit_is_capped_by_the_budget():
    assert simulation.sampled_step_limit(100) == simulation.DEFAULT_MAX_STEPS
    assert simulation.sampled_step_limit(50_000) == 2_500_000
    assert simulation.sampled_step_limit(10_000_000) == simulation.STEP_BUDGET
    # a diagnosis gives a diverging candidate up quickly, within the same budget
    assert simulation.judged_step_limit(1000) == 60_000
    assert simulation.judged_step_limit(10_000_000) == simulation.STEP_BUDGET


def test_a_record_longer_than_the_budget_is_refused_before_the_first_step(monkeypatch):
    monkeypatch.setattr(simulation, "STEP_BUDGET", 1_000)
    monkeypatch.setattr(simulation, "DEFAULT_MAX_STEPS", 100)
    t = np.linspace(0.0, 50.0, 5_000)
    skeleton = Skeleton(["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1"])
    start = time.perf_counter()
    with pytest.raises(SimulationError, match=r"5,000 samples.*in pieces") as info:
        skeleton.simulate(t, [0.0, 0.0], params={"a1": 0.5, "a2": 1.0},
                          inputs={"u": np.sin(t)})
    assert time.perf_counter() - start < 2.0
    assert info.value.t_reached == t[0] and len(info.value.partial) == 1


def test_a_stiff_model_on_a_long_record_stops_at_the_budget(monkeypatch):
    # every sample of a steep friction law needs tens of steps: without a budget that
    # does not grow with the record, ten million samples would run for hours
    monkeypatch.setattr(simulation, "STEP_BUDGET", 3_000)
    monkeypatch.setattr(simulation, "DEFAULT_MAX_STEPS", 100)
    t = np.linspace(0.0, 20.0, 2_000)
    skeleton = Skeleton(["x1_dot = x2", "x2_dot = u - a1 tanh(a3 x2) - a2 x1"])
    with pytest.raises(SimulationError, match=r"took 3000 steps|more than the step limit") as info:
        skeleton.simulate(t, [0.0, 0.0], params={"a1": 0.5, "a2": 1.0, "a3": 1e5},
                          inputs={"u": 0.2 * np.sin(t)})
    assert t[0] < info.value.t_reached < t[-1]


def test_an_explicit_max_steps_goes_beyond_the_budget(monkeypatch):
    monkeypatch.setattr(simulation, "STEP_BUDGET", 100)
    monkeypatch.setattr(simulation, "DEFAULT_MAX_STEPS", 100)
    t = np.linspace(0.0, 10.0, 1_000)
    sim = Skeleton(["x1_dot = u - x1"]).simulate(t, [0.0], inputs={"u": np.ones_like(t)},
                                                 max_steps=10_000)
    assert sim["x1"].iloc[-1] == pytest.approx(1.0 - np.exp(-10.0), rel=1e-5)


@pytest.mark.slow
def test_ten_million_samples_end_in_bounded_time(model):
    t = np.linspace(0.0, 1e5, 10_000_000)
    start = time.perf_counter()
    with pytest.warns(UserWarning, match="takes minutes"), \
            pytest.raises(SimulationError, match="in pieces"):
        model.simulate(t, [0.0, 0.0], {"F_ext": np.sin(t)})
    assert time.perf_counter() - start < 60.0


# -- user text that breaks LaTeX is drawn as written ----------------------------------------
def test_plot_comparison_draws_skeleton_names_as_written(record):
    from sklearn_pycc.plotting import plot_comparison

    X, y = record
    names = [BAD_TEX[0], "plain"]
    table = compare_skeletons({name: EQUATIONS for name in names}, X, y)
    fig = plot_comparison(table)
    try:
        fig.savefig(io.BytesIO(), format="png")  # mathtext would raise here
        assert [label.get_text() for label in fig.axes[0].get_xticklabels()] == names
    finally:
        _close(fig)


@pytest.fixture(scope="module")
def first_order():
    """A first-order record (quick to diagnose) and its units, each breaking LaTeX."""
    t = np.linspace(0.0, 20.0, 300)
    frame = Skeleton(["x1_dot = u - a1 x1 - a2 x1^3"]).simulate(
        t, [0.0], params={"a1": 1.0, "a2": 2.0}, inputs={"u": np.sin(t)},
        return_derivatives=True)
    units = {"x1": BAD_TEX[1], "t": "$s$$", "u": BAD_TEX[0]}
    return frame[["t", "x1", "u"]], frame[["x1_dot"]], units


@pytest.fixture(scope="module")
def report_with_bad_units(first_order):
    from sklearn_pycc import diagnose

    X, y, units = first_order
    model = PolyCCRegressor(equations=["x1_dot = u - a1 x1"]).fit(X, y)
    return diagnose(model, X, y, units=units, n_refit=0, held_out=False, n_bootstrap=0,
                    open_curves=False)


def test_a_diagnosis_with_units_that_break_latex_draws_its_figures(report_with_bad_units):
    # the notebook view draws every figure to PNG: mathtext would raise there
    markup = report_with_bad_units._repr_html_()
    assert markup.count("<img") == 3  # trajectories, residual, map


def test_units_that_break_latex_label_the_axes_as_written(report_with_bad_units):
    figures = report_with_bad_units.plot()
    try:
        labels = [label for fig in figures.values() for ax in fig.axes
                  for label in (ax.get_xlabel(), ax.get_ylabel())]
        assert f"x1 [{BAD_TEX[1]}]" in labels and "t [$s$$]" in labels
    finally:
        for fig in figures.values():
            _close(fig)


@pytest.mark.slow  # a loop round and its report: about 4 s
def test_a_loop_with_units_that_break_latex_writes_its_html(first_order, tmp_path):
    from sklearn_pycc import HypothesisLoop

    X, y, units = first_order
    loop = HypothesisLoop(PolyCCRegressor(equations=["x1_dot = u - a1 x1"]), X, y,
                          units=units, n_refit=1, held_out=False, n_bootstrap=0,
                          open_curves=False)
    loop.step()
    document = loop.to_html(tmp_path / "report.html")
    assert "<img" in document and (tmp_path / "report.html").read_text() == document


def test_the_unmeasured_diagnosis_draws_units_as_written():
    from sklearn_pycc.diagnostics._unmeasured import UnmeasuredDiagnosis

    t = np.linspace(0.0, 1.0, 20)
    report = object.__new__(UnmeasuredDiagnosis)
    report.simulation = pd.DataFrame({"t": t, "x1": t, "x1_sim": t, "x2_sim": -t})
    report.hidden, report.units = ["x2"], {"x1": BAD_TEX[1], "t": BAD_TEX[0]}
    fig = report.plot()["simulation"]
    try:
        fig.savefig(io.BytesIO(), format="png")
        assert fig.axes[0].get_ylabel() == f"x1 [{BAD_TEX[1]}]"
        assert fig.axes[-1].get_xlabel() == f"t [{BAD_TEX[0]}]"
    finally:
        _close(fig)


# -- the paper's functional API names the key it refuses -------------------------------------
@pytest.mark.parametrize("weights, message", [
    ("ab", "params\\['eq_weights'\\] must be numbers"),
    ({"x1_dot": 1.0}, "params\\['eq_weights'\\] must be numbers"),
    ([1.0, "b"], "params\\['eq_weights'\\] must be numbers"),
    ([1.0], "params\\['eq_weights'\\] holds 1 value"),
    ([1.0, float("nan")], "params\\['eq_weights'\\]\\[1\\] = nan"),
    ([1.0, -1.0], "params\\['eq_weights'\\]\\[1\\] = -1.0"),
    ([0.0, 0.0], "params\\['eq_weights'\\] are all zero"),
])
def test_pycc_train_names_eq_weights(record, weights, message):
    from sklearn_pycc import pycc

    X, y = record
    frame = pd.concat([X, y], axis=1)
    with pytest.raises(ValueError, match=message):
        pycc.train(frame, EQUATIONS, method="Poly", params={"eq_weights": weights})


# -- a Measurement: one record, used everywhere, never changed ------------------------------
def test_a_measurement_keeps_its_copy_and_leaves_the_users_frame_alone(record):
    X, _ = record
    users = X.copy()
    measurement = Measurement(users)
    before = PolyCCRegressor(equations=EQUATIONS).fit(measurement).params_
    untouched = users.copy()
    PolyCCRegressor(equations=EQUATIONS).fit(measurement)
    pd.testing.assert_frame_equal(users, untouched)  # the fit never writes to it
    users["x1"] *= 3.0
    users["x2"] *= 3.0
    after = PolyCCRegressor(equations=EQUATIONS).fit(measurement).params_
    assert after == before


def test_a_measurement_changed_in_place_is_estimated_again(record):
    X, _ = record
    measurement = Measurement(X)
    PolyCCRegressor(equations=EQUATIONS).fit(measurement)
    measurement.X["x1"] *= 3.0
    measurement.X["x2"] *= 3.0
    refit = PolyCCRegressor(equations=EQUATIONS).fit(measurement).params_
    fresh = PolyCCRegressor(equations=EQUATIONS).fit(measurement.X.copy()).params_
    assert refit == pytest.approx(fresh)
    assert X["x1"].abs().max() < measurement.X["x1"].abs().max()  # the user's X as it was


def test_cross_validation_of_a_measurement_says_what_to_pass(record):
    from sklearn.model_selection import GridSearchCV, cross_val_score

    X, y = record
    measurement = Measurement(X, y)
    with pytest.raises(TypeError, match=r"Pass measurement.X.*ExperimentSplit"):
        cross_val_score(PolyCCRegressor(equations=EQUATIONS), measurement)
    search = GridSearchCV(PolyCCRegressor(equations=EQUATIONS), {"degree": [2, 3]})
    with pytest.raises(TypeError, match="not an array scikit-learn can split"):
        search.fit(measurement)


def test_score_reads_the_targets_a_measurement_holds(model, record):
    X, y = record
    assert model.score(Measurement(X, y)) == model.score(X, y)
    assert model.score(Measurement(X, y), None) == model.score(X, y)
    with pytest.raises(ValueError, match="the Measurement holds none"):
        model.score(Measurement(X))
    with pytest.raises(ValueError, match="score got y beside a Measurement"):
        model.score(Measurement(X, y), y)


def test_estimate_initial_state_reads_a_measurement(model, record):
    X, y = record
    assert model.estimate_initial_state(Measurement(X, y)) == \
        model.estimate_initial_state(X)


# -- predict on a record of positions alone -----------------------------------------------------
def test_predict_on_a_position_only_record_says_where_the_velocity_comes_from():
    frame = datasets.make_duffing(n_samples=300, t_span=(0.0, 30.0))
    X = frame[["t", "x1", "F_ext"]]
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                            degree=3).fit(X)
    with pytest.raises(ValueError, match=r"no column 'x2', derivative 1 of 'x1'.*diagnose"):
        model.predict(X)
    # with the velocity given, it predicts
    assert np.isfinite(model.predict(frame[["x1", "x2", "F_ext"]])).all()
