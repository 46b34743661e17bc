"""How the hypothesis loop's time grows with the record: seconds per sample count.

A forced oscillator with hidden cubic stiffness, position only at 40 dB,
sampled at 50 Hz for longer and longer; the loop starts from the linear
skeleton (three rounds at most, defaults, output error chosen by the
noise). Printed: samples, seconds, seconds per thousand samples, what the
loop named. Output error's multiple shooting has a block-sparse Jacobian:
long records are solved at linear cost, so the last column should stay
level::

    python asv_benchmarks/loop_scaling.py [--samples 3000 12000 48000 200000]
"""

from __future__ import annotations

import argparse
import time
import warnings

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]


def run(n: int) -> tuple[float, list[str]]:
    frame = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=n,
                                     t_span=(0.0, n / 50.0), noise=40.0,
                                     noise_columns=["x1"], random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        began = time.perf_counter()
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR),
                              frame[["t", "x1", "F_ext"]]).run(max_rounds=3)
        seconds = time.perf_counter() - began
    return seconds, [r.added.effect for r in loop.rounds if r.added is not None]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, nargs="+", default=[3000, 12000, 48000, 200000])
    args = parser.parse_args()
    print(f"{'samples':>8} {'seconds':>8} {'s/1000':>7}  named")
    for n in args.samples:
        seconds, named = run(n)
        print(f"{n:>8} {seconds:>8.1f} {1000 * seconds / n:>7.2f}  {', '.join(named) or '-'}",
              flush=True)


if __name__ == "__main__":
    main()
