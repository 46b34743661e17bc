"""How often the true skeleton of rooms with unmeasured walls gives its parameters back.

Run from the repository root::

    python asv_benchmarks/rooms_study.py                 # 20 draws a case, 2 jobs
    python asv_benchmarks/rooms_study.py --draws 5 --samples 3000 --rooms 2

Each case is ``datasets.make_rooms`` (one or two rooms, five-minute samples,
the walls unmeasured) with 40 dB of white noise or AR(1) noise of pole 0.9
on the room temperatures, written in hours or in seconds; the true skeleton
is fitted by ``PolyCCRegressor`` with its defaults. It prints, per case, the
share of draws whose every parameter is within 10 % of the truth, the worst
parameter's median error, the warnings seen and the median seconds a fit.
It reports; it never fails.
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

from joblib import Parallel, delayed

from sklearn_pycc import PolyCCRegressor, datasets

CASES = [(rooms, pole, unit) for rooms in (1, 2) for pole in (0.0, 0.9) for unit in ("h", "s")]


def one_fit(n_rooms: int, pole: float, unit: str, seed: int, samples: int) -> dict:
    """Fit one draw; the worst relative parameter error, the seconds and the warnings."""
    frame, truth = datasets.make_rooms(samples, n_rooms=n_rooms, time_unit=unit,
                                       noise=None if pole else 40.0, random_state=seed,
                                       return_truth=True)
    if pole:
        rooms = [f"T{i}" for i in range(1, n_rooms + 1)]
        frame = datasets.add_sensor_noise(frame, rooms, snr=40.0, pole=pole,
                                          random_state=1000 + seed)
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = PolyCCRegressor(equations=truth.equations).fit(frame)
    seconds = time.perf_counter() - start
    errors = {a: abs(model.params_[a] / v - 1) for a, v in truth.params.items()}
    worst = max(errors, key=errors.get)
    return {"worst": errors[worst], "name": worst, "seconds": seconds,
            "warnings": sorted({type(w.message).__name__ for w in caught})}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=20)
    parser.add_argument("--samples", type=int, default=1500)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--rooms", type=int, nargs="+", default=[1, 2],
                        help="the cases of these numbers of rooms only")
    args = parser.parse_args()
    print(f"rooms with unmeasured walls, {args.samples} samples, {args.draws} draws a case")
    print(f"{'rooms':>5} {'noise':>10} {'unit':>4} {'within 10 %':>12} {'median worst':>13} "
          f"{'median s':>9}  warnings", flush=True)
    for case in [c for c in CASES if c[0] in args.rooms]:  # each line once its draws are fitted
        rows = Parallel(n_jobs=args.jobs)(delayed(one_fit)(*case, seed, args.samples)
                                          for seed in range(args.draws))
        within = sum(r["worst"] <= 0.10 for r in rows)
        seen = sorted({w for r in rows for w in r["warnings"]})
        noise = "white" if case[1] == 0 else f"AR {case[1]:g}"
        print(f"{case[0]:>5} {noise:>10} {case[2]:>4} {within:>8}/{len(rows):<3} "
              f"{statistics.median(r['worst'] for r in rows):>13.3f} "
              f"{statistics.median(r['seconds'] for r in rows):>9.1f}  {', '.join(seen)}",
              flush=True)
        for seed, r in enumerate(rows):
            if r["worst"] > 0.10:
                print(f"      draw {seed}: {r['name']} off by {r['worst']:.0%} "
                      f"({r['seconds']:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
