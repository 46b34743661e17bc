"""
Three rooms in a row: the heat path a building's skeleton leaves out
====================================================================

Three rooms stand in a row, each with its heater ``Qi`` and losing heat to
the outdoors ``To``; their temperatures are logged every five minutes (time
in hours). The skeleton joins each room to its neighbours, the way the plan
shows them: 1 to 2, 2 to 3. But a door between rooms 1 and 3 stands open,
and heat flows through it too.

The diagnosis tries a path between every two temperatures, those the
skeleton joins and those it does not: a flow that leaves one room and enters
the other, each with a coefficient of its own (the rooms' heat capacities
differ). It names the missing one in a building's words and draws the
network with the suggested path.
"""

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from sklearn_pycc import PolyCCRegressor, Skeleton, diagnose
from sklearn_pycc.model_selection import make_simulation_scorer

TRUE = ["T1_dot = a1 (To - T1) + a2 Q1 + a3 (T2 - T1) + a7 (T3 - T1)",
        "T2_dot = a4 (To - T2) + a5 Q2 + a3 (T1 - T2) + a3 (T3 - T2)",
        "T3_dot = a6 (To - T3) + a5 Q3 + a3 (T2 - T3) + a7 (T1 - T3)"]
PARAMS = {"a1": 0.3, "a2": 0.8, "a3": 0.4, "a4": 0.25, "a5": 0.7, "a6": 0.35, "a7": 0.5}
ROOMS = {"T1": "temperature", "T2": "temperature", "T3": "temperature"}


def record(seed, n=1500):
    """Five days every five minutes: heaters switched by the hour, a daily swing outdoors."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 12.0
    heaters = {f"Q{i}": np.repeat(rng.choice([0.0, 1.5, 3.0], n // 24 + 1), 24)[:n]
               for i in (1, 2, 3)}
    inputs = {"To": 5 + 5 * np.sin(2 * np.pi * t / 24 + rng.uniform(0, 2 * np.pi)), **heaters}
    states = Skeleton(TRUE).simulate(t, [18.0, 17.0, 16.0], params=PARAMS, inputs=inputs,
                                     input_hold="zoh")
    frame = pd.DataFrame({"t": t, **inputs})
    for room in ROOMS:  # 40 dB of sensor noise
        clean = states[room].to_numpy()
        frame[room] = clean + 0.01 * clean.std() * rng.standard_normal(n)
    return frame


X, fresh = record(0), record(1)

# %%
# The skeleton as the plan shows it, and its diagnosis
# ----------------------------------------------------
plan = ["T1_dot = a1 (To - T1) + a2 Q1 + a3 (T2 - T1)",
        "T2_dot = a4 (To - T2) + a5 Q2 + a6 (T1 - T2) + a7 (T3 - T2)",
        "T3_dot = a8 (To - T3) + a9 Q3 + a10 (T2 - T3)"]
model = PolyCCRegressor(equations=plan, quantities=ROOMS).fit(X)
report = diagnose(model, X)
print(next(part for part in report.summary().split("\n\n")
           if part.startswith("Missing effect")))

# %%
# The network: the rooms the plan joins, and the path the record asks for.
figures = report.plot()
for name, figure in figures.items():
    if name != "network":  # the trajectories and residuals: see the other examples
        plt.close(figure)
plt.show()

# %%
# The skeleton with the path, fitted, simulates a record it has not seen
# (other heater settings, another day) as well as the true one.
extended = PolyCCRegressor(equations=report.best.equations, quantities=ROOMS).fit(X)
true = PolyCCRegressor(equations=TRUE, quantities=ROOMS).fit(X)
scorer = make_simulation_scorer()
for name, m in (("the plan", model), ("with the path", extended), ("true", true)):
    print(f"{name:>14}: NRMSE on a fresh record {scorer.nrmse(m, fresh):.4f}")
