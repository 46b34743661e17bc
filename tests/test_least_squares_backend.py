"""The one-file backend passes the same checks as the shipped ones, and fits what it says."""

import pickle

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import check_param_validation, parametrize_with_checks
from test_sklearn_conformance import CHECK_EQUATIONS, EXPECTED_FAILURES

from sklearn_pycc import datasets
from sklearn_pycc.estimators.least_squares import LeastSquaresCCRegressor

CHECKED = LeastSquaresCCRegressor(equations=CHECK_EQUATIONS)


@parametrize_with_checks([CHECKED], expected_failed_checks=lambda est: EXPECTED_FAILURES)
def test_sklearn_compatible(estimator, check):
    check(estimator)


def test_every_hyperparameter_is_validated_before_fitting():
    check_param_validation(type(CHECKED).__name__, CHECKED)


@pytest.fixture(scope="module")
def duffing():
    frame = datasets.make_duffing(n_samples=800)
    return frame[["x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]


def test_it_recovers_odd_curves_as_the_polynomial_backend_does(duffing):
    X, y = duffing
    equations = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
    model = LeastSquaresCCRegressor(equations=equations, constraints=["f1 odd", "f2 odd"],
                                    degree=3).fit(X, y)
    assert model.score(X, y) > 0.9999
    x = np.linspace(-1.0, 1.0, 5)
    # make_duffing's curves: f1 = 0.3 x2, f2 = -1.05 x1 + 1.02 x1^3 (see its docstring)
    assert np.allclose(model.functions_["f1"](x), 0.3 * x, atol=0.01)
    assert np.allclose(model.functions_["f2"](x), -1.05 * x + 1.02 * x**3, atol=0.02)
    assert model.n_parameters_ == 4  # the coefficients of x and x^3 of each curve
    assert "x2_dot = F_ext" in model.equations_text()[1]


@pytest.mark.slow
def test_a_nonlinear_parameter_and_a_point_value_hold(duffing):
    X, y = duffing
    equations = ["x1_dot = x2", "x2_dot = F_ext - a1*tanh(a2*x2) - f1(x1)"]
    model = LeastSquaresCCRegressor(equations=equations, constraints=["f1(0)=0"],
                                    param_init={"a1": 1.0, "a2": 0.5}).fit(X, y)
    assert model.functions_["f1"](0.0) == pytest.approx(0.0, abs=1e-12)
    assert model.score(X, y) > 0.99


def test_what_it_cannot_hold_is_refused_by_name(duffing):
    X, y = duffing
    with pytest.raises(ValueError, match=r"f1 must be monotone.*PolyCCRegressor"):
        LeastSquaresCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - x1"],
                                constraints=["f1 increasing"]).fit(X, y)


def test_round_trips_and_simulation(duffing):
    X, y = duffing
    model = LeastSquaresCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                                    constraints=["f1 odd", "f2 odd"]).fit(X, y)
    again = pickle.loads(pickle.dumps(model))
    pd.testing.assert_frame_equal(
        pd.DataFrame(again.predict(X)), pd.DataFrame(model.predict(X)))
    assert clone(model).get_params() == model.get_params()
    t = np.linspace(0.0, 5.0, 101)
    sim = model.simulate(t, [0.5, 0.0], inputs={"F_ext": lambda s: 0.0 * s})
    assert np.isfinite(sim[["x1", "x2"]].to_numpy()).all()
