"""How an actuator reads its input: saturation and dead zone, found by the loop.

A heater gives no more than its full power, a valve does nothing inside its
dead band. The skeleton a user writes first reads the input as measured,
``a1 u``; the loop tries reading it levelled off (``a tanh(u/a)``) or past a
dead zone in every term that reads it, and names what it finds in the words
of the state's field.
"""

import warnings

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, Skeleton, effects
from sklearn_pycc.diagnostics._candidates import enumerate_input_moves, extend
from sklearn_pycc.diagnostics._roles import equation_roles

START = ["x1_dot = a1 u - a2 x1"]
TRUTHS = {
    "input_saturation": "x1_dot = 4 a1 tanh(u / 4) - a2 x1",
    "input_dead_zone": "x1_dot = a1 (u - 3 sign(u)) (1 + sign(abs(u) - 3))/2 - a2 x1",
    None: "x1_dot = a1 u - a2 x1",
}


def _heater(truth: str, seed: int = 0, snr: float = 40.0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 1000.0, 0.5)
    u = np.repeat(rng.uniform(0.0, 10.0, size=len(t) // 40 + 1), 40)[:len(t)]
    x = Skeleton([truth]).simulate(t, [1.0], params={"a1": 0.05, "a2": 0.1},
                                   inputs={"u": u})["x1"].to_numpy()
    x = x + 10 ** (-snr / 20) * np.std(x) * rng.standard_normal(len(t))
    return pd.DataFrame({"t": t, "u": u, "x1": x})


@pytest.mark.parametrize("hidden, called", [
    ("input_saturation", "heater saturation"),
    pytest.param("input_dead_zone", "heater dead band", marks=pytest.mark.slow)])
def test_the_loop_names_how_the_heater_reads_its_input(hidden, called):
    X = _heater(TRUTHS[hidden])
    start = PolyCCRegressor(equations=START, quantities={"x1": "temperature"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(start, X).run(max_rounds=3)
    first = loop.rounds[0]
    assert first.added is not None and first.added.effect == hidden
    assert first.diagnosis.best.called == called
    # the level of the saturation or the dead band's edge, fitted (true: 4 and 3)
    level = {"input_saturation": 4.0, "input_dead_zone": 3.0}[hidden]
    new = [v for a, v in loop.model.params_.items() if a not in ("a1", "a2", "a3")]
    assert any(abs(v - level) < 0.2 * level for v in new)


def test_the_loop_reads_a_linear_heater_as_it_is():
    X = _heater(TRUTHS[None], seed=1)
    start = PolyCCRegressor(equations=START, quantities={"x1": "temperature"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(start, X).run(max_rounds=2)
    assert [r.added for r in loop.rounds if r.added] == []


def test_an_input_inside_a_function_or_already_changed_is_left_alone():
    skeleton = Skeleton(["x1_dot = a1 tanh(u) + a3 w(t - a4) - a2 x1"])
    assert enumerate_input_moves(skeleton, equation_roles(skeleton)) == []


def test_the_parameters_an_input_move_brings_are_its_own_and_bounded():
    skeleton = Skeleton(["x1_dot = a1 u - a2 x1"], ["a1 >= 0"])
    moves = {c.effect.name: c for c in enumerate_input_moves(skeleton,
                                                             equation_roles(skeleton))}
    assert set(moves) == {e.name for e in effects.catalogue() if e.acts_through == "input"}
    saturation = moves["input_saturation"]
    extend(skeleton, saturation)
    late = saturation.extended
    assert late.equations == ("x1_dot = -a2*x1 + a3*a4*tanh(u / a4)",)
    assert late.bounds["a4"] == (0.0, np.inf)  # the level, not the gain, is bounded
    assert "a3" not in late.bounds and "a1" not in late.params


def test_a_mechanical_equation_keeps_its_input_s_shape_and_may_read_it_late():
    # on a forced mechanical record friction and springs take an actuator limit's shapes
    skeleton = Skeleton(["x1_dot = x2", "x2_dot = F - a1 x2 - a2 x1"])
    moves = enumerate_input_moves(skeleton, equation_roles(skeleton))
    assert [c.effect.name for c in moves] == ["transport_delay"]
    velocity = Skeleton(["x1_dot = a3 F - a1 x1"])
    moves = enumerate_input_moves(velocity, equation_roles(velocity, {"x1": "velocity"}))
    assert [c.effect.name for c in moves] == ["transport_delay"]


def test_a_tank_filled_through_a_valve_is_told_the_valve_s_characteristic():
    # an equal-percentage-like valve: the inflow grows with the square of the opening
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 600.0, 0.5)
    u = np.repeat(rng.uniform(0.1, 1.0, size=len(t) // 80 + 1), 80)[:len(t)]
    x = Skeleton(["x1_dot = a1 u^2 - a2 x1"]).simulate(
        t, [1.0], params={"a1": 0.8, "a2": 0.3}, inputs={"u": u})["x1"].to_numpy()
    X = pd.DataFrame({"t": t, "u": u, "x1": x + 0.01 * np.std(x) * rng.standard_normal(len(t))})
    start = PolyCCRegressor(equations=START, quantities={"x1": "level"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(start, X).run(max_rounds=2)
    first = loop.rounds[0].added
    assert (first.effect, first.called) == ("valve_characteristic", "valve characteristic")
    assert first.written == "+ a3*abs(u)^a4*sign(u)"  # a gain on the input: added
    exponent = [v for a, v in loop.model.params_.items() if a not in ("a1", "a2", "a3")]
    assert len(exponent) == 1 and abs(exponent[0] - 2.0) < 0.1
    # a heater has no valve: the characteristic is not tried on a temperature
    skeleton = Skeleton(START)
    tried = enumerate_input_moves(skeleton, equation_roles(skeleton, {"x1": "temperature"}))
    assert "valve_characteristic" not in {c.effect.name for c in tried}
