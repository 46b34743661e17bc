"""The numbers a refinement of a fit moves, and how they make a model: :class:`Numbers`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..skeleton.system import CompiledSystem
from .problem import FitResult, Problem

__all__ = ["Numbers", "parameters_only"]


@dataclass
class Numbers:
    """A fit written as one vector of numbers, for a stage that moves them.

    Attributes
    ----------
    theta0 : ndarray
        Where the vector starts (the fit being refined).
    low, high : ndarray
        Each number's least and largest value.
    system_for : callable
        Vector -> compiled right-hand side.
    result_for : callable
        Vector -> :class:`FitResult` (the curves and parameters it makes,
        the backend's attributes updated; a covariance of the start dropped).
    labels : list of str
        The names of the numbers a covariance of the vector is given in
        (``a1``, ``f1[k]``).
    to_labels : ndarray of shape (len(labels), len(theta0))
        The linear map from the vector to the labelled numbers (about the start).
    typical : ndarray or None
        Each number's typical size, where its start does not tell it (a
        curve's coefficients start at an offset of 0); None: the start's.
    held : list of str
        Curves kept as the fit drew them.
    """

    theta0: np.ndarray
    low: np.ndarray
    high: np.ndarray
    system_for: Callable[[np.ndarray], CompiledSystem]
    result_for: Callable[[np.ndarray], FitResult]
    labels: list[str]
    to_labels: np.ndarray
    typical: np.ndarray | None = None
    held: list[str] = field(default_factory=list)

    def covariance(self, cov: np.ndarray | None) -> pd.DataFrame | None:
        """The covariance of the labelled numbers, given that of the vector."""
        if cov is None or not self.labels:
            return None
        out = self.to_labels @ cov @ self.to_labels.T
        return pd.DataFrame(0.5 * (out + out.T), index=self.labels, columns=self.labels)


def parameters_only(problem: Problem, result: FitResult) -> Numbers:
    """The free parameters of ``result`` as the vector; every curve held as it is."""
    free = problem.free_params
    fixed = dict(problem.fixed_params)
    functions = dict(result.functions)
    bounds = problem.bounds

    def values(theta) -> dict:
        return {**fixed, **dict(zip(free, (float(v) for v in theta)))}

    def result_for(theta) -> FitResult:
        # the covariance was of the numbers at the start, which the stage moved
        kept = {k: v for k, v in result.attributes.items() if k != "covariance_"}
        return FitResult(functions, {**result.params, **{a: values(theta)[a] for a in free}},
                         kept)

    return Numbers(
        theta0=np.array([result.params[a] for a in free], dtype=float),
        low=np.array([bounds.get(a, (-np.inf, np.inf))[0] for a in free], dtype=float),
        high=np.array([bounds.get(a, (-np.inf, np.inf))[1] for a in free], dtype=float),
        system_for=lambda theta: problem.skeleton.compile(functions, values(theta)),
        result_for=result_for, labels=list(free), to_labels=np.eye(len(free)),
        held=list(problem.free_functions))
