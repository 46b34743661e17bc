"""
Two masses and a nonlinear coupling
===================================

Two forced masses, each on its own spring and damper, joined by a coupling
spring. Only the first mass is driven:

.. math::

    \\dot x_1 = x_3, \\quad \\dot x_2 = x_4, \\quad
    \\dot x_3 = F_{ext} - f_1(x_3) - f_2(x_1) - f_3(x_1 - x_2), \\quad
    \\dot x_4 = -f_4(x_4) - f_5(x_2) + f_3(x_1 - x_2).

The same coupling curve :math:`f_3` acts on both masses, with opposite signs
(action and reaction), and the skeleton says so by using it in two equations.
The coupling spring hardens (:math:`0.5 u + 0.3 u^3` for a stretch :math:`u`);
the other springs and dampers are linear.
"""

import matplotlib.pyplot as plt
import numpy as np

from sklearn_pycc import PolyCCRegressor, datasets, diagnose

frame, truth = datasets.make_two_dof(noise=40, noise_columns=["x1", "x2", "x3", "x4"],
                                     random_state=0, return_truth=True)
states = ["x1", "x2", "x3", "x4"]
X = frame[["t", *states, "F_ext"]]
y = frame[[f"{name}_dot" for name in states]]

# %%
# Start from the linear model
# ---------------------------
# Both masses with linear springs and dampers and a linear coupling.
for line in truth.base_equations:
    print(line)
linear = PolyCCRegressor(equations=truth.base_equations).fit(X, y)
report = diagnose(linear, X, y)
print(report.summary())

# %%
# The diagnosis points at the coupling: the residual of both accelerations
# follows the stretch ``x1 - x2``.
figures = report.plot()

# %%
# Its suggestion, fitted:
print(report.best.effect, "->", report.best.equations.equations[2:])
coupled = PolyCCRegressor(equations=report.best.equations).fit(X, y)
for line in coupled.equations()[2:]:
    print(line)

# %%
# Every curve free
# ----------------
# With all five curves unknown the skeleton is not identifiable as written:
# in ``F_ext - f1(x3) - f2(x1) - f3(x1 - x2)`` a constant can move between the
# curves without changing the model. The estimator pins such constants and
# records what it pinned and why in ``gauge_``.
functional = PolyCCRegressor(equations=truth.equations, degree=5).fit(X, y)
functional.gauge_

# %%
curves = functional.cc_curves(n=200)
fig, axes = plt.subplots(1, 5, figsize=(13, 3), sharey=False)
arguments = {"f1": "x3", "f2": "x1", "f3": "x1 - x2", "f4": "x4", "f5": "x2"}
for ax, (name, argument) in zip(axes, arguments.items()):
    x = curves[name]["x"].to_numpy()
    ax.plot(x, truth.functions[name](x), "k", lw=3, alpha=0.3, label="true")
    ax.plot(x, curves[name][name], "C0", label="learned")
    ax.set_title(f"{name}({argument})")
axes[0].legend(fontsize="small")
fig.tight_layout()

# %%
# Simulating both models
# ----------------------
# From the true initial state with the true force; the extended skeleton
# follows the second mass, which the linear one cannot.
fig, ax = plt.subplots(figsize=(9, 3))
ax.plot(frame["t"], frame["x2"], "k", lw=3, alpha=0.3, label="measured x2")
for model, label, color in [(linear, "linear", "C1"), (coupled, "+ cubic coupling", "C0")]:
    sim = model.simulate(frame["t"], y0=truth.y0, inputs=truth.inputs)
    rmse = np.sqrt(np.mean((sim["x2"] - frame["x2"]) ** 2))
    ax.plot(sim["t"], sim["x2"], color=color, label=f"{label} (RMSE {rmse:.2g})")
ax.set_xlabel("t")
ax.legend(loc="upper right", fontsize="small")
fig.tight_layout()
plt.show()
