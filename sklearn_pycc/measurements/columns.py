"""Columns of X and y read by name, as float64 copies, with every culprit named."""

from __future__ import annotations

import warnings
from collections.abc import Collection, Sequence

import numpy as np
import pandas as pd
from sklearn.utils.validation import check_array, validate_data

from ..simulation.delays import delayed_column, read_delayed
from .experiments import TIME, TRAJECTORY
from .measurement import Measurement

__all__ = ["TIME", "TRAJECTORY", "FitData", "read_X", "read_y", "time_values"]


class FitData:
    """Named float64 columns of one data set (never the user's arrays themselves)."""

    def __init__(self, columns: dict[str, np.ndarray], n_samples: int,
                 trajectory: np.ndarray | None = None) -> None:
        self.columns = columns
        self.n_samples = n_samples
        self.trajectory = trajectory

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns


def _first_bad(values: np.ndarray) -> int:
    return int(np.flatnonzero(~np.isfinite(values))[0])


def _finite_column(values: np.ndarray, what: str, trajectory: np.ndarray | None = None) -> None:
    if not np.isfinite(values).all():
        i = _first_bad(values)
        kind = "NaN" if np.isnan(values[i]) else "infinity"
        label = None if trajectory is None else trajectory[i]
        label = label.item() if isinstance(label, np.generic) else label
        where = "" if trajectory is None else f" (experiment {label!r})"
        raise ValueError(f"{what} contains {kind} at row {i}{where}; remove or fill it "
                         "before fitting (a gap splits an experiment in two; fit_mode='filter' "
                         "reads a state's missing samples as missing)")


def _seconds(series: pd.Series, what: str) -> np.ndarray | None:
    """A datetime or timedelta column in seconds (None for any other column).

    Datetimes count from the column's first value; the conversion is said
    in a warning, since a logger's clock becomes a relative time.
    """
    if pd.api.types.is_datetime64_any_dtype(series.dtype):
        values = (series - series.iloc[0]).dt.total_seconds()
        warnings.warn(f"{what} holds datetimes ({series.dtype}): read as seconds since its "
                      f"first value ({series.iloc[0]})", UserWarning, stacklevel=4)
        return values.to_numpy(dtype=np.float64, copy=True)
    if pd.api.types.is_timedelta64_dtype(series.dtype):
        return series.dt.total_seconds().to_numpy(dtype=np.float64, copy=True)
    return None


def time_values(series: pd.Series) -> np.ndarray:
    """A time column as the fit reads it: numbers, datetimes and durations in seconds.

    Datetimes count from the column's first value (as :func:`read_X` reads
    them, without its warning).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        seconds = _seconds(series, "t")
    return series.to_numpy(dtype=float) if seconds is None else seconds


def _numeric(series: pd.Series, what: str) -> np.ndarray:
    seconds = _seconds(series, what)
    if seconds is not None:
        if not what.endswith("'t'"):
            raise ValueError(f"{what} holds {series.dtype} values; only the time column 't' "
                             "may hold datetimes or durations")
        return seconds
    try:
        values = series.to_numpy(dtype=np.float64, copy=True)
    except (TypeError, ValueError):
        raise ValueError(f"{what} is not numeric (dtype {series.dtype})") from None
    return values


def read_X(estimator, X, needed: Sequence[str], *, reset: bool, who: str = "X",
           optional: Collection[str] = ()) -> FitData:
    """Validate ``X`` and return the float64 columns the skeleton reads.

    A DataFrame is read by column name; an array's columns (and those of a
    DataFrame whose column names are not all strings) are called
    ``x0, x1, ...``, and are refused for a skeleton that reads ``x1`` but
    not ``x0`` (its columns would be read shifted by one). Columns the
    skeleton does not use are left alone.
    ``t`` and ``trajectory`` are read when present. Names in ``optional``
    may be missing. With ``estimator=None`` nothing is recorded about ``X``
    (``validate_data`` is for estimators learning their input). A
    :class:`~sklearn_pycc.measurements.Measurement` is read as its frame.
    """
    if isinstance(X, Measurement):
        X = X.X
    named = isinstance(X, pd.DataFrame) and all(isinstance(c, str) for c in X.columns)
    if named:
        fitted_names = getattr(estimator, "feature_names_in_", None)
        if estimator is None:
            pass  # a diagnosis or a scorer: nothing is learned about X
        elif reset or fitted_names is None or list(fitted_names) == list(X.columns):
            validate_data(estimator, X, reset=reset, skip_check_array=True)
        # otherwise columns are matched by name below, whatever their order
        if len(X) == 0:
            raise ValueError(f"{who} has 0 samples; at least one is required")
        names = [str(c) for c in X.columns]
        columns: dict[str, np.ndarray] = {}
        trajectory = X[TRAJECTORY].to_numpy(copy=True) if TRAJECTORY in names else None
        for name in needed:
            if name not in names and name in optional:
                continue
            if name not in names and read_delayed(name) is not None:
                columns[name] = _delayed(X, name, names, trajectory, who)
                continue
            if name not in names:
                raise ValueError(
                    f"{who} has no column {name!r}, which the skeleton uses; "
                    f"{who} has columns {names}")
            matches = [c for c in X.columns if str(c) == name]
            if len(matches) > 1:
                raise ValueError(f"{who} has more than one column named {name!r}")
            values = _numeric(X[matches[0]], f"{who} column {name!r}")
            _finite_column(values, f"{who} column {name!r}", trajectory)
            columns[name] = values
        if TIME in names and TIME not in columns:
            values = _numeric(X[TIME], f"{who} column 't'")
            _finite_column(values, f"{who} column 't'", trajectory)
            columns[TIME] = values
        if estimator is not None and reset:
            _warn_if_standardised(columns, who)
        return FitData(columns, len(X), trajectory)
    if estimator is None:
        array = check_array(X, dtype=np.float64, ensure_all_finite=False, ensure_2d=True,
                            copy=True, input_name=who)
    else:
        array = validate_data(estimator, X, reset=reset, dtype=np.float64,
                              ensure_all_finite=False, ensure_2d=True, copy=True)
    names = [f"x{j}" for j in range(array.shape[1])]
    delayed = [name for name in needed if read_delayed(name) is not None]
    if delayed:
        raise ValueError(
            f"the skeleton reads {delayed[0]}, an input read late, which needs the record's "
            f"time: pass {who} as a DataFrame with a 't' column")
    _check_array_naming(needed, optional, array.shape[1], who)
    columns = {}
    for name in needed:
        if name not in names and name in optional:
            continue
        if name not in names:
            raise ValueError(
                f"{who} has no column {name!r}, which the skeleton uses. Pass a DataFrame "
                f"with named columns (an array's {array.shape[1]} columns are called "
                f"{', '.join(names[:4])}{', ...' if len(names) > 4 else ''})")
        values = array[:, names.index(name)]
        _finite_column(values, f"{who} column {name!r}")
        columns[name] = values
    return FitData(columns, array.shape[0])


def _delayed(X: pd.DataFrame, name: str, names: list[str], trajectory, who: str) -> np.ndarray:
    """The column of an input read late (``u(t - 0.3)``), made from ``u`` and ``t``."""
    signal, delay = read_delayed(name)
    if isinstance(delay, str):
        raise ValueError(f"{name} is read {delay} late, and {delay} has no value here: "
                         "its estimator fits it")
    for needed in (signal, TIME):
        if needed not in names:
            raise ValueError(f"{who} has no column {needed!r}, which {name} is read from; "
                             f"{who} has columns {names}")
    values = _numeric(X[signal], f"{who} column {signal!r}")
    _finite_column(values, f"{who} column {signal!r}", trajectory)
    t = _numeric(X[TIME], f"{who} column 't'")
    _finite_column(t, f"{who} column 't'", trajectory)
    return delayed_column(values, t, delay, trajectory)


def _warn_if_standardised(columns: dict[str, np.ndarray], who: str) -> None:
    """Warn when the variables arrive standardised (a scaler in front of the estimator).

    A skeleton's variables are physical quantities: ``x1_dot = x2`` holds for
    a position and its velocity, not for each divided by its own spread, so
    a ``StandardScaler`` in a pipeline silently changes the physics fitted.
    """
    scaled = []
    for name, values in columns.items():
        if name == TIME or values.size < 3:
            continue
        spread = float(np.std(values))
        if abs(float(np.mean(values))) < 1e-9 and abs(spread - 1.0) < 1e-9:
            scaled.append(name)
    if scaled:
        warnings.warn(
            f"{who} columns {', '.join(scaled)} have mean 0 and standard deviation 1 exactly, "
            "as a StandardScaler leaves them. The skeleton's variables are physical "
            "quantities: scaling them changes the equations (x1_dot = x2 no longer holds "
            "between scaled columns) and the fitted curves and parameters. Drop the scaler, "
            "or write the scales into the skeleton.", UserWarning, stacklevel=4)


def _check_array_naming(needed: Sequence[str], optional: Collection[str], width: int,
                        who: str) -> None:
    """Refuse an array for a skeleton that numbers its variables from 1.

    An array's columns are called ``x0, x1, ...``: a skeleton reading ``x1``
    and ``x2`` but not ``x0`` would silently skip the first column and read
    the others shifted by one.
    """
    numbered = sorted((n for n in needed if n[:1] == "x" and n[1:].isdigit()
                       and n not in optional), key=lambda n: int(n[1:]))
    if numbered and "x0" not in needed:
        others = [n for n in needed if n not in numbered and n not in optional]
        wanted = ", ".join(repr(n) for n in [*numbered, *others])
        raise ValueError(
            f"{who} is an array, whose {width} columns are called x0, x1, ...; the skeleton "
            f"reads {', '.join(numbered)} but not x0, so the columns would be read shifted by "
            f"one. Pass a DataFrame with named columns, e.g. pd.DataFrame({who}, "
            f"columns=[{wanted}]) in the order of your array")


def read_y(y, derivatives: Sequence[str], n_samples: int, *, with_ndim: bool = False):
    """Validate the measured targets; return ``(n_samples, n_targets)`` in their order.

    The targets are the derivatives ``NAME_dot`` (and the outputs of static
    equations, when ``y`` holds them). A DataFrame is matched by column
    name; an array's columns are taken in the order of the equations. With
    ``with_ndim``, return ``(values, ndim)`` where ``ndim`` is that of the
    ``y`` given.
    """
    ndim = 2
    derivatives = list(derivatives)
    what = "derivatives" if all(d.endswith("_dot") for d in derivatives) else "targets"
    if isinstance(y, pd.DataFrame):
        names = [str(c) for c in y.columns]
        missing = [d for d in derivatives if d not in names]
        extra = [c for c in names if c not in derivatives]
        if missing or extra:
            parts = []
            if missing:
                parts.append(f"missing {missing}")
            if extra:
                parts.append(f"unexpected {extra}")
            raise ValueError(
                f"y columns do not match the skeleton's {what} {derivatives}: "
                + "; ".join(parts))
        if len(set(names)) != len(names):
            raise ValueError("y has duplicated column names")
        values = np.column_stack([_numeric(y[d], f"y column {d!r}") for d in derivatives])
    elif isinstance(y, pd.Series):
        if len(derivatives) != 1:
            raise ValueError(
                f"y is a single series but the skeleton has {len(derivatives)} {what} "
                f"{derivatives}; pass a DataFrame with these columns")
        if y.name is not None and str(y.name) != derivatives[0]:
            raise ValueError(
                f"y is named {y.name!r} but the skeleton's {what[:-1]} is {derivatives[0]!r}")
        values = _numeric(y, "y")[:, None]
        ndim = 1
    else:
        values = check_array(y, dtype=np.float64, ensure_2d=False, ensure_all_finite=False,
                             input_name="y", copy=True)
        if values.ndim == 1:
            ndim = 1
            values = values[:, None]
        if values.ndim != 2 or values.shape[1] != len(derivatives):
            raise ValueError(
                f"y has {values.shape[1] if values.ndim == 2 else values.shape} columns but the "
                f"skeleton has {len(derivatives)} {what} {derivatives}")
    if len(values) != n_samples:
        raise ValueError(f"X has {n_samples} rows but y has {len(values)}")
    for j, d in enumerate(derivatives):
        _finite_column(values[:, j], f"y column {d!r}")
    return (values, ndim) if with_ndim else values
