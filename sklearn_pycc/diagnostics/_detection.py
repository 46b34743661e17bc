"""What a record could have shown: the detection limit of a diagnosis that finds nothing.

"Nothing is missing" is only as strong as the record. An effect the model
lacks shows as a change of the simulated measured states; it stands out
when that change is large against what the judgement compares it with:
the model's own simulation error (the noise, and what the simulations'
starts from noisy states add), over the samples that count as
independent. Coloured noise is worth fewer independent samples than it has
(see :attr:`SignalNoise.memory <sklearn_pycc.measurements.SignalNoise.memory>`),
so the same record is blinder under it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..measurements.noise import read_frame_noise

__all__ = ["DETECTION_Z", "Detection", "above_the_noise", "detection_limits"]

#: standard errors an effect's mark on the simulated states must reach to be seen
DETECTION_Z = 3.0
#: the least change of a measured state's simulation a free curve must make, in units of
#: its sensor's noise level: a shape drawn finer than the sensor reads is not a finding
OPEN_NOISE_FLOOR = 1.0


def above_the_noise(candidates: list, frame, states: list[str], trajectories) -> list:
    """The free curves whose change of a measured state's simulation reaches its noise level.

    A free curve has many numbers; held-out data confirm one that removes a
    slight systematic error the catalogue's laws leave, however far below
    what the sensor resolves (a damping that wanders along an encoder's
    track by a tenth of its step). Its change is read per measured state
    as ``sqrt(before^2 - after^2)`` of the simulation errors; a curve that
    changes no measured state by :data:`OPEN_NOISE_FLOOR` times its
    noise level (its quantisation, its sensor's noise) is dropped, with a
    note saying so.
    """
    measured = [s for s in states if s in frame.columns and s in trajectories.index]
    if "t" not in frame.columns or not measured:
        return candidates
    noise = read_frame_noise(frame, measured)
    kept = []
    for c in candidates:
        if c.state_rmse is None:
            kept.append(c)
            continue
        changes = {s: float(np.sqrt(max(float(trajectories.loc[s, "rmse"]) ** 2
                                        - float(c.state_rmse[states.index(s)]) ** 2, 0.0)))
                   for s in measured if s in noise}
        if not changes or any(change >= OPEN_NOISE_FLOOR * noise[s].level
                              for s, change in changes.items()):
            kept.append(c)
            continue
        state = max(changes, key=lambda s: changes[s] / max(noise[s].level, 1e-300))
        c.note = "; ".join(filter(None, [c.note, (
            f"changes the simulated {state} by {changes[state]:.3g} (RMS), below its "
            f"noise level {noise[state].level:.3g}: a shape finer than the sensor reads")]))
    return kept


@dataclass(frozen=True)
class Detection:
    """One measured state's detection limit and what the model leaves unexplained.

    Attributes
    ----------
    state : str
    limit : float
        The RMS change of the simulated state an effect must make to be
        seen: ``DETECTION_Z`` times the larger of the noise level and the
        model's simulation error, over the square root of the independent
        samples.
    noise : float
        The state's measurement-noise level.
    independent : float
        The judged samples divided by the noise's memory.
    samples : int
        The samples judged.
    error : float
        The model's simulation error (RMS) the judgement starts from.
    """

    state: str
    limit: float
    noise: float
    independent: float
    samples: int
    error: float

    def words(self, unit: str = "") -> list[str]:
        """The limit in words."""
        unit = f" {unit}" if unit else ""
        worth = ("" if self.independent >= 0.95 * self.samples else
                 f", correlated in time: {self.samples:,} samples worth "
                 f"{self.independent:,.0f} independent ones")
        return [f"Detection limit: an effect changing the simulated {self.state} by more "
                f"than {self.limit:.3g}{unit} (RMS) would have been seen (noise "
                f"{self.noise:.3g}{unit}, simulation error {self.error:.3g}{unit}{worth})."]


def detection_limits(frame, measured: list[str], errors: dict[str, float],
                     samples: int) -> dict[str, Detection]:
    """Each measured state's :class:`Detection` from the record and its simulation errors.

    ``errors`` are the model's simulation RMSEs by state over ``samples``
    judged samples; ``frame`` is the record (with ``t``) whose noise is read.
    """
    if "t" not in frame.columns or samples < 16:
        return {}
    noise = read_frame_noise(frame, [s for s in measured if s in errors])
    out = {}
    for state, reading in noise.items():
        error = errors[state]
        if not np.isfinite(error):
            continue
        independent = samples / reading.memory
        limit = DETECTION_Z * max(reading.level, error) / np.sqrt(max(independent, 1.0))
        out[state] = Detection(state, float(limit), reading.level, float(independent),
                               int(samples), float(error))
    return out
