"""A control the loop must leave alone: a linear oscillator's free decay filmed by a camera.

Each draw is a mass on a linear spring with viscous damping, released from
rest and filmed at 30 frames per second for 30 s: period 1.5-3 s, damping
ratio 0.002-0.02, release 60-120 px. The tracked position carries what a
camera gives: white noise of 0.3 px, a tracking jitter correlated over a few
frames (AR(1), pole 0.6-0.9, 0.3 px) and rounding to a whole pixel. Only
``t`` and ``x1`` (in pixels) are recorded, and there is no input. The loop
starts from the true (linear) skeleton with default settings; anything it
names is a false alarm::

    python asv_benchmarks/camera_control.py [--draws 10] [--seconds 30]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np
import pandas as pd
from scipy import signal

from sklearn_pycc import HypothesisLoop, PolyCCRegressor

LINEAR = ["x1_dot = x2", "x2_dot = -a1 x2 - a2 x1"]
FPS = 30.0


def camera_record(seed: int, *, seconds: float = 30.0) -> tuple[pd.DataFrame, dict]:
    """One filmed free decay: the frame (``t``, ``x1`` in px) and its true parameters."""
    rng = np.random.default_rng(seed)
    period, zeta = rng.uniform(1.5, 3.0), rng.uniform(0.002, 0.02)
    release = rng.uniform(60.0, 120.0)
    omega = 2 * np.pi / period
    damped = omega * np.sqrt(1 - zeta**2)
    t = np.arange(1, int(seconds * FPS) + 1) / FPS
    # x(0) = release, x'(0) = 0
    x = release * np.exp(-zeta * omega * t) * (
        np.cos(damped * t) + zeta * omega / damped * np.sin(damped * t))
    pole = rng.uniform(0.6, 0.9)
    jitter = signal.lfilter([np.sqrt(1 - pole**2)], [1.0, -pole], rng.normal(0.0, 0.3, t.size))
    tracked = np.round(x + rng.normal(0.0, 0.3, t.size) + jitter)
    truth = {"a1": 2 * zeta * omega, "a2": omega**2, "period": period, "zeta": zeta,
             "pole": pole}
    return pd.DataFrame({"t": t, "x1": tracked}), truth


def run_draw(seed: int, *, seconds: float) -> dict:
    frame, truth = camera_record(seed, seconds=seconds)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR), frame).run(max_rounds=3)
    named = [r.added.effect for r in loop.rounds if r.added is not None]
    return {"seed": seed, "named": named, "seconds": time.perf_counter() - start, **truth}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--draws", type=int, default=10)
    parser.add_argument("--seconds", type=float, default=30.0)
    args = parser.parse_args()
    print(f"{'seed':>4} {'period':>6} {'zeta':>6} {'pole':>5} {'s':>6}  named")
    rows = []
    for seed in range(args.draws):
        row = run_draw(seed, seconds=args.seconds)
        rows.append(row)
        print(f"{seed:>4} {row['period']:>6.2f} {row['zeta']:>6.3f} {row['pole']:>5.2f} "
              f"{row['seconds']:>6.1f}  {', '.join(row['named']) or '-'}", flush=True)
    alarms = sum(bool(r["named"]) for r in rows)
    print(f"nothing named in {len(rows) - alarms} of {len(rows)} draws; "
          f"median loop time {statistics.median(r['seconds'] for r in rows):.1f} s")


if __name__ == "__main__":
    main()
