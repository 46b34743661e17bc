"""Measurements as they come: differentiation, experiments, position-only fits."""

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import NeuralCCRegressor, PolyCCRegressor, Skeleton, datasets, diagnose
from sklearn_pycc.measurements import (
    DIFFERENTIATION_METHODS,
    estimate_states,
    kinematic_chains,
    resolve_differentiation,
    split_experiments,
)

SECOND_ORDER = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]


def curve_rmse(model, truth, name):
    frame = model.cc_curves()[name]
    return float(np.sqrt(np.mean((frame[name] - truth.functions[name](frame["x"])) ** 2)))


def nrmse(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return float(np.sqrt(np.mean((a - b) ** 2) / np.mean(b**2)))


@pytest.fixture(scope="module")
def duffing_40db():
    return datasets.make_duffing(noise=40, noise_columns=["x1"], random_state=0, return_truth=True)


# -- differentiation -----------------------------------------------------------------
# about three times the errors each method reaches here (d1, d2, smoothed values):
# spline 1.0e-7, 5.2e-5, 5.6e-6; savgol 2.6e-7, 8.6e-4, 5.1e-7;
# finite_difference 1.05e-4, 2.1e-4, 0; kalman 9.8e-8, 2.0e-7, 5.4e-6
SINE_TOLERANCES = {"spline": (3e-7, 2e-4, 2e-5), "savgol": (1e-6, 3e-3, 2e-6),
                   "finite_difference": (3e-4, 1e-3, 1e-12), "kalman": (3e-7, 1e-6, 2e-5)}


@pytest.mark.parametrize("method", ["spline", "savgol", "finite_difference", "kalman"])
def test_every_method_differentiates_a_sine(method):
    t = np.linspace(0, 10, 400)
    x = np.sin(t)
    smooth, d1, d2 = resolve_differentiation(method).derivatives(t, x, 2)
    inner = slice(20, -20)
    first, second, smoothed = SINE_TOLERANCES[method]
    assert nrmse(d1[inner], np.cos(t)[inner]) < first
    assert nrmse(d2[inner], -np.sin(t)[inner]) < second
    assert nrmse(smooth, x) < smoothed


def test_trend_filtered_is_available():
    t = np.linspace(0, 6, 120)
    d = resolve_differentiation({"method": "trend_filtered", "alpha": 1e-5})
    _, d1 = d.derivatives(t, np.sin(t), 1)
    assert nrmse(d1[10:-10], np.cos(t)[10:-10]) < 0.012  # it reaches 0.0041


def test_spline_smoothing_beats_savgol_on_noisy_acceleration(duffing_40db):
    frame, _ = duffing_40db
    sk = Skeleton(SECOND_ORDER)
    experiments = split_experiments(len(frame), frame["t"].to_numpy())
    errors = {}
    for method in ("spline", "savgol"):
        est = estimate_states(sk, {"x1": frame["x1"].to_numpy()}, experiments,
                              resolve_differentiation(method))
        errors[method] = nrmse(est.derivatives[:, 1], frame["x2_dot"])
    assert errors["spline"] < 0.7 * errors["savgol"]


def test_callable_and_derivative_objects_are_accepted():
    import derivative

    t = np.linspace(0, 5, 200)
    by_callable = resolve_differentiation(lambda x, t: np.gradient(x, t))
    by_object = resolve_differentiation(derivative.FiniteDifference(k=1))
    for d in (by_callable, by_object):
        _, d1 = d.derivatives(t, t**2, 1)
        assert np.allclose(d1[5:-5], 2 * t[5:-5], atol=1e-6)


@pytest.mark.parametrize("spec, message", [
    ("splines", "unknown differentiation method 'splines'"),
    ({"window": 5}, "needs a 'method' key"),
    ({"method": "savgol", "window": 4}, "odd integer"),
    ({"method": "spline", "bogus": 1}, "bad options"),
    (3, "differentiation must be one of"),
])
def test_bad_differentiation_is_named(spec, message):
    with pytest.raises(ValueError, match=message):
        resolve_differentiation(spec)


def test_every_documented_method_is_registered():
    assert set(DIFFERENTIATION_METHODS) == {"auto", "lowpass", "spline", "savgol",
                                            "finite_difference", "kalman", "trend_filtered"}


# -- experiments and reconstruction --------------------------------------------------
def test_kinematic_chains_reach_second_derivatives():
    sk = Skeleton(["x1_dot = x2", "x2_dot = x3", "x3_dot = F_ext - a1 x3 - a2 x1"])
    assert kinematic_chains(sk) == {"x2": ("x1", 1), "x3": ("x1", 2)}
    frame = pd.DataFrame({"t": np.linspace(0, 6, 300)})
    frame["x1"] = np.sin(frame["t"])
    est = estimate_states(sk, {"x1": frame["x1"].to_numpy()},
                          split_experiments(300, frame["t"].to_numpy()),
                          resolve_differentiation("spline"))
    assert nrmse(est.states["x3"][20:-20], -np.sin(frame["t"])[20:-20]) < 0.05
    assert nrmse(est.derivatives[20:-20, 2], -np.cos(frame["t"])[20:-20]) < 0.1
    assert "x3 as the derivative of order 2 of x1" in est.description


def test_a_pause_in_t_splits_an_experiment():
    t = np.r_[np.linspace(0, 1, 20), np.linspace(5, 6, 20)]
    parts = split_experiments(40, t)
    assert [len(p.rows) for p in parts] == [20, 20]
    assert "after a pause" in parts[1].where


def test_experiments_are_differentiated_separately():
    # two experiments whose values jump at the boundary: derivatives must not see it
    t = np.linspace(0, 2, 100)
    frame = pd.DataFrame({"t": np.r_[t, t], "trajectory": np.repeat(["a", "b"], 100),
                          "x1": np.r_[np.sin(t), 5 + np.sin(t)], "F_ext": 0.0})
    est = estimate_states(Skeleton(["x1_dot = a1 F_ext"]), {"x1": frame["x1"].to_numpy()},
                          split_experiments(200, frame["t"].to_numpy(),
                                            frame["trajectory"].to_numpy()),
                          resolve_differentiation("spline"))
    assert np.allclose(est.derivatives[:100, 0], est.derivatives[100:, 0], atol=1e-8)
    # no jump of 5 at the boundary: experiment b starts with the slope cos(0) = 1
    assert abs(est.derivatives[100, 0] - 1.0) < 0.05


def _set(frame, column, row, value):
    values = frame[column].to_numpy(copy=True)
    values[row] = value
    return frame.assign(**{column: values})


@pytest.mark.parametrize("mutate, message", [
    (lambda f: _set(f, "t", 250, 0.0), r"at row 250 in experiment 1 t=0 goes back"),
    (lambda f: _set(f, "t", 51, f["t"].iloc[50]), r"at row 51 in experiment 0 t=.* repeats"),
    (lambda f: f.assign(F_ext=np.where(np.arange(len(f)) == 310, np.nan, f["F_ext"])),
     r"X column 'F_ext' contains NaN at row 310 \(experiment 1\)"),
])
def test_bad_time_grids_name_the_experiment(mutate, message):
    frame = datasets.make_experiments(datasets.make_duffing, 2, n_samples=200, t_span=(0, 10))
    frame = mutate(frame)
    with pytest.raises(ValueError, match=message):
        PolyCCRegressor(equations=SECOND_ORDER, degree=3).fit(frame[["t", "trajectory", "x1",
                                                                    "F_ext"]])


def test_short_experiment_and_uneven_sampling_for_savgol_are_named():
    frame = datasets.make_experiments(datasets.make_duffing, 2, n_samples=200, t_span=(0, 10))
    short = pd.concat([frame[frame.trajectory == 0], frame[frame.trajectory == 1].head(5)])
    model = PolyCCRegressor(equations=SECOND_ORDER, degree=3,
                            differentiation={"method": "savgol", "window": 11})
    with pytest.raises(ValueError, match=r"5 samples in experiment 1 are too few .*at least 11"):
        model.fit(short[["t", "trajectory", "x1", "F_ext"]])
    uneven = frame[frame.trajectory == 0].iloc[np.r_[0:100:2, 100:200]]
    with pytest.raises(ValueError, match="needs evenly spaced samples"):
        model.fit(uneven[["t", "x1", "F_ext"]])
    # the spline handles uneven sampling
    PolyCCRegressor(equations=SECOND_ORDER, degree=3).fit(uneven[["t", "x1", "F_ext"]])


def test_missing_state_without_kinematic_equation_is_named():
    frame = datasets.make_duffing(n_samples=200)
    with pytest.raises(ValueError, match="X has no column 'x2', which the skeleton uses"):
        NeuralCCRegressor(equations=["x1_dot = a1 x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                          max_epochs=1).fit(frame[["t", "x1", "F_ext"]])
    with pytest.raises(ValueError, match="requires y to be passed"):
        PolyCCRegressor(equations=SECOND_ORDER).fit(frame[["x1", "F_ext"]])


def test_user_data_are_not_modified(duffing_40db):
    frame, _ = duffing_40db
    X = frame[["t", "x1", "F_ext"]].copy()
    before = X.copy()
    PolyCCRegressor(equations=SECOND_ORDER, degree=5).fit(X)
    pd.testing.assert_frame_equal(X, before)


# -- fitting position-only data ----------------------------------------------------------
@pytest.mark.parametrize("differentiation", ["auto", "spline"])
def test_position_only_equation_error_fit_beats_the_published_floor(duffing_40db,
                                                                    differentiation):
    frame, truth = duffing_40db
    model = PolyCCRegressor(equations=SECOND_ORDER, constraints=["f1 odd"], degree=7,
                            differentiation=differentiation)
    model.fit(frame[["t", "x1", "F_ext"]])
    assert model.measured_states_ == ["x1"]
    expected = {"auto": "low-pass", "spline": "spline"}[differentiation]
    assert expected in model.derivative_source_
    assert curve_rmse(model, truth, "f2") < 0.038


def test_smooth_states_switch_changes_the_fit(duffing_40db):
    frame, _ = duffing_40db
    X = frame[["t", "x1", "F_ext"]]
    a = PolyCCRegressor(equations=SECOND_ORDER, degree=5).fit(X)
    b = PolyCCRegressor(equations=SECOND_ORDER, degree=5, smooth_states=False).fit(X)
    assert not np.allclose(a.coefficients_["f2"], b.coefficients_["f2"])


@pytest.mark.slow
def test_diagnose_names_coulomb_on_position_only_stick_slip():
    frame = datasets.make_stick_slip(noise=30, noise_columns=["x1"], random_state=0)
    X = frame[["t", "x1", "F_ext"]]
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]).fit(X)
    report = diagnose(model, X)
    assert report.best is not None and report.best.effect == "coulomb_friction"
    assert "estimated" in report.summary()
    # an output-error model: its equation-error refit gives a start, not intervals
    assert model.fit_mode_ == "simulation" and report.best.intervals == {}
    assert "equation-error refit (a start for the output-error fit" in report.summary()
