"""Five records on which "nothing is missing" used to be said too early, and what the loop says.

Each case is generated twice (the record the loop sees, and a fresh one with
another release or forcing); the loop starts from a simpler skeleton with
default settings, and its final model is compared on the fresh record with
the true skeleton fitted the same way (the Duffing circuit: by output error).
Printed: what each round did, the coefficients that matter, and the ratio of
the simulation errors on the fresh record::

    python asv_benchmarks/loop_cases.py [--cases pendulum van_der_pol ...]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, SimulationError, datasets

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]


def _error(model, frame: pd.DataFrame, y0, inputs: list[str]) -> float:
    t = frame["t"].to_numpy()
    try:
        simulated = model.simulate(t, list(y0), inputs={u: frame[u].to_numpy() for u in inputs})
    except (SimulationError, ValueError):
        return float("inf")
    error = simulated["x1"].to_numpy() - frame["x1"].to_numpy()
    return float(np.sqrt(np.mean(error**2))) if np.isfinite(error).all() else float("inf")


def _pendulum(seed: int, fresh: bool):
    options = dict(stiffness=0.0, damping=0.3, n_samples=3000, t_span=(0.0, 60.0),
                   hidden={"pendulum": {"a1": 9.0}}, noise=40.0, noise_columns=["x1"],
                   random_state=seed + 1000 * fresh, return_truth=True,
                   y0=(1.5, 0.0) if fresh else (2.0, 0.0), omega=1.3 if fresh else 0.8)
    frame, truth = datasets.make_oscillator(**options)
    return frame[["t", "x1", "F_ext"]], truth.y0


def _van_der_pol(snr: float):
    def make(seed: int, fresh: bool):
        frame = datasets.make_van_der_pol(
            n_samples=3000, mu=0.8, noise=snr, noise_columns=["x1"],
            random_state=seed + 1000 * fresh, y0=(0.5, 0.0) if fresh else (1.0, 0.0),
            omega=1.1 if fresh else 0.9)
        return frame[["t", "x1", "F_ext"]], (0.5, 0.0) if fresh else (1.0, 0.0)
    return make


def _axis(seed: int, fresh: bool):
    frame, truth = datasets.make_positioning_axis(viscous=(10.0, 6.0),
                                                  random_state=seed + 1000 * fresh,
                                                  return_truth=True)
    return frame, tuple(truth.get("y0", (0.0, 0.0)))


def _circuit(seed: int, fresh: bool):
    frame, truth = datasets.make_resonator(samples_per_period=10, noise=65.0, n_samples=4000,
                                           random_state=seed + 1000 * fresh, return_truth=True)
    return frame, tuple(truth.get("y0", (0.0, 0.0)))


def _cogging(seed: int, fresh: bool):
    rng = np.random.default_rng(seed + 1000 * fresh)
    freqs = (0.6, 1.1, 1.9) if fresh else (0.5, 0.9, 1.7)
    phases = rng.uniform(0.0, 2 * np.pi, 3)
    y0 = (-1.0, 0.5) if fresh else (1.5, 0.0)

    def force(t):
        return 1.25 * sum(np.sin(w * t + p) for w, p in zip(freqs, phases))

    t = np.linspace(0.0, 60.0, 3000)
    solution = solve_ivp(
        lambda s, y: [y[1], force(s) - 0.3 * y[1] - 2.0 * y[0] - 0.6 * np.sin(3.0 * y[0])],
        (0.0, 60.0), y0, t_eval=t, rtol=1e-10, atol=1e-10)
    x = solution.y[0]
    x = x + rng.normal(0.0, np.std(x) * 1e-2, t.size)
    return pd.DataFrame({"t": t, "x1": x, "F_ext": force(t)}), y0


#: case -> (record maker, starting skeleton, true skeleton, true model's settings, inputs)
CASES = {
    "pendulum": (_pendulum, ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"],
                 ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 sin(x1)"], {}, ["F_ext"]),
    "van_der_pol_40dB": (_van_der_pol(40.0), LINEAR,
                         ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^2 x2"], {},
                         ["F_ext"]),
    "van_der_pol_30dB": (_van_der_pol(30.0), LINEAR,
                         ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^2 x2"], {},
                         ["F_ext"]),
    "asymmetric_axis": (_axis, ["x1_dot = x2", "x2_dot = a1 F - a2 x2"],
                        ["x1_dot = x2", "x2_dot = a1 F - a2 x2 - a3 tanh(a4 x2) - a5 "
                         "- a6 abs(x2)"], {"param_init": {"a4": 200.0}}, ["F"]),
    "duffing_circuit": (_circuit, ["x1_dot = x2", "x2_dot = a1 u - a2 x2 - a3 x1"],
                        ["x1_dot = x2", "x2_dot = a1 u - a2 x2 - a3 x1 - a4 x1^3"],
                        {"fit_mode": "simulation"}, ["u"]),
    "outside_catalogue": (_cogging, LINEAR,
                          ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 sin(a4 x1)"],
                          {"param_init": {"a3": 0.5, "a4": 2.5}}, ["F_ext"]),
}


def run_case(name: str, seed: int = 0) -> None:
    make, start, true, settings, inputs = CASES[name]
    frame, _ = make(seed, False)
    fresh, y0 = make(seed, True)
    began = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=start), frame).run(max_rounds=5)
        elapsed = time.perf_counter() - began
        reference = PolyCCRegressor(equations=true, **settings).fit(frame)
    ours, best = _error(loop.model, fresh, y0, inputs), _error(reference, fresh, y0, inputs)
    print(f"== {name} ({len(frame)} samples, loop {elapsed:.1f} s)")
    for r in loop.rounds:
        print(f"   round {r.index}: {r.decision}")
    if loop.refinement is not None:
        print(f"   final model {loop.refinement}")
    print("   final:", "; ".join(loop.model.equations()[1:]))
    print(f"   fresh record: simulation RMSE {ours:.4g} against {best:.4g} for the true skeleton"
          f" (ratio {ours / best:.2f})", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    for name in args.cases:
        run_case(name, args.seed)


if __name__ == "__main__":
    main()
