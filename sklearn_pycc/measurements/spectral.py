"""What a record's spectrum says about differentiating it: noise floor, cutoff, quantisation.

These are the measurements behind ``differentiation="auto"``. A sampled
signal is signal below some frequency and noise (sensor noise, quantisation)
above it. The noise floor is read from the top of the band, and the low-pass
cutoff is the one that minimises the estimated error of the highest
derivative needed: below the cutoff the filter passes noise, above it the
filter removes signal, and both are weighted by ``(2 pi f)^(2 k)`` for the
``k``-th derivative (the error a brick-wall low-pass would make).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, signal

__all__ = ["Quantum", "SpectrumReading", "choose_cutoff", "find_quantum", "read_spectrum"]

#: the share of the band, counted down from the Nyquist frequency, that gives the noise floor
FLOOR_BAND = 0.35
#: a record this many times quieter than its signal (in power) counts as noise-free
CLEAN_RATIO = 1e-10


@dataclass(frozen=True)
class Quantum:
    """The step of a quantised measurement (an encoder count, an ADC least significant bit)."""

    step: float
    #: share of the sample-to-sample changes that are whole multiples of the step
    share: float

    @property
    def noise_variance(self) -> float:
        """Variance of uniform rounding noise, ``step^2 / 12``."""
        return self.step**2 / 12.0


@dataclass(frozen=True)
class SpectrumReading:
    """A record's power spectral density and what it implies.

    Attributes
    ----------
    frequencies, density : ndarray
        One-sided PSD (Welch, linear detrend per segment, median-smoothed
        across bins), in units² per Hz.
    floor : float
        Noise floor (PSD units), from the top ``FLOOR_BAND`` of the band.
    noise_std : float
        Standard deviation of the white noise the floor implies.
    signal_std : float
        Standard deviation of the record after a linear detrend.
    """

    frequencies: np.ndarray
    density: np.ndarray
    floor: float
    noise_std: float
    signal_std: float

    @property
    def nyquist(self) -> float:
        """Half the sampling rate."""
        return float(self.frequencies[-1])

    @property
    def snr_db(self) -> float:
        """Signal-to-noise ratio in decibels (infinite for a noise-free record)."""
        if self.noise_std <= 0:
            return float("inf")
        return float(20 * np.log10(max(self.signal_std, 1e-300) / self.noise_std))


def _segment_length(n: int) -> int:
    """Welch segment: the whole of a short record, about an eighth of a long one."""
    if n <= 1024:
        return n
    return int(min(n, max(1024, 2 ** int(np.ceil(np.log2(n / 8))))))


def read_spectrum(x: np.ndarray, step: float, quantum: Quantum | None = None) -> SpectrumReading:
    """Estimate the PSD of evenly spaced samples and the noise floor at its top.

    Parameters
    ----------
    x : ndarray
        Samples on an even grid.
    step : float
        The grid's time step.
    quantum : Quantum, optional
        A known quantisation step: the floor is at least its rounding noise.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    fs = 1.0 / step
    length = _segment_length(n)
    frequencies, density = signal.welch(x, fs=fs, nperseg=length, detrend="linear",
                                        scaling="density")
    # the fewer segments Welch averages, the wider the median across bins
    segments = 1 + (n - length) // max(1, length // 2)
    width = max(3, round(15 / np.sqrt(segments)) | 1)
    smoothed = ndimage.median_filter(density, size=width, mode="nearest")
    top = frequencies >= (1.0 - FLOOR_BAND) * frequencies[-1]
    top[-1] = False  # the Nyquist bin is biased by the window
    floor = float(np.median(smoothed[top])) if top.any() else float(smoothed[-1])
    if quantum is not None:
        floor = max(floor, 2.0 * quantum.noise_variance / fs)
    detrended = signal.detrend(x, type="linear")
    signal_std = float(np.std(detrended))
    # a straight line leaves rounding only: nothing above it to call signal or noise
    straight = signal_std <= 1e-12 * (float(np.max(np.abs(x))) or 1.0)
    if straight or floor <= CLEAN_RATIO * signal_std**2 / fs:
        floor = 0.0
    noise_std = float(np.sqrt(floor * fs / 2.0))
    return SpectrumReading(frequencies, smoothed, floor, noise_std, signal_std)


def choose_cutoff(reading: SpectrumReading, order: int,
                  noise: np.ndarray | None = None) -> float:
    """The brick-wall cutoff that minimises the estimated error of the ``order``-th derivative.

    The error of cutting at ``fc`` is the noise passed below it plus the
    signal removed above it, both weighted by ``(2 pi f)^(2 order)``.
    ``noise`` is the noise's density at the reading's frequencies (coloured
    noise, see :mod:`.noise`); by default the flat floor.
    Returns the Nyquist frequency when nothing is worth removing.
    """
    f, p, floor = reading.frequencies, reading.density, reading.floor
    if floor <= 0 and noise is None:
        return reading.nyquist
    weight = (2 * np.pi * f) ** (2 * max(order, 1))
    density = np.full_like(p, floor) if noise is None else np.asarray(noise, dtype=float)
    excess = np.maximum(p - density, 0.0) * weight
    noise = density * weight
    # error(k) = noise passed in bins [0, k) + signal lost in bins [k, end)
    passed = np.concatenate([[0.0], np.cumsum(noise)])
    lost = np.concatenate([np.cumsum(excess[::-1])[::-1], [0.0]])
    error = passed + lost
    k = int(np.argmin(error))
    if k >= len(f):
        return reading.nyquist
    return float(f[max(k, 1)])


def find_quantum(x: np.ndarray, tolerance: float = 0.05) -> Quantum | None:
    """The step a quantised record moves in, or None when its values are not on a lattice.

    A record is quantised (an encoder's counts, an ADC's least significant
    bit) when nearly all of its sample-to-sample changes are whole multiples
    of the smallest non-zero change.
    """
    x = np.asarray(x, dtype=float)
    changes = np.abs(np.diff(x))
    scale = float(np.max(np.abs(x))) or 1.0
    moving = changes[changes > 1e-12 * scale]
    if len(moving) < 10:
        return None
    step = float(np.min(moving))
    ratio = moving / step
    whole = np.abs(ratio - np.round(ratio)) <= tolerance
    share = float(np.mean(whole))
    if share < 0.99:
        return None
    counts = np.round(ratio)
    if len(moving) == len(changes) and np.all(counts == counts[0]):
        return None  # one change, every sample: a straight line, not a lattice
    # refine the step over all changes (the smallest one carries rounding error)
    step = float(np.sum(moving * counts) / np.sum(counts * counts))
    return Quantum(step, share)
