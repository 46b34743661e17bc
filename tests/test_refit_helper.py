"""The one helper every diagnostic refit goes through: what it keeps and drops, what it reads."""

import numpy as np
import pandas as pd

from sklearn_pycc import PolyCCRegressor, Skeleton
from sklearn_pycc.diagnostics._data import read_measurements
from sklearn_pycc.diagnostics._refit import KEEP, fit_rows, prepared

EQUATIONS = ["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1"]


def _model(**settings):
    return PolyCCRegressor(equations=EQUATIONS, constraints=["a1 >= 0"], **settings)


def test_a_refit_makes_no_refits_on_resamples_unless_asked_to_keep_them():
    model = _model(n_bootstrap=3, param_init={"a1": 0.5})
    assert prepared(model).n_bootstrap == 0
    assert prepared(model, n_bootstrap=KEEP).n_bootstrap == 3
    assert prepared(model, n_bootstrap=5).n_bootstrap == 5
    assert prepared(_model()).n_bootstrap == _model().n_bootstrap
    # the user's model is never changed
    assert model.n_bootstrap == 3 and model.param_init == {"a1": 0.5}


def test_another_skeleton_brings_its_own_constraints_and_only_its_parameters_start():
    extended = Skeleton(["x1_dot = x2", "x2_dot = u - a1 x2 - a2 x1 - a3 x1^3"])
    refit = prepared(_model(), equations=extended,
                     param_init={"a1": 0.1, "a3": 2.0, "a9": 7.0})
    assert list(refit.equations) == list(extended.equations) and refit.constraints is None
    assert refit.param_init == {"a1": 0.1, "a3": 2.0}
    # skeleton text is left for the fit to read: nothing is filtered
    assert prepared(_model(), equations=EQUATIONS, param_init={"a9": 1.0}).param_init == \
        {"a9": 1.0}


def test_fit_mode_other_settings_and_the_fitted_hold():
    model = _model(input_hold="auto")
    assert prepared(model, fit_mode="simulation").fit_mode == "simulation"
    assert prepared(model, extrapolation="linear").extrapolation == "linear"
    model.input_hold_ = "zoh"  # as a fit that chose the held input leaves it
    assert prepared(model, hold_as_fitted=True).input_hold == "zoh"
    assert prepared(model).input_hold == "auto"


def _record(n=40, experiments=2, time=True):
    frame = pd.DataFrame({"x1": np.sin(np.arange(n) / 5), "x2": np.cos(np.arange(n) / 5),
                          "u": np.linspace(0, 1, n)})
    if time:
        frame.insert(0, "t", np.arange(n) * 0.1)
    if experiments > 1:
        frame["trajectory"] = np.repeat(["a", "b"], n // 2)
    y = pd.DataFrame({"x1_dot": frame["x2"], "x2_dot": -frame["x1"]})
    return read_measurements(Skeleton(EQUATIONS), frame, y), frame


def test_the_record_a_diagnosis_reads_names_its_experiments_and_the_columns_a_model_reads():
    record, _ = _record()
    assert record.names == ("x1", "x2", "u") and record.has_time
    assert list(record.X.columns) == ["t", "trajectory", "x1", "x2", "u"]
    assert [(label, rows.tolist()) for label, rows in record.experiment_rows] == \
        [("a", list(range(20))), ("b", list(range(20, 40)))]
    bare, _ = _record(experiments=1, time=False)
    assert not bare.has_time and [r.tolist() for _, r in bare.experiment_rows] == \
        [list(range(40))]


def test_a_subset_keeps_its_rows_in_order_and_a_held_out_block_splits_an_experiment():
    record, frame = _record()
    held = np.r_[0:5, 12:25, 30:33]
    part = record.subset(held)
    assert part.n_samples == len(held)
    assert np.array_equal(part.columns["t"], frame["t"].to_numpy()[held])
    assert np.array_equal(part.derivatives, record.derivatives[held])
    assert np.array_equal(part.X["x1"], frame["x1"].to_numpy()[held])
    # experiment a: rows 0-4 and 12-19 (a gap between them); b: 20-24 and 30-32
    assert [(label, len(rows)) for label, rows in part.experiment_rows] == \
        [("a", 5), ("a", 8), ("b", 5), ("b", 3)]
    assert np.array_equal(part.experiments[1].t, frame["t"].to_numpy()[12:20])
    # the record itself is untouched
    assert record.n_samples == 40 and len(record.experiment_rows) == 2
    bare, _ = _record(experiments=1, time=False)
    assert [len(r) for _, r in bare.subset(np.r_[0:3, 10:14]).experiment_rows] == [3, 4]


def test_a_refit_on_some_rows_reads_those_rows_and_the_record_s_derivatives():
    record, frame = _record()
    seen = {}

    class Recording(PolyCCRegressor):
        def fit(self, X, y=None):
            seen["X"], seen["y"] = X.copy(), np.array(y)
            return super().fit(X, y)

    rows = np.r_[0:10, 25:40]
    pieces = np.where(np.arange(40) < 25, "left", "right")
    fitted = fit_rows(Recording(equations=EQUATIONS), record, rows, pieces=pieces)
    assert hasattr(fitted, "params_")
    assert np.array_equal(seen["X"]["t"], frame["t"].to_numpy()[rows])
    assert list(seen["X"]["trajectory"]) == list(pieces[rows])
    assert np.array_equal(seen["y"], record.derivatives[rows])
    fit_rows(Recording(equations=EQUATIONS), record)
    assert len(seen["X"]) == 40 and list(seen["X"]["trajectory"][:1]) == ["a"]
