"""
A long lab record: the whole loop on a positioning axis
=======================================================

A linear axis (a 2 kg carriage) moves under a sampled position controller
for 25 s. The lab logs what such a rig logs, at 1 kHz: the encoder position
``x1`` (in metres, in steps of 20 µm) and the motor force ``F`` (in newtons).
No velocity, no acceleration: 25,000 rows of two columns.

The starting hypothesis is Newton's law with viscous friction,
``x2_dot = a1 F - a2 x2`` (``a1`` the inverse mass). The carriage also has
Coulomb friction and a constant force offset (a cable, gravity on a tilted
axis); the loop is to find them from the record alone.
"""

import matplotlib.pyplot as plt

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets
from sklearn_pycc.plotting import plot_loop

frame, truth = datasets.make_positioning_axis(random_state=0, return_truth=True)
X = frame[["t", "x1", "F"]]
print(f"{len(X)} samples at {1 / (X.t[1] - X.t[0]):.0f} Hz; columns {list(X.columns)}")

fig, axes = plt.subplots(2, 1, figsize=(9, 4), sharex=True)
axes[0].plot(X.t, 1e3 * X.x1, lw=0.8)
axes[0].set_ylabel("x1 (mm)")
axes[1].plot(X.t, X.F, lw=0.5, color="C1")
axes[1].set_ylabel("F (N)")
axes[1].set_xlabel("t (s)")
fig.tight_layout()

# %%
# The loop
# --------
# Units go with the record: the loop's tables and figures read them.
start = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = a1 F - a2 x2"])
loop = HypothesisLoop(start, X, units={"x1": "m", "F": "N"}).run(max_rounds=4)
print(loop.summary())

# %%
# Round by round: what each model adds, what its diagnosis suggests, and the
# error of the simulated position over the same windows every round.
loop.table()[["n_parameters", "x1_rmse", "adds", "suggests", "held_out_change"]]

# %%
fig = plot_loop(loop)

# %%
# The answer
# ----------
# The final model, and the truth it was generated from: ``a1 = 1 / mass`` and
# every force divided by the mass.
print("\n".join(loop.model.equations()))
print("true: " + truth.equations[1] + " with "
      + ", ".join(f"{a} = {v:g}" for a, v in truth.params.items()))
print("      mass {mass} kg, viscous {viscous} N s/m, Coulomb {coulomb} N, "
      "offset {offset} N".format(**truth.physical))

# %%
# The first round's diagnosis drew where the viscous model fails: the
# residual of the acceleration against velocity is a step at zero velocity
# (Coulomb friction) sitting on a constant (the offset).
fig = loop.rounds[0].diagnosis.plot()
plt.show()
