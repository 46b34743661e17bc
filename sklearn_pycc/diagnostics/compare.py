"""Fit several skeletons on the same data and tabulate how the error falls."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from numbers import Integral

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.model_selection import cross_val_score
from sklearn.utils._param_validation import HasMethods, validate_params

from ..measurements.measurement import Measurement, unwrap
from ..simulation.integration import judged_step_limit
from ..skeleton import Skeleton
from ._candidates import rss_floor
from ._data import check_units, read_measurements
from ._held_out import pooled_errors
from ._metrics import rmse
from ._refit import fit_rows
from ._roles import equation_roles
from ._trajectories import Horizon, horizon_of, simulate_against

__all__ = ["compare_skeletons"]


def _named(skeletons) -> dict[str, object]:
    if isinstance(skeletons, Mapping):
        named = dict(skeletons)
    elif isinstance(skeletons, (str, Skeleton)):
        raise TypeError("compare_skeletons needs several skeletons: a dict name -> skeleton "
                        "or a list of skeletons")
    else:
        named = {f"skeleton {i + 1}": sk for i, sk in enumerate(skeletons)}
    if not named:
        raise ValueError("compare_skeletons needs at least one skeleton")
    for name in named:
        if not isinstance(name, str):
            raise TypeError(f"skeleton names must be strings, got {name!r}")
    return named


@validate_params({  # the skeletons are checked by _named, which says what a single one lacks
    "estimator": [HasMethods(["fit", "get_params"]), None],
    "cv": ["cv_object"],
    "simulate": ["boolean"],
    "held_out": ["boolean"],
    "n_jobs": [Integral, None],
    "units": [dict, None],
}, prefer_skip_nested_validation=False)  # the estimator's fits validate its settings
def compare_skeletons(skeletons, X, y=None, estimator=None, cv=None, *,
                      simulate: bool = True, horizon="auto",
                      held_out: bool = True, n_jobs: int | None = None,
                      units=None) -> pd.DataFrame:
    """Fit each skeleton with a clone of ``estimator`` and tabulate its errors.

    This is the "watch the error fall" table of the hypothesis loop; draw it
    with :func:`sklearn_pycc.plotting.plot_comparison`.

    Parameters
    ----------
    skeletons : dict of str -> skeleton, or list of skeletons
        Each a list of equation strings or a :class:`~sklearn_pycc.Skeleton`
        (whose constraints replace the estimator's).
    X : DataFrame
        Measured states and inputs (``t`` to simulate, ``trajectory`` to
        separate experiments).
    y : DataFrame or array, optional
        Measured derivatives; see :func:`~sklearn_pycc.diagnose`.
    estimator : CCRegressor, default=PolyCCRegressor()
        The backend and its settings; it is cloned, never modified.
    cv : int or cross-validation splitter, optional
        Also report ``cv_score``, the mean over ``cv``'s folds of the R² of
        the derivatives (experiments are passed as ``groups`` when X has a
        ``trajectory`` column). R² is relative to each fold's own spread: a
        fold of a free decay's quiet tail scores low whatever the model, so
        prefer ``held_out``'s errors for a record of one experiment.
    simulate : bool, default=True
        Simulate each fitted model with the measured inputs (over ``horizon``).
    horizon : "auto", float or None, default="auto"
        Simulate windows of this time, each restarted from the measured
        state (see :func:`~sklearn_pycc.diagnose`); ``"auto"`` chooses it
        from the first skeleton's model (the baseline) and the record, and
        the same horizon judges every row. None simulates whole experiments.
    held_out : bool, default=True
        Fit each skeleton without each fold of the record (its experiments,
        or interleaved blocks in time, as :func:`~sklearn_pycc.diagnose`
        does) and judge it on that fold: ``held_out_nrmse`` (the derivatives
        of the non-kinematic equations) and ``held_out_simulation_nrmse``
        (the horizon-limited simulation, when simulated), each normalised by
        the whole record's spread, so that every fold is on one scale.
    units : dict of str -> str, optional
        Units of the columns, merged over ``X.attrs["units"]``; kept in
        ``table.attrs["units"]`` beside each state's ``NAME_simulation_rmse``.
    n_jobs : int or None, default=None
        Fit and judge the skeletons after the first in parallel with joblib
        (the first chooses the horizon). The table does not depend on it.

    Returns
    -------
    pandas.DataFrame
        One row per skeleton, in the order given: ``equations``,
        ``derivative_rmse`` (over the non-kinematic equations),
        ``simulation_rmse`` (over the states; inf when the simulation
        diverges), ``n_params`` (numbers fitted), ``bic`` (Bayesian
        information criterion of the derivative residual),
        ``derivative_nrmse`` and ``simulation_nrmse`` (the largest of an
        equation's or a measured state's RMSE over its spread: no units, so
        they share the figure's axis), the held-out
        errors (when ``held_out``), ``cv_score`` (when ``cv`` is given) and
        ``fit_time`` in seconds. ``table.attrs["horizon"]`` says what
        horizon the simulations ran over, ``table.attrs["held_out"]`` how
        the record was split.
    """
    from ..estimators import PolyCCRegressor

    named = _named(skeletons)
    if n_jobs is not None and (isinstance(n_jobs, bool) or not isinstance(n_jobs, Integral)
                               or n_jobs == 0):
        raise ValueError(f"n_jobs must be None or a non-zero integer, got {n_jobs!r}")
    base = PolyCCRegressor() if estimator is None else estimator
    # read once: every skeleton of the same states reuses the derivatives estimated for the first
    if isinstance(X, pd.DataFrame):
        X, y = Measurement(X, y), None
    X, y, record = unwrap(X, y, who="compare_skeletons")
    if record is not None and units is None:
        units = record.units or None
    options = dict(X=X, y=y, record=record, cv=cv, simulate=simulate, held_out=held_out)
    items = list(named.values())
    unit_map = check_units(units, X, items[0] if isinstance(items[0], Skeleton)
                           else Skeleton(items[0]))
    # the first skeleton's model chooses the horizon every row is judged over
    first, window, held_out_text = _row(items[0], base, horizon=horizon, **options)
    rest = [delayed(_row)(skeleton, base, horizon=window, **options) for skeleton in items[1:]]
    if n_jobs in (None, 1):
        done = [job[0](*job[1], **job[2]) for job in rest]
    else:
        done = Parallel(n_jobs=n_jobs)(rest)
    rows = [first, *(row for row, _, _ in done)]
    table = pd.DataFrame(rows, index=pd.Index(list(named), name="skeleton"))
    table.attrs["units"] = unit_map
    if window is not None:
        table.attrs["horizon"] = str(window)
    if held_out_text is not None:
        table.attrs["held_out"] = held_out_text
    return table


def _row(skeleton, base, *, X, y, record, cv, simulate: bool, horizon, held_out: bool):
    """One skeleton fitted and judged: its row, the horizon and the held-out split in words.

    ``horizon`` is a :class:`Horizon` already chosen, or what
    :func:`horizon_of` chooses from (``"auto"``, a time, None).
    """
    model = clone(base)
    settings = {"equations": skeleton}
    if isinstance(skeleton, Skeleton):
        settings["constraints"] = None
    model.set_params(**settings)
    spec = (skeleton if isinstance(skeleton, Skeleton)
            else Skeleton(skeleton, model.get_params().get("constraints")))
    params = model.get_params()
    source, given = (X, y) if record is None else (record, None)
    data = read_measurements(spec, source, given, params.get("differentiation", "auto"),
                             bool(params.get("smooth_states", True)), who="compare_skeletons")
    target = data.derivatives
    start = time.perf_counter()
    if data.estimated:  # the model estimates them as read_measurements did (kept: reused)
        model.fit(source)
    else:
        fit_rows(model, data)
    fit_time = time.perf_counter() - start
    residual = data.derivatives - data.predict(model)
    active = [r.index for r in equation_roles(model.skeleton_)] or list(
        range(residual.shape[1]))
    n = data.n_samples
    rss = np.maximum(np.sum(residual[:, active] ** 2, axis=0),
                     rss_floor(data.derivatives)[active])
    bic = float(np.sum(n * np.log(rss / n)) + model.n_parameters_ * math.log(n))
    spread = np.std(data.derivatives[:, active], axis=0)
    spread[spread == 0] = 1.0
    row = {"equations": "; ".join(model.skeleton_.equations),
           "derivative_rmse": rmse(np.zeros_like(residual[:, active]), residual[:, active]),
           "simulation_rmse": math.nan, "n_params": int(model.n_parameters_),
           "bic": bic,
           "derivative_nrmse": float(np.max(np.sqrt(np.mean(residual[:, active] ** 2, axis=0))
                                            / spread)),
           "simulation_nrmse": math.nan}
    window, held_out_text = None, None
    if simulate and data.has_time:
        window = horizon if isinstance(horizon, Horizon) else horizon_of(model, data, horizon)
        simulated, divergences, _ = simulate_against(model, data, window,
                                                     max_steps=judged_step_limit(n))
        states = np.column_stack([data.columns[s] for s in model.skeleton_.states])
        row["simulation_rmse"] = math.inf if divergences else rmse(states, simulated)
        worst = 0.0
        for j, state in enumerate(model.skeleton_.states):  # each measured state alone
            if state in X.columns:
                row[f"{state}_simulation_rmse"] = math.inf if divergences else rmse(
                    states[:, j], simulated[:, j])
                scale = float(np.std(states[:, j])) or 1.0
                worst = max(worst, row[f"{state}_simulation_rmse"] / scale)
        row["simulation_nrmse"] = worst if worst > 0 else math.nan
    if held_out:
        held_out_text, errors = pooled_errors(model, data, active,
                                                 window if simulate else None,
                                                 50 * n + 10_000)
        row.update(errors)
    if cv is not None:
        groups = X["trajectory"] if "trajectory" in X.columns else None
        scores = cross_val_score(clone(model), X, target, cv=cv, groups=groups,
                                 error_score="raise")
        row["cv_score"] = float(np.mean(scores))
    row["fit_time"] = fit_time
    return row, window, held_out_text
