"""A long record's filter fit: searched over a share of its segments, finished on the whole.

The thresholds are lowered here so that a record of a few thousand samples
takes the path a record of a million does.
"""

import warnings

import numpy as np
import pytest

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.fitting.filter import search, stage

OSCILLATOR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]


def _record(n: int, seed: int = 0):
    return datasets.make_oscillator(hidden=[], disturbance=0.08, noise=40.0,
                                    noise_columns=["x1"], n_samples=n,
                                    t_span=(0.0, n / 100), random_state=seed)[["t", "x1", "F_ext"]]


def _fit(X, monkeypatch, *, share: bool):
    monkeypatch.setattr(stage, "SEARCH_SHARE_ABOVE", 2_000 if share else 10**9)
    monkeypatch.setattr(stage, "SEARCH_SHARE", 1_000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(X)


@pytest.fixture(scope="module")
def record():
    return _record(6_000)


def test_a_share_and_one_newton_step_give_the_whole_records_fit(record, monkeypatch):
    whole = _fit(record, monkeypatch, share=False)
    shared = _fit(record, monkeypatch, share=True)
    assert whole.filter_["searched_segments"] == whole.filter_["segments"]
    assert shared.filter_["searched_segments"] <= shared.filter_["segments"] // 4
    for name in ("a1", "a2"):
        error = whole.params_std_[name]
        assert abs(shared.params_[name] - whole.params_[name]) < 0.25 * error
        assert shared.params_std_[name] == pytest.approx(error, rel=0.1)
    for fitted, errors in (("process_noise_", "process_noise_std_"),
                           ("measurement_noise_", "measurement_noise_std_")):
        state = "x2" if fitted == "process_noise_" else "x1"
        error = getattr(whole, errors)[state]
        assert abs(getattr(shared, fitted)[state] - getattr(whole, fitted)[state]) < 0.25 * error
        assert getattr(shared, errors)[state] == pytest.approx(error, rel=0.1)
    # the whole record's likelihood where the step landed: as high as the whole search's
    assert shared.filter_["nll"] == pytest.approx(whole.filter_["nll"], abs=0.05)


def test_the_whole_record_is_searched_where_the_step_cannot_be_trusted(record, monkeypatch):
    monkeypatch.setattr(search, "_scaled_curvature",
                        lambda whole, space, z, *, H, share: (0.0, np.zeros(len(z)), None))
    monkeypatch.setattr(stage, "SEARCH_SHARE_ABOVE", 2_000)
    monkeypatch.setattr(stage, "SEARCH_SHARE", 1_000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter", random_state=0)
        problem, _ = model._problem(record, None, model._make_backend())
    plan = stage.filter_plan(problem, problem.skeleton.compile({}, {"a1": 0.1, "a2": 1.0}),
                             whole=False)
    share = stage.search_segments(plan)
    assert share is not None
    layout = stage.noisy_states(problem, list(plan.measured))

    def system_for(theta):
        return problem.skeleton.compile({}, {"a1": theta[0], "a2": theta[1]})

    start = (np.array([0.1, 1.0]), np.array([0.0, 0.08]), np.array([0.006]))
    fitted = search.fit_filter(plan.segments(share), system_for, *start, noisy=layout,
                               whole=plan, curvature=False)
    alone = search.fit_filter(plan, system_for, *start, noisy=layout, curvature=False)
    assert fitted[3]["whole_step"] == "searched"
    assert fitted[3]["nll"] == pytest.approx(alone[3]["nll"], abs=0.05)
    np.testing.assert_allclose(fitted[0], alone[0], rtol=2e-3)


def test_the_share_holds_every_experiments_start_and_is_a_share(record, monkeypatch):
    monkeypatch.setattr(stage, "SEARCH_SHARE_ABOVE", 2_000)
    monkeypatch.setattr(stage, "SEARCH_SHARE", 1_000)
    two = record.assign(trajectory=np.repeat([0, 1], len(record) // 2))
    model = PolyCCRegressor(equations=OSCILLATOR)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem, _ = model._problem(two, None, model._make_backend())
    plan = stage.filter_plan(problem, problem.skeleton.compile({}, {"a1": 0.1, "a2": 1.0}),
                             whole=False)
    share = stage.search_segments(plan)
    assert set(plan.first_segments()) <= set(share)
    assert 2 * len(share) <= plan.n_segments
    part = plan.segments(share)
    np.testing.assert_array_equal(part.targets, plan.targets[share])
    np.testing.assert_array_equal(part.fine_signals()["F_ext"],
                                  plan.fine_signals()["F_ext"][share])
    # a short record is searched whole
    monkeypatch.setattr(stage, "SEARCH_SHARE_ABOVE", 10**9)
    assert stage.search_segments(plan) is None


def test_auto_mode_recognises_the_push_on_a_share_as_on_the_whole(record, monkeypatch):
    import sklearn_pycc.fitting.filter.evidence as evidence

    seen = []
    original = evidence.search_segments
    monkeypatch.setattr(evidence, "search_segments",
                        lambda plan: seen.append(original(plan)) or seen[-1])
    monkeypatch.setattr(stage, "SEARCH_SHARE_ABOVE", 2_000)
    monkeypatch.setattr(stage, "SEARCH_SHARE", 1_000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=OSCILLATOR).fit(record)
    assert seen and seen[0] is not None  # the evidence read a share
    assert model.process_noise_evidence_.recognised and model.fit_mode_ == "filter"
    assert model.filter_["searched_segments"] < model.filter_["segments"]
