"""Zero-phase low-pass filtering, then central differences: the identification recipe.

:class:`LowpassDifferentiator` filters one experiment with a zero-phase
Butterworth low-pass (forward and backward, so nothing is delayed) and
differentiates the result with a band-limited differentiator (a windowed
ideal one), exact to a part in 10^4 up to 0.84 of the Nyquist frequency: a
record at ten samples per period is differentiated as exactly as a slow one. Inputs are
filtered by the same filter, so that the equation still holds between the
filtered signals (a controller's output has content the filtered
acceleration no longer has). A record whose samples are evenly spaced but
for dropped ones is filled by cubic interpolation before filtering and read
back at its own samples; an irregular one is resampled on an even grid.

:class:`AutoDifferentiator` (``differentiation="auto"``) chooses the cutoff
per experiment from the record's spectrum (see :mod:`sklearn_pycc.measurements.spectral`).
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from ..._utils.bandlimited import HALF, EvenGrid, central_derivative, even_grid
from ..noise import read_noise
from ..spectral import choose_cutoff, find_quantum, read_spectrum
from ._classic import Differentiator

__all__ = ["AutoDifferentiator", "LowpassDifferentiator", "central_derivative", "even_grid"]

#: Butterworth order of the low-pass (applied twice: forward and backward)
FILTER_ORDER = 6
#: above this share of the Nyquist frequency a low-pass is not worth applying
NO_FILTER_ABOVE = 0.8
#: the filter's cutoff sits this far above the chosen brick-wall cutoff (its transition band)
CUTOFF_MARGIN = 1.2
#: periods of the cutoff a filtered record's ends are left to settle
SETTLING_PERIODS = 2.0
#: samples an experiment needs for a spectrum; shorter ones get plain central differences
MIN_SPECTRUM_SAMPLES = 16


class LowpassDifferentiator(Differentiator):
    """Zero-phase Butterworth low-pass at ``cutoff`` Hz, then a band-limited differentiator.

    Parameters
    ----------
    cutoff : float or None
        Cutoff frequency in cycles per time unit of ``t`` (Hz for seconds);
        None or a value at or above the Nyquist frequency filters nothing.
    order : int, default=6
        Butterworth order of each of the two passes.
    filter_inputs : bool, default=True
        Filter the inputs with the same filter.
    note : str, default=""
        What the record showed, appended to :meth:`describe` (``"auto"``
        writes its reading of the spectrum here).
    snr_db : float or None, default=None
        The lowest signal-to-noise ratio of the record's states, when read
        (``"auto"``; ``inf`` for a noise-free record).
    """

    def __init__(self, cutoff: float | None = None, order: int = FILTER_ORDER,
                 filter_inputs: bool = True, *, note: str = "",
                 snr_db: float | None = None) -> None:
        if cutoff is not None and not (np.isfinite(cutoff) and cutoff > 0):
            raise ValueError(f"lowpass cutoff must be a positive frequency or None, "
                             f"got {cutoff!r}")
        if int(order) != order or not 1 <= order <= 16:
            raise ValueError(f"lowpass order must be an integer from 1 to 16, got {order!r}")
        self.cutoff = cutoff
        self.order = int(order)
        self.filter_inputs = bool(filter_inputs)
        self.note = note
        self.snr_db = snr_db

    def min_samples(self, n: int) -> int:
        """Three samples."""
        return 3

    def describe(self) -> str:
        """The filter and the differentiator, with what the record showed (``note``)."""
        if self.cutoff is None:
            what = "a band-limited differentiator (no filter)"
        else:
            what = (f"zero-phase Butterworth low-pass at {self.cutoff:.4g} Hz (order "
                    f"{self.order}, forward and backward), then a band-limited "
                    "differentiator")
        return what + (f"; {self.note}" if self.note else "")

    def _filters(self, grid: EvenGrid) -> bool:
        """Whether the low-pass does anything on this grid (a cutoff above Nyquist is an error)."""
        nyquist = 0.5 / grid.step
        if self.cutoff is not None and self.cutoff >= nyquist:
            raise ValueError(f"lowpass cutoff {self.cutoff:g} Hz is at or above the record's "
                             f"Nyquist frequency {nyquist:.4g} Hz (half its sampling rate): "
                             "nothing there to filter; give a lower cutoff or "
                             "differentiation='auto'")
        return (self.cutoff is not None and grid.size >= 8
                and self.cutoff < NO_FILTER_ABOVE / (2 * grid.step))

    def _filter(self, t: np.ndarray, x: np.ndarray, grid: EvenGrid) -> np.ndarray:
        z = grid.fill(t, x)
        if not self._filters(grid):
            return z
        fs = 1.0 / grid.step
        sos = signal.butter(self.order, self.cutoff, fs=fs, output="sos")
        padlen = int(min(len(z) - 1, max(6 * self.order, 4 * fs / self.cutoff)))
        return signal.sosfiltfilt(sos, z, padtype="odd", padlen=padlen)

    def derivatives(self, t, x, order):
        """Filtered samples and their derivatives, read back at the samples' times."""
        grid = even_grid(t)
        z = self._filter(t, np.asarray(x, dtype=float), grid)
        series = [z]
        for _ in range(order):
            series.append(central_derivative(series[-1], grid.step))
        return [grid.read(t, s) for s in series]

    def settling(self, t: np.ndarray) -> float:
        """Two periods of the cutoff (at least the differentiator's half-length), when filtering.

        At the ends the filter sees padding instead of the record, and the
        differentiator runs out of neighbours: a record starting in a
        transient (a controller switched on, a saturated drive) would
        otherwise bias the fit by several per cent.
        """
        grid = even_grid(t)
        if not self._filters(grid):
            return 0.0
        return max(SETTLING_PERIODS / self.cutoff, HALF * grid.step)

    def smooth_input(self, t: np.ndarray, u: np.ndarray) -> np.ndarray | None:
        """The input through the same filter (None when nothing is filtered)."""
        if not self.filter_inputs or self.cutoff is None:
            return None
        grid = even_grid(t)
        if not self._filters(grid):
            return None
        return grid.read(t, self._filter(t, np.asarray(u, dtype=float), grid))


class AutoDifferentiator(Differentiator):
    """Derivatives chosen from the record: ``differentiation="auto"``.

    For each experiment, every measured state is looked at on its even grid
    (dropped samples filled, an irregular grid resampled): its spectrum
    gives the noise floor (at least the rounding noise of a quantised
    record), or, where the noise is coloured, its model (see :mod:`.noise`),
    and the cutoff that minimises the estimated error of the highest
    derivative needed. The experiment is then filtered at the
    lowest cutoff among its states (inputs too) by
    :class:`LowpassDifferentiator`; a noise-free record is differentiated
    without a filter.
    """

    def describe(self) -> str:
        """What ``"auto"`` does, before it has seen a record."""
        return ("chosen from the record (zero-phase low-pass at a cutoff read from its "
                "spectrum, then a band-limited differentiator)")

    def for_experiment(self, t: np.ndarray, states: dict[str, np.ndarray],
                       order: int) -> Differentiator:
        """A :class:`LowpassDifferentiator` set from this experiment's spectrum."""
        if len(t) < MIN_SPECTRUM_SAMPLES or not states:
            return LowpassDifferentiator(
                None, note=f"{len(t)} samples are too few to read a spectrum")
        grid = even_grid(t)
        fs = 1.0 / grid.step
        cutoffs, notes, snrs = {}, [], []
        for name, x in states.items():
            quantum = find_quantum(x)
            even = grid.fill(t, x)
            reading = read_spectrum(even, grid.step, quantum)
            noise = read_noise(even, grid.step, name=name, quantum=quantum)
            if noise.coloured:  # the noise rises below the band's top: its model, not a floor
                cutoffs[name] = choose_cutoff(reading, order, noise.density(reading.frequencies))
                snrs.append(noise.snr_db)
                notes.append(noise.describe())
                continue
            cutoffs[name] = choose_cutoff(reading, order)
            snrs.append(reading.snr_db)
            snr = ("no noise" if not np.isfinite(reading.snr_db)
                   else f"noise {reading.noise_std:.3g} (SNR {reading.snr_db:.0f} dB)")
            if quantum is not None:
                snr += f", quantised in steps of {quantum.step:.3g}"
            notes.append(f"{name}: {snr}")
        cutoff = min(cutoffs.values()) * CUTOFF_MARGIN
        sampling = f"{fs:.4g} Hz sampling"
        if grid.dropped:
            sampling += f", {grid.dropped} dropped samples filled by cubic interpolation"
        elif grid.resampled:
            sampling += ", uneven: resampled on an even grid"
        return LowpassDifferentiator(None if cutoff >= NO_FILTER_ABOVE * fs / 2 else cutoff,
                                     note=f"{sampling}; " + "; ".join(notes),
                                     snr_db=float(min(snrs)))
