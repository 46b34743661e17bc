"""``initial_state`` read by output error: every experiment's start held where the user gave it."""

import warnings

import numpy as np
import pytest
from test_hidden_states import CASCADE, POSITIVE

from sklearn_pycc import NeuralCCRegressor, PolyCCRegressor, datasets

OSCILLATOR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]


def _quiet_fit(model, X):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model.fit(X)


@pytest.fixture(scope="module")
def tanks():
    """The lower tank measured (40 dB), the upper one not: its start is what a user may know."""
    return datasets.make_two_tanks(n_samples=512, rims=(100.0, 100.0), random_state=0,
                                   return_truth=True)


def test_an_unmeasured_states_known_start_is_held_and_helps(tanks):
    frame, truth = tanks
    start = float(truth.y0[0])
    free = _quiet_fit(PolyCCRegressor(equations=CASCADE, constraints=POSITIVE), frame)
    known = _quiet_fit(PolyCCRegressor(equations=CASCADE, constraints=POSITIVE,
                                       initial_state={"x1": start}), frame)
    assert known.initial_states_.x1.iloc[0] == start  # held, not fitted
    assert free.initial_states_.x1.iloc[0] != pytest.approx(start, rel=0.05)
    # knowing where the upper tank starts pins the inflow's gain the free start trades away
    assert abs(known.params_["a1"] / truth.params["a1"] - 1) < 0.02
    assert abs(known.params_["a1"] - truth.params["a1"]) < abs(free.params_["a1"]
                                                               - truth.params["a1"])


def test_a_wrong_start_is_held_too_and_fits_worse(tanks):
    frame, truth = tanks
    right, wrong = (_quiet_fit(PolyCCRegressor(equations=CASCADE, constraints=POSITIVE,
                                               initial_state={"x1": value}), frame)
                    for value in (float(truth.y0[0]), 0.5 * float(truth.y0[0])))
    assert wrong.initial_states_.x1.iloc[0] == 0.5 * float(truth.y0[0])
    assert wrong.shooting_["nrmse_whole"] > right.shooting_["nrmse_whole"]


@pytest.fixture(scope="module")
def oscillator():
    X = datasets.make_oscillator(hidden=[], n_samples=600, noise=40.0, noise_columns=["x1"],
                                 random_state=0)
    return X[["t", "x1", "F_ext"]], float(X["x1"].iloc[0])


def test_a_measured_states_start_is_held_by_multiple_shooting(oscillator):
    X, first = oscillator
    model = _quiet_fit(PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation",
                                       initial_state={"x1": 3.0}), X)
    start = np.asarray(model.shooting_["initial_states"])[0]
    assert start[0] == 3.0 and start[1] != 0.0  # x1 held, x2 fitted
    assert model.params_["a1"] == pytest.approx(0.1, rel=0.05)
    assert model.params_["a2"] == pytest.approx(1.0, rel=0.01)
    off = _quiet_fit(PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation",
                                     initial_state={"x1": first - 1.5}), X)
    assert np.asarray(off.shooting_["initial_states"])[0, 0] == first - 1.5
    assert off.shooting_["nrmse_after"] > model.shooting_["nrmse_after"]


def test_a_neural_fit_holds_the_start_as_well(oscillator):
    X, first = oscillator
    skeleton = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - f1(x1)"]
    fits = [_quiet_fit(NeuralCCRegressor(equations=skeleton, fit_mode="simulation",
                                         initial_state=given, max_epochs=20, random_state=0), X)
            for given in (None, {"x1": first - 1.5})]
    # a start held 1.5 below the record's first sample: the damping takes up what it can
    assert fits[0].params_["a1"] == pytest.approx(0.1, rel=0.1)
    assert abs(fits[1].params_["a1"] - fits[0].params_["a1"]) > 0.02


def test_the_equation_error_fit_says_it_does_not_read_the_start(oscillator):
    X, _ = oscillator
    with pytest.warns(UserWarning, match=r"initial_state is read by the filter.*output error "
                      r"too.*fit_mode='equation' does not use it"):
        PolyCCRegressor(equations=OSCILLATOR, fit_mode="equation",
                        initial_state={"x1": 3.0}).fit(X)
