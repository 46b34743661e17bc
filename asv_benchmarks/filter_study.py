"""The filter's fit of an oscillator pushed by a random force: coverage of its errors, and speed.

Each draw is a damped linear oscillator driven by a measured harmonic force
and pushed by an unmeasured random one (its simulation from the true initial
state wanders by 10-30 % of the spread), measured through its position with
1 % noise. The skeleton's parameters, the force's
intensity and the measurement noise are fitted by the extended Kalman
filter's likelihood (``fit_mode="filter"``), and by output error beside it;
the study prints how often every parameter lies within two of its standard
errors of the truth, by either, and the time of one filter fit of 10,000
samples::

    python asv_benchmarks/filter_study.py [--draws 20] [--samples 2000]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np
import pandas as pd

from sklearn_pycc import PolyCCRegressor

EQUATIONS = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
TRUTH = {"a1": 0.2, "a2": 1.0}
#: the random force's intensity: the simulation from the true start wanders by 17-30 %
FORCE, STEP = 0.08, 0.05


def pushed_oscillator(n: int, seed: int, noise: float = 0.01) -> tuple[pd.DataFrame, float]:
    """A forced oscillator also pushed by a random force; position with ``noise`` of its spread.

    Returns the record and how far the simulation from the true initial state
    wanders from the true position (RMS, share of its spread).
    """
    rng = np.random.default_rng(seed)
    A = np.array([[0.0, 1.0], [-TRUTH["a2"], -TRUTH["a1"]]])
    x, free, fine = np.array([1.0, 0.0]), np.array([1.0, 0.0]), 20
    out, calm = np.empty(n), np.empty(n)
    dt = STEP / fine
    for k in range(n):
        out[k], calm[k] = x[0], free[0]
        for j in range(fine):
            push = np.array([0.0, 0.5 * np.cos(1.3 * (k * fine + j) * dt)])
            x = x + (A @ x + push) * dt + np.array([0.0, FORCE * np.sqrt(dt)
                                                    * rng.standard_normal()])
            free = free + (A @ free + push) * dt
    t = np.arange(n) * STEP
    X = pd.DataFrame({"t": t, "x1": out + noise * np.std(out) * rng.standard_normal(n),
                      "F_ext": 0.5 * np.cos(1.3 * t)})
    return X, float(np.sqrt(np.mean((out - calm) ** 2)) / np.std(out))


def fit(X: pd.DataFrame, mode: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Parameters, their standard errors and the fit's seconds, by ``fit_mode=mode``."""
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=EQUATIONS, fit_mode=mode).fit(X)
    seconds = time.perf_counter() - start
    theta = np.array([model.params_[a] for a in TRUTH])
    errors = np.array([model.params_std_[a] for a in TRUTH])
    return theta, errors, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=20)
    parser.add_argument("--samples", type=int, default=2000)
    args = parser.parse_args()
    truth = np.array(list(TRUTH.values()))
    inside, seconds, off = {"filter": [], "simulation": []}, [], {"filter": [], "simulation": []}
    print(f"{'draw':>4} {'filter a1':>16} {'filter a2':>16}  {'output error a1':>16} "
          f"{'output error a2':>16}")
    wanders = []
    for seed in range(args.draws):
        X, wander = pushed_oscillator(args.samples, seed)
        wanders.append(wander)
        row = []
        for mode in ("filter", "simulation"):
            theta, errors, s = fit(X, mode)
            inside[mode].append(np.abs(theta - truth) <= 2 * errors)
            off[mode].append(np.abs(theta - truth))
            if mode == "filter":
                seconds.append(s)
            row += [f"{v:7.3f} +- {e:5.3f}" for v, e in zip(theta, errors)]
        print(f"{seed:>4} " + " ".join(row))
    for mode, label in (("filter", "filter"), ("simulation", "output error")):
        hits = np.array(inside[mode])
        error = np.median(np.array(off[mode]), axis=0)
        told = ("no standard errors (n_bootstrap would give them)"
                if mode == "simulation" else
                f"within 2 standard errors a1 {hits[:, 0].mean():.0%}, a2 "
                f"{hits[:, 1].mean():.0%} ({hits.mean():.0%} of {hits.size})")
        print(f"{label:>12}: {told}; median error a1 {error[0]:.3f}, a2 {error[1]:.3f}")
    print(f"the simulation from the true start wandered by {min(wanders):.0%}-{max(wanders):.0%}"
          f" of the spread; median filter fit {statistics.median(seconds):.2f} s "
          f"({args.samples} samples)")
    _, _, s = fit(pushed_oscillator(10_000, 99)[0], "filter")
    print(f"10,000 samples: one filter fit {s:.2f} s")


if __name__ == "__main__":
    main()
