"""What a measured signal's noise is: level, colour, quantisation and drift, read from the record.

Sensors rarely give white noise. A filter inside the sensor, vibration, a
closed loop or a tracker's smoothing make it **coloured**: correlated from
sample to sample, strong at low frequencies and weak at the top of the band.
Read from the top of the spectrum alone, such noise looks small, and what it
puts into the signal's band looks like signal.

:func:`read_noise` reads the noise of one evenly sampled signal as a
process. Above the band the signal occupies, the spectrum is noise alone; a
noise model (white, or an autoregressive process of order 1 or 2 plus a
white part, such as rounding) is fitted there by Whittle's likelihood, the
band of that fit widened downwards as long as the model explains the
spectrum, and the model carried into the signal's band. A coloured model is
kept only when it explains the noise band decisively better than white
noise; otherwise the reading is the flat floor of the band's top, as it
always was.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage, optimize, signal

from .spectral import CLEAN_RATIO, FLOOR_BAND

__all__ = [
    "NoiseReading",
    "SignalNoise",
    "multitaper_density",
    "read_noise",
    "second_difference_level",
    "slow_memory",
    "uneven_level",
]

#: a coloured reading this many times quieter than the signal (in power, 80 dB) is the
#: tapers' own leakage from a noise-free signal
QUIET_RATIO = 1e-8
#: autoregressive orders tried for coloured noise
AR_ORDERS = (1, 2)
#: an AR(1) fit to the band's top with a smaller pole, on a spectrum that does not fall
#: across that band by more than ``FLAT_SLOPE``, reads the noise as white at once
COLOUR_GATE = 0.3
FLAT_SLOPE = 1.1
#: a coloured model must lower the Whittle criterion (with the BIC's penalty) by this much
COLOUR_EVIDENCE = 10.0
#: and its spectrum must fall by at least this factor across the band it was fitted on
COLOUR_CONTRAST = 2.0
#: the ratio of the spectrum to the noise model above which a bin is counted as signal
SIGNAL_RATIO = 3.0
#: the largest partial autocorrelation of a fitted AR model (a pole at most this close to 1)
MAX_PARTIAL = 0.999
#: a noise model may rise to this multiple of the record's spectrum below its band, no higher
CEILING = 2.0
#: how strongly a longer noise memory must be asked for (see ``_whittle_ar``)
POLE_PRIOR = 1.0
#: passes of the fit-and-widen iteration
WIDENINGS = 4
#: readings remembered by their samples: every fit of one record (a loop's rounds, a
#: diagnosis's refits) reads the same signals, and a reading takes a fraction of a second
REMEMBERED = 16
_readings: OrderedDict[tuple, SignalNoise] = OrderedDict()


#: the slowest frequencies a record resolves (1 to this many cycles over it), where
#: :func:`slow_memory` reads a residual's wander
SLOW_BINS = 3

#: time-bandwidth product and number of the Slepian tapers of the multitaper spectrum
TAPER_NW = 4.0
TAPERS = 7
#: a longer record is read in pieces of this many samples, whose spectra are averaged
PIECE = 2**16


def multitaper_density(x: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray, float]:
    """One-sided multitaper PSD of evenly spaced samples, averaged over bands of ``2 NW`` bins.

    Slepian tapers leak almost nothing from the strong low-frequency signal
    into the noise above it (a Hann window's sidelobes do), and the whole
    record's resolution lets the noise band reach close to the signal.
    Returns the frequencies, the density (units² per frequency unit) and the
    degrees of freedom of each returned value over two (a chi-square's
    ``dof / 2``, what weights Whittle's criterion).
    """
    # pre-whitened by a first difference: the signal's strong low frequencies are cut
    # down before the tapers see them, and the tapers' broadband leakage with them
    x = np.diff(np.asarray(x, dtype=float))
    n = len(x)
    pieces = max(1, n // PIECE)
    length = n // pieces
    tapers = signal.windows.dpss(length, TAPER_NW, TAPERS)
    total = None
    for k in range(pieces):
        piece = x[k * length:(k + 1) * length]
        piece = piece - piece.mean()
        spectra = np.abs(np.fft.rfft(tapers * piece, axis=1)) ** 2
        power = spectra.mean(axis=0)
        total = power if total is None else total + power
    frequencies = np.fft.rfftfreq(length, step)
    difference = 4.0 * np.sin(np.pi * frequencies * step) ** 2
    difference[0] = np.inf  # what a difference leaves at zero frequency is not read
    density = 2.0 * step * total / pieces / difference
    # neighbouring bins within the tapers' bandwidth are nearly the same estimate
    group = int(2 * TAPER_NW)
    usable = (len(frequencies) - 1) // group * group
    density = np.concatenate([density[:1], density[1:usable + 1].reshape(-1, group).mean(1)])
    frequencies = np.concatenate([frequencies[:1],
                                  frequencies[1:usable + 1].reshape(-1, group).mean(1)])
    return frequencies, density, float(TAPERS * pieces)


def _ar_denominator(ar: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """``|1 - sum_k ar[k] exp(-i k omega)|^2`` on the angular frequencies ``omega``."""
    return _denominator_from_cosines(ar, np.cos(omega), np.cos(2 * omega))


def _denominator_from_cosines(ar, cos1: np.ndarray, cos2: np.ndarray) -> np.ndarray:
    """``_ar_denominator`` for orders up to 2, from ``cos(omega)`` and ``cos(2 omega)``."""
    phi1 = ar[0] if len(ar) > 0 else 0.0
    phi2 = ar[1] if len(ar) > 1 else 0.0
    return 1.0 + phi1**2 + phi2**2 - 2 * phi1 * (1 - phi2) * cos1 - 2 * phi2 * cos2


def _ar_from_partials(partials: np.ndarray) -> np.ndarray:
    """AR coefficients from partial autocorrelations in (-1, 1) (always stationary)."""
    ar = np.zeros(0)
    for k, kappa in enumerate(partials):
        ar = np.concatenate([ar - kappa * ar[::-1], [kappa]]) if k else np.array([kappa])
    return ar


def _ar_variance(ar: np.ndarray) -> float:
    """Variance of a stationary AR process with unit innovations."""
    if len(ar) == 0:
        return 1.0
    if len(ar) == 1:
        return 1.0 / (1.0 - ar[0] ** 2)
    phi1, phi2 = ar[0], ar[1]
    return (1.0 - phi2) / ((1.0 + phi2) * ((1.0 - phi2) ** 2 - phi1**2))


@dataclass(frozen=True)
class SignalNoise:
    """The noise of one measured signal, as :func:`read_noise` read it.

    The noise is modelled as an autoregressive process (``ar`` empty: white)
    with innovations of standard deviation ``innovation``, plus white noise
    of standard deviation ``white`` (rounding, a sensor's own noise).

    Attributes
    ----------
    name : str
        The signal (a column of the record).
    level : float
        Standard deviation of the noise, colour included.
    ar : tuple of float
        Coefficients ``phi_k`` of ``e[n] = sum_k phi_k e[n-k] + w[n]``.
    innovation, white : float
        Standard deviations of the AR process's innovations and of the
        white part.
    step : float
        The sampling step the model is written on.
    quantum : float or None
        The quantisation step, when the values lie on a lattice.
    band : float
        The highest frequency (cycles per time unit) where the signal
        stands above the noise; the noise model was fitted above it.
    signal_std : float
        Standard deviation of the record after a linear detrend, less the noise.
    drift : float
        The record's linear trend, per time unit (drift, or slow signal: the
        record alone cannot tell them apart; a model's residuals can).
    """

    name: str
    level: float
    ar: tuple[float, ...] = ()
    innovation: float = 0.0
    white: float = 0.0
    step: float = 1.0
    quantum: float | None = None
    band: float = float("nan")
    signal_std: float = 0.0
    drift: float = 0.0
    _frequencies: np.ndarray | None = field(default=None, repr=False, compare=False)
    _density: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def coloured(self) -> bool:
        """Whether the noise is correlated in time (an AR part)."""
        return len(self.ar) > 0 and self.innovation > 0

    @property
    def poles(self) -> tuple[float, ...]:
        """Poles of the AR part (absolute values, largest first; empty for white noise)."""
        if not self.coloured:
            return ()
        roots = np.roots(np.concatenate([[1.0], -np.asarray(self.ar)]))
        return tuple(sorted((float(abs(r)) for r in roots), reverse=True))

    @property
    def correlation_time(self) -> float:
        """Time over which the noise's autocorrelation falls to 1/e (0 for white noise)."""
        if not self.coloured or self.level <= 0:
            return 0.0
        pole = self.poles[0]
        share = self.innovation**2 * _ar_variance(np.asarray(self.ar)) / self.level**2
        if pole <= 0 or share <= np.exp(-1.0):
            return 0.0
        # beyond lag 0 the autocorrelation is share * pole^k (the white part is gone)
        return float((1.0 + np.log(share)) / -np.log(pole) * self.step) if pole < 1 \
            else float("inf")

    @property
    def memory(self) -> float:
        """How many samples one independent sample of this noise is worth (1 for white).

        The ratio of the noise's long-run variance (its spectrum at zero
        frequency) to its variance: the effective number of independent
        samples in a record of ``n`` is ``n / memory``.
        """
        if self.level <= 0 or not self.coloured:
            return 1.0
        long_run = self.innovation**2 / (1.0 - float(np.sum(self.ar))) ** 2 + self.white**2
        return float(max(long_run / self.level**2, 1.0))

    @property
    def arma(self) -> tuple[tuple[float, ...], tuple[float, ...], float]:
        """The same noise as one ARMA process: ``(ar, ma, sigma)``.

        An AR(p) process plus white noise is an ARMA(p, p) process
        ``e[n] = sum_k ar_k e[n-k] + w[n] + sum_k ma_k w[n-k]`` whose
        innovations ``w`` have standard deviation ``sigma``: the moving
        average is the minimum-phase factor of the numerator of the
        spectrum, so both give the same autocovariance. ``ma`` is empty
        where the white part is (pure AR), ``ar`` too where the noise is white.
        """
        if not self.coloured:
            return (), (), float(self.white)
        if self.white <= 0:
            return tuple(self.ar), (), float(self.innovation)
        a = np.concatenate([[1.0], -np.asarray(self.ar, dtype=float)])
        p = len(a) - 1
        # spectrum's numerator: innovation^2 + white^2 A(z) A(1/z), a symmetric Laurent
        # polynomial whose roots pair as (r, 1/r); the factor keeps those inside the circle
        c = self.white**2 * np.correlate(a, a, mode="full")
        c[p] += self.innovation**2
        roots = np.roots(c)
        inside = roots[np.argsort(np.abs(roots))[:p]]
        b = np.real(np.poly(inside))
        sigma = float(np.sqrt(c[p] / np.sum(b**2)))
        return tuple(self.ar), tuple(float(v) for v in b[1:]), sigma

    @property
    def snr_db(self) -> float:
        """Signal-to-noise ratio in decibels (infinite for a noise-free signal)."""
        if self.level <= 0:
            return float("inf")
        return float(20 * np.log10(max(self.signal_std, 1e-300) / self.level))

    def density(self, frequencies: np.ndarray) -> np.ndarray:
        """The model's one-sided power spectral density at ``frequencies``."""
        f = np.asarray(frequencies, dtype=float)
        white = np.full_like(f, 2.0 * self.step * self.white**2)
        if not self.coloured:
            return white
        omega = 2 * np.pi * f * self.step
        coloured = 2.0 * self.step * self.innovation**2 / _ar_denominator(np.asarray(self.ar),
                                                                           omega)
        return white + coloured

    @property
    def spectrum(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The record's Welch spectrum the reading was made from (frequencies, density)."""
        if self._frequencies is None:
            return None
        return self._frequencies, self._density

    def describe(self) -> str:
        """One line in words."""
        if self.level <= 0:
            text = f"{self.name}: no noise"
        else:
            snr = f"{self.snr_db:.0f} dB" if np.isfinite(self.snr_db) else "inf dB"
            text = f"{self.name}: noise {self.level:.3g} (SNR {snr})"
            if self.coloured:
                poles = ", ".join(f"{p:.3f}" for p in self.poles)
                plural = "s" if len(self.ar) > 1 else ""
                text += (f", coloured: AR({len(self.ar)}) with pole{plural} {poles}, "
                         f"correlation time {self.correlation_time:.3g}")
            else:
                text += ", white"
        if self.quantum is not None:
            text += f", quantised in steps of {self.quantum:.3g}"
        return text


def _whittle(density: np.ndarray, model: np.ndarray) -> float:
    """Whittle's criterion (twice the negative log-likelihood per segment, up to a constant)."""
    return float(np.sum(np.log(model) + density / model))


def _white_score(density: np.ndarray) -> float:
    """Whittle's criterion of the best white model (its level the density's mean)."""
    return _whittle(density, np.full_like(density, float(np.mean(density))))


def _whittle_ar(frequencies: np.ndarray, density: np.ndarray, step: float, order: int,
            white_start: float, *, ceiling: tuple[np.ndarray, np.ndarray] | None = None,
            weight: float = 1.0) -> tuple[np.ndarray, float, float, float]:
    """An AR(order)-plus-white model fitted by Whittle: ``(ar, innovation², white², criterion)``.

    ``ceiling`` gives frequencies below the fitted band and the record's
    spectrum there: the noise cannot be stronger than signal and noise
    together, so a model that rises above it there is penalised (what keeps
    a pole from running to 1 on a band that cannot see the noise's corner).
    Where the band cannot tell poles apart, a weak preference for the
    shorter memory (``POLE_PRIOR`` per unit of ``-log(1 - pole)``, in units of
    ``weight`` times the criterion) chooses the smaller.
    """
    def cosines(f):
        omega = 2 * np.pi * f * step
        return np.cos(omega), np.cos(2 * omega)

    band = cosines(frequencies)
    scale = float(np.mean(density))
    below = None if ceiling is None or len(ceiling[0]) == 0 else (
        cosines(ceiling[0]), ceiling[1])

    def model(theta, where=band):
        ar = _ar_from_partials(MAX_PARTIAL * np.tanh(theta[:order]))
        innovation = np.exp(theta[order])
        white = np.exp(theta[order + 1])
        return ar, innovation, white, (
            2 * step * (innovation / _denominator_from_cosines(ar, *where) + white))

    def criterion(theta):
        value = _whittle(density / scale, model(theta)[3] / scale)
        # the memory is measured by the largest partial autocorrelation (AR(1): the pole)
        largest = MAX_PARTIAL * float(np.max(np.abs(np.tanh(theta[:order]))))
        value -= POLE_PRIOR / weight * np.log1p(-largest)
        if below is not None:
            excess = np.log(model(theta, below[0])[3] / (CEILING * below[1]))
            value += len(density) * float(np.sum(np.maximum(excess, 0.0) ** 2))
        return value

    best = None
    for pole in (0.6, 0.95):
        start = np.concatenate([[np.arctanh(pole)], np.zeros(order - 1),
                                [np.log(0.5 * scale / (2 * step) * (1 - pole) ** 2 + 1e-300),
                                 np.log(max(white_start, 1e-6 * scale) / (2 * step))]])
        result = optimize.minimize(criterion, start, method="Nelder-Mead",
                                   options={"xatol": 1e-4, "fatol": 1e-7, "maxiter": 2000})
        if best is None or result.fun < best.fun:
            best = result
    ar, innovation, white, fitted = model(best.x)
    return ar, float(innovation), float(white), _whittle(density, fitted)


def read_noise(x: np.ndarray, step: float, *, name: str = "x", quantum=None) -> SignalNoise:
    """Read the noise of evenly spaced samples: level, colour and the band above the signal.

    Parameters
    ----------
    x : ndarray
        Samples on an even grid.
    step : float
        The grid's time step.
    name : str, default="x"
        The signal's name (kept in the reading).
    quantum : Quantum, optional
        A known quantisation step: the white part is at least its rounding noise.

    Returns
    -------
    SignalNoise
    """
    x = np.ascontiguousarray(x, dtype=float)
    key = (hashlib.blake2b(x.tobytes(), digest_size=16).digest(), len(x), float(step),
           None if quantum is None else (float(quantum.step), float(quantum.noise_variance)))
    reading = _readings.get(key)
    if reading is None:
        reading = _readings[key] = _read(x, step, quantum)
        while len(_readings) > REMEMBERED:
            _readings.popitem(last=False)
    else:
        _readings.move_to_end(key)
    return replace(reading, name=name)


def _read(x: np.ndarray, step: float, quantum) -> SignalNoise:
    """:func:`read_noise` itself, under the name ``"x"``."""
    name = "x"
    detrended = signal.detrend(x, type="linear")
    spread = float(np.std(detrended))
    drift = float(np.polyfit(np.arange(len(x)) * step, x, 1)[0]) if len(x) > 1 else 0.0
    frequencies, raw, segments = multitaper_density(x, step)
    frequencies.flags.writeable = raw.flags.writeable = False  # a remembered reading's
    # the spectrum averaged over neighbouring bins: the ceiling a noise model must stay under
    smooth = np.convolve(raw, np.ones(5) / 5, mode="same")
    nyquist = float(frequencies[-1])
    q_step = None if quantum is None else float(quantum.step)
    rounding = 0.0 if quantum is None else quantum.noise_variance
    common = dict(name=name, step=step, quantum=q_step, drift=drift,
                  _frequencies=frequencies, _density=raw)
    straight = spread <= 1e-12 * (float(np.max(np.abs(x))) or 1.0)
    if straight or len(frequencies) < 8:
        return SignalNoise(level=0.0, band=nyquist, signal_std=spread, **common)

    inner = np.ones(len(frequencies), dtype=bool)
    inner[0] = inner[-1] = False  # the DC and Nyquist bins are biased by detrend and window
    lowest = 2 * frequencies[1]
    band_low = (1.0 - FLOOR_BAND) * nyquist
    white = _white_floor(frequencies, raw, segments, band_low, inner)
    white = max(white, 2.0 * rounding * step)
    if white <= CLEAN_RATIO * spread**2 * step:
        return SignalNoise(level=0.0, band=nyquist, signal_std=spread, **common)

    # widen the band from the top down, following an AR(1)-plus-white fit: below the
    # band's top the noise may rise (coloured) until the signal stands out of it
    flat = False
    for _ in range(WIDENINGS):
        fit = inner & (frequencies >= band_low)
        if fit.sum() < 8:
            break
        ceiling = inner & (frequencies < band_low)
        ar, innovation, extra, _ = _whittle_ar(frequencies[fit], raw[fit], step, 1, white / 2,
                                           ceiling=(frequencies[ceiling], smooth[ceiling]),
                                           weight=segments)
        if abs(ar[0]) < COLOUR_GATE and _flat(frequencies, raw, fit):
            flat = True
            break
        density = _coloured_density(frequencies, step, ar, innovation, max(extra, rounding))
        new_low = _band_edge(frequencies, raw, density, segments, inner, lowest=lowest)
        if new_low >= band_low * 0.95:
            break
        band_low = new_low

    chosen = None  # (ar, innovation², white²) of a coloured model, when one is decisive
    fit = inner & (frequencies >= band_low)
    if not flat and fit.sum() >= 8:
        f_band, p_band = frequencies[fit], raw[fit]
        ceiling = inner & (frequencies < band_low)
        ceiling = (frequencies[ceiling], smooth[ceiling])
        white_score = _white_score(p_band)
        n_eff = fit.sum() * segments
        best = None
        for order in AR_ORDERS:
            ar, innovation, extra, score = _whittle_ar(f_band, p_band, step, order, white / 2,
                                                   ceiling=ceiling, weight=segments)
            penalised = segments * score + (order + 1) * np.log(n_eff)
            if best is None or penalised < best[0]:
                best = (penalised, ar, innovation, extra)
        model = _coloured_density(f_band, step, best[1], best[2], best[3])
        contrast = float(model.max() / model.min())
        if (segments * white_score - best[0] >= COLOUR_EVIDENCE
                and contrast >= COLOUR_CONTRAST):
            chosen = (best[1], best[2], max(best[3], rounding))

    if chosen is None:  # white: the flat floor of the band's top
        level = float(np.sqrt(white / (2 * step)))
        if level**2 <= QUIET_RATIO * spread**2:
            return SignalNoise(level=0.0, band=nyquist, signal_std=spread, **common)
        band = _band_edge(frequencies, raw, np.full_like(raw, white), segments, inner,
                          lowest=lowest)
        return SignalNoise(level=level, white=level, band=band,
                           signal_std=float(np.sqrt(max(spread**2 - level**2, 0.0))), **common)
    ar, innovation, extra = chosen
    variance = innovation * _ar_variance(ar) + extra
    if variance <= QUIET_RATIO * spread**2:  # the tapers' own leakage, not noise
        return SignalNoise(level=0.0, band=nyquist, signal_std=spread, **common)
    level = float(np.sqrt(variance))
    density = _coloured_density(frequencies, step, ar, innovation, extra)
    return SignalNoise(level=level, ar=tuple(float(a) for a in ar),
                       innovation=float(np.sqrt(innovation)), white=float(np.sqrt(extra)),
                       band=_band_edge(frequencies, raw, density, segments, inner, lowest=lowest),
                       signal_std=float(np.sqrt(max(spread**2 - variance, 0.0))), **common)


def _coloured_density(frequencies, step, ar, innovation, white) -> np.ndarray:
    omega = 2 * np.pi * frequencies * step
    return 2 * step * (innovation / _ar_denominator(np.asarray(ar), omega) + white)


def _flat(frequencies, density, band) -> bool:
    """Whether the spectrum is level across ``band``.

    Level: its lowest third is within ``FLAT_SLOPE`` of its highest.
    """
    values = density[band]
    third = max(1, len(values) // 3)
    return float(np.mean(values[:third])) <= FLAT_SLOPE * float(np.mean(values[-third:]))


def _white_floor(frequencies, density, segments, band_low, inner) -> float:
    """The flat floor of the band above ``band_low``: the median-smoothed median."""
    width = max(3, round(15 / np.sqrt(segments)) | 1)
    smoothed = ndimage.median_filter(density, size=width, mode="nearest")
    top = inner & (frequencies >= band_low)
    return float(np.median(smoothed[top])) if top.any() else float(smoothed[-1])


def _band_edge(frequencies, density, model, segments, inner, *, lowest) -> float:
    """Where the noise band begins: just above the last frequency the signal stands out.

    A bin counts as signal where the spectrum, averaged over a few
    neighbours, exceeds the noise model by ``SIGNAL_RATIO``.
    """
    width = max(3, round(9 / np.sqrt(segments)) | 1)
    kernel = np.ones(width) / width
    ratio = np.convolve(density / model, kernel, mode="same")
    above = np.flatnonzero(inner & (ratio > SIGNAL_RATIO))
    if len(above) == 0:
        return float(lowest)
    edge = frequencies[min(above[-1] + width, len(frequencies) - 1)]
    return float(max(edge * 1.5, lowest))


class NoiseReading(Mapping):
    """The noise of every measured signal of a record: ``{name: SignalNoise}``.

    What :attr:`Measurement.noise <sklearn_pycc.measurements.Measurement.noise>`
    gives. Each signal is read on its longest experiment (see
    :func:`read_noise`); :meth:`summary` says it in words and :meth:`plot`
    draws each signal's spectrum with the noise model and the signal's band.
    """

    def __init__(self, signals: dict[str, SignalNoise], units: dict | None = None) -> None:
        self._signals = dict(signals)
        self.units = dict(units or {})

    def __getitem__(self, name: str) -> SignalNoise:
        try:
            return self._signals[name]
        except KeyError:
            raise KeyError(f"no noise reading for {name!r}; the record's signals are "
                           f"{', '.join(map(repr, self._signals))}") from None

    def __iter__(self):
        return iter(self._signals)

    def __len__(self) -> int:
        return len(self._signals)

    def summary(self) -> str:
        """One line per signal."""
        return "\n".join(noise.describe() for noise in self._signals.values())

    def __repr__(self) -> str:
        return "<NoiseReading>\n" + self.summary()

    def to_frame(self):
        """The readings as a table, one row per signal.

        Columns: level, SNR, orders of the ARMA form (:attr:`SignalNoise.arma`)
        and largest pole, correlation time, quantisation step, band and drift.
        """
        import pandas as pd

        rows = [{"signal": n.name, "level": n.level, "snr_db": n.snr_db,
                 "ar_order": len(n.ar), "ma_order": len(n.arma[1]),
                 "pole": n.poles[0] if n.poles else 0.0,
                 "correlation_time": n.correlation_time, "quantum": n.quantum,
                 "band": n.band, "drift": n.drift} for n in self._signals.values()]
        return pd.DataFrame(rows).set_index("signal")

    def plot(self, signals=None):
        """Each signal's spectrum, the noise model and the signal's band; returns the figure."""
        from ..plotting import plot_noise

        return plot_noise(self, signals=signals)


def read_frame_noise(frame, columns) -> dict[str, SignalNoise]:
    """The noise of some columns of a record with ``t``, each read on its longest experiment.

    A record sampled on no even grid (a logger's irregular clock), or on
    one it fills more than :data:`FILLED_SHARE` of (bursts of samples with
    long pauses between them), is interpolated for the spectrum, which
    smooths or folds its noise: read there, a level can come out far too
    low (zero) or too high. Its level is then
    read from the samples themselves (:func:`uneven_level`), as white noise:
    the colour of a noise sampled so unevenly is not read.
    """
    from .._utils.bandlimited import even_grid
    from .experiments import TIME, TRAJECTORY, split_experiments
    from .spectral import find_quantum

    t = frame[TIME].to_numpy(dtype=float)
    labels = frame[TRAJECTORY].to_numpy() if TRAJECTORY in frame.columns else None
    longest = max(split_experiments(len(frame), t, labels), key=lambda e: len(e.rows))
    out = {}
    for name in columns:
        values = np.asarray(frame[name], dtype=float)[longest.rows]
        # a missing sample splits the signal: it is read on its longest stretch without one
        run = _longest_finite_run(values)
        if run.stop - run.start < 16:
            continue
        times, values = t[longest.rows][run], values[run]
        grid = even_grid(times)
        quantum = find_quantum(values)
        reading = read_noise(grid.fill(times, values), grid.step, name=str(name),
                             quantum=quantum)
        if grid.resampled or grid.dropped > FILLED_SHARE * len(times):
            # no sensor reads finer than it rounds
            rounding = 0.0 if quantum is None else float(np.sqrt(quantum.noise_variance))
            reading = _white_at(reading, max(uneven_level(times, values), rounding), times,
                                values)
        out[str(name)] = reading
    return out


#: the share of a record's samples an even grid may have to fill for its noise to be read there
FILLED_SHARE = 0.25


def uneven_level(t: np.ndarray, x: np.ndarray) -> float:
    """The level of a signal's white noise from samples at uneven times, robustly.

    Each sample is compared with the cubic through its two neighbours on
    either side (Lagrange weights ``w`` at its time): for white noise of
    level sigma the difference has spread ``sigma sqrt(1 + sum w^2)``, by
    which it is divided, and the median absolute value is read (a kink
    here and there does not count). The signal's bend and its third
    derivative cancel: only its fourth derivative is left, small wherever
    the samples are close against the signal's changes.
    """
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    if len(t) < 5:
        return float("nan")
    centre = t[2:-2]
    others = [t[j:len(t) - 4 + j] for j in (0, 1, 3, 4)]
    values = [x[j:len(x) - 4 + j] for j in (0, 1, 3, 4)]
    weights = []
    with np.errstate(all="ignore"):
        for i, ti in enumerate(others):
            w = np.ones_like(centre)
            for k, tk in enumerate(others):
                if k != i:
                    w = w * (centre - tk) / (ti - tk)
            weights.append(w)
        predicted = sum(w * v for w, v in zip(weights, values))
        residual = (x[2:-2] - predicted) / np.sqrt(1.0 + sum(w * w for w in weights))
    residual = residual[np.isfinite(residual)]
    return 1.4826 * float(np.median(np.abs(residual))) if residual.size else float("nan")


def _white_at(reading: SignalNoise, level: float, t: np.ndarray, x: np.ndarray) -> SignalNoise:
    """``reading`` as white noise of ``level``, its signal's spread read again beside it."""
    if not np.isfinite(level):
        return reading
    trend = np.polyval(np.polyfit(t - t[0], x, 1), t - t[0])
    spread = float(np.std(x - trend))
    return replace(reading, level=level, ar=(), innovation=0.0, white=level,
                   signal_std=float(np.sqrt(max(spread**2 - level**2, 0.0))))


def _longest_finite_run(values: np.ndarray) -> slice:
    """The longest stretch of consecutive finite values (the first of equal ones)."""
    finite = np.concatenate([[False], np.isfinite(values), [False]])
    edges = np.flatnonzero(np.diff(finite.astype(int)))
    if not edges.size:
        return slice(0, 0)
    starts, stops = edges[::2], edges[1::2]
    k = int(np.argmax(stops - starts))
    return slice(int(starts[k]), int(stops[k]))


def second_difference_level(pieces) -> float:
    """The level of a signal's white noise, read from its second differences, robustly.

    ``pieces`` are the signal's stretches (each experiment's samples), each
    differenced on its own. White noise of level sigma gives second
    differences of spread sqrt(6) sigma; their median absolute value is read,
    so a kink here and there (a heater switched on) does not count. Noise
    correlated in time reads low (its second differences cancel): a bound
    from below. NaN where no stretch has three finite samples.
    """
    second = [np.diff(np.asarray(piece, dtype=float), 2) for piece in pieces]
    second = np.concatenate([d[np.isfinite(d)] for d in second] or [np.zeros(0)])
    if not second.size:
        return float("nan")
    return 1.4826 * float(np.median(np.abs(second))) / np.sqrt(6.0)


def slow_memory(residuals: np.ndarray) -> float:
    """How many samples one sample of a residual is worth at the slowest frequencies.

    The periodogram of each column of ``residuals`` (rows in time order)
    averaged over the lowest :data:`SLOW_BINS` frequencies the record
    resolves (1, 2, 3 cycles over it), divided by the column's variance:
    about 1 for white noise, ``(1 + pole) / (1 - pole)`` for AR(1) noise,
    and far more where something slow wanders through it (a sensor's drift,
    a slow force the model lacks), which the noise read above the signal's
    band cannot show. The largest over the columns; 1 for a residual too
    short to resolve them or without variance. A rough reading (a mean of
    three periodogram values): a guard against what wanders, not a
    measurement.
    """
    errors = np.asarray(residuals, dtype=float)
    errors = errors.reshape(len(errors), -1)
    if len(errors) < 4 * SLOW_BINS:
        return 1.0
    errors = errors - errors.mean(axis=0)
    variance = np.mean(errors**2, axis=0)
    lowest = np.abs(np.fft.rfft(errors, axis=0)[1:SLOW_BINS + 1]) ** 2 / len(errors)
    ratios = np.mean(lowest, axis=0)[variance > 0] / variance[variance > 0]
    return float(max(np.max(ratios), 1.0)) if ratios.size else 1.0
