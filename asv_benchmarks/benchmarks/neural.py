"""Benchmarks of :class:`~sklearn_pycc.NeuralCCRegressor` on the seed paper's example."""

from __future__ import annotations

from sklearn_pycc import NeuralCCRegressor

from .systems import FUNCTIONAL, HYBRID, SystemBenchmark, stick_slip_curves


class NeuralCCRegressorBenchmark(SystemBenchmark):
    """Fit, predict, simulate and accuracy of NeuralCCRegressor (default settings).

    ``case``: the stick-slip oscillator with its functional skeleton (f1, f2
    odd) or the hybrid one (f1 odd, spring ``a4 x1 + a5 x1^3``), and the
    chaotic Duffing oscillator with its functional skeleton (f1, f2 odd).
    """

    CASES = {
        "stick_slip_functional": {
            "system": "stick_slip",
            "equations": FUNCTIONAL,
            "constraints": ["f1 odd", "f2 odd"],
        },
        "stick_slip_hybrid": {
            "system": "stick_slip",
            "equations": HYBRID,
            "constraints": ["f1 odd"],
            "curves": stick_slip_curves,
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
    # a fit takes seconds: fewer repeats
    repeat = (2, 5, 20.0)

    def make_estimator(self, params):
        (case,) = params
        return NeuralCCRegressor(equations=self.equations(case),
                                 constraints=self.CASES[case]["constraints"], random_state=0)
