"""How long work grows with the record: the filter's fit, the loop, a neural model's simulation.

The long cases (the filter at 100,000 and 1,000,000 samples, the loop at
48,000) run only with ``SKLEARN_PYCC_BENCH_FULL=1``.
"""

from __future__ import annotations

import time
import warnings

from threadpoolctl import threadpool_limits

from sklearn_pycc import HypothesisLoop, NeuralCCRegressor, PolyCCRegressor, datasets

from .common import FULL

OSCILLATOR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]


class FilterFit:
    """``fit_mode="filter"`` of a pushed oscillator, position only at 40 dB, 100 samples a second.

    The goal: 1,000,000 samples in under 60 s on two cores. Over 150,000
    samples the search runs over an even share of the segments and the whole
    record gives one Newton step (``filter_["searched_segments"]``); at
    1,000,000: 39 s and 1.1 GiB peak.
    """

    param_names = ["n_samples"]
    params = ([10_000, *([100_000, 1_000_000] if FULL else [])],)
    processes = 1
    repeat = (1, 3, 60.0)
    timeout = 900

    def setup(self, n_samples):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        self.X = datasets.make_oscillator(hidden=[], disturbance=0.08, noise=40.0,
                                          noise_columns=["x1"],
                                          n_samples=n_samples, t_span=(0.0, n_samples / 100),
                                          random_state=0)[["t", "x1", "F_ext"]]

    def teardown(self, n_samples):
        self._limits.restore_original_limits()

    def _fit(self):
        return PolyCCRegressor(equations=OSCILLATOR, fit_mode="filter").fit(self.X)

    def time_fit(self, n_samples):
        self._fit()

    def peakmem_fit(self, n_samples):
        self._fit()

    def track_push_error(self, n_samples):
        """Relative error of the fitted push's intensity (the truth: 0.08)."""
        return abs(self._fit().process_noise_["x2"] / 0.08 - 1)


class LoopScaling:
    """``HypothesisLoop`` on a forced oscillator with hidden cubic stiffness, position only, 40 dB.

    Today: 4.2 s at 3,000 samples and 6.5 s at 12,000 on a quiet machine
    (``python asv_benchmarks/loop_scaling.py`` prints seconds per thousand).
    """

    param_names = ["n_samples"]
    params = ([3_000, 12_000, *([48_000] if FULL else [])],)
    processes = 1
    repeat = (1, 3, 60.0)
    timeout = 600

    def setup(self, n_samples):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        self.frame = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=n_samples,
                                              t_span=(0.0, n_samples / 50.0), noise=40.0,
                                              noise_columns=["x1"], random_state=0)
        self.frame = self.frame[["t", "x1", "F_ext"]]

    def teardown(self, n_samples):
        self._limits.restore_original_limits()

    def time_loop(self, n_samples):
        HypothesisLoop(PolyCCRegressor(equations=OSCILLATOR), self.frame).run(max_rounds=3)


class NeuralSimulation:
    """``simulate`` of the stick-slip model with neural curves beside its parametric twin.

    The twin is the same skeleton with the true laws written out (a plain
    numpy right-hand side); the goal: the neural model within 3 times its
    time.
    """

    processes = 1
    repeat = (3, 10, 10.0)

    def setup_cache(self):
        frame, truth = datasets.make_stick_slip(return_truth=True)
        X, y = frame[["x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            neural = NeuralCCRegressor(equations=["x1_dot = x2",
                                                  "x2_dot = F_ext - f1(x2) - f2(x1)"],
                                       constraints=["f1 odd", "f2 odd"],
                                       random_state=0).fit(X, y)
            numpy = PolyCCRegressor(equations=truth.parametric_equations).fit(X, y)
        return frame, truth, neural, numpy

    def setup(self, cached):
        self.frame, self.truth, self.neural, self.numpy = cached
        self.inputs = {"F_ext": self.truth.inputs["F_ext"]}

    def _simulate(self, model):
        return model.simulate(self.frame["t"], y0=self.truth.y0, inputs=self.inputs)

    def time_simulate_neural(self, cached):
        self._simulate(self.neural)

    def time_simulate_numpy(self, cached):
        self._simulate(self.numpy)

    def track_neural_over_numpy(self, cached):
        """The neural model's simulation time over the numpy one's, interleaved, median of 5."""
        ratios = []
        for _ in range(5):
            start = time.perf_counter()
            self._simulate(self.neural)
            middle = time.perf_counter()
            self._simulate(self.numpy)
            ratios.append((middle - start) / (time.perf_counter() - middle))
        return sorted(ratios)[len(ratios) // 2]
