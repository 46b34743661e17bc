"""Benchmarks shared by every backend: the benchmark systems with known curves.

A backend's benchmark class names its ``CASES`` (system, skeleton,
constraints and backend options) and builds its estimator; data, the
simulation benchmarks and the accuracy tracks live here.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from sklearn.utils import Bunch

from sklearn_pycc import SimulationError, datasets

from .common import Benchmark, Estimator

FUNCTIONAL = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
HYBRID = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - a4 x1 - a5 x1^3"]
STATES = ["x1", "x2"]
INPUTS = ["F_ext"]
TARGETS = ["x1_dot", "x2_dot"]
# argument of each true curve, for evaluating the curves of a parametric model
ARGUMENTS = {"f1": "x2", "f2": "x1"}


def case(system: str, equations, *constraints: str, curves=None) -> dict:
    """One entry of a benchmark class's ``CASES``.

    ``equations`` None stands for the truth's parametric skeleton; ``curves``
    computes true-shaped curves from fitted parameters (see
    :meth:`SystemBenchmark.track_cc_rmse`).
    """
    entry = {"system": system, "equations": equations, "constraints": list(constraints) or None}
    if curves is not None:
        entry["curves"] = curves
    return entry


@cache
def dataset(system: str):
    """``(frame, truth)`` of a benchmark system, simulated once per process."""
    if system == "stick_slip":
        return datasets.make_stick_slip(return_truth=True)
    if system == "duffing":
        return datasets.make_duffing(return_truth=True)
    raise ValueError(f"unknown system {system!r}")


def stick_slip_curves(params):
    """The curves of the stick-slip system from (some of) its parameters a1..a5."""
    a = params
    curves = {}
    if "a1" in a:
        curves["f1"] = lambda v: a["a1"] * v + a["a2"] * np.tanh(a["a3"] * v)
    if "a4" in a:
        curves["f2"] = lambda x: a["a4"] * x + a["a5"] * x**3
    return curves


class SystemBenchmark(Estimator, Benchmark):
    """Simulation and accuracy benchmarks on the systems of :mod:`sklearn_pycc.datasets`.

    Subclasses set ``CASES`` (case name -> dict with ``system``,
    ``equations`` (None: the truth's parametric skeleton), ``constraints``,
    optionally ``curves`` computing true-shaped curves from fitted
    parameters) and define :meth:`make_estimator`.
    """

    CASES: dict = {}
    param_names = ["case"]

    def equations(self, case: str) -> list[str]:
        equations = self.CASES[case]["equations"]
        if equations is None:
            equations = dataset(self.CASES[case]["system"])[1].parametric_equations
        return list(equations)

    def make_data(self, params):
        (case,) = params
        frame, truth = dataset(self.CASES[case]["system"])
        X = frame[["t", *STATES, *INPUTS]]
        y = frame[TARGETS]
        return Bunch(X=X, y=y, frame=frame, truth=truth)

    def _simulate(self):
        frame, truth = self.data.frame, self.data.truth
        inputs = {name: truth.inputs[name] for name in INPUTS}
        return self.estimator.simulate(frame["t"], y0=truth.y0, inputs=inputs)

    def time_simulate(self, fitted, *params):
        self._simulate()

    def track_sim_rmse(self, fitted, *params):
        try:
            sim = self._simulate()
        except SimulationError:
            return float("inf")
        error = sim["x1"].to_numpy() - self.data.frame["x1"].to_numpy()
        return float(np.sqrt(np.mean(error**2)))

    track_sim_rmse.unit = "x1 RMSE"

    def track_cc_rmse(self, fitted, *params):
        (case,) = params
        truth, model = self.data.truth, self.estimator
        grids = {name: (frame["x"].to_numpy(), frame[name].to_numpy())
                 for name, frame in model.cc_curves(n=200).items()}
        from_params = self.CASES[case].get("curves")
        if from_params is not None:
            for name, curve in from_params(model.params_).items():
                column = self.data.frame[ARGUMENTS[name]]
                x = np.linspace(column.min(), column.max(), 200)
                grids[name] = (x, curve(x))
        errors = [values - truth.functions[name](x) for name, (x, values) in grids.items()]
        return float(np.sqrt(np.mean(np.concatenate(errors) ** 2)))

    track_cc_rmse.unit = "curve RMSE"
