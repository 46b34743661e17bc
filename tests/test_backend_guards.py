"""Careless input to the backend contract and to long runs: each refused or announced.

A user's backend is checked where its result is received, and every error
names the backend; a skeleton of many curves is analysed and fitted in
bounded time (or refused by the backend that cannot, with the reason); refits
on resamples that would take long say so before they start.
"""

import re
import time
import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from joblib import delayed

from sklearn_pycc import CCRegressor, PolyCCRegressor, Skeleton, datasets
from sklearn_pycc.estimators.backend import RESERVED_ATTRIBUTES, Backend, FitResult
from sklearn_pycc.estimators.least_squares import MAX_NUMBERS, LeastSquaresCCRegressor
from sklearn_pycc.fitting.uncertainty import (
    hidden_bootstrap as _hidden_bootstrap,
)
from sklearn_pycc.fitting.uncertainty import (
    resampling as _resampling,
)
from sklearn_pycc.skeleton import identifiability

SKELETON = ["x1_dot = f1(x1) + a1*u"]


class Line:
    """A curve that behaves: ``slope * x``, value by value."""

    def __init__(self, slope: float) -> None:
        self.slope = slope

    def __call__(self, x):
        return self.slope * np.asarray(x, dtype=float)


def good(problem):
    return FitResult({"f1": Line(-0.5)}, {"a1": 2.0}, {"slope_": -0.5})


class Careless(Backend):
    """Hands back what its ``answer`` makes of the problem, whatever that is."""

    settings = ("answer",)
    output_error = True

    def fit(self, problem):
        return self.answer(problem)

    def refine(self, problem, result, plan):
        return getattr(self, "refined", lambda p, r: r)(problem, result)


class CarelessCurves(CCRegressor):
    def __init__(self, *, equations=None, answer=good, fit_mode="equation") -> None:
        super().__init__(equations=equations, fit_mode=fit_mode)
        self.answer = answer

    def _make_backend(self):
        return Careless(answer=self.answer)


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, 200)
    x1, u = np.sin(t), rng.uniform(-1.0, 1.0, t.size)
    X = pd.DataFrame({"t": t, "x1": x1, "u": u})
    return X, pd.DataFrame({"x1_dot": -0.5 * x1 + 2.0 * u})


def test_a_backend_that_keeps_the_contract_is_stored(record):
    model = CarelessCurves(equations=SKELETON).fit(*record)
    assert model.params_ == {"a1": 2.0} and model.slope_ == -0.5
    assert model.score(*record) == pytest.approx(1.0)


def with_result(**changes):
    """An answer: the good result with some of its parts replaced."""
    def answer(problem):
        result = good(problem)
        return FitResult(**{"functions": result.functions, "params": result.params,
                            "attributes": result.attributes, **changes})
    return answer


def curve(function):
    return with_result(functions={"f1": function})


N_ROWS = 200

CARELESS = {
    "a dict": (lambda p: {"f1": Line(1.0), "a1": 1.0}, TypeError,
               "returned dict, not a FitResult"),
    "None": (lambda p: None, TypeError, "returned NoneType, not a FitResult"),
    "functions not a dict": (with_result(functions=[Line(1.0)]), TypeError,
                             "functions is list, not a dict"),
    "a curve of the wrong length": (curve(lambda x: np.zeros(7)), ValueError,
                                    r"curve f1 that maps an array of shape \(5,\) to one of "
                                    r"shape \(7,\)"),
    "a curve giving its training values": (curve(lambda x: np.zeros(N_ROWS)), ValueError,
                                           r"to one of shape \(200,\)"),
    "a 2-D curve": (curve(lambda x: np.column_stack([x, x])), ValueError,
                    r"to one of shape \(5, 2\)"),
    "a number for a curve": (curve(3.0), TypeError, "float for the curve f1, not a callable"),
    "a curve that fails": (curve(lambda x: x["u"]), ValueError,
                           "curve f1 that fails on 5 values of its argument"),
    "a NaN parameter": (with_result(params={"a1": np.nan}), ValueError,
                        "parameter a1 = nan: a fit gives finite values"),
    "an infinite parameter": (with_result(params={"a1": -np.inf}), ValueError,
                              "parameter a1 = -inf"),
    "an array for a parameter": (with_result(params={"a1": np.ones(3)}), TypeError,
                                 r"a1 = array\(\[1., 1., 1.\]\), not a number"),
    "a missing parameter": (with_result(params={}), ValueError,
                            r"returned no parameter a1: a result holds every parameter"),
    "an extra parameter": (with_result(params={"a1": 1.0, "a9": 2.0}), ValueError,
                           "the parameter 'a9', which the skeleton does not have"),
    "a missing curve": (with_result(functions={}), ValueError,
                        "returned no curve f1: .*ZeroCurve"),
    "an extra curve": (with_result(functions={"f1": Line(1.0), "f2": Line(1.0)}), ValueError,
                       "the curve 'f2', which the skeleton does not have"),
    "a reserved attribute": (with_result(attributes={"params_": {"a1": 0.0}}), ValueError,
                             "'params_', which the estimator sets itself"),
    "the estimator's backend": (with_result(attributes={"backend_": None}), ValueError,
                                "'backend_', which the estimator sets itself"),
    "a private attribute": (with_result(attributes={"__dict__": {}}), ValueError,
                            "'__dict__': a fitted attribute is a name that ends in '_' and "
                            "does not start with one"),
}


@pytest.mark.parametrize("case", list(CARELESS))
def test_a_careless_result_is_refused_where_it_is_received_naming_the_backend(record, case):
    answer, error, words = CARELESS[case]
    model = CarelessCurves(equations=SKELETON, answer=answer)
    with pytest.raises(error, match=words) as raised:
        model.fit(*record)
    assert str(raised.value).startswith("Careless.fit returned")
    # refused before anything is stored: the estimator is left unfitted
    assert not hasattr(model, "params_")


def test_a_backend_may_not_move_what_the_gauge_pinned(record):
    # a1 f1(x1): the gauge pins a1 = 1, and the backend fits f1 only
    def answer(problem):
        assert problem.fixed_params == {"a1": 1.0}
        return FitResult({"f1": Line(-0.5)}, {"a1": 3.0})

    with pytest.raises(ValueError, match="a1 = 3, which the problem pins to 1"):
        CarelessCurves(equations=["x1_dot = a1*f1(x1)"], answer=answer).fit(*record)


def test_the_reserved_names_are_those_the_estimator_sets(record):
    model = PolyCCRegressor(equations=SKELETON).fit(*record)
    own = {"params_", "functions_", "skeleton_", "gauge_", "curve_ranges_", "n_parameters_",
           "backend_", "fit_mode_", "derivative_source_", "measured_states_"}
    assert own <= set(vars(model)) and own <= RESERVED_ATTRIBUTES
    # what the backend itself hands back stays its own
    assert not RESERVED_ATTRIBUTES & {"coefficients_", "cost_", "covariance_", "shooting_",
                                      "initial_states_", "input_hold_"}


def test_what_refine_returns_is_checked_too(record):
    backend = Careless(answer=good)
    backend.refined = lambda problem, result: {"f1": result.functions["f1"]}
    model = CarelessCurves(equations=SKELETON, fit_mode="simulation")
    model._make_backend = lambda: backend
    with pytest.raises(TypeError, match=r"^Careless\.refine returned dict, not a FitResult"):
        model.fit(*record)


# -- many curves ----------------------------------------------------------------------------
def many_curves(n: int) -> list[str]:
    """``x1_dot = f1(u1) + ... + fn(un)``, in sums of 20 (one sum of 200 is too deep)."""
    terms = [f"f{i}(u{i})" for i in range(1, n + 1)]
    return ["x1_dot = " + " + ".join("(" + " + ".join(terms[k:k + 20]) + ")"
                                     for k in range(0, n, 20))]


def many_records(n: int, rows: int = 300):
    rng = np.random.default_rng(1)
    inputs = {f"u{i}": rng.uniform(-1.0, 1.0, rows) for i in range(1, n + 1)}
    X = pd.DataFrame({"x1": rng.normal(size=rows), **inputs})
    y = sum(np.tanh(inputs[f"u{i}"]) for i in range(1, n + 1))
    return X, pd.DataFrame({"x1_dot": y})


def test_the_identifiability_analysis_probes_only_curves_read_alike(monkeypatch):
    # every pair of curves used to be probed: a cube of their number (40 curves 6 s, 200 about
    # 20 min); curves read at other points cannot trade a curve and are not probed
    calls = []
    original = identifiability._Probe.__call__
    monkeypatch.setattr(identifiability._Probe, "__call__",
                        lambda self, *a: calls.append(1) or original(self, *a))
    n = 60
    report = Skeleton(many_curves(n)).identifiability()
    assert len(calls) < 5 * n  # every pair would be 3 n (n - 1) / 2 = 5310
    # each curve but one exchanges a constant with the others, and nothing else is found
    assert {a.kind for a in report.ambiguities} == {"additive_constant"}
    assert len(report.ambiguities) == n - 1


@pytest.mark.parametrize(("equations", "constraints", "pins"), [
    (["x1_dot = f1(x1) + f2(x1)"], None, ["f2=0"]),
    (["x1_dot = f1(x1) + f2(-x1)"], ["f1 odd", "f2 odd"], ["f2=0"]),
    (["x1_dot = x2*f1(2*x1) + x2*f2(x1*2)"], None, ["f2=0"]),
    (["x1_dot = f1(x1) + f2(x1)", "x2_dot = f1(x1) - f2(x1)"], None, []),
    (["x1_dot = f1(x1) + f2(x2)", "x2_dot = f1(x2) + f2(x1)"], None, ["f2(0)=0"]),
])
def test_curves_read_at_the_same_points_are_still_found_to_trade(equations, constraints, pins):
    report = Skeleton(equations, constraints).identifiability()
    assert [str(fix) for fix in report.fixes] == pins


@pytest.mark.slow
def test_two_hundred_curves_fit_in_seconds():
    X, y = many_records(200, rows=600)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=many_curves(200), degree=3).fit(X, y)
    assert time.perf_counter() - start < 60.0  # about 5 s on one core
    assert model.score(X, y) > 0.999


def test_least_squares_refuses_more_numbers_than_it_can_fit_in_bounded_time():
    # 20 curves of degree 15: 301 numbers, each a column of a finite-difference Jacobian
    X, y = many_records(20)
    model = LeastSquaresCCRegressor(equations=many_curves(20), degree=15)
    with pytest.raises(ValueError, match=re.escape(
            f"LeastSquaresBackend would fit 301 numbers (20 curves' coefficients and the free "
            f"parameters), more than its {MAX_NUMBERS}")) as raised:
        model.fit(X, y)
    assert "Use PolyCCRegressor" in str(raised.value)


# -- long runs ------------------------------------------------------------------------------
def numbered(k: int) -> _resampling.Member:
    return _resampling.Member({}, {"k": float(k)})


def test_refits_that_would_take_long_are_announced_before_they_start(monkeypatch, record):
    monkeypatch.setattr(_resampling, "LONG_REFITS", 0.0)
    X = record[0].drop(columns="t")
    with pytest.warns(UserWarning, match=r"^6 refits on resamples: the first took .* s each, "
                      r"so the other 4 take about \d+ s on 1 worker\(s\)\. Fewer refits"):
        model = PolyCCRegressor(equations=SKELETON, n_bootstrap=6, random_state=0).fit(
            X, record[1])
    assert len(model.bootstrap_params_) == 6


def test_refits_that_end_soon_say_nothing(record):
    X = record[0].drop(columns="t")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        PolyCCRegressor(equations=SKELETON, n_bootstrap=4, random_state=0).fit(X, record[1])


def test_verbose_shows_the_refits_progress_instead(monkeypatch, capsys):
    monkeypatch.setattr(_resampling, "LONG_REFITS", 0.0)
    calls = [delayed(numbered)(k) for k in range(7)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        members, failures = _resampling.run_refits(calls, None, "threads", verbose=True)
    assert [m.params["k"] for m in members] == list(range(7)) and not failures
    assert re.search(r"n_bootstrap: 100%.*7/7", capsys.readouterr().err)


@pytest.mark.parametrize("n_jobs", [1, 2])
def test_the_refits_keep_their_order_whoever_runs_them(n_jobs):
    calls = [delayed(numbered)(k) for k in range(5)]
    members, _ = _resampling.run_refits(calls, n_jobs, "threads")
    assert [m.params["k"] for m in members] == list(range(5))


class QuickNoise:
    """Stands for the noise resampler of a fit with unmeasured states."""

    def __init__(self, problem, params, first, substeps) -> None:
        self.problem = problem

    def draw(self, rng):
        return rng.integers(0, 10, 4)

    def describe(self) -> str:
        return "redrawn noise"


def slow_refit(resampler, picks, params, first, substeps, iterations, functions):
    time.sleep(0.01)
    return _resampling.Member(dict(functions), dict(params))


def test_refits_with_an_unmeasured_state_are_timed_and_announced(monkeypatch):
    # each is a whole-record fit: 10,000 of them took 1.5 h without a word
    monkeypatch.setattr(_resampling, "LONG_REFITS", 0.05)
    monkeypatch.setattr(_hidden_bootstrap, "NoiseResampler", QuickNoise)
    monkeypatch.setattr(_hidden_bootstrap, "_refit", slow_refit)
    attributes = {"shooting_": {"initial_states": [[1.0]], "substeps": 1}}
    problem = SimpleNamespace(input_hold="zoh")
    monkeypatch.setattr(_hidden_bootstrap, "replace", lambda problem, **changes: problem)
    with pytest.warns(UserWarning, match=r"^12 refits on resamples: the first took [\d.e-]+ s "
                      r"each, so the other 10 take about \d+ s on 1 worker"):
        members, failures, method = _hidden_bootstrap.hidden_members(
            problem, {"a1": 1.0}, {}, attributes, 12, seed=0, n_jobs=None, iterations=5)
    assert len(members) == 12 and not failures and method == "redrawn noise"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _hidden_bootstrap.hidden_members(problem, {"a1": 1.0}, {}, attributes, 12, seed=0,
                                         n_jobs=None, iterations=5,
                                         verbose=True)


@pytest.mark.slow
def test_refits_with_an_unmeasured_state_are_announced_too(monkeypatch):
    monkeypatch.setattr(_resampling, "LONG_REFITS", 0.0)
    frame = datasets.make_two_tanks(n_samples=48, rims=(100.0, 100.0), random_state=0)
    with pytest.warns(UserWarning, match=r"^3 refits on resamples: the first took"):
        model = PolyCCRegressor(
            equations=["x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = 1.25 a2 sqrt(x1) - a3 sqrt(x2)"],
            constraints=["a1 >= 0", "a2 >= 0", "a3 >= 0"], n_bootstrap=3,
            random_state=0).fit(frame)
    assert "simulation errors drawn again" in model.bootstrap_method_
