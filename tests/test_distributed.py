"""Skeleton sweeps on a dask cluster through joblib (the ``dist`` extra)."""

import numpy as np
import pytest
from sklearn.model_selection import GridSearchCV

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.model_selection import ExperimentSplit, make_simulation_scorer

distributed = pytest.importorskip("distributed")

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
CUBIC = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]
TRUE = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1 - a5 x1^3"]


def search(n_jobs):
    return GridSearchCV(PolyCCRegressor(equations=LINEAR),
                        {"equations": [LINEAR, CUBIC, TRUE]},
                        scoring=make_simulation_scorer(), cv=ExperimentSplit(),
                        error_score="raise", n_jobs=n_jobs)


@pytest.mark.slow
def test_grid_search_over_skeletons_on_a_local_dask_cluster():
    from joblib import parallel_backend

    settings = [{"amplitude": a, "omega": w} for a, w in [(1.0, 1.0), (1.3, 0.8), (1.6, 1.2)]]
    frame = datasets.make_experiments(datasets.make_stick_slip, settings, n_samples=400,
                                      t_span=(0, 12), noise=40, noise_columns=["x1"],
                                      random_state=0)
    X = frame[["t", "trajectory", "x1", "F_ext"]]
    local = search(n_jobs=1).fit(X)
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None)
    with cluster, distributed.Client(cluster) as client, parallel_backend("dask"), \
            distributed.get_task_stream(client) as tasks:
        remote = search(n_jobs=-1).fit(X)
    # the fits ran as tasks on the cluster's two worker processes
    assert len(tasks.data) >= 9  # 3 skeletons x 3 folds
    assert len({task["worker"] for task in tasks.data}) == 2
    assert remote.best_params_ == local.best_params_ == {"equations": TRUE}
    np.testing.assert_allclose(remote.cv_results_["mean_test_score"],
                               local.cv_results_["mean_test_score"], rtol=1e-10)
