"""The filter against the exact discrete Kalman filter, on a two-state Ornstein-Uhlenbeck record.

The record is made as the reference SDE tools' textbook example is:
``dx1 = theta (mu + u - x1) dt + s1 dW``, ``dx2 = alpha (x1 - x2) dt + s2 dW``,
both states measured with white noise, the input held between samples. Its
exact discretisation (transition, held input and Van Loan's noise) gives the
reference likelihood, with and without missing samples.
"""

import warnings

import numpy as np
import pandas as pd
import pytest
from scipy.linalg import expm
from sklearn.exceptions import NotFittedError

from sklearn_pycc import PolyCCRegressor
from sklearn_pycc.diagnostics import check_innovations

THETA, MU, ALPHA, S1, S2, R = 2.0, 1.0, 1.0, 0.5, 0.3, 0.1
FREE = ["x1_dot = a1*(a2 + u - x1)", "x2_dot = a3*(x1 - x2)"]
GIVEN = [f"x1_dot = {THETA}*({MU} + u - x1)", f"x2_dot = {ALPHA}*(x1 - x2)"]
START = {"x1": (1.0, 0.1), "x2": (1.0, 0.1)}


def _discrete(theta, mu, alpha, s1, s2, h):
    """The exact transition, held-input gain and process noise over a step ``h``."""
    A = np.array([[-theta, 0.0], [alpha, -alpha]])
    phi = expm(A * h)
    block = expm(np.block([[-A, np.diag([s1**2, s2**2])], [np.zeros((2, 2)), A.T]]) * h)
    gain = np.linalg.solve(A, phi - np.eye(2)) @ np.array([theta, 0.0])
    return phi, gain * 1.0, block[2:, 2:].T @ block[:2, 2:], mu


def _record(n: int, h: float, seed: int, *, missing: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    phi, gain, noise, mu = _discrete(THETA, MU, ALPHA, S1, S2, h)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 20 + 1), 20)[:n]
    x, states = np.array([1.0, 1.0]), []
    root = np.linalg.cholesky(noise)
    for k in range(n):
        states.append(x.copy())
        x = phi @ x + gain * (mu + u[k]) + root @ rng.standard_normal(2)
    states = np.array(states) + R * rng.standard_normal((n, 2))
    X = pd.DataFrame({"t": np.arange(n) * h, "u": u, "x1": states[:, 0], "x2": states[:, 1]})
    for name in ("x1", "x2")[:2 if missing else 0]:
        X.loc[rng.choice(n, missing, replace=False), name] = np.nan
    return X


def _exact_log_likelihood(X, h, numbers, noise_sd, start_mean, start_cov) -> float:
    """The exact discrete Kalman filter's log-likelihood, each sample updated by what it holds."""
    phi, gain, noise, mu = _discrete(*numbers, h)
    mean, cov, total = np.asarray(start_mean, float), np.asarray(start_cov, float), 0.0
    for k, y in enumerate(X[["x1", "x2"]].to_numpy()):
        have = np.isfinite(y)
        H = np.eye(2)[have]
        S = H @ cov @ H.T + np.diag(np.asarray(noise_sd)[have] ** 2)
        nu = y[have] - H @ mean
        total -= 0.5 * (nu @ np.linalg.solve(S, nu) + np.log(np.linalg.det(S))
                        + have.sum() * np.log(2 * np.pi))
        K = cov @ H.T @ np.linalg.inv(S)
        mean, cov = mean + K @ nu, cov - K @ S @ K.T
        mean, cov = phi @ mean + gain * (mu + X.u.iloc[k]), phi @ cov @ phi.T + noise
    return total


def _given(**settings) -> PolyCCRegressor:
    return PolyCCRegressor(equations=GIVEN, fit_mode="filter", input_hold="zoh",
                           process_noise={"x1": S1, "x2": S2},
                           measurement_noise={"x1": R, "x2": R}, **settings)


@pytest.mark.parametrize("h", [0.05, 0.3, 1.0])  # theta h from 0.1 to 2
@pytest.mark.parametrize("missing", [0, 150])
def test_a_given_linear_model_has_the_exact_discrete_likelihood(h, missing):
    X = _record(800, h, seed=1, missing=missing)
    # every number given: nothing to fit, the likelihood of that model
    model = _given(initial_state=START)
    exact = _exact_log_likelihood(X, h, (THETA, MU, ALPHA, S1, S2), [R, R], [1.0, 1.0],
                                  np.diag([0.1, 0.1]))
    assert model.log_likelihood(X) == pytest.approx(exact, abs=0.05)
    assert not hasattr(model, "params_")  # evaluated, not fitted


@pytest.mark.parametrize("missing", [pytest.param(0, marks=pytest.mark.slow), 100])
def test_a_fitted_linear_model_has_the_exact_discrete_likelihood(missing):
    X = _record(600, 0.3, seed=2, missing=missing)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=FREE, fit_mode="filter", input_hold="zoh").fit(X)
    a, q, r = model.params_, model.process_noise_, model.measurement_noise_
    for name, truth in {"a1": THETA, "a2": MU, "a3": ALPHA}.items():
        assert abs(a[name] - truth) < 3 * model.params_std_[name]
    for name, truth in {"x1": S1, "x2": S2}.items():
        assert 0 < model.process_noise_std_[name] < 0.3 * q[name]
        assert abs(q[name] - truth) < 3 * model.process_noise_std_[name]
    for name in ("x1", "x2"):
        assert 0 < model.measurement_noise_std_[name] < r[name]
        assert abs(r[name] - R) < 3 * model.measurement_noise_std_[name]
    # the filter starts each experiment at its first sample, with the states' spread
    first = [X.x1.dropna().iloc[0], X.x2.dropna().iloc[0]]
    spread = np.diag([np.nanmean(X.x1**2), np.nanmean(X.x2**2)])
    exact = _exact_log_likelihood(X, 0.3, (a["a1"], a["a2"], a["a3"], q["x1"], q["x2"]),
                                  [r["x1"], r["x2"]], first, spread)
    assert model.log_likelihood(X) == pytest.approx(exact, abs=0.05)


def test_a_held_measurement_noise_is_kept_and_has_no_error():
    X = _record(400, 0.3, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=FREE, fit_mode="filter", input_hold="zoh",
                                measurement_noise={"x1": 0.2}).fit(X)
    assert model.measurement_noise_["x1"] == 0.2
    assert model.measurement_noise_std_["x1"] == 0.0
    assert model.measurement_noise_["x2"] == pytest.approx(R, rel=0.3)


def test_the_filter_starts_where_the_user_says():
    X = _record(300, 0.3, seed=4)
    near = _given(initial_state=START).log_likelihood(X)
    far = _given(initial_state={"x1": (5.0, 0.01), "x2": 1.0}).log_likelihood(X)
    broad = _given().log_likelihood(X)  # the record's first sample, broad
    assert far < near - 100  # a start 40 standard deviations away from the first sample
    assert broad == pytest.approx(near, abs=5.0)


def test_an_unfitted_model_with_numbers_left_to_fit_names_them():
    X = _record(200, 0.3, seed=5)
    model = PolyCCRegressor(equations=FREE, fit_mode="filter", measurement_noise={"x1": R})
    with pytest.raises(NotFittedError, match=r"a1, a2, a3, the process noise of x1, "
                       r"the process noise of x2, the measurement noise of x2 are not"):
        model.log_likelihood(X)


def test_the_filters_methods_read_through_missing_samples():
    X = _record(400, 0.3, seed=6, missing=60)
    model = _given(initial_state=START)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = model.fit(X)  # nothing to fit: the given model, fitted
    smooth = model.smooth(X)
    assert len(smooth) == len(X) and np.isfinite(smooth[["x1", "x2"]]).all().all()
    lost = X.x1.isna().to_numpy()
    innovations = model.innovations(X)
    assert innovations.x1.isna().to_numpy().sum() == lost.sum()
    assert innovations.x2.notna().sum() == X.x2.notna().sum()
    # a missing sample is smoothed from its neighbours, within its band
    inside = ((smooth.x1_lower <= smooth.x1) & (smooth.x1 <= smooth.x1_upper))[lost]
    assert inside.all()
    check = check_innovations(model, X)  # the right model: white through the gaps
    assert check.tests["white"].all() and np.isfinite(check.tests["ljung_box_p"]).all()


def test_auto_mode_recognises_the_push_on_the_textbook_record():
    # on this draw the grid of noises alone left the errors lasting (Ljung-Box p 5e-8)
    X = _record(800, 0.3, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=FREE, input_hold="zoh").fit(X)
    assert model.fit_mode_ == "filter" and model.process_noise_evidence_.recognised
    assert check_innovations(model, _record(800, 0.3, seed=11)).tests["white"].all()


@pytest.mark.parametrize(("settings", "match"), [
    ({"initial_state": {"x3": 1.0}}, r"initial_state names 'x3'"),
    ({"initial_state": {"x1": (1.0, -0.1)}}, r"initial_state\['x1'\] must be"),
    ({"initial_state": {"x1": "1.0"}}, r"initial_state\['x1'\] must be"),
    ({"measurement_noise": {"x1": 0.0}}, r"measurement_noise\['x1'\] must be a positive"),
    ({"measurement_noise": {"u": 0.1}}, r"measurement_noise names 'u'"),
])
def test_the_filters_settings_are_checked_naming_the_culprit(settings, match):
    X = _record(100, 0.3, seed=7)
    with pytest.raises(ValueError, match=match):
        PolyCCRegressor(equations=FREE, fit_mode="filter", **settings).fit(X)


def test_settings_only_the_filter_reads_are_said_to_be_unused_elsewhere():
    X = _record(200, 0.3, seed=8)
    with pytest.warns(UserWarning, match=r"measurement_noise is read by "
                      r"the filter.*does not use it"):
        PolyCCRegressor(equations=FREE, fit_mode="simulation", measurement_noise={"x1": R},
                        initial_state={"x1": 1.0}).fit(X)


def test_a_missing_sample_splits_the_experiment_outside_the_filter_and_says_so():
    X = _record(200, 0.3, seed=9)
    whole = PolyCCRegressor(equations=FREE, fit_mode="simulation").fit(X)
    X.loc[50, "x2"] = np.nan
    with pytest.warns(UserWarning, match=r"x2 misses 1 sample\(s\) \(NaN\): "
                      r"fit_mode='simulation' splits the record there into 2 experiments.*"
                      r"fit_mode='filter' reads across"):
        split = PolyCCRegressor(equations=FREE, fit_mode="simulation").fit(X)
    for name, value in whole.params_.items():
        assert split.params_[name] == pytest.approx(value, rel=0.05)
    assert list(split.feature_names_in_) == list(X.columns)  # as the user gave them
    course = split.simulate(X["t"], y0=[1.0, 1.0], inputs={"u": X["u"].to_numpy()})
    assert np.isfinite(course["x1"]).all()


def _filter_problem(X):
    from sklearn_pycc.fitting.filter.stage import filter_plan

    estimator = PolyCCRegressor(equations=GIVEN, fit_mode="filter", input_hold="zoh")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem, _ = estimator._problem(X, None, estimator._make_backend())
    right = problem.skeleton.compile({}, {})
    return problem, filter_plan(problem, right, whole=True), right


def test_a_filtered_model_that_simulates_worse_than_its_start_is_said_to():
    # the start follows the record; the 'filtered' one has a level off by a whole unit
    from sklearn_pycc.fitting.filter.stage import _warn_worse_simulation, simulation_error

    X = _record(400, 0.3, seed=10)
    problem, plan, right = _filter_problem(X)
    off = PolyCCRegressor(equations=[f"x1_dot = {THETA}*({MU + 1.0} + u - x1)",
                                      f"x2_dot = {ALPHA}*(x1 - x2)"])._problem(
        X, None)[0].skeleton.compile({}, {})
    assert simulation_error(problem, plan, off) > 1.5 * simulation_error(problem, plan, right)
    q, r = np.array([S1, S2]), np.array([0.001, R])
    with pytest.warns(UserWarning, match=r"simulates the record worse than the output-error "
                      r"fit it started from.*x1: 0\.001 against"):
        _warn_worse_simulation(problem, plan, (right, off), q=q, r=r, level=np.array([R, R]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # as good as its start, or better: nothing to say
        _warn_worse_simulation(problem, plan, (off, right), q=q, r=r, level=np.array([R, R]))
        _warn_worse_simulation(problem, plan, (right, right), q=q, r=r, level=np.array([R, R]))


def test_a_measurement_is_filtered_as_its_frame_is():
    from sklearn_pycc.measurements import Measurement

    X = _record(300, 0.3, seed=12)
    y = pd.DataFrame({f"{s}_dot": np.gradient(X[s].to_numpy(), X.t.to_numpy())
                      for s in ("x1", "x2")})  # a Measurement that carries derivatives too
    model = _given(initial_state=START)
    assert model.log_likelihood(Measurement(X, y)) == pytest.approx(model.log_likelihood(X))
    with pytest.raises(ValueError, match=r"measurement_noise names 'x2', which X does not "
                       r"measure"):
        PolyCCRegressor(equations=FREE, fit_mode="filter", measurement_noise={"x2": 0.1}).fit(
            X.drop(columns="x2"))


def test_the_noise_a_step_adds_is_the_exact_integral_for_short_and_long_steps_alike():
    from sklearn_pycc.fitting.filter.discrete import step_noise

    rng = np.random.default_rng(0)
    # steps short (corrected trapezoid), middling (series) and long (Van Loan) in one batch,
    # a non-normal flow among them, and a diverged variant
    scales = np.array([0.01, 0.05, 0.3, 0.9, 4.0, 20.0])
    A = rng.standard_normal((len(scales), 2, 2)) * scales[:, None, None]
    A[2] = [[0.0, 25.0], [0.0, -0.5]]
    q2, h = rng.uniform(0.1, 1.0, (len(scales), 2)), np.full(len(scales), 0.1)
    F = np.array([expm(a * 0.1) for a in A])
    A[-1, 0, 0] = np.nan
    noise = step_noise(A, q2, h, F)
    for k in range(len(scales) - 1):
        block = expm(np.block([[-A[k], np.diag(q2[k])], [np.zeros((2, 2)), A[k].T]]) * 0.1)
        exact = block[2:, 2:].T @ block[:2, 2:]
        assert np.allclose(noise[k], exact, rtol=1e-4, atol=1e-12 * np.abs(exact).max())
    assert not np.isfinite(noise[-1]).all()
    assert np.all(step_noise(A[:2], q2[:2], np.zeros(2), F[:2]) == 0.0)  # padding adds none
