"""The published package's post-fine-tuning keys, translated onto output-error fitting.

``'fitting_forw_sim': True`` refines a fit by simulating the record and
comparing it with the measurements; here that is ``fit_mode="simulation"``
(multiple shooting). ``params_simul`` describes the simulation the published
package ran: its times and inputs complete ``df``, the rest is checked or
noted.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from ..skeleton import Skeleton
from ._params import Params

__all__ = ["OUTER_KEYS", "post_fine_tuning"]

#: what ``params_simul`` of the post-fine-tuning stage may hold
SIMUL_KEYS = {"t_span": None, "y0": None, "t_eval": None, "method": None, "atol": None,
              "rtol": None, "check_nan": None, "local_funcs": None}
SIMUL_SOLVER = ("the output-error stage integrates short windows that start from the "
                "measured states, with its own integrator and sensitivities")
OUTER_KEYS = ("n_iter_outer", "outer_tol", "params_simul")



def _params_simul(read: Params) -> Params:
    """``params_simul`` (a dict, or the published list of one-key dicts) as checked keys."""
    given = read["params_simul"]
    where = read.where
    if given is None:
        return Params({}, SIMUL_KEYS, where, name="params_simul")
    items = [given] if isinstance(given, Mapping) else given
    if isinstance(items, str) or not isinstance(items, Sequence):
        raise TypeError(f"{where}: params_simul must be a dict or a list of one-key dicts, "
                        f"got {type(given).__name__}")
    merged: dict = {}
    for position, item in enumerate(items):
        if not isinstance(item, Mapping):
            raise TypeError(f"{where}: params_simul[{position}] must be a dict, got "
                            f"{type(item).__name__}")
        twice = sorted(set(item) & set(merged))
        if twice:
            raise ValueError(f"{where}: params_simul[{position}] gives {twice[0]!r} again")
        merged.update(item)
    return Params(merged, SIMUL_KEYS, where, name="params_simul")


def _with_time(df: pd.DataFrame, simul: Params, where: str) -> pd.DataFrame:
    """``df`` with its time column, taken from ``t_eval`` when ``df`` has none."""
    if simul.given("t_eval"):
        t = np.asarray(simul["t_eval"], dtype=float).ravel()
        if t.size != len(df):
            raise ValueError(f"{where}: params_simul's t_eval has {t.size} times but df has "
                             f"{len(df)} rows; the post-fine-tuning compares simulations "
                             "with the rows of df, one time per row")
        if "t" not in df.columns:
            return df.assign(t=t)
        if not np.allclose(df["t"].to_numpy(dtype=float), t, rtol=1e-9, atol=1e-12):
            raise ValueError(f"{where}: params_simul's t_eval disagrees with df['t']; "
                             "give the times of the rows of df")
        return df
    if "t" not in df.columns:
        raise ValueError(f"{where}: 'fitting_forw_sim' refines the model by simulating the "
                         "record, which needs its times: give df a column 't', or "
                         "params_simul's 't_eval' (one time per row of df)")
    return df


def _with_inputs(df: pd.DataFrame, simul: Params, skeleton: Skeleton,
                 where: str) -> pd.DataFrame:
    """``df`` with the inputs of ``local_funcs`` it lacks; those it has must agree."""
    local = dict(simul["local_funcs"] or {})
    strays = [name for name in local if name not in skeleton.inputs]
    if strays:
        raise ValueError(f"{where}: params_simul's local_funcs has {strays[0]!r}, which is "
                         "not an input of the equations (inputs: "
                         f"{', '.join(skeleton.inputs) or 'none'}); the curves are fitted")
    t = df["t"].to_numpy(dtype=float)
    added = {}
    for name, signal in local.items():
        values = np.broadcast_to(np.asarray(signal(t), dtype=float), t.shape)
        if name not in df.columns:
            added[name] = values
            continue
        measured = df[name].to_numpy(dtype=float)
        scale = float(np.max(np.abs(measured))) or 1.0
        gap = np.abs(measured - values)
        if not np.all(gap <= 1e-6 * scale):
            k = int(np.argmax(gap))
            raise ValueError(f"{where}: params_simul's local_funcs[{name!r}] disagrees with "
                             f"df[{name!r}] (at t={t[k]:.6g}: {values[k]:.6g} against "
                             f"{measured[k]:.6g}); the post-fine-tuning uses the measured "
                             "input")
    return df.assign(**added) if added else df


def _check_start(df: pd.DataFrame, simul: Params, skeleton: Skeleton, read: Params) -> None:
    """Note ``y0`` and ``t_span`` when they do not describe ``df``; note the solver keys."""
    if simul.given("y0"):
        y0 = np.asarray(simul["y0"], dtype=float).ravel()
        if y0.size != len(skeleton.states):
            raise ValueError(f"{read.where}: params_simul's y0 has {y0.size} value(s) but "
                             f"the states are {len(skeleton.states)} "
                             f"({', '.join(skeleton.states)})")
        states = [s for s in skeleton.states if s in df.columns]
        first = np.array([df[s].iloc[0] for s in states], dtype=float)
        start = np.array([y0[skeleton.states.index(s)] for s in states])
        if not np.allclose(first, start, rtol=1e-6, atol=1e-9):
            read.note("params_simul's y0 differs from the first row of df; it has no "
                      f"effect here: {SIMUL_SOLVER}")
    if simul.given("t_span"):
        t0, t1 = (float(v) for v in simul["t_span"])
        t = df["t"].to_numpy(dtype=float)
        if t.min() < t0 or t.max() > t1:
            read.note("params_simul's t_span does not cover the times of df; it has no "
                      "effect here: the whole record is refined")
    solver = [key for key in ("method", "atol", "rtol", "check_nan") if simul.given(key)]
    if solver:
        verb = "has" if len(solver) == 1 else "have"
        read.note(f"params_simul's {', '.join(map(repr, solver))} {verb} no effect: "
                  f"{SIMUL_SOLVER}")


def post_fine_tuning(read: Params, df: pd.DataFrame, skeleton: Skeleton):
    """Estimator settings and data for the published post-fine-tuning keys."""
    given = [key for key in OUTER_KEYS if read.supplied(key)]
    if not read["fitting_forw_sim"]:
        if given:
            verb = "has" if len(given) == 1 else "have"
            read.note(f"{', '.join(map(repr, given))} {verb} no effect without "
                      "'fitting_forw_sim': True, which enables the post-fine-tuning")
        return {}, df
    settings = {"fit_mode": "simulation"}
    if read.given("n_iter_outer"):
        settings["shooting_iterations"] = read.integer("n_iter_outer", 1)
    if read.supplied("outer_tol"):
        read.note("'outer_tol' has no effect: the output-error stage (multiple "
                  "shooting) stops at its own tolerances or after n_iter_outer iterations")
    simul = _params_simul(read)
    df = _with_time(df, simul, read.where)
    df = _with_inputs(df, simul, skeleton, read.where)
    _check_start(df, simul, skeleton, read)
    for text in simul.notes:
        read.note(text)
    return settings, df
