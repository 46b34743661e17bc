"""The hypothesis loop beyond mechanics: hidden effects named in the words of each field.

Each case is a record of a field: first-order records of a tank's level, a
substrate's concentration, a body's temperature, a capacitor's voltage, a
population, measured through the state and driven by a stepped input (a
heater's reaching its tank 6 samples late, a pump or a heater that levels off
or does nothing inside a dead band, a valve whose flow is the square of its
opening); a cascade of two tanks draining alike, two species
reacting in a stirred tank (A + B, both fed) or a predator and its prey
(stocked), both states measured; and two
bodies joined by a spring, the first one forced, measured at both positions
only (4,000 samples, four states), with the hidden effect on the second body.
Noise is Gaussian. The loop starts from the skeleton a scientist of that
field writes first (linear laws; Lotka-Volterra's product for the predator),
told what a first-order state measures (the estimator's ``quantities``; the
bodies' structure says they are mechanical), with default settings
otherwise. Per case and noise level it reports

right
    the first effect the loop names is the hidden one, called as its field
    calls it (``Suggestion.called``: "Torricelli outflow", not a friction);
complete
    the loop's final model simulates a fresh record (another input) within
    twice the error of the true skeleton fitted the same way on the same data,
    or within 0.1 % of the fresh record's spread (ten times below the
    quietest noise of the study: on such clean first-order records the true
    skeleton's own error is a few hundredths of a per cent, and twice that is
    no difference a measurement could show);
false alarm
    on a control (the starting skeleton is the truth), the loop names anything.

It also counts every name the loop gives in mechanical words (friction,
spring, drag, ...) to a state that is not mechanical: there must be none.
``--pole`` makes the noise coloured as a sensor's (AR(1) with that pole, of
the state's spread, :func:`sklearn_pycc.datasets.add_sensor_noise`) and
``--bits`` rounds it to a converter's resolution; the fresh record stays
clean. Not timed for speed claims (the median loop time is printed beside)::

    python asv_benchmarks/field_study.py [--seeds 0 1] [--snr 40 30] [--cases tank ...]
    python asv_benchmarks/field_study.py --pole 0.9 --bits 12
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, SimulationError, Skeleton, datasets

MECHANICAL_WORDS = ("friction", "spring", "stiffness", "drag", "pendulum", "force", "mass")
#: a fresh-record error below this share of the record's spread counts as complete
COMPLETE_FLOOR = 1e-3


def _without_mass_action(name: str) -> str:
    """A name in lower case without a chemist's "mass action" (no mechanical mass)."""
    return name.lower().replace("mass-action", "").replace("mass action", "")


@dataclass(frozen=True)
class Case:
    """One generated system of a field."""

    field: str
    quantity: str | None  # what a first-order state measures (None: the structure says)
    truth: str | tuple[str, ...]
    params: dict
    start: str | tuple[str, ...]
    effect: str | None  # the hidden effect's catalogue name (None: a control)
    called: str | None  # what the field calls it
    inputs: tuple[float, float]  # range of the stepped input (of the forcing's amplitude)
    y0: float | tuple[float, ...]
    dt: float = 0.25
    hold: int = 120
    delay: float | None = None  # the input's transport delay in the truth, seconds
    n_samples: int = 1200
    measured: tuple[str, ...] = ("x1",)
    forcing: str = "steps"  # "steps" of the input u, or "sines": a force F_ext of two tones

    @property
    def equations(self) -> tuple[list[str], list[str]]:
        """The true and the starting skeleton's equations."""
        return tuple([e] if isinstance(e, str) else list(e) for e in (self.truth, self.start))

    @property
    def initial(self) -> list[float]:
        return [self.y0] if isinstance(self.y0, float | int) else list(self.y0)

    @property
    def signal(self) -> str:
        return "F_ext" if self.forcing == "sines" else "u"


# two bodies joined by a spring, the first one forced; the hidden effect is on the second
_BODY_1 = ("x1_dot = x3", "x2_dot = x4", "x3_dot = F_ext - a1 x3 - a2 x1 - a3 (x1 - x2)")
_BODY_2 = "x4_dot = - a4 x4 - a5 x2 + a3 (x1 - x2)"
_BODIES = {"a1": 0.2, "a2": 1.0, "a3": 0.5, "a4": 0.15, "a5": 1.2}
_TWO_BODY = dict(dt=0.025, n_samples=4000, measured=("x1", "x2"), forcing="sines",
                 y0=(0.5, -0.3, 0.0, 0.0))


CASES = {
    "tank_torricelli": Case(
        "process", "level", "x1_dot = a1 u - a2 sqrt(abs(x1))", {"a1": 0.5, "a2": 0.4},
        "x1_dot = a1 u - a2 x1", "square_root_outflow", "Torricelli outflow", (0.2, 1.0),
        1.0, dt=0.5, hold=80),
    "tank_weir": Case(
        "process", "level", "x1_dot = a1 u - a2 abs(x1)^a3", {"a1": 0.5, "a2": 0.4, "a3": 1.5},
        "x1_dot = a1 u - a2 x1", "power_law_outflow", "weir outflow (power law)", (0.2, 1.0),
        1.0, dt=0.5, hold=80),
    "tank_pump_saturation": Case(
        "process", "level", "x1_dot = a1 a3 tanh(u/a3) - a2 x1",
        {"a1": 0.5, "a2": 0.3, "a3": 0.6}, "x1_dot = a1 u - a2 x1", "input_saturation",
        "pump or valve saturation", (0.0, 1.6), 1.0, dt=0.5, hold=80),
    "tank_valve_characteristic": Case(
        "process", "level", "x1_dot = a1 u^2 - a2 x1", {"a1": 0.8, "a2": 0.3},
        "x1_dot = a1 u - a2 x1", "valve_characteristic", "valve characteristic", (0.1, 1.0),
        1.0, dt=0.5, hold=80),
    "tanks_cascade_torricelli": Case(
        "process", "level",
        ("x1_dot = a1 u - a2 sqrt(abs(x1))", "x2_dot = a2 sqrt(abs(x1)) - a3 sqrt(abs(x2))"),
        {"a1": 0.5, "a2": 0.4, "a3": 0.3},
        ("x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 x2"), "square_root_outflow",
        "Torricelli outflow", (0.2, 1.0), (1.0, 1.0), dt=0.5, hold=80, measured=("x1", "x2")),
    "tanks_cascade_control": Case(
        "process", "level", ("x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 x2"),
        {"a1": 0.5, "a2": 0.4, "a3": 0.3}, ("x1_dot = a1 u - a2 x1", "x2_dot = a2 x1 - a3 x2"),
        None, None, (0.2, 1.0), (1.0, 1.0), dt=0.5, hold=80, measured=("x1", "x2")),
    "tank_control": Case(
        "process", "level", "x1_dot = a1 u - a2 x1", {"a1": 0.5, "a2": 0.3},
        "x1_dot = a1 u - a2 x1", None, None, (0.2, 1.0), 1.0, dt=0.5, hold=80),
    "substrate_michaelis_menten": Case(
        "kinetics", "concentration", "x1_dot = u - a1 x1/(a2 + abs(x1))", {"a1": 2.0, "a2": 1.0},
        "x1_dot = u - a1 x1", "saturating_rate", "Michaelis-Menten saturation", (0.1, 1.6),
        0.5),
    "dimer_second_order": Case(
        "kinetics", "concentration", "x1_dot = u - a1 x1 - a2 x1^2", {"a1": 0.2, "a2": 0.8},
        "x1_dot = u - a1 x1", "quadratic_rate", "second-order reaction", (0.2, 2.0), 0.5),
    "substrate_hill": Case(
        "kinetics", "concentration", "x1_dot = u - a1 x1^2/(a2 + x1^2)", {"a1": 2.0, "a2": 1.0},
        "x1_dot = u - a1 x1", "hill_rate", "Hill kinetics (cooperative, order 2)", (0.1, 1.6),
        0.5),
    "reactor_a_plus_b": Case(
        "kinetics", "concentration",
        ("x1_dot = u - a1 x1 - a3 x1 x2", "x2_dot = a2 - a1 x2 - a3 x1 x2"),
        {"a1": 0.5, "a2": 0.5, "a3": 1.0}, ("x1_dot = u - a1 x1", "x2_dot = a2 - a1 x2"),
        "mass_action", "mass-action reaction (A + B)", (0.1, 1.5), (0.5, 0.5),
        measured=("x1", "x2")),
    "reactor_control": Case(
        "kinetics", "concentration", ("x1_dot = u - a1 x1", "x2_dot = a2 - a1 x2"),
        {"a1": 0.5, "a2": 0.5}, ("x1_dot = u - a1 x1", "x2_dot = a2 - a1 x2"), None, None,
        (0.1, 1.5), (0.5, 0.5), measured=("x1", "x2")),
    "kinetics_control": Case(
        "kinetics", "concentration", "x1_dot = u - a1 x1", {"a1": 0.7},
        "x1_dot = u - a1 x1", None, None, (0.1, 1.6), 0.5),
    "body_radiation": Case(
        "thermal", "temperature", "x1_dot = a1 u - a2 x1 - a3 x1^4",
        {"a1": 1.0, "a2": 0.1, "a3": 0.05}, "x1_dot = a1 u - a2 x1", "radiation",
        "radiation (Stefan-Boltzmann)", (0.5, 3.0), 1.0, dt=0.1),
    "heater_transport_delay": Case(
        "thermal", "temperature", "x1_dot = a1 u(t - 1.5) - a2 x1", {"a1": 1.0, "a2": 0.4},
        "x1_dot = a1 u - a2 x1", "transport_delay", "transport delay", (0.5, 3.0), 1.0,
        dt=0.25, hold=40, delay=1.5),
    "heater_dead_band": Case(
        "thermal", "temperature", "x1_dot = a1 (u - a3 sign(u)) (1 + sign(abs(u) - a3))/2 - a2 x1",
        {"a1": 1.0, "a2": 0.4, "a3": 1.0}, "x1_dot = a1 u - a2 x1", "input_dead_zone",
        "heater dead band", (0.0, 3.0), 1.0, dt=0.1),
    "thermal_control": Case(
        "thermal", "temperature", "x1_dot = a1 u - a2 x1", {"a1": 1.0, "a2": 0.4},
        "x1_dot = a1 u - a2 x1", None, None, (0.5, 3.0), 1.0, dt=0.1),
    "capacitor_diode": Case(
        "electrical", "voltage", "x1_dot = a1 u - a2 x1 - a3 (exp(a4 x1) - 1)",
        {"a1": 1.0, "a2": 0.5, "a3": 0.01, "a4": 3.0}, "x1_dot = a1 u - a2 x1",
        "exponential_rate", "diode current (Shockley)", (0.2, 2.0), 0.0, dt=0.1),
    "circuit_control": Case(
        "electrical", "voltage", "x1_dot = a1 u - a2 x1", {"a1": 1.0, "a2": 0.5},
        "x1_dot = a1 u - a2 x1", None, None, (0.2, 2.0), 0.0, dt=0.1),
    "population_crowding": Case(
        "populations", "population", "x1_dot = a1 x1 - a2 x1^2 - a3 u",
        {"a1": 0.8, "a2": 0.4, "a3": 0.5}, "x1_dot = a1 x1 - a3 u", "quadratic_rate",
        "logistic crowding", (0.0, 0.4), 1.0, dt=0.1),
    "predator_prey_holling": Case(
        "populations", "population",
        ("x1_dot = a1 x1 - a6 x1^2 - a2 x1 x2/(a3 + x1) + u",
         "x2_dot = a4 x1 x2/(a3 + x1) - a5 x2"),
        {"a1": 1.0, "a2": 1.0, "a3": 1.0, "a4": 0.8, "a5": 0.4, "a6": 0.5},
        ("x1_dot = a1 x1 - a6 x1^2 - a2 x1 x2 + u", "x2_dot = a4 x1 x2 - a5 x2"),
        "saturating_interaction", "Holling type II predation", (0.0, 0.5), (1.0, 1.0),
        hold=80, measured=("x1", "x2")),
    "predator_prey_control": Case(
        "populations", "population",
        ("x1_dot = a1 x1 - a6 x1^2 - a2 x1 x2 + u", "x2_dot = a4 x1 x2 - a5 x2"),
        {"a1": 1.0, "a2": 0.5, "a4": 0.4, "a5": 0.4, "a6": 0.5},
        ("x1_dot = a1 x1 - a6 x1^2 - a2 x1 x2 + u", "x2_dot = a4 x1 x2 - a5 x2"), None, None,
        (0.0, 0.5), (1.0, 1.0), hold=80, measured=("x1", "x2")),
    "population_control": Case(
        "populations", "population", "x1_dot = a1 x1 - a3 u", {"a1": -0.3, "a3": 0.5},
        "x1_dot = a1 x1 - a3 u", None, None, (0.0, 0.4), 1.0, dt=0.1),
    "bodies_cubic_spring": Case(
        "mechanics", None, (*_BODY_1, _BODY_2 + " - a6 x2^3"), {**_BODIES, "a6": 2.0},
        (*_BODY_1, _BODY_2), "cubic_stiffness", "cubic stiffness", (0.8, 1.2), **_TWO_BODY),
    "bodies_dry_friction": Case(
        "mechanics", None, (*_BODY_1, _BODY_2 + " - a6 tanh(20 x4)"), {**_BODIES, "a6": 0.1},
        (*_BODY_1, _BODY_2), "coulomb_friction", "coulomb friction", (0.8, 1.2), **_TWO_BODY),
    "bodies_control": Case(
        "mechanics", None, (*_BODY_1, _BODY_2), _BODIES, (*_BODY_1, _BODY_2), None, None,
        (0.8, 1.2), **_TWO_BODY),
}


def _input(case: Case, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    if case.forcing == "sines":  # two tones of drawn amplitudes and phases
        low, high = case.inputs
        a, b = rng.uniform(low, high, size=2)
        phase = rng.uniform(0.0, 2 * np.pi, size=2)
        return a * np.cos(0.8 * t + phase[0]) + 0.5 * b * np.cos(1.36 * t + phase[1])
    return np.repeat(rng.uniform(*case.inputs, size=len(t) // case.hold + 1),
                     case.hold)[:len(t)]


def _record(case: Case, *, snr, seed: int, sensor: dict | None = None) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, case.n_samples * case.dt, case.dt)[:case.n_samples]
    u = _input(case, t, rng)
    simulated = Skeleton(case.equations[0]).simulate(t, case.initial, params=case.params,
                                                     inputs={case.signal: u})
    frame = pd.DataFrame({"t": t, **{c: simulated[c].to_numpy() for c in case.measured},
                          case.signal: u})
    for c in case.measured:
        x = frame[c].to_numpy()
        if snr is not None and sensor is None:
            frame[c] = x + np.std(x) * 10 ** (-snr / 20) * rng.standard_normal(len(t))
        if snr is not None and sensor is not None:  # coloured, rounded: as a sensor reads it
            # of the state's spread, as the white noise is (a level's mean is no signal)
            mean = float(np.mean(x))
            noisy = datasets.add_sensor_noise(frame[["t"]].assign(**{c: x - mean}), [c],
                                              snr=snr, random_state=seed + 7, **sensor)
            frame[c] = noisy[c].to_numpy() + mean
    return frame


def _simulation_error(model, frame: pd.DataFrame, case: Case) -> float:
    """The fresh record's simulation error, root mean square over the measured states."""
    try:
        simulated = model.simulate(frame["t"].to_numpy(), case.initial,
                                   inputs={case.signal: frame[case.signal].to_numpy()})
    except (SimulationError, ValueError):
        return float("inf")
    error = np.concatenate([simulated[c].to_numpy() - frame[c].to_numpy()
                            for c in case.measured])
    return float(np.sqrt(np.mean(error**2))) if np.isfinite(error).all() else float("inf")


def run_case(name: str, snr, seed: int, sensor: dict | None = None) -> dict:
    case = CASES[name]
    X = _record(case, snr=snr, seed=seed, sensor=sensor)
    fresh = _record(case, snr=None, seed=seed + 1000)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth, first = case.equations
        quantities = (None if case.quantity is None
                      else dict.fromkeys(Skeleton(first).states, case.quantity))
        model = PolyCCRegressor(equations=first, quantities=quantities)
        loop = HypothesisLoop(model, X).run(max_rounds=4)
        elapsed = time.perf_counter() - start
        reference = PolyCCRegressor(equations=truth).fit(X)
    added = [r.added for r in loop.rounds if r.added is not None]
    named = [a.effect for a in added]
    called = [a.called or a.effect for a in added]
    ours = _simulation_error(loop.model, fresh, case)
    best = _simulation_error(reference, fresh, case)
    floor = COMPLETE_FLOOR * float(np.std(fresh[list(case.measured)].to_numpy()))
    control = case.effect is None
    fitted = list(getattr(loop.model, "delays_", {}).values())
    return {
        "delay_off": (abs(fitted[0] - case.delay) / case.dt
                      if case.delay is not None and len(fitted) == 1 else None),
        "case": name, "field": case.field, "snr": snr, "seed": seed, "named": named,
        "called": called, "control": control,
        "right": (not named) if control else bool(named) and named[0] == case.effect
        and called[0] == case.called,
        "complete": ours <= max(2 * best, floor),
        "ratio": ours / best if best > 0 else float("inf"),
        "mechanical_words": 0 if case.field == "mechanics" else
        sum(any(w in _without_mass_action(c) for w in MECHANICAL_WORDS) for c in called),
        "seconds": elapsed,
    }


def _figures(rows: list[dict]) -> str:
    hidden = [r for r in rows if not r["control"]]
    controls = [r for r in rows if r["control"]]
    right = sum(r["right"] for r in hidden)
    complete = sum(r["complete"] for r in hidden)
    alarms = sum(not r["right"] for r in controls)
    words = sum(r["mechanical_words"] for r in rows)
    return (f"right {right}/{len(hidden)} ({100 * right / max(len(hidden), 1):.0f} %), "
            f"complete {complete}/{len(hidden)} ({100 * complete / max(len(hidden), 1):.0f} %); "
            f"false alarms {alarms}/{len(controls)}; mechanical names {words}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--snr", type=float, nargs="+", default=[40.0, 30.0])
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES))
    parser.add_argument("--pole", type=float, default=None)
    parser.add_argument("--bits", type=int, default=None)
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()
    sensor = None if args.pole is None and args.bits is None else \
        {"pole": args.pole or 0.0, "bits": args.bits}
    jobs = [(name, snr, seed) for name in args.cases for snr in args.snr for seed in args.seeds]
    rows = Parallel(n_jobs=args.jobs)(delayed(run_case)(*job, sensor=sensor) for job in jobs)
    print(f"{'case':<28} {'field':<12} {'SNR':>4} {'seed':>4} {'right':>5} {'complete':>8} "
          f"{'ratio':>7} {'s':>6}  called")
    for r in rows:
        print(f"{r['case']:<28} {r['field']:<12} {r['snr']:>4g} {r['seed']:>4} "
              f"{r['right']!s:>5} {r['complete']!s:>8} {r['ratio']:>7.2f} {r['seconds']:>6.1f}  "
              f"{', '.join(r['called']) or '-'}")
    print()
    for field in dict.fromkeys(r["field"] for r in rows):
        print(f"{field:<12} {_figures([r for r in rows if r['field'] == field])}")
    print(f"{'all':<12} {_figures(rows)}")
    delays = [r for r in rows if CASES[r["case"]].delay is not None]
    if delays:
        off = [r["delay_off"] for r in delays]
        within = sum(d is not None and d <= 1.0 for d in off)
        print(f"delays fitted within one sampling interval: {within} of {len(delays)} (off by "
              f"{', '.join('-' if d is None else f'{d:.2f}' for d in off)} intervals)")
    print(f"median loop time {statistics.median(r['seconds'] for r in rows):.1f} s")


if __name__ == "__main__":
    main()
