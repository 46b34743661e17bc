"""Inputs read at a delayed time: ``u(t - a5)`` (a fitted delay) or ``u(t - 0.3)``.

A delayed input is one more input of the skeleton, named by how it is
written: the symbol ``u(t - a5)``. With a number for its delay the name says
everything needed to make its column from the record (:func:`delayed_column`),
so every layer that reads inputs reads it as it reads any other. With a
parameter the delay is fitted: the estimator tries delays as numbers
(:meth:`~sklearn_pycc.skeleton.Skeleton.with_delays`) and keeps the best.
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["delayed_column", "delayed_name", "read_delayed"]

_DELAYED = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\(t - ([A-Za-z0-9_.+\-e]+)\)$")


def delayed_name(signal: str, delay: str | float) -> str:
    """The symbol of ``signal`` read ``delay`` (a parameter's name or a number) late.

    A delay of zero is the signal itself.
    """
    if isinstance(delay, str):
        return f"{signal}(t - {delay})"
    if float(delay) == 0.0:
        return signal
    value = float(delay)
    text = str(int(value)) if value.is_integer() and value < 1e15 else f"{value:.12g}"
    return f"{signal}(t - {text})"


def read_delayed(name: str) -> tuple[str, str | float] | None:
    """``(signal, delay)`` of a delayed input's symbol, or None for any other name.

    The delay is a parameter's name (``"a5"``) or a number of time units.
    """
    match = _DELAYED.match(name)
    if match is None:
        return None
    signal, delay = match.groups()
    if delay[0] == "a" and delay[1:].isdigit():
        return signal, delay
    return signal, float(delay)


def delayed_column(values: np.ndarray, t: np.ndarray, delay: float,
                   trajectory: np.ndarray | None = None) -> np.ndarray:
    """``values`` as read ``delay`` time units late, each experiment on its own.

    Between samples the signal is interpolated linearly; before an
    experiment's first sample it holds its first value (nothing earlier was
    recorded).
    """
    values = np.asarray(values, dtype=float)
    t = np.asarray(t, dtype=float)
    out = np.empty_like(values)
    if trajectory is None:
        groups = [np.arange(len(values))]
    else:
        labels = np.asarray(trajectory)
        groups = [np.flatnonzero(labels == label) for label in dict.fromkeys(labels.tolist())]
    for rows in groups:
        if np.any(np.diff(t[rows]) <= 0):
            raise ValueError("an input read late needs the time of each experiment to "
                             "increase from sample to sample")
        out[rows] = np.interp(t[rows] - float(delay), t[rows], values[rows])
    return out
