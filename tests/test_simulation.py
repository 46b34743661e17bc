"""``Skeleton.simulate``: the paper's "Theoretical" simulation with given curves and parameters."""

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc.exceptions import SimulationError, SkeletonError
from sklearn_pycc.skeleton import Skeleton

TOL = {"rtol": 1e-9, "atol": 1e-11}


# --------------------------------------------------------------------------- analytic solutions
@pytest.mark.parametrize("method", ["LSODA", "RK45", "BDF"])
def test_exponential_decay(method):
    t = np.linspace(0.0, 3.0, 31)
    sim = Skeleton(["x1_dot = -a1 x1"]).simulate(
        t, [2.0], params={"a1": 0.8}, method=method, **TOL
    )
    assert isinstance(sim, pd.DataFrame)
    assert list(sim.columns) == ["t", "x1"]
    np.testing.assert_array_equal(sim["t"].to_numpy(), t)
    np.testing.assert_allclose(sim["x1"], 2.0 * np.exp(-0.8 * t), rtol=1e-6)


@pytest.mark.parametrize("method", ["LSODA", "RK45", "BDF"])
def test_harmonic_oscillator(method):
    t = np.linspace(0.0, 6.0, 121)
    sk = Skeleton(["x1_dot = x2", "x2_dot = -a1 x1"])
    sim = sk.simulate(t, [1.0, 0.0], params={"a1": 4.0}, method=method, **TOL)
    assert list(sim.columns) == ["t", "x1", "x2"]
    np.testing.assert_allclose(sim["x1"], np.cos(2.0 * t), atol=1e-6)
    np.testing.assert_allclose(sim["x2"], -2.0 * np.sin(2.0 * t), atol=1e-6)


def test_oscillator_with_curves():
    # f1, f2 linear: the damped oscillator x'' + 2 z w x' + w^2 x = 0
    t = np.linspace(0.0, 5.0, 101)
    w, z = 3.0, 0.1
    sk = Skeleton(["x1_dot = x2", "x2_dot = -f1(x2) - f2(x1)"])
    sim = sk.simulate(
        t, [1.0, 0.0], functions={"f1": lambda v: 2 * z * w * v, "f2": lambda v: w**2 * v}, **TOL
    )
    wd = w * np.sqrt(1 - z**2)
    expected = np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))
    np.testing.assert_allclose(sim["x1"], expected, atol=1e-6)


def test_state_order_follows_equations():
    t = np.linspace(0.0, 1.0, 11)
    sim = Skeleton(["v_dot = -x", "x_dot = v"]).simulate(t, [0.0, 1.0], **TOL)
    assert list(sim.columns) == ["t", "v", "x"]
    np.testing.assert_allclose(sim["x"], np.cos(t), atol=1e-7)
    np.testing.assert_allclose(sim["v"], -np.sin(t), atol=1e-7)


def test_time_grid_not_starting_at_zero():
    t = np.linspace(1.0, 2.0, 11)
    sim = Skeleton(["x1_dot = t"]).simulate(t, [0.5], **TOL)
    np.testing.assert_allclose(sim["x1"], t**2 / 2, atol=1e-8)


def test_uneven_time_grid():
    t = np.array([0.0, 0.01, 0.5, 0.51, 2.0, 3.7])
    sim = Skeleton(["x1_dot = -x1"]).simulate(t, [1.0], **TOL)
    np.testing.assert_allclose(sim["x1"], np.exp(-t), rtol=1e-7)


def test_derivative_used_on_a_right_side():
    # x'' = -x - 0.5 x' written through x1_dot
    t = np.linspace(0.0, 4.0, 41)
    a = Skeleton(["x1_dot = x2", "x2_dot = -x1 - 0.5 x1_dot"]).simulate(t, [1.0, 0.0], **TOL)
    b = Skeleton(["x1_dot = x2", "x2_dot = -x1 - 0.5 x2"]).simulate(t, [1.0, 0.0], **TOL)
    np.testing.assert_allclose(a["x1"], b["x1"], atol=1e-7)


# --------------------------------------------------------------------------- inputs
def test_input_as_callable():
    t = np.linspace(0.0, 4.0, 41)
    sim = Skeleton(["x1_dot = u"]).simulate(t, [0.0], inputs={"u": np.cos}, **TOL)
    np.testing.assert_allclose(sim["x1"], np.sin(t), atol=1e-7)


def test_input_as_python_callable_of_float():
    t = np.linspace(0.0, 2.0, 21)
    sim = Skeleton(["x1_dot = u"]).simulate(t, [0.0], inputs={"u": lambda s: 3.0 * s}, **TOL)
    np.testing.assert_allclose(sim["x1"], 1.5 * t**2, atol=1e-7)


def test_input_as_array_sampled_on_t():
    # a linear signal is interpolated exactly between its samples
    t = np.linspace(0.0, 2.0, 9)
    sim = Skeleton(["x1_dot = u"]).simulate(t, [1.0], inputs={"u": 2.0 * t}, **TOL)
    np.testing.assert_allclose(sim["x1"], 1.0 + t**2, atol=1e-7)


def test_input_as_array_is_interpolated_linearly_by_a_first_order_hold():
    t = np.array([0.0, 1.0, 2.0])
    u = np.array([0.0, 2.0, 0.0])  # a triangle: the integral is t^2 then 2 - (2 - t)^2
    sim = Skeleton(["x1_dot = u"]).simulate(t, [0.0], inputs={"u": u}, input_hold="foh",
                                            **TOL)
    np.testing.assert_allclose(sim["x1"], [0.0, 1.0, 2.0], atol=1e-6)


def test_input_as_list():
    t = np.linspace(0.0, 1.0, 5)
    sim = Skeleton(["x1_dot = u"]).simulate(t, [0.0], inputs={"u": [1.0] * 5}, **TOL)
    np.testing.assert_allclose(sim["x1"], t, atol=1e-8)


@pytest.mark.parametrize("value", [2, 2.0, np.float64(2.0)])
def test_input_as_constant(value):
    t = np.linspace(0.0, 1.0, 11)
    sim = Skeleton(["x1_dot = u - x1"]).simulate(t, [0.0], inputs={"u": value}, **TOL)
    np.testing.assert_allclose(sim["x1"], 2.0 * (1 - np.exp(-t)), atol=1e-7)


def test_forced_oscillator_with_all_kinds_of_inputs():
    t = np.linspace(0.0, 3.0, 61)
    sk = Skeleton(["x1_dot = x2", "x2_dot = F + G + H - x1"])
    sim = sk.simulate(
        t, [0.0, 0.0], inputs={"F": np.ones_like(t), "G": lambda s: 0.0 * s, "H": 0}, **TOL
    )
    np.testing.assert_allclose(sim["x1"], 1.0 - np.cos(t), atol=1e-6)


def test_time_dependent_model_without_inputs():
    t = np.linspace(0.0, 2.0, 21)
    sim = Skeleton(["x1_dot = cos(t) - x1 + sin(t)"]).simulate(t, [0.0], **TOL)
    np.testing.assert_allclose(sim["x1"], np.sin(t), atol=1e-7)


# --------------------------------------------------------------------------- derivatives
def test_return_derivatives_columns_and_values():
    t = np.linspace(0.0, 3.0, 31)
    sk = Skeleton(["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"])
    functions = {"f1": lambda v: 0.3 * v, "f2": lambda v: v + v**3}
    sim = sk.simulate(
        t,
        [0.5, 0.0],
        functions=functions,
        inputs={"F_ext": np.cos},
        return_derivatives=True,
        **TOL,
    )
    assert list(sim.columns) == ["t", "x1", "x2", "F_ext", "x1_dot", "x2_dot"]
    x1, x2 = sim["x1"].to_numpy(), sim["x2"].to_numpy()
    np.testing.assert_allclose(sim["F_ext"], np.cos(t))
    np.testing.assert_allclose(sim["x1_dot"], x2)
    np.testing.assert_allclose(sim["x2_dot"], np.cos(t) - 0.3 * x2 - (x1 + x1**3))
    # the derivative columns agree with the trajectory itself
    np.testing.assert_allclose(np.gradient(x1, t), sim["x1_dot"], atol=0.02)


def test_return_derivatives_with_constant_and_array_inputs():
    t = np.linspace(0.0, 1.0, 11)
    u = np.linspace(1.0, 2.0, 11)
    sim = Skeleton(["x1_dot = u + 2 v - x1"]).simulate(
        t, [0.0], inputs={"u": u, "v": 0.5}, return_derivatives=True, **TOL
    )
    assert list(sim.columns) == ["t", "x1", "u", "v", "x1_dot"]
    np.testing.assert_allclose(sim["u"], u)
    np.testing.assert_allclose(sim["v"], 0.5)
    np.testing.assert_allclose(sim["x1_dot"], u + 1.0 - sim["x1"])


def test_without_derivatives_only_states():
    t = np.linspace(0.0, 1.0, 5)
    sim = Skeleton(["x1_dot = u"]).simulate(t, [0.0], inputs={"u": 1.0})
    assert list(sim.columns) == ["t", "x1"]


# --------------------------------------------------------------------------- implicit equations
def test_unsolved_first_order_family_matches_explicit_form():
    t = np.linspace(0.0, 4.0, 41)
    functions = {"f1": lambda v: v**3 + 0.5 * v, "f2": lambda v: 2.0 + np.tanh(v)}
    inputs = {"F_ext": lambda s: np.sin(2 * s)}
    implicit = Skeleton(["F_ext = f1(x1) + f2(x1) x1_dot"])
    explicit = Skeleton(["x1_dot = (F_ext - f1(x1)) / f2(x1)"])
    a = implicit.simulate(
        t, [0.3], functions=functions, inputs=inputs, return_derivatives=True, **TOL
    )
    b = explicit.simulate(
        t, [0.3], functions=functions, inputs=inputs, return_derivatives=True, **TOL
    )
    assert list(a.columns) == list(b.columns) == ["t", "x1", "F_ext", "x1_dot"]
    np.testing.assert_allclose(a["x1"], b["x1"], atol=1e-8)
    np.testing.assert_allclose(a["x1_dot"], b["x1_dot"], atol=1e-8)
    # and x1 actually moved: the comparison is not between two constants
    assert np.ptp(a["x1"]) > 0.1


def test_unsolved_first_order_linear_case_analytic():
    # u = x + 2 x' with u = 1: x = 1 - exp(-t/2) from x(0) = 0
    t = np.linspace(0.0, 3.0, 31)
    sk = Skeleton(["u = f1(x1) + f2(x1) x1_dot"])
    sim = sk.simulate(
        t,
        [0.0],
        functions={"f1": lambda v: v, "f2": lambda v: 2.0 + 0.0 * v},
        inputs={"u": 1.0},
        **TOL,
    )
    np.testing.assert_allclose(sim["x1"], 1.0 - np.exp(-t / 2), atol=1e-7)


def test_implicit_second_order_equation():
    # m x'' + x = 0 written unsolved for x2_dot
    t = np.linspace(0.0, 3.0, 31)
    sk = Skeleton(["x1_dot = x2", "0 = a1 x2_dot + x1"])
    sim = sk.simulate(t, [1.0, 0.0], params={"a1": 0.25}, **TOL)
    np.testing.assert_allclose(sim["x1"], np.cos(2.0 * t), atol=1e-6)


def test_model_nonlinear_in_its_derivative_cannot_be_simulated():
    sk = Skeleton(["F_ext = f1(x1) + x1_dot^2"])
    with pytest.raises(SkeletonError) as info:
        sk.simulate(np.linspace(0, 1, 5), [0.0], functions={"f1": np.sin}, inputs={"F_ext": 1.0})
    assert "x1_dot" in str(info.value)
    assert "linearly" in str(info.value)
    assert info.value.equation == 0


@pytest.mark.parametrize("text", ["u = sin(x1_dot)", "u = x1 / x1_dot", "u = f1(x1_dot)"])
def test_derivative_inside_nonlinearity_cannot_be_simulated(text):
    sk = Skeleton([text])
    functions = {"f1": np.sin} if sk.functions else None
    with pytest.raises(SkeletonError, match="x1_dot"):
        sk.simulate(np.linspace(0, 1, 5), [0.1], functions=functions, inputs={"u": 1.0})


def test_cyclic_derivatives_are_rejected_before_simulation():
    with pytest.raises(SkeletonError, match="cycle"):
        Skeleton(["x1_dot = x2_dot", "x2_dot = x1_dot"])


# --------------------------------------------------------------------------- solvers
@pytest.mark.parametrize("method", ["LSODA", "RK45", "BDF", "RK23", "DOP853", "Radau"])
def test_solver_methods_agree(method):
    t = np.linspace(0.0, 2.0, 21)
    sk = Skeleton(["x1_dot = x2", "x2_dot = -x1 - 0.2 x2 + u"])
    sim = sk.simulate(t, [1.0, 0.0], inputs={"u": np.sin}, method=method, rtol=1e-8, atol=1e-10)
    ref = sk.simulate(t, [1.0, 0.0], inputs={"u": np.sin}, method="DOP853", rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(sim[["x1", "x2"]], ref[["x1", "x2"]], atol=1e-5)


def test_solver_options_are_passed_through():
    t = np.linspace(0.0, 1.0, 3)
    sk = Skeleton(["x1_dot = -f1(x1)"])
    counts = []

    def run(**options):
        calls = []

        def curve(v):
            calls.append(v)
            return v

        sim = sk.simulate(t, [1.0], functions={"f1": curve}, method="RK45", **options)
        np.testing.assert_allclose(sim["x1"], np.exp(-t), rtol=1e-5)
        counts.append(len(calls))

    run()
    run(max_step=1e-3)
    # RK45 evaluates the right-hand side 6 times per step: at least 6000 calls in 1000 steps
    assert counts[0] < 1000
    assert counts[1] >= 6000
    with pytest.warns(UserWarning, match="not_an_option"):
        sk.simulate(t, [1.0], functions={"f1": np.negative}, method="RK45", not_an_option=3)


def test_unknown_solver_method():
    with pytest.raises(ValueError, match=r"unknown solver method 'Euler'.*LSODA"):
        Skeleton(["x1_dot = -x1"]).simulate(np.linspace(0, 1, 5), [1.0], method="Euler")


# --------------------------------------------------------------------------- argument errors
SK = Skeleton(["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a1 x1"])
T = np.linspace(0.0, 1.0, 11)
GOOD = {"functions": {"f1": np.tanh}, "params": {"a1": 1.0}, "inputs": {"F_ext": 0.0}}


def simulate(**changes):
    kwargs = {"t": T, "y0": [1.0, 0.0], **GOOD, **changes}
    return SK.simulate(**kwargs)


def test_good_arguments_simulate():
    sim = simulate()
    assert sim.shape == (11, 3)
    assert np.isfinite(sim.to_numpy()).all()


def test_missing_input():
    with pytest.raises(ValueError, match="needs the input 'F_ext'"):
        simulate(inputs={})
    with pytest.raises(ValueError, match="needs the input 'F_ext'"):
        simulate(inputs=None)


def test_unknown_input_name():
    with pytest.raises(ValueError, match=r"unknown input 'G'.*'F_ext'"):
        simulate(inputs={"F_ext": 0.0, "G": 1.0})


def test_inputs_must_be_a_mapping():
    with pytest.raises(TypeError, match="dict"):
        simulate(inputs=[0.0])


@pytest.mark.parametrize("length", [5, 12])
def test_input_array_of_wrong_length(length):
    with pytest.raises(ValueError, match=rf"'F_ext'.*length 11.*\({length},\)"):
        simulate(inputs={"F_ext": np.zeros(length)})


def test_input_array_2d():
    with pytest.raises(ValueError, match="F_ext"):
        simulate(inputs={"F_ext": np.zeros((11, 2))})


def test_input_array_with_nan():
    values = np.zeros(11)
    values[4] = np.nan
    with pytest.raises(ValueError, match="'F_ext' is not finite at position 4"):
        simulate(inputs={"F_ext": values})


def test_input_callable_returning_several_values():
    with pytest.raises(ValueError, match="one value per time"):
        simulate(inputs={"F_ext": lambda s: [s, s]})


def test_input_constant_nan():
    with pytest.raises(ValueError, match="not finite"):
        simulate(inputs={"F_ext": float("nan")})


@pytest.mark.parametrize("y0", [[1.0], [1.0, 0.0, 0.0], [[1.0, 0.0]], 1.0])
def test_y0_of_wrong_length(y0):
    with pytest.raises(ValueError, match=r"y0 must hold 2 values.*x1, x2"):
        simulate(y0=y0)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_y0_not_finite(bad):
    with pytest.raises(ValueError, match="y0 contains NaN"):
        simulate(y0=[1.0, bad])


def test_t_not_strictly_increasing_says_where():
    t = np.array([0.0, 0.1, 0.2, 0.2, 0.4, 0.3])  # the first offence is reported
    with pytest.raises(ValueError, match=r"strictly increasing; t\[3\]=0.2 follows t\[2\]=0.2"):
        simulate(t=t)


def test_t_decreasing_says_where():
    with pytest.raises(ValueError, match=r"t\[2\]=0.1 follows t\[1\]=0.5"):
        simulate(t=[0.0, 0.5, 0.1, 0.7])


@pytest.mark.parametrize("t", [[0.0], [], [[0.0, 1.0]]])
def test_t_too_short_or_not_1d(t):
    with pytest.raises(ValueError, match="at least two times"):
        simulate(t=t)


def test_t_not_finite():
    with pytest.raises(ValueError, match="NaN"):
        simulate(t=[0.0, np.nan, 1.0])


def test_missing_function_value():
    with pytest.raises(ValueError, match="no value for the curve 'f1'"):
        simulate(functions={})


def test_extra_function_value():
    with pytest.raises(ValueError, match="'f2' is not a curve of the skeleton"):
        simulate(functions={"f1": np.tanh, "f2": np.sin})


def test_function_not_callable():
    with pytest.raises(TypeError, match="'f1' must be callable"):
        simulate(functions={"f1": 2.0})


def test_missing_param_value():
    with pytest.raises(ValueError, match="no value for the parameter 'a1'"):
        simulate(params=None)


def test_extra_param_value():
    with pytest.raises(ValueError, match="'a2' is not a parameter of the skeleton"):
        simulate(params={"a1": 1.0, "a2": 2.0})


def test_values_for_a_skeleton_without_curves():
    with pytest.raises(ValueError, match=r"'f1' is not a curve.*none"):
        Skeleton(["x1_dot = -x1"]).simulate(T, [1.0], functions={"f1": np.sin})


# --------------------------------------------------------------------------- divergence
def assert_partial_is_clean(err):
    partial = err.partial
    assert isinstance(partial, pd.DataFrame)
    assert partial.columns[0] == "t"
    assert len(partial) >= 1
    assert np.isfinite(partial.to_numpy()).all()
    assert partial["t"].iloc[-1] <= err.t_reached
    assert np.all(np.diff(partial["t"].to_numpy()) > 0)


@pytest.mark.parametrize("method", ["LSODA", "RK45", "BDF"])
def test_blow_up_raises_with_partial_result(method):
    t = np.linspace(0.0, 2.0, 201)
    with pytest.raises(SimulationError) as info:
        Skeleton(["x1_dot = x1^2"]).simulate(t, [1.0], method=method)
    err = info.value
    assert err.t_reached < 1.01
    assert err.t_reached > 0.5
    assert_partial_is_clean(err)
    assert list(err.partial.columns) == ["t", "x1"]
    # the partial result is the true solution 1 / (1 - t) up to the blow-up
    early = err.partial[err.partial["t"] <= 0.8]
    assert len(early) == 81
    np.testing.assert_allclose(early["x1"], 1.0 / (1.0 - early["t"]), rtol=1e-4)
    assert "reached t=" in str(err)


def test_blow_up_keeps_all_state_columns():
    t = np.linspace(0.0, 2.0, 21)
    with pytest.raises(SimulationError) as info:
        Skeleton(["x1_dot = x2", "x2_dot = x2^2"]).simulate(t, [0.0, 1.0])
    assert list(info.value.partial.columns) == ["t", "x1", "x2"]
    assert_partial_is_clean(info.value)
    assert info.value.t_reached < 1.01


@pytest.mark.parametrize("method", ["LSODA", "RK45", "BDF"])
@pytest.mark.parametrize(
    ("text", "y0"),
    [
        ("x1_dot = log(x1)", 0.5),  # x1 falls to 0, where log is undefined
        ("x1_dot = -sqrt(x1)", 0.5),  # x1 reaches 0 in finite time, then goes negative
        ("x1_dot = exp(x1)", 1.0),  # blows up at t = exp(-1)
        ("x1_dot = x1 x1 x1", 1.0),  # blows up at t = 1/2
    ],
)
def test_domain_errors_and_blow_ups_raise_simulation_error(text, y0, method):
    t = np.linspace(0.0, 5.0, 51)
    with pytest.raises(SimulationError) as info:
        Skeleton([text]).simulate(t, [y0], method=method)
    assert_partial_is_clean(info.value)
    assert info.value.t_reached < 5.0


def test_domain_error_at_initial_state():
    with pytest.raises(SimulationError) as info:
        Skeleton(["x1_dot = log(x1)"]).simulate(np.linspace(0, 1, 5), [-1.0])
    assert info.value.t_reached == 0.0
    assert len(info.value.partial) == 1
    assert info.value.partial["x1"].iloc[0] == -1.0


def test_nan_from_user_curve_raises_simulation_error():
    # a numpy curve returns NaN (not an exception) outside its domain
    t = np.linspace(0.0, 5.0, 51)
    with np.errstate(all="ignore"), pytest.raises(SimulationError) as info:
        Skeleton(["x1_dot = f1(x1)"]).simulate(t, [0.5], functions={"f1": np.log})
    assert_partial_is_clean(info.value)
    assert info.value.t_reached < 1.0


def test_nan_from_input_raises_simulation_error():
    t = np.linspace(0.0, 2.0, 21)
    signal = lambda s: 1.0 if s < 1.0 else float("nan")  # noqa: E731
    with pytest.raises(SimulationError) as info:
        Skeleton(["x1_dot = u"]).simulate(t, [0.0], inputs={"u": signal})
    assert_partial_is_clean(info.value)
    assert info.value.t_reached <= 1.0 + 1e-9
    np.testing.assert_allclose(info.value.partial["x1"], info.value.partial["t"], atol=1e-6)


def test_simulation_error_is_a_runtime_error():
    with pytest.raises(RuntimeError):
        Skeleton(["x1_dot = x1^2"]).simulate(np.linspace(0, 2, 5), [1.0])


def test_stiff_but_stable_model_does_not_raise():
    t = np.linspace(0.0, 1.0, 11)
    sim = Skeleton(["x1_dot = -1000 (x1 - cos(t))"]).simulate(t, [0.0], method="BDF")
    np.testing.assert_allclose(sim["x1"].iloc[-1], np.cos(1.0), atol=1e-2)


def test_a_chattering_model_is_stopped_by_max_steps():
    # the dry-friction idealisation sign() makes the solver chatter once x1 reaches zero
    skeleton = Skeleton(["x1_dot = -sign(x1)"])
    with pytest.raises(SimulationError, match="took 2000 steps") as info:
        skeleton.simulate(np.linspace(0.0, 3.0, 31), [1.0], max_steps=2000)
    assert info.value.t_reached == pytest.approx(1.0, abs=1e-3)
    assert len(info.value.partial) >= 10


@pytest.mark.parametrize("bad", [0, -5, 2.5, True])
def test_max_steps_must_be_a_positive_integer(bad):
    with pytest.raises(ValueError, match="max_steps"):
        Skeleton(["x1_dot = -x1"]).simulate(np.linspace(0.0, 1.0, 5), [1.0], max_steps=bad)
