"""State limits held everywhere: in the parsed skeleton, at the domain edges of the
right-hand side, at the start of a simulation and in estimated initial states."""

import math
import warnings

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, SimulationError, Skeleton, datasets
from sklearn_pycc.exceptions import SkeletonError
from sklearn_pycc.model_selection import make_simulation_scorer
from sklearn_pycc.skeleton.compiler import compile_expression
from sklearn_pycc.skeleton.functions import ELEMENTARY
from sklearn_pycc.skeleton.parser import parse_expression

TORRICELLI = ["x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a3 sqrt(x1) - a4 sqrt(x2)"]
#: the issue's cascade: a leak on each tank, the rims fitted
LEAKY = ["x1_dot = a1 u - a2 sqrt(x1) - a7 x1", "x2_dot = a3 sqrt(x1) - a4 sqrt(x2) - a8 x2"]
LEAKY_LIMITS = ["x1 >= 0", "x1 <= a5", "x2 >= 0", "x2 <= a6"]
DRAIN = ["x1_dot = -a1 sqrt(x1) - a2"]


@pytest.fixture(scope="module")
def tanks():
    """Both levels measured: a fast fit, whose record can hide x1 afterwards."""
    return datasets.make_two_tanks(n_samples=300, random_state=0, measured=("x1", "x2"))


@pytest.fixture(scope="module")
def rimmed(tanks):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return PolyCCRegressor(equations=TORRICELLI,
                               constraints=["x1 >= 0", "x1 <= 12", "x2 >= 0", "x2 <= 13"]
                               ).fit(tanks)


# -- domain edges -------------------------------------------------------------------
def test_sqrt_of_a_state_a_hair_below_its_floor_reads_the_floor():
    system = Skeleton(DRAIN, ["x1 >= 0"]).compile({}, {"a1": 1.0, "a2": 0.1})
    rhs = system.make_rhs(lambda t: [], list_states=True)
    # at the floor the outflow stops; a stage pushed below it is read at it
    assert rhs(0.0, [0.0]) == [0.0]
    assert rhs(0.0, [-1e-12]) == [0.0]
    with np.errstate(invalid="ignore"):  # as the window integrators call it
        rates = system.batch_rhs(2, [])(np.array([[-1e-12], [0.25]]), [])
    assert np.array_equal(rates, [[0.0], [-0.6]])


@pytest.mark.parametrize("inflow, method", [
    (np.full(101, -0.1), None),  # sampled: the project's own integrator
    (-0.1, None),  # LSODA
    (-0.1, "RK45"),
])
def test_a_tank_drains_to_its_floor_without_a_domain_error(inflow, method):
    t = np.linspace(0.0, 10.0, 101)
    skeleton = Skeleton(["x1_dot = u - a1 sqrt(x1)"], ["x1 >= 0"])
    frame = skeleton.simulate(t, [1.0], params={"a1": 1.0}, inputs={"u": inflow},
                              method=method)
    assert frame.x1.min() == 0.0
    assert frame.x1.iloc[-1] == 0.0


def test_a_state_leaving_a_domain_without_a_limit_is_named():
    t = np.linspace(0.0, 10.0, 101)
    with pytest.raises(SimulationError, match=r"math domain error in x1_dot at t=[\d.]+ "
                                              r"\(x1=-[\d.e-]+\).*'x1 >= 0'"):
        Skeleton(DRAIN).simulate(t, [1.0], params={"a1": 1.0, "a2": 0.1})


def test_a_rate_that_divides_by_zero_is_named_with_where_the_states_were():
    # a curve in a denominator can reach zero: the rates and the states are named, in the
    # explicit steps and in the implicit solver that takes over a stiff stretch alike
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(SimulationError, match=r"right-hand side \(x1_dot\) divides by zero "
                                              r"at t=0 \(x1=0\)"):
        Skeleton(["x1_dot = -a1/x1"]).simulate(t, [0.0], params={"a1": 1.0})


@pytest.mark.parametrize("name", ["log", "log10"])
def test_a_logarithm_at_zero_is_answered_not_raised(name):
    assert ELEMENTARY[name].math(0.0) == -math.inf
    assert ELEMENTARY[name].math(100.0) == pytest.approx(ELEMENTARY[name].numpy(100.0))
    fn = compile_expression(parse_expression(f"{name}(x1)"), {"x1": 0}, mode="scalar")
    assert fn([0.0]) == -math.inf
    with pytest.raises(ValueError):  # beyond the edge it is outside the domain
        fn([-1.0])


# -- limits as written ----------------------------------------------------------------
@pytest.mark.parametrize("order", [["x1 <= a5", "x1 >= 0"], ["x1 >= 0", "x1 <= a5"]])
def test_a_limit_to_fit_survives_either_order(order):
    skeleton = Skeleton(TORRICELLI, order)
    assert skeleton.limits == {"x1": (0.0, "a5")}
    assert skeleton.bounds == {"a5": (0.0, np.inf)}  # the rim stands above the floor
    assert skeleton == Skeleton(TORRICELLI, order[::-1])


@pytest.mark.parametrize("order", [["x2 <= a6", "x2 >= 0"], ["x2 >= 0", "x2 <= a6"]])
def test_the_fitted_end_is_the_one_the_model_applies(tanks, order):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=TORRICELLI, constraints=order,
                                fit_mode="equation").fit(tanks)
    rim = model.params_["a6"]
    assert model.skeleton_.limits_at(model.params_) == {"x2": (0.0, rim)}
    assert model._system().limits == {"x2": (0.0, rim)}
    assert f"0 <= x2 <= {rim:.6g}" in model.equations()


@pytest.mark.parametrize("constraints, match", [
    (["x1 >= 3", "x1 <= 2"], r"contradictory limits on x1: x1 >= 3, x1 <= 2 leave no value"),
    (["x1 >= 3", "x1 <= a5", "a5 <= 2"],
     r"contradictory limits on x1: x1 >= 3, x1 <= a5, a5 <= 2 leave x1 no value"),
    (["x1 >= a5", "x1 <= 3", "a5 >= 4"],
     r"contradictory limits on x1: x1 >= a5, x1 <= 3, a5 >= 4 leave x1 no value"),
    (["x1 >= 3", "x1 <= a5", "a5 <= 3"], r"leave x1 the single value 3"),
])
def test_limits_that_leave_no_value_are_refused(tanks, constraints, match):
    with pytest.raises(SkeletonError, match=match):
        Skeleton(TORRICELLI, constraints)
    with pytest.raises(ValueError, match=match):
        PolyCCRegressor(equations=TORRICELLI, constraints=constraints).fit(tanks)


def test_a_limit_the_data_break_is_warned_about(tanks):
    def fit(constraints):
        PolyCCRegressor(equations=TORRICELLI, constraints=constraints,
                        fit_mode="equation").fit(tanks)

    with pytest.warns(UserWarning, match=r"the measured x2 crosses its limit x2 <= 5 at "
                                         r"2\d\d of 300 samples, by up to 8\.\d+ \(its noise "
                                         r"is about 0\.1\d*\)"):
        fit(["x2 <= 5"])
    with pytest.warns(UserWarning, match=r"the measured x1 crosses its limit x1 >= 6"):
        fit(["x1 >= 6"])
    # the true rims: the levels reach them, and cross them only by the noise
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit(["x1 <= 12", "x2 <= 13"])
    assert not [w for w in caught if "crosses its limit" in str(w.message)]


# -- the start of a simulation -----------------------------------------------------------
def test_a_start_outside_the_limits_is_refused(tanks, rimmed):
    t, u = tanks.t.to_numpy(), tanks.u.to_numpy()
    with pytest.raises(ValueError, match=r"y0 starts x2 at 14, above its upper limit "
                                         r"\(0 <= x2 <= 13\)"):
        rimmed.simulate(t, [5.0, 14.0], inputs={"u": u})
    with pytest.raises(ValueError, match=r"y0 starts x1 at -0.5, below its lower limit"):
        rimmed.simulate(t, {"x1": -0.5, "x2": 5.0}, inputs={"u": u})
    skeleton = Skeleton(DRAIN, ["x1 >= 0", "x1 <= 2"])
    with pytest.raises(ValueError, match="y0 starts x1 at 3, above its upper limit"):
        skeleton.simulate(t[:5], [3.0], params={"a1": 1.0, "a2": 0.1})
    # a start beyond by rounding is taken at the limit
    frame = rimmed.simulate(t, [5.0, 13.0 + 1e-12], inputs={"u": u})
    assert frame.x2.iloc[0] == 13.0
    assert frame[["x1", "x2"]].min().min() >= 0.0
    assert frame.x2.max() <= 13.0


def test_a_record_starting_above_the_models_rim_is_scored_from_the_rim(rimmed):
    # another record's lower tank starts above the rim the model knows: the scorer's
    # simulation starts at the rim rather than refuse the model
    frame = datasets.make_two_tanks(n_samples=100, random_state=3, y0=(10.0, 16.0),
                                    rims=(30.0, 30.0), measured=("x1", "x2"))
    score = make_simulation_scorer(horizon=None)(rimmed, frame)
    assert np.isfinite(score) and score < 0


def test_a_model_whose_limits_leave_no_value_cannot_be_simulated():
    skeleton = Skeleton(DRAIN, ["x1 >= 0", "x1 <= a5"])
    with pytest.raises(SimulationError, match=r"the limits of x1 leave it no value"):
        skeleton.simulate(np.linspace(0, 1, 5), [0.0], params={"a1": 1.0, "a2": 0.1,
                                                                 "a5": -1.0})


# -- estimated initial states ---------------------------------------------------------------
def _hidden_x1(frame: pd.DataFrame) -> pd.DataFrame:
    return frame[["t", "u", "x2"]]


def test_an_estimated_initial_state_respects_the_limits(tanks, rimmed):
    # a reading above its rim (noise) is taken at the rim
    record = tanks.assign(x2=tanks.x2.where(tanks.index > 0, 13.6))
    assert rimmed.estimate_initial_state(record)["x2"] == 13.0
    # a record whose upper level runs above the model's rim: the estimate stops at the rim
    frame = datasets.make_two_tanks(n_samples=300, random_state=1, y0=(18.0, 6.0),
                                    rims=(30.0, 30.0), pump=(9.0, 10.0), measured=("x1", "x2"))
    state = rimmed.estimate_initial_state(_hidden_x1(frame), n_samples=20)
    assert 11.99 <= state["x1"] <= 12.0


@pytest.mark.parametrize("change, match", [
    (lambda f: f.iloc[:1], "X has a single row: x1 \\(not in X\\) can only be estimated"),
    (lambda f: f.assign(u=f.u.where(f.index != 3)),
     "X's input 'u' is NaN or infinite at row 3 \\(t = 12\\)"),
    (lambda f: f.assign(t=f.t.where(f.index != 2)),
     "X's time column 't' is NaN or infinite at row 2"),
    (lambda f: f.iloc[::-1], "X's times run backwards \\(t falls from 1196 to 400\\)"),
    (lambda f: f.assign(t=f.t.where(f.index != 4, 0.0)), "X's times do not increase at row 4"),
])
def test_an_initial_state_is_not_estimated_from_a_record_that_cannot_tell(tanks, rimmed,
                                                                          change, match):
    with pytest.raises(ValueError, match=match):
        rimmed.estimate_initial_state(change(_hidden_x1(tanks)))


def test_an_initial_state_fitted_to_two_rows_comes_with_a_warning(tanks, rimmed):
    with pytest.warns(UserWarning, match="x1 fitted to 2 rows of X: .* give 5 rows or more"):
        state = rimmed.estimate_initial_state(_hidden_x1(tanks).iloc[:2])
    assert np.isfinite(state["x1"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # five rows and more: no word
        rimmed.estimate_initial_state(_hidden_x1(tanks).iloc[:5])


def test_a_backward_record_is_refused_even_with_every_state_measured(tanks, rimmed):
    with pytest.raises(ValueError, match="X's times run backwards"):
        rimmed.estimate_initial_state(tanks.iloc[::-1])
    # one row that holds every state is read as it stands
    assert rimmed.estimate_initial_state(tanks.iloc[:1]) == {
        "x1": float(tanks.x1.iloc[0]), "x2": float(tanks.x2.iloc[0])}


# -- the cascade, only the lower level measured --------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("random_state", [0, 1])
def test_the_leaky_cascade_fits_and_keeps_every_state_within_its_limits(random_state):
    frame = datasets.make_two_tanks(n_samples=200, random_state=random_state)
    X = frame[["t", "x2", "u"]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=LEAKY, constraints=LEAKY_LIMITS).fit(X)
    limits = model.skeleton_.limits_at(model.params_)
    assert model.params_["a5"] >= 0.0 and model.params_["a6"] >= 0.0
    first = model.initial_states_.iloc[0]
    assert limits["x1"][0] <= first["x1"] <= limits["x1"][1]
    state = model.estimate_initial_state(X)
    for name, value in state.items():
        assert limits[name][0] <= value <= limits[name][1]
    simulated = model.simulate(frame.t.to_numpy(), state, inputs={"u": frame.u.to_numpy()})
    for name, (low, high) in limits.items():
        assert simulated[name].between(low, high).all()


def test_a_rate_that_becomes_infinite_is_named_with_where_the_states_were():
    # a rate that overflows to infinity: the error says which rate, and where the states were
    from sklearn_pycc.simulation import Diverged

    system = Skeleton(["x1_dot = x2", "x2_dot = -a1 f1(x1)"]).compile(
        {"f1": lambda x: np.where(np.asarray(x) < 0, x, 1e308)}, {"a1": 10.0})
    rhs = system.make_rhs(None, list_states=True)
    assert rhs(0.0, [-1.0, 2.0])[1] == pytest.approx(10.0)
    with pytest.raises(Diverged, match=r"^the right-hand side of x2_dot is -inf at t=0\.5 "
                                       r"\(x1=0, x2=2\)$"):
        rhs(0.5, [0.0, 2.0])


def test_a_record_in_which_nothing_moves_is_said_to_fix_nothing():
    t = np.arange(500) * 0.01
    still = pd.DataFrame({"t": t, "x1": np.full(500, 0.3), "F_ext": np.zeros(500)})
    oscillator = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
    for mode in ("equation", "simulation"):
        with pytest.warns(UserWarning, match=r"no measured state moves in X \(x1 at 0\.3 "
                                             r"throughout\)"):
            PolyCCRegressor(equations=oscillator, fit_mode=mode).fit(still)
    with warnings.catch_warnings():  # a record that moves says nothing of the kind
        warnings.filterwarnings("error", message="no measured state moves")
        moving = still.assign(x1=0.3 + 0.1 * np.sin(3 * t), F_ext=np.cos(3 * t))
        PolyCCRegressor(equations=oscillator, fit_mode="equation").fit(moving)
        # nor in tiny units: a position in light years moves all the same
        tiny = moving.assign(x1=moving["x1"] * 1e-16, F_ext=moving["F_ext"] * 1e-16)
        PolyCCRegressor(equations=oscillator, fit_mode="equation").fit(tiny)
