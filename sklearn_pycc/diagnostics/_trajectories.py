"""Simulate a fitted model from each experiment's measured start, with its measured inputs."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..exceptions import SimulationError
from ._data import TIME, Measurements

__all__ = ["Divergence", "simulate_experiments"]


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
