"""Simulate a fitted model against measurements: whole experiments, or windows of a horizon.

A whole-record simulation of an integrator drifts, a lightly damped
oscillator's phase slips and a chaotic trajectory separates, however good
the model: their error says little about the dynamics. Windows of a
horizon, each restarted from the measured (estimated) state, test the
dynamics over the time they act, and pool the errors
(:func:`simulate_horizon`; ``horizon="auto"`` chooses it from the model and
the record, :func:`horizon_of`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..exceptions import SimulationError
from ..windows import Horizon, choose_horizon, simulate_windows
from ._data import TIME, Measurements

__all__ = ["Divergence", "Horizon", "horizon_of", "simulate_against", "simulate_experiments",
           "simulate_horizon"]


@dataclass(frozen=True)
class Divergence:
    """A simulation that stopped before the end of its experiment."""

    trajectory: object
    t_reached: float
    t_end: float
    reason: str

    def __str__(self) -> str:
        where = "" if self.trajectory is None else f" (trajectory {self.trajectory!r})"
        return (f"the simulation stopped at t={self.t_reached:.4g} of {self.t_end:.4g}"
                f"{where}: {self.reason}")


def simulate_experiments(model, data: Measurements, *, max_steps: int,
                         rtol: float = 1e-6, atol: float = 1e-8):
    """Simulated states on every measured row.

    Returns
    -------
    simulated : ndarray of shape (n_samples, n_states)
        NaN after a divergence.
    divergences : list of Divergence
    warned : list of str
        Warnings the simulations raised (extrapolation beyond the training
        range, for instance), once each.
    """
    states = model.skeleton_.states
    inputs = model.skeleton_.inputs
    simulated = np.full((data.n_samples, len(states)), np.nan)
    divergences: list[Divergence] = []
    warned: list[str] = []
    for label, rows in data.groups:
        t = data.columns[TIME][rows]
        if len(t) < 2:
            simulated[rows] = np.column_stack([data.columns[s][rows] for s in states])
            continue
        y0 = [float(data.columns[s][rows[0]]) for s in states]
        signals = {name: data.signals.get(name, data.columns[name])[rows] for name in inputs}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                frame = model.simulate(t, y0, signals, rtol=rtol, atol=atol,
                                       max_steps=max_steps)
            except SimulationError as exc:
                frame = exc.partial
                divergences.append(Divergence(label, float(exc.t_reached), float(t[-1]),
                                              str(exc.args[0]) if exc.args else str(exc)))
        for item in caught:
            text = str(item.message)
            if text not in warned:
                warned.append(text)
        if frame is not None and len(frame):
            k = len(frame)
            simulated[rows[:k]] = frame[states].to_numpy(dtype=float)
    return simulated, divergences, warned


def _columns(model, data: Measurements) -> dict[str, np.ndarray]:
    skeleton = model.skeleton_
    names = [*skeleton.states, *(n for n in skeleton.inputs if n != TIME)]
    out = {name: data.columns[name] for name in names}
    out[TIME] = data.columns[TIME]
    return out


def _experiments(data: Measurements) -> list[tuple[np.ndarray, np.ndarray]]:
    return [(rows, data.columns[TIME][rows]) for _, rows in data.groups]


def horizon_of(model, data: Measurements, horizon="auto") -> Horizon:
    """The horizon of a comparison of ``model`` with ``data`` (see :func:`choose_horizon`)."""
    if horizon is None:
        return Horizon(None, None, "whole experiments")
    system = model.skeleton_.compile(model.functions_, model.params_)
    return choose_horizon(system, model.skeleton_.states, _columns(model, data),
                          _experiments(data), horizon)


def simulate_horizon(model, data: Measurements, horizon: Horizon):
    """Simulated states on every row, each window restarted from the measured state.

    Returns
    -------
    simulated : ndarray of shape (n_samples, n_states)
    divergences : list of Divergence
        One per experiment with windows that left the states' range.
    warned : list of str
        Always empty (kept to match :func:`simulate_experiments`).
    """
    skeleton = model.skeleton_
    inputs = [n for n in skeleton.inputs if n != TIME]
    system = skeleton.compile(model.functions_, model.params_)
    signals = {name: data.signals.get(name, data.columns[name]) for name in inputs}
    simulated, escaped = simulate_windows(
        system, skeleton.states, inputs, TIME in skeleton.variables, _columns(model, data),
        signals, _experiments(data), horizon, data.n_samples)
    labels = [label for label, _ in data.groups]
    divergences = [Divergence(labels[e], start, end,
                              f"{count} of {total} windows of the horizon left the states' "
                              "range")
                   for e, (start, end, count, total) in escaped.items()]
    return simulated, divergences, []


def simulate_against(model, data: Measurements, horizon: Horizon, *, max_steps: int):
    """:func:`simulate_horizon`, or :func:`simulate_experiments` for whole experiments."""
    if horizon.samples is None:
        return simulate_experiments(model, data, max_steps=max_steps)
    return simulate_horizon(model, data, horizon)
