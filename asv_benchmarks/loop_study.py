"""The hypothesis loop over generated hidden-effect cases: right, complete, false alarms.

Each case hides effects in a forced oscillator measured through its position
alone (``t, x1, F_ext``, Gaussian noise on ``x1``); the loop starts from the
linear skeleton with default settings. Per case and noise level it reports

right
    the first effect the loop names is a hidden one (for the pendulum
    without a linear spring, by replacing that spring);
complete
    the loop's final model simulates a fresh record (another release and
    forcing frequency) within twice the error of the true skeleton fitted
    the same way on the same data;
false alarm
    on a control (nothing hidden), the loop names anything.

Sensor noise as real records carry it: ``--poles`` makes the noise coloured
(AR(1), one study per pole), ``--bits`` rounds the position to a converter's
resolution and ``--drift`` adds a slow wander (a share of the RMS); the
fresh record stays noise-free. Not timed for speed claims (the median loop
time is printed beside, and each coloured record's against the same record under
white noise, run just before it)::

    python asv_benchmarks/loop_study.py [--seeds 0 1] [--snr 40 30] [--cases pendulum ...]
    python asv_benchmarks/loop_study.py --poles 0.8 0.9 0.95 --bits 12 [--drift 0.02]

Process noise: ``--pushes`` pushes every record, the fresh one too, by an
unmeasured random force (``make_oscillator(disturbance=...)``; by default
the intensities 0.02 and 0.05, whose simulation from the true start wanders
by about 10 and 25 % of the spread). Complete is then judged by the filter:
the loop's final skeleton and the true one are each fitted with
``fit_mode="filter"`` on the record, and the fresh record's log-likelihood
per sample must be within :data:`LIKELIHOOD_TOLERANCE` of the true
skeleton's (the ratio column prints the difference)::

    python asv_benchmarks/loop_study.py --pushes --jobs 2

``--acceptance`` runs every noise set of the coloured-noise study (white;
AR(1) poles 0.8, 0.9 and 0.95 rounded to 12 bits; pole 0.9 with a drift of
2 % of the RMS) and prints the figures of each set and of the coloured
sets together; ``--jobs`` runs that many loops at once::

    python asv_benchmarks/loop_study.py --acceptance --jobs 2
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import clone

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, SimulationError, datasets

BASE = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
#: under process noise, complete: the fresh record's log-likelihood per sample within this
#: of the true skeleton's (both fitted by the filter)
LIKELIHOOD_TOLERANCE = 0.01
#: case -> (hidden effects with their strengths, true skeleton when not make_oscillator's)
CASES: dict[str, tuple[dict, list[str] | None]] = {
    "coulomb_friction": ({"coulomb_friction": None}, None),
    "stribeck_friction": ({"stribeck_friction": {"a1": 0.2, "a2": 0.3, "a3": 0.3, "a4": 20.0}},
                          None),
    "quadratic_drag": ({"quadratic_drag": None}, None),
    "cubic_stiffness": ({"cubic_stiffness": None}, None),
    "saturation": ({"saturation": None}, None),
    "dead_zone": ({"dead_zone": {"a1": 2.0, "a2": 0.8}}, None),
    "pendulum": ({"pendulum": None}, None),
    "position_dependent_damping": ({"position_dependent_damping": None}, None),
    "offset": ({"offset": None}, None),
    "asymmetric_viscous_damping": ({"asymmetric_viscous_damping": None}, None),
    "asymmetric_stiffness": ({"asymmetric_stiffness": None}, None),
    "falling_damping": ({"falling_damping": None}, None),
    # a pendulum with no linear spring: named by replacing the skeleton's spring
    "pendulum_replace": ({"pendulum": {"a1": 2.0}}, ["x1_dot = x2",
                                                      "x2_dot = F_ext - a1 x2 - a3 sin(x1)"]),
    "coulomb+cubic": ({"coulomb_friction": None, "cubic_stiffness": None}, None),
    "quadratic_drag+offset": ({"quadratic_drag": None, "offset": None}, None),
    "cubic+quadratic_drag": ({"cubic_stiffness": None, "quadratic_drag": None}, None),
    "control_linear": ({}, None),
    "control_cubic": ({"cubic_stiffness": None}, "truth"),
}


def _record(hidden: dict, *, snr, seed: int, fresh: bool, no_spring: bool, sensor=None,
            push=None):
    options = dict(stiffness=0.0 if no_spring else 1.0, n_samples=3000, t_span=(0.0, 60.0),
                   disturbance=push)
    if fresh:
        options.update(y0=(2.0, 0.0), omega=1.3, amplitude=0.5)
    seed = seed + (1000 if fresh else 0)
    if sensor is not None:  # coloured, rounded or drifting noise; the fresh record is clean
        frame, truth = datasets.make_oscillator(hidden=dict(hidden), random_state=seed,
                                                return_truth=True, **options)
        if not fresh:
            frame = datasets.add_sensor_noise(frame, ["x1"], snr=snr, random_state=seed,
                                              **sensor)
        return frame, truth
    frame, truth = datasets.make_oscillator(
        hidden={k: v for k, v in hidden.items()}, noise=snr, noise_columns=["x1"],
        random_state=seed, return_truth=True, **options)
    return frame, truth


def _simulation_error(model, frame, truth) -> float:
    t = frame["t"].to_numpy()
    try:
        simulated = model.simulate(t, list(truth.y0), inputs={"F_ext": frame["F_ext"].to_numpy()})
    except (SimulationError, ValueError):
        return float("inf")
    error = simulated["x1"].to_numpy() - frame["x1"].to_numpy()
    return float(np.sqrt(np.mean(error**2))) if np.isfinite(error).all() else float("inf")


def _filtered_likelihood(model, X, fresh) -> float:
    """``model``'s skeleton fitted by the filter on ``X``: the fresh record's log-likelihood.

    Per sample; a model already fitted by the filter is scored as it is.
    """
    try:
        if getattr(model, "fit_mode_", None) != "filter":
            model = clone(model).set_params(fit_mode="filter").fit(X)
        return model.log_likelihood(fresh) / len(fresh)
    except (SimulationError, ValueError):
        return float("-inf")


def run_case(name: str, snr, seed: int, sensor: dict | None = None,
             push: float | None = None, at_stake_too: bool = False) -> dict:
    hidden, true_equations = CASES[name]
    control = name.startswith("control")
    no_spring = name == "pendulum_replace"
    frame, truth = _record(hidden, snr=snr, seed=seed, fresh=False, no_spring=no_spring,
                           sensor=sensor, push=push)
    fresh, fresh_truth = _record(hidden, snr=snr, seed=seed, fresh=True, no_spring=no_spring,
                                 sensor=sensor, push=push)
    X = frame[["t", "x1", "F_ext"]]
    start_equations = BASE
    if true_equations == "truth":
        start_equations, true_equations = truth.parametric_equations, None
    if true_equations is None:
        true_equations = truth.parametric_equations
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=start_equations), X).run(max_rounds=5)
        elapsed = time.perf_counter() - start
        reference = PolyCCRegressor(equations=true_equations).fit(X)
    named = [r.added.effect for r in loop.rounds if r.added is not None]
    at_stake = float("nan")  # under process noise: what the start skeleton loses per sample
    if push is None:
        ours = _simulation_error(loop.model, fresh, fresh_truth)
        best = _simulation_error(reference, fresh, fresh_truth)
        complete, ratio = ours <= 2 * best, ours / best if best > 0 else float("inf")
    else:  # judged on a fresh pushed record by each skeleton's filter fit on this one
        fresh = fresh[["t", "x1", "F_ext"]].copy()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            best = _filtered_likelihood(reference, X, fresh)
            ours = _filtered_likelihood(loop.model, X, fresh)
            if at_stake_too:
                at_stake = best - _filtered_likelihood(
                    PolyCCRegressor(equations=start_equations), X, fresh)
        ratio = best - ours  # log-likelihood per sample the true skeleton gains over ours
        complete = ratio <= LIKELIHOOD_TOLERANCE
    return {
        "case": name, "snr": snr, "seed": seed, "named": named, "control": control,
        "right": (not named) if control else bool(named) and named[0] in hidden,
        "complete": bool(complete), "ratio": ratio, "at_stake": at_stake, "seconds": elapsed,
    }


#: the noise sets of the coloured-noise acceptance study: label -> sensor (None: white)
ACCEPTANCE = {
    "white": None,
    **{f"AR(1) {pole:g}, 12 bits": {"pole": pole, "bits": 12, "drift": 0.0}
       for pole in (0.8, 0.9, 0.95)},
    "AR(1) 0.9, 12 bits, drift 0.02": {"pole": 0.9, "bits": 12, "drift": 0.02},
}


#: the process-noise study's intensities of the random force (the simulation from the true
#: start wanders by about 10 and 25 % of the spread)
PUSHES = (0.02, 0.05)


def _sets(args) -> dict[str, tuple[dict | None, float | None]]:
    """Noise set label -> (sensor noise, or None for white; random force, or None)."""
    if args.acceptance:
        return {label: (sensor, None) for label, sensor in ACCEPTANCE.items()}
    if args.pushes is not None:
        return {f"random force {push:g}": (None, push) for push in args.pushes or PUSHES}
    if args.poles is None and args.bits is None and not args.drift:
        return {"white": (None, None)}
    return {f"pole {pole:g}": ({"pole": pole, "bits": args.bits, "drift": args.drift}, None)
            for pole in (args.poles or [0.0])}


def _figures(rows: list[dict]) -> str:
    cases = [r for r in rows if not r["control"]]
    controls = [r for r in rows if r["control"]]
    words = []
    if cases:
        right, complete = (sum(r[k] for r in cases) for k in ("right", "complete"))
        words.append(f"right {right}/{len(cases)} ({100 * right / len(cases):.0f} %), "
                     f"complete {complete}/{len(cases)} ({100 * complete / len(cases):.0f} %)")
    if controls:
        words.append(f"false alarms {sum(not r['right'] for r in controls)}/{len(controls)}")
    return "; ".join(words)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--snr", type=float, nargs="+", default=[40.0, 30.0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--poles", type=float, nargs="+", default=None,
                        help="AR(1) poles of coloured noise (one study each)")
    parser.add_argument("--bits", type=int, default=None, help="round to this resolution")
    parser.add_argument("--drift", type=float, default=0.0, help="slow wander, share of RMS")
    parser.add_argument("--acceptance", action="store_true",
                        help="every noise set of the coloured-noise study, white included")
    parser.add_argument("--pushes", type=float, nargs="*", default=None,
                        help="process noise: intensities of an unmeasured random force "
                             f"(none given: {' '.join(map(str, PUSHES))})")
    parser.add_argument("--jobs", type=int, default=1, help="runs in parallel (processes)")
    args = parser.parse_args()
    sets = _sets(args)
    # one record's noise sets run one after the other, so that its loop times under
    # white and coloured noise are measured on the machine in the same state
    runs = [(label, name, snr, seed) for name in args.cases for snr in args.snr
            for seed in args.seeds for label in sets]
    print(f"{'case':<28} {'noise':<31} {'SNR':>4} {'seed':>4} {'right':>5} {'complete':>8} "
          f"{'ratio':>7} {'s':>6}  named")
    rows = Parallel(n_jobs=args.jobs, return_as="generator")(
        delayed(run_case)(name, snr, seed, *sets[label]) for label, name, snr, seed in runs)
    by_set: dict[str, list[dict]] = {label: [] for label in sets}
    for (label, name, snr, seed), row in zip(runs, rows):
        by_set[label].append(row)
        print(f"{name:<28} {label:<31} {snr:>4.0f} {seed:>4} {row['right']!s:>5} "
              f"{row['complete']!s:>8} {row['ratio']:>7.2f} "
              f"{row['seconds']:>6.1f}  {', '.join(row['named']) or '-'}"
              + (f"  (at stake {row['at_stake']:.4f})" if np.isfinite(row["at_stake"]) else ""),
              flush=True)
    print()
    for label, members in by_set.items():
        print(f"{label:<31} {_figures(members)}")
    coloured = [r for label, members in by_set.items() if sets[label][0] is not None
                for r in members]
    if coloured and len(by_set) > 2:
        print(f"{'all coloured sets':<31} {_figures(coloured)}")
    every = [r for members in by_set.values() for r in members]
    print(f"median loop time {statistics.median(r['seconds'] for r in every):.1f} s")
    if "white" in by_set and coloured:
        # each coloured record's loop against the same case, SNR and seed under white noise
        white = {(r["case"], r["snr"], r["seed"]): r["seconds"] for r in by_set["white"]}
        ratios = [r["seconds"] / white[key] for r in coloured
                  if (key := (r["case"], r["snr"], r["seed"])) in white and white[key] > 0]
        if ratios:
            within = sum(ratio <= 2.0 for ratio in ratios)
            print(f"loop time against the same record under white noise: median "
                  f"{statistics.median(ratios):.2f}x, within 2x in {within} of {len(ratios)}")


if __name__ == "__main__":
    main()
