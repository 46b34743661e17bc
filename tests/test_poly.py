"""PolyCCRegressor: accuracy on the reference systems and the estimator contract."""

import copy
import io
import pickle
import warnings

import joblib
import numpy as np
import pandas as pd
import pytest
from conftest import STICK_SLIP_FUNCTIONAL, split
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, KFold, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import FunctionTransformer

from sklearn_pycc import (
    CCRegressor,
    GaugeWarning,
    IdentifiabilityError,
    PolyCCRegressor,
    RankDeficiencyWarning,
    SkeletonError,
    datasets,
)


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


# -- acceptance: the seed paper's skeletons --------------------------------------------
def test_parametric_stick_slip_recovers_parameters_and_trajectory(stick_slip):
    frame, truth = stick_slip
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.parametric_equations).fit(X, y)
    for name in ("a1", "a2", "a4", "a5"):
        assert model.params_[name] == pytest.approx(truth.params[name], rel=1e-3)
    assert model.params_["a3"] >= 100
    sim = model.simulate(frame["t"], y0=[0.0, 0.0], inputs={"F_ext": truth.inputs["F_ext"]})
    assert rmse(sim["x1"], frame["x1"]) <= 1e-3
    assert model.nonlinear_params_ == ["a3"]


def test_functional_duffing_curves_within_1e3_of_their_spread(duffing):
    frame, truth = duffing
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.equations, constraints=["f1 odd", "f2 odd"])
    model.fit(X, y)
    curves = model.cc_curves(n=300)
    for name in ("f1", "f2"):
        x, fitted = curves[name]["x"], curves[name][name]
        true = truth.functions[name](x)
        assert rmse(fitted, true) <= 1e-3 * np.std(true)
    assert model.gauge_ == {}


def test_hybrid_skeleton_fits(duffing):
    frame, _truth = duffing
    X, y = split(frame)
    eqs = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a4 x1 - a5 x1^3"]
    model = PolyCCRegressor(equations=eqs, constraints=["f1 odd"]).fit(X, y)
    assert model.params_["a4"] == pytest.approx(-1.05, rel=1e-6)
    assert model.params_["a5"] == pytest.approx(1.02, rel=1e-6)
    assert model.score(X, y) > 1 - 1e-10


def test_first_order_family_fits_and_simulates():
    frame, truth = datasets.make_first_order(return_truth=True)
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.equations, degree=9).fit(X, y)
    assert model.score(X, y) > 0.9999
    pred = model.predict(X)
    assert pred.shape == (len(frame), 1)
    sim = model.simulate(frame["t"], [frame["x1"].iloc[0]],
                         inputs={"F_ext": truth.inputs["F_ext"]})
    assert rmse(sim["x1"], frame["x1"]) < 1e-3


def test_two_dof_with_shared_coupling_curve_fits_and_simulates():
    frame, truth = datasets.make_two_dof(n_samples=1500, return_truth=True)
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.equations, degree=5).fit(X, y)
    # the gauge pinned the additive constants the skeleton cannot determine
    assert set(model.gauge_) == {"f2(0)=0", "f4(0)=0", "f5(0)=0"}
    curve = model.cc_curves()["f3"]
    assert rmse(curve["f3"], truth.functions["f3"](curve["x"])) < 1e-6
    states = ["x1", "x2", "x3", "x4"]
    sim = model.simulate(frame["t"], frame.loc[0, states].to_numpy(),
                         inputs={"F_ext": truth.inputs["F_ext"]})
    assert rmse(sim[["x1", "x2"]], frame[["x1", "x2"]]) < 1e-3


# -- constraints are exact in the curve's own argument -----------------------------------
def test_constraints_hold_exactly(stick_slip):
    frame, _ = stick_slip
    X, y = split(frame)
    model = PolyCCRegressor(equations=STICK_SLIP_FUNCTIONAL,
                            constraints=["f1 odd", {"constraint": "f2(0.5)=2.5e-1"}])
    model.fit(X, y)
    x = np.linspace(-2, 2, 41)
    f1, f2 = model.functions_["f1"], model.functions_["f2"]
    np.testing.assert_allclose(f1(-x), -f1(x), rtol=0, atol=1e-12)
    assert f2(0.5) == pytest.approx(0.25, abs=1e-10)


def test_even_constraint():
    frame = datasets.make_van_der_pol(n_samples=800)
    X, y = split(frame)
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x1) x2 - f2(x1)"],
                            constraints=["f1 even", "f2 odd"], degree=4).fit(X, y)
    x = np.linspace(-2, 2, 11)
    np.testing.assert_allclose(model.functions_["f1"](x), model.functions_["f1"](-x),
                               atol=1e-12)
    np.testing.assert_allclose(model.functions_["f1"](x), 1.0 * (x**2 - 1), atol=1e-8)


# -- gauge ----------------------------------------------------------------------------------
def test_gauge_auto_pins_and_records(duffing):
    frame, truth = duffing
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.equations, degree=3).fit(X, y)
    assert list(model.gauge_) == ["f2(0)=0"]
    assert "additive constant" in model.gauge_["f2(0)=0"]
    assert model.functions_["f2"](0.0) == pytest.approx(0.0, abs=1e-12)
    curves = model.cc_curves()
    assert rmse(curves["f1"]["f1"], truth.functions["f1"](curves["f1"]["x"])) < 1e-8


def test_gauge_raise_and_warn(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(IdentifiabilityError, match="f2"):
        PolyCCRegressor(equations=truth.equations, gauge="raise").fit(X, y)
    with pytest.warns(GaugeWarning, match="additive constant"):
        model = PolyCCRegressor(equations=truth.equations, gauge="warn", degree=3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RankDeficiencyWarning)
            model.fit(X, y)
    assert model.gauge_ == {}
    with pytest.raises(ValueError, match="gauge"):
        PolyCCRegressor(equations=truth.equations, gauge="sometimes").fit(X, y)


def test_scale_gauge_pins_parameter(duffing):
    frame, _ = duffing
    X, y = split(frame)
    eqs = ["x1_dot = x2", "x2_dot = F_ext - a1 f1(x2) - f2(x1)"]
    model = PolyCCRegressor(equations=eqs, constraints=["f1 odd", "f2 odd"], degree=3).fit(X, y)
    assert model.params_ == {"a1": 1.0}
    assert "a1=1" in model.gauge_


def test_rank_deficient_design_is_reported_with_names():
    rng = np.random.default_rng(0)
    x = rng.normal(size=200)
    X = pd.DataFrame({"u": x, "v": 2.0 * x})  # u and v perfectly collinear
    y = pd.DataFrame({"z_dot": np.sin(x)})
    model = PolyCCRegressor(equations=["z_dot = f1(u) + a1 v"], constraints=["f1 odd"],
                            degree=3)
    with pytest.warns(RankDeficiencyWarning, match=r"a1.*f1|f1.*a1"):
        model.fit(X, y)
    with pytest.raises(IdentifiabilityError, match="a1"):
        clone(model).set_params(gauge="raise").fit(X, y)


# -- the estimator contract --------------------------------------------------------------------
def test_predict_shape_order_and_score(duffing):
    frame, truth = duffing
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.equations, constraints=["f1 odd"]).fit(X, y)
    pred = model.predict(X)
    assert pred.shape == (len(X), 2)
    np.testing.assert_allclose(pred, y[["x1_dot", "x2_dot"]].to_numpy(), atol=1e-8)
    # y matched by name, whatever its column order
    assert model.score(X, y[["x2_dot", "x1_dot"]]) == pytest.approx(1.0)
    # X columns matched by name, whatever their order
    np.testing.assert_allclose(model.predict(X[X.columns[::-1]]), pred)


def test_equations_written_out(duffing):
    frame, truth = duffing
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.equations, constraints=["f1 odd", "f2 odd"],
                            degree=3).fit(X, y)
    lines = model.equations(4)
    assert lines[:2] == truth.equations
    assert lines[2] == "f1(x2) = 0.3*x2"
    assert lines[3] == "f2(x1) = -1.05*x1 + 1.02*x1^3"
    # the hyperparameter is still the list given
    assert list(model.equations) == truth.equations
    assert model.get_params()["equations"] is truth.equations


def test_fit_does_not_modify_user_objects(duffing):
    frame, truth = duffing
    X, y = split(frame)
    X_before, y_before = X.copy(), y.copy()
    eqs = list(truth.equations)
    constraints = [{"constraint": "f1 odd"}, "f2 odd"]
    cons_before = copy.deepcopy(constraints)
    PolyCCRegressor(equations=eqs, constraints=constraints).fit(X, y)
    pd.testing.assert_frame_equal(X, X_before)
    pd.testing.assert_frame_equal(y, y_before)
    assert eqs == truth.equations and constraints == cons_before


def test_clone_pickle_joblib_round_trips(stick_slip):
    frame, truth = stick_slip
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.parametric_equations).fit(X, y)
    pred = model.predict(X)
    restored = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(restored.predict(X), pred)
    buffer = io.BytesIO()
    joblib.dump(model, buffer)
    buffer.seek(0)
    np.testing.assert_array_equal(joblib.load(buffer).predict(X), pred)
    sim_a = model.simulate(frame["t"][:200], [0, 0], inputs={"F_ext": np.cos})
    sim_b = restored.simulate(frame["t"][:200], [0, 0], inputs={"F_ext": np.cos})
    pd.testing.assert_frame_equal(sim_a, sim_b)
    fresh = clone(model)
    assert fresh.get_params()["equations"] == model.get_params()["equations"]
    assert not hasattr(fresh, "params_")


@pytest.mark.slow
def test_grid_search_picks_the_true_skeleton(duffing):
    frame, _ = duffing
    X, y = split(frame)
    true = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
    position_damping = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) x1 - f2(x1)"]
    no_stiffness = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x2 x1)"]
    search = GridSearchCV(
        PolyCCRegressor(degree=5),
        {"equations": [position_damping, true, no_stiffness]},
        cv=KFold(5), error_score="raise", n_jobs=2,
    )
    search.fit(X, y)
    assert search.best_params_["equations"] == true
    assert np.isfinite(search.cv_results_["mean_test_score"]).all()
    assert search.best_score_ > 0.999999


def test_pipeline_last_step(duffing):
    frame, truth = duffing
    X, y = split(frame)
    identity = FunctionTransformer(lambda Z: Z, feature_names_out="one-to-one")
    pipe = make_pipeline(identity.set_output(transform="pandas"),
                         PolyCCRegressor(equations=truth.equations, constraints=["f1 odd"]))
    scores = cross_val_score(pipe, X, y, cv=3, error_score="raise")
    assert np.all(scores > 0.9999)


def test_skeleton_object_and_constraint_dicts_are_accepted(duffing):
    from sklearn_pycc import Skeleton

    frame, truth = duffing
    X, y = split(frame)
    sk = Skeleton(truth.equations, ["f1 odd"])
    model = PolyCCRegressor(equations=sk, constraints=[{"constraint": "f2 odd"}]).fit(X, y)
    assert {str(c) for c in model.skeleton_.constraints} == {"f1 odd", "f2 odd"}


def test_param_init_and_degree_dict(stick_slip):
    frame, truth = stick_slip
    X, y = split(frame)
    model = PolyCCRegressor(equations=truth.parametric_equations, param_init={"a3": 300.0})
    model.fit(X, y)
    assert model.params_["a3"] == pytest.approx(500, rel=1e-6)
    model = PolyCCRegressor(equations=STICK_SLIP_FUNCTIONAL, constraints=["f1 odd"],
                            degree={"f1": 11, "f2": 3}).fit(X, y)
    assert model.coefficients_["f1"].size == 6 and model.coefficients_["f2"].size == 4


def test_base_class_is_not_a_backend(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(TypeError, match="abstract class CCRegressor"):
        CCRegressor(equations=truth.equations).fit(X, y)


# -- bad input, each naming the culprit ------------------------------------------------------
@pytest.fixture
def fitted(duffing):
    frame, truth = duffing
    X, y = split(frame)
    return PolyCCRegressor(equations=truth.equations, constraints=["f1 odd"],
                           degree=3).fit(X, y), X, y


def test_missing_column_is_named(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(ValueError, match="no column 'F_ext'"):
        PolyCCRegressor(equations=truth.equations).fit(X.drop(columns="F_ext"), y)


@pytest.mark.parametrize("value, word", [(np.nan, "NaN"), (np.inf, "infinity")])
def test_non_finite_values_are_located(duffing, value, word):
    frame, truth = duffing
    X, y = split(frame)
    bad_X = X.copy()
    bad_X.loc[bad_X.index[7], "x2"] = value
    if word == "NaN":  # a missing sample: the experiment is split there, and y with it
        with pytest.warns(UserWarning, match=r"x2 misses 1 sample.*into 2 experiments"):
            model = PolyCCRegressor(equations=truth.equations).fit(bad_X, y)
        assert model.params_ == pytest.approx(
            PolyCCRegressor(equations=truth.equations).fit(X, y).params_, rel=0.02)
    else:
        with pytest.raises(ValueError, match=rf"X column 'x2' contains {word} at row 7"):
            PolyCCRegressor(equations=truth.equations).fit(bad_X, y)
    bad_y = y.copy()
    bad_y.loc[bad_y.index[3], "x2_dot"] = value
    with pytest.raises(ValueError, match=rf"y column 'x2_dot' contains {word} at row 3"):
        PolyCCRegressor(equations=truth.equations).fit(X, bad_y)


def test_length_mismatch(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(ValueError, match=r"X has 1500 rows but y has 1499"):
        PolyCCRegressor(equations=truth.equations).fit(X, y.iloc[:-1])


def test_y_columns_must_match_the_derivatives(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(ValueError, match=r"missing \['x2_dot'\]"):
        PolyCCRegressor(equations=truth.equations).fit(X, y[["x1_dot"]])
    with pytest.raises(ValueError, match=r"unexpected \['x3_dot'\]"):
        PolyCCRegressor(equations=truth.equations).fit(X, y.assign(x3_dot=0.0))
    with pytest.raises(ValueError, match="2 derivatives"):
        PolyCCRegressor(equations=truth.equations).fit(X, y.to_numpy()[:, :1])


def test_non_numeric_column_is_named(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(ValueError, match="column 'F_ext' is not numeric"):
        PolyCCRegressor(equations=truth.equations).fit(X.assign(F_ext="high"), y)


def test_unknown_and_foreign_constraints(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(SkeletonError, match="unknown constraint"):
        PolyCCRegressor(equations=truth.equations, constraints=["f1 monotone"]).fit(X, y)
    with pytest.raises(SkeletonError, match="names f3"):
        PolyCCRegressor(equations=truth.equations, constraints=["f3 odd"]).fit(X, y)
    with pytest.raises(SkeletonError, match="both odd and even"):
        PolyCCRegressor(equations=truth.equations, constraints=["f1 odd", "f1 even"]).fit(X, y)


def test_bad_hyperparameters(duffing):
    frame, truth = duffing
    X, y = split(frame)
    with pytest.raises(ValueError, match="degree of f1"):
        PolyCCRegressor(equations=truth.equations, degree={"f1": -1}).fit(X, y)
    with pytest.raises(ValueError, match="'f9'"):
        PolyCCRegressor(equations=truth.equations, degree={"f9": 3}).fit(X, y)
    with pytest.raises(ValueError, match="basis"):
        PolyCCRegressor(equations=truth.equations, basis="fourier").fit(X, y)
    with pytest.raises(ValueError, match="'a9'"):
        PolyCCRegressor(equations=truth.equations, param_init={"a9": 1}).fit(X, y)
    with pytest.raises(SkeletonError, match="no skeleton"):
        PolyCCRegressor().fit(X, y)


def test_simulate_bad_input(fitted):
    model, _X, _ = fitted
    t = np.linspace(0, 1, 11)
    with pytest.raises(ValueError, match="needs the input 'F_ext'"):
        model.simulate(t, [0, 0])
    with pytest.raises(ValueError, match="unknown input 'F'"):
        model.simulate(t, [0, 0], inputs={"F_ext": np.cos, "F": np.sin})
    with pytest.raises(ValueError, match="y0 must hold 2 values"):
        model.simulate(t, [0, 0, 0], inputs={"F_ext": np.cos})
    with pytest.raises(ValueError, match="strictly increasing"):
        model.simulate(t[::-1], [0, 0], inputs={"F_ext": np.cos})
    with pytest.raises(ValueError, match="no value for the state 'x2'"):
        model.simulate(t, {"x1": 0.0}, inputs={"F_ext": np.cos})
    sim = model.simulate(t, {"x2": 0.0, "x1": 1.0}, inputs={"F_ext": 0.5})
    assert sim["x1"].iloc[0] == 1.0 and list(sim.columns) == ["t", "x1", "x2"]


def test_predict_checks_columns_and_fit_state(fitted):
    model, X, _ = fitted
    with pytest.raises(ValueError, match="no column 'x1'"):
        model.predict(X.drop(columns="x1"))
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        PolyCCRegressor(equations=["x1_dot = f1(x1)"]).predict(X)


def test_parameters_shared_by_two_equations():
    frame, _ = datasets.make_two_dof(n_samples=1200, return_truth=True)
    X, y = split(frame)
    eqs = [
        "x1_dot = x3",
        "x2_dot = x4",
        "x3_dot = F_ext - a1 x3 - a2 x1 - a3 (x1 - x2) - a6 (x1 - x2)^3",
        "x4_dot = -a4 x4 - a5 x2 + a3 (x1 - x2) + a6 (x1 - x2)^3",
    ]
    model = PolyCCRegressor(equations=eqs).fit(X, y)
    expected = {"a1": 0.2, "a2": 1.0, "a3": 0.5, "a4": 0.15, "a5": 1.2, "a6": 0.3}
    for name, value in expected.items():
        assert model.params_[name] == pytest.approx(value, rel=1e-8)


def test_time_symbol_in_a_skeleton(duffing):
    frame, _ = duffing
    X, y = split(frame)
    eqs = ["x1_dot = x2", "x2_dot = a1 cos(1.2 t) - f1(x2) - f2(x1)"]
    model = PolyCCRegressor(equations=eqs, constraints=["f1 odd", "f2 odd"], degree=3)
    model.fit(X.drop(columns="F_ext"), y)
    assert model.params_["a1"] == pytest.approx(0.5, rel=1e-8)
    sim = model.simulate(frame["t"][:300], [1.0, 0.0])
    assert rmse(sim["x1"], frame["x1"][:300]) < 1e-4


@pytest.mark.parametrize("kind", ["legendre", "chebyshev", "power"])
@pytest.mark.parametrize("parity", [None, "odd", "even"])
@pytest.mark.parametrize("degree", [0, 1, 2, 7, 8])
def test_basis_matches_numpy_vandermonde_and_curve(kind, parity, degree):
    from numpy.polynomial import chebyshev, legendre, polynomial

    from sklearn_pycc.backends.poly.basis import PolyBasis

    vander = {"legendre": legendre.legvander, "chebyshev": chebyshev.chebvander,
              "power": polynomial.polyvander}[kind]
    x = np.linspace(-2, 3, 50)
    basis = PolyBasis(-2, 3, degree, parity, kind)
    u = (x - basis.center) / basis.half
    expected = vander(u, degree)[:, basis.degrees]
    np.testing.assert_allclose(basis.design(x), expected, atol=1e-12)
    coef = np.random.default_rng(degree).normal(size=basis.size)
    np.testing.assert_allclose(basis.curve(coef)(x), expected @ coef, atol=1e-10)
    np.testing.assert_allclose([basis.curve(coef)(float(v)) for v in x], expected @ coef,
                               atol=1e-10)


def test_a_long_records_multi_start_ranks_on_a_thinned_record_and_lands_alike(monkeypatch):
    # every k-th row ranks the starting values of a long record's nonlinear parameter;
    # the winner is then refined on every row, to the optimum the full search finds
    from sklearn_pycc.estimators import poly
    from sklearn_pycc.fitting import problem as _setup

    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(-3.0, 3.0, 12000))
    X = pd.DataFrame({"x": x})
    y = 2.0 * np.tanh(0.7 * x) - 0.5 * x + 0.05 * rng.standard_normal(x.size)
    skeleton = ["x_dot = a1*tanh(a2*x) - a3*x"]
    seen = []
    original = _setup.thinned
    monkeypatch.setattr(poly, "thinned",
                        lambda problem, rows: seen.append(original(problem, rows)) or seen[-1])
    fast = PolyCCRegressor(equations=skeleton).fit(X, y)
    assert [t.data.n_samples for t in seen] == [3000]
    assert seen[0].data["x"][1] == x[4]
    monkeypatch.setattr(poly, "_SEARCH_ROWS", 10**9)
    full = PolyCCRegressor(equations=skeleton).fit(X, y)
    assert len(seen) == 1
    for name in ("a1", "a2", "a3"):
        assert fast.params_[name] == pytest.approx(full.params_[name], rel=1e-7)
    assert fast.params_["a2"] == pytest.approx(0.7, rel=0.02)
