"""Held-out folds: the rows a fold's fit is trained on never meet the rows it is judged on.

A recording estimator notes the times of the rows each of its fits reads and
of the rows each prediction is asked for; every time is unique in these
records, so the times name the rows. A fit judged on part of the record (a
held-out fold) must not have seen any of those rows, and the folds together
must judge every row once.
"""

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, compare_skeletons, datasets
from sklearn_pycc.diagnostics._data import read_measurements
from sklearn_pycc.diagnostics._held_out import held_out_check, make_folds
from sklearn_pycc.diagnostics._trajectories import horizon_of

#: (the model's equations, times it was fitted on, times it was asked about), per prediction
PREDICTIONS: list[tuple[tuple, np.ndarray, np.ndarray]] = []


class RecordingRegressor(PolyCCRegressor):
    """A PolyCCRegressor that records the times of the rows it fits and predicts."""

    def fit(self, X, y=None):
        super().fit(X, y)
        self.fit_times_ = np.sort(np.asarray(X["t"], dtype=float))
        return self

    def predict(self, X):
        PREDICTIONS.append((tuple(self.skeleton_.equations), self.fit_times_,
                            np.asarray(X["t"], dtype=float)))
        return super().predict(X)


@pytest.fixture(autouse=True)
def fresh_record_of_predictions():
    PREDICTIONS.clear()
    yield
    PREDICTIONS.clear()


def friction_record(n_samples=600, experiments=1):
    """The oscillator with dry friction; each experiment's times follow the last one's."""
    parts = []
    for k in range(experiments):
        frame, truth = datasets.make_oscillator(hidden=["coulomb_friction"], noise=40,
                                                noise_columns=["x1_dot", "x2_dot"],
                                                n_samples=n_samples, t_span=(0.0, 12.0),
                                                random_state=k,
                                                return_truth=True)
        parts.append(frame.assign(t=frame["t"] + 1000.0 * k, trajectory=f"run {k}"))
    frame = pd.concat(parts, ignore_index=True)
    if experiments == 1:
        frame = frame.drop(columns="trajectory")
    assert frame["t"].is_unique
    return frame, truth


def assert_folds_are_held_out(times, n_models, n_folds):
    """Each fit judged on part of the record saw none of it; each model's folds cover it."""
    by_model: dict[tuple, list[np.ndarray]] = {}
    for equations, fitted, judged in PREDICTIONS:
        if len(judged) == len(times):  # a model of the whole record, judged on all of it
            continue
        assert not np.isin(judged, fitted).any(), "a fold's fit saw rows it is judged on"
        # the fit saw most of the rest of the record (not some other subset)
        assert len(fitted) >= 0.5 * (len(times) - len(judged))
        assert np.isin(fitted, times).all()
        by_model.setdefault(equations, []).append(judged)
    assert len(by_model) == n_models
    for folds in by_model.values():
        assert len(folds) == n_folds
        assert np.array_equal(np.sort(np.concatenate(folds)), np.sort(times))


def test_the_held_out_check_fits_each_fold_without_its_rows():
    frame, truth = friction_record()
    X = frame[["t", "x1", "x2", "F_ext", "x1_dot", "x2_dot"]]
    base = RecordingRegressor(equations=truth.base_equations).fit(X)
    extended = RecordingRegressor(equations=truth.parametric_equations).fit(X)
    data = read_measurements(extended.skeleton_, X, None)
    _, folds = make_folds(data)
    PREDICTIONS.clear()
    result = held_out_check(base, extended, data, horizon_of(base, data), [1],
                            max_steps=10**6)
    assert result.n_folds == len(folds) == 3
    assert result.confirmed  # the check itself still works with the recording estimator
    assert_folds_are_held_out(X["t"].to_numpy(), n_models=2, n_folds=3)


@pytest.mark.parametrize("experiments, n_folds", [(1, 3), (2, 2)])
def test_compare_skeletons_judges_each_fold_on_rows_its_fit_did_not_see(experiments, n_folds):
    frame, truth = friction_record(400, experiments)
    table = compare_skeletons({"base": truth.base_equations,
                               "friction": truth.parametric_equations},
                              frame, estimator=RecordingRegressor())
    assert np.isfinite(table["held_out_nrmse"]).all()
    assert table.loc["friction", "held_out_nrmse"] < table.loc["base", "held_out_nrmse"]
    assert table.attrs["held_out"].startswith(f"{n_folds} ")
    assert_folds_are_held_out(frame["t"].to_numpy(), n_models=2, n_folds=n_folds)


@pytest.mark.parametrize("first, confirmed", [(1.5, True), (0.05, False)])
def test_one_fold_that_strays_wildly_does_not_outweigh_two_that_confirm(monkeypatch, first,
                                                                        confirmed):
    # Stribeck friction under coloured noise: fitted on one fold's short blocks, both models
    # strayed on the blocks they did not see, the one with dry friction further (4.5 times
    # the spread, squared), where the two other folds confirmed it a hundredfold. An error
    # beyond the spread counts as the spread; where the model without the effect does well
    # on that fold (0.05), the other's straying still counts against it.
    from sklearn_pycc.diagnostics import _held_out

    frame, truth = friction_record()
    X = frame[["t", "x1", "x2", "F_ext", "x1_dot", "x2_dot"]]
    base = PolyCCRegressor(equations=truth.base_equations).fit(X)
    extended = PolyCCRegressor(equations=truth.parametric_equations).fit(X)
    data = read_measurements(extended.skeleton_, X, None)
    errors = iter([({"simulation": first, "derivatives": 43.6},
                    {"simulation": 4.5, "derivatives": 0.65}),
                   ({"simulation": 0.25, "derivatives": 0.38},
                    {"simulation": 0.005, "derivatives": 0.08}),
                   ({"simulation": 0.28, "derivatives": 0.36},
                    {"simulation": 0.0007, "derivatives": 0.03})])
    monkeypatch.setattr(_held_out, "_fold_errors", lambda *args, **kwargs: next(errors))
    result = held_out_check(base, extended, data, horizon_of(base, data), [1],
                            max_steps=10**6)
    assert (result.n_folds, result.wins) == (3, 2)
    assert result.confirmed is confirmed
    # the spread caps the simulation's errors only
    weights = [len(fold) for fold in make_folds(data)[1]]
    assert result.before["simulation"] == pytest.approx(
        np.sqrt(np.average([min(first, 1.0), 0.25, 0.28], weights=weights)))
    assert result.after["simulation"] == pytest.approx(
        np.sqrt(np.average([1.0, 0.005, 0.0007], weights=weights)))
    assert result.before["derivatives"] == pytest.approx(
        np.sqrt(np.average([43.6, 0.38, 0.36], weights=weights)))
