"""Benchmarks of the symbolic backend and of converting fitted curves (post-SR, tables)."""

from __future__ import annotations

import warnings

from threadpoolctl import threadpool_limits

from sklearn_pycc import (
    NeuralCCRegressor,
    SymbolicCCRegressor,
    datasets,
    to_interpolated,
    to_symbolic,
)

from .common import FULL
from .systems import FUNCTIONAL, INPUTS, STATES, TARGETS, SystemBenchmark, case


class SymbolicCCRegressorBenchmark(SystemBenchmark):
    """Fit, predict, simulate and accuracy of SymbolicCCRegressor (default settings).

    ``case``: the forced Duffing oscillator and the stick-slip oscillator,
    each with its functional skeleton (the stick-slip friction odd).
    """

    CASES = {
        "duffing_functional": case("duffing", FUNCTIONAL),
        # a search of a minute with its simulations: only with SKLEARN_PYCC_BENCH_FULL=1
        **({"stick_slip_functional": case("stick_slip", FUNCTIONAL, "f1 odd")}
           if FULL else {}),
    }
    params = (list(CASES),)
    # a fit takes seconds: fewer repeats, and no warm-up fit (the search dwarfs what
    # a first fit in a process caches)
    repeat = (2, 5, 30.0)
    timeout = 300
    warm_up_rows = 0

    def setup_cache(self):  # one per class: asv keys the cache by this line
        return self.fit_every_case()

    def make_estimator(self, params):
        (name,) = params
        return SymbolicCCRegressor(equations=self.equations(name),
                                   constraints=self.CASES[name]["constraints"],
                                   random_state=0)


def noisy_stick_slip_model():
    """The seed paper's noise study (20 dB on ``F_ext``) and its neural fit."""
    frame, truth = datasets.make_stick_slip(noise=20, noise_columns=INPUTS, random_state=0,
                                            return_truth=True)
    X, y = frame[["t", *STATES, *INPUTS]], frame[TARGETS]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = NeuralCCRegressor(equations=FUNCTIONAL, constraints=["f1 odd", "f2 odd"],
                                  random_state=0).fit(X, y)
    return X, y, truth, model


def _only_when_full(*params):
    """A benchmark's own setup that skips it unless the long cases are asked for."""
    if not FULL:
        raise NotImplementedError("a long case: SKLEARN_PYCC_BENCH_FULL=1 runs it")


class ConversionBenchmark:
    """``to_symbolic`` (post-SR, without and with the data) and ``to_interpolated``.

    The model is the neural fit of the stick-slip oscillator with 20 dB
    noise on the measured force (fitted once, in ``setup_cache``).
    """

    processes = 1
    repeat = (2, 3, 60.0)
    timeout = 300

    def setup_cache(self):
        return noisy_stick_slip_model()

    def setup(self, cached):
        self._limits = threadpool_limits(limits=1)
        self.X, self.y, self.truth, self.model = cached

    def teardown(self, cached):
        self._limits.restore_original_limits()

    def time_to_symbolic(self, cached):
        to_symbolic(self.model, random_state=0)

    def time_to_symbolic_with_data(self, cached):
        to_symbolic(self.model, self.X, self.y, random_state=0)

    # twenty seconds of searching: only with SKLEARN_PYCC_BENCH_FULL=1
    time_to_symbolic_with_data.setup = _only_when_full

    def time_to_interpolated(self, cached):
        to_interpolated(self.model)
