"""The one way the diagnosis and the loop refit a model: a clone with what they change.

Every refit of the diagnosis (a candidate's extended skeleton, a held-out
fold, a whole-record check, a hidden-state limit) and of the loop (the next
round's model, the refinement by output error) goes through
:func:`prepared`, so that which of the user's settings a refit keeps or
drops is decided here once. A refit on some rows of the diagnosis's record
is :func:`fit_rows`, the one place those rows become what ``fit`` reads.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from sklearn.base import clone

from ..measurements.experiments import TRAJECTORY
from ..measurements.record import Record

__all__ = ["fit_rows", "prepared"]

#: ``n_bootstrap`` as the model has it (a refit otherwise makes no refits on resamples)
KEEP = None


def prepared(model, *, equations=None, param_init: Mapping[str, float] | None = None,
             fit_mode: str | None = None, n_bootstrap: int | None = 0,
             hold_as_fitted: bool = False, **settings):
    """An unfitted clone of ``model`` with the settings a refit changes.

    Parameters
    ----------
    model : CCRegressor
        The model to refit (fitted, where ``hold_as_fitted`` asks for it).
    equations : Skeleton or list of str, optional
        Another skeleton; its constraints are then its own (``constraints=None``).
    param_init : mapping, optional
        Starting values, for an estimator that takes them; with a
        :class:`~sklearn_pycc.Skeleton` as ``equations``, those of parameters
        it does not have are left out.
    fit_mode : str, optional
        Another fit mode, for an estimator that has one.
    n_bootstrap : int or None, default=0
        Refits on resamples: none by default (a refit is judged by its
        errors); :data:`KEEP` (None) keeps the model's own.
    hold_as_fitted : bool, default=False
        Keep the input hold an ``input_hold="auto"`` model chose.
    **settings
        Any other hyperparameters, set as given.
    """
    params = model.get_params()
    new = {}
    if equations is not None:
        new.update(equations=equations, constraints=None)
    if param_init is not None and "param_init" in params:
        # a skeleton says which parameters it has; text is read by the fit itself
        known = set(equations.params) if hasattr(equations, "params") else None
        new["param_init"] = {a: v for a, v in param_init.items()
                             if known is None or a in known}
    if fit_mode is not None and "fit_mode" in params:
        new["fit_mode"] = fit_mode
    if n_bootstrap is not KEEP and (params.get("n_bootstrap") or n_bootstrap):
        new["n_bootstrap"] = n_bootstrap
    if hold_as_fitted and params.get("input_hold") == "auto":
        new["input_hold"] = model.input_hold_
    new.update(settings)
    return clone(model).set_params(**new)


def fit_rows(estimator, record: Record, rows: np.ndarray | None = None, *,
             pieces: np.ndarray | None = None):
    """Fit ``estimator`` on some rows of ``record``, with the record's derivatives.

    The derivatives the record holds (measured, or estimated once on the
    whole record) are the targets, and start an output-error fit too: the
    rows are not differentiated again.

    Parameters
    ----------
    estimator : CCRegressor
        An unfitted estimator (see :func:`prepared`).
    record : Record
        The record the diagnosis read (:func:`~._data.read_measurements`).
    rows : ndarray of int, optional
        Row positions, in order (all by default).
    pieces : ndarray, optional
        An experiment label per row of ``record``, which then replaces its
        ``trajectory`` (a held-out block splits an experiment in two).

    Returns
    -------
    estimator
        ``estimator``, fitted.
    """
    X, derivatives = record.X, record.derivatives
    if rows is not None:
        X, derivatives = X.iloc[rows].reset_index(drop=True), derivatives[rows]
    if pieces is not None:
        X = X.assign(**{TRAJECTORY: pieces if rows is None else pieces[rows]})
    return estimator.fit(X, derivatives)
