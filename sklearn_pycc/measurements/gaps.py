"""Missing samples of a measured state: where they are, and a record read across them.

A NaN in a state's column is a sample the sensor did not give. The filter
(``fit_mode="filter"``) updates with the signals present and predicts
through the others; what reads the record before it (the smoothing that
starts each segment, the output-error start) reads a missing sample on the
straight line between its neighbours in time, and the filter is told which
samples those are (:func:`missing_samples`). The other fit modes split an
experiment at its gaps (:func:`split_at_gaps`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .columns import time_values
from .experiments import TIME, TRAJECTORY

__all__ = ["Split", "filled_across_gaps", "missing_samples", "split_at_gaps"]


def missing_samples(X, states: Sequence[str]) -> dict[str, np.ndarray]:
    """Each state column of ``X`` with missing samples (NaN), and where (a mask per row).

    A column that holds no number at all is not a state with gaps but one
    nobody measured; it is left out, as is a state ``X`` has no column for.
    """
    if not isinstance(X, pd.DataFrame):
        return {}
    out = {}
    for state in states:
        if state not in X.columns or not pd.api.types.is_numeric_dtype(X[state].dtype):
            continue
        missing = X[state].isna().to_numpy()
        if missing.any() and not missing.all():
            out[state] = missing
    return out


def filled_across_gaps(X: pd.DataFrame, missing: dict[str, np.ndarray]) -> pd.DataFrame:
    """A copy of ``X`` whose missing state samples lie on the line between their neighbours.

    The line is drawn in time (``t``, else the row's position) within each
    experiment (``trajectory``); before an experiment's first sample or
    after its last, the nearest one is held.

    Raises
    ------
    ValueError
        Where an experiment holds no sample of a state that others hold
        (nothing to draw the line from), naming both.
    """
    X = X.copy()
    position = (time_values(X[TIME]) if TIME in X.columns
                else np.arange(len(X), dtype=float))
    labels = X[TRAJECTORY].to_numpy() if TRAJECTORY in X.columns else np.zeros(len(X))
    codes, uniques = pd.factorize(labels, sort=False)
    for state, gaps in missing.items():
        values = X[state].to_numpy(dtype=float, copy=True)
        for k, label in enumerate(uniques):
            rows = np.flatnonzero(codes == k)
            have = rows[~gaps[rows]]
            if not len(have):
                where = f" of experiment {label!r}" if TRAJECTORY in X.columns else ""
                raise ValueError(f"X's column {state!r} holds no sample{where}: the filter "
                                 "reads a state through missing samples, not through a whole "
                                 "experiment without one")
            lost = rows[gaps[rows]]
            values[lost] = np.interp(position[lost], position[have], values[have])
        X[state] = values
    return X


@dataclass(frozen=True)
class Split:
    """A record split at its missing samples (:func:`split_at_gaps`).

    Attributes
    ----------
    X, y
        The rows kept (``y`` None where it was), each stretch between gaps
        its own experiment (``trajectory``).
    missing : int
        Rows left out for a missing sample.
    pieces : int
        Experiments the record's experiments became.
    alone : int
        Rows left out because no neighbour was kept beside them (a sample
        alone between two gaps tells no rate).
    """

    X: pd.DataFrame
    y: object
    missing: int
    pieces: int
    alone: int


def split_at_gaps(X: pd.DataFrame, y, missing: dict[str, np.ndarray]) -> Split:
    """``X`` (and ``y``) without the rows a state misses, each experiment split there.

    Every stretch of rows between missing samples becomes its own
    experiment: labelled by its position when ``X`` has no ``trajectory``,
    else ``"<label>, part <k>"`` where its experiment was split. A stretch
    of one row is left out too. ``t`` keeps its values, so a stretch's
    times are the record's.
    """
    gone = np.any(np.column_stack(list(missing.values())), axis=1)
    has_labels = TRAJECTORY in X.columns
    labels = X[TRAJECTORY].to_numpy() if has_labels else np.zeros(len(X), dtype=int)
    codes, uniques = pd.factorize(labels, sort=False)
    piece = np.full(len(X), -1)
    names: list = []
    for k, label in enumerate(uniques):
        rows = np.flatnonzero(codes == k)
        lost = gone[rows]
        stretch = np.cumsum(~lost & np.r_[True, lost[:-1]])  # a kept row after a gap starts one
        parts = [rows[~lost & (stretch == j)] for j in np.unique(stretch[~lost])]
        parts = [mine for mine in parts if len(mine) >= 2]
        for j, mine in enumerate(parts):
            piece[mine] = len(names)
            if not has_labels:
                names.append(len(names))
            else:
                names.append(f"{label}, part {j + 1}" if len(parts) > 1 else label)
    keep = piece >= 0
    out = X.iloc[keep].copy()
    out[TRAJECTORY] = [names[p] for p in piece[keep]]
    kept_y = None
    if y is not None:
        kept_y = y.iloc[keep] if isinstance(y, (pd.DataFrame, pd.Series)) else \
            np.asarray(y)[keep]
    return Split(out, kept_y, missing=int(gone.sum()), pieces=len(names),
                 alone=int((~gone & ~keep).sum()))
