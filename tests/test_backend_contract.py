"""The backend contract: one method returning a FitResult; the estimator stores it."""

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import CCRegressor
from sklearn_pycc.estimators.backend import Backend, FitResult


class Proportional(Backend):
    """A toy backend: every curve is a line through zero fitted by least squares alone."""

    def fit(self, problem):
        x = problem.data.columns["x1"]
        target = problem.y[:, 0]
        slope = float(x @ target / (x @ x))
        curves = {name: (lambda u, s=slope: s * np.asarray(u, dtype=float))
                  for name in problem.skeleton.functions}
        return FitResult(curves, {}, {"slope_": slope})


class ProportionalCurves(CCRegressor):
    def _make_backend(self):
        return Proportional()


def test_a_backend_is_one_method_and_the_base_does_the_rest():
    x = np.linspace(-1.0, 1.0, 50)
    X, y = pd.DataFrame({"x1": x}), pd.DataFrame({"x1_dot": -0.5 * x})
    model = ProportionalCurves(equations=["x1_dot = f1(x1)"]).fit(X, y)
    assert model.slope_ == pytest.approx(-0.5)
    assert model.score(X, y) == pytest.approx(1.0)
    sim = model.simulate(np.linspace(0.0, 2.0, 21), [1.0])
    assert sim["x1"].iloc[-1] == pytest.approx(np.exp(-1.0), rel=1e-5)
    assert model.curve_ranges_["f1"] == (-1.0, 1.0)
    assert model.n_parameters_ == 0  # the backend counts nothing for its curves


def test_fitted_attributes_must_end_in_an_underscore():
    with pytest.raises(ValueError, match="end in '_'"):
        FitResult({}, {}, {"slope": 1.0})


def test_a_backend_takes_exactly_its_settings():
    from sklearn_pycc import PolyCCRegressor
    from sklearn_pycc.estimators.poly import PolyBackend

    backend = PolyCCRegressor(degree=3)._make_backend()
    assert isinstance(backend, PolyBackend) and backend.degree == 3
    assert repr(backend).startswith("PolyBackend(degree=3, basis='legendre'")
    with pytest.raises(TypeError, match=r"missing \['basis'"):
        PolyBackend(degree=3)
    with pytest.raises(TypeError, match=r"unknown \['n_jobs'\]"):
        PolyBackend(**PolyCCRegressor()._backend_settings(PolyBackend), n_jobs=2)
