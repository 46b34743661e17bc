"""
Noisy positions only: output-error fitting
==========================================

Real measurements are rarely the clean states and derivatives a model needs.
Here only the position ``x1`` of a forced, chaotic Duffing oscillator is
measured, with 20 dB of Gaussian noise (the noise has a tenth of the signal's
amplitude). Its velocity ``x2`` is not measured at all.

sklearn-pycc takes ``X`` with ``t`` and the measured columns, and no ``y``
(with several experiments, a ``trajectory`` column keeps them apart):

1. the derivatives are estimated (``differentiation="auto"``: a zero-phase
   low-pass at a cutoff read from the record's spectrum, then a band-limited
   differentiator), and ``x2`` is reconstructed as the derivative of ``x1``
   from the kinematic equation ``x1_dot = x2``;
2. ``fit_mode="equation"`` fits the skeleton to those estimates (equation
   error); ``fit_mode="simulation"`` goes on to refine it so that simulated
   positions match the measured ones (output error, by multiple shooting over
   short windows, so that a chaotic system can be fitted at all). The default,
   ``fit_mode="auto"``, refines on its own when the positions are as noisy as
   these (``fit_mode_`` says which mode was used).
"""

import matplotlib.pyplot as plt
import numpy as np

from sklearn_pycc import PolyCCRegressor, datasets

frame, truth = datasets.make_duffing(noise=20, noise_columns=["x1"], random_state=0,
                                     return_truth=True)
clean = datasets.make_duffing()
X = frame[["t", "x1", "F_ext"]]
X.head()

# %%
fig, ax = plt.subplots(figsize=(9, 3))
ax.plot(frame["t"], frame["x1"], ".", ms=2, color="0.5", label="measured x1 (20 dB)")
ax.plot(clean["t"], clean["x1"], "k", lw=1, label="true x1")
ax.set_xlim(0, 40)
ax.set_xlabel("t")
ax.legend(loc="upper right")
fig.tight_layout()

# %%
# Equation error, then output error
# ---------------------------------
# Both curves are odd polynomials of degree 5; ``truth`` holds the true
# damping ``0.3 x2`` and spring ``-1.05 x1 + 1.02 x1^3``.
skeleton = dict(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                constraints=["f1 odd", "f2 odd"], degree=5)
equation_error = PolyCCRegressor(**skeleton, fit_mode="equation").fit(X)
output_error = PolyCCRegressor(**skeleton, fit_mode="simulation").fit(X)
LABELS = {"equation": "equation error", "simulation": "output error"}
for model in (equation_error, output_error):
    print(f"{LABELS[model.fit_mode_]:>14}: {model.equations()[2]};  {model.equations()[3]}")

# %%
# The curves of both fits against the truth, over the range of the data:
fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
for ax, name, argument in [(axes[0], "f1", "x2"), (axes[1], "f2", "x1")]:
    x = np.linspace(clean[argument].min(), clean[argument].max(), 300)
    true = truth.functions[name](x)
    ax.plot(x, true, "k", lw=3, alpha=0.3, label="true")
    for model, color in [(equation_error, "C1"), (output_error, "C0")]:
        rmse = np.sqrt(np.mean((model.functions_[name](x) - true) ** 2))
        ax.plot(x, model.functions_[name](x), color=color,
                label=f"{LABELS[model.fit_mode_]} (RMSE {rmse:.1e})")
    ax.set_title(f"{name}({argument})")
    ax.legend(fontsize="small")
fig.tight_layout()

# %%
# On an experiment never seen
# ---------------------------
# The forced system is chaotic, so any model parts from a long measured
# trajectory sooner or later. A fairer test of what was learned is a
# different experiment: released from ``x1 = 1.4`` without forcing, the
# oscillator rings down into one of its two wells, at a rate set by the
# damping curve.
release = datasets.make_duffing(n_samples=600, t_span=(0, 30), amplitude=0.0, y0=(1.4, 0.0))
fig, ax = plt.subplots(figsize=(9, 3))
ax.plot(release["t"], release["x1"], "k", lw=3, alpha=0.3, label="true x1")
for model, color in [(equation_error, "C1"), (output_error, "C0")]:
    sim = model.simulate(release["t"], y0=[1.4, 0.0], inputs={"F_ext": np.zeros_like})
    rmse = np.sqrt(np.mean((sim["x1"].to_numpy() - release["x1"].to_numpy()) ** 2))
    ax.plot(sim["t"], sim["x1"], color=color, label=f"{LABELS[model.fit_mode_]} (RMSE {rmse:.1e})")
ax.set_xlabel("t")
ax.legend(loc="upper right", fontsize="small")
fig.tight_layout()
plt.show()
