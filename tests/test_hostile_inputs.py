"""Promises kept under bad input: clear errors that name the culprit, no silent NaN,
no shared or global state."""

import threading
import warnings

import numpy as np
import pandas as pd
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from sklearn_pycc import (
    DomainWarning,
    NeuralCCRegressor,
    PolyCCRegressor,
    RankDeficiencyWarning,
    Skeleton,
    SymbolicCCRegressor,
    pycc,
)

STICK_SLIP = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]


def _tank(n=300):
    """A draining tank: h' = -0.3 sqrt(h), measured while h falls from 4 to 0.6."""
    t = np.linspace(0.0, 8.0, n)
    h = (2.0 - 0.15 * t) ** 2
    return pd.DataFrame({"t": t, "x1": h}), pd.DataFrame({"x1_dot": -0.3 * np.sqrt(h)})


BACKENDS = [
    (PolyCCRegressor, {}),
    (NeuralCCRegressor, {"max_epochs": 60, "random_state": 0}),
    (SymbolicCCRegressor, {"random_state": 0}),
]


@pytest.mark.parametrize("cls, options", BACKENDS, ids=lambda v: getattr(v, "__name__", ""))
@pytest.mark.parametrize("equations, rhs, truth", [
    (["x1_dot = -a1 sqrt(x1)"], lambda h: -0.3 * np.sqrt(h), {"a1": 0.3}),
    (["x1_dot = -a1 log(x1 + 1) - a2 arcsin(x1 / 10)"],
     lambda h: -0.2 * np.log(h + 1) - 0.5 * np.arcsin(h / 10), {"a1": 0.2, "a2": 0.5}),
], ids=["sqrt", "log-arcsin"])
def test_skeletons_with_functions_of_half_the_line_fit(cls, options, equations, rhs, truth):
    X, _ = _tank()
    y = pd.DataFrame({"x1_dot": rhs(X["x1"].to_numpy())})
    model = cls(equations=equations, **options).fit(X, y)
    assert model.score(X, y) > 0.999
    for name, value in truth.items():
        assert model.params_[name] == pytest.approx(value, rel=1e-3)


def test_a_parameter_inside_sqrt_fits_by_least_squares_and_guides_the_network():
    X, y = _tank()
    model = PolyCCRegressor(equations=["x1_dot = -sqrt(a1 x1)"]).fit(X, y)
    assert model.params_["a1"] == pytest.approx(0.09, rel=1e-6)
    bounded = NeuralCCRegressor(equations=["x1_dot = -sqrt(a1 x1)"], constraints=["a1 >= 0"],
                                max_epochs=60, random_state=0).fit(X, y)
    assert bounded.params_["a1"] == pytest.approx(0.09, rel=1e-3)


def test_the_identifiability_probe_stays_inside_the_domains():
    report = Skeleton(["x1_dot = -a1 sqrt(a2 x1)"]).identifiability()
    assert not report.identifiable  # a1 and a2 trade a scale through the square root
    assert Skeleton(["x1_dot = -a1 sqrt(x1) - a2 log(x1)"]).identifiability().identifiable


@pytest.mark.parametrize("cls, options", BACKENDS, ids=lambda v: getattr(v, "__name__", ""))
@pytest.mark.parametrize("n", [1, 3])
def test_fewer_rows_than_unknowns_is_an_error(cls, options, n):
    X = pd.DataFrame({"x1": np.linspace(0.1, 1.0, n), "x2": np.linspace(-1.0, 1.0, n)})
    y = pd.DataFrame({"x1_dot": np.ones(n)})
    with pytest.raises(ValueError, match=f"n_samples = {n}: {n} residual value.* 4 unknowns"):
        cls(equations=["x1_dot = -a1 x1 - a2 x2 - a3 x1 x2 - a4"], **options).fit(X, y)


def test_a_curve_with_more_coefficients_than_rows_warns_of_rank_deficiency():
    X = pd.DataFrame({"x2": [-1.0, 0.0, 1.0]})
    y = pd.DataFrame({"x1_dot": [1.0, 0.0, 1.0]})
    with pytest.warns(RankDeficiencyWarning, match="3 directions undetermined.*f1"):
        PolyCCRegressor(equations=["x1_dot = f1(x2)"], degree=5).fit(X, y)


def test_predict_outside_a_domain_warns_and_names_the_term():
    X, y = _tank()
    model = PolyCCRegressor(equations=["x1_dot = -a1 sqrt(x1) + f1(x1)"], degree=2).fit(X, y)
    outside = X.copy()
    outside.loc[5:7, "x1"] = -1.0
    with pytest.warns(DomainWarning, match=r"equations\[0\] \(x1_dot\) at 3 of 300 rows, "
                                           r"first at row 5 \(x1=-1\).*'-a1\*sqrt\(x1\)'"):
        pred = model.predict(outside)
    assert np.isnan(pred[5:8]).all() and np.isfinite(np.delete(pred, [5, 6, 7])).all()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning inside the domain
        model.predict(X)


def test_score_of_huge_values_is_exact_or_refused():
    X, y = _tank()
    linear = PolyCCRegressor(equations=["x1_dot = -a1 x1"]).fit(X, y)
    reference = linear.score(X, y)
    assert linear.score(X * 1e300, y * 1e300) == pytest.approx(reference, rel=1e-12)
    curved = PolyCCRegressor(equations=["x1_dot = f1(x1)"], degree=3).fit(X, y)
    with pytest.warns(DomainWarning), pytest.raises(ValueError, match="NaN or infinite"):
        curved.score(X * 1e300, y * 1e300)


def test_post_processing_needs_the_coefficients_of_the_skeleton():
    x = np.linspace(-1.0, 1.0, 50)
    params = {"evals": [x, np.tanh(x)], "plot": False}
    with pytest.raises(ValueError, match="a1 but params\\['obtained_coefs'\\] gives no value"):
        pycc.post_processing(["x1_dot = -a1 x1 - f1(x1)"], params=params)
    with pytest.raises(ValueError, match="obtained_coefs\\['a1'\\] must be one finite number"):
        pycc.post_processing(["x1_dot = -a1 x1 - f1(x1)"],
                             params={**params, "obtained_coefs": {"a1": np.nan}})


@pytest.fixture(scope="module")
def stick_slip_model():
    from sklearn_pycc.datasets import make_stick_slip

    data = make_stick_slip(n_samples=400, random_state=0)
    model = PolyCCRegressor(equations=STICK_SLIP, degree=5).fit(
        data[["x1", "x2", "F_ext"]], data[["x1_dot", "x2_dot"]])
    return model, data


@pytest.mark.parametrize("options, words", [
    ({"rtol": -1}, "rtol must be a positive number"),
    ({"rtol": "a"}, "rtol must be a positive number"),
    ({"atol": -1.0}, "atol must be a non-negative number"),
    ({"method": "LSODA", "max_step": -1}, "max_step must be a positive number"),
    ({"method": "RK45", "first_step": 0.0}, "first_step must be a positive number"),
    ({"method": "Radau", "min_step": -1e-3}, "min_step must be a non-negative number"),
])
def test_solver_options_are_blamed_on_themselves(stick_slip_model, options, words):
    model, data = stick_slip_model
    with pytest.raises(ValueError, match=words):
        model.simulate(data["t"].to_numpy(), [0.0, 0.0], inputs={"F_ext": np.cos}, **options)


@pytest.mark.parametrize("value", ["cos", None, b"1"])
def test_an_input_of_the_wrong_kind_is_named(stick_slip_model, value):
    model, data = stick_slip_model
    with pytest.raises(ValueError, match=r"input 'F_ext' is .*give a callable of t"):
        model.simulate(data["t"].to_numpy(), [0.0, 0.0], inputs={"F_ext": value})


def test_fitted_models_do_not_share_their_skeleton(stick_slip_model):
    model, data = stick_slip_model
    X, y = data[["x1", "x2", "F_ext"]], data[["x1_dot", "x2_dot"]]
    other = PolyCCRegressor(equations=STICK_SLIP, degree=5).fit(X, y)
    assert other.skeleton_ == model.skeleton_ and other.skeleton_ is not model.skeleton_
    given = Skeleton(STICK_SLIP)
    third = PolyCCRegressor(equations=given, degree=5).fit(X, y)
    assert third.skeleton_ is not given


@pytest.mark.parametrize("cls, options", BACKENDS[1:], ids=lambda v: getattr(v, "__name__", ""))
def test_random_state_none_leaves_numpys_global_generator_alone(cls, options):
    X, y = _tank(80)
    np.random.seed(123)  # noqa: NPY002 - the legacy global generator is what is watched
    before = np.random.get_state()  # noqa: NPY002
    cls(equations=["x1_dot = -a1 sqrt(x1)"], **{**options, "random_state": None}).fit(X, y)
    after = np.random.get_state()  # noqa: NPY002
    assert (before[1] == after[1]).all() and before[2] == after[2]


def test_a_generator_as_random_state_is_honoured():
    X, y = _tank(80)
    options = {"equations": ["x1_dot = f1(x1)"], "max_epochs": 3, "optimizer": "adam"}

    def fitted(random_state):
        return NeuralCCRegressor(**options, random_state=random_state).fit(X, y).predict(X)

    assert np.array_equal(fitted(np.random.default_rng(5)), fitted(np.random.default_rng(5)))
    assert not np.array_equal(fitted(np.random.default_rng(5)), fitted(np.random.default_rng(6)))
    generator = np.random.default_rng(5)
    first, second = fitted(generator), fitted(generator)  # the stream moves on
    assert not np.array_equal(first, second)


def _blas_limits():
    return sorted(info["num_threads"] for info in threadpool_info()
                  if info["user_api"] == "blas")


def test_two_fits_in_two_threads_restore_the_blas_limit(stick_slip_model):
    from sklearn_pycc._utils.threads import blas_threads

    _, data = stick_slip_model
    X, y = data[["x1", "x2", "F_ext"]], data[["x1_dot", "x2_dot"]]
    entered = threading.Barrier(2)

    def overlapping():
        with blas_threads(1):
            entered.wait(timeout=30)  # both inside at once
            PolyCCRegressor(equations=STICK_SLIP, degree=5).fit(X, y)
            entered.wait(timeout=30)

    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_limits()
        assert before and max(before) == 2  # else the test could not see a leaked limit
        threads = [threading.Thread(target=overlapping) for _ in range(2)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        assert _blas_limits() == before


def test_an_array_for_a_skeleton_numbered_from_one_is_refused(stick_slip_model):
    _, data = stick_slip_model
    X, y = data[["x1", "x2", "F_ext"]], data[["x1_dot", "x2_dot"]]
    with pytest.raises(ValueError, match=r"reads x1, x2 but not x0.*columns=\['x1', 'x2', "
                                         r"'F_ext'\]"):
        PolyCCRegressor(equations=STICK_SLIP, degree=5).fit(X.to_numpy(), y.to_numpy())
    zero_based = ["x0_dot = x1", "x1_dot = x2 - f1(x1) - f2(x0)"]
    model = PolyCCRegressor(equations=zero_based, degree=5).fit(X.to_numpy(), y.to_numpy())
    named = PolyCCRegressor(equations=STICK_SLIP, degree=5).fit(X, y)
    assert model.score(X.to_numpy(), y.to_numpy()) == pytest.approx(named.score(X, y))


def test_a_scaler_in_front_of_the_estimator_is_flagged(stick_slip_model):
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    _, data = stick_slip_model
    X, y = data[["x1", "x2", "F_ext"]], data[["x1_dot", "x2_dot"]]
    pipe = make_pipeline(StandardScaler().set_output(transform="pandas"),
                         PolyCCRegressor(equations=STICK_SLIP, degree=5))
    with pytest.warns(UserWarning, match="mean 0 and standard deviation 1 exactly.*physical"):
        pipe.fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        PolyCCRegressor(equations=STICK_SLIP, degree=5).fit(X, y)


def test_a_refit_forgets_what_the_previous_fit_learned(stick_slip_model):
    _, data = stick_slip_model
    X, y = data[["x1", "x2", "F_ext"]], data[["x1_dot", "x2_dot"]]
    model = PolyCCRegressor(equations=STICK_SLIP, degree=5).fit(X, y)
    model.left_over_ = "from another fit"
    model.set_params(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a1 x1"]).fit(X, y)
    assert not hasattr(model, "left_over_")
    assert list(model.coefficients_) == ["f1"] and list(model.params_) == ["a1"]
