"""The hypothesis loop on networks: the missing effect between two states, or in several.

Each case is a generated network of a field, the loop started from the
skeleton a scientist of that field writes first, told what each state
measures (``quantities``), with default settings otherwise:

rooms_door
    three rooms in a row (time in hours), the heat path between the first
    and the last (a door) missing;
tanks_orifice
    two tanks joined at the bottom by an orifice, the skeleton's path
    linear;
reaction_a_b_c
    ``A + B -> C`` in a stirred tank fed with A and B, missing from the
    three balances;
chain_saturating
    five compartments in a chain, the third passing its content on at a
    rate that saturates (Michaelis-Menten), written linear;
circuit_diode
    two RC nodes joined by a resistor, a diode from the second node to
    ground missing;
circuit_diode_link
    the same nodes, a diode beside the resistor between them missing;
room_heat_load
    one room with unmeasured walls (time in seconds), a constant internal
    heat load missing;

and the controls ``rooms_control``, ``chain_control`` and ``room_control``
(the correct skeletons). The inputs are stepped, and the records simulated
with them band-limited (as the estimator reads them by default). Noise is
40 dB on every measured state, white or AR(1) of pole 0.9 rounded to 12
bits (``--noise``). Per run it reports

right
    the first effect the loop names is the hidden one, between the right
    states (a path either way round) or in exactly the equations it acts in
    (a flow from the third compartment into the fourth: in both, and in no
    other), in the field's words;
complete
    the loop's final model simulates a fresh noiseless record (other
    inputs) within twice the error of the true skeleton fitted on the same
    record;
false alarm
    on a control, the loop names anything;

and the loop's seconds. It reports; it never fails. Two loops run at a time
(``--jobs``)::

    python asv_benchmarks/network_study.py [--seeds 0 1] [--noise white ar] [--cases ...]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, Skeleton, datasets
from sklearn_pycc.model_selection import make_simulation_scorer

#: AR(1) sensor noise as the study's "ar": pole 0.9, 12 bits
SENSOR = {"pole": 0.9, "bits": 12}


@dataclass(frozen=True)
class Case:
    """One generated network; the truth, the skeleton the loop starts from, the answer."""

    truth: tuple[str, ...]
    params: dict
    start: tuple[str, ...]
    quantity: str
    y0: tuple[float, ...]
    inputs: dict  # name -> (low, high, samples held)
    effect: str | None  # catalogue name of the missing effect (None: a control)
    where: frozenset = field(default_factory=frozenset)  # the states it joins or acts in
    called: str | None = None
    dt: float = 0.5
    n_samples: int = 600
    hidden: tuple[str, ...] = ()  # states no sensor reads
    outdoor: str | None = None  # an input swinging daily (hours of dt)


_ROOMS_TRUE = ("T1_dot = a1 (To - T1) + a2 Q1 + a3 (T2 - T1) + a7 (T3 - T1)",
               "T2_dot = a4 (To - T2) + a5 Q2 + a3 (T1 - T2) + a3 (T3 - T2)",
               "T3_dot = a6 (To - T3) + a5 Q3 + a3 (T2 - T3) + a7 (T1 - T3)")
_ROOMS_START = ("T1_dot = a1 (To - T1) + a2 Q1 + a3 (T2 - T1)",
                "T2_dot = a4 (To - T2) + a5 Q2 + a6 (T1 - T2) + a7 (T3 - T2)",
                "T3_dot = a8 (To - T3) + a9 Q3 + a10 (T2 - T3)")
_ROOMS = dict(params={"a1": 0.3, "a2": 0.8, "a3": 0.4, "a4": 0.25, "a5": 0.7, "a6": 0.35,
                      "a7": 0.5},
              quantity="temperature", y0=(18.0, 17.0, 16.0),
              inputs={"Q1": (0, 3, 24), "Q2": (0, 3, 30), "Q3": (0, 3, 36)}, outdoor="To",
              dt=1 / 12, n_samples=1500)
_CHAIN_TRUE = ("x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 x2",
               "x3_dot = a3 x2 - a4 x3/(a5 + x3)", "x4_dot = a4 x3/(a5 + x3) - a6 x4",
               "x5_dot = a6 x4 - a7 x5")
_CHAIN_START = ("x1_dot = a1 u - a2 x1", "x2_dot = a3 x1 - a4 x2", "x3_dot = a5 x2 - a6 x3",
                "x4_dot = a7 x3 - a8 x4", "x5_dot = a9 x4 - a10 x5")
_CHAIN = dict(params={"a1": 1.0, "a2": 0.5, "a3": 0.4, "a4": 2.0, "a5": 1.0, "a6": 0.3,
                      "a7": 0.2},
              quantity="concentration", y0=(0.5,) * 5, inputs={"u": (0.1, 1.4, 40)})
_ROOM = ("T1_dot = a1 (W1 - T1) + a2 (To - T1) + a3 Q1",
         "W1_dot = a4 (T1 - W1) + a5 (To - W1)")
_ROOM_LOADED = (_ROOM[0] + " + a6", _ROOM[1])
#: one room and its walls (unmeasured), rates per hour written per second
_WALLS = dict(params={"a1": 1.2 / 3600, "a2": 0.3 / 3600, "a3": 0.8 / 3600, "a4": 0.1 / 3600,
                      "a5": 0.02 / 3600, "a6": 1.5 / 3600},
              quantity="temperature", y0=(18.0, 12.0), inputs={"Q1": (0, 3, 24)}, dt=300.0,
              n_samples=1500, hidden=("W1",), outdoor="To")

CASES = {
    "rooms_door": Case(_ROOMS_TRUE, start=_ROOMS_START, effect="linear_link",
                       where=frozenset({"T1", "T3"}), called="heat path (conduction)", **_ROOMS),
    "rooms_control": Case(_ROOMS_TRUE, start=_ROOMS_TRUE, effect=None, **_ROOMS),
    "tanks_orifice": Case(
        ("h1_dot = a1 u - a2 sign(h1 - h2) sqrt(abs(h1 - h2))",
         "h2_dot = a2 sign(h1 - h2) sqrt(abs(h1 - h2)) - a3 h2"),
        {"a1": 0.5, "a2": 0.4, "a3": 0.15},
        ("h1_dot = a1 u - a2 (h1 - h2)", "h2_dot = a3 (h1 - h2) - a4 h2"), "level",
        (1.0, 0.5), {"u": (0.1, 1.0, 60)}, "orifice_link", frozenset({"h1", "h2"}),
        "orifice between tanks (Torricelli)"),
    "reaction_a_b_c": Case(
        ("A_dot = a1 uA - a2 A - a3 A B", "B_dot = a1 uB - a2 B - a3 A B",
         "C_dot = a3 A B - a2 C"),
        {"a1": 0.5, "a2": 0.1, "a3": 0.05},
        ("A_dot = a1 uA - a2 A", "B_dot = a3 uB - a4 B", "C_dot = - a5 C"), "concentration",
        (1.0, 1.0, 0.5), {"uA": (0.5, 3.0, 40), "uB": (0.5, 3.0, 50)}, "mass_action",
        frozenset({"A", "B", "C"}), "mass-action reaction (A + B)", n_samples=800),
    "chain_saturating": Case(_CHAIN_TRUE, start=_CHAIN_START, effect="saturating_rate",
                             where=frozenset({"x3", "x4"}),
                             called="Michaelis-Menten saturation", **_CHAIN),
    "chain_control": Case(_CHAIN_TRUE, start=_CHAIN_TRUE, effect=None, **_CHAIN),
    "circuit_diode": Case(
        ("v1_dot = a1 (u - v1) - a2 (v1 - v2)",
         "v2_dot = a2 (v1 - v2) - a3 v2 - a4 (exp(a5 v2) - 1)"),
        {"a1": 1.0, "a2": 0.6, "a3": 0.3, "a4": 0.01, "a5": 3.0},
        ("v1_dot = a1 (u - v1) - a2 (v1 - v2)", "v2_dot = a3 (v1 - v2) - a4 v2"), "voltage",
        (0.0, 0.0), {"u": (0.0, 2.5, 50)}, "exponential_rate", frozenset({"v2"}),
        "diode current (Shockley)", dt=0.1, n_samples=1200),
    "circuit_diode_link": Case(
        ("v1_dot = a1 (u - v1) - a2 (v1 - v2) - a4 (exp(a5 (v1 - v2)) - 1)",
         "v2_dot = a2 (v1 - v2) + a4 (exp(a5 (v1 - v2)) - 1) - a3 v2"),
        {"a1": 1.0, "a2": 0.3, "a3": 0.6, "a4": 0.01, "a5": 3.0},
        ("v1_dot = a1 (u - v1) - a2 (v1 - v2)", "v2_dot = a3 (v1 - v2) - a4 v2"), "voltage",
        (0.0, 0.0), {"u": (0.0, 3.0, 50)}, "diode_link", frozenset({"v1", "v2"}),
        "diode between nodes (Shockley)", dt=0.1, n_samples=1200),
    "room_heat_load": Case(_ROOM_LOADED, start=_ROOM, effect="offset", where=frozenset({"T1"}),
                           called="constant heat load", **_WALLS),
    "room_control": Case(_ROOM, start=_ROOM, effect=None,
                         **{**_WALLS, "params": {a: v for a, v in _WALLS["params"].items()
                                                 if a != "a6"}}),
}


def record(case: Case, seed: int, noise: str | None) -> pd.DataFrame:
    """A record of the case's truth: stepped inputs, 40 dB on each measured state."""
    rng = np.random.default_rng(seed)
    t = np.arange(case.n_samples) * case.dt
    inputs = {}
    for name, (low, high, hold) in case.inputs.items():
        levels = rng.uniform(low, high, size=case.n_samples // hold + 1)
        inputs[name] = np.repeat(levels, hold)[:case.n_samples]
    if case.outdoor:  # a daily swing; dt is in hours, or in seconds where it is large
        hours = t / 3600.0 if case.dt > 10 else t
        inputs[case.outdoor] = 5 + 5 * np.sin(2 * np.pi * hours / 24 + rng.uniform(0, 6.3))
    states = Skeleton(list(case.truth)).simulate(t, list(case.y0), params=case.params,
                                                 inputs=inputs)
    measured = [s for s in states.columns if s not in case.hidden and s != "t"]
    frame = pd.DataFrame({"t": t, **inputs, **{s: states[s].to_numpy() for s in measured}})
    if noise is None:
        return frame
    sensor = SENSOR if noise == "ar" else {}
    return datasets.add_sensor_noise(frame, measured, snr=40.0, random_state=seed + 100,
                                     **sensor)


def _right(case: Case, suggestion) -> bool:
    if case.effect is None:
        return suggestion is None
    if suggestion is None or suggestion.effect != case.effect:
        return False
    touched = {suggestion.equation[:-4], *(e[:-4] for e in suggestion.also)}
    if case.effect.endswith("_link"):
        touched = {s.strip() for s in suggestion.variable.split("-")}
    return touched == case.where and suggestion.called == case.called


def run(name: str, seed: int, noise: str) -> dict:
    """One loop from the case's starting skeleton; right, complete and seconds."""
    case = CASES[name]
    X, fresh = record(case, seed, noise), record(case, seed + 50, None)
    quantities = dict.fromkeys(Skeleton(list(case.start)).states, case.quantity)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.perf_counter()
        loop = HypothesisLoop(PolyCCRegressor(equations=list(case.start),
                                              quantities=quantities), X).run()
        seconds = time.perf_counter() - start
        true = PolyCCRegressor(equations=list(case.truth), quantities=quantities).fit(X)
    scorer = make_simulation_scorer()
    ours, best = scorer.nrmse(loop.model, fresh), scorer.nrmse(true, fresh)
    first = loop.rounds[0].diagnosis.best
    return {"case": name, "seed": seed, "noise": noise, "control": case.effect is None,
            "right": _right(case, first), "complete": ours <= 2 * best,
            "ratio": ours / best, "seconds": seconds,
            "named": [str(r.diagnosis.best).split(":")[0] if r.diagnosis.best else "-"
                      for r in loop.rounds]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--noise", nargs="+", choices=["white", "ar"], default=["white", "ar"])
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES))
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    jobs = [(c, s, n) for c in args.cases for n in args.noise for s in args.seeds]
    print(f"{'case':<18} {'noise':>5} {'seed':>4} {'right':>5} {'complete':>8} {'ratio':>7} "
          f"{'s':>6}  named", flush=True)
    rows = []
    for r in Parallel(n_jobs=args.jobs, return_as="generator")(delayed(run)(*job)
                                                                for job in jobs):
        rows.append(r)  # each line once its loop is done
        print(f"{r['case']:<18} {r['noise']:>5} {r['seed']:>4} {r['right']!s:>5} "
              f"{r['complete']!s:>8} {r['ratio']:>7.2f} {r['seconds']:>6.1f}  "
              f"{' | '.join(r['named'])}", flush=True)
    hidden = [r for r in rows if not r["control"]]
    controls = [r for r in rows if r["control"]]
    print(f"\nright {sum(r['right'] for r in hidden)}/{len(hidden)}, "
          f"complete {sum(r['complete'] for r in hidden)}/{len(hidden)}, "
          f"false alarms {sum(not r['right'] for r in controls)}/{len(controls)}, "
          f"median loop {statistics.median(r['seconds'] for r in rows):.0f} s, "
          f"largest {max(r['seconds'] for r in rows):.0f} s")


if __name__ == "__main__":
    main()
