"""Benchmarks of :class:`~sklearn_pycc.PolyCCRegressor` on systems with known curves."""

from __future__ import annotations

from sklearn_pycc import PolyCCRegressor

from .systems import FUNCTIONAL, SystemBenchmark, case, stick_slip_curves


class PolyCCRegressorBenchmark(SystemBenchmark):
    """Fit, predict, simulate and accuracy of PolyCCRegressor.

    ``case`` names a system of :mod:`sklearn_pycc.datasets` and a skeleton:
    the stick-slip oscillator with its functional skeleton (curves f1, f2) or
    its parametric skeleton (a1..a5), and the chaotic Duffing oscillator with
    its functional skeleton.
    """

    CASES = {
        "stick_slip_functional": case("stick_slip", FUNCTIONAL, "f1 odd", "f2(0)=0"),
        "stick_slip_parametric": case("stick_slip", None, curves=stick_slip_curves),
        "duffing_functional": case("duffing", FUNCTIONAL, "f1 odd", "f2 odd"),
    }
    params = (list(CASES),)

    def setup_cache(self):  # one per class: asv keys the cache by this line
        return self.fit_every_case()

    def make_estimator(self, params):
        (name,) = params
        return PolyCCRegressor(equations=self.equations(name),
                               constraints=self.CASES[name]["constraints"], degree=7,
                               random_state=0)
