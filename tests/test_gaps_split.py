"""Missing samples outside the filter: each experiment split at its gaps, and said."""

import warnings

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.measurements.gaps import split_at_gaps

OSCILLATOR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]


def test_every_stretch_between_gaps_is_its_own_experiment_named_after_its_own():
    X = pd.DataFrame({"t": np.arange(12.0), "x1": np.arange(12.0),
                      "trajectory": ["a"] * 8 + ["b"] * 4})
    gaps = np.zeros(12, dtype=bool)
    gaps[[3, 5]] = True  # a: rows 0-2, row 4 alone, rows 6-7; b whole
    y = pd.DataFrame({"x1_dot": np.ones(12)})
    split = split_at_gaps(X, y, {"x1": gaps})
    assert list(split.X["trajectory"]) == ["a, part 1"] * 3 + ["a, part 2"] * 2 + ["b"] * 4
    assert list(split.X["t"]) == [0, 1, 2, 6, 7, 8, 9, 10, 11]  # times kept
    assert len(split.y) == 9 and split.missing == 2 and split.alone == 1 and split.pieces == 3
    unlabelled = split_at_gaps(X.drop(columns="trajectory"), None, {"x1": gaps})
    assert list(unlabelled.X["trajectory"]) == [0] * 3 + [1] * 6
    assert X["trajectory"].tolist() == ["a"] * 8 + ["b"] * 4  # the caller's frame untouched


@pytest.fixture(scope="module")
def record():
    return datasets.make_oscillator(hidden=[], n_samples=1500, noise=40.0,
                                    noise_columns=["x1"], random_state=0)[["t", "x1", "F_ext"]]


def test_a_simulated_fit_reads_a_record_with_scattered_gaps_about_as_well(record):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation").fit(record)
    gappy = record.copy()
    gappy.loc[np.random.default_rng(0).choice(len(gappy), 40, replace=False), "x1"] = np.nan
    with pytest.warns(UserWarning, match=r"x1 misses 40 sample\(s\).*splits the record there "
                      r"into \d+ experiments"):
        split = PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation").fit(gappy)
    assert split.params_["a1"] == pytest.approx(whole.params_["a1"], abs=0.005)  # truth 0.1
    assert split.params_["a2"] == pytest.approx(whole.params_["a2"], rel=0.005)  # truth 1
    assert record["x1"].notna().all()  # the user's record is left as it was


def test_the_equation_fit_says_its_short_stretches_give_noisy_derivatives(record):
    gappy = record.copy()
    gappy.loc[np.arange(50, len(gappy), 50), "x1"] = np.nan
    with pytest.warns(UserWarning, match=r"noisy on short ones \(median 49 samples here: see "
                      r"params_std_\), where fit_mode='simulation'"):
        model = PolyCCRegressor(equations=OSCILLATOR, fit_mode="equation").fit(gappy)
    assert model.params_std_["a1"] > 0.1  # far less sure than the whole record's fit


def test_a_state_with_no_two_neighbouring_samples_is_refused(record):
    sparse = record.head(40).copy()
    sparse.loc[sparse.index[::2], "x1"] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=r"'x1' leaves no two neighbouring samples"):
            PolyCCRegressor(equations=OSCILLATOR, fit_mode="simulation").fit(sparse)
