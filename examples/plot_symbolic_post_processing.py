"""
From learned curves to formulas (post-SR)
=========================================

A neural characteristic curve follows any shape, but it is not a formula you
can write in a paper. :func:`~sklearn_pycc.to_symbolic` turns the curves of any
fitted model into analytic expressions by one-dimensional symbolic regression
(pyoperon, offline), under the same constraints. Given the measurements, it
lets them choose among the candidates and refines every number of the
expressions together with the skeleton's parameters.

The data are the seed paper's noise study: the stick-slip oscillator with
20 dB of Gaussian noise on the measured force.
"""

import matplotlib.pyplot as plt
import numpy as np

from sklearn_pycc import NeuralCCRegressor, datasets, to_symbolic

frame, truth = datasets.make_stick_slip(noise=20, noise_columns=["F_ext"], random_state=0,
                                        return_truth=True)
X = frame[["t", "x1", "x2", "F_ext"]]
y = frame[["x1_dot", "x2_dot"]]

# %%
# The neural fit
# --------------
generations = 50
# sphinx_gallery_start_ignore
import os  # noqa: E402

if os.environ.get("SKLEARN_PYCC_SMALL_EXAMPLES"):
    generations = 10
# sphinx_gallery_end_ignore
neural = NeuralCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                           constraints=["f1 odd", "f2 odd"], random_state=0).fit(X, y)

# %%
# Post-SR with the measurements
# -----------------------------
# Every candidate of the search is refined on the equation residuals and
# chosen by them; the result is a fitted
# :class:`~sklearn_pycc.SymbolicCCRegressor`.
symbolic = to_symbolic(neural, X, y, generations=generations, random_state=0)
symbolic.conversion_

# %%
# The fitted model, written out:
for line in symbolic.equations():
    print(line)

# %%
# ``pareto_`` keeps the candidates of each search: complexity against the
# loss on the data, with the chosen one marked.
fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
for ax, name in zip(axes, ["f1", "f2"]):
    front = symbolic.pareto_[name]
    ax.semilogy(front["complexity"], front["loss"], "o-", color="C0")
    chosen = front[front["chosen"]]
    ax.semilogy(chosen["complexity"], chosen["loss"], "o", ms=12, mfc="none", color="C3",
                label="chosen")
    ax.set_xlabel("complexity")
    ax.set_title(f"candidates for {name}")
    ax.legend()
axes[0].set_ylabel("loss on the data")
fig.tight_layout()

# %%
# Neural and symbolic curves against the truth
# --------------------------------------------
fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
for ax, name in zip(axes, ["f1", "f2"]):
    column = frame["x2" if name == "f1" else "x1"]
    x = np.linspace(column.min(), column.max(), 300)
    true = truth.functions[name](x)
    ax.plot(x, true, "k", lw=3, alpha=0.3, label="true")
    for model, label, color in [(neural, "neural", "C1"), (symbolic, "symbolic", "C0")]:
        values = model.functions_[name](x)
        rmse = np.sqrt(np.mean((values - true) ** 2))
        ax.plot(x, values, color=color, label=f"{label} (RMSE {rmse:.1e})")
    ax.set_title(name)
    ax.legend(fontsize="small")
fig.tight_layout()
plt.show()

# %%
# The friction curve comes out in the form the physics has, viscous plus
# smoothed dry friction. With the default operators (``+ - *``, ``tanh``,
# ``sin``, ``cos``) the spring is written ``a x - b sin(c x)``: its Taylor
# series is ``(a - b c) x + b c^3 x^3 / 6``, the true ``x + 0.2 x^3`` to two
# digits. Adding ``"^"`` to ``binary_operators`` lets the search write powers.
