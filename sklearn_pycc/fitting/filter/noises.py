"""Which states a process noise pushes, and which intensities are fitted: :class:`NoiseLayout`."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from numbers import Real

import numpy as np

from ..initial_state import state_settings

__all__ = ["NoiseLayout", "check_measurement_noise", "check_process_noise"]


@dataclass(frozen=True)
class NoiseLayout:
    """The process noise of each state: fitted (alone or shared), held at a value, or none.

    Attributes
    ----------
    n_states : int
        How many states the skeleton has.
    groups : tuple of tuple of int
        The states of each fitted intensity: one state each by default,
        several where they share one.
    held : tuple of (int, float)
        States whose intensity is given, with its value. A state in
        neither is not pushed.
    measurement_held : tuple of (int, float)
        Measured states (by their position among the measured ones) whose
        measurement noise is given (a standard deviation); the others' is
        fitted.
    """

    n_states: int
    groups: tuple[tuple[int, ...], ...]
    held: tuple[tuple[int, float], ...] = ()
    measurement_held: tuple[tuple[int, float], ...] = ()

    @classmethod
    def each(cls, noisy: Sequence[int], n_states: int) -> NoiseLayout:
        """Every state of ``noisy`` with its own fitted intensity, the others not pushed."""
        return cls(int(n_states), tuple((int(j),) for j in noisy))

    @property
    def n_fitted(self) -> int:
        """How many intensities are fitted."""
        return len(self.groups)

    def intensities(self, fitted: np.ndarray) -> np.ndarray:
        """Every state's intensity, given the fitted ones (one per group)."""
        q = np.zeros(self.n_states)
        for j, value in self.held:
            q[j] = value
        for group, value in zip(self.groups, np.asarray(fitted, dtype=float)):
            q[list(group)] = value
        return q

    def fitted_of(self, q: np.ndarray) -> np.ndarray:
        """The fitted intensities ``q`` (one per state) gives: each group's mean."""
        q = np.asarray(q, dtype=float)
        return np.array([float(np.mean(q[list(group)])) for group in self.groups])

    def measurement(self, fitted: np.ndarray) -> np.ndarray:
        """Every measured state's noise, given the fitted ones (in order, the held left out)."""
        fitted = np.asarray(fitted, dtype=float)
        r = np.empty(len(fitted) + len(self.measurement_held))
        held = dict(self.measurement_held)
        free = [j for j in range(len(r)) if j not in held]
        r[free] = fitted
        for j, value in held.items():
            r[j] = value
        return r

    def measurement_fitted_of(self, r: np.ndarray) -> np.ndarray:
        """The fitted measurement noises of ``r`` (one per measured state)."""
        held = dict(self.measurement_held)
        return np.array([value for j, value in enumerate(np.asarray(r, dtype=float))
                         if j not in held])


def _reads_as_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def check_process_noise(process_noise: Mapping | None, states: Sequence[str],
                        default: Sequence[int]) -> NoiseLayout:
    """The layout the estimator's ``process_noise`` asks for, checked against the skeleton.

    Parameters
    ----------
    process_noise : dict or None
        State -> a non-negative number (its intensity, held) or a name (a
        fitted intensity, shared by the states given the same name).
    states : sequence of str
        The skeleton's states, in order.
    default : sequence of int
        The states pushed, each by its own fitted intensity, where
        ``process_noise`` does not say otherwise.

    Raises
    ------
    ValueError
        Naming the entry that is not a state, or whose value is neither a
        non-negative number nor a name.
    """
    states = list(states)
    settings = state_settings("process_noise", process_noise, states)
    for state, value in settings.items():
        number = isinstance(value, Real) and not isinstance(value, bool)
        if number and not (np.isfinite(value) and value >= 0):
            raise ValueError(f"process_noise[{state!r}] must be a non-negative intensity or a "
                             f"name, got {value!r}")
        if not number and not (isinstance(value, str) and value.strip()):
            raise ValueError(f"process_noise[{state!r}] must be a non-negative intensity (held) "
                             f"or a name (fitted, shared by the states given it), got "
                             f"{value!r}")
        if not number and _reads_as_number(value):
            raise ValueError(f"process_noise[{state!r}] is the text {value!r}, which reads as a "
                             "number: give the number to hold the intensity, or a name (not a "
                             "number) to fit one")
    groups: dict[str, list[int]] = {}
    held = []
    for j, state in enumerate(states):
        value = settings.get(state, state if j in set(default) else 0.0)
        if isinstance(value, str):
            # a default state's own group is keyed so that no name given can join it
            key = value.strip() if state in settings else f"\0{state}"
            groups.setdefault(key, []).append(j)
        elif value > 0:
            held.append((j, float(value)))
    return NoiseLayout(len(states), tuple(tuple(g) for g in groups.values()), tuple(held))


def check_measurement_noise(measurement_noise: Mapping | None, states: Sequence[str],
                            measured: Sequence[str] | None = None
                            ) -> tuple[tuple[int, float], ...]:
    """The held measurement noises the estimator's ``measurement_noise`` gives, checked.

    Parameters
    ----------
    measurement_noise : dict or None
        State -> the standard deviation of its sensor's noise (positive).
    states : sequence of str
        The skeleton's states.
    measured : sequence of str, optional
        The measured states, in the filter's order: where given, each held
        noise is returned by its position among them.

    Raises
    ------
    ValueError
        Naming the entry that is not a state (or not a measured one), or
        whose value is not a positive finite number.
    """
    settings = state_settings("measurement_noise", measurement_noise, list(states))
    for state, value in settings.items():
        number = isinstance(value, Real) and not isinstance(value, bool)
        if not (number and np.isfinite(value) and value > 0):
            raise ValueError(f"measurement_noise[{state!r}] must be a positive standard "
                             f"deviation (a number), got {value!r}")
    if measured is None:
        return ()
    unmeasured = [state for state in settings if state not in measured]
    if unmeasured:
        raise ValueError(f"measurement_noise names {unmeasured[0]!r}, which X does not measure "
                         f"(measured: {', '.join(measured)})")
    return tuple((list(measured).index(state), float(value))
                 for state, value in settings.items())
