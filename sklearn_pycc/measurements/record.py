"""One path from a user's ``X`` and ``y`` to what a model is fitted and judged on.

``fit``, :func:`~sklearn_pycc.diagnose`, :func:`~sklearn_pycc.compare_skeletons`
and the simulation scorer all read measurements through :func:`read_record`,
so they see the same columns, the same experiments and the same estimated
derivatives for the same data and settings.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pandas as pd

from ..simulation.delays import delayed_column, read_delayed
from ..skeleton.nodes import Symbol, walk
from .columns import FitData, read_X, read_y
from .differentiation import resolve_differentiation
from .experiments import TIME, TRAJECTORY, Experiment, split_experiments
from .measurement import unwrap
from .reconstruct import estimate_states, kinematic_chains, unmeasured_states

__all__ = ["Record", "read_record", "targets_in_y"]

MEASURED = "measured"
#: the derivative source of a skeleton of static equations only
STATIC = "none needed (static equations only)"


@dataclass
class Record:
    """Measurements lined up against a skeleton.

    Attributes
    ----------
    data : FitData
        What the model is fitted and judged on: the states (smoothed when
        derivatives were estimated and smoothing is on, reconstructed when
        unmeasured), the inputs (filtered when the differentiation filters
        them), ``t``, and the derivatives ``NAME_dot``.
    derivatives : ndarray of shape (n_samples, n_states)
        Measured or estimated derivatives, in equation order.
    y_ndim : int
        1 when ``y`` was one-dimensional.
    experiments : list of Experiment or None
        Experiments with their times (None without ``t``).
    measured : dict
        The states ``X`` holds, as measured.
    smoothed : dict
        Every state, smoothed or reconstructed (initial states of simulations).
    signals : dict
        The inputs as measured (what drives a simulation).
    trusted : ndarray of bool or None
        Rows whose estimated derivatives can be trusted (None: all of them).
    snr_db : float or None
        The lowest signal-to-noise ratio of the states, when the
        differentiation read one from the record.
    hidden : tuple of str
        States no column holds (or only holds missing values) and no
        kinematic equation reconstructs: unmeasured, to be fitted by output
        error. Read only when the caller allows it (``hidden_ok``).
    source : str
        ``"measured"``, or how the derivatives were obtained, in words.
    names : tuple of str
        The columns a model of the skeleton reads, in order (its states,
        inputs and static outputs): those of :attr:`X`.

    When the derivatives were estimated by a filter, the rows within its
    settling time of an experiment's ends cannot be trusted (see
    :meth:`Differentiator.settling`): equation fits, diagnoses and scores
    judge only the others (:meth:`keep`); an output-error fit, which needs
    no derivatives, uses every row.
    """

    data: FitData
    derivatives: np.ndarray
    y_ndim: int
    experiments: list[Experiment] | None
    measured: dict[str, np.ndarray]
    smoothed: dict[str, np.ndarray]
    signals: dict[str, np.ndarray]
    source: str = MEASURED
    trusted: np.ndarray | None = None
    snr_db: float | None = None
    hidden: tuple[str, ...] = ()
    names: tuple[str, ...] = ()

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return self.data.n_samples

    @property
    def columns(self) -> dict[str, np.ndarray]:
        """Name -> values of every column of :attr:`data`."""
        return self.data.columns

    def environment(self, nodes=()) -> tuple[dict[str, int], list[np.ndarray]]:
        """Slots and columns to evaluate expressions on, with the inputs read late they read.

        An input read late by a number (``u(t - 0.3)``) that :attr:`data`
        lacks (a candidate's refit chose the delay) is made from its signal.
        """
        columns = dict(self.data.columns)
        for node in nodes:
            for n in walk(node):
                if isinstance(n, Symbol) and n.name not in columns \
                        and read_delayed(n.name) is not None:
                    columns[n.name] = self.column(n.name)
        names = list(columns)
        return {name: i for i, name in enumerate(names)}, [columns[n] for n in names]

    def column(self, name: str) -> np.ndarray:
        """One column by name.

        An input read late by a number (``u(t - 0.3)``) is made from its
        signal when :attr:`data` lacks it.
        """
        if name in self.data.columns:
            return self.data.columns[name]
        read = read_delayed(name)
        if read is None or isinstance(read[1], str):
            raise KeyError(name)
        return delayed_column(self.data.columns[read[0]], self.data.columns[TIME], read[1],
                              self.data.trajectory)

    @property
    def estimated(self) -> bool:
        """Whether the derivatives were estimated from the states."""
        return self.source not in (MEASURED, STATIC)

    @property
    def has_time(self) -> bool:
        """Whether the record has a time column (needed to simulate)."""
        return TIME in self.data

    @property
    def experiment_rows(self) -> list[tuple[object, np.ndarray]]:
        """``(label, rows)`` of each experiment, in data order (one without ``t``)."""
        if self.experiments is None:
            return [(None, np.arange(self.n_samples))]
        return [(e.label, e.rows) for e in self.experiments]

    @cached_property
    def X(self) -> pd.DataFrame:
        """What a model of the skeleton reads, as a frame: :attr:`names`, ``t``, ``trajectory``.

        The states are those the model is judged on (smoothed or
        reconstructed when the derivatives were estimated).
        """
        return self.frame(self.names)

    def predict(self, model) -> np.ndarray:
        """A fitted model's derivatives on these rows, ``(n_samples, n_states)``.

        The outputs of static equations, which ``predict`` returns after the
        derivatives, are left out.
        """
        predicted = np.asarray(model.predict(self.X), dtype=float).reshape(self.n_samples, -1)
        return predicted[:, :self.derivatives.shape[1]]

    def frame(self, names) -> pd.DataFrame:
        """A DataFrame of some columns (with ``t`` and ``trajectory`` when known)."""
        out = {}
        if TIME in self.data:
            out[TIME] = self.data[TIME]
        if self.data.trajectory is not None:
            out[TRAJECTORY] = self.data.trajectory
        for name in names:
            out[name] = self.data[name]
        return pd.DataFrame(out)

    def keep(self, rows: np.ndarray | None = None) -> Record:
        """The record restricted to some rows (a boolean mask; the trusted ones by default).

        Experiments are renumbered; the result has every row trusted.
        """
        rows = self.trusted if rows is None else rows
        if rows is None:
            return self
        position = np.cumsum(rows) - 1
        experiments = None
        if self.experiments is not None:
            experiments = []
            for e in self.experiments:
                inside = rows[e.rows]
                experiments.append(Experiment(e.label, position[e.rows[inside]],
                                              None if e.t is None else e.t[inside], e.part))
        return self._taken(rows, experiments, trusted=None)

    def subset(self, rows: np.ndarray) -> Record:
        """The record on some row positions, in their order.

        Each contiguous run of ``rows`` within an experiment is an
        experiment of its own (a held-out block splits one in two); a
        record without ``t`` counts as one experiment.
        """
        rows = np.asarray(rows, dtype=int)
        position = np.full(self.n_samples, -1)
        position[rows] = np.arange(len(rows))
        experiments = []
        for e in self.experiments or [Experiment(None, np.arange(self.n_samples))]:
            inside = position[e.rows]
            inside = inside[inside >= 0]
            if not inside.size:
                continue
            breaks = np.flatnonzero(np.diff(rows[inside]) != 1) + 1
            for run in np.split(inside, breaks):
                t = None if e.t is None else self.data[TIME][rows[run]]
                experiments.append(Experiment(e.label, run, t, e.part))
        return self._taken(rows, experiments,
                           trusted=None if self.trusted is None else self.trusted[rows])

    def _taken(self, rows: np.ndarray, experiments, *, trusted) -> Record:
        """The record on ``rows`` (a mask or positions) with these experiments."""
        derivatives = self.derivatives[rows]
        data = FitData({name: values[rows] for name, values in self.data.columns.items()},
                       len(derivatives),
                       None if self.data.trajectory is None else self.data.trajectory[rows])

        def cut(values: dict) -> dict:
            return {name: v[rows] for name, v in values.items()}

        return Record(data, derivatives, self.y_ndim, experiments,
                      cut(self.measured), cut(self.smoothed), cut(self.signals), self.source,
                      trusted, self.snr_db, self.hidden, self.names)


def read_record(skeleton, X, y=None, *, differentiation="auto", smooth: bool = True,
                estimator=None, reset: bool = False, derivatives_from_X: bool = False,
                need_time: str | None = None, split: bool = False,
                who: str | None = None, trim: bool = True, hidden_ok: bool = False) -> Record:
    """Read ``X`` (and ``y``) against a skeleton; estimate what was not measured.

    Every state of the skeleton that ``X`` holds is read, whether or not a
    right-hand side uses it. Without ``y`` (and, with
    ``derivatives_from_X``, without ``NAME_dot`` columns in ``X``) the
    derivatives are estimated per experiment by ``differentiation``, and a
    state missing from ``X`` but defined by a kinematic equation is
    reconstructed.

    Parameters
    ----------
    skeleton : Skeleton
        What is read: its states, inputs and derivatives.
    X : DataFrame or array
        The measurements (an array's columns are called ``x0, x1, ...``).
    y : DataFrame or array, optional
        Measured derivatives.
    differentiation : str, dict or callable, default="auto"
        See :func:`~sklearn_pycc.measurements.resolve_differentiation`.
    smooth : bool, default=True
        Fit on smoothed states rather than raw ones when derivatives are estimated.
    estimator : estimator, optional
        Learns ``n_features_in_`` and ``feature_names_in_`` when ``reset``.
    reset : bool, default=False
        Whether ``estimator`` learns ``X`` (in ``fit``).
    derivatives_from_X : bool, default=False
        Read the derivatives from ``NAME_dot`` columns of ``X`` when ``y`` is None.
    need_time : str, optional
        Why experiments must be split: a time column is then required, and
        its absence is reported with this reason.
    split : bool, default=False
        Split experiments whenever ``X`` has ``t`` (they are split anyway
        when derivatives are estimated).
    who : str, optional
        Names the caller in the message when ``y`` is None and ``X`` has no ``t``.
    trim : bool, default=True
        Leave out the rows whose estimated derivatives cannot be trusted
        (else they are only marked, in :attr:`Record.trusted`).
    hidden_ok : bool, default=False
        Accept states that ``X`` does not hold (or holds only as missing
        values) and no kinematic equation reconstructs, when the derivatives
        are estimated: they are :attr:`Record.hidden`. Otherwise such a
        state is an error.

    ``X`` may be a :class:`~sklearn_pycc.measurements.Measurement` (with
    ``y`` inside it): derivatives it has estimated before for the same
    states, kinematic equations, inputs and settings are reused.

    Raises
    ------
    ValueError
        For a missing or non-numeric column, non-finite values, a bad time
        grid, or a state that can be neither read nor reconstructed; the
        message names the column, the row or the experiment.
    """
    X, y, measurement = unwrap(X, y, who=who or "fit")
    states = skeleton.states
    outputs = list(getattr(skeleton, "outputs", []))
    in_y = targets_in_y(y, skeleton) if y is not None else []
    # a skeleton of static equations only has no derivative to measure or estimate
    given = y is not None or not skeleton.derivatives
    if not given and derivatives_from_X and isinstance(X, pd.DataFrame):
        given = all(d in X.columns for d in skeleton.derivatives)
    # states no right-hand side reads are read when present; without y, so are
    # states a kinematic equation defines (they can be reconstructed)
    optional = set(states) - set(skeleton.variables)
    if not given:
        optional |= set(kinematic_chains(skeleton))
    hidden: list[str] = []
    if not given and isinstance(X, pd.DataFrame):
        blank = [c for c in X.columns if str(c) in states and X[c].isna().all()]
        present = {str(c) for c in X.columns} - {str(c) for c in blank}
        hidden = unmeasured_states(skeleton, present)
        if hidden and not hidden_ok:
            raise ValueError(_hidden_message(hidden[0], blank, who))
        if hidden:
            X = X.drop(columns=[c for c in blank if str(c) in hidden])
            optional |= set(hidden)
    needed = list(dict.fromkeys([*skeleton.variables, *states,
                                 *(o for o in outputs if o not in in_y)]))
    data = read_X(estimator, X, needed, reset=reset, optional=optional)
    experiments = None
    if TIME not in data and (need_time or not given):
        raise ValueError(need_time if given and need_time else
                         _no_time_message(skeleton, who))
    if TIME in data and (split or need_time or not given):
        experiments = split_experiments(data.n_samples, data[TIME], data.trajectory)
    measured = {s: data[s] for s in states if s in data}
    signals = {name: data[name] for name in skeleton.inputs if name != TIME}
    columns = dict(data.columns)
    n_derivatives = len(skeleton.derivatives)
    if given:
        ndim = 2
        if y is not None:
            values, ndim = read_y(y, in_y, data.n_samples, with_ndim=True)
            _check_twice_given(X, in_y[n_derivatives:], values[:, n_derivatives:])
            columns.update({name: values[:, j] for j, name in enumerate(in_y)})
            derivatives = values[:, :n_derivatives]
        elif n_derivatives:
            derivatives = read_y(X[list(skeleton.derivatives)], skeleton.derivatives,
                                 data.n_samples)
        else:
            derivatives = np.zeros((data.n_samples, 0))
        smoothed, source = dict(measured), MEASURED if n_derivatives else STATIC
    else:
        observed = {name: columns[name] for name in outputs}

        def estimated():
            return estimate_states(skeleton, measured, experiments,
                                   resolve_differentiation(differentiation),
                                   smooth=bool(smooth), inputs={**signals, **observed},
                                   hidden=hidden)

        if measurement is None:
            estimate = estimated()
        else:
            key = (tuple(states), tuple(sorted(kinematic_chains(skeleton).items())),
                   tuple(measured), tuple(signals), tuple(observed), tuple(hidden),
                   _setting_key(differentiation, measurement), bool(smooth))
            estimate = measurement.estimated(key, estimated)
        derivatives, ndim = estimate.derivatives, 2
        columns.update(estimate.states)
        columns.update(estimate.inputs)
        smoothed, source = estimate.smoothed, estimate.description
    for j, name in enumerate(skeleton.derivatives):
        columns[name] = derivatives[:, j]
    record = Record(FitData(columns, data.n_samples, data.trajectory), derivatives, ndim,
                    experiments, measured, smoothed, signals, source,
                    None if given else estimate.trusted,
                    None if given else estimate.snr_db, tuple(hidden))
    return record.keep() if trim else record


def _setting_key(differentiation, measurement) -> tuple:
    """A differentiation setting as part of a key: by value, or by identity for an object."""
    if isinstance(differentiation, str):
        return ("name", differentiation)
    if isinstance(differentiation, Mapping):
        return ("options", repr(sorted((str(k), repr(v)) for k, v in differentiation.items())))
    # an object or a callable: by identity, kept alive with the record so the id stays its own
    measurement.keep_alive(differentiation)
    return ("object", id(differentiation))


def _check_twice_given(X, outputs: list[str], values: np.ndarray) -> None:
    """Refuse a static output given in ``X`` and in ``y`` with different values."""
    if not isinstance(X, pd.DataFrame):
        return
    for j, name in enumerate(outputs):
        if name not in X.columns:
            continue
        other = pd.to_numeric(X[name], errors="coerce").to_numpy(dtype=float)
        differ = ~np.isclose(other, values[:, j], rtol=1e-12, atol=0.0, equal_nan=True)
        if differ.any():
            row = int(np.flatnonzero(differ)[0])
            raise ValueError(
                f"the static output {name!r} is in both X and y, with different values (first "
                f"at row {row}: {float(other[row]):.6g} in X, {float(values[row, j]):.6g} in y): "
                "give it once")


def targets_in_y(y, skeleton) -> list[str]:
    """The targets ``y`` holds, in order: the derivatives, and static outputs.

    ``y`` holds the derivatives (for a skeleton of static equations only, its
    outputs). A DataFrame may add static outputs by name; an array or a
    series as wide as every target holds them all. Outputs ``y`` does not
    hold are read from ``X``.
    """
    derivatives = list(skeleton.derivatives)
    outputs = list(getattr(skeleton, "outputs", []))
    expected = derivatives or outputs
    if isinstance(y, pd.DataFrame):
        return [*expected, *(o for o in outputs if o in y.columns and o not in expected)]
    if isinstance(y, pd.Series):
        if y.name is not None and str(y.name) in outputs and not derivatives:
            return [str(y.name)]
        return expected
    if not (derivatives and outputs):
        return expected
    shape = np.shape(np.asarray(y))
    if len(shape) == 2 and shape[1] == len(derivatives) + len(outputs):
        return [*derivatives, *outputs]
    return expected


def _hidden_message(state: str, blank, who: str | None) -> str:
    """Why an unmeasured state is refused here, and where it would be fitted."""
    held = (f"X's column {state!r} holds only missing values" if state in map(str, blank)
            else f"X has no column {state!r}")
    return (f"{held}, a state of the skeleton, and no kinematic equation (NAME_dot = {state}) "
            f"ties it to a measured state. An unmeasured state is fitted by output error "
            f"(fit_mode='auto' or 'simulation'); {who or 'this call'} reads every state "
            f"from X")


def _no_time_message(skeleton, who: str | None) -> str:
    lead = f"{who} requires y to be passed, but the target y is None and" if who else \
        "y is None and"
    return (f"{lead} X has no time column 't' to estimate the derivatives "
            f"{skeleton.derivatives} from: give y, or X with 't'")
