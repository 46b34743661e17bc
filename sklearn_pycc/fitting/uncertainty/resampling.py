"""Refits on resamples of a record that respect time.

Samples of a record are not independent: noise is coloured and estimated
derivatives are smoothed, so resampling single rows would understate the
spread of the estimates. A resample is instead made of whole blocks of
consecutive samples drawn within each experiment (the moving-block
bootstrap), each block long enough to hold the record's correlation; when
the record has many experiments, whole experiments are drawn instead. Each
block becomes an experiment of its own, so nothing joins the end of one
block to the start of the next: derivatives, shooting segments and
simulations stay within a block.

The seeds of the resamples and of the refits are drawn in the parent from
``random_state`` before any work is handed out, so ``n_jobs=1`` and
``n_jobs=2`` give the same members. The first refits run in the parent and
are timed: when the others would take longer than :data:`LONG_REFITS`
seconds, a warning says how long before they start (``verbose`` shows a
progress bar instead).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from joblib import Parallel, delayed, effective_n_jobs

from ..._utils.blocks import MIN_EXPERIMENTS, block_length, draw_blocks, segments
from ..._utils.progress import duration
from ...measurements.columns import FitData
from ...measurements.experiments import Experiment
from ..problem import FitResult, Problem

__all__ = ["LONG_REFITS", "REFIT_FAILURES", "Member", "Resampler", "fit_members",
           "run_refits"]


class Refitted(Protocol):
    """What a refit on a resample needs of a backend (an ``estimators.backend.Backend``)."""

    resample_in: str

    def reseeded(self, seed: int) -> Refitted:
        """The backend with its randomness seeded by ``seed``."""

    def estimate(self, problem: Problem, *, shooting_window: int,
                 shooting_iterations: int) -> FitResult:
        """The backend's fit of ``problem``, output error included where asked."""


#: what a refit on a resample may meet: a failure to count, not to raise
REFIT_FAILURES = (ValueError, ArithmeticError, np.linalg.LinAlgError, RuntimeError)
#: refits expected to take longer than this many seconds are announced before they start
LONG_REFITS = 60.0
#: refits run and timed in the parent, to estimate how long the others take
TIMED_REFITS = 2

@dataclass
class Member:
    """One refit on a resample: its curves (numpy callables) and free parameters."""

    functions: dict
    params: dict


class Resampler:
    """Draws resamples of a fitting problem's rows as blocks of consecutive samples.

    Parameters
    ----------
    problem : Problem
        The fitted problem.
    residuals : ndarray of shape (n_samples, k)
        The fit's residuals on the problem's rows: their correlation sets
        the block length.
    min_block : int, default=2
        Shortest block (an output-error fit needs blocks longer than its
        shooting segments).
    """

    def __init__(self, problem: Problem, residuals: np.ndarray, min_block: int = 2) -> None:
        n_full = _n_full(problem)
        self.rows = _data_rows(problem)  # full-record row of each data row
        self.experiments = _full_segments(problem, n_full)
        self.whole = len(self.experiments) >= MIN_EXPERIMENTS
        if self.whole:
            self.block = max(len(e) for e in self.experiments)
        else:
            residuals = np.asarray(residuals, dtype=float).reshape(len(self.rows), -1)
            self.block = block_length(residuals, segments(len(residuals),
                                                          problem.data.trajectory), min_block)

    def describe(self) -> str:
        """How the resamples are drawn, in words."""
        if self.whole:
            return f"whole experiments ({len(self.experiments)}) drawn with replacement"
        return (f"blocks of {self.block} consecutive samples drawn within each of the "
                f"{len(self.experiments)} experiment(s)")

    def draw(self, rng: np.random.Generator) -> list[np.ndarray]:
        """One resample: a list of blocks, each an array of full-record rows."""
        if self.whole:
            picks = rng.integers(0, len(self.experiments), len(self.experiments))
            return [self.experiments[k] for k in picks]
        return [b for b in draw_blocks(rng, self.experiments, self.block) if len(b) >= 2]


def _n_full(problem: Problem) -> int:
    if problem.experiments is None:
        return problem.data.n_samples
    return int(max(int(e.rows.max()) + 1 for e in problem.experiments if len(e.rows)))


def _data_rows(problem: Problem) -> np.ndarray:
    rows = problem.rows
    return np.arange(problem.data.n_samples) if rows is None else np.asarray(rows)


def _full_segments(problem: Problem, n_full: int) -> list[np.ndarray]:
    """Rows of each experiment in the full record (of the data when none are known)."""
    if problem.experiments is not None:
        return [np.asarray(e.rows) for e in problem.experiments if len(e.rows) >= 2]
    return [np.arange(s.start, s.stop) for s in segments(n_full, problem.data.trajectory)
            if s.stop - s.start >= 2]


def resampled_problem(problem: Problem, blocks: list[np.ndarray]) -> Problem:
    """``problem`` on the rows of ``blocks``, each block an experiment of its own."""
    full = np.concatenate(blocks)
    block_of = np.repeat(np.arange(len(blocks)), [len(b) for b in blocks])
    # data rows (the trusted ones) among the drawn full-record rows
    position = np.full(_n_full(problem), -1)
    position[_data_rows(problem)] = np.arange(problem.data.n_samples)
    drawn = position[full]
    kept = drawn >= 0
    data_rows = drawn[kept]
    data = FitData({name: values[data_rows] for name, values in problem.data.columns.items()},
                   int(data_rows.size), block_of[kept])
    experiments = None
    if problem.experiments is not None:
        times = np.full(len(position), np.nan)
        for e in problem.experiments:
            if e.t is not None:
                times[e.rows] = e.t
        experiments, offset = [], 0
        for k, rows in enumerate(blocks):
            t = times[rows]
            experiments.append(Experiment(k, np.arange(offset, offset + len(rows)),
                                          None if np.isnan(t).any() else t))
            offset += len(rows)

    def cut(values: dict) -> dict:
        return {name: column[full] for name, column in values.items()}

    return replace(problem, data=data, y=problem.y[data_rows], experiments=experiments,
                   measured=cut(problem.measured), smoothed=cut(problem.smoothed),
                   signals=cut(problem.signals),
                   rows=None if kept.all() else np.flatnonzero(kept), covariance=False)


def _fit_one(backend: Refitted, problem: Problem, blocks: list[np.ndarray], seed: int,
             window: int, *, iterations: int) -> Member | str:
    """Refit on one resample; the reason in words when it fails."""
    member = backend.reseeded(seed)
    sample = resampled_problem(problem, blocks)
    with warnings.catch_warnings():  # the full fit has said what there is to say
        warnings.simplefilter("ignore")
        try:
            result: FitResult = member.estimate(sample, shooting_window=window,
                                                shooting_iterations=iterations)
        except REFIT_FAILURES as error:
            return f"{type(error).__name__}: {error}"
    return Member(dict(result.functions), {k: float(v) for k, v in result.params.items()})


def fit_members(backend: Refitted, problem: Problem, resampler: Resampler, n: int, seed: int, *,
                n_jobs, window: int, iterations: int, verbose: bool = False
                ) -> tuple[list[Member], list[str]]:
    """``n`` refits by ``backend`` on resamples, in parallel; and the failures' reasons.

    The resamples and the refits' seeds are drawn here from ``seed``, so the
    members do not depend on ``n_jobs``; ``verbose`` shows their progress.
    """
    rng = np.random.default_rng(seed)
    draws = [(resampler.draw(rng), int(rng.integers(0, 2**31 - 1))) for _ in range(n)]
    return run_refits([delayed(_fit_one)(backend, problem, blocks, member_seed, window,
                                         iterations=iterations) for blocks, member_seed in draws],
                      n_jobs, backend.resample_in, verbose=verbose)


def run_refits(calls: list, n_jobs, prefer: str, *, verbose: bool = False
               ) -> tuple[list[Member], list[str]]:
    """Run delayed refits in parallel: the members, and the failures' reasons in words.

    The first :data:`TIMED_REFITS` run here and are timed; when the others
    would take longer than :data:`LONG_REFITS` seconds, a warning says how
    long before they start, unless ``verbose``, which shows a progress bar.
    """
    timed = calls[:TIMED_REFITS]
    start = time.perf_counter()
    outcomes = [function(*args, **kwargs) for function, args, kwargs in timed]
    each = (time.perf_counter() - start) / max(len(timed), 1)
    rest = calls[len(timed):]
    workers = max(1, min(effective_n_jobs(n_jobs), len(rest)))
    expected = each * len(rest) / workers
    if rest and expected > LONG_REFITS and not verbose:
        warnings.warn(
            f"{len(calls):,} refits on resamples: the first took {each:.2g} s each, so the "
            f"other {len(rest):,} take about {duration(expected)} on {workers} worker(s). "
            "Fewer refits finish sooner (n_bootstrap=200 sets a standard error to within "
            "about 5 %), as do more processes (n_jobs)", UserWarning, stacklevel=6)
    bar = _progress(len(calls), len(timed)) if verbose and rest else None
    try:
        for outcome in Parallel(n_jobs=n_jobs, prefer=prefer, return_as="generator")(rest):
            outcomes.append(outcome)
            if bar is not None:
                bar.update()
    finally:
        if bar is not None:
            bar.close()
    members = [o for o in outcomes if isinstance(o, Member)]
    failures = [o for o in outcomes if not isinstance(o, Member)]
    return members, failures


def _progress(total: int, done: int):
    """A tqdm bar over the refits, ``done`` of them already counted."""
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=done, unit="refit", desc="n_bootstrap")
