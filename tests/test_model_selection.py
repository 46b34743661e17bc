"""Splitters keeping experiments whole, and the simulation scorer."""

import numpy as np
import pandas as pd
import pytest
from sklearn.model_selection import GridSearchCV, cross_validate

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.model_selection import BlockSplit, ExperimentSplit, make_simulation_scorer

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
CUBIC = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]
TRUE = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1 - a5 x1^3"]


@pytest.fixture(scope="module")
def four_experiments():
    settings = [{"amplitude": a, "omega": w} for a, w in
                [(1.0, 1.0), (1.3, 0.8), (1.6, 1.2), (2.0, 0.9)]]
    return datasets.make_experiments(datasets.make_stick_slip, settings, n_samples=600,
                                     t_span=(0, 15), noise=40, noise_columns=["x1"],
                                     random_state=0)


def test_experiment_split_keeps_experiments_whole(four_experiments):
    X = four_experiments
    cv = ExperimentSplit()
    assert cv.get_n_splits(X) == 4
    for train, test in cv.split(X):
        assert set(X["trajectory"].iloc[train]).isdisjoint(X["trajectory"].iloc[test])
        assert len(set(X["trajectory"].iloc[test])) == 1
    folds = list(ExperimentSplit(n_splits=2).split(X))
    assert [sorted(set(X["trajectory"].iloc[test])) for _, test in folds] == [[0, 1], [2, 3]]
    with pytest.raises(ValueError, match="needs experiment labels"):
        list(ExperimentSplit().split(X.drop(columns="trajectory")))
    with pytest.raises(ValueError, match="no more folds than experiments"):
        list(ExperimentSplit(n_splits=5).split(X))


def test_block_split_cuts_contiguous_blocks_with_a_gap():
    X = pd.DataFrame({"t": np.arange(100.0)})
    folds = list(BlockSplit(n_splits=4, gap=3).split(X))
    assert len(folds) == 4
    train, test = folds[1]
    assert test.tolist() == list(range(25, 50))
    assert not set(range(22, 53)) & set(train.tolist())
    assert set(train) | set(range(22, 53)) == set(range(100))
    with pytest.raises(ValueError, match="n_splits must be an integer of at least 2"):
        BlockSplit(n_splits=1).get_n_splits()


def test_block_split_fold_fits_without_differentiating_across_the_hole():
    frame, truth = datasets.make_duffing(n_samples=1500, t_span=(0, 75), noise=40,
                                         noise_columns=["x1"], random_state=1, return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    train, _ = list(BlockSplit(n_splits=3).split(X))[1]
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                            constraints=["f1 odd"], degree=5).fit(X.iloc[train])
    curve = model.cc_curves()["f2"]
    assert np.sqrt(np.mean((curve["f2"] - truth.functions["f2"](curve["x"])) ** 2)) < 0.03


@pytest.mark.slow
def test_simulation_scorer_ranks_true_model_first(four_experiments):
    X = four_experiments[["t", "trajectory", "x1", "F_ext"]]
    scorer = make_simulation_scorer()
    scores = {name: scorer(PolyCCRegressor(equations=eqs).fit(X), X)
              for name, eqs in {"linear": LINEAR, "true": TRUE}.items()}
    assert scores["true"] > scores["linear"]
    assert -0.05 < scores["true"] <= 0
    with pytest.raises(ValueError, match="time column 't'"):
        scorer(PolyCCRegressor(equations=TRUE).fit(X), X.drop(columns="t"))
    with pytest.raises(ValueError, match="'x9', which is not a state"):
        make_simulation_scorer(["x9"])(PolyCCRegressor(equations=TRUE).fit(X), X)


@pytest.mark.slow
def test_grid_search_over_skeletons_picks_the_true_one(four_experiments):
    X = four_experiments[["t", "trajectory", "x1", "F_ext"]]
    search = GridSearchCV(PolyCCRegressor(equations=LINEAR),
                          {"equations": [LINEAR, CUBIC, TRUE]},
                          scoring=make_simulation_scorer(), cv=ExperimentSplit(),
                          error_score="raise")
    search.fit(X)
    assert search.best_params_["equations"] == TRUE
    scores = search.cv_results_["mean_test_score"]
    assert np.isfinite(scores).all()
    assert scores[2] > scores[1] > scores[0]


def test_cross_validate_with_the_scorer_returns_finite_scores(four_experiments):
    X = four_experiments[["t", "trajectory", "x1", "F_ext"]]
    result = cross_validate(PolyCCRegressor(equations=CUBIC), X, cv=ExperimentSplit(n_splits=2),
                            scoring=make_simulation_scorer(), error_score="raise")
    assert np.isfinite(result["test_score"]).all()


def test_a_diverging_model_scores_minus_infinity():
    model = PolyCCRegressor(equations=["x1_dot = a1 x1^2"]).fit(
        pd.DataFrame({"x1": np.linspace(0.5, 1.0, 50)}), np.linspace(0.5, 1.0, 50) ** 2)
    X = pd.DataFrame({"t": np.linspace(0, 5, 200), "x1": np.full(200, 1.0)})
    assert make_simulation_scorer()(model, X) == -np.inf
