"""Benchmarks of :class:`~sklearn_pycc.InterpolatedCCRegressor` (curves kept as tables)."""

from __future__ import annotations

from sklearn_pycc import InterpolatedCCRegressor, PolyCCRegressor

from .poly import PolyCCRegressorBenchmark
from .systems import SystemBenchmark


class InterpolatedCCRegressorBenchmark(SystemBenchmark):
    """Fit, predict, simulate and accuracy of InterpolatedCCRegressor.

    The curves are fitted by PolyCCRegressor (degree 7) and kept as PCHIP
    tables of 200 points; ``case`` is the stick-slip or the Duffing
    oscillator with its functional skeleton.
    """

    CASES = {name: PolyCCRegressorBenchmark.CASES[name]
             for name in ("stick_slip_functional", "duffing_functional")}
    params = (list(CASES),)

    def setup_cache(self):  # one per class: asv keys the cache by this line
        return self.fit_every_case()

    def make_estimator(self, params):
        (name,) = params
        return InterpolatedCCRegressor(equations=self.equations(name),
                                       constraints=self.CASES[name]["constraints"],
                                       estimator=PolyCCRegressor(degree=7))
