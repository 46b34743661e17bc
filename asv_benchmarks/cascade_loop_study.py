"""How often the loop names Torricelli's law in a tank nobody measures, and how well it ends.

Run from the repository root::

    python asv_benchmarks/cascade_loop_study.py                 # 20 draws, 2 jobs
    python asv_benchmarks/cascade_loop_study.py --draws 5 --samples 2048

Each draw is ``datasets.make_two_tanks`` below its rims (1,024 samples every
4 s, the lower level at 40 dB, the upper level unmeasured). The loop starts
from linear outflows with every rate positive, the states read as levels.
It prints, per draw, the first effect the loop names and in which equation,
the effects it added, the final model's simulation error on a fresh record
over that of the true (Torricelli) skeleton fitted to the same record, and
the seconds of the loop. The summary gives the share of draws whose first
named effect is the square-root outflow of the upper tank (``x1_dot``),
the share whose final model is within 2x of the truth, both together, and
the median seconds. It reports; it never fails.
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

from joblib import Parallel, delayed

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets
from sklearn_pycc.model_selection import make_simulation_scorer

LINEAR = ["x1_dot = a1 u - a2 x1", "x2_dot = a3 x1 - a4 x2"]
POSITIVE = ["a1 >= 0", "a2 >= 0", "a3 >= 0", "a4 >= 0"]
TORRICELLI = ["x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a3 sqrt(x1) - a4 sqrt(x2)"]


def one_draw(seed: int, samples: int) -> dict:
    """One loop: what it named first and where, its effects, fresh error ratio, seconds."""
    frame = datasets.make_two_tanks(n_samples=samples, rims=(100.0, 100.0), random_state=seed)
    fresh = datasets.make_two_tanks(n_samples=samples, rims=(100.0, 100.0),
                                    random_state=seed + 1000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.perf_counter()
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR, constraints=POSITIVE), frame,
                              quantities={"x1": "level", "x2": "level"}).run()
        seconds = time.perf_counter() - start
        true = PolyCCRegressor(equations=TORRICELLI, constraints=POSITIVE).fit(frame)
        scorer = make_simulation_scorer()
        try:
            ratio = scorer.nrmse(loop.model, fresh) / scorer.nrmse(true, fresh)
        except Exception as exc:  # a study reports what failed, and goes on
            ratio, failure = float("inf"), f"{type(exc).__name__}: {exc}"[:80]
        else:
            failure = ""
    first = loop.rounds[0].diagnosis.best
    added = [r.diagnosis.best.effect for r in loop.rounds if r.diagnosis.best is not None]
    return {"first": None if first is None else first.effect,
            "where": None if first is None else first.equation,
            "added": added, "ratio": ratio, "seconds": seconds, "failure": failure}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=20)
    parser.add_argument("--samples", type=int, default=1024)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    print(f"two tanks, the upper level unmeasured, the loop from linear outflows, "
          f"{args.samples} samples", flush=True)
    print(f"{'draw':>4} {'first named':>22} {'in':>7} {'fresh / truth':>13} {'s':>6}  added")
    rows = Parallel(n_jobs=args.jobs)(delayed(one_draw)(seed, args.samples)
                                      for seed in range(args.draws))
    for seed, r in enumerate(rows):
        print(f"{seed:>4} {r['first']!s:>22} {r['where']!s:>7} {r['ratio']:>13.2f} "
              f"{r['seconds']:>6.0f}  {', '.join(r['added'])} {r['failure']}")
    right = [r["first"] == "square_root_outflow" and r["where"] == "x1_dot" for r in rows]
    close = [r["ratio"] < 2 for r in rows]
    print(f"Torricelli named first in the upper tank: {sum(right)}/{len(rows)}; "
          f"fresh within 2x of the truth: {sum(close)}/{len(rows)}; both: "
          f"{sum(a and b for a, b in zip(right, close))}/{len(rows)}; median loop "
          f"{statistics.median(r['seconds'] for r in rows):.0f} s")


if __name__ == "__main__":
    main()
