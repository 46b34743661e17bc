"""What a diagnosis compares a fitted model with, read from the record as ``fit`` reads it.

The diagnosis holds one :class:`~sklearn_pycc.measurements.record.Record`
from its entry to every refit: candidates and held-out folds fit on its rows
(:func:`~._refit.fit_rows`), and folds are :meth:`Record.subset` of it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import pandas as pd

from ..measurements import read_record
from ..measurements.experiments import TIME
from ..measurements.measurement import Measurement
from ..measurements.record import Record

__all__ = ["check_units", "read_measurements", "thin"]

#: equation-error refits inside a diagnosis read at most this many rows, evenly spread:
#: neighbouring samples of a long record carry nearly the same information
REFIT_ROWS = 20_000


def thin(rows: np.ndarray, limit: int = REFIT_ROWS) -> np.ndarray:
    """At most ``limit`` of ``rows``, evenly spread over them (all of them when fewer)."""
    rows = np.asarray(rows)
    if len(rows) <= limit:
        return rows
    return rows[np.linspace(0, len(rows) - 1, limit).round().astype(int)]


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
                      smooth: bool = True, *, who: str = "diagnose") -> Record:
    """Check ``X`` and ``y`` against a skeleton and line them up.

    This is :func:`~sklearn_pycc.measurements.read_record`, the path ``fit``
    takes too: without ``y`` (and without ``NAME_dot`` columns in ``X``) the
    derivatives are estimated by ``differentiation`` per experiment, states
    missing from ``X`` but defined by kinematic equations are reconstructed,
    and the record's :attr:`~Record.X` is a frame of what the model is judged
    on. Experiments are split whenever there is a time column.

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
    if skeleton.uses_time and not record.has_time:
        raise ValueError("X lacks the time column 't', which the skeleton reads")
    # an input read late comes with the input it is read from: a refit may read it anew
    inputs = [name for n in skeleton.inputs if n != TIME
              for name in ((n, skeleton.delays[n][0]) if n in skeleton.delays else (n,))]
    names = dict.fromkeys([*skeleton.states, *inputs, *skeleton.outputs])
    return replace(record, names=tuple(names))
