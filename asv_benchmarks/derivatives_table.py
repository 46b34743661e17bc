"""Derivative accuracy of ``differentiation="auto"`` against each fixed method, by regime.

Run from the repository root::

    python asv_benchmarks/derivatives_table.py

Five records of the kind laboratories hand over, each with its exact
velocity and acceleration known. For every method the table gives the
relative RMS error of the estimated velocity and acceleration (``v``, ``a``)
over the record, without its first and last 2 %, and the time it took.
"n/a" marks a method that refuses the record (Savitzky-Golay needs evenly
spaced samples). It reports; it never fails.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from sklearn_pycc import datasets
from sklearn_pycc.measurements import resolve_differentiation

# trend filtering is left out: at its default setting it takes minutes on these records
METHODS = ["auto", "spline", "savgol", "finite_difference", "kalman"]


def _resonator(**options):
    frame, truth = datasets.make_resonator(n_samples=5000, random_state=0, return_truth=True,
                                           **options)
    x1, x2 = truth.states["x1"].to_numpy(), truth.states["x2"].to_numpy()
    p, u = truth.params, frame["u"].to_numpy()
    acceleration = p["a1"] * u - p["a2"] * x2 - p["a3"] * x1 - p["a4"] * x1**3
    return frame["t"].to_numpy(), frame["x1"].to_numpy(), x2, acceleration


def _axis():
    frame, truth = datasets.make_positioning_axis(n_samples=5000, t_span=(0, 4.999),
                                                  random_state=0, return_truth=True)
    return frame["t"].to_numpy(), frame["x1"].to_numpy(), truth.velocity, truth.acceleration


def _camera():
    # a pendulum-like oscillator filmed at 6 frames per second, 2 % of the frames lost
    frame = datasets.make_duffing(n_samples=600, t_span=(0, 99.9), noise=45,
                                  noise_columns=["x1"], random_state=0)
    keep = np.sort(np.random.default_rng(0).choice(np.arange(1, 599), 586, replace=False))
    frame = frame.iloc[np.r_[0, keep, 599]]
    return (frame["t"].to_numpy(), frame["x1"].to_numpy(), frame["x2"].to_numpy(),
            frame["x2_dot"].to_numpy())


def _drift():
    frame = datasets.make_stick_slip(n_samples=2000, t_span=(0, 40), noise=40,
                                     noise_columns=["x1"], random_state=0)
    t = frame["t"].to_numpy()
    drift, rate = 0.02 * t + 0.3 * np.sin(0.05 * t), 0.02 + 0.015 * np.cos(0.05 * t)
    curvature = -0.00075 * np.sin(0.05 * t)
    return (t, frame["x1"].to_numpy() + drift, frame["x2"].to_numpy() + rate,
            frame["x2_dot"].to_numpy() + curvature)


REGIMES = {
    "clean, 10 samples/period": lambda: _resonator(noise=None),
    "encoder 1 kHz, closed loop": _axis,
    "camera 6 Hz, 2 % dropped": _camera,
    "30 dB white noise": lambda: _resonator(noise=30),
    "slow drift, 40 dB": _drift,
}


def _error(estimate, truth):
    k = max(1, len(truth) // 50)
    inner = slice(k, -k)
    return float(np.sqrt(np.mean((estimate[inner] - truth[inner]) ** 2)
                         / np.mean(truth[inner] ** 2)))


def main() -> None:
    warnings.simplefilter("ignore")
    print(f"{'regime':<28}" + "".join(f"{m:>24}" for m in METHODS))
    print(f"{'':<28}" + "".join(f"{'v / a / ms':>24}" for _ in METHODS))
    for name, make in REGIMES.items():
        t, x, velocity, acceleration = make()
        cells = []
        for method in METHODS:
            steps = np.diff(t)
            differentiator = resolve_differentiation(method)
            if differentiator.uniform_only and np.ptp(steps) > 1e-3 * np.median(steps):
                cells.append("n/a")
                continue
            try:
                start = time.perf_counter()
                chosen = differentiator.for_experiment(t, {"x": x}, 2)
                _, v, a = chosen.derivatives(t, x, 2)
                ms = 1e3 * (time.perf_counter() - start)
                cells.append(f"{_error(v, velocity):.3f} / {_error(a, acceleration):.3f}"
                             f" / {ms:.0f}")
            except Exception:  # a method refusing the record is a finding
                cells.append("n/a")
        print(f"{name:<28}" + "".join(f"{c:>24}" for c in cells))


if __name__ == "__main__":
    main()
