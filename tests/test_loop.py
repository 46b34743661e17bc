"""The hypothesis loop on laboratory records: the right effects, in order, then a stop.

Records are generated as a lab would log them (position only, closed loop,
a few samples per period, a camera dropping frames, coloured noise); the
loop runs with default settings.
"""

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets, diagnose
from sklearn_pycc.diagnostics import Round
from sklearn_pycc.diagnostics._data import read_measurements
from sklearn_pycc.diagnostics._held_out import held_out_check, make_folds
from sklearn_pycc.diagnostics._trajectories import horizon_of

AXIS = ["x1_dot = x2", "x2_dot = a1 F - a2 x2"]


def relative(estimate, truth):
    return abs(estimate / truth - 1)


def ar1_noise(n, rho, std, rng):
    """AR(1)-coloured noise of standard deviation ``std``."""
    white = rng.standard_normal(n) * np.sqrt(1 - rho**2)
    out = np.empty(n)
    out[0] = rng.standard_normal()
    for i in range(1, n):
        out[i] = rho * out[i - 1] + white[i]
    return std * out


def coloured(frame, rho, snr_db, rng, column="x1"):
    x = frame[column].to_numpy()
    std = np.std(x) * 10 ** (-snr_db / 20)
    return frame.assign(**{column: x + ar1_noise(len(x), rho, std, rng)})


def effects_added(loop):
    return [None if r.added is None else r.added.effect for r in loop.rounds]


# -- the acceptance records ------------------------------------------------------------
@pytest.fixture(scope="module")
def axis_loop():
    frame, truth = datasets.make_positioning_axis(random_state=0, return_truth=True)
    loop = HypothesisLoop(PolyCCRegressor(equations=AXIS), frame).run(max_rounds=5)
    return loop, truth


@pytest.mark.slow
def test_the_axis_loop_names_dry_friction_then_the_offset_then_stops(axis_loop):
    loop, truth = axis_loop
    added = effects_added(loop)
    assert added[0] in ("coulomb_friction", "stribeck_friction")
    assert added[1:] == ["offset", None]
    assert loop.stopped and "nothing is missing" in loop.rounds[-1].decision
    final = loop.model.params_
    # mass, viscous and Coulomb friction, offset (a4 is the smoothing of the dry friction)
    for name in ("a1", "a2", "a3", "a5"):
        assert relative(final[name], truth.params[name]) < 0.05, name


@pytest.mark.slow
def test_no_round_of_the_axis_loop_recommends_a_non_physical_model(axis_loop):
    loop, _ = axis_loop
    for r in loop.rounds:
        assert r.diagnosis.implausible == [], r
        if r.added is not None:
            assert r.added.held_out.confirmed
    # every round is judged over the first round's horizon, and the error only falls
    horizons = {r.diagnosis.horizon.time for r in loop.rounds}
    assert len(horizons) == 1
    errors = loop.table()["simulation_rmse"].to_numpy()
    assert np.all(np.diff(errors) < 0), errors


@pytest.mark.slow
def test_a_hardening_resonator_at_ten_samples_per_period_gets_its_cubic_spring():
    frame, truth = datasets.make_resonator(noise=60.0, random_state=0, return_truth=True)
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), frame)
    loop.run(max_rounds=3)
    assert effects_added(loop) == ["cubic_stiffness", None]
    held = loop.rounds[0].added.held_out
    assert held.criterion == "simulation"
    assert held.after["simulation"] * 5 <= held.before["simulation"]
    assert loop.model.params_["a4"] > 0  # hardening
    assert relative(loop.model.params_["a4"], truth.params["a4"]) < 0.02


@pytest.mark.slow
def test_a_filmed_pendulum_is_named_a_pendulum_or_a_softening_spring():
    frame, truth = datasets.make_pendulum(random_state=0, return_truth=True)
    assert frame["t"].diff().max() > 1.5 / 30  # frames were dropped
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), frame)
    loop.run(max_rounds=4)
    added = effects_added(loop)
    assert added[-1] is None and len(added) == 2, added
    first = loop.rounds[0].added
    assert first.effect in ("pendulum", "cubic_stiffness")
    if first.effect == "cubic_stiffness":
        assert first.param_init["a3"] < 0  # softening


@pytest.mark.slow
@pytest.mark.parametrize("kind, rho", [("axis", 0.95), ("resonator", 0.9)])
def test_coloured_noise_on_a_correct_skeleton_names_nothing(kind, rho):
    rng = np.random.default_rng(7)
    if kind == "axis":
        frame, truth = datasets.make_positioning_axis(n_samples=20_000, t_span=(0, 19.999),
                                                      random_state=3, return_truth=True)
    else:
        frame, truth = datasets.make_resonator(noise=None, random_state=3, return_truth=True)
    frame = coloured(frame, rho, 40.0, rng)
    report = diagnose(PolyCCRegressor(equations=truth.equations).fit(frame), frame)
    assert report.best is None, report.summary()


def _correct_record(kind, n, seed):
    """A record of ``kind`` with ``n`` samples, position only, and its true skeleton."""
    if kind == "oscillator":
        frame, truth = datasets.make_oscillator(n_samples=n, t_span=(0, n / 50),
                                                hidden=["coulomb_friction"], random_state=seed,
                                                return_truth=True)
        return frame[["t", "x1", "F_ext"]], truth.equations
    if kind == "axis":
        frame, truth = datasets.make_positioning_axis(n_samples=n, t_span=(0, (n - 1) / 1000),
                                                      random_state=seed, return_truth=True)
    elif kind == "resonator":
        frame, truth = datasets.make_resonator(n_samples=n, noise=None, random_state=seed,
                                               return_truth=True)
    else:
        frame, truth = datasets.make_pendulum(n_samples=n, t_span=(0, n / 100), noise=None,
                                              drop_fraction=0.02, random_state=seed,
                                              return_truth=True)
    return frame, truth.equations


@pytest.mark.slow
def test_twenty_correct_records_with_coloured_noise_raise_at_most_one_alarm():
    kinds = ["oscillator", "axis", "resonator", "pendulum"]
    rhos, sizes = [0.6, 0.8, 0.9, 0.95, 0.95], [20_000, 30_000, 50_000, 100_000]
    alarms = []
    for i in range(20):
        kind, rho, n = kinds[i % 4], rhos[i // 4], sizes[(i // 4 + i) % 4]
        frame, equations = _correct_record(kind, n, i)
        frame = coloured(frame, rho, 40.0 if i % 2 else 30.0, np.random.default_rng(100 + i))
        report = diagnose(PolyCCRegressor(equations=equations).fit(frame), frame)
        if report.best is not None:
            alarms.append(f"{kind} n={n} rho={rho}: {report.best.effect}")
    assert len(alarms) <= 1, alarms


# -- the loop object --------------------------------------------------------------------
@pytest.mark.slow
def test_the_loop_steps_one_round_at_a_time_and_never_touches_the_estimator():
    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], return_truth=True)
    estimator = PolyCCRegressor(equations=truth.base_equations)
    loop = HypothesisLoop(estimator, frame)
    assert loop.model is None and not loop.stopped
    assert "has not run" in loop.summary()
    first = loop.step()
    assert isinstance(first, Round) and first.index == 0
    assert first.added.effect == "cubic_stiffness" and not loop.stopped
    assert not hasattr(estimator, "skeleton_")
    second = loop.step()
    assert second.added is None and loop.stopped
    assert loop.step() is None and len(loop.rounds) == 2
    assert second.skeleton.equations[1].endswith("a3*x1^3")
    table = loop.table()
    assert list(table.index) == [0, 1]
    assert table.loc[0, "suggests"] == "cubic_stiffness" and pd.isna(table.loc[0, "adds"])
    assert table.loc[1, "adds"] == "cubic_stiffness" and pd.isna(table.loc[1, "suggests"])
    assert table.loc[1, "simulation_rmse"] < 1e-2 * table.loc[0, "simulation_rmse"]
    # every column says what it measures: the pooled error names the states it pools
    assert set(table.columns) <= set(table.attrs["columns"])
    assert "pooled over x1, x2" in table.attrs["columns"]["simulation_rmse"]
    assert "x1's own" in table.attrs["columns"]["x1_rmse"]
    text = loop.summary()
    assert "Round 1" in text and "stop: nothing is missing" in text
    assert "confirmed by the simulation error" in text


def test_the_loop_names_bad_arguments():
    frame = datasets.make_oscillator(hidden=[])
    with pytest.raises(TypeError, match="CCRegressor backend"):
        HypothesisLoop(object(), frame)
    with pytest.raises(TypeError, match="pandas DataFrame"):
        HypothesisLoop(PolyCCRegressor(equations=AXIS), frame.to_numpy())
    with pytest.raises(ValueError, match="horizon"):
        HypothesisLoop(PolyCCRegressor(equations=AXIS), frame, horizon="long")
    with pytest.raises(ValueError, match="verbose must be a non-negative integer"):
        HypothesisLoop(PolyCCRegressor(equations=AXIS), frame, verbose=-1)
    with pytest.raises(ValueError, match="max_rounds"):
        HypothesisLoop(PolyCCRegressor(equations=AXIS), frame).run(max_rounds=0)


# -- held-out evidence ------------------------------------------------------------------
@pytest.fixture(scope="module")
def cubic_record():
    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], noise=40,
                                            noise_columns=["x1"], random_state=0,
                                            return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    base = PolyCCRegressor(equations=truth.base_equations).fit(X)
    right = PolyCCRegressor(equations=truth.parametric_equations).fit(X)
    spurious = PolyCCRegressor(equations=[truth.parametric_equations[0],
                                          truth.parametric_equations[1] + " - a4 - a5 t"])
    data = read_measurements(right.skeleton_, X, None)
    return data, base, right, spurious.fit(X)


def test_folds_interleave_blocks_in_time_or_follow_the_experiments(cubic_record):
    data, base, _, _ = cubic_record
    description, folds = make_folds(data)
    assert len(folds) == 3 and description == "3 folds of 4 interleaved blocks in time"
    rows = np.sort(np.concatenate(folds))
    assert np.array_equal(rows, np.arange(data.n_samples))  # each row held out once
    # every fold spans the record: a free decay is not judged by extrapolation
    for fold in folds:
        assert fold.min() < data.n_samples / 2 < fold.max()
        assert np.count_nonzero(np.diff(fold) > 1) >= 1  # blocks apart in time
    # several experiments are folds of their own
    X = data.X.assign(trajectory=np.where(np.arange(data.n_samples) < 900, "a", "b"))
    two = read_measurements(base.skeleton_, X, data.derivatives)
    description, folds = make_folds(two)
    assert description == "2 folds of 2 experiments"
    assert [len(f) for f in folds] == [900, data.n_samples - 900]


def test_the_held_out_check_confirms_a_true_effect_and_not_a_spurious_one(cubic_record):
    data, base, right, spurious = cubic_record
    horizon = horizon_of(base, data)
    confirmed = held_out_check(base, right, data, horizon, [1], max_steps=10**6)
    assert confirmed.confirmed and confirmed.wins == 3
    assert confirmed.change() < -0.5 and confirmed.change("derivatives") < -0.5
    rejected = held_out_check(right, spurious, data, horizon, [1], max_steps=10**6)
    assert not rejected.confirmed
    assert rejected.change() > -0.01
    assert "not confirmed by the simulation error" in str(rejected)
    # it lost the first two folds: the third, whatever it showed, could not confirm it
    assert rejected.stopped and rejected.n_folds == 2 and rejected.wins == 0
    assert "the folds left were not fitted" in str(rejected)
    # fitted side by side, every fold is judged, and the verdict is the same
    every = held_out_check(right, spurious, data, horizon, [1], max_steps=10**6, n_jobs=2)
    assert not every.confirmed and not every.stopped and every.n_folds == 3
    assert every.before["simulation"] == pytest.approx(rejected.before["simulation"], rel=0.5)
    # a force of time stops at the first fold it does not win
    timed = held_out_check(right, spurious, data, horizon, [1], max_steps=10**6,
                           every_fold=True)
    assert timed.stopped and timed.n_folds == 1 and not timed.confirmed
    assert confirmed.wins == 3 and not confirmed.stopped  # a confirmation sees every fold


def test_the_ranking_shows_the_held_out_evidence():
    frame, truth = datasets.make_oscillator(hidden=["coulomb_friction"], return_truth=True)
    model = PolyCCRegressor(equations=truth.base_equations).fit(frame)
    report = diagnose(model, frame)
    row = report.ranking.iloc[0]
    assert row.effect == report.best.effect == "coulomb_friction"
    assert row.held_out_change < -0.5 and row.held_out_wins == "3 of 3"
    assert "Decided on data each fit did not see" in report.summary()
    quick = diagnose(model, frame, held_out=False)
    assert quick.best.effect == "coulomb_friction" and quick.best.held_out is None
    assert pd.isna(quick.ranking.iloc[0].held_out_change)
    with pytest.raises(ValueError, match="held_out"):
        diagnose(model, frame, held_out="yes")


def test_a_search_over_skeletons_of_a_chaotic_duffing_picks_the_cubic_spring():
    from sklearn.model_selection import GridSearchCV

    from sklearn_pycc.model_selection import BlockSplit, make_simulation_scorer

    frame = datasets.make_duffing(noise=40, noise_columns=["x1"], random_state=0)
    X = frame[["t", "x1", "F_ext"]]
    linear = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
    cubic = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]
    wrong_damping = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 abs(x2) - a2 x1 - a3 x1^3"]
    search = GridSearchCV(PolyCCRegressor(), {"equations": [linear, cubic, wrong_damping]},
                          scoring=make_simulation_scorer(), cv=BlockSplit(n_splits=3),
                          error_score="raise").fit(X)
    assert search.best_params_["equations"] == cubic
    scores = search.cv_results_["mean_test_score"]
    assert scores[1] > 0.5 * scores[2] and scores[1] > 0.1 * scores[0]  # negative errors
