"""Characteristic curves through states nobody measures: written out, fitted by output error."""

import warnings

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from sklearn_pycc import NeuralCCRegressor, PolyCCRegressor, Skeleton, datasets
from sklearn_pycc.estimators.base import set_fitted
from sklearn_pycc.fitting.output_error.hidden_curves import (
    curve_form,
    hidden_level_gauge,
    line_laws,
)
from sklearn_pycc.model_selection import make_simulation_scorer
from sklearn_pycc.skeleton.constraints import Constraint

#: two tanks of one cross-section in cascade: the upper one's outflow feeds the lower one
SAME_TANKS = {"a1": 0.02, "a2": 0.04, "a3": 0.04, "a4": 0.045}
CURVES = ["x1_dot = a1 u - f1(x1)", "x2_dot = f1(x1) - f2(x2)"]
INCREASING = ["f1 increasing", "f2 increasing"]
TORRICELLI = ["x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a2 sqrt(x1) - a4 sqrt(x2)"]


def _tanks(n_samples, seed):
    return datasets.make_two_tanks(n_samples=n_samples, rims=(100.0, 100.0),
                                   params=SAME_TANKS, random_state=seed)


def _ideal(frame):
    """The true skeleton at the true parameters (what a perfect fit would give)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=TORRICELLI).fit(frame)
    return set_fitted(model, {"params_": {a: SAME_TANKS[a] for a in ("a1", "a2", "a4")}})


# -- the written-out forms ----------------------------------------------------------------
@pytest.mark.parametrize("points", [(), ((0.0, 0.0),), ((3.0, 1.5),)])
def test_a_monotone_form_increases_over_its_range_whatever_its_numbers(points):
    form = curve_form("f1", 5, (0.0, 7.0), points=points, monotone="increasing")
    assert form.bounds() == {n: (0.0, np.inf) for n in form.names}
    rng = np.random.default_rng(0)
    x = np.linspace(0.0, 7.0, 400)
    u = (x - form.center) / form.half
    for _ in range(20):
        values = dict(zip(form.names, rng.exponential(size=len(form.names))))
        curve = np.polynomial.Polynomial(form.series(values))(u)
        assert np.all(np.diff(curve) >= -1e-12)
        for at, value in points:
            held = np.polynomial.Polynomial(form.series(values))((at - form.center) / form.half)
            assert held == pytest.approx(value, abs=1e-12)


@pytest.mark.parametrize("parity", ["odd", "even"])
def test_an_odd_or_even_form_keeps_its_symmetry(parity):
    form = curve_form("f2", 6, (-1.0, 3.0), parity=parity)
    rng = np.random.default_rng(1)
    values = dict(zip(form.names, rng.normal(size=len(form.names))))
    series = np.polynomial.Polynomial(form.series(values))
    x = np.linspace(0.1, 3.0, 9)
    sign = -1.0 if parity == "odd" else 1.0
    np.testing.assert_allclose(series(-x / form.half), sign * series(x / form.half),
                               atol=1e-12)


def test_a_form_started_on_a_line_follows_it():
    form = curve_form("f1", 7, (2.0, 9.0), points=[(0.0, 0.0)], monotone="increasing")
    x = np.linspace(2.0, 9.0, 50)
    numbers = form.numbers_for(lambda x: 0.3 * x, x)
    u = (x - form.center) / form.half
    np.testing.assert_allclose(np.polynomial.Polynomial(form.series(numbers))(u), 0.3 * x,
                               atol=1e-9)


# -- the gauge and the law --------------------------------------------------------------------
def test_the_level_of_a_state_seen_only_through_curves_is_pinned_at_zero():
    skeleton = Skeleton(CURVES)
    constraints, gauge = hidden_level_gauge(skeleton, ["x1"], {"f1": [], "f2": []}, {})
    assert constraints["f1"] == [Constraint("f1", "value", 0.0, 0.0)]
    assert constraints["f2"] == []
    assert list(gauge) == ["f1(0)=0"] and "shift of x1" in gauge["f1(0)=0"]


@pytest.mark.parametrize("equations, constraints", [
    (CURVES, {"f1": [Constraint("f1", "value", 2.0, 0.1)], "f2": []}),  # a point holds it
    (CURVES, {"f1": [Constraint("f1", "odd")], "f2": []}),  # odd: f1(0) = 0 already
    # the level is seen where the state enters as itself too
    (["x1_dot = a1 u - f1(x1) - a2 x1", "x2_dot = f1(x1) - f2(x2)"], {"f1": [], "f2": []}),
])
def test_a_level_seen_otherwise_is_not_pinned(equations, constraints):
    _, gauge = hidden_level_gauge(Skeleton(equations), ["x1"], constraints, {})
    assert gauge == {}


def test_the_law_writes_each_curve_as_a_line_of_its_constraints():
    frame = _tanks(60, 0)
    model = PolyCCRegressor(equations=CURVES, constraints=INCREASING)
    problem = model._problem(frame, None)[0]
    lined, laws = line_laws(problem)
    assert lined.functions == []
    assert lined.equations[0].replace(" ", "") == "x1_dot=a1*u-(0.0+a2*((x1)-(0.0)))"
    assert lined.equations[1].replace(" ", "") == "x2_dot=(0.0+a2*((x1)-(0.0)))-(a4+a3*(x2))"
    assert lined.bounds == {"a2": (0.0, np.inf), "a3": (0.0, np.inf)}
    assert laws["f2"](np.array([2.0]), {"a3": 0.5, "a4": 1.0})[0] == pytest.approx(2.0)


# -- fitting ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def short_cascade():
    frame = _tanks(300, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=CURVES, constraints=INCREASING, degree=3).fit(frame)
    return frame, model


def test_curves_of_a_tank_nobody_measures_are_fitted(short_cascade):
    frame, model = short_cascade
    fresh = _tanks(300, 101)
    scorer = make_simulation_scorer()
    assert scorer.nrmse(model, fresh) < 1.3 * scorer.nrmse(_ideal(frame), fresh)
    assert "f1(0)=0" in model.gauge_
    assert model.functions_["f1"](np.array([0.0]))[0] == pytest.approx(0.0, abs=1e-12)
    for name in ("f1", "f2"):  # increasing where they were fitted
        lo, hi = model.curve_ranges_[name]
        assert np.all(np.diff(model.functions_[name](np.linspace(lo, hi, 200))) >= -1e-12)
    assert model.curve_ranges_["f1"][0] == 0.0 and model.curve_ranges_["f1"][1] > 5.0
    # a1 and the curves' numbers: 3 for f1 (held at 0), 4 for f2
    assert model.n_parameters_ == 8
    assert list(model.starts_["stage"].unique()) == ["straight lines", "curves"]
    assert model.params_["a1"] == pytest.approx(SAME_TANKS["a1"], rel=0.25)


def test_a_curve_through_a_hidden_state_has_a_band(short_cascade):
    _, model = short_cascade
    assert {"a1", "f1[0]", "f1[3]", "f2[3]"} <= set(model.covariance_.index)
    lo, hi = model.curve_ranges_["f2"]
    sd = model.backend_.curve_sd(model, "f2", np.linspace(lo, hi, 5))
    assert np.all(np.isfinite(sd)) and np.all(sd > 0)


def test_an_unseen_scale_of_a_hidden_state_is_pinned_and_said():
    # the upper tank's outflow reaches the lower one scaled by a2: x1's scale is not seen
    frame = datasets.make_two_tanks(n_samples=200, rims=(100.0, 100.0), random_state=1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = PolyCCRegressor(equations=["x1_dot = a1 u - f1(x1)",
                                           "x2_dot = a2 f1(x1) - f2(x2)"],
                                constraints=INCREASING, degree=2).fit(frame)
    assert model.params_["a2"] == 1.0
    assert "scale is pinned by a2 = 1" in model.gauge_["a2=1"]
    assert "f1(0)=0" in model.gauge_
    # the pin leaves nothing unseen, and no warning names a number the user never wrote
    assert not [w for w in caught if "not measured, and the measurements cannot fix"
                in str(w.message)]
    assert not [w for w in caught if "f1:" in str(w.message) or "f2:" in str(w.message)]
    assert np.isfinite(make_simulation_scorer().nrmse(model, frame))


def test_a_backend_without_written_curves_says_which_one_has_them():
    frame = _tanks(60, 0)
    with pytest.raises(ValueError, match=r"NeuralBackend does not fit curves .*PolyCCRegressor"):
        NeuralCCRegressor(equations=CURVES, max_epochs=1).fit(frame)


@pytest.mark.slow
def test_the_cascade_of_curves_simulates_fresh_records_as_the_true_skeleton():
    scorer = make_simulation_scorer()
    x1 = np.linspace(5.0, 12.0, 8)  # where the upper level runs
    law = SAME_TANKS["a2"] * np.sqrt(x1)
    for seed in (2, 4):
        frame, fresh = _tanks(1024, seed), _tanks(1024, seed + 1000)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = PolyCCRegressor(equations=CURVES, constraints=INCREASING,
                                    extrapolation="linear").fit(frame)
        assert scorer.nrmse(model, fresh) < 2 * scorer.nrmse(_ideal(frame), fresh)

        def worst(shift, model=model):  # the level of x1 is the gauge's: up to a shift
            return np.max(np.abs(model.functions_["f1"](x1 + shift) / law - 1))

        best = minimize_scalar(worst, bounds=(-30.0, 30.0), method="bounded")
        assert best.fun < 0.05
