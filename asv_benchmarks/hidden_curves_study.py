"""How well the outflow curve of a tank nobody measures comes back, and how it simulates.

Run from the repository root::

    python asv_benchmarks/hidden_curves_study.py                 # 10 draws, 2 jobs
    python asv_benchmarks/hidden_curves_study.py --draws 20 --samples 2048

Each draw is ``datasets.make_two_tanks`` below its rims, the two tanks of one
cross-section (so the upper tank's outflow is the lower one's inflow), the
lower level logged at 40 dB. The skeleton ``x1_dot = a1 u - f1(x1)``,
``x2_dot = f1(x1) - f2(x2)`` with both curves increasing is fitted by
``PolyCCRegressor`` (its default degree, linear extrapolation). It prints, per
draw, the simulation error on a fresh record against the true skeleton's at
its true parameters, the largest relative error of ``f1`` against Torricelli's
law over the levels the upper tank runs at (after the shift of the level the
record cannot see, the gauge's), how far the law lies from the fitted curve
there in the curve's standard deviations (``curve_sd``; the 95 % band is 1.96
of them), and the seconds of the fit. It reports; it never fails.
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np
from joblib import Parallel, delayed
from scipy.optimize import minimize_scalar

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.estimators.base import set_fitted
from sklearn_pycc.model_selection import make_simulation_scorer

PARAMS = {"a1": 0.02, "a2": 0.04, "a3": 0.04, "a4": 0.045}
CURVES = ["x1_dot = a1 u - f1(x1)", "x2_dot = f1(x1) - f2(x2)"]
TRUE = ["x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a2 sqrt(x1) - a4 sqrt(x2)"]


def one_draw(seed: int, samples: int) -> dict:
    """Fit one draw: its fresh-record error against the truth's, the curve's error, seconds."""
    frame = datasets.make_two_tanks(n_samples=samples, rims=(100.0, 100.0), params=PARAMS,
                                    random_state=seed)
    fresh = datasets.make_two_tanks(n_samples=samples, rims=(100.0, 100.0), params=PARAMS,
                                    random_state=seed + 1000)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = PolyCCRegressor(equations=CURVES, constraints=["f1 increasing", "f2 increasing"],
                                extrapolation="linear").fit(frame)
        seconds = time.perf_counter() - start
        truth = set_fitted(PolyCCRegressor(equations=TRUE).fit(frame),
                           {"params_": {a: PARAMS[a] for a in ("a1", "a2", "a4")}})
        scorer = make_simulation_scorer()
        ratio = scorer.nrmse(model, fresh) / scorer.nrmse(truth, fresh)
    x1 = np.linspace(5.0, 12.0, 8)
    law = PARAMS["a2"] * np.sqrt(x1)

    def worst(shift: float) -> float:
        return float(np.max(np.abs(model.functions_["f1"](x1 + shift) / law - 1)))

    best = minimize_scalar(worst, bounds=(-40.0, 40.0), method="bounded")
    # the true law against the fitted curve's band, both at the shifted levels: the largest
    # distance in the curve's standard deviations (the 95 % band is 1.96 of them)
    shifted = x1 + best.x
    sd = model.backend_.curve_sd(model, "f1", shifted)
    distance = (np.nan if sd is None else
                float(np.max(np.abs(model.functions_["f1"](shifted) - law) / sd)))
    return {"ratio": ratio, "curve": best.fun, "shift": best.x, "seconds": seconds,
            "band": distance}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=10)
    parser.add_argument("--samples", type=int, default=1024)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    rows = Parallel(n_jobs=args.jobs)(delayed(one_draw)(seed, args.samples)
                                      for seed in range(args.draws))
    print(f"two tanks, the upper one's outflow a curve, {args.samples} samples")
    print(f"{'draw':>4} {'fresh / truth':>13} {'f1 error':>9} {'level shift':>12} "
          f"{'law in SDs':>10} {'s':>6}")
    for seed, r in enumerate(rows):
        print(f"{seed:>4} {r['ratio']:>13.2f} {r['curve']:>9.3f} {r['shift']:>12.2f} "
              f"{r['band']:>10.2f} {r['seconds']:>6.1f}")
    print(f"within 2x of the truth: {sum(r['ratio'] < 2 for r in rows)}/{len(rows)}; "
          f"f1 within 10 %: {sum(r['curve'] < 0.1 for r in rows)}/{len(rows)}; "
          f"the law within the 95 % band: {sum(r['band'] <= 1.96 for r in rows)}/{len(rows)}; "
          f"median fit {statistics.median(r['seconds'] for r in rows):.1f} s")


if __name__ == "__main__":
    main()
