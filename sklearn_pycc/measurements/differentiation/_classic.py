"""The classic differentiators: smoothing spline, Savitzky-Golay, finite differences, packages."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from scipy.interpolate import make_smoothing_spline
from scipy.signal import savgol_filter

__all__ = ["CallableDifferentiator", "Differentiator", "FiniteDifferences",
           "PackageDifferentiator", "SavgolDifferentiator", "SplineDifferentiator", "kalman",
           "trend_filtered"]


class Differentiator:
    """Smoothed values and derivatives of one experiment's samples."""

    #: whether the method needs evenly spaced samples
    uniform_only = False
    #: the lowest signal-to-noise ratio (dB) the method read from the record, when it read one
    snr_db: float | None = None

    def min_samples(self, n: int) -> int:
        """Fewest samples the method works with (``n``: the experiment's length)."""
        return 3

    def describe(self) -> str:
        """Plain-words name of the method and its settings."""
        raise NotImplementedError

    def derivatives(self, t: np.ndarray, x: np.ndarray, order: int) -> list[np.ndarray]:
        """``[x smoothed, dx/dt, ..., d^order x/dt^order]`` on the times ``t``."""
        raise NotImplementedError

    def for_experiment(self, t: np.ndarray, states: Mapping[str, np.ndarray],
                       order: int) -> Differentiator:
        """The differentiator for one experiment (``states``: its measured samples by name).

        A method that adapts to the record (``"auto"``) chooses here; the
        others are the same for every experiment.
        """
        return self

    def settling(self, t: np.ndarray) -> float:
        """Time at each end of an experiment where the estimate is not to be trusted.

        A filter settles and a differentiator runs out of neighbours at the
        ends of a record; samples within this time of either end are left
        out of fits and diagnoses. None of the fixed methods needs it (0).
        """
        return 0.0

    def smooth_input(self, t: np.ndarray, u: np.ndarray) -> np.ndarray | None:
        """An input as the fit should see it, or None to use it as measured.

        A method that low-pass filters the states filters the inputs by the
        same filter, so that the equations hold between filtered signals.
        """
        return None


class SplineDifferentiator(Differentiator):
    """Cubic smoothing spline; its smoothing chosen by generalised cross-validation.

    Parameters
    ----------
    smoothing : float, optional
        The penalty ``lam`` of :func:`scipy.interpolate.make_smoothing_spline`
        in the time units of the data; None chooses it by GCV per
        experiment (noise-adaptive).
    """

    def __init__(self, smoothing: float | None = None) -> None:
        if smoothing is not None and not (np.isfinite(smoothing) and smoothing >= 0):
            raise ValueError(f"spline smoothing must be a non-negative number or None, "
                             f"got {smoothing!r}")
        self.smoothing = smoothing

    def min_samples(self, n: int) -> int:
        return 5

    def describe(self) -> str:
        lam = "chosen by GCV" if self.smoothing is None else f"lam={self.smoothing:g}"
        return f"cubic smoothing spline ({lam})"

    def derivatives(self, t, x, order):
        spline = make_smoothing_spline(t, x, lam=self.smoothing)
        return [spline(t)] + [spline.derivative(k)(t) for k in range(1, order + 1)]


class SavgolDifferentiator(Differentiator):
    """Savitzky-Golay filter (the method's published choice); evenly spaced samples only.

    Parameters
    ----------
    window : int, optional
        Odd window length in samples; default about 2 % of the experiment,
        at least 7.
    polyorder : int, default=3
        Degree of the local polynomial.
    """

    uniform_only = True

    def __init__(self, window: int | None = None, polyorder: int = 3) -> None:
        if window is not None and (int(window) != window or window < 3 or window % 2 == 0):
            raise ValueError(f"savgol window must be an odd integer of at least 3, "
                             f"got {window!r}")
        if int(polyorder) != polyorder or polyorder < 1:
            raise ValueError(f"savgol polyorder must be a positive integer, got {polyorder!r}")
        if window is not None and polyorder >= window:
            raise ValueError(f"savgol polyorder ({polyorder}) must be less than the window "
                             f"({window})")
        self.window = window
        self.polyorder = int(polyorder)

    def _window(self, n: int) -> int:
        return int(self.window) if self.window is not None else max(7, 2 * (n // 100) + 1)

    def min_samples(self, n: int) -> int:
        return self._window(n)

    def describe(self) -> str:
        window = "about 2 % of each experiment" if self.window is None else self.window
        return f"Savitzky-Golay filter (window {window}, degree {self.polyorder})"

    def derivatives(self, t, x, order):
        window = self._window(len(t))
        dt = float(np.median(np.diff(t)))
        return [savgol_filter(x, window, self.polyorder, deriv=k, delta=dt)
                for k in range(order + 1)]


class FiniteDifferences(Differentiator):
    """Second-order central differences (no smoothing); uneven sampling allowed."""

    def describe(self) -> str:
        return "central finite differences (no smoothing)"

    def derivatives(self, t, x, order):
        out = [np.array(x, dtype=float)]
        for _ in range(order):
            out.append(np.gradient(out[-1], t, edge_order=2))
        return out


class PackageDifferentiator(Differentiator):
    """A method of the ``derivative`` package (anything with ``d(x, t)`` and maybe ``x(x, t)``).

    Higher derivatives differentiate the previous one again.
    """

    def __init__(self, method, label: str, min_samples: int = 3) -> None:
        self.method = method
        self.label = label
        self._min = min_samples

    def min_samples(self, n: int) -> int:
        return self._min

    def describe(self) -> str:
        return self.label

    def _method_for(self, t: np.ndarray, x: np.ndarray):
        """The package object used on these samples."""
        return self.method

    def derivatives(self, t, x, order):
        method = self._method_for(t, x)
        smooth = getattr(method, "x", None)
        out = [np.asarray(smooth(x, t), dtype=float) if smooth is not None
               else np.array(x, dtype=float)]
        current = np.asarray(x, dtype=float)
        for _ in range(order):
            current = np.asarray(method.d(current, t), dtype=float)
            out.append(current)
        return out


class CallableDifferentiator(Differentiator):
    """A user's function ``f(x, t) -> dx/dt``; higher derivatives apply it again."""

    def __init__(self, function: Callable) -> None:
        self.function = function

    def describe(self) -> str:
        return f"the callable {getattr(self.function, '__name__', repr(self.function))}"

    def derivatives(self, t, x, order):
        out = [np.array(x, dtype=float)]
        for _ in range(order):
            value = np.asarray(self.function(out[-1], t), dtype=float)
            if value.shape != out[-1].shape:
                raise ValueError(f"differentiation callable {self.describe()[13:]} returned "
                                 f"shape {value.shape} for samples of shape {out[-1].shape}")
            out.append(value)
        return out


def _derivative_package():
    try:
        import derivative
    except ImportError:
        raise ImportError(
            "this differentiation method needs the 'derivative' package: "
            "pip install 'sklearn-pycc[differentiation]'") from None
    return derivative


def kalman(alpha: float | None = None) -> Differentiator:
    derivative = _derivative_package()
    if alpha is not None and not (np.isfinite(alpha) and alpha > 0):
        raise ValueError(f"kalman alpha must be a positive number or None, got {alpha!r}")
    return _KalmanDifferentiator(derivative.Kalman, alpha)


class _KalmanDifferentiator(PackageDifferentiator):
    """Kalman smoother of the ``derivative`` package; ``alpha`` from a noise estimate if None."""

    def __init__(self, kalman, alpha: float | None) -> None:
        label = "from a noise estimate" if alpha is None else f"{alpha:g}"
        super().__init__(None, f"Kalman smoother (alpha {label})", min_samples=5)
        self.kalman = kalman
        self.alpha = alpha

    def _method_for(self, t, x):
        return self.kalman(alpha=self.alpha if self.alpha is not None else _kalman_alpha(t, x))


def _kalman_alpha(t: np.ndarray, x: np.ndarray) -> float:
    """Ratio of measurement-noise variance to the velocity's random-walk intensity."""
    second = np.diff(x, 2)
    sigma2 = (np.median(np.abs(second - np.median(second))) / 0.6745) ** 2 / 6.0
    spline = make_smoothing_spline(t, x)
    accel = spline.derivative(2)(t)
    q = float(np.mean(accel**2)) * float(np.median(np.diff(t)))
    if not (np.isfinite(sigma2) and np.isfinite(q)) or q <= 0:
        return 1.0
    return float(np.clip(sigma2 / q, 1e-12, 1e12)) if sigma2 > 0 else 1e-12


def trend_filtered(order: int = 2, alpha: float = 1e-4, max_iter: int = 10000) -> Differentiator:
    derivative = _derivative_package()
    method = derivative.TrendFiltered(order=order, alpha=alpha, max_iter=max_iter)
    differentiator = PackageDifferentiator(
        method, f"trend filtering (order {order}, alpha {alpha:g})", min_samples=order + 3)
    differentiator.uniform_only = True  # the package reads one time step, t[1] - t[0]
    return differentiator
