"""Base classes shared by the benchmarks.

The layout follows the idea of scikit-learn's asv suite: a benchmark class
mixes :class:`Estimator` (what to measure on an estimator) with
:class:`Benchmark` (how asv measures it) and only says how to build its
data and its estimator for one combination of ``params``::

    class PolyCC(Estimator, Benchmark):
        param_names = ["case"]
        params = (["a", "b"],)

        def make_data(self, params):
            return Bunch(X=..., y=...)

        def make_estimator(self, params):
            return PolyCCRegressor(...)

        def setup_cache(self):
            return self.fit_every_case()

Every estimator is fitted once, in ``setup_cache`` (asv runs it once per
class and hands its pickled result to every benchmark), so ``time_predict``
and the ``track_*`` methods do not pay for fitting. Each concrete class
writes ``def setup_cache(self): return self.fit_every_case()`` itself: asv
tells caches apart by where ``setup_cache`` is written.
"""

from __future__ import annotations

import itertools
import os
import time
import warnings
from abc import ABC, abstractmethod
from contextlib import suppress

from sklearn.base import clone
from threadpoolctl import threadpool_limits

#: the long cases (a million samples, a loop at 100,000) run only with
#: SKLEARN_PYCC_BENCH_FULL=1 (``make bench-full``); asv hands the environment on
FULL = os.environ.get("SKLEARN_PYCC_BENCH_FULL") == "1"


class Benchmark(ABC):
    """How asv measures: wall-clock timer, few processes, short runs.

    The machine the suite runs on is small and shared; every benchmark is
    kept to well under a second per call and asv to one process.
    """

    timer = time.perf_counter
    # BLAS/OpenMP threads while benchmarking (None: the libraries' own
    # setting). On a small shared machine, waking worker threads for every
    # small matrix call costs milliseconds at random; one thread measures
    # the code rather than the scheduler.
    blas_threads: int | None = 1
    processes = 1
    # (min_repeat, max_repeat, max_time in seconds) of each timing benchmark
    repeat = (3, 10, 5.0)
    sample_time = 0.05
    warmup_time = 0.1
    timeout = 120

    @property
    @abstractmethod
    def params(self):
        """Values of every parameter (a tuple of lists)."""


class Estimator(ABC):
    """Benchmarks of an estimator's ``fit``, ``predict`` and ``score``.

    Subclasses define ``param_names``, ``params``, :meth:`make_data` and
    :meth:`make_estimator`.
    """

    param_names: tuple | list = ()

    @abstractmethod
    def make_data(self, params):
        """Data for one combination of ``params``: a Bunch with at least ``X`` and ``y``."""

    @abstractmethod
    def make_estimator(self, params):
        """The (unfitted) estimator for one combination of ``params``."""

    def skip(self, params) -> bool:
        """True where a combination of ``params`` makes no sense (it is then skipped)."""
        return False

    def combinations(self):
        """Every combination of ``params`` as a tuple, in asv's order."""
        return list(itertools.product(*self.params))

    def fit_every_case(self):
        """Fit every estimator once (the body of each class's ``setup_cache``).

        asv keys a ``setup_cache`` by the file and line where it is written,
        not by class: one defined here would be run for the first class only
        and its result handed to every other. Each concrete class therefore
        writes its own one-line ``setup_cache`` returning this.
        """
        fitted = {}
        for params in self.combinations():
            if self.skip(params):
                continue
            data = self.make_data(params)
            estimator = self.make_estimator(params)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                estimator.fit(data.X, data.y)
            fitted[params] = (data, estimator)
        return {"owner": type(self).__qualname__, "fitted": fitted}

    def setup(self, cache, *params):
        """Load the data and the fitted estimator of this combination of ``params``."""
        if cache["owner"] != type(self).__qualname__:
            raise RuntimeError(f"{type(self).__qualname__} got the cache of {cache['owner']}: "
                               "define setup_cache in the class itself")
        fitted = cache["fitted"]
        if params not in fitted:
            raise NotImplementedError(f"skipped: {params}")
        if getattr(self, "blas_threads", None):
            # the limit holds for the rest of this benchmark process
            self._limits = threadpool_limits(limits=self.blas_threads)
        self.data, self.estimator = fitted[params]
        self.unfitted = clone(self.estimator)
        # not timed: the first prediction after unpickling compiles the model, and
        # the first fit in a process parses the skeleton and starts torch (cached
        # after); a fit on a few rows does that at a fraction of a full fit's cost
        self.estimator.predict(self.data.X[:2])
        self._warm_up()

    #: rows of the warm-up fit in ``setup`` (0: none)
    warm_up_rows = 200

    def _warm_up(self):
        """Fit a fresh copy on the first :attr:`warm_up_rows` rows, whatever comes of it."""
        rows = self.warm_up_rows
        if not rows:
            return
        X, y = self.data.X, self.data.y
        # too few rows for a skeleton may raise: the caches are warm all the same
        with warnings.catch_warnings(), suppress(ValueError, ArithmeticError, RuntimeError):
            warnings.simplefilter("ignore")
            clone(self.unfitted).fit(X[:rows], None if y is None else y[:rows])

    def _fit_fresh(self):
        """Fit a fresh copy of the estimator (warnings such as rank deficiency muted)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return clone(self.unfitted).fit(self.data.X, self.data.y)

    def time_fit(self, fitted, *params):
        self._fit_fresh()

    def peakmem_fit(self, fitted, *params):
        self._fit_fresh()

    def time_predict(self, fitted, *params):
        self.estimator.predict(self.data.X)

    def track_train_score(self, fitted, *params):
        return float(self.estimator.score(self.data.X, self.data.y))

    track_train_score.unit = "R2"
