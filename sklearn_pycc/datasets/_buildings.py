"""Records of the kind a building logs: room temperatures, heaters and the weather; walls unread.

Each room is the textbook two-node model (a resistance-capacitance
network): the air of the room and the mass of its walls, the walls
exchanging heat with the room and with the outdoors, the room with its
walls, the outdoors (windows, ventilation), its heater and the rooms next
to it. A thermostat's log has the room temperatures, the heaters' power and
the outdoor temperature; nothing reads the walls.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.linalg import expm
from sklearn.utils import Bunch

from ._generation import (
    add_noise,
    check_n_samples,
    check_noise,
    check_noise_columns,
    check_random_state,
    check_t_span,
)
from ._lab_records import positive
from ._process_records import HeldInput

__all__ = ["make_rooms"]

#: seconds in each time unit a record may be written in
TIME_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}

#: each room's rates per hour: walls to room, outdoors to room, heater gain (K/h per kW),
#: room to walls, outdoors to walls; and the rate between two rooms side by side
ROOM_RATES = {"walls": 1.2, "outdoors": 0.3, "heater": 0.8, "into_walls": 0.1,
              "walls_out": 0.02}
BETWEEN_ROOMS = 0.4


def _equations(n_rooms: int) -> tuple[list[str], dict[str, float]]:
    """The skeleton of ``n_rooms`` rooms in a row with numbered parameters, and their values."""
    equations, values, k = [], {}, 0

    def new(value: float) -> str:
        nonlocal k
        k += 1
        values[f"a{k}"] = value
        return f"a{k}"

    rooms, walls = [], []
    for i in range(1, n_rooms + 1):
        room = (f"T{i}_dot = {new(ROOM_RATES['walls'])} (W{i} - T{i}) + "
                f"{new(ROOM_RATES['outdoors'])} (To - T{i}) + {new(ROOM_RATES['heater'])} Q{i}")
        wall = (f"W{i}_dot = {new(ROOM_RATES['into_walls'])} (T{i} - W{i}) + "
                f"{new(ROOM_RATES['walls_out'])} (To - W{i})")
        rooms.append(room)
        walls.append(wall)
    for i in range(1, n_rooms):  # a wall between neighbours, the same conductance both ways
        a = new(BETWEEN_ROOMS)
        rooms[i - 1] += f" + {a} (T{i + 1} - T{i})"
        rooms[i] += f" + {a} (T{i} - T{i + 1})"
    for room, wall in zip(rooms, walls):
        equations += [room, wall]
    return equations, values


def _matrices(n_rooms: int, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """``A`` and ``B`` of ``x_dot = A x + B [To, Q1, ...]`` per hour, x = [T1, W1, T2, W2, ...]."""
    n = 2 * n_rooms
    A, B = np.zeros((n, n)), np.zeros((n, 1 + n_rooms))
    rates = list(values.values())
    for i in range(n_rooms):
        walls, out, heater, into, walls_out = rates[5 * i:5 * i + 5]
        r, w = 2 * i, 2 * i + 1
        A[r, r] -= walls + out
        A[r, w] += walls
        B[r, 0] += out
        B[r, 1 + i] += heater
        A[w, w] -= into + walls_out
        A[w, r] += into
        B[w, 0] += walls_out
    for i, between in enumerate(rates[5 * n_rooms:]):
        r, s = 2 * i, 2 * (i + 1)
        A[r, r] -= between
        A[r, s] += between
        A[s, s] -= between
        A[s, r] += between
    return A, B


def _heater(n: int, rng: np.random.Generator) -> np.ndarray:
    """A heater switched among off, half and full power (kW) every 1 to 4 hours of samples."""
    out, k = np.empty(n), 0
    while k < n:
        length = int(rng.integers(12, 48))
        out[k:k + length] = rng.choice([0.0, 1.5, 3.0])
        k += length
    return out


def make_rooms(
    n_samples: int = 1500,
    t_span: tuple[float, float] | None = None,
    *,
    n_rooms: int = 1,
    time_unit: str = "h",
    noise: float | None = 40.0,
    noise_columns=None,
    y0=None,
    random_state=None,
    return_truth: bool = False,
):
    """Rooms in a row heated and cooled through their walls, logged every five minutes.

    For each room ``i`` (rates per hour, written in the record's time unit)::

        Ti_dot = a1 (Wi - Ti) + a2 (To - Ti) + a3 Qi [+ a (Tj - Ti) for each neighbour j]
        Wi_dot = a4 (Ti - Wi) + a5 (To - Wi)

    with the room temperature ``Ti`` (degC, logged), the temperature of its
    walls ``Wi`` (not logged), its heater's power ``Qi`` (kW, switched among
    0, 1.5 and 3 every one to four hours) and the outdoor temperature ``To``
    (a daily swing around 5 degC with a slow random wander). Per hour the
    room follows its walls at 1.2, the outdoors at 0.3, and each neighbour
    through the wall between them at 0.4; the walls follow the room at 0.1
    and the outdoors at 0.02 (a time constant of eight hours). The model is
    linear, and the record is its exact solution with the inputs held
    between samples.

    Parameters
    ----------
    n_samples : int, default=1500
        Samples logged.
    t_span : tuple of float, optional
        Time of the first and the last sample, in ``time_unit``; by default
        one sample every five minutes from 0.
    n_rooms : int, default=1
        Rooms in a row, each next to the one before.
    time_unit : {"h", "min", "s"}, default="h"
        The unit the time column, and so every rate, is written in.
    noise : float or None, default=40.0
        Signal-to-noise ratio in dB of white noise on the ``noise_columns``;
        None for none (:func:`~sklearn_pycc.datasets.add_sensor_noise` adds
        coloured and quantised noise).
    noise_columns : sequence of str, optional
        The noisy columns; by default the room temperatures.
    y0 : sequence of float, optional
        Initial temperatures, room then walls for each room (``T1, W1, T2,
        ...``); by default about 18 degC in the rooms and 12 in the walls.
    random_state : int, Generator or None
        Seeds the heaters, the weather, the initial temperatures and the noise.
    return_truth : bool, default=False
        Also return a Bunch with the skeleton, its parameters, the inputs
        (:class:`HeldInput` each) and the exact temperatures.

    Returns
    -------
    frame : DataFrame
        ``t``, ``To``, each ``Qi`` and each ``Ti``.
    truth : Bunch
        Only with ``return_truth``: ``equations``, ``params`` (in
        ``time_unit``), ``inputs``, ``states`` (every temperature, exact,
        walls included), ``y0`` and ``unmeasured`` (the walls).

    Raises
    ------
    ValueError
        For a setting out of its range, named.

    Examples
    --------
    >>> from sklearn_pycc import datasets
    >>> frame = datasets.make_rooms(random_state=0)
    >>> list(frame.columns), float(frame.t[1] - frame.t[0]) * 60
    (['t', 'To', 'Q1', 'T1'], 5.0)
    """
    n = check_n_samples(n_samples)
    if time_unit not in TIME_UNITS:
        raise ValueError(f"time_unit must be one of {sorted(TIME_UNITS)}, got {time_unit!r}")
    if isinstance(n_rooms, bool) or not isinstance(n_rooms, (int, np.integer)) or n_rooms < 1:
        raise ValueError(f"n_rooms must be a positive integer, got {n_rooms!r}")
    hours = TIME_UNITS[time_unit] / 3600.0  # one time unit in hours
    step = 5.0 / 60.0 / hours
    start, end = (0.0, step * (n - 1)) if t_span is None else check_t_span(t_span)
    h = positive("the sampling step", (end - start) / max(n - 1, 1))
    noise = check_noise(noise)
    rooms = [f"T{i}" for i in range(1, n_rooms + 1)]
    heater_names = [f"Q{i}" for i in range(1, n_rooms + 1)]
    noisy = check_noise_columns(noise_columns, ["t", "To", *heater_names, *rooms], rooms)
    rng = check_random_state(random_state)
    t = start + np.arange(n) * h
    t_hours = t * hours
    outdoor = (5.0 + 5.0 * np.sin(2 * np.pi * t_hours / 24.0 + rng.uniform(0, 2 * np.pi))
               + np.cumsum(rng.normal(0.0, 0.05 * np.sqrt(h * hours * 12), n)))
    heaters = [_heater(n, rng) for _ in range(n_rooms)]
    equations, per_hour = _equations(n_rooms)
    A, B = _matrices(n_rooms, per_hour)
    # exact steps with the inputs held: exp of the augmented matrix over one sample
    m, k = A.shape[0], B.shape[1]
    block = np.zeros((m + k, m + k))
    block[:m, :m], block[:m, m:] = A * h * hours, B * h * hours
    stepped = expm(block)
    Ad, Bd = stepped[:m, :m], stepped[:m, m:]
    x = np.ravel([[18.0 + rng.normal(), 12.0 + rng.normal()] for _ in range(n_rooms)])
    if y0 is not None:
        x = np.array([float(v) for v in y0]) if np.ndim(y0) == 1 else np.zeros(0)
        if x.shape != (2 * n_rooms,) or not np.all(np.isfinite(x)):
            raise ValueError(f"y0 must be {2 * n_rooms} finite temperatures (T1, W1, ...), "
                             f"got {y0!r}")
    start_state = x.copy()
    drive = np.column_stack([outdoor, *heaters])
    states = np.empty((n, m))
    for i in range(n):
        states[i] = x
        x = Ad @ x + Bd @ drive[i]
    names = [name for i in range(1, n_rooms + 1) for name in (f"T{i}", f"W{i}")]
    frame = pd.DataFrame({"t": t, "To": outdoor,
                          **{f"Q{i + 1}": q for i, q in enumerate(heaters)},
                          **{f"T{i}": states[:, 2 * (i - 1)] for i in range(1, n_rooms + 1)}})
    if noise is not None and noisy:
        frame = add_noise(frame, noise, noisy, rng)
    if not return_truth:
        return frame
    inputs = {"To": HeldInput(t, outdoor),
              **{f"Q{i + 1}": HeldInput(t, q) for i, q in enumerate(heaters)}}
    truth = Bunch(equations=equations,
                  params={a: v * hours for a, v in per_hour.items()},
                  inputs=inputs, states=pd.DataFrame(states, columns=names),
                  y0=tuple(float(v) for v in start_state),
                  unmeasured=[f"W{i}" for i in range(1, n_rooms + 1)])
    return frame, truth
