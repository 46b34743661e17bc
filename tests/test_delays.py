"""Inputs read late: ``u(t - a5)`` in the skeleton language, fitted, simulated, diagnosed.

A heater's power reaches a stirred tank through a pipe: the skeleton reads
it a transport delay late. The delay is written like any other unknown, and
fitted within a sampling interval; the loop names a delay that the user's
skeleton lacks, in the words of the state's field.
"""

import pickle
import warnings

import numpy as np
import pandas as pd
import pytest
from conftest import LATE_INPUT
from sklearn.base import clone

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, Skeleton, datasets, effects
from sklearn_pycc.diagnostics._candidates import enumerate_input_moves
from sklearn_pycc.diagnostics._roles import equation_roles
from sklearn_pycc.estimators.least_squares import LeastSquaresCCRegressor
from sklearn_pycc.exceptions import SkeletonError
from sklearn_pycc.simulation.delays import delayed_column

HEATER = ["x1_dot = a1 u(t - a5) - a2 x1"]
NO_DELAY = ["x1_dot = a1 u - a2 x1"]


def _tank(seed=0, *, delay_samples=6, snr=40.0, pole=0.9):
    """A heated tank, its temperature read by a sensor with coloured noise."""
    frame, truth = datasets.make_heated_tank(delay_samples=delay_samples, noise=None,
                                             random_state=seed, return_truth=True)
    frame = datasets.add_sensor_noise(frame, ["x1"], snr=snr, pole=pole, bits=12,
                                      random_state=seed)
    return frame, truth


# -- the language -------------------------------------------------------------------
def test_an_input_read_late_is_one_input_and_its_delay_a_parameter():
    skeleton = Skeleton(HEATER, ["a5 <= 8"])
    assert skeleton.inputs == ["u(t - a5)"]
    assert skeleton.params == ["a1", "a2", "a5"]
    assert skeleton.delays == {"u(t - a5)": ("u", "a5")}
    assert skeleton.bounds["a5"] == (0.0, 8.0)  # a delay is never negative
    fixed = skeleton.with_delays({"a5": 0.25})
    assert fixed.equations == ("x1_dot = a1*u(t - 0.25) - a2*x1",)
    assert fixed.params == ["a1", "a2"] and fixed.constraints == ()
    assert skeleton.with_delays({"a5": 0.0}).inputs == ["u"]
    assert Skeleton(["x1_dot = a1 u(t) - a2 x1"]).inputs == ["u"]
    assert Skeleton(["x1_dot = a1 u(t-0.50) - a2 x1"]).inputs == ["u(t - 0.5)"]


@pytest.mark.parametrize("equations, words", [
    (["x1_dot = a1 x1(t - a5)"], "only an input may be read late"),
    (["x1_dot = a5 u(t - a5)"], "a5 is the delay of u(t - a5) and cannot also be a coefficient"),
    (["x1_dot = a1 u(t + a5)"], "u(t - a5) (a fitted delay) or u(t - 0.3)"),
    (["x1_dot = a1 u(x1)"], "unknown function 'u'"),
])
def test_a_delay_written_wrongly_is_refused_by_name(equations, words):
    with pytest.raises(SkeletonError, match=words.replace("(", r"\(").replace(")", r"\)")):
        Skeleton(equations)


def test_a_delayed_column_holds_the_first_value_before_each_experiment():
    t = np.r_[np.arange(5.0), np.arange(5.0)]
    u = np.r_[np.arange(5.0), 10 + np.arange(5.0)]
    late = delayed_column(u, t, 1.5, trajectory=np.repeat([0, 1], 5))
    np.testing.assert_allclose(late, [0, 0, 0.5, 1.5, 2.5, 10, 10, 10.5, 11.5, 12.5])


# -- fitting --------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_the_delay_is_fitted_within_a_sampling_interval_under_coloured_noise(seed):
    frame, truth = _tank(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=HEATER).fit(frame)
    assert abs(model.params_["a5"] - truth.delay) < 0.5  # one sample is 0.5 s
    assert model.delays_ == {"a5": model.params_["a5"]}
    for name in ("a1", "a2"):
        assert model.params_[name] == pytest.approx(truth.params[name], rel=0.1)
    assert model.get_params()["equations"] == HEATER  # the user's text is untouched
    assert "u(t - a5)" not in model.equations_text()[0]


def test_a_held_input_gives_the_delay_itself_when_the_estimator_is_told_so():
    # estimated derivatives smear a held input's steps over a sample; a simulation
    # that holds the input between samples settles the delay
    frame, truth = _tank(2, pole=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=HEATER, input_hold="zoh").fit(frame)
    assert model.fit_mode_ == "simulation"
    assert model.params_["a5"] == pytest.approx(truth.delay, abs=0.1)


def test_a_fitted_delay_predicts_and_simulates_from_the_input_itself():
    frame, truth = datasets.make_heated_tank(noise=None, random_state=3, return_truth=True)
    model = PolyCCRegressor(equations=HEATER).fit(frame)
    predicted = model.predict(frame[["t", "u", "x1"]])
    assert predicted.shape == (len(frame), 1)
    t, u = frame["t"].to_numpy(), frame["u"].to_numpy()
    from_array = model.simulate(t, [2.0], inputs={"u": u})["x1"].to_numpy()
    held = datasets._process_records.HeldInput(t, u)
    from_callable = model.simulate(t, [2.0], inputs={"u": held})["x1"].to_numpy()
    spread = np.std(truth.states["x1"])
    for simulated in (from_array, from_callable):
        assert np.sqrt(np.mean((simulated - truth.states["x1"]) ** 2)) < 0.05 * spread


def test_a_fitted_delay_survives_a_clone_and_a_pickle():
    frame, _ = datasets.make_heated_tank(random_state=4, return_truth=True)
    model = PolyCCRegressor(equations=HEATER).fit(frame)
    again = clone(model).fit(frame)
    assert again.params_ == pytest.approx(model.params_)
    restored = pickle.loads(pickle.dumps(model))
    np.testing.assert_allclose(restored.predict(frame), model.predict(frame))


@pytest.mark.slow
def test_a_bound_on_the_delay_widens_the_search():
    frame, truth = datasets.make_heated_tank(delay_samples=90, random_state=5,
                                             return_truth=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=HEATER, constraints=["a5 <= 60"]).fit(frame)
    assert abs(model.params_["a5"] - truth.delay) < 0.5


@pytest.mark.slow
def test_a_slow_backend_searches_the_delay_with_polynomial_curves():
    frame, truth = datasets.make_heated_tank(n_samples=800, random_state=6,
                                             return_truth=True)
    model = LeastSquaresCCRegressor(equations=["x1_dot = a1 u(t - a5) - f1(x1)"]).fit(frame)
    assert abs(model.params_["a5"] - truth.delay) < 0.5


@pytest.mark.parametrize("X, words", [
    (lambda f: f.drop(columns="t"), "a 't' column"),
    (lambda f: f.to_numpy(), "a 't' column"),
])
def test_a_delay_needs_the_record_s_time(X, words):
    frame, _ = datasets.make_heated_tank(n_samples=200, random_state=0, return_truth=True)
    with pytest.raises(ValueError, match=words):
        PolyCCRegressor(equations=HEATER).fit(X(frame))


def test_an_input_read_late_by_a_given_delay_is_read_from_its_signal():
    frame, truth = datasets.make_heated_tank(noise=None, random_state=7, return_truth=True)
    model = PolyCCRegressor(equations=["x1_dot = a1 u(t - 3) - a2 x1"]).fit(frame)
    assert "a5" not in model.params_
    assert model.params_["a1"] == pytest.approx(truth.params["a1"], rel=0.05)
    assert not hasattr(model, "delays_")


# -- the loop ---------------------------------------------------------------------------
def test_the_loop_names_a_missing_transport_delay_and_fits_it():
    frame, truth = _tank(0)
    start = PolyCCRegressor(equations=NO_DELAY, quantities={"x1": "temperature"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(start, frame).run(max_rounds=3)
    first = loop.rounds[0]
    assert first.added is not None and first.added.effect == "transport_delay"
    assert first.diagnosis.best.called == "transport delay"
    assert "+ a3*u(t - a4)" in first.decision
    delays = [v for a, v in loop.model.params_.items() if a in loop.model.delays_]
    assert len(delays) == 1 and abs(delays[0] - truth.delay) < 0.5
    summary = first.diagnosis.summary()
    assert "transport_delay" in summary and "friction" not in summary


def test_the_loop_names_no_delay_where_there_is_none():
    frame, _ = _tank(1, delay_samples=0)
    start = PolyCCRegressor(equations=NO_DELAY, quantities={"x1": "temperature"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(start, frame).run(max_rounds=2)
    assert "transport_delay" not in [r.added.effect for r in loop.rounds if r.added]


@pytest.mark.parametrize("equations, quantity, called", [
    (NO_DELAY, "temperature", "transport delay"),
    (NO_DELAY, None, "dead time"),
    (["x1_dot = x2", "x2_dot = F - a1 x2 - a2 x1"], None, "actuator delay"),
    (["x1_dot = x2", "x2_dot = a3 F - a1 x2 - a2 x1"], None, "actuator delay"),
])
def test_a_delay_is_tried_on_every_term_that_reads_an_input(equations, quantity, called):
    skeleton = Skeleton(equations)
    roles = equation_roles(skeleton, None if quantity is None else {"x1": quantity})
    tried = [c for c in enumerate_input_moves(skeleton, roles)
             if c.effect.name == "transport_delay"]
    assert len(tried) == 1
    candidate = tried[0]
    assert candidate.effect.called(candidate.roles.quantity_of("input")) == called
    from sklearn_pycc.diagnostics._candidates import extend
    extend(skeleton, candidate)
    late = candidate.extended
    assert len(late.delay_params) == 1 and not set(late.inputs) & {"u", "F"}
    assert len(late.params) == len(skeleton.params) + 1


def test_a_skeleton_already_reading_an_input_late_is_not_delayed_again():
    skeleton = Skeleton(HEATER)
    assert enumerate_input_moves(skeleton, equation_roles(skeleton)) == []
    # nor is a term moved twice: the loop's next round leaves the delayed input alone
    late = Skeleton(["x1_dot = -a2*x1 + a3*u(t - a4)"])
    assert enumerate_input_moves(late, equation_roles(late)) == []


def test_an_effect_through_an_input_says_how_the_input_is_read():
    with pytest.raises(ValueError, match="how the skeleton's terms read it"):
        effects.Effect("gain", "a gain", "input", "a1", curve="f1({i})")
    assert effects.get("transport_delay").term_for(i="u") == "u(t - a1)"


def test_a_frame_of_the_user_is_not_modified_by_a_delay():
    frame, _ = datasets.make_heated_tank(n_samples=300, random_state=8, return_truth=True)
    before = frame.copy()
    PolyCCRegressor(equations=HEATER).fit(frame)
    pd.testing.assert_frame_equal(frame, before)


def test_a_skeleton_simulates_its_delay_from_the_parameters():
    t = np.arange(0.0, 20.0, 0.5)
    step = lambda s: float(s >= 5.0)  # noqa: E731 - a switch at t = 5
    params = {"a1": 1.0, "a2": 1.0, "a5": 3.0}
    x = Skeleton(HEATER).simulate(t, [0.0], params=params, inputs={"u": step})["x1"]
    assert np.all(np.abs(x[t < 8.0]) < 1e-6)
    np.testing.assert_allclose(x[t >= 8.0], 1 - np.exp(-(t[t >= 8.0] - 8.0)), atol=1e-4)


def test_a_delay_is_fitted_in_seconds_on_a_logger_s_datetimes(late_input):
    X, _ = late_input
    clock = pd.Timestamp("2026-01-01 08:00") + pd.to_timedelta(X["t"], unit="s")
    fits = []
    for frame in (X, X.assign(t=clock)):  # the delay search read datetimes in nanoseconds: 0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fits.append(PolyCCRegressor(equations=LATE_INPUT).fit(frame))
    assert fits[1].delays_["a3"] == pytest.approx(0.35, abs=0.02)
    assert fits[1].delays_["a3"] == pytest.approx(fits[0].delays_["a3"])
