"""Benchmarks of :class:`~sklearn_pycc.PolyCCRegressor` on systems with known curves."""

from __future__ import annotations

from functools import cache

import numpy as np
from sklearn.utils import Bunch

from sklearn_pycc import PolyCCRegressor, SimulationError, datasets

from .common import Benchmark, Estimator

FUNCTIONAL = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
STATES = ["x1", "x2"]
INPUTS = ["F_ext"]
TARGETS = ["x1_dot", "x2_dot"]


@cache
def _dataset(system: str):
    """``(frame, truth)`` of a benchmark system, simulated once per process."""
    if system == "stick_slip":
        return datasets.make_stick_slip(return_truth=True)
    if system == "duffing":
        return datasets.make_duffing(return_truth=True)
    raise ValueError(f"unknown system {system!r}")


def _stick_slip_curves(params):
    """The curves of the parametric stick-slip skeleton, from its fitted parameters."""
    a = params
    return {
        "f1": lambda v: a["a1"] * v + a["a2"] * np.tanh(a["a3"] * v),
        "f2": lambda x: a["a4"] * x + a["a5"] * x**3,
    }


# case -> system, skeleton (None: the truth's parametric skeleton), constraints,
# degree, and for a parametric skeleton its curves from the fitted parameters
CASES = {
    "stick_slip_functional": {
        "system": "stick_slip",
        "equations": FUNCTIONAL,
        "constraints": ["f1 odd", "f2(0)=0"],
        "degree": 7,
    },
    "stick_slip_parametric": {
        "system": "stick_slip",
        "equations": None,
        "constraints": None,
        "degree": 7,
        "curves": _stick_slip_curves,
    },
    "duffing_functional": {
        "system": "duffing",
        "equations": FUNCTIONAL,
        "constraints": ["f1 odd", "f2 odd"],
        "degree": 7,
    },
}

# argument of each true curve, for evaluating the curves of a parametric model
ARGUMENTS = {"f1": "x2", "f2": "x1"}


class PolyCCRegressorBenchmark(Estimator, Benchmark):
    """Fit, predict, simulate and accuracy of PolyCCRegressor.

    ``case`` names a system of :mod:`sklearn_pycc.datasets` and a skeleton:
    the stick-slip oscillator with its functional skeleton (curves f1, f2) or
    its parametric skeleton (a1..a5), and the chaotic Duffing oscillator with
    its functional skeleton.
    """

    param_names = ["case"]
    params = (list(CASES),)

    def make_data(self, params):
        (case,) = params
        frame, truth = _dataset(CASES[case]["system"])
        X = frame[["t", *STATES, *INPUTS]]
        y = frame[TARGETS]
        return Bunch(X=X, y=y, frame=frame, truth=truth)

    def make_estimator(self, params):
        (case,) = params
        spec = CASES[case]
        equations = spec["equations"]
        if equations is None:
            equations = _dataset(spec["system"])[1].parametric_equations
        return PolyCCRegressor(equations=list(equations), constraints=spec["constraints"],
                               degree=spec["degree"], random_state=0)

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
        if model.functions_:
            grids = {name: (frame["x"].to_numpy(), frame[name].to_numpy())
                     for name, frame in model.cc_curves(n=200).items()}
        else:
            curves = CASES[case]["curves"](model.params_)
            grids = {}
            for name, curve in curves.items():
                column = self.data.frame[ARGUMENTS[name]]
                x = np.linspace(column.min(), column.max(), 200)
                grids[name] = (x, curve(x))
        errors = [values - truth.functions[name](x) for name, (x, values) in grids.items()]
        return float(np.sqrt(np.mean(np.concatenate(errors) ** 2)))

    track_cc_rmse.unit = "curve RMSE"
