"""Careless input gets a clear answer: typos that would change the model, time columns, reports."""

import copy
import math
import pickle
import warnings

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets, diagnose
from sklearn_pycc.exceptions import SkeletonError
from sklearn_pycc.skeleton import Bound, Constraint, Skeleton


@pytest.fixture(scope="module")
def record():
    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], return_truth=True)
    return frame[["t", "x1", "F_ext"]], truth


# -- skeleton text that no data could contradict ------------------------------------------
def test_a_forgotten_dot_is_refused_with_the_likely_intent():
    with pytest.raises(SkeletonError, match=r"x2 is on both sides.*did you mean 'x2_dot"):
        Skeleton(["x1_dot = x2", "x2 = F_ext - f1(x2) - f2(x1)"])


@pytest.mark.parametrize("equations, message", [
    (["F1 = f1(F1)"], "F1 is on both sides"),
    (["x1_dot = x2", "x2_dot = -a1 x1", "0 = a1"], "reads no measured quantity"),
])
def test_tautologies_are_refused(equations, message):
    with pytest.raises(SkeletonError, match=message):
        Skeleton(equations)


def test_a_static_output_of_the_states_is_still_accepted():
    skeleton = Skeleton(["x1_dot = -a1 x1 + u", "y = f1(x1)"])
    assert skeleton.outputs == ["y"]


# -- constraints built by hand --------------------------------------------------------------
@pytest.mark.parametrize("make, message", [
    (lambda: Bound("a1", math.nan, 1.0), "low must be a number"),
    (lambda: Bound("a1", 0.0, "1"), "high must be a number"),
    (lambda: Bound("a1", 2.0, 1.0), "low 2 exceeds high 1"),
    (lambda: Bound("x1", 0.0, 1.0), "a bound applies to a parameter"),
    (lambda: Constraint("f1", "sideways"), "kind must be one of"),
    (lambda: Constraint("f1", "value", 0.0, math.inf), "value must be a finite number"),
    (lambda: Constraint("a1", "odd"), "applies to a curve"),
])
def test_hand_made_constraints_are_checked(make, message):
    with pytest.raises(SkeletonError, match=message):
        make()


def test_numpy_numbers_make_valid_bounds():
    assert Bound("a1", np.float64(0.0), np.int64(3)).contains(1.0)


# -- time columns as loggers write them ---------------------------------------------------
def test_datetime_and_timedelta_time_columns_are_read_as_seconds(record):
    X, truth = record
    plain = PolyCCRegressor(equations=truth.base_equations).fit(X)
    stamps = X.assign(t=pd.Timestamp("2026-03-01 08:00") + pd.to_timedelta(X["t"], unit="s"))
    with pytest.warns(UserWarning, match="read as seconds since its first value"):
        dated = PolyCCRegressor(equations=truth.base_equations).fit(stamps)
    spans = X.assign(t=pd.to_timedelta(X["t"], unit="s"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a duration is already a time: nothing to say
        timed = PolyCCRegressor(equations=truth.base_equations).fit(spans)
    for model in (dated, timed):
        for name, value in plain.params_.items():
            assert model.params_[name] == pytest.approx(value, rel=1e-9)


def test_a_duration_outside_the_time_column_is_refused(record):
    X, truth = record
    with pytest.raises(ValueError, match="column 'x1' holds timedelta64"):
        PolyCCRegressor(equations=truth.base_equations).fit(
            X.assign(x1=pd.to_timedelta(X["x1"], unit="s")))


# -- the loop's own arguments ---------------------------------------------------------------
def test_the_loop_names_a_class_given_for_an_estimator(record):
    X, _ = record
    with pytest.raises(TypeError, match=r"got the class PolyCCRegressor: pass "
                                        r"PolyCCRegressor\(equations="):
        HypothesisLoop(PolyCCRegressor, X)


def test_a_loop_that_has_not_run_says_so(record):
    X, truth = record
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), X)
    with pytest.raises(ValueError, match="has not run yet"):
        loop.table()
    with pytest.raises(TypeError, match="title must be a string"):
        loop.to_html(title=123)


# -- saved reports tell the same story ------------------------------------------------------
def test_a_copied_or_pickled_diagnosis_keeps_its_stability(record):
    X, truth = record
    model = PolyCCRegressor(equations=truth.base_equations).fit(X)
    report = diagnose(model, X, n_bootstrap=10)
    assert "cubic_stiffness wins in 10 of 10" in report.summary()
    for again in (pickle.loads(pickle.dumps(report)), copy.deepcopy(report)):
        assert again.summary() == report.summary()
        pd.testing.assert_frame_equal(again.ranking, report.ranking)


# -- work that cannot finish, or numbers no fit can hold ------------------------------------
def test_absurd_amounts_of_work_are_refused(record):
    X, truth = record
    with pytest.raises(ValueError, match="degree of every curve is 100, above 60"):
        PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                        degree=100).fit(X)
    with pytest.raises(ValueError, match="n_bootstrap"):
        PolyCCRegressor(equations=truth.base_equations, n_bootstrap=10**9).fit(X)
    model = PolyCCRegressor(equations=truth.base_equations).fit(X)
    with pytest.raises(ValueError, match=r"n_bootstrap must be 0 .* from 2 to 100,000"):
        diagnose(model, X, n_bootstrap=10**9)


def test_a_bound_beyond_what_a_float_fit_can_hold_is_refused():
    with pytest.raises(SkeletonError, match="beyond 1e\\+100"):
        Skeleton(["x1_dot = -a1 x1"], constraints=["a1 >= 1e300"])


def test_horizons_too_long_or_too_short(record):
    X, truth = record
    model = PolyCCRegressor(equations=truth.base_equations).fit(X)
    whole = diagnose(model, X, horizon=10**400, n_bootstrap=0, held_out=False)
    assert whole.horizon.time is None  # longer than the record: whole experiments
    with pytest.raises(ValueError, match="shorter than two sampling steps"):
        diagnose(model, X, horizon=1e-9, n_bootstrap=0, held_out=False)



# -- static outputs: fit and score read them alike ----------------------------------------------
def _decay():
    t = np.linspace(0.0, 10.0, 500)
    x = np.exp(-0.5 * t)
    return (pd.DataFrame({"t": t, "x1": x, "y": 2 * x + 0.1}),
            pd.DataFrame({"x1_dot": -0.5 * x}), ["x1_dot = -a1 x1", "y = a2 x1 + a3"])


def test_score_reads_a_static_output_from_X_as_fit_does():
    from sklearn.model_selection import cross_val_score

    X, y, equations = _decay()
    model = PolyCCRegressor(equations=equations).fit(X)
    assert model.score(X, y) == pytest.approx(1.0, abs=1e-6)
    scores = cross_val_score(PolyCCRegressor(equations=equations), X, y, cv=3,
                             error_score="raise")
    assert np.all(scores > 0.999)


def test_a_static_output_given_twice_must_agree():
    X, y, equations = _decay()
    with pytest.raises(ValueError, match=r"'y' is in both X and y, with different values "
                                         r"\(first at row 0: 2.1 in X, 2 in y\)"):
        PolyCCRegressor(equations=equations).fit(X, y.assign(y=2 * X["x1"]))
    same = PolyCCRegressor(equations=equations).fit(X, y.assign(y=X["y"]))
    assert same.params_["a2"] == pytest.approx(2.0)


# -- the automatic differentiation on records it should not misread -----------------------------
def test_a_clean_ramp_is_neither_quantised_nor_noisy():
    t = np.linspace(0.0, 10.0, 1001)
    X = pd.DataFrame({"t": t, "x1": 0.5 * t, "u": np.ones_like(t)})
    model = PolyCCRegressor(equations=["x1_dot = a1 u"]).fit(X)
    assert "quantised" not in model.derivative_source_ and "no noise" in model.derivative_source_
    assert model.fit_mode_ == "equation"
    assert model.params_["a1"] == pytest.approx(0.5, rel=1e-3)


def test_a_lowpass_cutoff_above_nyquist_is_refused(record):
    X, truth = record
    with pytest.raises(ValueError, match=r"cutoff 1e\+06 Hz is at or above the record's "
                                         r"Nyquist frequency"):
        PolyCCRegressor(equations=truth.base_equations,
                        differentiation={"method": "lowpass", "cutoff": 1e6}).fit(X)


@pytest.mark.slow
def test_a_pickled_or_copied_loop_writes_the_same_report(record):
    X, truth = record
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), X,
                          n_bootstrap=10).run(max_rounds=2)
    document = loop.to_html()
    for again in (pickle.loads(pickle.dumps(loop)), copy.deepcopy(loop)):
        assert again.to_html() == document
        assert again.summary() == loop.summary()


# -- fuzzing skeletons, constraints and parameter values (make test-slow) -------------------
_PIECES = ["x1", "x2", "u", "a1", "a2", "a3", "f1(x1)", "f2(x2)", "f1(u)", "tanh(", "exp(",
           "sqrt(", "log(", "abs(", "sin(", "(", ")", " + ", " - ", " * ", " / ", "^2", "^a1",
           "-", "2.5", "0", "1e308", "pi", "t"]
_LEFT = ["x1_dot", "x2_dot", "0", "y", "x1", "u"]
_CONSTRAINTS = ["f1 odd", "f1 even", "f2(0)=0", "f1 increasing", "f3 odd", "a1 >= 0",
                "a2 <= -1", "0 <= a3 <= 1", "a1 >= 1e300", "f1(nan)=0", "a9 >= 0", "f1 sideways",
                "a1 >= 2", "a1 <= 1"]


@pytest.mark.slow
def test_fuzzed_skeletons_constraints_and_values_fail_only_with_a_named_error():
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    equation = st.tuples(st.sampled_from(_LEFT),
                         st.lists(st.sampled_from(_PIECES), min_size=1, max_size=12)).map(
        lambda pair: f"{pair[0]} = {''.join(pair[1])}")
    values = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                       st.sampled_from([0.0, 1.0, -1.0, 1e300]))

    @settings(max_examples=5000, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
    @given(st.lists(equation, min_size=1, max_size=3),
           st.lists(st.sampled_from(_CONSTRAINTS), max_size=3), st.lists(values, min_size=3,
                                                                           max_size=3))
    def check(equations, constraints, numbers):
        try:
            skeleton = Skeleton(equations, constraints=constraints)
            params = dict(zip(skeleton.params, numbers * 3))
            curves = {f: np.tanh for f in skeleton.functions}
            if skeleton.states:
                system = skeleton.compile(curves, params)
                assert system is not None
        except (SkeletonError, ValueError, TypeError) as error:
            assert str(error).strip(), f"an empty message for {equations} {constraints}"

    check()


def test_a_skeleton_of_very_many_curves_is_warned_about(monkeypatch):
    from sklearn_pycc.fitting import problem as setup

    monkeypatch.setattr(setup, "MANY_CURVES", 50)  # 200 in use: fewer curves test as well
    rng = np.random.default_rng(0)
    n_curves = 51
    X = pd.DataFrame({f"u{i}": rng.standard_normal(300) for i in range(1, n_curves + 1)})
    y = pd.DataFrame({"z_dot": np.tanh(X).sum(axis=1)})
    equation = "z_dot = " + " + ".join(f"f{i}(u{i})" for i in range(1, n_curves + 1))
    with pytest.warns(UserWarning, match="51 curves: its identifiability analysis"):
        PolyCCRegressor(equations=[equation], degree=2).fit(X, y)


def test_a_very_long_simulation_says_so_and_offers_progress(monkeypatch):
    import sklearn_pycc.skeleton.skeleton as module

    monkeypatch.setattr(module, "LONG_SIMULATION", 100)
    skeleton = Skeleton(["x1_dot = -a1 x1"])
    t = np.linspace(0.0, 1.0, 101)
    with pytest.warns(UserWarning, match="simulating 101 samples takes minutes"):
        skeleton.simulate(t, [1.0], params={"a1": 1.0})
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        skeleton.simulate(t[:100], [1.0], params={"a1": 1.0})


def test_a_relation_the_data_contradict_is_said_not_to_hold():
    t = np.linspace(0.0, 10.0, 500)
    X = pd.DataFrame({"t": t, "x1": np.sin(t) + 2.0, "x2": np.cos(t)})
    y = pd.DataFrame({"x1_dot": np.cos(t)})
    with pytest.warns(UserWarning, match=r"'0 = x1 - a1'\) does not hold on the data: after "
                                         r"the fit its residual keeps 100 %"):
        PolyCCRegressor(equations=["x1_dot = x2", "0 = x1 - a1"]).fit(X, y)
    with warnings.catch_warnings():  # a relation that holds (a circle) says nothing
        warnings.simplefilter("error", UserWarning)
        circle = PolyCCRegressor(equations=["x1_dot = x2", "0 = x2^2 + (x1 - a2)^2 - a1"],
                                 param_init={"a2": 1.5}).fit(X, y)
    assert circle.params_["a1"] == pytest.approx(1.0)
    assert circle.params_["a2"] == pytest.approx(2.0)


def test_a_generator_as_random_state_gives_a_reproducible_fit():
    t = np.linspace(0.0, 10.0, 200)
    x = np.sin(t) + 0.3 * np.sin(2.3 * t)
    X = pd.DataFrame({"x1": x})
    y = pd.DataFrame({"x1_dot": 1.5 * np.tanh(2 * x) + 0.7 * np.exp(-0.8 * x**2)
                      + np.sin(1.3 * x)})
    # three nonlinear parameters or more: the starts of the search are drawn
    equations = ["x1_dot = a1 tanh(a2 x1) + a3 exp(-a4 x1^2) + a5 sin(a6 x1)"]
    fits = [PolyCCRegressor(equations=equations, random_state=np.random.default_rng(5)).fit(X, y)
            for _ in range(3)]
    assert fits[0].params_ == fits[1].params_ == fits[2].params_


def test_score_without_y_points_to_the_simulation_scorer(record):
    X, truth = record
    model = PolyCCRegressor(equations=truth.base_equations).fit(X)
    with pytest.raises(ValueError, match=r"score needs y.*make_simulation_scorer"):
        model.score(X, None)


def test_skeleton_names_that_break_latex_are_drawn_as_given(record):
    import io

    import matplotlib.pyplot as plt

    from sklearn_pycc import compare_skeletons
    from sklearn_pycc.plotting import plot_comparison

    X, truth = record
    names = ["$\\frac{", "a_b^c{", "x $ y", "100% \\"]
    table = compare_skeletons({name: truth.base_equations for name in names}, X)
    fig = plot_comparison(table)
    try:
        fig.savefig(io.BytesIO(), format="png")  # mathtext would fail here
        assert [label.get_text() for label in fig.axes[0].get_xticklabels()] == names
    finally:
        plt.close(fig)


# -- the public functions check their arguments as scikit-learn's do ------------------------
def test_public_functions_name_the_argument_they_refuse(record):
    from sklearn.utils._param_validation import InvalidParameterError

    from sklearn_pycc import compare_skeletons, from_tables, to_symbolic
    from sklearn_pycc.model_selection import make_simulation_scorer

    X, truth = record
    model = PolyCCRegressor(equations=truth.base_equations).fit(X)
    cases = [
        (lambda: make_simulation_scorer(rtol="tight"), "'rtol' parameter of make_simulation"),
        (lambda: make_simulation_scorer(horizon=-1.0), "'horizon' parameter"),
        (lambda: diagnose(model, X, min_improvement=1.5), "'min_improvement' parameter of diag"),
        (lambda: diagnose(model, X, held_out="yes"), "'held_out' parameter of diagnose"),
        (lambda: compare_skeletons([truth.base_equations], X, estimator="poly"),
         "'estimator' parameter of compare_skeletons"),
        (lambda: to_symbolic(model, maxsize=0), "'maxsize' parameter of to_symbolic"),
        (lambda: from_tables(truth.base_equations, [1, 2]), "'curves' parameter of from_tabl"),
    ]
    for call, message in cases:
        with pytest.raises(InvalidParameterError, match=message):
            call()


def test_a_term_that_leaves_its_domain_on_the_record_is_named_with_where():
    # a level that noise reads below zero under a sqrt: refused before the solver sees NaN
    t = np.arange(0.0, 50.0, 0.5)
    level = 0.5 + 0.4 * np.sin(0.3 * t)
    level[40] = -0.02
    X = pd.DataFrame({"t": t, "x1": level, "u": np.ones_like(t)})
    y = np.gradient(level, t)
    with pytest.raises(ValueError, match=r"equations\[0\] \(x1_dot\) is not finite at t=20 "
                                         r"\(u=1, x1=-0\.02.*the term of a2.*on 1 of the "
                                         r"fitted rows.*sqrt\(abs\(x1\)\)"):
        PolyCCRegressor(equations=["x1_dot = a1 u - a2 sqrt(x1)"]).fit(X, y)
    # written for every measured value, it fits
    PolyCCRegressor(equations=["x1_dot = a1 u - a2 sqrt(abs(x1))"]).fit(X, y)
