"""Accuracy by noise level of equation-error and output-error fits on positions only.

Prints, for the Duffing and stick-slip oscillators measured through ``x1``
alone (Gaussian noise on ``x1`` at the given SNR, derivatives and velocity
estimated by the default smoothing spline), the curve RMSE of each fit mode
(polynomial backend on both systems, neural backend on stick-slip)
and the median time ratio of output-error to equation-error fitting, both
measured side by side in this run::

    python asv_benchmarks/measurements_table.py [--repeats 3] [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sklearn_pycc import NeuralCCRegressor, PolyCCRegressor, datasets

SKELETON = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
#: label -> (estimator, data generator, hyperparameters)
SYSTEMS = {
    "duffing": (PolyCCRegressor, datasets.make_duffing,
                {"constraints": ["f1 odd"], "degree": 7}),
    "stick_slip": (PolyCCRegressor, datasets.make_stick_slip,
                   {"constraints": ["f1 odd"], "degree": 9}),
    "ss_neural": (NeuralCCRegressor, datasets.make_stick_slip,
                  {"constraints": ["f1 odd"], "random_state": 0}),
}


def curve_rmse(model, truth, name: str) -> float:
    frame = model.cc_curves()[name]
    return float(np.sqrt(np.mean((frame[name] - truth.functions[name](frame["x"])) ** 2)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--systems", nargs="+", default=list(SYSTEMS), choices=list(SYSTEMS))
    args = parser.parse_args()
    print(f"{'system':<11} {'SNR':>5} {'mode':<10} {'f1 RMSE':>9} {'f2 RMSE':>9} "
          f"{'fit s':>7}")
    ratios: dict[str, list[float]] = {}
    for system in args.systems:
        estimator, make, settings = SYSTEMS[system]
        for snr in (None, 40, 30, 20):
            rows = {"equation": [], "simulation": []}
            for seed in args.seeds:
                frame, truth = make(noise=snr, noise_columns=["x1"], random_state=seed,
                                    return_truth=True)
                X = frame[["t", "x1", "F_ext"]]
                times = {}
                for mode in rows:
                    spent = []
                    for _ in range(args.repeats if seed == args.seeds[0] else 1):
                        start = time.perf_counter()
                        model = estimator(equations=SKELETON, fit_mode=mode,
                                          **settings).fit(X)
                        spent.append(time.perf_counter() - start)
                    times[mode] = float(np.median(spent))
                    rows[mode].append((curve_rmse(model, truth, "f1"),
                                       curve_rmse(model, truth, "f2"), times[mode]))
                ratios.setdefault(system, []).append(times["simulation"] / times["equation"])
            label = "clean" if snr is None else f"{snr}dB"
            for mode, values in rows.items():
                f1, f2, spent = np.median(np.array(values), axis=0)
                print(f"{system:<11} {label:>5} {mode:<10} {f1:9.4f} {f2:9.4f} {spent:7.2f}")
    print("\noutput-error / equation-error fit time, median ratio (range, pairs):")
    for system, values in ratios.items():
        print(f"  {system:<11} {np.median(values):.2f} ({min(values):.2f}-{max(values):.2f}, "
              f"{len(values)})")


if __name__ == "__main__":
    main()
