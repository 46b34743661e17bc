"""A sensor's reading as what is measured: static outputs of states no sensor reads."""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.model_selection import GridSearchCV

from sklearn_pycc import PolyCCRegressor, Skeleton, from_tables
from sklearn_pycc.model_selection import ExperimentSplit, make_simulation_scorer

#: a mass on a spring and a damper, pushed by a force: only an accelerometer on it is logged
SPRING = ["x1_dot = x2", "x2_dot = -a1 x1 - a2 x2 + a3 u"]
TRUE = {"a1": 4.0, "a2": 0.3, "a3": 2.0}


def accelerometer_record(seed: int, n_samples: int = 1500, bias: float = 0.05,
                         snr_db: float = 40.0) -> tuple[pd.DataFrame, np.ndarray]:
    """A multisine force and the acceleration it causes (bias, white noise); the start."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_samples) * 0.02
    freqs, phases = rng.uniform(0.05, 1.5, 8), rng.uniform(0, 2 * np.pi, 8)
    u = np.sin(2 * np.pi * t[:, None] * freqs + phases).sum(axis=1) / 3
    start = rng.uniform(-0.3, 0.3, 2)
    exact = Skeleton(SPRING).simulate(t, start, params=TRUE, inputs={"u": u})
    acc = -TRUE["a1"] * exact.x1 - TRUE["a2"] * exact.x2 + TRUE["a3"] * u + bias
    sd = np.std(acc) * 10 ** (-snr_db / 20)
    frame = pd.DataFrame({"t": t, "u": u, "acc": acc + sd * rng.standard_normal(n_samples)})
    return frame, start


@pytest.mark.slow
def test_a_spring_measured_by_an_accelerometer_alone_is_fitted():
    frame, start = accelerometer_record(0)
    skeleton = [*SPRING, "acc = -a1 x1 - a2 x2 + a3 u + a4"]  # the sensor has a bias
    model = PolyCCRegressor(equations=skeleton).fit(frame)
    for name, value in TRUE.items():
        assert model.params_[name] == pytest.approx(value, rel=0.03), name
    assert model.params_["a4"] == pytest.approx(0.05, abs=0.01)
    assert model.fit_mode_ == "simulation"
    assert "fitted by output error on acc" in model.derivative_source_
    # position and velocity at the start, neither of them measured
    assert model.initial_states_.to_numpy().ravel() == pytest.approx(start,
                                                                      abs=0.01)

    new, new_start = accelerometer_record(1)
    y0 = model.estimate_initial_state(new)
    assert [y0["x1"], y0["x2"]] == pytest.approx(new_start, abs=0.02)
    simulated = model.simulate(new.t, y0, inputs={"u": new.u.to_numpy()})
    noise = np.std(new.acc) * 0.01
    assert np.sqrt(np.mean((simulated.acc - new.acc) ** 2)) < 1.5 * noise


@pytest.mark.slow
def test_refits_on_redrawn_noise_read_the_sensor_too():
    # the accelerometer's errors are drawn again and added to the simulated reading
    frame, _ = accelerometer_record(0, n_samples=600)
    before = frame.copy()
    skeleton = [*SPRING, "acc = -a1 x1 - a2 x2 + a3 u + a4"]
    model = PolyCCRegressor(equations=skeleton, n_bootstrap=12, random_state=0).fit(frame)
    pd.testing.assert_frame_equal(frame, before)
    table = model.bootstrap_params_
    assert table.shape == (12, 4)
    for name in table:
        # about the linearised spread (30 refits: 0.82-1.08 times it; 12 spread more)
        spread = model.params_std_[name]
        assert 0.4 < spread / np.sqrt(model.covariance_.loc[name, name]) < 2.0, name
        assert abs(table[name].mean() - model.params_[name]) < 1.5 * spread, name


def test_where_nothing_is_measured_the_error_names_the_sensor_it_lacks():
    frame = accelerometer_record(0, n_samples=100)[0].drop(columns="acc")
    with pytest.raises(ValueError, match="no static output"):
        PolyCCRegressor(equations=SPRING).fit(frame)


def test_a_sensor_that_does_not_see_a_state_is_refused_with_the_reason():
    frame, _ = accelerometer_record(0, n_samples=100)
    # without a spring nothing reads the position: an accelerometer cannot tell where it is
    skeleton = ["x1_dot = x2", "x2_dot = -a1 x2 + a3 u", "acc = -a1 x2 + a3 u"]
    with pytest.raises(ValueError, match="x1 is not measured and cannot be seen"):
        PolyCCRegressor(equations=skeleton).fit(frame)


def test_a_static_output_is_still_refused_by_output_error_when_every_state_is_measured():
    frame, _ = accelerometer_record(0, n_samples=100)
    frame["x1"], frame["x2"] = 0.0, 0.0
    with pytest.raises(ValueError, match="without a derivative of its own"):
        PolyCCRegressor(equations=[*SPRING, "acc = a4 x1"], fit_mode="simulation").fit(frame)


@pytest.mark.slow
def test_the_simulation_scorer_compares_a_sensor_of_unmeasured_states():
    frames = []
    for k in range(3):
        frame, _ = accelerometer_record(k, n_samples=250, bias=0.0)
        frame["trajectory"] = k
        frames.append(frame)
    X = pd.concat(frames, ignore_index=True)
    damped = [*SPRING, "acc = -a1 x1 - a2 x2 + a3 u"]
    undamped = ["x1_dot = x2", "x2_dot = -a1 x1 + a3 u", "acc = -a1 x1 + a3 u"]
    scorer = make_simulation_scorer()
    search = GridSearchCV(PolyCCRegressor(equations=damped), {"equations": [damped, undamped]},
                          scoring=scorer, cv=ExperimentSplit(n_splits=3),
                          error_score="raise").fit(X)
    assert search.best_params_["equations"] == damped
    scores = search.cv_results_["mean_test_score"]
    assert scores[0] > -0.05 > scores[1]
    # the true model scores at the noise level
    truth = from_tables(damped, {}, TRUE)
    assert -scorer(truth, X) == pytest.approx(0.01, abs=0.01)


def test_an_unmeasured_start_at_rest_is_moved_off_it():
    # the velocity starts at rest in the first guess (0): bumped by a share of itself, the
    # polish's Jacobian could not see it, and it stayed there with the numbers a little off
    frame, start = accelerometer_record(0, n_samples=600)
    skeleton = [*SPRING, "acc = -a1 x1 - a2 x2 + a3 u + a4"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=skeleton).fit(frame)
    assert model.initial_states_.to_numpy().ravel() == pytest.approx(start, abs=0.005)
    for name, value in TRUE.items():
        assert model.params_[name] == pytest.approx(value, rel=0.01), name
