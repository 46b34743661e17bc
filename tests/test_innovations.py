"""The innovations of a filtered model: white where it is right, telling where it is not."""

import warnings

import matplotlib
import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, check_innovations
from sklearn_pycc.plotting import plot_innovations

STEP, PUSH, NOISE = 0.05, 0.3, 0.02
LINEAR = ["x1_dot = x2", "x2_dot = -a1 x2 - a2 x1"]
DUFFING = ["x1_dot = x2", "x2_dot = -a1 x2 - a2 x1 - a3 x1^3"]


def _pushed_duffing(n: int, seed: int, *, cubic: float = 1.0) -> pd.DataFrame:
    """A damped oscillator with a hardening spring, pushed by white noise; x1 measured."""
    rng = np.random.default_rng(seed)
    x, out, fine = np.array([1.5, 0.0]), [], 20
    dt = STEP / fine
    for _ in range(n):
        out.append(x[0])
        for _ in range(fine):
            force = -0.2 * x[1] - x[0] - cubic * x[0] ** 3
            x = x + np.array([x[1], force]) * dt + np.array(
                [0.0, PUSH * np.sqrt(dt) * rng.standard_normal()])
    return pd.DataFrame({"t": np.arange(n) * STEP,
                         "x1": np.array(out) + NOISE * rng.standard_normal(n)})


def _fit(equations, X):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return PolyCCRegressor(equations=equations, fit_mode="filter").fit(X)


@pytest.fixture(scope="module")
def records():
    return _pushed_duffing(2000, seed=2), _pushed_duffing(2000, seed=3)


@pytest.fixture(scope="module")
def models(records):
    fit_on, _ = records
    return {"linear": _fit(LINEAR, fit_on), "duffing": _fit(DUFFING, fit_on)}


def test_the_right_skeleton_leaves_white_innovations_that_depend_on_nothing(records, models):
    _, fresh = records
    check = check_innovations(models["duffing"], fresh)
    assert check.white and check.depends.empty
    assert list(check.tests.index) == ["x1"]
    assert 0.8 < check.tests.loc["x1", "variance"] < 1.25
    assert check.autocorrelation.index[0] == 1 and len(check.autocorrelation) == 30
    assert (check.autocorrelation["x1"].abs() < 2 * check.band).all()
    assert "x1: innovations white in time" in check.summary()
    assert "depend" not in check.summary()


def test_a_missing_spring_shows_in_what_the_innovations_depend_on(records, models):
    _, fresh = records
    check = check_innovations(models["linear"], fresh)
    top = check.depends.iloc[0]
    # x1 is measured, x1_dot = x2 is exact: the missing force is in the equation of x2
    assert (top["measured"], top["variable"], top["equation"]) == ("x1", "x1", "x2")
    assert "an effect of x1 is missing from the equation of x2" in check.summary()
    # judged on the fresh record by the filter, the hardening spring earns its place
    assert models["duffing"].log_likelihood(fresh) > models["linear"].log_likelihood(fresh) + 5
    matplotlib.use("Agg")
    fig = plot_innovations(check)
    assert len(fig.axes) == 3
    assert fig.axes[2].get_xlabel() == "x1 (predicted)"


def test_coloured_noise_the_model_does_not_know_is_not_white(records, models):
    _, fresh = records
    rng = np.random.default_rng(4)
    drift = np.zeros(len(fresh))
    for k in range(1, len(drift)):
        drift[k] = 0.95 * drift[k - 1] + 0.02 * rng.standard_normal()
    check = check_innovations(models["duffing"], fresh.assign(x1=fresh.x1 + drift))
    assert not check.white
    assert "x1: innovations not white" in check.summary()


def test_the_innovations_line_up_with_the_record(records, models):
    _, fresh = records
    raw = models["duffing"].innovations(fresh)
    assert list(raw.columns) == ["t", "trajectory", "x1", "x1_sd"]
    assert len(raw) == len(fresh) and np.allclose(raw.t, fresh.t)
    assert (raw.x1_sd > 0).all() and (raw.trajectory == 0).all()
    assert np.isfinite(models["duffing"].log_likelihood(fresh))


def test_only_a_filtered_model_has_innovations(records):
    fit_on, _ = records
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=LINEAR, fit_mode="simulation").fit(fit_on.iloc[:500])
    with pytest.raises(ValueError, match="innovations needs a model fitted with"):
        check_innovations(model, fit_on)
    with pytest.raises(ValueError, match="log_likelihood needs a model fitted with"):
        model.log_likelihood(fit_on)


def test_a_few_innovations_are_not_called_white(records, models):
    _, fresh = records
    # three samples pass any test of whiteness: the check refuses, naming how many it got
    with pytest.raises(ValueError, match=r"at least 20 innovations .* X gives 3"):
        check_innovations(models["duffing"], fresh.iloc[:3])
    assert check_innovations(models["duffing"], fresh.iloc[:400]).tests.shape[0] == 1
