"""Rooms whose walls nobody measures: the unit of time, the starts, and the noise floor."""

import warnings

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, StartsWarning, datasets
from sklearn_pycc.fitting.output_error.starts import StartContest, noise_floor


def _fit(frame, truth):
    with warnings.catch_warnings():
        warnings.simplefilter("error", StartsWarning)
        return PolyCCRegressor(equations=truth.equations).fit(frame)


def test_make_rooms_writes_the_same_record_in_every_unit_of_time():
    hours, truth_h = datasets.make_rooms(200, n_rooms=2, random_state=3, return_truth=True)
    seconds, truth_s = datasets.make_rooms(200, n_rooms=2, time_unit="s", random_state=3,
                                           return_truth=True)
    assert list(hours.columns) == ["t", "To", "Q1", "Q2", "T1", "T2"]
    assert truth_h.unmeasured == ["W1", "W2"]
    np.testing.assert_allclose(seconds["t"], 3600 * hours["t"])
    np.testing.assert_allclose(seconds[["T1", "T2"]], hours[["T1", "T2"]])
    for name, value in truth_h.params.items():
        assert truth_s.params[name] == pytest.approx(value / 3600)
    # the wall between the rooms carries the same conductance both ways
    assert truth_h.equations[0].endswith("+ a11 (T2 - T1)")
    assert truth_h.equations[2].endswith("+ a11 (T1 - T2)")


def test_make_rooms_is_the_exact_solution_of_its_skeleton():
    frame, truth = datasets.make_rooms(300, noise=None, random_state=0, return_truth=True)
    # the walls read too: the equations fitted to the exact course's derivatives
    X = pd.concat([frame[["t", "To", "Q1"]], truth.states], axis=1)
    rates = np.gradient(truth.states.to_numpy(), frame["t"].to_numpy(), axis=0)
    model = PolyCCRegressor(equations=truth.equations)
    model.fit(X, pd.DataFrame(rates, columns=["T1_dot", "W1_dot"]))
    for name, value in truth.params.items():
        assert model.params_[name] == pytest.approx(value, rel=0.05), name


@pytest.mark.parametrize("bad, match", [({"n_rooms": 0}, "n_rooms"),
                                         ({"n_rooms": 1.5}, "n_rooms"),
                                         ({"time_unit": "days"}, "time_unit")])
def test_make_rooms_refuses_bad_settings(bad, match):
    with pytest.raises(ValueError, match=match):
        datasets.make_rooms(50, **bad)


def test_the_fit_of_hidden_walls_does_not_depend_on_the_unit_of_time():
    # a sample every five minutes for 50 hours: rates 0.02 to 1.2 per hour, or
    # 6e-6 to 3e-4 per second; the default start is 1 either way
    fits = {}
    for unit in ("h", "s"):
        frame, truth = datasets.make_rooms(600, time_unit=unit, random_state=2,
                                           return_truth=True)
        model = _fit(frame, truth)
        fits[unit] = {a: model.params_[a] / v for a, v in truth.params.items()}
        for name, ratio in fits[unit].items():
            assert ratio == pytest.approx(1.0, rel=0.1), (unit, name)
        table = model.starts_
        assert list(table.columns) == ["start", "nrmse_start", "nrmse", "polished", "kept"]
        assert table["kept"].sum() == 1
        kept = table[table["kept"]].iloc[0]
        assert kept.polished == "whole"
        assert kept.nrmse == pytest.approx(table["nrmse"].min())
        assert kept.nrmse == pytest.approx(model.shooting_["nrmse_whole"])
    for name in fits["h"]:
        assert fits["s"][name] == pytest.approx(fits["h"][name], rel=1e-3), name


def test_the_noise_floor_reads_white_noise_and_stays_low_under_coloured():
    frame, truth = datasets.make_rooms(1500, noise=None, random_state=1, return_truth=True)
    model = PolyCCRegressor(equations=truth.equations, param_init=truth.params,
                            shooting_iterations=1)
    rms = float(np.sqrt(np.mean(frame["T1"] ** 2)))
    for pole, low, high in ((0.0, 0.85, 1.15), (0.9, 0.0, 0.5)):
        noisy = datasets.add_sensor_noise(frame, ["T1"], snr=40, pole=pole, random_state=0)
        level = float(np.std(noisy["T1"] - frame["T1"])) / rms
        problem = model._problem_of(noisy)
        assert low * level <= noise_floor(problem) <= high * level, pole


def test_starts_that_fit_equally_well_at_other_numbers_are_told():
    contest = StartContest(substeps=1, iterations=1)
    frame, truth = datasets.make_rooms(100, random_state=0, return_truth=True)
    problem = PolyCCRegressor(equations=truth.equations)._problem_of(frame)
    first = np.zeros((1, 2))
    contest.best, contest.problem = ({"a1": 1.0, "a2": 0.3}, first, 0.0100, []), problem
    contest.finished = [(0.0100, {"a1": 1.0, "a2": 0.3}), (0.01001, {"a1": 1.0, "a2": 0.5}),
                        (0.0200, {"a1": 3.0, "a2": 0.3})]
    words = contest.disagreement()
    assert words is not None and words.startswith("a2 is 0.3 in the fit kept and 0.5")
    contest.finished = contest.finished[::2]  # only a worse one differs
    assert contest.disagreement() is None


def test_rates_that_carry_a_state_toward_another_are_read_from_the_skeleton():
    from sklearn_pycc import Skeleton
    from sklearn_pycc.fitting.output_error.couplings import coupling_rates

    _, truth = datasets.make_rooms(50, n_rooms=2, return_truth=True)
    found = coupling_rates(Skeleton(truth.equations).parsed)
    assert found["a1"] == ("T1_dot", "T1", "W1") and found["a4"] == ("W1_dot", "W1", "T1")
    assert found["a11"] == ("T1_dot", "T1", "T2") and found["a10"] == ("W2_dot", "W2", "To")
    assert not {"a3", "a8"} & set(found)  # the heaters' gains move nothing toward anything
    # written with the difference the other way round, negated: still toward
    skeleton = Skeleton(["x1_dot = a1 u - a2 (x1 - x2)", "x2_dot = -a3 (x2 - x1) - a4 x2",
                         "x3_dot = a5 (x3 - x1)"])
    assert set(coupling_rates(skeleton.parsed)) == {"a2", "a3"}  # a5 pushes x3 away


def test_a_rate_that_drives_heat_uphill_is_named():
    from sklearn_pycc.estimators.base import make_problem
    from sklearn_pycc.fitting.output_error.hidden_fit import _warn_against_gradient

    frame, truth = datasets.make_rooms(200, n_rooms=1, random_state=0, return_truth=True)
    problem = make_problem(PolyCCRegressor(equations=truth.equations), frame)
    with pytest.warns(UserWarning, match=r"a4 is -0.1 .*drives W1 away from T1"):
        _warn_against_gradient(problem, {**truth.params, "a4": -0.1})
    bounded = make_problem(PolyCCRegressor(equations=truth.equations,
                                           constraints=["a4 >= -1"]), frame)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a bound the user wrote is theirs
        _warn_against_gradient(bounded, {**truth.params, "a4": -0.1})


@pytest.mark.slow
def test_two_rooms_whose_first_estimate_sends_heat_uphill_are_fitted():
    # multiple shooting alone ends with the walls of room 1 cut off (a1 = 0, a4 = -138)
    frame, truth = datasets.make_rooms(3000, n_rooms=2, noise=40.0, random_state=5,
                                       return_truth=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=truth.equations).fit(frame)
    assert "multiple shooting (couplings positive)" in set(model.starts_["start"])
    for name, value in truth.params.items():
        assert model.params_[name] == pytest.approx(value, rel=0.1), name
