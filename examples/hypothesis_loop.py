"""The hypothesis loop: find the physics a linear model is missing.

An oscillator is measured with 1 % noise on its positions, velocities and
accelerations. Hidden in it are two effects a linear model cannot
represent: dry (Coulomb) friction and a hardening (cubic) spring. We do not
tell the product; we start from the textbook linear oscillator and let the
diagnosis tell us, one effect at a time, what is missing:

    fit a skeleton -> compare it with the measurements -> see where it fails
    -> learn which physical effect is missing -> add it -> watch the error fall

Run it with ``make demo`` (figures go to ``demo-output/``, with the whole loop
in one self-contained HTML report, ``hypothesis_loop.html``) or
``python examples/hypothesis_loop.py [output folder]``.
"""

import sys
import time
from pathlib import Path

import matplotlib.pyplot as plt

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, compare_skeletons, datasets
from sklearn_pycc.plotting import plot_comparison

output = Path(sys.argv[1] if len(sys.argv) > 1 else "demo-output")
output.mkdir(parents=True, exist_ok=True)
start = time.perf_counter()


def save(figures, prefix):
    for name, fig in figures.items():
        path = output / f"{prefix}_{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        print(f"    saved {path}")


# -- the measurements ----------------------------------------------------------------
# A released, weakly forced oscillator. ``truth`` knows what is hidden; we only
# use it to start from the linear skeleton and, at the very end, to check.
frame, truth = datasets.make_oscillator(
    hidden=["coulomb_friction", "cubic_stiffness"], n_samples=2000,
    noise=40.0, noise_columns=["x1", "x2", "x1_dot", "x2_dot"], random_state=0,
    return_truth=True)
X = frame[["t", "x1", "x2", "F_ext"]]
y = frame[["x1_dot", "x2_dot"]]
print(f"Measurements: {len(frame)} samples of t, x1 (position), x2 (velocity), F_ext "
      "(force) and their derivatives, 1 % noise.\n")

# -- the loop: fit, diagnose, add what is missing, again ----------------------------------------
# HypothesisLoop keeps every round: the skeleton, the fitted model, its diagnosis
# and the decision taken. It stops when the diagnosis finds nothing missing.
loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), X, y)
while not loop.stopped and len(loop.rounds) < 4:
    current = loop.step()
    print("=" * 78)
    print(f"Round {current.index}: {'; '.join(current.skeleton.equations)}")
    print(current.diagnosis.summary())
    save(current.diagnosis.plot(), f"round{current.index}")
skeletons = {"linear": loop.rounds[0].skeleton}
skeletons.update({f"+{r.added.effect}": r.added.equations for r in loop.rounds if r.added})
model = loop.model

# -- watch the error fall ---------------------------------------------------------------------
print("\n" + "=" * 78)
table = compare_skeletons(skeletons, X, y, estimator=PolyCCRegressor())
print("The error falling, skeleton by skeleton. In sample: RMSE of the derivatives and of "
      f"the simulation ({table.attrs['horizon']}); held out ({table.attrs['held_out']}): "
      "NRMSE of each fold's derivatives and simulation, refitted without it, on the whole "
      "record's scale.")
with_text = table.drop(columns=["equations"])
print(with_text.to_string(float_format=lambda v: f"{v:.4g}"))
fig = plot_comparison(table)
fig.savefig(output / "error_falling.png", dpi=110)
plt.close(fig)
print(f"    saved {output / 'error_falling.png'}")

report = output / "hypothesis_loop.html"
loop.to_html(report, title="The hypothesis loop on an oscillator with hidden effects")
print(f"    saved {report} (the whole loop; opens offline)")

first, last = table.simulation_rmse.iloc[0], table.simulation_rmse.iloc[-1]
print(f"\nSimulation RMSE: {first:.4g} -> {last:.4g} ({first / last:.0f} times lower).")
print(f"Hidden effects: {', '.join(truth.hidden)}; found: "
      f"{', '.join(name.lstrip('+') for name in list(skeletons)[1:])}.")
print(f"Fitted: {model.equations()[1]}")
print(f"True:   {truth.parametric_equations[1]} with "
      + ", ".join(f"{a}={v:g}" for a, v in truth.params.items()))
print(f"Walkthrough done in {time.perf_counter() - start:.1f} s.")
