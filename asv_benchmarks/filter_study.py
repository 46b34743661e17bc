"""The filter's fit of an oscillator pushed by a random force: coverage of its errors, and speed.

Each draw is a damped linear oscillator pushed by white noise (its simulation
from the true initial state wanders by 10-30 % of the spread), measured
through its position with 1 % noise. The skeleton's parameters, the force's
intensity and the measurement noise are fitted by the extended Kalman
filter's likelihood (:func:`sklearn_pycc.fitting.filter.fit_filter`), started
away from the truth; the study prints how often every parameter lies within
two of its standard errors of the truth, and the time of one fit of 10,000
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
from sklearn_pycc.fitting.filter import fit_filter
from sklearn_pycc.fitting.output_error.shooting import ShootingPlan

EQUATIONS = ["x1_dot = x2", "x2_dot = -a1 x2 - a2 x1"]
TRUTH = {"a1": 0.2, "a2": 1.0}
FORCE, STEP = 0.3, 0.05
WINDOW = 200


def pushed_oscillator(n: int, seed: int, noise: float = 0.01) -> pd.DataFrame:
    """Position of the oscillator under a white random force, ``noise`` of its spread added."""
    rng = np.random.default_rng(seed)
    A = np.array([[0.0, 1.0], [-TRUTH["a2"], -TRUTH["a1"]]])
    x, out, fine = np.array([1.0, 0.0]), np.empty(n), 20
    dt = STEP / fine
    for k in range(n):
        out[k] = x[0]
        for _ in range(fine):
            x = x + A @ x * dt + np.array([0.0, FORCE * np.sqrt(dt) * rng.standard_normal()])
    return pd.DataFrame({"t": np.arange(n) * STEP,
                         "x1": out + noise * np.std(out) * rng.standard_normal(n)})


def fit(X: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, float]:
    """Parameters, their standard errors and the fit's seconds."""
    estimator = PolyCCRegressor(equations=EQUATIONS, fit_mode="simulation")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem, _ = estimator._problem(X, None, estimator._make_backend())
    start = time.perf_counter()
    plan = ShootingPlan(problem, WINDOW)
    plan.choose_substeps(problem.skeleton.compile({}, TRUTH), dict(problem.data.columns))

    def system_for(theta):
        return problem.skeleton.compile({}, {"a1": theta[0], "a2": theta[1]})

    theta, _, _, info = fit_filter(plan, system_for, np.array([0.5, 0.8]),
                                   np.array([0.0, 0.05]), np.array([0.1]), noisy=[1])
    errors = np.sqrt(np.diag(info["covariance"])) if info["covariance"] is not None \
        else np.full(2, np.nan)
    return theta, errors, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=20)
    parser.add_argument("--samples", type=int, default=2000)
    args = parser.parse_args()
    truth = np.array(list(TRUTH.values()))
    inside, seconds = [], []
    print(f"{'draw':>4} {'a1':>16} {'a2':>16}  within 2 SE")
    for seed in range(args.draws):
        theta, errors, s = fit(pushed_oscillator(args.samples, seed))
        ok = np.abs(theta - truth) <= 2 * errors
        inside.append(ok)
        seconds.append(s)
        print(f"{seed:>4} {theta[0]:7.3f} +- {errors[0]:5.3f} {theta[1]:7.3f} +- {errors[1]:5.3f}"
              f"  {ok.tolist()}")
    inside = np.array(inside)
    median = statistics.median(seconds)
    print(f"within 2 standard errors: a1 {inside[:, 0].mean():.0%}, a2 {inside[:, 1].mean():.0%},"
          f" all {inside.mean():.0%} of {inside.size}; median fit {median:.2f} s"
          f" ({args.samples} samples)")
    theta, errors, s = fit(pushed_oscillator(10_000, 99))
    print(f"10,000 samples: one fit {s:.2f} s")


if __name__ == "__main__":
    main()
