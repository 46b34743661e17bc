"""Benchmarks of :class:`~sklearn_pycc.InterpolatedCCRegressor` (curves kept as tables)."""

from __future__ import annotations

from sklearn_pycc import InterpolatedCCRegressor, PolyCCRegressor

from .systems import FUNCTIONAL, SystemBenchmark


class InterpolatedCCRegressorBenchmark(SystemBenchmark):
    """Fit, predict, simulate and accuracy of InterpolatedCCRegressor.

    The curves are fitted by PolyCCRegressor (degree 7) and kept as PCHIP
    tables of 200 points; ``case`` is the stick-slip or the Duffing
    oscillator with its functional skeleton.
    """

    CASES = {
        "stick_slip_functional": {
            "system": "stick_slip",
            "equations": FUNCTIONAL,
            "constraints": ["f1 odd", "f2(0)=0"],
        },
        "duffing_functional": {
            "system": "duffing",
            "equations": FUNCTIONAL,
            "constraints": ["f1 odd", "f2 odd"],
        },
    }
    params = (list(CASES),)

    def setup_cache(self):  # one per class: asv keys the cache by this line
        return self.fit_every_case()

    def make_estimator(self, params):
        (case,) = params
        return InterpolatedCCRegressor(equations=self.equations(case),
                                       constraints=self.CASES[case]["constraints"],
                                       estimator=PolyCCRegressor(degree=7))
