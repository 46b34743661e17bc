"""Benchmarks of laboratory records: position-only fits at real sizes, sampled inputs."""

from __future__ import annotations

import warnings

from threadpoolctl import threadpool_limits

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, Skeleton, datasets, diagnose

from .common import FULL


class _Resonator:
    """Positions of the resonator (a hardening oscillator, 60 dB) at a size of record."""

    param_names = ["n_samples"]
    processes = 1
    repeat = (1, 3, 60.0)
    timeout = 300

    def setup(self, n_samples):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        self.frame, self.truth = datasets.make_resonator(n_samples=n_samples, random_state=0,
                                                         return_truth=True)

    def teardown(self, n_samples):
        self._limits.restore_original_limits()


class PositionOnly(_Resonator):
    """Position-only fit (``differentiation="auto"``) of the resonator.

    The goal: linear in ``n_samples`` (100,000 and a million samples only with
    ``SKLEARN_PYCC_BENCH_FULL=1``; compare.py line p times 100,000).
    """

    params = ([10_000, *([100_000, 1_000_000] if FULL else [])],)

    def _fit(self):
        return PolyCCRegressor(equations=self.truth.equations).fit(self.frame)

    def time_fit(self, n_samples):
        self._fit()

    def peakmem_fit(self, n_samples):
        self._fit()

    def track_stiffness_error(self, n_samples):
        """Relative error of the fitted linear stiffness ``a3``."""
        return abs(self._fit().params_["a3"] / self.truth.params["a3"] - 1)


class PositionOnlyDiagnosis(_Resonator):
    """``diagnose`` of the linear skeleton fitted to the resonator's positions.

    The goal: fit plus diagnose under 3 s at 100,000 samples (compare.py line p).
    """

    params = ([10_000, *([100_000] if FULL else [])],)

    def setup(self, n_samples):
        super().setup(n_samples)
        self.model = PolyCCRegressor(equations=self.truth.base_equations).fit(self.frame)

    def time_diagnose(self, n_samples):
        diagnose(self.model, self.frame)


class SampledInput:
    """``simulate`` with a 100,000-sample input array (compare.py lines n and o give its ratio
    to a hand-written numpy RK4 at the sample rate, measured side by side)."""

    processes = 1
    repeat = (1, 3, 60.0)
    timeout = 300

    def setup(self):
        if not FULL:
            raise NotImplementedError("a long case: SKLEARN_PYCC_BENCH_FULL=1 runs it")
        self._limits = threadpool_limits(limits=1)
        frame, self.truth = datasets.make_resonator(n_samples=100_000, noise=None,
                                                    random_state=0, return_truth=True)
        self.skeleton = Skeleton(self.truth.equations)
        self.t, self.u = frame["t"].to_numpy(), frame["u"].to_numpy()

    def teardown(self):
        limits = getattr(self, "_limits", None)  # asv tears down a skipped setup too
        if limits is not None:
            limits.restore_original_limits()

    def time_simulate(self):
        self.skeleton.simulate(self.t, [0.0, 0.0], params=self.truth.params,
                               inputs={"u": self.u})

    def time_simulate_rtol_1e3(self):
        self.skeleton.simulate(self.t, [0.0, 0.0], params=self.truth.params,
                               inputs={"u": self.u}, rtol=1e-3)


class AxisLoop:
    """``HypothesisLoop`` (3 rounds) on a closed-loop axis, position only.

    The goal: under 10 s at 100,000 samples (compare.py line q measures it
    with its peak memory).
    """

    param_names = ["n_samples"]
    params = ([10_000, *([100_000] if FULL else [])],)
    processes = 1
    repeat = (1, 3, 60.0)
    timeout = 300

    def setup(self, n_samples):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        self.frame, self.truth = datasets.make_positioning_axis(
            n_samples=n_samples, t_span=(0, (n_samples - 1) / 1000), random_state=0,
            return_truth=True)

    def teardown(self, n_samples):
        self._limits.restore_original_limits()

    def _run(self):
        estimator = PolyCCRegressor(equations=self.truth.base_equations)
        return HypothesisLoop(estimator, self.frame).run(max_rounds=3)

    def time_loop(self, n_samples):
        self._run()

    def peakmem_loop(self, n_samples):
        self._run()

    def track_mass_error(self, n_samples):
        """Relative error of the final model's ``a1`` (one over the mass)."""
        return abs(self._run().model.params_["a1"] / self.truth.params["a1"] - 1)


class UnmeasuredTank:
    """The two-tank cascade logged every 4 s, the upper level unmeasured (1,024 samples).

    Below the tanks' rims (the skeleton has no overflow); compare.py line w
    gives the parameter errors and the validation ratio beside the time.
    """

    processes = 1
    repeat = (1, 3, 60.0)
    timeout = 300
    skeleton = ["x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = 1.25 a2 sqrt(x1) - a3 sqrt(x2)"]

    def setup(self):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        self.frame, self.truth = datasets.make_two_tanks(rims=(100.0, 100.0), random_state=0,
                                                         return_truth=True)

    def teardown(self):
        self._limits.restore_original_limits()

    def _fit(self):
        return PolyCCRegressor(equations=self.skeleton,
                               constraints=["a1 >= 0", "a2 >= 0", "a3 >= 0"]).fit(self.frame)

    def time_fit(self):
        self._fit()

    def track_outflow_error(self):
        """Relative error of the upper tank's outflow coefficient ``a2``."""
        return abs(self._fit().params_["a2"] / self.truth.params["a2"] - 1)


class UnmeasuredTankLoop:
    """The loop on the overflowing two-tank cascade, the upper level unmeasured.

    From the Torricelli skeleton without limits (``a1``-``a4`` free) on 1,024
    samples every 4 s; the goal is 30 s. compare.py line w gives the effects
    it names and its final model's validation ratio beside the time.
    """

    processes = 1
    repeat = (1, 2, 300.0)
    timeout = 600
    skeleton = ["x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a3 sqrt(x1) - a4 sqrt(x2)"]

    def setup(self):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        self.frame = datasets.make_two_tanks(random_state=0)

    def teardown(self):
        self._limits.restore_original_limits()

    def _run(self):
        return HypothesisLoop(PolyCCRegressor(equations=self.skeleton), self.frame).run()

    def time_loop(self):
        self._run()

    def track_rounds(self):
        """Rounds until nothing is missing (3: the overflow of each tank, then stop)."""
        return len(self._run().rounds)


class CascadeLawLoop:
    """The loop from linear outflows on a cascade below its rims, the upper level unmeasured.

    1,024 samples every 4 s, the states told as levels; the loop names
    Torricelli's law in the upper tank's equation, then stops. Goal: 60 s.
    """

    processes = 1
    repeat = (1, 2, 300.0)
    timeout = 600
    skeleton = ["x1_dot = a1 u - a2 x1", "x2_dot = a3 x1 - a4 x2"]

    def setup(self):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        self.frame = datasets.make_two_tanks(n_samples=1024, rims=(100.0, 100.0),
                                             random_state=0)

    def teardown(self):
        self._limits.restore_original_limits()

    def _run(self):
        estimator = PolyCCRegressor(equations=self.skeleton,
                                    constraints=["a1 >= 0", "a2 >= 0", "a3 >= 0", "a4 >= 0"])
        return HypothesisLoop(estimator, self.frame,
                              quantities={"x1": "level", "x2": "level"}).run()

    def time_loop(self):
        self._run()

    def track_rounds(self):
        """Rounds until nothing is missing (2: Torricelli's law, then stop)."""
        return len(self._run().rounds)
