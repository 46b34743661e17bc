"""
Finding a hidden effect
=======================

An oscillator is measured with 1 % noise. Hidden in it are two effects that
the textbook linear oscillator cannot represent: dry (Coulomb) friction and a
hardening (cubic) spring. We start from the linear skeleton and let
:func:`~sklearn_pycc.diagnose` say, one effect at a time, what is missing:

    fit a skeleton → compare it with the measurements → see where it fails →
    learn which physical effect is missing → add it → watch the error fall.
"""

import matplotlib.pyplot as plt

from sklearn_pycc import PolyCCRegressor, compare_skeletons, datasets, diagnose
from sklearn_pycc.plotting import plot_comparison

# %%
# The measurements
# ----------------
# ``truth`` knows what is hidden; we use it only for the linear skeleton we
# start from and, at the end, to check the answer.
frame, truth = datasets.make_oscillator(
    hidden=["coulomb_friction", "cubic_stiffness"], noise=40.0,
    noise_columns=["x1", "x2", "x1_dot", "x2_dot"], random_state=0, return_truth=True)
X = frame[["t", "x1", "x2", "F_ext"]]
y = frame[["x1_dot", "x2_dot"]]
truth.base_equations

# %%
# Round 1: the linear oscillator
# ------------------------------
# The diagnosis compares the model with the measurements twice: on the
# derivatives, and on trajectories simulated from the measured start with the
# measured force.
model = PolyCCRegressor(equations=truth.base_equations).fit(X, y)
report = diagnose(model, X, y)
print(report.summary())

# %%
# Every effect of the catalogue that can enter the failing equation was fitted
# to the residual, the most promising refitted into the model, and ranked.
# ``score`` is minus the change of the Bayesian information criterion the
# refit brings (higher is better), but a plausible refit comes first whatever
# its score (``plausible``: the term plays its physical role), and
# ``stability`` is the share of resamples of the record in which the effect
# wins:
report.ranking[["effect", "variable", "score", "error_removed", "plausible",
                "stability", "suggested_term"]].head()


# %%
# The figures show where the model fails. First the states, measured and
# simulated: each window of the horizon restarts from the measured state, and
# the windows of largest error are shaded.
def one_figure(report, name):
    """The diagnosis's figure ``name`` alone (the others are closed)."""
    figures = report.plot()
    for other, fig in figures.items():
        if other != name:
            plt.close(fig)
    return figures[name]


fig = one_figure(report, "trajectories")

# %%
# The residual of the acceleration against the variable that explains it best,
# here the position ``x1``: the spring is not linear. In red, what the refit
# with the suggested cubic term predicts on top of the linear model.
fig = one_figure(report, "residual")

# %%
# The mean residual over position and velocity, on a colour scale centred on
# zero (white: no error; grey: fewer than 3 samples there).
fig = one_figure(report, "map")

# %%
# Round 2 and on: add what the diagnosis names
# --------------------------------------------
# ``report.best.equations`` is the skeleton with the suggested term added,
# ready to fit. We repeat until nothing beats the noise.
skeletons = {"linear": model.skeleton_}
while report.best is not None:
    best = report.best
    print(f"adding {best.effect}: {best.equation}")
    skeletons[f"+{best.effect}"] = best.equations
    model = PolyCCRegressor(equations=best.equations).fit(X, y)
    report = diagnose(model, X, y)
print(report.summary())

# %%
# Watch the error fall
# --------------------
# :func:`~sklearn_pycc.compare_skeletons` refits every skeleton and tabulates
# derivative and simulation errors, the BIC, and the errors on held-out data:
# each skeleton refitted without each fold of the record (here
# ``table.attrs["held_out"]``) and judged on it, on the whole record's scale.
table = compare_skeletons(skeletons, X, y, estimator=PolyCCRegressor())
print(table.attrs["held_out"])
table.drop(columns=["equations"])

# %%
fig = plot_comparison(table)
plt.show()

# %%
# The fitted model against the truth:
print("fitted:", model.equations()[1])
print("true:  ", truth.parametric_equations[1], truth.params)
