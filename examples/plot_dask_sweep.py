"""
Skeleton sweeps on a dask cluster
=================================

Sweeps in sklearn-pycc run on :mod:`joblib` (``n_jobs``), so they move to a
cluster without changing a line of the search: inside
``joblib.parallel_backend("dask")`` every fit of a
:class:`~sklearn.model_selection.GridSearchCV` becomes a task on the cluster's
workers. This needs the ``dist`` extra (``pip install "sklearn-pycc[dist]"``).

Here the cluster is a :class:`~distributed.LocalCluster` of two workers
inside this process, which keeps the example self-contained. A cluster of
worker processes, ``LocalCluster(processes=True)``, needs the script's work
under an ``if __name__ == "__main__":`` guard, since each worker process
imports the script. On a real cluster, connect to its scheduler instead,
``Client("tcp://scheduler-address:8786")``; every worker needs sklearn-pycc
installed in the same version.
"""

import matplotlib.pyplot as plt
import numpy as np
from distributed import Client, LocalCluster
from joblib import parallel_backend
from sklearn.model_selection import GridSearchCV

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.model_selection import ExperimentSplit, make_simulation_scorer

# %%
# Three experiments, position only
# --------------------------------
settings = [{"amplitude": a, "omega": w} for a, w in [(1.0, 1.0), (1.3, 0.8), (1.6, 1.2)]]
frame = datasets.make_experiments(datasets.make_stick_slip, settings, n_samples=400,
                                  t_span=(0, 12), noise=40, noise_columns=["x1"],
                                  random_state=0)
X = frame[["t", "trajectory", "x1", "F_ext"]]

# %%
# The sweep: three parametric skeletons, and one that leaves the friction
# curve free (odd, a polynomial of degree 5).
LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
CUBIC = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]
FRICTION = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1 - a5 x1^3"]
FREE_FRICTION = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a1 x1 - a2 x1^3"]
search = GridSearchCV(
    PolyCCRegressor(equations=LINEAR),
    [{"equations": [LINEAR, CUBIC, FRICTION]},
     {"equations": [FREE_FRICTION], "constraints": [["f1 odd"]], "degree": [5]}],
    scoring=make_simulation_scorer(), cv=ExperimentSplit(), error_score="raise", n_jobs=-1,
)

# %%
# Run it on the cluster
# ---------------------
# ``n_jobs=-1`` hands every (candidate, fold) pair to joblib, and the dask
# backend sends each to a worker. Every fit is seeded by its own
# ``random_state``, so the result is the same as with ``n_jobs=1``.
with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                  dashboard_address=None) as cluster, Client(cluster) as client:
    with parallel_backend("dask"):
        search.fit(X)
    workers = len(client.scheduler_info()["workers"])
print(f"{len(search.cv_results_['params']) * search.n_splits_} fits on {workers} workers")

# %%
labels = []
for params in search.cv_results_["params"]:
    name = {str(LINEAR): "linear", str(CUBIC): "+ cubic spring", str(FRICTION): "+ dry friction",
            str(FREE_FRICTION): "free friction curve"}[str(params["equations"])]
    labels.append(name)
rmse = -search.cv_results_["mean_test_score"]
order = np.argsort(rmse)
fig, ax = plt.subplots(figsize=(6, 3))
ax.barh([labels[i] for i in order], rmse[order], color="C2")
ax.set_xscale("log")
ax.set_xlabel("held-out simulation RMSE")
ax.invert_yaxis()
fig.tight_layout()
plt.show()

# %%
print("best:", labels[search.best_index_])
search.best_estimator_.equations()
