"""Experiments of a tidy data set and the checks on their time grids."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["TIME", "TRAJECTORY", "Experiment", "split_experiments"]

#: the column names of time and of the experiment label in a tidy data set
TIME = "t"
TRAJECTORY = "trajectory"

#: relative spread of the time steps below which an experiment counts as evenly sampled
UNIFORM_RTOL = 1e-3
#: a pause in ``t`` longer than this many median steps ends a stretch of samples
GAP_FACTOR = 10.0


@dataclass(frozen=True)
class Experiment:
    """The rows of one experiment.

    Attributes
    ----------
    label : object
        Its value in the ``trajectory`` column (None without one).
    rows : ndarray of int
        Row positions in the data, in data order.
    t : ndarray or None
        Its times, when the data have a ``t`` column.
    """

    label: object
    rows: np.ndarray
    t: np.ndarray | None = None
    part: int = 0

    @property
    def where(self) -> str:
        """``" in experiment 'a'"``, or ``""`` for the only, unlabelled experiment."""
        text = "" if self.label is None else f" in experiment {self.label!r}"
        if self.part:
            text += f" (its stretch from t={self.t[0]:g}, after a pause in t)"
        return text

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return len(self.rows)

    def is_uniform(self) -> bool:
        """Whether the time steps are equal (to a relative ``UNIFORM_RTOL``)."""
        if self.t is None or len(self.t) < 3:
            return True
        steps = np.diff(self.t)
        return bool(np.ptp(steps) <= UNIFORM_RTOL * np.median(steps))


def split_experiments(n_samples: int, t: np.ndarray | None = None,
                      trajectory: np.ndarray | None = None) -> list[Experiment]:
    """Split rows into experiments and check each one's time grid.

    Parameters
    ----------
    n_samples : int
        Number of rows.
    t : ndarray, optional
        Times (finite floats).
    trajectory : ndarray, optional
        Experiment labels; rows sharing a label form one experiment, in data
        order (its rows need not be contiguous).

    Returns
    -------
    list of Experiment
        In the order of first appearance. A pause in ``t`` longer than
        ``GAP_FACTOR`` median steps (a block left out of a long record, a
        break in the recording) splits an experiment into stretches that are
        differentiated and simulated separately.

    Raises
    ------
    ValueError
        If a label is missing, or if ``t`` does not strictly increase within
        an experiment (repeated or going back); the message names the
        experiment, the row and the times.
    """
    if trajectory is None:
        groups = [(None, np.arange(n_samples))]
    else:
        labels = np.asarray(trajectory, dtype=object)
        missing = pd.isna(labels)
        if missing.any():
            row = int(np.flatnonzero(missing)[0])
            raise ValueError(f"the 'trajectory' column has no label at row {row}")
        codes, uniques = pd.factorize(labels, sort=False)
        groups = [(_plain(uniques[k]), np.flatnonzero(codes == k)) for k in range(len(uniques))]
    out = []
    for label, rows in groups:
        times = None if t is None else np.asarray(t, dtype=float)[rows]
        experiment = Experiment(label, rows, times)
        if times is None:
            out.append(experiment)
            continue
        _check_increasing(experiment)
        out.extend(_stretches(experiment))
    return out


def _plain(label):
    return label.item() if isinstance(label, np.generic) else label


def _stretches(experiment: Experiment) -> list[Experiment]:
    if experiment.n_samples < 4:
        return [experiment]
    steps = np.diff(experiment.t)
    cuts = np.flatnonzero(steps > GAP_FACTOR * np.median(steps)) + 1
    if cuts.size == 0:
        return [experiment]
    bounds = [0, *cuts.tolist(), experiment.n_samples]
    return [Experiment(experiment.label, experiment.rows[a:b], experiment.t[a:b], part)
            for part, (a, b) in enumerate(itertools.pairwise(bounds))]


def _check_increasing(experiment: Experiment) -> None:
    steps = np.diff(experiment.t)
    bad = np.flatnonzero(steps <= 0)
    if bad.size == 0:
        return
    k = int(bad[0])
    row, before = int(experiment.rows[k + 1]), int(experiment.rows[k])
    t_now, t_before = experiment.t[k + 1], experiment.t[k]
    what = "repeats" if t_now == t_before else "goes back from"
    raise ValueError(
        f"t must strictly increase within each experiment: at row {row}{experiment.where} "
        f"t={t_now:g} {what} t={t_before:g} at row {before}. Sort each experiment by time, "
        "drop duplicated samples, or label separate experiments in a 'trajectory' column")
