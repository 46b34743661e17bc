"""
The stick-slip oscillator of the seed paper
===========================================

The illustrative example of the paper that introduced characteristic-curve
models: a forced oscillator with Coulomb-like friction and a hardening spring,

.. math::

    \\dot x_1 = x_2, \\qquad
    \\dot x_2 = F_{ext} - f_1(x_2) - f_2(x_1),

with :math:`f_1(v) = 0.1 v + 0.5 \\tanh(500 v)` (viscous plus dry friction)
and :math:`f_2(x) = x + 0.2 x^3`. Nothing is assumed about the two curves but
their symmetry: both are odd. Each is a small neural network, trained through
skorch on the equation residuals.
"""

import matplotlib.pyplot as plt
import numpy as np

from sklearn_pycc import NeuralCCRegressor, datasets

# %%
# The data
# --------
# 1000 samples over 20 s of the states, the measured force and the
# derivatives. ``truth`` holds the true curves, for checking.
frame, truth = datasets.make_stick_slip(return_truth=True)
X = frame[["t", "x1", "x2", "F_ext"]]
y = frame[["x1_dot", "x2_dot"]]

# %%
# The functional skeleton
# -----------------------
# ``max_epochs`` bounds the L-BFGS epochs; early stopping ends training when
# the loss stops falling.
max_epochs = 100
# sphinx_gallery_start_ignore
import os  # noqa: E402

if os.environ.get("SKLEARN_PYCC_SMALL_EXAMPLES"):
    max_epochs = 10
# sphinx_gallery_end_ignore
model = NeuralCCRegressor(
    equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
    constraints=["f1 odd", "f2 odd"],
    max_epochs=max_epochs,
    random_state=0,
).fit(X, y)
print(f"R2 of the derivatives: {model.score(X, y):.5f}")
model.gauge_

# %%
# The learned curves against the true ones
# ----------------------------------------
# ``cc_curves`` evaluates every curve over the range of its argument in the
# data (the paper's ``evals``).
curves = model.cc_curves(n=300)
fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
for ax, (name, label) in zip(axes, [("f1", "friction f1(x2)"), ("f2", "spring f2(x1)")]):
    x = curves[name]["x"].to_numpy()
    ax.plot(x, truth.functions[name](x), "k", lw=3, alpha=0.3, label="true")
    ax.plot(x, curves[name][name], "C1", label="learned")
    error = np.sqrt(np.mean((curves[name][name] - truth.functions[name](x)) ** 2))
    ax.set_title(f"{label}: RMSE {error:.2g}")
    ax.legend()
fig.tight_layout()

# %%
# Simulating the learned model
# ----------------------------
# The model is simulated from the true initial state with the true force.
# After ``fit`` the networks are plain numpy: the right-hand side is compiled
# once, and ``simulate`` never calls torch.
sim = model.simulate(frame["t"], y0=truth.y0, inputs=truth.inputs)
fig, ax = plt.subplots(figsize=(9, 3))
ax.plot(frame["t"], frame["x1"], "k", lw=3, alpha=0.3, label="measured x1")
ax.plot(sim["t"], sim["x1"], "C1", label="simulated x1")
ax.set_xlabel("t")
ax.legend(loc="upper right")
fig.tight_layout()
print(f"max |x1 error| of the simulation: {np.max(np.abs(sim['x1'] - frame['x1'])):.2g}")
plt.show()

# %%
# The fitted model written out
# ----------------------------
# A neural curve has no formula; :func:`~sklearn_pycc.to_symbolic` finds one
# (see :ref:`sphx_glr_auto_examples_plot_symbolic_post_processing.py`).
model.equations()
