"""One record, read once: the object every fit, diagnosis and comparison on it can share."""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Hashable, Mapping

import numpy as np
import pandas as pd

from .experiments import TIME, TRAJECTORY

__all__ = ["Measurement"]

#: why scikit-learn's cross-validation cannot take a Measurement, and what to pass instead
NOT_SPLIT = (
    "a Measurement is a whole record, not an array scikit-learn can split by rows: "
    "cross_val_score, GridSearchCV and the other cross-validation tools take the DataFrame "
    "instead. Pass measurement.X (and measurement.y, if any), with a 'trajectory' column "
    "separating the experiments, and cv=sklearn_pycc.model_selection.ExperimentSplit() "
    "(or BlockSplit() for one long record), which keep experiments whole")


class Measurement:
    """A record, and the derivatives estimated from it, kept for every use.

    ``fit``, :func:`~sklearn_pycc.diagnose`, :func:`~sklearn_pycc.compare_skeletons`
    and :class:`~sklearn_pycc.HypothesisLoop` take a Measurement wherever they
    take ``X`` (with ``y`` inside it). The derivatives a fit estimates from
    the record (what ``differentiation="auto"`` chose, and why) are kept,
    per differentiation setting and per structure of the skeleton (its
    states and kinematic equations): every other skeleton of the same states
    fitted or diagnosed on it reuses them, so a loop over candidate
    skeletons differentiates the record once.

    The estimates are kept for the record as it is: if :attr:`X` or
    :attr:`y` is changed in place, the next use estimates again.

    A Measurement is not split by scikit-learn's cross-validation
    (``cross_val_score``, ``GridSearchCV``): give those the DataFrame, with
    the splitters of :mod:`sklearn_pycc.model_selection` (a ``TypeError``
    says so).

    Parameters
    ----------
    X : DataFrame
        States and inputs by name, ``t`` and ``trajectory`` optional, as for
        ``fit``. It is copied (the user's frame is never changed): later
        changes to the frame do not reach the Measurement.
    y : DataFrame or array, optional
        Measured derivatives, as for ``fit`` (copied too).
    units : dict, optional
        Unit of each column, ``{"x1": "m", "F": "N"}``; by default those of
        ``X.attrs["units"]``.

    Attributes
    ----------
    X : DataFrame
        The record.
    y : DataFrame, array or None
        The measured derivatives, when given.
    units : dict
        Unit of each column that has one.

    Examples
    --------
    >>> from sklearn_pycc import PolyCCRegressor, datasets
    >>> from sklearn_pycc.measurements import Measurement
    >>> frame = datasets.make_oscillator(hidden=["cubic_stiffness"])
    >>> record = Measurement(frame[["t", "x1", "F_ext"]])
    >>> linear = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
    >>> cubic = PolyCCRegressor(
    ...     equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"])
    >>> _ = linear.fit(record), cubic.fit(record)   # differentiated once
    >>> len(record.derivative_sources)
    1
    """

    def __init__(self, X, y=None, *, units: Mapping[str, str] | None = None) -> None:
        if isinstance(X, Measurement):
            raise TypeError("X is a Measurement already: use it as it is")
        if not isinstance(X, pd.DataFrame):
            raise TypeError(f"a Measurement reads X as a pandas DataFrame with named columns, "
                            f"got {type(X).__name__}")
        self.X = X.copy()
        self.y = None if y is None else (y.copy() if hasattr(y, "copy") else np.array(y))
        given = X.attrs.get("units") if units is None else units
        if given is not None and not isinstance(given, Mapping):
            raise TypeError(f"units must be a dict of column -> unit, got {type(given).__name__}")
        self.units = dict(given or {})
        self._estimates: dict[Hashable, object] = {}
        self._held: list = []
        self._fingerprint = self._digest()

    # -- what it is --------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return len(self.X)

    @property
    def columns(self) -> list[str]:
        """The record's column names."""
        return [str(c) for c in self.X.columns]

    @property
    def n_experiments(self) -> int:
        """Number of experiments (``trajectory`` labels; 1 without that column)."""
        if TRAJECTORY not in self.X.columns:
            return 1
        return int(self.X[TRAJECTORY].nunique(dropna=False))

    @property
    def derivative_sources(self) -> list[str]:
        """How the derivatives kept so far were estimated, in words (one per setting)."""
        return [estimate.description for estimate in self._estimates.values()]

    @property
    def noise(self):
        """The noise of each measured signal: level, colour, quantisation, drift.

        A :class:`~sklearn_pycc.measurements.noise.NoiseReading`
        (``{column: SignalNoise}``) over every column but ``t`` and
        ``trajectory``, each read from its longest experiment (see
        :func:`~sklearn_pycc.measurements.noise.read_noise`); kept like the
        derivatives. ``m.noise.summary()`` says it in words, ``m.noise.plot()``
        draws it.
        """
        return self.estimated(("noise",), self._read_noise)

    def _read_noise(self):
        from .noise import NoiseReading, read_frame_noise

        frame = self.X
        if TIME not in frame.columns:
            raise ValueError("reading the noise needs the time column 't' (the spectrum is in "
                             "cycles per time unit)")
        columns = [c for c in frame.columns if c not in (TIME, TRAJECTORY)
                   and pd.api.types.is_numeric_dtype(frame[c])]
        return NoiseReading(read_frame_noise(frame, columns), self.units)

    def __len__(self) -> int:
        return self.n_samples

    def __array__(self, dtype=None, copy=None):
        # scikit-learn turns an X it cannot index into an array: say what to pass instead
        raise TypeError(NOT_SPLIT)

    def __repr__(self) -> str:
        columns = ", ".join(self.columns[:8]) + (", ..." if len(self.columns) > 8 else "")
        time = "" if TIME in self.X.columns else ", no time column"
        return (f"<Measurement: {self.n_samples} samples in {self.n_experiments} "
                f"experiment{'s' if self.n_experiments != 1 else ''} ({columns}){time}>")

    # -- kept estimates ------------------------------------------------------------------
    def estimated(self, key: Hashable, estimate: Callable[[], object]) -> object:
        """The estimate kept under ``key``, made by ``estimate()`` the first time.

        ``key`` names everything the estimate depends on besides the record
        (the skeleton's states and kinematic equations, the inputs, the
        differentiation and smoothing settings).
        """
        digest = self._digest()
        if digest != self._fingerprint:  # X or y changed in place: their estimates are stale
            self._estimates.clear()
            self._fingerprint = digest
        if key not in self._estimates:
            self._estimates[key] = estimate()
        return self._estimates[key]

    def _digest(self) -> bytes:
        """A digest of the record's values, labels and targets: what the estimates depend on."""
        return values_digest(self.X, self.y)

    def keep_alive(self, setting: object) -> None:
        """Hold ``setting`` (a differentiator object) as long as estimates keyed by its id."""
        if not any(held is setting for held in self._held):
            self._held.append(setting)


def values_digest(*parts) -> bytes | None:
    """A digest of frames, series and arrays (their values, labels and shapes).

    None parts are skipped; None where a part is another object (an array
    of objects included), which has no digest.
    """
    digest = hashlib.blake2b(digest_size=16)
    for part in parts:
        if part is None:
            continue
        if isinstance(part, pd.DataFrame):
            digest.update(repr(list(part.columns)).encode())
        if isinstance(part, (pd.DataFrame, pd.Series)):
            part = pd.util.hash_pandas_object(part, index=True).to_numpy()
        if not isinstance(part, np.ndarray) or part.dtype == object:
            return None
        values = np.ascontiguousarray(part)
        digest.update(repr((values.shape, values.dtype.str)).encode())
        digest.update(values.tobytes())
    return digest.digest()


def unwrap(X, y=None, *, who: str = "fit"):
    """``(X, y, measurement)``: the frame and targets of ``X``, and ``X`` if it is a Measurement.

    Raises
    ------
    ValueError
        If ``y`` is given beside a Measurement (it belongs inside it).
    """
    if not isinstance(X, Measurement):
        return X, y, None
    if y is not None:
        raise ValueError(f"{who} got y beside a Measurement: give y to the Measurement "
                         "(Measurement(X, y))")
    return X.X, X.y, X
