"""What a diagnosis compares a fitted model with, read from the record as ``fit`` reads it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..measurements import read_record
from ..measurements.experiments import TIME
from ..measurements.measurement import Measurement

__all__ = ["DiagnosisData", "check_units", "read_measurements", "thin"]

#: equation-error refits inside a diagnosis read at most this many rows, evenly spread:
#: neighbouring samples of a long record carry nearly the same information
REFIT_ROWS = 20_000


def thin(rows: np.ndarray, limit: int = REFIT_ROWS) -> np.ndarray:
    """At most ``limit`` of ``rows``, evenly spread over them (all of them when fewer)."""
    rows = np.asarray(rows)
    if len(rows) <= limit:
        return rows
    return rows[np.linspace(0, len(rows) - 1, limit).round().astype(int)]


@dataclass
class DiagnosisData:
    """The data a diagnosis compares the model with.

    Made by :func:`read_measurements` from the
    :class:`~sklearn_pycc.measurements.record.Record` that ``fit`` reads too
    (same columns, experiments and estimated derivatives), laid out for
    the diagnosis: a frame to predict and refit on, and the rows of each
    experiment even without a time column. Held-out folds are subsets of
    it (:func:`~._held_out.subset`), where a fold's gaps split an
    experiment in two.

    Attributes
    ----------
    X : DataFrame
        What the model is judged on: ``t``, ``trajectory``, the states
        (smoothed or reconstructed when derivatives were estimated), the
        inputs and the outputs of static equations (a new frame; the user's
        is never modified).
    columns : dict
        Name -> float array: states, inputs, ``t`` and the measured
        derivatives ``NAME_dot``.
    derivatives : ndarray of shape (n_samples, n_states)
        Measured (or estimated) derivatives, in equation order.
    experiments : list of (label, ndarray of int)
        Row positions of each experiment, in the order of the data.
    has_time : bool
        Whether a time column is present (needed to simulate).
    estimated : str
        How the derivatives were obtained when ``y`` was None, else "".
    signals : dict
        The inputs as measured, which drive simulations (``columns`` holds
        them as the equations are judged on, filtered alike with the states
        when the differentiation filters).
    """

    X: pd.DataFrame
    columns: dict[str, np.ndarray]
    derivatives: np.ndarray
    experiments: list[tuple[object, np.ndarray]]
    has_time: bool
    estimated: str = ""
    signals: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return self.derivatives.shape[0]

    def predict(self, model) -> np.ndarray:
        """A fitted model's derivatives on these rows, ``(n_samples, n_states)``.

        The outputs of static equations, which ``predict`` returns after the
        derivatives, are left out.
        """
        predicted = np.asarray(model.predict(self.X), dtype=float).reshape(self.n_samples, -1)
        return predicted[:, :self.derivatives.shape[1]]


def check_units(units, X, skeleton) -> dict[str, str]:
    """``units`` merged over ``X.attrs["units"]``, each naming a column or state, checked."""
    merged = {}
    for source, given in (("X.attrs['units']", getattr(X, "attrs", {}).get("units")),
                          ("units", units)):
        if given is None:
            continue
        if not isinstance(given, Mapping):
            raise TypeError(f"{source} must be a dict of name -> unit, got "
                            f"{type(given).__name__}")
        known = {*map(str, getattr(X, "columns", ())), *skeleton.states, TIME}
        for name, unit in given.items():
            if not isinstance(name, str) or name not in known:
                raise ValueError(f"{source} names {name!r}, which is neither a column of X "
                                 f"nor a state of the skeleton")
            if not isinstance(unit, str):
                raise TypeError(f"{source}[{name!r}] must be a string, got {unit!r}")
            merged[name] = unit
    return merged


def read_measurements(skeleton, X, y, differentiation="auto",
                      smooth: bool = True, *, who: str = "diagnose") -> DiagnosisData:
    """Check ``X`` and ``y`` against a skeleton and line them up.

    This is :func:`~sklearn_pycc.measurements.read_record`, the path ``fit``
    takes too: without ``y`` (and without ``NAME_dot`` columns in ``X``) the
    derivatives are estimated by ``differentiation`` per experiment, states
    missing from ``X`` but defined by kinematic equations are reconstructed,
    and ``DiagnosisData.X`` is a frame of what the model is judged on.

    Raises
    ------
    TypeError
        If ``X`` is not a DataFrame.
    ValueError
        If a column the skeleton needs is missing, or values are not finite.
    """
    if not isinstance(X, pd.DataFrame | Measurement):
        raise TypeError(f"diagnose needs X as a pandas DataFrame with the columns "
                        f"{skeleton.variables}, got {type(X).__name__}")
    if not skeleton.states:
        raise ValueError("the skeleton has no differential equation: a diagnosis compares "
                         "derivatives and simulated trajectories with the measurements; "
                         "judge a static model by its score")
    record = read_record(skeleton, X, y, differentiation=differentiation, smooth=smooth,
                         derivatives_from_X=True, split=True, who=who)
    has_time = TIME in record.data
    if skeleton.uses_time and not has_time:
        raise ValueError("X lacks the time column 't', which the skeleton reads")
    if record.experiments is None:
        experiments = [(None, np.arange(record.n_samples))]
    else:
        experiments = [(e.label, e.rows) for e in record.experiments]
    names = [*skeleton.states, *(n for n in skeleton.inputs if n != TIME), *skeleton.outputs]
    frame = record.frame(names)
    estimated = record.source if record.estimated else ""
    return DiagnosisData(frame, dict(record.columns), record.derivatives, experiments, has_time,
                        estimated, record.signals)
