"""Refits on resamples of a fit with unmeasured states: the record's noise drawn again.

A record with an unmeasured state cannot be cut into blocks and refitted
block by block (each block would need its own initial hidden states, which
a short stretch does not fix). Instead the fit's own simulation of what
was measured is kept, and its errors are drawn again in blocks of
consecutive samples within each experiment, the experiment read as a
circle (a moving-block bootstrap of the residuals, so coloured noise keeps
its colour, and an experiment no longer than a block is still redrawn).
Each resample is then refitted by whole-record output error, started from
the fit, under the hold the fit chose. The spread of those refits is how
far the noise moves the estimate near the fit; a second minimum far from
it, as where a cascade's two stages have nearly the same speed, is not
seen.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
from joblib import delayed

from ..._utils.blocks import block_length
from ..output_error.hidden import single_shooting
from ..output_error.whole_record import ESCAPED, WholeRecord
from ..problem import Problem
from .resampling import REFIT_FAILURES, Member, run_refits

__all__ = ["NoiseResampler", "hidden_members"]


class NoiseResampler:
    """Draws records that differ from a fitted one only in their noise.

    Parameters
    ----------
    problem : Problem
        The fitted problem, under the hold the fit chose.
    params : dict
        The fitted free parameters.
    first : ndarray of shape (n_experiments, n_states)
        The fitted initial states.
    substeps : int
        Integration substeps per sample of the fit.
    """

    def __init__(self, problem: Problem, params: dict, first: np.ndarray, substeps: int) -> None:
        whole = WholeRecord(problem)
        whole.windows.substeps = int(substeps)
        names, residuals, _, _ = whole.unknowns(first.shape)
        z = whole.packed([float(params[a]) for a in names], first)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            scaled = residuals(z)
        if np.any(scaled == ESCAPED):
            raise ValueError("the fitted model escapes along the record, so it has no errors "
                             "to draw again: fit with n_bootstrap=0")
        valid = whole.windows.valid
        scaled = scaled.reshape(-1, whole.targets.shape[-1])
        self.problem = problem
        # errors as measured minus simulated, in the record's units, one row per valid sample
        self.errors = -scaled * whole.scale
        self.rows = whole.windows.rows[valid]
        ends = np.cumsum(valid.sum(axis=1))
        self.runs = [np.arange(end - count, end)
                     for count, end in zip(valid.sum(axis=1), ends) if count >= 2]
        if not self.runs:
            raise ValueError("no experiment has two measured samples to draw the errors of "
                             "again: fit with n_bootstrap=0")
        self.columns = [whole.states[q] for q in whole.index] + list(whole.outputs)
        self.n_measured = len(whole.index)
        # the block from the errors in units of each signal, as the fit weighs them
        self.block = block_length(-scaled, [slice(int(r[0]), int(r[-1]) + 1)
                                            for r in self.runs])

    def describe(self) -> str:
        """How the resamples are drawn, in words."""
        return (f"the fit's simulation errors drawn again in blocks of {self.block} consecutive "
                f"samples within each of the {len(self.runs)} experiment(s), each resample "
                "refitted by whole-record output error from the fit")

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """One resample: for each valid sample, the row of ``errors`` it takes.

        Each experiment is read as a circle, so a block may wrap from its
        end to its start, and one no longer than a block is still shifted.
        """
        picks = np.arange(len(self.errors))
        for run in self.runs:
            size = min(self.block, len(run))
            starts = rng.integers(0, len(run), -(-len(run) // size))
            offsets = (starts[:, None] + np.arange(size)).ravel()[: len(run)] % len(run)
            picks[run] = run[offsets]
        return picks

    def resampled(self, picks: np.ndarray) -> Problem:
        """The problem with the fit's simulation plus the errors at ``picks``."""
        # measured = simulated + error, so the resample is measured - error + drawn error
        shift = self.errors[picks] - self.errors
        measured = dict(self.problem.measured)
        observed = dict(self.problem.observed)
        for j, name in enumerate(self.columns):
            table = measured if j < self.n_measured else observed
            values = np.array(table[name], dtype=float)
            values[self.rows] += shift[:, j]
            table[name] = values
        return replace(self.problem, measured=measured, observed=observed)

    def escaped(self, nrmse: float) -> bool:
        """Whether a refit's whole-record error holds a sample where it escaped."""
        # one escaped sample alone adds ESCAPED squared to the errors' sum of squares
        return not nrmse < ESCAPED / np.sqrt(self.errors.size)


def _refit(resampler: NoiseResampler, picks: np.ndarray, params: dict, first: np.ndarray,
           substeps: int, *, iterations: int, functions: dict) -> Member | str:
    """One refit from the fit; the reason in words when it fails."""
    with warnings.catch_warnings():  # the full fit has said what there is to say
        warnings.simplefilter("ignore")
        try:
            found, _, nrmse, _ = single_shooting(resampler.resampled(picks), params, first,
                                                 substeps, iterations)
        except REFIT_FAILURES as error:
            return f"{type(error).__name__}: {error}"
    if resampler.escaped(nrmse):
        return "SimulationError: the refit's model escapes along the record"
    return Member(dict(functions), {k: float(v) for k, v in found.items()})


def hidden_members(problem: Problem, params: dict, functions: dict, attributes: dict, n: int, *,
                   seed: int, n_jobs, iterations: int, verbose: bool = False
                   ) -> tuple[list[Member], list[str], str]:
    """``n`` refits of an output-error fit with unmeasured states on redrawn noise.

    The refits run in processes (``n_jobs``): their integration holds
    Python's lock. Each is a whole-record fit (about half a second for two
    tanks of 500 samples): when they would take long, a warning says how
    long before they start, and ``verbose`` shows their progress
    (:func:`~sklearn_pycc.fitting.uncertainty.resampling.run_refits`).

    Returns
    -------
    members : list of Member
    failures : list of str
        Why each refit that failed did.
    description : str
        How the resamples were drawn.
    """
    info = attributes["shooting_"]
    first = np.asarray(info["initial_states"], dtype=float)
    substeps = int(info["substeps"])
    fitted = replace(problem, input_hold=attributes.get("input_hold_", problem.input_hold),
                     hold_chosen=False)
    resampler = NoiseResampler(fitted, params, first, substeps)
    rng = np.random.default_rng(seed)
    draws = [resampler.draw(rng) for _ in range(n)]
    members, failures = run_refits(
        [delayed(_refit)(resampler, picks, params, first, substeps, iterations=iterations,
                         functions=functions)
         for picks in draws], n_jobs, "processes", verbose=verbose)
    return members, failures, resampler.describe()
