"""Checks and noise shared by the data generators (:mod:`sklearn_pycc.datasets`)."""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np
import pandas as pd

__all__ = ["add_noise", "check_n_samples", "check_noise", "check_noise_columns",
           "check_random_state", "check_real", "check_t_span"]

_TIME = "t"


# -- validation ---------------------------------------------------------------
def check_n_samples(n_samples) -> int:
    if (not isinstance(n_samples, numbers.Integral) or isinstance(n_samples, bool)
            or n_samples < 2):
        raise ValueError(f"n_samples must be an integer >= 2, got {n_samples!r}")
    return int(n_samples)


def check_t_span(t_span) -> tuple[float, float]:
    if isinstance(t_span, (str, bytes)):
        raise ValueError(f"t_span must be a pair (t_start, t_end) of floats, got {t_span!r}")
    try:
        values = [float(v) for v in t_span]
    except (TypeError, ValueError):
        raise ValueError(
            f"t_span must be a pair (t_start, t_end) of floats, got {t_span!r}") from None
    if len(values) != 2:
        raise ValueError(
            f"t_span must be a pair (t_start, t_end) of floats, got {len(values)} values")
    start, end = values
    if not (math.isfinite(start) and math.isfinite(end)):
        raise ValueError(f"t_span must hold finite times, got {t_span!r}")
    if not start < end:
        raise ValueError(f"t_span must be increasing (t_start < t_end), got {t_span!r}")
    return start, end


def check_real(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a finite float, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be a finite float, got {value!r}")
    return value


def check_noise(noise) -> float | None:
    if noise is None:
        return None
    if isinstance(noise, bool) or not isinstance(noise, numbers.Real):
        raise ValueError(
            f"noise must be None or a finite signal-to-noise ratio in dB, got {noise!r}")
    noise = float(noise)
    if not math.isfinite(noise):
        raise ValueError(
            f"noise must be None or a finite signal-to-noise ratio in dB, got {noise!r}")
    return noise


def check_noise_columns(noise_columns, columns: Sequence[str],
                         states: Sequence[str]) -> list[str]:
    if noise_columns is None:
        return list(states)
    if isinstance(noise_columns, str):
        noise_columns = [noise_columns]
    try:
        chosen = list(noise_columns)
    except TypeError:
        raise ValueError(
            f"noise_columns must be None or a list of column names, got {noise_columns!r}"
        ) from None
    allowed = [c for c in columns if c != _TIME]
    for name in chosen:
        if name == _TIME:
            raise ValueError("noise_columns cannot include the time column 't'")
        if name not in allowed:
            raise ValueError(
                f"noise_columns names {name!r}, which is not a column of the data set; "
                f"choose among {', '.join(map(repr, allowed))}")
    # keep the first occurrence of each name, in the order given
    return list(dict.fromkeys(chosen))


def check_random_state(random_state) -> np.random.Generator:
    try:
        return np.random.default_rng(random_state)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"random_state must be None, an integer or a numpy Generator, got {random_state!r}"
        ) from exc


# -- noise ----------------------------------------------------------------------
def add_noise(frame: pd.DataFrame, snr_db: float, columns: Sequence[str],
               rng: np.random.Generator) -> pd.DataFrame:
    """Add white Gaussian noise at a signal-to-noise ratio to some columns.

    Parameters
    ----------
    frame : pandas.DataFrame
        The noise-free data; it is not modified.
    snr_db : float
        Signal-to-noise ratio in decibels. For each column the noise has
        standard deviation ``rms(column) / 10**(snr_db / 20)`` with
        ``rms = sqrt(mean(column**2))``.
    columns : sequence of str
        Columns to corrupt, noise drawn in this order.
    rng : numpy.random.Generator
        Source of the noise.

    Returns
    -------
    pandas.DataFrame
        A copy of ``frame`` with noise added to ``columns``.

    """
    noisy = frame.copy()
    scale = 10.0 ** (snr_db / 20.0)
    for name in columns:
        values = noisy[name].to_numpy(dtype=float)
        rms = float(np.sqrt(np.mean(values**2)))
        sigma = rms / scale
        noisy[name] = values + rng.normal(0.0, sigma, size=values.shape)
    return noisy
