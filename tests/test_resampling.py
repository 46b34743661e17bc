"""Refits on resamples that respect time (``n_bootstrap``), for every backend.

The resamples are blocks of consecutive samples within each experiment (or
whole experiments when there are many); their spread must agree with the
covariance where both exist, be reproducible from ``random_state`` and not
depend on ``n_jobs``; a network's covariance comes from its last layers.
"""

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from joblib import parallel_backend
from scipy.signal import lfilter
from scipy.stats import t as student
from sklearn.utils._param_validation import InvalidParameterError

from sklearn_pycc import (
    NeuralCCRegressor,
    PolyCCRegressor,
    Skeleton,
    SymbolicCCRegressor,
    datasets,
)
from sklearn_pycc.estimators.base import CCRegressor, make_problem
from sklearn_pycc.estimators.poly import PolyBackend
from sklearn_pycc.fitting.uncertainty.resampling import Resampler

TRUE = ["x1_dot = x2", "x2_dot = F - a1 x2 - a2 x1 - a3 x1^3"]
HYBRID = ["x1_dot = x2", "x2_dot = F - a1 x2 - f1(x1)"]
FORCE = {"F": lambda t: 0.5 * np.cos(1.2 * t)}


def record(n=3000, rho=0.0, seed=0, t_end=60.0, experiments=1):
    """A forced Duffing oscillator; noise (white or AR(1)) on the measured acceleration."""
    frames = []
    rng = np.random.default_rng(seed)
    for k in range(experiments):
        t = np.linspace(0, t_end, n)
        frame = Skeleton(TRUE).simulate(t, [1.0 + 0.2 * k, 0.0],
                                        params={"a1": 0.3, "a2": -1.0, "a3": 1.0},
                                        inputs=FORCE, return_derivatives=True)
        e = rng.standard_normal(n)
        if rho:
            e = lfilter([np.sqrt(1 - rho**2)], [1, -rho], e)
        frame["x2_dot"] += 0.05 * frame["x2_dot"].std() * e
        frame["trajectory"] = k
        frames.append(frame)
    frame = pd.concat(frames, ignore_index=True)
    X = frame[["t", "trajectory", "x1", "x2", "F"]]
    return (X if experiments > 1 else X.drop(columns="trajectory")), frame[["x1_dot", "x2_dot"]]


def test_the_bootstrap_agrees_with_the_covariance_on_coloured_noise():
    X, y = record(rho=0.9)
    settings = dict(equations=HYBRID, constraints=["f1(0)=0"], degree=5)
    covariance = PolyCCRegressor(**settings).fit(X, y)
    model = PolyCCRegressor(**settings, n_bootstrap=60, random_state=0).fit(X, y)
    assert model.params_ == covariance.params_  # the estimate itself is the full fit's
    assert list(model.bootstrap_params_.columns) == ["a1"]
    assert len(model.bootstrap_params_) == 60
    assert "blocks of" in model.bootstrap_method_
    ratio = model.params_std_["a1"] / covariance.params_std_["a1"]
    assert 0.7 < ratio < 1.4, ratio
    # the bands of the curve agree too, and grow where the data say less
    grid = {"f1": (-1.0, 1.0)}
    boot = model.cc_curves(n=21, level=0.9, domain=grid)["f1"]
    cov = covariance.cc_curves(n=21, level=0.9, domain=grid)["f1"]
    widths = (boot.upper - boot.lower).to_numpy(), (cov.upper - cov.lower).to_numpy()
    away = np.abs(boot.x.to_numpy()) > 0.3
    assert 0.6 < np.median(widths[0][away] / widths[1][away]) < 1.6
    # blocks hold the correlation: longer than for white noise
    white = PolyCCRegressor(**settings, n_bootstrap=2, random_state=0).fit(*record(rho=0.0))
    assert int(model.bootstrap_method_.split()[2]) > int(white.bootstrap_method_.split()[2])


def test_a_few_refits_give_wide_intervals_not_narrow_ones():
    X, y = record(n=800)
    two = PolyCCRegressor(equations=TRUE, n_bootstrap=2, random_state=0).fit(X, y)
    low, high = two.params_interval(0.95)["a1"]
    # Student's quantile with one degree of freedom: 12.7 standard deviations
    assert (high - low) / 2 == pytest.approx(student.ppf(0.975, 1) * two.params_std_["a1"])


def test_resamples_are_reproducible_and_do_not_depend_on_n_jobs():
    X, y = record(n=800)
    settings = dict(equations=HYBRID, constraints=["f1(0)=0"], degree=5, n_bootstrap=8)
    one = PolyCCRegressor(**settings, random_state=3, n_jobs=1).fit(X, y)
    two = PolyCCRegressor(**settings, random_state=3, n_jobs=2).fit(X, y)
    pd.testing.assert_frame_equal(one.bootstrap_params_, two.bootstrap_params_)
    other = PolyCCRegressor(**settings, random_state=4).fit(X, y)
    assert not one.bootstrap_params_.equals(other.bootstrap_params_)
    t = X["t"].to_numpy()[:200]
    bands = [m.simulate(t, [1.0, 0.0], inputs=FORCE, level=0.9, random_state=0)
             for m in (one, two)]
    pd.testing.assert_frame_equal(*bands)
    assert (bands[0].x1_lower <= bands[0].x1_upper).all()


def test_blocks_stay_within_experiments_and_many_experiments_are_drawn_whole():
    X, y = record(n=300, experiments=3)
    model = PolyCCRegressor(equations=TRUE, n_bootstrap=4, random_state=0).fit(X, y)
    assert model.bootstrap_method_.endswith("each of the 3 experiment(s)")
    problem = make_problem(model, X, y)
    resampler = Resampler(problem, np.zeros((problem.data.n_samples, 1)))
    labels = X["trajectory"].to_numpy()
    for block in resampler.draw(np.random.default_rng(0)):
        assert len(np.unique(labels[block])) == 1
        assert np.all(np.diff(block) == 1)
    many = PolyCCRegressor(equations=TRUE, n_bootstrap=4, random_state=0).fit(
        *record(n=60, experiments=10))
    assert many.bootstrap_method_ == "whole experiments (10) drawn with replacement"
    assert np.isfinite(list(many.params_std_.values())).all()


def test_a_network_has_parameter_errors_for_free_and_bands_from_its_ensemble():
    X, y = record(n=1200, t_end=40.0)
    settings = dict(equations=HYBRID, constraints=["f1(0)=0"], hidden_layer_sizes=(16,),
                    random_state=0)
    plain = NeuralCCRegressor(**settings).fit(X, y)
    poly = PolyCCRegressor(equations=HYBRID, constraints=["f1(0)=0"]).fit(X, y)
    # the last layers' linearisation: the polynomial fit's standard error, near enough
    assert list(plain.covariance_.index) == ["a1"]
    ratio = plain.params_std_["a1"] / poly.params_std_["a1"]
    assert 0.7 < ratio < 1.4, ratio
    low, high = plain.params_interval(0.95)["a1"]
    assert low < 0.3 < high
    ensemble = [NeuralCCRegressor(**settings, n_bootstrap=4, n_jobs=1).fit(X, y)]
    with parallel_backend("threading"):  # worker processes would each import torch first
        ensemble.append(NeuralCCRegressor(**settings, n_bootstrap=4, n_jobs=2).fit(X, y))
    pd.testing.assert_frame_equal(ensemble[0].bootstrap_params_, ensemble[1].bootstrap_params_)
    member = ensemble[0].bootstrap_[0].functions["f1"]
    assert type(member).__module__.endswith("numpy_mlp")  # kept as numpy
    curve = ensemble[0].cc_curves(n=31, level=0.95)["f1"]
    truth = -curve.x + curve.x**3
    assert np.mean((curve.lower <= truth) & (truth <= curve.upper)) > 0.6
    assert (curve.upper - curve.lower).min() >= 0
    # beyond the data every network continues its edge slope: no band there
    lo, hi = ensemble[0].curve_ranges_["f1"]
    wide = ensemble[0].cc_curves(n=41, level=0.95, domain=(lo - 1, hi + 1))["f1"]
    outside = (wide.x < lo) | (wide.x > hi)
    assert wide.lower[outside].isna().all() and wide.upper[~outside].notna().all()


def test_a_symbolic_fit_is_refitted_on_resamples():
    frame = datasets.make_stick_slip(n_samples=400, noise=30, random_state=0,
                                     noise_columns=["F_ext"])
    model = SymbolicCCRegressor(
        equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - f1(x1)"], constraints=["f1 odd"],
        generations=3, population_size=50, max_iterations=1, random_state=0, n_bootstrap=3)
    model.fit(frame[["x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]])
    assert len(model.bootstrap_params_) == 3
    assert model.params_std_["a1"] > 0
    band = model.cc_curves(n=11, level=0.9)["f1"]
    assert (band.upper >= band.lower).all()


def test_an_output_error_fit_is_refitted_by_output_error():
    frame = datasets.make_stick_slip(n_samples=600, noise=30, noise_columns=["x1"],
                                     random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"],
                                fit_mode="simulation", shooting_iterations=5, n_bootstrap=3,
                                random_state=0).fit(frame[["t", "x1", "F_ext"]])
    # every block holds whole shooting segments
    assert int(model.bootstrap_method_.split()[2]) >= 2 * model.shooting_window
    assert all(v > 0 for v in model.params_std_.values())


@pytest.mark.parametrize("value", [-1, 1.5, "3"])
def test_n_bootstrap_is_checked(value):
    X, y = record(n=100)
    with pytest.raises((InvalidParameterError, ValueError), match="n_bootstrap"):
        PolyCCRegressor(equations=TRUE, n_bootstrap=value).fit(X, y)


def test_one_resample_is_refused_and_failed_refits_are_counted():
    X, y = record(n=100)
    with pytest.raises(ValueError, match="at least 2, got 1"):
        PolyCCRegressor(equations=TRUE, n_bootstrap=1).fit(X, y)

    class FragileBackend(PolyBackend):
        calls = 0

        def fit(self, problem):
            if not problem.covariance and problem.data.trajectory is not None:
                FragileBackend.calls += 1
                if FragileBackend.calls % 2:
                    raise ValueError("singular on this resample")
            return super().fit(problem)

    class Fragile(PolyCCRegressor):
        def _make_backend(self):
            return FragileBackend(**self._backend_settings(FragileBackend))

    with pytest.warns(UserWarning, match=r"2 of 4 refits on resamples failed.*singular"):
        model = Fragile(equations=TRUE, n_bootstrap=4, n_jobs=1).fit(X, y)
    assert len(model.bootstrap_params_) == 2
    assert math.isfinite(model.params_std_["a1"])


def test_the_base_class_takes_no_resampling_parameters():
    assert "n_bootstrap" not in CCRegressor._parameter_constraints
    for backend in (PolyCCRegressor, NeuralCCRegressor, SymbolicCCRegressor):
        params = backend().get_params()
        assert params["n_bootstrap"] == 0 and params["n_jobs"] is None
