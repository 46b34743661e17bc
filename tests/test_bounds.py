"""Bounds and monotone curves in the skeleton language, held exactly by every backend."""

import pickle

import numpy as np
import pytest

from sklearn_pycc import (
    NeuralCCRegressor,
    PolyCCRegressor,
    Skeleton,
    SkeletonError,
    SymbolicCCRegressor,
    datasets,
    to_symbolic,
)
from sklearn_pycc.exceptions import IdentifiabilityError
from sklearn_pycc.skeleton import Bound

PARAMETRIC = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 tanh(a4 x2)"]
FUNCTIONAL = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
SEMI = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - f1(x1)"]


@pytest.fixture(scope="module")
def record():
    frame = datasets.make_oscillator(hidden=["coulomb_friction"], noise=30,
                                     noise_columns=["x1", "x2", "x1_dot", "x2_dot"],
                                     random_state=0)
    return frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]


def steps(model, name, n=4001):
    """Differences of a fitted curve on a dense grid over its data range."""
    table = model.cc_curves(n=n)[name]
    return np.diff(table[name].to_numpy())


# -- the language -----------------------------------------------------------------------
@pytest.mark.parametrize("text, low, high", [
    ("a2 >= 0", 0.0, np.inf), ("a2 <= 5", -np.inf, 5.0), ("0 <= a2 <= 10", 0.0, 10.0),
    ("10 >= a2 >= -1.5", -1.5, 10.0), ("-2 <= a2", -2.0, np.inf), ("3 >= a2", -np.inf, 3.0),
])
def test_bounds_are_read_in_every_direction(text, low, high):
    skeleton = Skeleton(["x1_dot = -a1 x1 + a2"], [text])
    assert skeleton.bounds == {"a2": (low, high)}
    assert Skeleton(["x1_dot = -a1 x1 + a2"], [str(skeleton.constraints[0])]) == skeleton


def test_bounds_and_monotone_curves_travel_with_the_skeleton():
    skeleton = Skeleton(FUNCTIONAL, ["f1 odd", "f1 increasing", "f2 decreasing"])
    assert skeleton.monotone("f1") == "increasing" and skeleton.monotone("f2") == "decreasing"
    extended = skeleton.add_term(1, "a1 tanh(a2 x2)", constraints=["a1 >= 0", "0 <= a2 <= 50"])
    assert extended.bounds == {"a1": (0.0, np.inf), "a2": (0.0, 50.0)}
    assert "subject to: f1 odd, f1 increasing, f2 decreasing, a1 >= 0" in str(extended)
    assert pickle.loads(pickle.dumps(extended)) == extended
    # several bounds on one parameter meet
    assert Skeleton(["x1_dot = -a1 x1"], ["a1 >= 0", "a1 <= 4", "1 <= a1"]).bounds == {
        "a1": (1.0, 4.0)}
    assert Skeleton(["x1_dot = -a1 x1"], [Bound("a1", 0.0)]).bounds == {"a1": (0.0, np.inf)}


@pytest.mark.parametrize("constraints, message", [
    (["a1 > 0"], "strict comparison '>': write >="),
    (["a9 >= 0"], "names a9, but the skeleton has a1"),
    (["0 <= a1 <= -1"], "empty bound"),
    (["a1 >= 2", "a1 <= 1"], "contradictory bounds on a1"),
    (["a1 <= 0 <= 5"], "stands between its ends"),
    (["a1 >= x1"], "a1 appears in the equations too; a limit to fit has a parameter of its "
                   "own"),
    (["a1 >= f1"], "expected a number or a parameter"),
    (["1 <= 2"], "names exactly one parameter"),
    (["f1 increasing", "f1 decreasing"], "cannot be both increasing and decreasing"),
    (["f1 even", "f1 increasing"], "an even f1 cannot be increasing"),
    (["f1 rising"], "unknown constraint"),
])
def test_bad_bounds_are_named(constraints, message):
    with pytest.raises(SkeletonError, match=message):
        Skeleton(["x1_dot = -a1 x1 - f1(x1)"], constraints)


def test_comparisons_stay_errors_in_equations():
    with pytest.raises(SkeletonError, match="unexpected character '<'"):
        Skeleton(["x1_dot <= x2"])


# -- the polynomial backend --------------------------------------------------------------
def test_linear_and_nonlinear_parameters_stay_within_their_bounds(record):
    X, y = record
    free = PolyCCRegressor(equations=PARAMETRIC).fit(X, y).params_
    assert free["a1"] == pytest.approx(0.1, rel=0.1)
    # inactive bounds change nothing
    loose = PolyCCRegressor(equations=PARAMETRIC, constraints=["a1 >= 0", "a4 >= 0"]).fit(X, y)
    assert loose.params_ == pytest.approx(free, rel=1e-6)
    # active ones hold exactly, and the rest of the model adapts
    tight = PolyCCRegressor(equations=PARAMETRIC,
                            constraints=["a1 <= 0.05", "0 <= a3 <= 0.1", "5 <= a4 <= 8"]).fit(X, y)
    assert tight.params_["a1"] <= 0.05 and tight.params_["a1"] == pytest.approx(0.05, abs=1e-12)
    assert tight.params_["a3"] <= 0.1 and tight.params_["a3"] == pytest.approx(0.1, abs=1e-12)
    assert 5.0 <= tight.params_["a4"] <= 8.0 and tight.params_["a4"] == pytest.approx(8.0)
    assert tight.score(X, y) < loose.score(X, y)


def friction_error(model):
    """RMS distance of the fitted friction curve from the true one (viscous + Coulomb)."""
    table = model.cc_curves(n=400)["f1"]
    v = table["x"].to_numpy()
    return float(np.sqrt(np.mean((table["f1"] - (0.1 * v + 0.3 * np.tanh(20 * v))) ** 2)))


def test_monotone_curves_are_monotone_over_their_whole_range(record):
    X, y = record
    free = PolyCCRegressor(equations=FUNCTIONAL, constraints=["f1 odd"], degree=9).fit(X, y)
    assert steps(free, "f1").min() < 0  # the noise bends the free fit
    shaped = PolyCCRegressor(equations=FUNCTIONAL, degree=9,
                             constraints=["f1 odd", "f1 increasing", "f2 increasing"]).fit(X, y)
    assert steps(shaped, "f1").min() >= 0 and steps(shaped, "f2").min() >= 0
    # the prior knowledge brings the friction curve closer to the truth
    assert friction_error(shaped) < 0.8 * friction_error(free)
    # a shape the data contradict leaves the curve flat, never bent the other way
    wrong = PolyCCRegressor(equations=FUNCTIONAL, constraints=["f2 decreasing"]).fit(X, y)
    assert steps(wrong, "f2").max() <= 1e-12


def test_bounds_hold_through_the_output_error_stage(record):
    X, _ = record
    model = PolyCCRegressor(equations=PARAMETRIC, constraints=["a1 >= 0.2", "a4 >= 0"],
                            fit_mode="simulation").fit(X[["t", "x1", "F_ext"]])
    assert model.params_["a1"] >= 0.2 and model.params_["a4"] >= 0
    assert model.shooting_["nrmse_after"] < 0.1
    shaped = PolyCCRegressor(equations=SEMI, constraints=["f1 increasing", "a1 >= 0"],
                             fit_mode="simulation").fit(X[["t", "x1", "F_ext"]])
    assert steps(shaped, "f1").min() >= 0 and shaped.params_["a1"] >= 0


def test_impossible_constraints_are_named(record):
    X, y = record
    with pytest.raises(SkeletonError, match="an increasing curve cannot take"):
        PolyCCRegressor(equations=SEMI, constraints=[
            "f1 increasing", "f1(0)=0", "f1(1)=-1"]).fit(X, y)
    from sklearn_pycc.fitting.lstsq import InfeasibleError, bounded_lstsq

    A, b = np.eye(3), np.ones(3)
    with pytest.raises(InfeasibleError, match="no coefficients satisfy"):
        bounded_lstsq(A, b, None, None, np.array([[1.0, 0, 0], [-1.0, 0, 0]]),
                      h=np.array([1.0, 0.0]))
    with pytest.raises(ValueError, match="param_init gives a1 = -1"):
        PolyCCRegressor(equations=PARAMETRIC, constraints=["a1 >= 0"],
                        param_init={"a1": -1.0}).fit(X, y)
    scaled = ["x1_dot = x2", "x2_dot = F_ext - a1 f1(x2) - f2(x1)"]
    with pytest.raises(IdentifiabilityError, match="the gauge pins"):
        PolyCCRegressor(equations=scaled, constraints=["0 <= a1 <= 0.5"]).fit(X, y)


# -- the neural and symbolic backends ----------------------------------------------------
def test_neural_parameters_and_curves_keep_their_bounds_and_shapes(record):
    X, y = record
    bounded = NeuralCCRegressor(equations=PARAMETRIC, max_epochs=200, random_state=0,
                                constraints=["a1 >= 0.2", "0 <= a3 <= 0.25", "a4 >= 0"])
    params = bounded.fit(X, y).params_
    assert params["a1"] >= 0.2 and 0 <= params["a3"] <= 0.25 and params["a4"] >= 0
    shaped = NeuralCCRegressor(equations=FUNCTIONAL, max_epochs=200, random_state=0,
                               constraints=["f1 odd", "f1 increasing", "f2 decreasing"])
    shaped.fit(X, y)
    assert steps(shaped, "f1").min() >= 0 and steps(shaped, "f2").max() <= 0
    assert pickle.loads(pickle.dumps(shaped)).predict(X) == pytest.approx(shaped.predict(X))
    with pytest.raises(ValueError, match="non-decreasing activation"):
        NeuralCCRegressor(equations=FUNCTIONAL, constraints=["f1 increasing"],
                          activation="silu", max_epochs=1).fit(X, y)


@pytest.mark.slow
def test_symbolic_fits_and_conversions_keep_bounds_and_shapes(record):
    X, y = record
    constraints = ["a1 >= 0.3", "f1 odd", "f1 increasing"]
    model = SymbolicCCRegressor(equations=SEMI, constraints=constraints, generations=10,
                                random_state=0).fit(X, y)
    assert model.params_["a1"] >= 0.3
    assert steps(model, "f1").min() >= 0
    poly = PolyCCRegressor(equations=SEMI, constraints=constraints).fit(X, y)
    converted = to_symbolic(poly, X, y, generations=10, random_state=0)
    assert converted.params_["a1"] >= 0.3
    assert steps(converted, "f1").min() >= 0


# -- edge cases ---------------------------------------------------------------------------
def test_bounds_far_from_one_and_a_redundant_bounded_term(record):
    X, y = record
    # a bound of the order of 1e5 is met, not reported infeasible
    far = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - 1e-5 a2 x1"]
    model = PolyCCRegressor(equations=far, constraints=["a2 >= 1.2e5"]).fit(X, y)
    assert model.params_["a2"] == pytest.approx(1.2e5) and model.params_["a2"] >= 1.2e5
    # rank deficiency is still reported with bounds in place
    from sklearn_pycc import RankDeficiencyWarning

    redundant = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 + a3 c - a4"]
    constant = X.assign(c=1.0)  # the data cannot tell a3 c from a4
    with pytest.warns(RankDeficiencyWarning, match="a3, a4"):
        PolyCCRegressor(equations=redundant, constraints=["a3 >= 0"]).fit(constant, y)


def test_the_gauge_takes_the_sign_the_bounds_admit(record):
    X, y = record
    scaled = ["x1_dot = x2", "x2_dot = F_ext - a1 f1(x2) - f2(x1)"]
    model = PolyCCRegressor(equations=scaled, constraints=["a1 <= 0"]).fit(X, y)
    assert model.params_["a1"] == -1.0 and "a1=-1" in model.gauge_
    assert model.score(X, y) > 0.9


def test_fixed_or_disordered_shapes_are_refused():
    with pytest.raises(SkeletonError, match="fix it at 1"):
        Skeleton(["x1_dot = -a1 x1"], ["a1 >= 1", "a1 <= 1"])
    with pytest.raises(SkeletonError, match="leaves no interval"):
        Skeleton(["x1_dot = -a1 x1"], ["1 <= a1 <= 1"])
    with pytest.raises(SkeletonError, match="an increasing curve cannot take"):
        Skeleton(["x1_dot = -f1(x1)"], ["f1 increasing", "f1(0)=1", "f1(1)=0"])
    with pytest.raises(SkeletonError, match="an increasing curve cannot take"):
        Skeleton(["x1_dot = -f1(x1)"], ["f1 odd", "f1 increasing", "f1(0.5)=-1"])
    assert str(Skeleton(["x1_dot = -a1 x1"], ["a1 >= 0.1234567"]).constraints[0]) == \
        "a1 >= 0.1234567"


def test_neural_bounds_hold_after_rounding_to_float32(record):
    X, y = record
    model = NeuralCCRegressor(equations=PARAMETRIC, max_epochs=50, random_state=0,
                              constraints=["a1 <= 0.05", "0.2 <= a3 <= 0.3", "a4 >= 0"])
    params = model.fit(X, y).params_
    assert params["a1"] <= 0.05 and 0.2 <= params["a3"] <= 0.3
