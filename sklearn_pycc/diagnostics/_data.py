"""Measurements lined up against a fitted model: columns, experiments, derivatives."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..measurements import (
    estimate_states,
    kinematic_chains,
    resolve_differentiation,
    split_experiments,
)
from ..measurements.experiments import TIME, TRAJECTORY

__all__ = ["Measurements", "read_measurements"]



@dataclass
class Measurements:
    """The data a diagnosis compares the model with.

    Attributes
    ----------
    X : DataFrame
        The user's columns (never modified).
    columns : dict
        Name -> float array: states, inputs, ``t`` and the measured
        derivatives ``NAME_dot``.
    derivatives : ndarray of shape (n_samples, n_states)
        Measured (or estimated) derivatives, in equation order.
    groups : list of (label, ndarray of int)
        Row positions of each experiment, in the order of the data.
    has_time : bool
        Whether a time column is present (needed to simulate).
    estimated : str
        How the derivatives were obtained when ``y`` was None, else "".
    """

    X: pd.DataFrame
    columns: dict[str, np.ndarray]
    derivatives: np.ndarray
    groups: list[tuple[object, np.ndarray]]
    has_time: bool
    estimated: str = ""

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return self.derivatives.shape[0]

    def predict(self, model) -> np.ndarray:
        """A fitted model's derivatives on these rows, ``(n_samples, n_states)``."""
        return np.asarray(model.predict(self.X), dtype=float).reshape(self.n_samples, -1)


def _float_column(frame: pd.DataFrame, name: str, what: str) -> np.ndarray:
    try:
        values = frame[name].to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} column {name!r} must be numeric") from None
    bad = ~np.isfinite(values)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{what} column {name!r} holds {values[row]} at row {row}; "
                         "diagnose needs finite measurements")
    return values


def read_measurements(skeleton, X, y, differentiation="spline") -> Measurements:
    """Check ``X`` and ``y`` against a skeleton and line them up.

    Without ``y`` (and without ``NAME_dot`` columns in ``X``) the
    derivatives are estimated by ``differentiation`` per experiment; states
    missing from ``X`` but defined by kinematic equations are reconstructed,
    and ``Measurements.X`` is a copy of ``X`` completed with them.

    Raises
    ------
    TypeError
        If ``X`` is not a DataFrame.
    ValueError
        If a column the skeleton needs is missing, or values are not finite.
    """
    if not isinstance(X, pd.DataFrame):
        raise TypeError(f"diagnose needs X as a pandas DataFrame with the columns "
                        f"{skeleton.variables}, got {type(X).__name__}")
    needed = [name for name in skeleton.variables if name != TIME]
    derivatives_given = y is not None or all(d in X.columns for d in skeleton.derivatives)
    optional = set() if derivatives_given else set(kinematic_chains(skeleton))
    needed_now = [name for name in needed if name not in optional or name in X.columns]
    missing = [name for name in needed_now if name not in X.columns]
    if missing:
        raise ValueError(f"X lacks the column{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(map(repr, missing))} of the skeleton "
                         f"(it reads {', '.join(skeleton.variables)})")
    has_time = TIME in X.columns
    if skeleton.uses_time and not has_time:
        raise ValueError("X lacks the time column 't', which the skeleton reads")
    columns = {name: _float_column(X, name, "X") for name in needed_now}
    if has_time:
        columns[TIME] = _float_column(X, TIME, "X")
    labels = None
    if TRAJECTORY in X.columns:
        labels = X[TRAJECTORY].to_numpy()
    experiments = split_experiments(len(X), columns.get(TIME), labels)
    groups = [(e.label, e.rows) for e in experiments]
    if derivatives_given:
        derivatives = _read_derivatives(skeleton, X, y)
        estimated = ""
    else:
        if not has_time:
            raise ValueError(f"y is None and X has neither the derivatives "
                             f"{skeleton.derivatives} nor a time column 't' to estimate them "
                             "from")
        measured = {s: columns[s] for s in skeleton.states if s in columns}
        estimate = estimate_states(skeleton, measured, experiments,
                                   resolve_differentiation(differentiation))
        derivatives, estimated = estimate.derivatives, estimate.description
        completed = X.copy()
        for state, values in estimate.states.items():
            columns[state] = values
            completed[state] = values
        X = completed
    for j, name in enumerate(skeleton.derivatives):
        columns[name] = derivatives[:, j]
    return Measurements(X, columns, derivatives, groups, has_time, estimated)


def _read_derivatives(skeleton, X, y) -> np.ndarray:
    names = skeleton.derivatives
    n = len(X)
    if y is not None:
        if isinstance(y, pd.Series):
            if len(names) != 1 or y.name not in (None, names[0]):
                raise ValueError(f"y is a series named {y.name!r}; give a DataFrame with the "
                                 f"columns {', '.join(names)}")
            y = y.to_frame(names[0])
        if isinstance(y, pd.DataFrame):
            missing = [name for name in names if name not in y.columns]
            if missing:
                raise ValueError(f"y lacks the column{'s' if len(missing) > 1 else ''} "
                                 f"{', '.join(map(repr, missing))}; it must hold "
                                 f"{', '.join(names)}")
            values = np.column_stack([_float_column(y, name, "y") for name in names])
        else:
            values = np.asarray(y, dtype=float)
            if values.ndim == 1:
                values = values[:, None]
            if values.shape[1] != len(names):
                raise ValueError(f"y has {values.shape[1]} columns; the skeleton has "
                                 f"{len(names)} equations ({', '.join(names)})")
            if not np.isfinite(values).all():
                raise ValueError("y holds NaN or infinity; diagnose needs finite measurements")
        if values.shape[0] != n:
            raise ValueError(f"X has {n} rows but y has {values.shape[0]}")
        return values
    return np.column_stack([_float_column(X, name, "X") for name in names])
