"""The loop's acceptance figures, checked on every run: right, complete, no false alarm.

A reduced form of ``asv_benchmarks/loop_study.py``: four hidden-effect cases
and two controls, one seed, position only (``t, x1, F_ext``), 40 dB on the
position, the loop from defaults. Per case:

right
    the first effect the loop names is the hidden one; on a control the loop
    names nothing;
complete
    the loop's answer simulates a fresh record (another release and forcing
    frequency) within twice the error of the true skeleton fitted alike.
"""

import warnings

import numpy as np
import pytest
from benchmark_scripts import load

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, SimulationError, datasets

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
# case -> hidden effects (with their strengths); the controls hide nothing, or start
# from the true skeleton
CASES = {
    "cubic_stiffness": {"cubic_stiffness": None},
    "saturation": {"saturation": None},
    "dead_zone": {"dead_zone": {"a1": 2.0, "a2": 0.8}},
    "pendulum": {"pendulum": None},
    "control_linear": {},
    "control_cubic": {"cubic_stiffness": None},
}


def _record(hidden, *, fresh: bool):
    options = dict(n_samples=1500, t_span=(0.0, 60.0))
    if fresh:
        options.update(y0=(2.0, 0.0), omega=1.3, amplitude=0.5)
    return datasets.make_oscillator(hidden=dict(hidden), noise=40.0, noise_columns=["x1"],
                                    random_state=1000 if fresh else 0, return_truth=True,
                                    **options)


def _error(model, frame, truth) -> float:
    t = frame["t"].to_numpy()
    try:
        simulated = model.simulate(t, list(truth.y0), inputs={"F_ext": frame["F_ext"].to_numpy()})
    except SimulationError:
        return np.inf
    return float(np.sqrt(np.mean((simulated["x1"].to_numpy() - frame["x1"].to_numpy()) ** 2)))


def _check_loop(case: str, frame, truth, fresh, fresh_truth) -> None:
    """The loop from defaults on ``frame``: right, complete and quiet."""
    hidden = CASES[case]
    X = frame[["t", "x1", "F_ext"]]
    start = truth.parametric_equations if case == "control_cubic" else LINEAR
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=start), X).run(max_rounds=5)
        reference = PolyCCRegressor(equations=truth.parametric_equations).fit(X)
    named = [r.added.effect for r in loop.rounds if r.added is not None]
    if case.startswith("control"):
        assert named == [], f"false alarm on {case}: {named}"
    else:
        assert named and named[0] in hidden, f"{case}: the loop named {named}"
    ours, best = _error(loop.model, fresh, fresh_truth), _error(reference, fresh, fresh_truth)
    assert ours <= 2 * best, f"{case}: fresh-record error {ours:.4g}, the truth {best:.4g}"


@pytest.mark.parametrize("case", list(CASES))
def test_the_loop_is_right_complete_and_quiet(case):
    _check_loop(case, *_record(CASES[case], fresh=False), *_record(CASES[case], fresh=True))


def _sensor_record(hidden, *, fresh: bool, pole: float, snr: float, seed: int):
    options = dict(n_samples=3000, t_span=(0.0, 60.0))
    if fresh:
        options.update(y0=(2.0, 0.0), omega=1.3, amplitude=0.5)
    frame, truth = datasets.make_oscillator(hidden=dict(hidden), return_truth=True,
                                            random_state=seed + 1000 * fresh, **options)
    if not fresh:  # the fresh record the answer is judged on is clean
        frame = datasets.add_sensor_noise(frame, ["x1"], snr=snr, pole=pole, bits=12,
                                          random_state=seed)
    return frame, truth


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_the_loop_is_right_complete_and_quiet_under_coloured_noise(case):
    # AR(1) noise of pole 0.9 at 40 dB, rounded to 12 bits: read from the top of the
    # spectrum it looked small, the derivatives were noise and the loop named nothing
    noise = dict(pole=0.9, snr=40.0, seed=0)
    _check_loop(case, *_sensor_record(CASES[case], fresh=False, **noise),
                *_sensor_record(CASES[case], fresh=True, **noise))


@pytest.mark.slow
def test_a_quadratic_drag_joins_the_viscous_damping_the_user_wrote():
    # pole 0.9 at 30 dB: replacing 'a1*x2' by the drag did as well on held-out folds, and
    # the fresh release then decayed too slowly at low speed (7x the truth's error); a
    # later round removed the damping again, on folds whose error is the noise
    noise = dict(pole=0.9, snr=30.0, seed=1)
    hidden = {"quadratic_drag": None}
    frame, truth = _sensor_record(hidden, fresh=False, **noise)
    fresh, fresh_truth = _sensor_record(hidden, fresh=True, **noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR),
                              frame[["t", "x1", "F_ext"]]).run(max_rounds=5)
        reference = PolyCCRegressor(equations=truth.parametric_equations).fit(
            frame[["t", "x1", "F_ext"]])
    named = [r.added for r in loop.rounds if r.added is not None]
    assert [s.effect for s in named] == ["quadratic_drag"] and named[0].move == "add"
    assert "a1 x2" in loop.model.equations[1]
    assert _error(loop.model, fresh, fresh_truth) <= 1.5 * _error(reference, fresh, fresh_truth)


@pytest.mark.slow
def test_an_effect_the_folds_like_and_the_whole_record_does_not_is_not_named():
    # a linear oscillator, pole 0.8 at 30 dB: a cubic spring lowered the held-out folds'
    # error by 12.6 %, and the whole record's output error by 0.3 %
    frame, _ = _sensor_record({}, fresh=False, pole=0.8, snr=30.0, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR),
                              frame[["t", "x1", "F_ext"]]).run(max_rounds=3)
    assert loop.rounds[0].added is None, loop.rounds[0].diagnosis.summary()
    ranking = loop.rounds[0].diagnosis.ranking
    assert ranking.note.str.contains("not confirmed by the whole record").any()


@pytest.mark.slow
def test_a_dead_zone_is_named_under_strongly_coloured_noise():
    # pole 0.95 at 30 dB: the derivatives once scored a stiffening x1|x1| a hair above the
    # dead zone; the dead zone is named
    frame, _ = _sensor_record(CASES["dead_zone"], fresh=False, pole=0.95, snr=30.0, seed=1)
    _assert_named(frame, "dead_zone")


@pytest.mark.slow
def test_on_a_long_record_the_cubic_spring_is_named():
    # 48,000 samples: the derivatives once scored x1|x1| 3 % above the cubic spring, which
    # simulates the record three times better
    frame = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=48000,
                                     t_span=(0.0, 960.0), noise=40.0, noise_columns=["x1"],
                                     random_state=0)
    _assert_named(frame, "cubic_stiffness")


def _assert_named(frame, effect: str) -> None:
    """The linear skeleton's diagnosis names ``effect``."""
    from sklearn_pycc import diagnose

    X = frame[["t", "x1", "F_ext"]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = diagnose(PolyCCRegressor(equations=LINEAR).fit(X), X)
    assert report.best.effect == effect


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 4, 8])
def test_a_filmed_free_decay_of_a_linear_oscillator_raises_no_alarm(seed):
    # 30 fps, whole pixels, 0.3 px white noise and 0.3 px of jitter correlated over frames:
    # the loop from the true skeleton names nothing (asv_benchmarks/camera_control.py: 10
    # draws)
    camera = load("camera_control")
    row = camera.run_draw(seed, seconds=30.0)
    assert row["named"] == [], row


@pytest.mark.slow
@pytest.mark.parametrize("guard", ["whole record", "every fold"])
def test_the_wander_of_coloured_noise_is_no_unmeasured_periodic_force(guard, monkeypatch):
    # Coulomb friction, pole 0.9 at 30 dB: after the friction, a periodic force lowered the
    # held-out error by 59 %, all of it in the one fold where the friction model's fit had
    # gone astray (it did worse in another fold); on the whole record it took out 1.9 %,
    # about what its three numbers take out of noise that wanders so slowly. Each guard
    # stops it alone.
    from sklearn_pycc.diagnostics import _decide

    if guard == "every fold":
        monkeypatch.setattr(_decide, "CHANCE_Z", 0.0)
    frame, _ = _sensor_record({"coulomb_friction": None}, fresh=False, pole=0.9, snr=30.0,
                              seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR),
                              frame[["t", "x1", "F_ext"]]).run(max_rounds=3)
    assert [r.added.effect for r in loop.rounds if r.added] == ["coulomb_friction"]
    note = loop.rounds[1].diagnosis.ranking.set_index("effect").note["periodic_forcing"]
    assert {"whole record": "times what its numbers would take out of this record's noise",
            "every fold": "a force of time alone must lower it in every fold"}[guard] in note
