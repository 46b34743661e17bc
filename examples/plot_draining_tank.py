"""
A draining tank: the missing effect in a process engineer's words
=================================================================

A tank fed by a pump drains through an orifice at its bottom. Its level
``x1`` is logged every half second while the pump's flow ``u`` steps between
settings. A process engineer's first model is a linear outflow,
``x1_dot = a1 u - a2 x1``; the water leaves by Torricelli's law instead, at a
rate growing with the square root of the level.

The estimator is told what the state measures
(``quantities={"x1": "level"}``; a unit of length on a first-order state,
``units={"x1": "m"}``, says the same). It then tries the laws of a stored
quantity's own rate of loss, never friction or springs, and names what it
finds as the field does: Torricelli outflow.
"""

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, Skeleton
from sklearn_pycc.plotting import plot_loop

# %%
# The record: ten minutes of level, 1 % noise
# -------------------------------------------
rng = np.random.default_rng(0)
t = np.arange(0.0, 600.0, 0.5)
pump = np.repeat(rng.uniform(0.2, 1.0, size=len(t) // 80 + 1), 80)[:len(t)]
truth = Skeleton(["x1_dot = a1 u - a2 sqrt(x1)"])
level = truth.simulate(t, [1.0], params={"a1": 0.5, "a2": 0.4}, inputs={"u": pump})["x1"]
X = pd.DataFrame({"t": t, "x1": level + 0.01 * level.std() * rng.standard_normal(len(t)),
                  "u": pump})

# %%
# The loop, from the linear outflow
# ---------------------------------
model = PolyCCRegressor(equations=["x1_dot = a1 u - a2 x1"], quantities={"x1": "level"})
loop = HypothesisLoop(model, X, units={"x1": "m", "u": "m3/s"}).run()
for r in loop.rounds:
    print(f"round {r.index}: {r.decision}")
print(loop.model.equations())

# %%
# What the first round saw, in words and in the residual: the outflow the
# linear model misses grows like the square root of the level.
report = loop.rounds[0].diagnosis
print(next(part for part in report.summary().split("\n\n")
           if part.startswith("Missing effect")))
report.plot()["residual"]
plt.show()

# %%
# The error falls, round by round.
plot_loop(loop)
plt.show()
