"""
A heater that acts late: a transport delay found and fitted
===========================================================

A stirred tank is heated by hot water that runs down a pipe: a change of the
heater's power ``u`` reaches the tank three seconds later. The tank's
temperature ``x1`` is logged every half second by a thermocouple whose noise
is correlated in time. The first model a process engineer writes has no
delay, ``x1_dot = a1 u - a2 x1``.

The loop tries a delay on every term that reads an input: ``a1 u`` becomes
``a3 u(t - a4)``, the delay ``a4`` fitted like any other number. On a
temperature it is named as the field names it, a transport delay. A skeleton
may say so from the start: ``x1_dot = a1 u(t - a5) - a2 x1``.
"""

import matplotlib.pyplot as plt

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets
from sklearn_pycc.plotting import plot_loop

# %%
# The record: 2,000 samples, coloured and rounded sensor noise
# ------------------------------------------------------------
X, truth = datasets.make_heated_tank(noise=None, random_state=0, return_truth=True)
X = datasets.add_sensor_noise(X, ["x1"], snr=40, pole=0.9, bits=12, random_state=0)
print(truth.equations, truth.params)

# %%
# The loop, from the model without a delay
# ----------------------------------------
model = PolyCCRegressor(equations=["x1_dot = a1 u - a2 x1"],
                        quantities={"x1": "temperature"})
loop = HypothesisLoop(model, X).run()
for r in loop.rounds:
    print(f"round {r.index}: {r.decision}")
print(loop.model.equations_text(precision=3))
print(f"fitted delay {next(iter(loop.model.delays_.values())):.2f} s, "
      f"true {truth.delay:.2f} s, one sample {X.t[1] - X.t[0]:.2f} s")

# %%
# Where the first model fails: simulated from the measured temperature over its
# worst windows, it answers each step of the heater too early.
report = loop.rounds[0].diagnosis
report.plot()["trajectories"]
plt.show()

# %%
# The error falls, round by round.
plot_loop(loop)
plt.show()
