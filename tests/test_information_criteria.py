"""The BIC values the diagnosis and the comparison report, pinned to the formula by hand.

``n log(RSS / n) + k log n`` per model (:func:`compare_skeletons`), and its
change ``n sum log(RSS' / RSS) + k_new log n`` when ``k_new`` numbers are
added (the diagnosis's candidates and the resamples of its choice). Each test
computes the value from its ingredients, so that a criterion that loses its
penalty, or counts the samples wrongly, fails.
"""

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, compare_skeletons, diagnose
from sklearn_pycc.diagnostics._candidates import _delta_bic
from sklearn_pycc.diagnostics._stability import selection_stability


def test_the_change_of_bic_is_the_log_ratio_of_the_residuals_plus_the_penalty():
    bic, removed = _delta_bic([4.0, 9.0], [1.0, 3.0], np.array([1e-9, 1e-9]), 2, 100)
    assert bic == pytest.approx(100 * (math.log(1 / 4) + math.log(3 / 9)) + 2 * math.log(100),
                                rel=1e-12)
    assert bic == pytest.approx(-239.2804, abs=1e-4)  # -248.4907 + 9.2103
    assert removed == pytest.approx(1 - 4 / 13, rel=1e-12)
    # nothing removed: the penalty alone, growing with the numbers added and the samples
    assert _delta_bic([2.0], [2.0], np.array([1e-9]), 3, 50)[0] == pytest.approx(
        3 * math.log(50), rel=1e-12)


def test_a_residual_below_its_rounding_floor_counts_as_the_floor():
    bic, _ = _delta_bic([1.0], [1e-30], np.array([1e-6]), 1, 10)
    assert bic == pytest.approx(10 * math.log(1e-6) + math.log(10), rel=1e-12)


def first_order_record(n=300, seed=0):
    """``x1_dot = u - 0.8 x1 - 0.3``, derivatives measured with noise: the offset is missing."""
    t = np.linspace(0, 30, n)
    x = 1 + 0.5 * np.sin(0.7 * t) + 0.3 * np.sin(1.9 * t + 1)
    dx = 0.35 * np.cos(0.7 * t) + 0.57 * np.cos(1.9 * t + 1)
    u = dx + 0.8 * x + 0.3  # the input that drives x1 along x
    noise = 0.01 * np.random.default_rng(seed).standard_normal(n)
    return pd.DataFrame({"t": t, "x1": x, "u": u, "x1_dot": dx + noise})


def bic_by_hand(design, target):
    """``n log(RSS / n) + k log n`` of the least-squares fit of ``target`` on ``design``."""
    n, k = design.shape
    coef = np.linalg.lstsq(design, target, rcond=None)[0]
    rss = float(np.sum((target - design @ coef) ** 2))
    return n * math.log(rss / n) + k * math.log(n)


def test_compare_skeletons_reports_the_bic_of_each_least_squares_fit():
    frame = first_order_record()
    table = compare_skeletons({"lagging": ["x1_dot = u - a1 x1"],
                               "offset": ["x1_dot = u - a1 x1 - a2"]},
                              frame, simulate=False, held_out=False)
    target = frame["x1_dot"].to_numpy() - frame["u"].to_numpy()
    x = frame["x1"].to_numpy()
    expected = {"lagging": bic_by_hand(x[:, None], target),
                "offset": bic_by_hand(np.column_stack([x, np.ones_like(x)]), target)}
    assert table["n_params"].to_dict() == {"lagging": 1, "offset": 2}
    for name, value in expected.items():
        assert table.loc[name, "bic"] == pytest.approx(value, rel=1e-6, abs=1e-6), name


def test_the_diagnosis_ranks_by_the_change_of_bic_with_its_penalty():
    frame = first_order_record()
    model = PolyCCRegressor(equations=["x1_dot = u - a1 x1"]).fit(frame)
    report = diagnose(model, frame, simulate=False, held_out=False, n_bootstrap=0,
                      open_curves=False)
    assert report.best.effect == "offset"
    refitted = report.ranking[report.ranking["refit"]]
    assert len(refitted) >= 3
    n = len(frame)  # derivatives measured: every row is judged
    for row in refitted.itertuples():
        # one equation: RSS = n rmse^2 before and after
        expected = 2 * n * math.log(row.rmse_after / row.rmse_before) + row.n_params * math.log(n)
        assert row.delta_bic == pytest.approx(expected, rel=1e-9, abs=1e-9), row.effect


def test_the_resampled_choice_keeps_the_penalty_of_each_candidate():
    # 10 experiments of 30 rows: each resample draws whole experiments, m = 300 rows
    groups = [np.arange(30 * i, 30 * (i + 1)) for i in range(10)]
    residuals = np.ones((300, 1))
    penalty = math.log(300)  # 5.70 per number added

    def wins(fall, n_change):
        """Resamples won by a candidate with m log(RSS'/RSS) = -fall, against a threshold of 10."""
        candidate = SimpleNamespace(key="c", equations=[0], n_change=n_change,
                                    after_squares=math.exp(-fall / 300) * residuals)
        stability = selection_stability([candidate], residuals, residuals, groups, (10.0, 0.01),
                                        tie=(0.0, 0.0), simulates_better=set(), n_resamples=20,
                                        random_state=0)
        return stability.wins.get("c", 0)

    # just either side of the threshold, for one and for two numbers added
    assert wins(10 + penalty - 0.3, 1) == 0
    assert wins(10 + penalty + 0.3, 1) == 20
    assert wins(10 + 2 * penalty - 0.3, 2) == 0
    assert wins(10 + 2 * penalty + 0.3, 2) == 20
