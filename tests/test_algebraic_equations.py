"""Equations without a derivative of their own: static, algebraic, conserved quantities.

A static equation ``F1 = f1(x1)`` is fitted like any other and predicts its
left side; an implicit relation ``0 = ...`` and a further relation among
derivatives other equations define (a conserved quantity) join the loss,
weighted by ``equation_weights``, and stay out of simulations. Curves in a
denominator are fitted with the denominator multiplied out.
"""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.model_selection import GridSearchCV, KFold

from sklearn_pycc import (
    InterpolatedCCRegressor,
    NeuralCCRegressor,
    PolyCCRegressor,
    Skeleton,
    SkeletonError,
    SymbolicCCRegressor,
    diagnose,
)


def relative_rmse(values, truth) -> float:
    truth = np.asarray(truth, dtype=float)
    return float(np.sqrt(np.mean((np.asarray(values) - truth) ** 2)) / np.ptp(truth))


def quick_neural(**kwargs):
    return NeuralCCRegressor(random_state=0, **kwargs)


def quick_symbolic(**kwargs):
    return SymbolicCCRegressor(random_state=0, generations=10, population_size=200,
                               max_iterations=2, **kwargs)


BACKENDS = {
    "poly": lambda **kw: PolyCCRegressor(degree=11, **kw),
    "neural": quick_neural,
    "symbolic": lambda **kw: quick_symbolic(unary_operators=("sin",), **kw),
    "interpolated": lambda **kw: InterpolatedCCRegressor(
        estimator=PolyCCRegressor(degree=11), **kw),
}


# -- the skeleton ----------------------------------------------------------------------------
def test_a_static_equation_predicts_its_left_side():
    sk = Skeleton(["F1 = f1(x1)"])
    assert sk.states == [] and sk.derivatives == []
    assert sk.outputs == ["F1"] and sk.targets == ["F1"]
    assert sk.inputs == ["x1"] and sk.variables == ["x1"]
    assert [eq.kind for eq in sk.residual_equations] == ["static"]


def test_equations_of_every_kind_in_one_skeleton():
    sk = Skeleton(["x1_dot = x2", "F_ext = f1(x1) + f2(x1) x2_dot", "Fs = a1 f1(x1)",
                   "0 = x2 x2_dot + f1(x1) x2 - a2 F_ext x2"])
    assert [eq.kind for eq in sk.residual_equations] == ["explicit", "implicit", "static",
                                                          "algebraic"]
    assert sk.states == ["x1", "x2"] and sk.outputs == ["Fs"]
    assert sk.targets == ["x1_dot", "x2_dot", "Fs"]
    assert "Fs" not in sk.inputs and "F_ext" in sk.inputs
    # the simulation integrates the differential equations alone
    assert [eq.index for eq in sk.parsed] == [0, 1]
    assert [eq.index for eq in sk.algebraic] == [2, 3]


def test_a_conserved_quantity_removes_the_ambiguity_it_settles():
    base = Skeleton(["x1_dot = x2", "x2_dot = -f1(x2) - f2(x1)"])
    energy = Skeleton([*base.equations, "0 = x2 x2_dot + f2(x1) x2"])
    assert not base.identifiability().identifiable
    assert energy.identifiability().identifiable


@pytest.mark.parametrize("equations, words", [
    (["x1_dot = x2", "x2 = x1 + 1"], "nothing to fit"),
    (["y = f1(x)", "y = a1 x"], "duplicate left-hand side y"),
])
def test_algebraic_equations_that_cannot_be_meant(equations, words):
    with pytest.raises(SkeletonError, match=words) as info:
        Skeleton(equations)
    assert info.value.equation == 1


# -- static fits on every backend ----------------------------------------------------------------
@pytest.fixture(scope="module")
def static_record():
    x = np.linspace(-10, 10, 1000)
    return pd.DataFrame({"x1": x, "F1_th": x + 0.1 * x**2 + np.sin(x)})


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_a_static_curve_is_fitted_by_every_backend(static_record, backend):
    model = BACKENDS[backend](equations=["F1_th = f1(x1)"])
    model.fit(static_record)  # the left side is read from X
    predicted = model.predict(static_record[["x1"]])
    assert predicted.shape == (1000, 1)
    assert relative_rmse(predicted[:, 0], static_record["F1_th"]) < 0.02
    curve = model.cc_curves()["f1"]
    assert relative_rmse(curve["f1"], curve["x"] + 0.1 * curve["x"] ** 2
                         + np.sin(curve["x"])) < 0.02
    assert model.score(static_record[["x1"]], static_record["F1_th"]) > 0.999
    assert model.derivative_source_.startswith("none needed")


def test_a_static_target_may_come_as_y_and_a_gauge_is_kept(static_record):
    x = static_record[["x1"]].rename(columns={"x1": "x"})
    y = pd.Series(2.0 + 0.5 * x["x"] ** 2, name="y")
    model = PolyCCRegressor(equations=["y = a1 + f1(x)"], degree=3).fit(x, y)
    assert model.predict(x).shape == (1000,)  # a series in, one column out
    assert model.gauge_ == {"f1(0)=0": model.gauge_["f1(0)=0"]}
    assert model.params_["a1"] == pytest.approx(2.0)
    assert model.equations()[0] == "y = 2 + f1(x)"


def test_an_implicit_relation_among_measured_quantities():
    # a static force balance written as a relation: 0 = F - f1(x) - a1 v
    rng = np.random.default_rng(0)
    x, v = rng.uniform(-2, 2, 500), rng.uniform(-1, 1, 500)
    X = pd.DataFrame({"x": x, "v": v, "F": 0.5 * x**3 + 0.3 * v})
    model = PolyCCRegressor(equations=["0 = F - f1(x) - a1 v"], degree=5).fit(X)
    assert model.params_["a1"] == pytest.approx(0.3, rel=1e-6)
    assert model.predict(X).shape == (500, 0)  # no derivative, no output: nothing to predict


def test_static_skeletons_compete_in_a_grid_search(static_record):
    search = GridSearchCV(PolyCCRegressor(degree=11),
                          {"equations": [["F1_th = a1 x1"], ["F1_th = f1(x1)"]]},
                          cv=KFold(3, shuffle=True, random_state=0), error_score="raise")
    search.fit(static_record[["x1"]], static_record["F1_th"])
    assert search.best_params_["equations"] == ["F1_th = f1(x1)"]


def test_a_static_model_is_not_simulated_or_diagnosed(static_record):
    model = PolyCCRegressor(equations=["F1_th = f1(x1)"], degree=5).fit(static_record)
    with pytest.raises(ValueError, match=r"no differential equation.*use predict"):
        model.simulate(np.linspace(0, 1, 5), [])
    with pytest.raises(ValueError, match="no differential equation"):
        diagnose(model, static_record)
    with pytest.raises(ValueError, match="no differential equation"):
        PolyCCRegressor(equations=["F1_th = f1(x1)"], fit_mode="simulation").fit(static_record)


# -- a conserved quantity in the loss ------------------------------------------------------------
BASE = ["x1_dot = x2", "x2_dot = -f1(x2) - f2(x1)"]
ENERGY = [*BASE, "0 = x2 x2_dot + f2(x1) x2"]


@pytest.fixture(scope="module")
def free_oscillation():
    """One orbit of an undamped hardening spring: friction and spring trade off on it."""
    t = np.linspace(0, 20, 2000)
    sim = Skeleton(["x1_dot = x2", "x2_dot = -f2(x1)"]).simulate(
        t, [1.5, 0.0], {"f2": lambda x: x + x**3}, return_derivatives=True)
    y = sim[["x1_dot", "x2_dot"]].copy()
    rng = np.random.default_rng(0)
    y["x2_dot"] += 0.01 * y["x2_dot"].std() * rng.standard_normal(len(y))
    return sim[["t", "x1", "x2"]], y


def curve_errors(model):
    curves = model.cc_curves()
    x = curves["f2"]["x"]
    spring = x + x**3
    return (float(np.sqrt(np.mean(curves["f1"]["f1"] ** 2)) / np.ptp(spring)),
            relative_rmse(curves["f2"]["f2"], spring))


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["poly", "neural", "symbolic"])
def test_a_conserved_energy_identifies_what_one_orbit_cannot(free_oscillation, backend):
    X, y = free_oscillation
    make = {"poly": lambda **kw: PolyCCRegressor(degree=5, **kw), "neural": quick_neural,
            "symbolic": quick_symbolic}[backend]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alone = make(equations=BASE).fit(X, y)
    with_energy = make(equations=ENERGY).fit(X, y)
    assert with_energy.gauge_ == {}  # the energy equation pins f2's offset
    friction, spring = curve_errors(with_energy)
    assert friction < 0.005 and spring < 0.005
    if backend != "neural":  # a small network's own smoothness hides the trade-off
        assert curve_errors(alone)[0] > 20 * friction


@pytest.mark.parametrize("backend", ["poly", "neural"])
def test_equation_weights_set_how_much_each_relation_counts(backend):
    # two relations that disagree: y says a1 = 1, z says a1 = 2. Each residual is
    # divided by its size (RMS of y, and of z: twice as large), then weighted, so
    # a1 = (w1^2 + w2^2 / 2) / (w1^2 + w2^2 / 4)
    x = np.linspace(-1, 1, 200)
    X = pd.DataFrame({"x": x, "y": x, "z": 2 * x})
    make = {"poly": PolyCCRegressor, "neural": quick_neural}[backend]
    for w, expected in [(1e-3, 1.0), (1.0, 1.2), (1e3, 2.0)]:
        model = make(equations=["y = a1 x", "0 = z - a1 x"], equation_weights=[1, w]).fit(X)
        assert model.params_["a1"] == pytest.approx(expected, rel=1e-3), w


@pytest.mark.parametrize("weights, words", [
    ([1, 1], "holds 2 value"), ([1, -1, 1], r"equation_weights\[1\]"),
    ([0, 0, 0], "all zero"), ([1, np.nan, 1], r"equation_weights\[1\]"),
])
def test_equation_weights_are_checked_against_the_skeleton(free_oscillation, weights, words):
    X, y = free_oscillation
    with pytest.raises(ValueError, match=words):
        PolyCCRegressor(equations=ENERGY, equation_weights=weights).fit(X, y)


def test_simulate_leaves_algebraic_equations_out_and_says_so_once(free_oscillation):
    X, y = free_oscillation
    model = PolyCCRegressor(equations=ENERGY, degree=5).fit(X, y)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim = model.simulate(X["t"].to_numpy()[:200], [1.5, 0.0])
    notes = [w for w in caught if "no derivative of its own" in str(w.message)]
    assert len(notes) == 1 and "equations[2]" in str(notes[0].message)
    np.testing.assert_allclose(sim["x1"], X["x1"][:200], atol=1e-3)
    with pytest.raises(ValueError, match=r"equations\[2\].*fit_mode='equation'"):
        PolyCCRegressor(equations=ENERGY, fit_mode="simulation").fit(X, y)


def test_a_static_output_is_simulated_and_diagnosed_along_with_the_states(free_oscillation):
    X, y = free_oscillation
    X = X.assign(Fs=X["x1"] + X["x1"] ** 3)  # a force sensor on the spring
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = -f1(x1)", "Fs = f1(x1)"],
                            degree=3).fit(X, y)
    assert model.predict(X).shape == (len(X), 3)
    assert model.score(X, y.assign(Fs=X["Fs"])) > 0.999
    sim = model.simulate(X["t"].to_numpy()[:100], [1.5, 0.0])
    assert list(sim.columns) == ["t", "x1", "x2", "Fs"]
    np.testing.assert_allclose(sim["Fs"], model.functions_["f1"](sim["x1"]), rtol=1e-12)
    report = diagnose(model, X, y)
    assert list(report.derivatives.index) == ["x1_dot", "x2_dot"]


# -- curves in a denominator ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def denominator_record():
    """The published first-order example: x_dot = (F_ext - f1(x)) / f2(x), f2 = 1 + |x|."""
    t = np.linspace(0, 50, 1000)
    sim = Skeleton(["x_dot = (F_ext - f1(x))/f2(x)"]).simulate(
        t, [0.5], {"f1": lambda x: 0.1 * x + 0.2 * np.sin(3 * x),
                   "f2": lambda x: 1 + np.abs(x)},
        inputs={"F_ext": lambda t: 3.0 * np.cos(t)}, return_derivatives=True)
    return sim


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["poly", "neural"])
def test_curves_in_a_denominator_are_trained(denominator_record, backend):
    sim = denominator_record
    make = {"poly": lambda **kw: PolyCCRegressor(degree=9, **kw),
            # the published recipe's wide networks: with the denominator in the loss they
            # blew up to f2 = -7000; multiplied out, they train
            "neural": lambda **kw: quick_neural(hidden_layer_sizes=(100, 100, 100),
                                                max_epochs=20, **kw)}
    model = make[backend](equations=["x_dot = (F_ext - f1(x))/f2(x)"])
    model.fit(sim[["t", "x", "F_ext"]], sim[["x_dot"]])
    curves = model.cc_curves()
    x = curves["f2"]["x"]
    assert relative_rmse(curves["f2"]["f2"], 1 + np.abs(x)) < 0.02
    assert relative_rmse(curves["f1"]["f1"], 0.1 * x + 0.2 * np.sin(3 * x)) < 0.02
    again = model.simulate(sim["t"], [0.5], inputs={"F_ext": lambda t: 3.0 * np.cos(t)})
    assert relative_rmse(again["x"], sim["x"]) < 0.02
