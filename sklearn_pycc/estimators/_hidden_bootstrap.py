"""Refits on resamples of a fit with unmeasured states: the record's noise drawn again.

A record with an unmeasured state cannot be cut into blocks and refitted
block by block (each block would need its own initial hidden states, which
a short stretch does not fix). Instead the fit's own simulation of what
was measured is kept, and its errors are drawn again in blocks of
consecutive samples within each experiment (a moving-block bootstrap of
the residuals, so coloured noise keeps its colour). Each resample is then
refitted by whole-record output error, started from the fit, under the
hold the fit chose. The spread of those refits is how far the noise moves
the estimate. The linearised covariance understates it where the error is
far from quadratic in the parameters, as for two stages of a cascade with
nearly the same speed.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
from joblib import Parallel, delayed

from .._blocks import block_length, draw_blocks
from ._hidden import _ESCAPED, WholeRecord, single_shooting
from ._resampling import Member
from ._setup import Problem

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
        z = np.r_[[float(params[a]) for a in names], np.asarray(first, dtype=float).ravel()]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            scaled = residuals(z)
        if np.any(scaled == _ESCAPED):
            raise ValueError("the fitted model escapes along the record, so it has no errors "
                             "to draw again: fit with n_bootstrap=0")
        valid = whole.windows.valid
        m = whole.targets.shape[-1]
        self.problem, self.whole = problem, whole
        # errors as measured minus simulated, in the record's units, one row per valid sample
        self.errors = -scaled.reshape(-1, m) * whole.scale
        self.rows = whole.windows.rows[valid]
        counts = valid.sum(axis=1)
        ends = np.cumsum(counts)
        self.runs = [slice(int(end - count), int(end)) for count, end in zip(counts, ends)
                     if count >= 2]
        self.block = block_length(self.errors, self.runs)
        self.measured = [whole.states[q] for q in whole.index]

    def describe(self) -> str:
        """How the resamples are drawn, in words."""
        return (f"the fit's simulation errors drawn again in blocks of {self.block} consecutive "
                f"samples within each of the {len(self.runs)} experiment(s), each resample "
                "refitted by whole-record output error from the fit")

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """One resample's errors: for each valid sample, the row of ``errors`` it takes."""
        picks = np.arange(len(self.errors))
        for run in self.runs:
            picks[run] = np.concatenate(draw_blocks(rng, [picks[run]], self.block))
        return picks

    def resampled(self, picks: np.ndarray) -> Problem:
        """The problem with the fit's simulation plus the errors at ``picks``."""
        # measured = simulated + error, so the resample is measured - error + drawn error
        shift = self.errors[picks] - self.errors
        measured = dict(self.problem.measured)
        observed = dict(self.problem.observed)
        columns = [*self.measured, *self.whole.outputs]
        for j, name in enumerate(columns):
            table = measured if j < len(self.measured) else observed
            values = np.array(table[name], dtype=float)
            values[self.rows] += shift[:, j]
            table[name] = values
        return replace(self.problem, measured=measured, observed=observed, covariance=False)


def _refit(resampler: NoiseResampler, picks: np.ndarray, params: dict, first: np.ndarray,
           substeps: int, iterations: int, functions: dict) -> Member | str:
    """One refit from the fit; the reason in words when it fails."""
    with warnings.catch_warnings():  # the full fit has said what there is to say
        warnings.simplefilter("ignore")
        try:
            found, _, _, _ = single_shooting(resampler.resampled(picks), params, first,
                                             substeps, iterations)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError, RuntimeError) as error:
            return f"{type(error).__name__}: {error}"
    return Member(dict(functions), {k: float(v) for k, v in found.items()})


def hidden_members(problem: Problem, params: dict, functions: dict, attributes: dict, n: int,
                   seed: int, n_jobs, iterations: int
                   ) -> tuple[list[Member], list[str], str]:
    """``n`` refits of an output-error fit with unmeasured states on redrawn noise.

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
    outcomes = Parallel(n_jobs=n_jobs)(
        delayed(_refit)(resampler, picks, params, first, substeps, iterations, functions)
        for picks in draws)
    members = [o for o in outcomes if isinstance(o, Member)]
    failures = [o for o in outcomes if not isinstance(o, Member)]
    return members, failures, resampler.describe()
