"""Benchmarks of :class:`~sklearn_pycc.NeuralCCRegressor` on the seed paper's example."""

from __future__ import annotations

from sklearn_pycc import NeuralCCRegressor

from .systems import FUNCTIONAL, HYBRID, SystemBenchmark, case, stick_slip_curves


class NeuralCCRegressorBenchmark(SystemBenchmark):
    """Fit, predict, simulate and accuracy of NeuralCCRegressor (default settings).

    ``case``: the stick-slip oscillator with its functional skeleton (f1, f2
    odd) or the hybrid one (f1 odd, spring ``a4 x1 + a5 x1^3``), and the
    chaotic Duffing oscillator with its functional skeleton (f1, f2 odd).
    """

    CASES = {
        "stick_slip_functional": case("stick_slip", FUNCTIONAL, "f1 odd", "f2 odd"),
        "stick_slip_hybrid": case("stick_slip", HYBRID, "f1 odd", curves=stick_slip_curves),
        "duffing_functional": case("duffing", FUNCTIONAL, "f1 odd", "f2 odd"),
    }
    params = (list(CASES),)
    # a fit takes seconds: fewer repeats
    repeat = (2, 5, 20.0)

    def setup_cache(self):  # one per class: asv keys the cache by this line
        return self.fit_every_case()

    def make_estimator(self, params):
        (name,) = params
        return NeuralCCRegressor(equations=self.equations(name),
                                 constraints=self.CASES[name]["constraints"], random_state=0)
