"""The user's initial states: a start's mean, and for the filter its variance."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from numbers import Real

import numpy as np

__all__ = ["check_initial_state", "state_settings"]


def _number(value) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool) and bool(np.isfinite(value))


def state_settings(name: str, settings: Mapping | None, states: Sequence[str]) -> dict:
    """The setting ``name`` (state -> value) as a dict, each key checked to be a state.

    Raises
    ------
    ValueError
        Naming the key that is not a state of the skeleton.
    """
    settings = dict(settings or {})
    for state in settings:
        if state not in states:
            raise ValueError(f"{name} names {state!r}, which is not a state of the skeleton "
                             f"(states: {', '.join(states)})")
    return settings


def check_initial_state(initial_state: Mapping | None,
                        states: Sequence[str]) -> dict[str, tuple[float, float]]:
    """The estimator's ``initial_state``, checked: state -> (mean, variance).

    A number alone fixes the mean (variance 0: the start is known); a pair
    gives the mean and the variance the filter starts from.

    Raises
    ------
    ValueError
        Naming the entry that is not a state, or whose value is neither a
        finite number nor a pair of a finite mean and a non-negative
        variance.
    """
    out = {}
    for state, value in state_settings("initial_state", initial_state, states).items():
        if _number(value):
            out[state] = (float(value), 0.0)
            continue
        pair = isinstance(value, (tuple, list)) and len(value) == 2
        if not (pair and _number(value[0]) and _number(value[1]) and value[1] >= 0):
            raise ValueError(f"initial_state[{state!r}] must be a number (the start) or a pair "
                             f"(mean, variance) with a non-negative variance, got {value!r}")
        out[state] = (float(value[0]), float(value[1]))
    return out
