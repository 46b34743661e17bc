"""Noise as sensors give it: coloured, quantised and drifting (``datasets.add_sensor_noise``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import signal

from ._generation import check_noise_columns, check_random_state

__all__ = ["add_sensor_noise"]


def add_sensor_noise(frame: pd.DataFrame, columns: Sequence[str] | None = None, *,
                     snr: float = 40.0, pole: float = 0.0, bits: int | None = None,
                     drift: float = 0.0, random_state=None) -> pd.DataFrame:
    """Add the noise a real sensor gives to some columns of a record.

    Each column gets Gaussian noise whose standard deviation is the
    column's RMS divided by ``10**(snr/20)``, correlated in time as an AR(1)
    process with the given ``pole`` (0: white; 0.9: a correlation time of
    about ten samples), then optionally a slow drift and rounding to an
    analogue-to-digital converter of ``bits`` over the column's range.

    Parameters
    ----------
    frame : DataFrame
        The record; it is not modified.
    columns : list of str, optional
        Columns to corrupt (default: every column but ``t`` and ``trajectory``).
    snr : float, default=40.0
        Signal-to-noise ratio in dB of the coloured noise.
    pole : float, default=0.0
        Pole of the AR(1) noise, in ``[0, 1)``.
    bits : int, optional
        Resolution of the converter: values are rounded to ``range / 2**bits``.
    drift : float, default=0.0
        Standard deviation of a slow random wander (its correlation time a
        fifth of the record), as a share of the column's RMS.
    random_state : int, numpy.random.Generator or None
        Seed of the noise.

    Returns
    -------
    DataFrame
        A copy of ``frame`` with the noise added; a missing sample (NaN)
        stays missing, and the RMS and range are read from the others.

    Raises
    ------
    ValueError
        If a setting is out of range, ``columns`` names ``t`` or a column
        the frame does not have, or a chosen column holds no number or an
        infinite one.

    Examples
    --------
    >>> from sklearn_pycc import datasets
    >>> clean = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=6000,
    ...                                  t_span=(0, 60))
    >>> X = datasets.add_sensor_noise(clean[["t", "x1", "F_ext"]], ["x1"], snr=40, pole=0.9,
    ...                               bits=12, random_state=0)
    """
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(f"frame must be a DataFrame, got {type(frame).__name__}")
    if not (np.isfinite(pole) and 0.0 <= pole < 1.0):
        raise ValueError(f"pole must be in [0, 1), got {pole!r}")
    if not np.isfinite(snr):
        raise ValueError(f"snr must be a finite number of dB, got {snr!r}")
    if bits is not None and (int(bits) != bits or not 2 <= bits <= 32):
        raise ValueError(f"bits must be an integer from 2 to 32, got {bits!r}")
    if not (np.isfinite(drift) and drift >= 0):
        raise ValueError(f"drift must be a non-negative share of the RMS, got {drift!r}")
    names = [c for c in frame.columns if c not in ("t", "trajectory")]
    chosen = check_noise_columns(columns, [str(c) for c in frame.columns], names)
    rng = check_random_state(random_state)
    noisy = frame.copy()
    n = len(frame)
    for name in chosen:
        values = noisy[name].to_numpy(dtype=float)
        present = ~np.isnan(values)  # a missing sample stays missing; the others get noise
        if not present.any() or np.isinf(values).any():
            held = "no number" if not present.any() else "an infinite value"
            raise ValueError(f"column {name!r} holds {held}: sensor noise is scaled by the "
                             "signal's RMS")
        rms = float(np.sqrt(np.mean(values[present] ** 2)))
        white = rng.normal(0.0, 1.0, n)
        white[0] /= np.sqrt(1.0 - pole**2)  # the AR process starts in its stationary state
        coloured = signal.lfilter([1.0], [1.0, -pole], white) * np.sqrt(1.0 - pole**2)
        out = values + coloured * rms / 10.0 ** (snr / 20.0)
        if drift > 0:
            slow = signal.lfilter([1.0], [1.0, -np.exp(-5.0 / n)], rng.normal(0.0, 1.0, n))
            slow = slow - slow.mean()
            out = out + slow / (np.std(slow) or 1.0) * drift * rms
        if bits is not None:
            quantum = (float(np.nanmax(values)) - float(np.nanmin(values))) / 2.0**bits
            if quantum > 0:
                out = np.round(out / quantum) * quantum
        noisy[name] = out
    return noisy
