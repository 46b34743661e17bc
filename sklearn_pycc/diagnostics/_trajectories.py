"""Simulate a fitted model against measurements: whole experiments, or windows of a horizon.

A whole-record simulation of an integrator drifts, a lightly damped
oscillator's phase slips and a chaotic trajectory separates, however good
the model: their error says little about the dynamics. Windows of a
horizon, each restarted from the measured (estimated) state, test the
dynamics over the time they act, and pool the errors
(:func:`simulate_against`; ``horizon="auto"`` chooses it from the model and
the record, :func:`horizon_of`).
"""

from __future__ import annotations

import numpy as np

from ..measurements.record import Record
from ..simulation.windows import Divergence, Horizon, choose_horizon, simulate_rows
from ._data import TIME

__all__ = ["Divergence", "Horizon", "horizon_of", "simulate_against"]


def _columns(model, data: Record) -> dict[str, np.ndarray]:
    skeleton = model.skeleton_
    names = [*skeleton.states, *(n for n in skeleton.inputs if n != TIME)]
    out = {name: data.columns[name] for name in names}
    out[TIME] = data.columns[TIME]
    return out


def _experiments(data: Record) -> list[tuple[np.ndarray, np.ndarray]]:
    return [(rows, data.columns[TIME][rows]) for _, rows in data.experiment_rows]


def horizon_of(model, data: Record, horizon="auto") -> Horizon:
    """The horizon of a comparison of ``model`` with ``data`` (see :func:`choose_horizon`)."""
    if horizon is None:
        return Horizon(None, None, "whole experiments")
    system = model.skeleton_.compile(model.functions_, model.params_)
    return choose_horizon(system, model.skeleton_.states, _columns(model, data),
                          _experiments(data), horizon)


def simulate_against(model, data: Record, horizon: Horizon, *, max_steps: int):
    """Simulated states on every row: whole experiments, or windows of ``horizon``.

    The loop the simulation scorer runs too (:func:`~sklearn_pycc.windows.simulate_rows`).

    Returns
    -------
    simulated : ndarray of shape (n_samples, n_states)
        NaN after a divergence.
    divergences : list of Divergence
    warned : list of str
        Warnings the simulations raised (extrapolation beyond the training
        range, for instance), once each.
    """
    skeleton = model.skeleton_
    inputs = [n for n in skeleton.inputs if n != TIME]
    columns = {**{s: data.columns[s] for s in skeleton.states},
               **{name: data.column(name) for name in inputs}, TIME: data.columns[TIME]}
    experiments = [(label, rows, data.columns[TIME][rows]) for label, rows in data.experiment_rows]
    return simulate_rows(model, columns, data.signals, experiments, horizon,
                         n_samples=data.n_samples,
                         max_steps=max_steps)
