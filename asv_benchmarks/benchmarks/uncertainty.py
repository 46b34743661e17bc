"""Benchmarks of the uncertainty estimates: the covariance's cost, refits on resamples."""

from __future__ import annotations

import warnings

from threadpoolctl import threadpool_limits

from sklearn_pycc import PolyCCRegressor, datasets

FUNCTIONAL = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
CONSTRAINTS = ["f1 odd", "f2(0)=0"]


class Intervals:
    """Cost of the intervals relative to the plain fit (compare.py lines t and u).

    ``mode``: ``"covariance"`` is the default fit (the covariance comes with
    it; goal: at most 1.5 times a fit without it), ``"bootstrap"`` adds 100
    refits on block resamples with ``n_jobs=2`` (goal: under 5 s at 10,000
    samples).
    """

    param_names = ["mode"]
    params = (["covariance", "bootstrap"],)
    processes = 1
    repeat = (1, 3, 60.0)
    timeout = 300

    def setup(self, mode):
        self._limits = threadpool_limits(limits=1)
        warnings.simplefilter("ignore")
        frame = datasets.make_stick_slip(n_samples=10_000, t_span=(0, 100), noise=30,
                                         noise_columns=["x1_dot", "x2_dot"], random_state=0)
        self.X = frame[["x1", "x2", "F_ext"]]
        self.y = frame[["x1_dot", "x2_dot"]]
        extra = {"n_bootstrap": 100, "n_jobs": 2} if mode == "bootstrap" else {}
        self.settings = dict(equations=FUNCTIONAL, constraints=CONSTRAINTS, degree=7,
                             random_state=0, **extra)

    def teardown(self, mode):
        self._limits.restore_original_limits()

    def time_fit(self, mode):
        PolyCCRegressor(**self.settings).fit(self.X, self.y)

    def track_f1_band_width(self, mode):
        """Median width of the 95 % band of the friction curve."""
        curve = PolyCCRegressor(**self.settings).fit(self.X, self.y).cc_curves(
            n=41, level=0.95)["f1"]
        return float((curve.upper - curve.lower).median())
