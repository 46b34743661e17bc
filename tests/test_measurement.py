"""A record read once: one differentiation shared by every fit, diagnosis and comparison."""

import numpy as np
import pandas as pd
import pytest

import sklearn_pycc.measurements.record as record_module
from sklearn_pycc import HypothesisLoop, PolyCCRegressor, compare_skeletons, datasets, diagnose
from sklearn_pycc.measurements import Measurement
from sklearn_pycc.model_selection import make_simulation_scorer

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
CUBIC = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]


@pytest.fixture
def differentiations(monkeypatch):
    """Counts the times a record is differentiated."""
    calls = []
    original = record_module.estimate_states

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(record_module, "estimate_states", counted)
    return calls


@pytest.fixture(scope="module")
def frame():
    return datasets.make_oscillator(hidden=["cubic_stiffness"])[["t", "x1", "F_ext"]]


def test_fits_of_skeletons_of_the_same_states_share_one_differentiation(frame, differentiations):
    record = Measurement(frame)
    linear = PolyCCRegressor(equations=LINEAR).fit(record)
    cubic = PolyCCRegressor(equations=CUBIC).fit(record)
    assert len(differentiations) == 1
    assert linear.derivative_source_ == cubic.derivative_source_
    assert record.derivative_sources == [cubic.derivative_source_]
    direct = PolyCCRegressor(equations=CUBIC).fit(frame)  # the same numbers without it
    assert direct.params_ == pytest.approx(cubic.params_, rel=1e-12)
    assert len(differentiations) == 2


def test_another_setting_is_differentiated_on_its_own(frame, differentiations):
    record = Measurement(frame)
    PolyCCRegressor(equations=LINEAR).fit(record)
    PolyCCRegressor(equations=LINEAR, differentiation="spline").fit(record)
    PolyCCRegressor(equations=LINEAR, smooth_states=False).fit(record)
    assert len(differentiations) == 3 and len(record.derivative_sources) == 3


def test_diagnose_compare_and_the_scorer_reuse_it(frame, differentiations):
    record = Measurement(frame)
    model = PolyCCRegressor(equations=LINEAR).fit(record)
    report = diagnose(model, record, n_bootstrap=0)
    assert report.best.effect == "cubic_stiffness"
    score = make_simulation_scorer()(model, record)
    assert score == pytest.approx(make_simulation_scorer()(model, frame))
    assert len(differentiations) == 2  # the frame itself, for the second score
    table = compare_skeletons({"linear": LINEAR, "cubic": CUBIC}, record, held_out=False)
    assert table.simulation_rmse["cubic"] < table.simulation_rmse["linear"] / 10
    assert len(differentiations) == 2


@pytest.mark.slow
def test_a_loop_differentiates_a_position_only_record_once(differentiations):
    frame = datasets.make_positioning_axis(random_state=0)
    assert len(frame) == 25_000 and "x2" not in frame.columns
    loop = HypothesisLoop(PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = a1 F - a2 x2"]),
                          frame).run(max_rounds=2)
    assert len(loop.rounds) == 2 and loop.refinement is not None
    assert len(differentiations) == 1
    assert isinstance(loop.measurement, Measurement) and loop.X is frame


def test_it_is_a_copy_and_refuses_what_it_cannot_hold(frame):
    given = frame.copy()
    record = Measurement(given, units={"x1": "m"})
    given.loc[0, "x1"] = 99.0
    assert record.X.loc[0, "x1"] != 99.0
    assert record.units == {"x1": "m"} and record.n_samples == len(frame) == len(record)
    assert repr(record) == f"<Measurement: {len(frame)} samples in 1 experiment (t, x1, F_ext)>"
    with pytest.raises(TypeError, match="pandas DataFrame"):
        Measurement(frame.to_numpy())
    with pytest.raises(TypeError, match="a Measurement already"):
        Measurement(record)
    with pytest.raises(ValueError, match="y beside a Measurement"):
        PolyCCRegressor(equations=LINEAR).fit(record, np.zeros((len(frame), 2)))
    with pytest.raises(ValueError, match="y beside a Measurement"):
        HypothesisLoop(PolyCCRegressor(equations=LINEAR), record, np.zeros(len(frame)))


def test_measured_derivatives_travel_inside_it():
    data = datasets.make_duffing(n_samples=400)
    X, y = data[["x1", "x2", "F_ext"]], data[["x1_dot", "x2_dot"]]
    equations = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
    inside = PolyCCRegressor(equations=equations, degree=3).fit(Measurement(X, y))
    beside = PolyCCRegressor(equations=equations, degree=3).fit(X, y)
    assert inside.derivative_source_ == "measured"
    pd.testing.assert_frame_equal(pd.DataFrame(inside.predict(X)),
                                  pd.DataFrame(beside.predict(X)))
