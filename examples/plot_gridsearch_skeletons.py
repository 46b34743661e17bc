"""
Comparing skeletons with cross-validation
=========================================

The skeleton is an ordinary hyperparameter, so scikit-learn's
:class:`~sklearn.model_selection.GridSearchCV` compares candidate skeletons
like any other setting. Two things make the comparison trustworthy for
dynamical systems:

* :class:`~sklearn_pycc.model_selection.ExperimentSplit` holds out whole
  experiments, so no fold is differentiated or simulated across another
  fold's data;
* :func:`~sklearn_pycc.model_selection.make_simulation_scorer` scores a
  model by simulating it on the held-out experiment from its measured start
  with its measured input, rather than by its derivatives.
"""

import matplotlib.pyplot as plt
import pandas as pd
from sklearn.model_selection import GridSearchCV

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.model_selection import ExperimentSplit, make_simulation_scorer

# %%
# Four experiments on the stick-slip oscillator
# ---------------------------------------------
# Each experiment has its own forcing; only the position ``x1`` is measured,
# with 40 dB of noise. The velocity ``x2`` is reconstructed from ``x1``
# through the kinematic equation ``x1_dot = x2``.
settings = [{"amplitude": a, "omega": w}
            for a, w in [(1.0, 1.0), (1.3, 0.8), (1.6, 1.2), (1.2, 1.5)]]
frame = datasets.make_experiments(datasets.make_stick_slip, settings, n_samples=500,
                                  t_span=(0, 15), noise=40, noise_columns=["x1"],
                                  random_state=0)
X = frame[["t", "trajectory", "x1", "F_ext"]]
X.groupby("trajectory").size()

# %%
# Candidate skeletons
# -------------------
# From the linear oscillator to the seed paper's parametric model, and the
# functional skeleton that leaves both curves free. Constraints belong to a
# skeleton (a parametric skeleton has no ``f1`` to make odd), so the grid is a
# list of two grids: the parametric skeletons without constraints, the
# functional one with friction odd. Its curves are polynomials of degree 5:
# a held-out experiment reaches beyond the range the curves were fitted on,
# and higher degrees extrapolate wildly there.
skeletons = {
    "linear": ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"],
    "+ cubic spring": ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"],
    "+ dry friction": ["x1_dot = x2",
                       "x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1 - a5 x1^3"],
    "free curves": ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
}
parametric = [skeletons[name] for name in ("linear", "+ cubic spring", "+ dry friction")]
search = GridSearchCV(
    PolyCCRegressor(equations=skeletons["linear"], degree=5),
    [{"equations": parametric, "constraints": [None]},
     {"equations": [skeletons["free curves"]], "constraints": [["f1 odd"]]}],
    scoring=make_simulation_scorer(), cv=ExperimentSplit(), error_score="raise",
)
search.fit(X)

# %%
# The simulation score is the negative RMS error of the simulated states on
# the held-out experiment, so higher is better.
names = {str(equations): name for name, equations in skeletons.items()}
results = pd.DataFrame({
    "skeleton": [names[str(p["equations"])] for p in search.cv_results_["params"]],
    "mean score": search.cv_results_["mean_test_score"],
    "std": search.cv_results_["std_test_score"],
})
results

# %%
fig, ax = plt.subplots(figsize=(6, 3))
ax.barh(results["skeleton"], -results["mean score"], xerr=results["std"], color="C0")
ax.set_xscale("log")
ax.set_xlabel("held-out simulation RMSE (lower is better)")
ax.invert_yaxis()
fig.tight_layout()
plt.show()

# %%
# The best skeleton, refitted on every experiment:
print(names[str(search.best_params_["equations"])])
search.best_estimator_.equations()
