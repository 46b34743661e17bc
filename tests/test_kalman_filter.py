"""The extended Kalman filter of a skeleton: its likelihood, and the numbers that maximise it."""

import warnings

import numpy as np
import pandas as pd
import pytest
from benchmark_scripts import load
from conftest import LATE_INPUT
from scipy.linalg import expm

from sklearn_pycc import NeuralCCRegressor, PolyCCRegressor, Skeleton, datasets
from sklearn_pycc.fitting.filter import fit_filter, kalman_pass, smoothed
from sklearn_pycc.fitting.filter.stage import filter_plan
from sklearn_pycc.fitting.output_error.shooting import ShootingPlan

OSCILLATOR = ["x1_dot = x2", "x2_dot = -a1 x2 - a2 x1"]
A1, A2, Q, R, STEP = 0.2, 1.0, 0.3, 0.05, 0.05


def _pushed_oscillator(n: int, seed: int, *, truth: bool = False):
    """A damped oscillator pushed by white noise (Euler-Maruyama on a fine grid), x1 measured.

    With ``truth``, the true states ``(n, 2)`` too.
    """
    rng = np.random.default_rng(seed)
    A = np.array([[0.0, 1.0], [-A2, -A1]])
    x, out, fine = np.array([1.0, 0.0]), [], 20
    dt = STEP / fine
    for _ in range(n):
        out.append(x.copy())
        for _ in range(fine):
            x = x + A @ x * dt + np.array([0.0, Q * np.sqrt(dt) * rng.standard_normal()])
    states = np.array(out)
    X = pd.DataFrame({"t": np.arange(n) * STEP, "x1": states[:, 0] + R * rng.standard_normal(n)})
    return (X, states) if truth else X


def _plan(X: pd.DataFrame, window: int):
    estimator = PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem, _ = estimator._problem(X, None, estimator._make_backend())
    plan = ShootingPlan(problem, window)
    plan.choose_substeps(problem.skeleton.compile({}, {"a1": A1, "a2": A2}),
                         dict(problem.data.columns))
    return problem, plan


@pytest.fixture(scope="module")
def record():
    return _pushed_oscillator(2000, seed=0)


def test_the_likelihood_is_the_exact_kalman_filters_on_a_linear_skeleton(record):
    problem, plan = _plan(record, len(record))  # one segment: the filter runs through
    system = problem.skeleton.compile({}, {"a1": A1, "a2": A2})
    run = kalman_pass(plan, system, np.array([[0.0, Q]]), np.array([[R]]))
    # the same model discretised exactly (the transition matrix and Van Loan's noise)
    A = np.array([[0.0, 1.0], [-A2, -A1]])
    phi = expm(A * STEP)
    block = expm(np.block([[-A, np.diag([0.0, Q**2])], [np.zeros((2, 2)), A.T]]) * STEP)
    noise = block[2:, 2:].T @ block[:2, 2:]
    mean, cov, nll = plan.initial[0].copy(), np.diag(plan.scale**2), 0.0
    for y in record.x1:
        s = cov[0, 0] + R**2
        nu = y - mean[0]
        nll += 0.5 * (nu**2 / s + np.log(s) + np.log(2 * np.pi))
        gain = cov[:, 0] / s
        mean, cov = mean + gain * nu, cov - np.outer(gain, cov[0])
        mean, cov = phi @ mean, phi @ cov @ phi.T + noise
    assert run.nll[0] == pytest.approx(nll, abs=0.05)
    assert run.innovations.shape == (1, len(record), 1) and run.terms.sum() == \
        pytest.approx(run.nll[0])
    # white innovations of unit variance once scaled: the model is the one that made them
    scaled = (run.innovations[0, 50:, 0] / np.sqrt(run.variances[0, 50:, 0]))
    assert np.std(scaled) == pytest.approx(1.0, abs=0.1)
    assert abs(np.corrcoef(scaled[:-1], scaled[1:])[0, 1]) < 0.1


def test_variants_filtered_side_by_side_are_each_filtered_as_alone(record):
    problem, plan = _plan(record, 200)
    numbers = [(0.2, 1.0, 0.3, 0.05), (0.4, 0.8, 0.1, 0.1), (0.1, 1.2, 0.5, 0.02)]
    systems = [problem.skeleton.compile({}, {"a1": a, "a2": b}) for a, b, _, _ in numbers]
    together = kalman_pass(plan, systems, np.array([[0.0, q] for *_, q, _ in numbers]),
                           np.array([[r] for *_, r in numbers]), keep=True)
    for k, (system, (_, _, q, r)) in enumerate(zip(systems, numbers)):
        alone = kalman_pass(plan, system, np.array([[0.0, q]]), np.array([[r]]))
        assert together.nll[k] == pytest.approx(alone.nll[0], rel=1e-9)
    assert together.means.shape == (3, plan.n_segments, plan.n_steps + 1, 2)
    # the truth is the likeliest of the three
    assert np.argmin(together.nll) == 0


def test_a_filter_that_diverges_has_no_likelihood(record):
    _, plan = _plan(record, 200)
    # the velocity runs away within a step: no measurement of the position can hold it
    exploding = Skeleton(["x1_dot = x2", "x2_dot = a1 x2^3"]).compile({}, {"a1": 1e6})
    assert kalman_pass(plan, exploding, np.array([[0.0, Q]]), np.array([[R]])).nll[0] == np.inf
    # an unstable system the measurements keep in check is only unlikely
    skeleton = Skeleton(OSCILLATOR)
    unstable = skeleton.compile({}, {"a1": -5.0, "a2": 1.0})
    truth = skeleton.compile({}, {"a1": A1, "a2": A2})
    both = kalman_pass(plan, [unstable, truth], np.array([[0.0, Q]] * 2), np.array([[R]] * 2))
    assert np.isfinite(both.nll).all() and both.nll[0] > both.nll[1] + 100


def test_the_parameters_and_noise_intensities_are_recovered_with_honest_errors(record):
    problem, plan = _plan(record, 200)

    def system_for(theta):
        return problem.skeleton.compile({}, {"a1": theta[0], "a2": theta[1]})

    theta, q, r, info = fit_filter(plan, system_for, np.array([0.5, 0.8]),
                                   np.array([0.0, 0.05]), np.array([0.2]), noisy=[1])
    assert info["converged"]
    errors = np.sqrt(np.diag(info["covariance"]))
    assert np.all(np.abs(theta - [A1, A2]) < 3 * errors)
    assert np.all(errors < [0.1, 0.1])
    assert q[0] == 0.0 and q[1] == pytest.approx(Q, rel=0.2)
    assert r[0] == pytest.approx(R, rel=0.2)


def test_an_estimator_fitted_by_the_filter_says_what_pushed_it(record):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(record)
        output_error = PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation").fit(record)
    assert model.fit_mode_ == "filter"
    assert "extended Kalman filter" in model.derivative_source_
    truth = {"a1": A1, "a2": A2}
    for name, value in truth.items():
        assert abs(model.params_[name] - value) < 3 * model.params_std_[name]
    # x1_dot = x2 is exact: only the force's equation is pushed
    assert model.process_noise_["x1"] == 0.0
    assert model.process_noise_["x2"] == pytest.approx(Q, rel=0.2)
    assert model.measurement_noise_["x1"] == pytest.approx(R, rel=0.2)
    assert model.filter_["converged"] and model.filter_["segments"] == 10
    # the output-error fit chases the wander: its damping is further from the truth
    assert abs(output_error.params_["a1"] - A1) > abs(model.params_["a1"] - A1)
    lows, highs = zip(*model.params_interval(0.95).values())
    assert all(low < value < high for low, high, value in zip(lows, highs, truth.values()))


def test_several_experiments_are_filtered_each_on_its_own():
    first, second = _pushed_oscillator(1000, seed=3), _pushed_oscillator(1000, seed=4)
    both = pd.concat([first.assign(trajectory=0), second.assign(trajectory=1)],
                     ignore_index=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(both)
    assert model.fit_mode_ == "filter" and model.filter_["segments"] == 10
    for name, value in {"a1": A1, "a2": A2}.items():
        assert abs(model.params_[name] - value) < 3 * model.params_std_[name]
    # no information crosses from one experiment to the next: the likelihood is the sum (but
    # for each one's broad start, the states' spread over the record it is read from)
    alone = model.log_likelihood(first) + model.log_likelihood(second)
    assert model.log_likelihood(both) == pytest.approx(alone, rel=1e-3)
    errors = model.innovations(both)
    assert sorted(set(errors["trajectory"])) == [0, 1] and len(errors) == len(both)


@pytest.mark.parametrize("settings, match", [
    ({"equations": OSCILLATOR, "noise_model": "ar"}, "noise_model is for output-error"),
    ({"equations": OSCILLATOR, "n_bootstrap": 5}, "n_bootstrap is for output-error"),
])
def test_the_filter_refuses_what_it_cannot_fit_yet_naming_it(record, settings, match):
    with pytest.raises(ValueError, match=match):
        PolyCCRegressor(fit_mode="filter", **settings).fit(record.iloc[:300])


def _pushed_cubic_friction(n: int, seed: int):
    """An oscillator with friction 0.2 v + 0.3 v^3, pushed by white noise; x1 measured."""
    rng = np.random.default_rng(seed)
    x, out, fine = np.array([1.5, 0.0]), [], 20
    dt = STEP / fine
    for _ in range(n):
        out.append(x.copy())
        for _ in range(fine):
            friction = 0.2 * x[1] + 0.3 * x[1] ** 3
            x = x + np.array([x[1], -friction - x[0]]) * dt + np.array(
                [0.0, Q * np.sqrt(dt) * rng.standard_normal()])
    states = np.array(out)
    return pd.DataFrame({"t": np.arange(n) * STEP,
                         "x1": states[:, 0] + R * rng.standard_normal(n)}), states


def test_a_polynomial_curve_is_fitted_by_the_filter_with_its_band():
    X, states = _pushed_cubic_friction(2000, seed=1)
    settings = {"equations": ["x1_dot = x2", "x2_dot = -f1(x2) - a2 x1"],
                "constraints": ["f1 odd"], "degree": 3}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(fit_mode="filter", **settings).fit(X)
        output_error = PolyCCRegressor(fit_mode="simulation", **settings).fit(X)
    assert model.filter_["held"] == [] and model.filter_["converged"]
    assert {"a2", "f1[1]", "f1[3]"} <= set(model.covariance_.index)
    v = np.array([-1.0, -0.5, 0.5, 1.0])
    truth = 0.2 * v + 0.3 * v**3
    sd = model.backend_.curve_sd(model, "f1", v)
    assert np.all(np.abs(model.functions_["f1"](v) - truth) < 3 * sd)
    # the output-error fit chases the wander; the filter's curve is nearer the truth
    assert np.abs(model.functions_["f1"](v) - truth).sum() < \
        np.abs(output_error.functions_["f1"](v) - truth).sum()
    assert abs(model.params_["a2"] - 1.0) < 3 * model.params_std_["a2"]
    smooth = model.smooth(X)
    inside = np.mean((smooth.x2_lower <= states[:, 1]) & (states[:, 1] <= smooth.x2_upper))
    assert 0.9 <= inside <= 0.99


def test_a_neural_curve_is_refitted_by_the_filter():
    # the networks' last layers move with the parameters: the curve the output error drew
    # while chasing the wander is corrected, and the push is read at its true intensity
    X, states = _pushed_cubic_friction(2000, seed=1)
    settings = {"equations": ["x1_dot = x2", "x2_dot = -f1(x2) - a2 x1"],
                "constraints": ["f1 odd"], "max_epochs": 200, "random_state": 0}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = NeuralCCRegressor(fit_mode="filter", **settings).fit(X)
        output_error = NeuralCCRegressor(fit_mode="simulation", **settings).fit(X)
    assert model.filter_["held"] == [] and model.filter_["converged"]
    v = np.array([-1.0, -0.5, 0.5, 1.0])
    truth = 0.2 * v + 0.3 * v**3
    assert np.abs(model.functions_["f1"](v) - truth).max() < 0.06
    assert np.abs(model.functions_["f1"](v) - truth).sum() < \
        0.5 * np.abs(output_error.functions_["f1"](v) - truth).sum()
    assert abs(model.params_["a2"] - 1.0) < 3 * model.params_std_["a2"]
    assert model.process_noise_["x2"] == pytest.approx(Q, rel=0.2)
    smooth = model.smooth(X)
    inside = np.mean((smooth.x2_lower <= states[:, 1]) & (states[:, 1] <= smooth.x2_upper))
    assert 0.9 <= inside <= 0.99


def _filtered_with(record, **process_noise):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter", **process_noise).fit(
            record)


@pytest.fixture(scope="module")
def free(record):
    return _filtered_with(record)


def test_the_user_holds_the_process_noise(record, free):
    held = _filtered_with(record, process_noise={"x2": Q})
    assert free.process_noise_ == {"x1": 0.0, "x2": pytest.approx(Q, rel=0.1)}
    assert held.process_noise_ == {"x1": 0.0, "x2": Q}  # held exactly, the rest refitted
    for name, value in {"a1": A1, "a2": A2}.items():
        assert abs(held.params_[name] - value) < 3 * held.params_std_[name]
    assert held.filter_["nll"] == pytest.approx(free.filter_["nll"], abs=2.0)


def test_the_user_shares_or_removes_the_process_noise(record, free):
    shared = _filtered_with(record, process_noise={"x1": "push", "x2": "push"})
    calm = _filtered_with(record, process_noise={"x2": 0})
    # one intensity for both states: a worse account of a push that enters one
    assert shared.process_noise_["x1"] == shared.process_noise_["x2"] > 0
    assert shared.filter_["nll"] > free.filter_["nll"] + 10
    # no push at all: the wander is then read as measurement noise, far less likely
    assert calm.process_noise_ == {"x1": 0.0, "x2": 0.0}
    assert calm.filter_["nll"] > free.filter_["nll"] + 1000


@pytest.mark.parametrize("process_noise, match", [
    ({"x3": 0.1}, r"process_noise names 'x3', which is not a state of the skeleton "
                  r"\(states: x1, x2\)"),
    ({"x2": -0.1}, r"process_noise\['x2'\] must be a non-negative intensity"),
    ({"x2": float("nan")}, r"process_noise\['x2'\] must be a non-negative intensity"),
    ({"x2": " "}, r"process_noise\['x2'\] must be .* or a name"),
    ({"x2": [0.1]}, r"process_noise\['x2'\] must be .* or a name"),
    # a number written as text is no name: it would be fitted as a group called '0.05'
    ({"x2": "0.05"}, r"process_noise\['x2'\] is the text '0.05', which reads as a number"),
])
def test_a_process_noise_the_filter_cannot_read_is_refused_naming_it(record, process_noise,
                                                                      match):
    with pytest.raises(ValueError, match=match):
        PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter",
                        process_noise=process_noise).fit(record.iloc[:300])


def test_a_process_noise_no_filter_reads_is_said_to_be_unused(record):
    with pytest.warns(UserWarning, match="process_noise is read by the filter"):
        PolyCCRegressor(equations=OSCILLATOR, fit_mode="equation",
                        process_noise={"x2": 0.1}).fit(record.iloc[:300])


def test_the_filter_needs_time(record):
    with pytest.raises(ValueError, match="X has no time column 't'"):
        PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(record[["x1"]])


def test_the_states_are_smoothed_with_bands_that_hold_them():
    X, states = _pushed_oscillator(2000, seed=5, truth=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(X)
    smooth = model.smooth(X)
    assert list(smooth.columns) == ["t", "x1", "x1_lower", "x1_upper", "x2", "x2_lower",
                                    "x2_upper"]
    assert len(smooth) == len(X) and np.allclose(smooth.t, X.t)
    # the position read closer than the sensor reads it; the velocity nobody measured read too
    assert np.sqrt(np.mean((smooth.x1 - states[:, 0]) ** 2)) < 0.7 * R
    for j, name in enumerate(["x1", "x2"]):
        inside = np.mean((smooth[f"{name}_lower"] <= states[:, j])
                         & (states[:, j] <= smooth[f"{name}_upper"]))
        assert 0.9 <= inside <= 0.99
    narrower = model.smooth(X, level=0.5)
    assert (narrower.x2_upper - narrower.x2_lower).mean() < \
        0.5 * (smooth.x2_upper - smooth.x2_lower).mean()


def test_smoothing_reads_each_state_from_the_samples_after_it_too():
    # what only the backward pass gives: the filtered states use the samples up to each one,
    # the smoothed ones every sample; the velocity nobody measured gains most
    X, states = _pushed_oscillator(1500, seed=6, truth=True)
    problem, plan = _plan(X, len(X))
    system = problem.skeleton.compile({}, {"a1": A1, "a2": A2})
    run = kalman_pass(plan, system, np.array([[0.0, Q]]), np.array([[R]]), keep=True)
    means, covs = smoothed(run)
    filtered, smooth = run.means[0, 0], means[0, 0]
    settled = slice(100, None)  # past the broad start
    error = {name: np.sqrt(np.mean((values[settled] - states[settled]) ** 2, axis=0))
             for name, values in (("filtered", filtered), ("smoothed", smooth))}
    assert error["smoothed"][1] < 0.85 * error["filtered"][1]
    assert error["smoothed"][0] < error["filtered"][0]
    variance = {"filtered": np.diagonal(run.covariances[0, 0], axis1=-2, axis2=-1),
                "smoothed": np.diagonal(covs[0, 0], axis1=-2, axis2=-1)}
    # narrower everywhere before the last sample, and equal at it (nothing comes after)
    assert (variance["smoothed"][settled][:-1] < 0.9 * variance["filtered"][settled][:-1]).all()
    assert np.allclose(variance["smoothed"][-1], variance["filtered"][-1])
    assert np.allclose(smooth[-1], filtered[-1])


def test_only_a_model_fitted_by_the_filter_smooths(record):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation").fit(record)
    with pytest.raises(ValueError, match="smooth needs a model fitted with fit_mode='filter'"):
        model.smooth(record)


def test_predictions_ahead_come_from_the_filtered_states(record):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(record)
    one, ten = model.predict_ahead(record), model.predict_ahead(record, steps=10)
    assert list(one.columns) == ["t", "x1", "x2"] and len(one) == len(record)
    assert one.x1.isna().sum() == 1 and ten.x1.iloc[:10].isna().all()
    errors = {k: (p.x1 - record.x1).to_numpy()[10:] for k, p in (("one", one), ("ten", ten))}
    # one step ahead: the innovations, white and about the measurement noise and one
    # step's push; ten steps ahead the random force has had time to act
    assert abs(np.corrcoef(errors["one"][:-1], errors["one"][1:])[0, 1]) < 0.2
    assert np.std(errors["one"]) < 2 * R < np.std(errors["ten"])
    with pytest.raises(ValueError, match="steps must be a positive integer"):
        model.predict_ahead(record, steps=0)


@pytest.mark.slow
def test_the_filters_standard_errors_cover_the_truth_over_draws():
    # the record: a forced oscillator a random force also pushes (its simulation
    # from the true start wanders by 17-33 % of the spread), position with 1 % noise
    study = load("filter_study")
    truth = np.array(list(study.TRUTH.values()))
    inside = []
    for seed in range(20):
        X, wander = study.pushed_oscillator(2000, seed)
        assert 0.1 <= wander <= 0.4
        theta, errors, _ = study.fit(X, "filter")
        inside.extend(np.abs(theta - truth) <= 2 * errors)
    assert 0.85 <= np.mean(inside) <= 0.99


@pytest.mark.slow
def test_an_upper_tank_nobody_measures_is_smoothed_inside_its_band():
    # two tanks in cascade, the inflow disturbed (a random push on the upper level), only
    # the lower level measured; the pump steps and holds
    rng = np.random.default_rng(1)
    a1, a2, a3, push, step, n, fine = 0.5, 0.4, 0.3, 0.02, 2.0, 1500, 40
    u = np.repeat(rng.uniform(0.3, 1.0, n // 100 + 1), 100)[:n]
    x, levels, dt = np.array([1.0, 1.0]), [], step / fine
    for k in range(n):
        levels.append(x.copy())
        for _ in range(fine):
            flow = a2 * np.sqrt(max(x[0], 0.0))
            x = x + np.array([a1 * u[k] - flow, flow - a3 * np.sqrt(max(x[1], 0.0))]) * dt \
                + np.array([push * np.sqrt(dt) * rng.standard_normal(), 0.0])
    levels = np.array(levels)
    X = pd.DataFrame({"t": np.arange(n) * step, "u": u,
                      "x2": levels[:, 1] + 0.01 * np.std(levels[:, 1]) * rng.standard_normal(n)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=["x1_dot = a1 u - a2 sqrt(x1)",
                                           "x2_dot = a2 sqrt(x1) - a3 sqrt(x2)"],
                                fit_mode="filter", input_hold="zoh").fit(X)
    for name, value in {"a1": a1, "a2": a2, "a3": a3}.items():
        assert abs(model.params_[name] - value) < 3 * model.params_std_[name]
    assert model.process_noise_["x1"] == pytest.approx(push, rel=0.3)
    smooth = model.smooth(X)
    for j, name in enumerate(["x1", "x2"]):
        inside = np.mean((smooth[f"{name}_lower"] <= levels[:, j])
                         & (levels[:, j] <= smooth[f"{name}_upper"]))
        assert inside >= 0.9


def _tank_at_its_rim(n: int, seed: int, *, rim: float = 1.0):
    """A tank filled through a held pump, pushed, that spills at its rim; the level measured.

    ``x1_dot = u - x1`` with ``x1 <= rim``: a pump setting of 1.4 holds the
    level at the rim. Returns the record and the true level.
    """
    rng = np.random.default_rng(seed)
    step, fine, push = 0.5, 20, 0.03
    u = np.repeat(rng.choice([0.2, 0.6, 1.4], size=n // 80 + 1), 80)[:n]
    x, levels, dt = 0.5, [], step / fine
    for k in range(n):
        levels.append(x)
        for _ in range(fine):
            x = min(x + (u[k] - x) * dt + push * np.sqrt(dt) * rng.standard_normal(), rim)
    levels = np.array(levels)
    X = pd.DataFrame({"t": np.arange(n) * step, "u": u,
                      "x1": levels + 0.01 * rng.standard_normal(n)})
    return X, levels


def test_a_level_held_at_its_rim_is_filtered_within_its_limit():
    X, levels = _tank_at_its_rim(800, seed=1)
    assert 0.1 < np.mean(levels == 1.0) < 0.5  # the level spends a good share of it spilling

    def fit(constraints):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return PolyCCRegressor(equations=["x1_dot = a1 u - a2 x1"], constraints=constraints,
                                   fit_mode="filter", input_hold="zoh").fit(X)

    model, unlimited = fit(["x1 <= 1"]), fit([])
    # the rim held inside the filter: the numbers and both noises found again
    for name in ("a1", "a2"):
        assert abs(model.params_[name] - 1.0) < 3 * model.params_std_[name] < 0.15
    assert model.process_noise_["x1"] == pytest.approx(0.03, rel=0.2)
    assert model.measurement_noise_["x1"] == pytest.approx(0.01, rel=0.2)
    # without the rim the filter cannot hold the level there: far less likely
    assert unlimited.filter_["nll"] > model.filter_["nll"] + 100
    smooth = model.smooth(X)
    assert smooth[["x1", "x1_lower", "x1_upper"]].to_numpy().max() <= 1.0
    assert np.mean((smooth.x1_lower <= levels) & (levels <= smooth.x1_upper)) >= 0.9
    assert model.predict_ahead(X, steps=5).x1.max() <= 1.0


def test_variants_with_their_own_limit_are_each_filtered_as_alone():
    X, _ = _tank_at_its_rim(400, seed=2)
    estimator = PolyCCRegressor(equations=["x1_dot = a1 u - a2 x1"],
                                constraints=["x1 <= a3"], fit_mode="filter", input_hold="zoh")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem, _ = estimator._problem(X, None, estimator._make_backend())
    plan = ShootingPlan(problem, 100)
    rims = [0.95, 1.0, 1.05]
    systems = [problem.skeleton.compile({}, {"a1": 1.0, "a2": 1.0, "a3": rim}) for rim in rims]
    plan.choose_substeps(systems[1], dict(problem.data.columns))
    q, r = np.array([[0.03]] * 3), np.array([[0.01]] * 3)
    together = kalman_pass(plan, systems, q, r, keep=True)
    for k, system in enumerate(systems):
        alone = kalman_pass(plan, system, q[:1], r[:1], keep=True)
        assert together.nll[k] == pytest.approx(alone.nll[0], rel=1e-9)
        assert together.means[k, ..., 0].max() <= rims[k]
    assert np.argmin(together.nll) == 1  # the true rim is the likeliest


def _lower_tank_of_a_rim(n: int = 400):
    """A second tank fed by the tank at its rim, only its level measured.

    Returns the filter's plan of the whole record under the true numbers,
    the true system and the upper tank's true level.
    """
    X, levels = _tank_at_its_rim(n, seed=2)
    lower, fine = [0.5], 20
    for k in range(len(X) - 1):
        x = lower[-1]
        for _ in range(fine):
            x += (levels[k] - x) * 0.5 / fine
        lower.append(x)
    X = pd.DataFrame({"t": X.t, "u": X.u, "x2": np.array(lower) + 0.01 * np.random.default_rng(
        3).standard_normal(len(X))})
    estimator = PolyCCRegressor(equations=["x1_dot = a1 u - a2 x1", "x2_dot = x1 - x2"],
                                constraints=["x1 <= 1"], fit_mode="filter", input_hold="zoh")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem, _ = estimator._problem(X, None, estimator._make_backend())
    system = problem.skeleton.compile({}, {"a1": 1.0, "a2": 1.0})
    return filter_plan(problem, system, whole=True), system, levels


def test_a_state_held_at_its_limit_is_smoothed_beside_one_that_is_not():
    # a second tank fed by the first: while the first spills, its level is held at the rim
    # and shares nothing with the second; the smoother must still carry both back
    plan, system, levels = _lower_tank_of_a_rim()
    run = kalman_pass(plan, system, np.array([[0.03, 0.002]]), np.array([[0.01]]), keep=True)
    means, covs = smoothed(run)
    assert np.isfinite(means).all() and np.isfinite(covs).all()
    assert means[..., 0].max() <= 1.0 + 1e-3
    assert np.sqrt(np.mean((means[0, 0, :, 0] - levels) ** 2)) < 0.05


def test_a_hidden_level_started_on_its_rim_starts_within_it():
    # the filter starts a level nobody measures where a simulation put it, here on its rim,
    # with the spread of the record: half of that normal lies beyond the rim, and read so
    # the first measurements of the lower tank threw the upper level far below its truth
    plan, system, levels = _lower_tank_of_a_rim()
    assert plan.initial[0][0] == 1.0 and levels[0] == 0.5  # started on the rim, truly half
    run = kalman_pass(plan, system, np.array([[0.03, 0.002]]), np.array([[0.01]]), keep=True)
    # the start's mean and spread are those of the normal within the rim
    spread = plan.scale[0]
    assert run.predicted[0, 0, 0, 0] == pytest.approx(1.0 - spread * np.sqrt(2 / np.pi))
    assert run.predicted_covariances[0, 0, 0, 0, 0] == pytest.approx(spread**2 * (1 - 2 / np.pi))
    means, _ = smoothed(run)
    # read from the lower level's first samples (which the record's held steps bias low),
    # within the tank: it was read below the empty tank before
    assert 0.0 < means[0, 0, 0, 0] < 1.0


def test_a_level_held_at_its_rim_without_a_push_still_has_a_likelihood():
    # the noise grid's calm rows (no process noise) must be scored, not failed: a failed
    # calm row would make any push look like a gain
    X, _ = _tank_at_its_rim(800, seed=1)
    estimator = PolyCCRegressor(equations=["x1_dot = a1 u - a2 x1"], constraints=["x1 <= 1"],
                                fit_mode="filter", input_hold="zoh")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem, _ = estimator._problem(X, None, estimator._make_backend())
    plan = ShootingPlan(problem, len(X) - 1)
    system = problem.skeleton.compile({}, {"a1": 1.0, "a2": 1.0})
    plan.choose_substeps(system, dict(problem.data.columns))
    run = kalman_pass(plan, [system] * 2, np.array([[0.0], [0.03]]), np.array([[0.01]] * 2))
    assert np.isfinite(run.nll).all() and run.nll[1] < run.nll[0]


def test_a_filtered_model_with_a_fitted_delay_reads_records_after_its_fit(late_input):
    # the methods after fit read a record through a clone, which must read the input late by
    # the fitted delay (it used to refuse: "the delays a3 are fitted by fit")
    X, clean = late_input
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=LATE_INPUT, fit_mode="filter").fit(X)
    assert model.delays_["a3"] == pytest.approx(0.35, abs=0.02)
    wider = X.assign(note="logged by hand", spare=np.nan)  # columns the model does not read
    assert model.log_likelihood(wider) == pytest.approx(model.log_likelihood(X))
    smoothed = model.smooth(wider)
    assert np.sqrt(np.mean((smoothed["x1"] - clean) ** 2)) < 0.01
    assert len(model.predict_ahead(X, steps=2)) == len(X)
    assert np.isfinite(model.innovations(X)["x1"]).all()


@pytest.mark.parametrize("push", [None, 0.05])
def test_a_noise_the_search_leaves_at_its_floor_is_said_not_to_be_trusted(push):
    X = datasets.make_oscillator(hidden=[], disturbance=push, noise=40.0, noise_columns=["x1"],
                                 n_samples=800, random_state=0)[["t", "x1", "F_ext"]]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"],
                                fit_mode="filter").fit(X)
    said = [str(w.message) for w in caught if "end of its range" in str(w.message)]
    if push is None:  # nothing pushes the record: the intensity stays where the search starts
        assert model.process_noise_["x2"] <= 1e-11
        assert len(said) == 1 and "the process noise of x2 (1e-12, at the floor)" in said[0]
        assert "not to be trusted" in said[0] and "measurement noise" not in said[0]
        # no standard errors then; the interval says why, not to refit with resamples the
        # filter refuses
        assert np.isnan(model.params_std_["a1"])
        with pytest.raises(ValueError, match=r"curvature of the filter's likelihood was not "
                                             r"positive definite .* hold that noise"):
            model.params_interval()
    else:
        assert model.process_noise_["x2"] == pytest.approx(push, rel=0.3) and not said


def test_a_quantised_sensor_is_never_read_finer_than_it_rounds():
    # position counts of an encoder (step 0.05), nothing else on them: left free, the filter
    # read their noise at 0.0140, below the 0.0144 that rounding alone makes
    X, states = _pushed_oscillator(2000, seed=3, truth=True)
    step = 0.05
    X["x1"] = np.round(states[:, 0] / step) * step
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(X)
    assert model.measurement_noise_["x1"] >= step / np.sqrt(12) * (1 - 1e-9)
    assert model.process_noise_["x2"] == pytest.approx(Q, rel=0.3)
