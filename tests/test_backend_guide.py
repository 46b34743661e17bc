"""The user guide's example backend is real: it passes the conformance checks and fits."""

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import check_param_validation, parametrize_with_checks
from test_sklearn_conformance import CHECK_EQUATIONS, EXPECTED_FAILURES

from sklearn_pycc import datasets

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "user_guide"))
from line_backend import LineCCRegressor

CHECKED = LineCCRegressor(equations=CHECK_EQUATIONS)


@parametrize_with_checks([CHECKED], expected_failed_checks=lambda est: EXPECTED_FAILURES)
def test_sklearn_compatible(estimator, check):
    check(estimator)


def test_every_hyperparameter_is_validated_before_fitting():
    check_param_validation(type(CHECKED).__name__, CHECKED)


def test_it_fits_a_linear_oscillator_from_positions_alone():
    frame, truth = datasets.make_oscillator(hidden=[], return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    model = LineCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a1*x1"]).fit(X)
    # f1 is the damping line c*x2 (offset near 0), a1 the stiffness
    assert model.params_["a1"] == pytest.approx(truth.params["a2"], rel=0.02)
    assert model.functions_["f1"](1.0) - model.functions_["f1"](0.0) == pytest.approx(
        truth.params["a1"], rel=0.05)
    assert model.n_parameters_ == 3
    again = pickle.loads(pickle.dumps(model))
    assert np.allclose(again.predict(X.assign(x2=0.1)), model.predict(X.assign(x2=0.1)))
    assert clone(model).get_params() == model.get_params()


def test_a_constraint_it_cannot_hold_is_refused():
    frame = datasets.make_oscillator(hidden=[])
    with pytest.raises(ValueError, match="LineBackend holds no constraints, and f1"):
        LineCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - x1"],
                        constraints=["f1 odd"]).fit(frame[["t", "x1", "F_ext"]])
