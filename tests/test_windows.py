"""Windows integrated side by side and one by one in floats give the same numbers."""

import re

import numpy as np
import pytest

from sklearn_pycc import Skeleton
from sklearn_pycc.simulation import windows as windows_module
from sklearn_pycc.simulation.windows import Windows


def _windows(hold: str, n_windows: int) -> Windows:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 60.0, 0.5)
    u = rng.uniform(0, 10, len(t))
    n = len(t) * n_windows
    rows = np.arange(n).reshape(n_windows, len(t))
    return Windows(["x1", "x2"], ["u"], True, [(r, t) for r in rows],
                   {"x1": np.zeros(n), "x2": np.zeros(n)}, signals={"u": np.tile(u, n_windows)},
                   window=len(t), merge_tail=False, hold=hold)


@pytest.mark.parametrize("hold", ["bandlimited", "zoh"])
@pytest.mark.parametrize("n_windows", [1, 3])
def test_few_windows_in_floats_match_the_side_by_side_integration(monkeypatch, hold, n_windows):
    # a limited cascade reading t, and a model that escapes part way (a1 x1^2 blows up)
    cases = [(["x1_dot = a1 u - a2 sqrt(x1) + 0.001 t", "x2_dot = 1.25 a2 sqrt(x1) - a3 sqrt(x2)"],
              ["x1 <= 12", "0 <= x2 <= 13"], {"a1": 0.3, "a2": 0.4, "a3": 0.45}),
             (["x1_dot = a1 u + a2 x1^2", "x2_dot = a3 sqrt(x1) - a3 x2"], [],
              {"a1": 0.02, "a2": 0.05, "a3": 0.045})]
    for equations, limits, params in cases:
        system = Skeleton(equations, limits).compile({}, params)
        start = np.tile([3.0, 7.0], (n_windows, 1)) * np.arange(1, n_windows + 1)[:, None]
        floats = _windows(hold, n_windows)
        one, escaped_one = floats.simulate(system, start)
        steps_one = floats.escape_step.copy()
        monkeypatch.setattr(windows_module, "FEW_WINDOWS", 0)
        side = _windows(hold, n_windows)
        many, escaped_many = side.simulate(system, start)
        monkeypatch.undo()
        assert np.array_equal(one, many)
        assert np.array_equal(escaped_one, escaped_many)
        assert np.array_equal(steps_one, side.escape_step)
    assert escaped_one.all() and not np.isnan(one).any()  # the second model escaped


def test_stacked_variants_integrate_as_each_does_alone():
    # variants of one limited skeleton that differ in a parameter, a polynomial curve
    # (linear beyond its domain) and a plain callable: one pass gives each one's numbers
    from sklearn_pycc.backends.poly.basis import PolyBasis
    from sklearn_pycc.skeleton.system import stack_systems

    skeleton = Skeleton(["x1_dot = a1 u - f1(x1) + 0.001 t", "x2_dot = f2(x1) - a2 sqrt(x2)"],
                        ["0 <= x2 <= 13"])
    basis = PolyBasis(0.0, 6.0, 3, None, "legendre")
    variants = [({"f1": basis.curve(c, "linear"), "f2": g}, {"a1": a1, "a2": 0.45})
                for c, g, a1 in [([0.2, 0.3, 0.0, 0.01], np.sqrt, 0.3),
                                 ([0.2, 0.3, 0.0, 0.02], np.sqrt, 0.3),
                                 ([0.2, 0.3, 0.0, 0.01], lambda x: 0.4 * x, 0.3),
                                 ([0.2, 0.3, 0.0, -0.5], np.sqrt, 2.0)]]  # the last escapes
    systems = [skeleton.compile(*v) for v in variants]
    windows = _windows("bandlimited", 3)
    start = np.array([[3.0, 7.0], [30.0, 1.0], [0.5, 12.0]])
    alone = []
    for system in systems:
        states, escaped = windows.simulate(system, start)
        alone.append((states, escaped, windows.escape_step.copy()))
    stacked = stack_systems(systems, len(start))
    together, escaped = windows.simulate(stacked, np.tile(start, (len(systems), 1)),
                                         copies=len(systems))
    assert np.array_equal(windows.escape_step, alone[-1][2])  # left as the last call set it
    for b, (states, escaped_alone, _) in enumerate(alone):
        block = slice(3 * b, 3 * (b + 1))
        np.testing.assert_allclose(together[block], states, rtol=1e-13, atol=1e-13)
        assert np.array_equal(escaped[block], escaped_alone)
    assert alone[-1][1].any() and not alone[0][1].any()
    assert not np.allclose(alone[0][0], alone[1][0])  # the variants do differ


def test_systems_that_differ_in_their_limits_are_not_stacked():
    from sklearn_pycc.skeleton.system import stack_systems

    skeleton = Skeleton(["x1_dot = u - a1 x1"], ["x1 <= a2"])
    systems = [skeleton.compile({}, {"a1": 1.0, "a2": high}) for high in (2.0, 3.0)]
    assert stack_systems(systems, 4) is None
    assert stack_systems(systems[:1] * 2, 4) is not None


GENERATED_CASES = [
    # a limited cascade reading t: rates held at the limits, states clipped after each step
    (["x1_dot = a1 u - a2 sqrt(x1) + 0.001 t", "x2_dot = 1.25 a2 sqrt(x1) - a3 sqrt(x2)"],
     ["x1 <= 12", "0 <= x2 <= 13"], {"a1": 0.3, "a2": 0.4, "a3": 0.45}),
    # powers written out (a square and a cube kept once), a power of a parameter, folded
    # constants, a negated sum, a curve and an elementary function of a sum
    (["x1_dot = a1 u - a2 x1^3 + (a1 a2)^2 - (x2 - x1)^2 / 50 + x1^5 / 1e6",
      "x2_dot = -(a3 x2 + f1(x1)) + 0.1 tanh(x1 - x2) + x2^a4 / 100"],
     ["x2 >= 0"], {"a1": 0.02, "a2": 0.001, "a3": 0.045, "a4": 1.5}),
    # a model that escapes part way: the general path takes the window over
    (["x1_dot = a1 u + a2 x1^2", "x2_dot = a3 sqrt(x1) - a3 x2"], [],
     {"a1": 0.02, "a2": 0.05, "a3": 0.045}),
    # a square root read below zero: the general path says so
    (["x1_dot = a1 - a2 sqrt(x1)", "x2_dot = x1 - x2"], [], {"a1": -0.5, "a2": 0.1}),
]


@pytest.mark.parametrize("case", range(len(GENERATED_CASES)))
def test_generated_steps_give_the_general_float_path_s_numbers(monkeypatch, case):
    from sklearn_pycc.simulation.float_steps import float_integrator

    equations, limits, params = GENERATED_CASES[case]
    skeleton = Skeleton(equations, limits)
    curves = {"f1": lambda x: 0.01 * x} if "f1" in skeleton.functions else {}
    system = skeleton.compile(curves, params)
    assert float_integrator(system) is not None
    start = np.array([[3.0, 7.0]])
    fast = _windows("zoh", 1)
    states, escaped = fast.simulate(system, start)
    steps = fast.escape_step.copy()
    monkeypatch.setattr(windows_module, "float_integrator", lambda system: None)
    general = _windows("zoh", 1)
    expected, escaped_expected = general.simulate(system, start)
    assert np.array_equal(states, expected)
    assert np.array_equal(escaped, escaped_expected)
    assert np.array_equal(steps, general.escape_step)
    assert np.ptp(states[0, :, 1]) > 0.1  # the states do move


def test_an_equation_solved_for_its_derivative_has_no_generated_steps():
    from sklearn_pycc.simulation.float_steps import float_integrator

    system = Skeleton(["2 x1_dot + x1 = u"]).compile({}, {})
    assert float_integrator(system) is None
    states, escaped = _windows("zoh", 1).simulate(system, np.array([[1.0]]))
    assert not escaped.any() and np.isfinite(states).all()


@pytest.mark.parametrize("case", range(len(GENERATED_CASES)))
def test_the_generated_right_hand_side_gives_the_general_one_s_numbers_and_errors(case):
    from sklearn_pycc.exceptions import SimulationError

    equations, limits, params = GENERATED_CASES[case]
    skeleton = Skeleton(equations, limits)
    curves = {"f1": lambda x: 0.01 * x} if "f1" in skeleton.functions else {}
    system = skeleton.compile(curves, params)
    fast = system.make_rhs(lambda t: [2.0 + t], list_states=True)
    general = system.make_rhs(lambda t: [2.0 + t])  # on arrays: the closures of each node
    assert fast.__code__.co_filename == "<generated rhs>"
    rng = np.random.default_rng(case)
    # states within and at the limits, beyond them, and below zero under a square root
    points = [*rng.uniform(0.0, 14.0, (20, 2)), [12.0, 0.0], [12.5, 13.0], [-1.0, 2.0],
              [3.0, -1e-3], [0.0, 0.0]]
    outcomes = raised = 0
    for t, state in zip(np.linspace(0.0, 30.0, len(points)), points):
        try:
            expected = list(general(float(t), np.asarray(state, dtype=float)))
        except (ArithmeticError, ValueError, SimulationError) as error:
            raised += 1
            with pytest.raises(type(error), match=re.escape(str(error))):
                fast(float(t), [float(v) for v in state])
            continue
        assert fast(float(t), [float(v) for v in state]) == expected
        outcomes += 1
    assert outcomes >= 20
    assert raised == (case != 1)  # a square root read below zero, not at a limit, fails
