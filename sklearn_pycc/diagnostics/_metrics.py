"""Error measures between a measured and a modelled signal."""

from __future__ import annotations

import numpy as np

__all__ = ["error_table_row", "fit_percent", "nrmse", "r2", "rmse"]


def rmse(measured: np.ndarray, model: np.ndarray) -> float:
    """Root mean square error over the finite pairs (inf when the model has none)."""
    with np.errstate(over="ignore", invalid="ignore"):
        diff = np.asarray(model, dtype=float) - np.asarray(measured, dtype=float)
        finite = np.isfinite(diff)
        if not finite.any():
            return float("inf")
        return float(np.sqrt(np.mean(diff[finite] ** 2)))


def _spread(measured: np.ndarray) -> float:
    return float(np.std(np.asarray(measured, dtype=float)))


def nrmse(measured: np.ndarray, model: np.ndarray) -> float:
    """RMSE divided by the standard deviation of the measured signal."""
    spread = _spread(measured)
    error = rmse(measured, model)
    return error / spread if spread > 0 else (0.0 if error == 0 else float("inf"))


def r2(measured: np.ndarray, model: np.ndarray) -> float:
    """Coefficient of determination, ``1 - NRMSE**2``."""
    return 1.0 - nrmse(measured, model) ** 2


def fit_percent(measured: np.ndarray, model: np.ndarray) -> float:
    """Normalised fit ``100 (1 - |y - y_model| / |y - mean(y)|)`` (100 is perfect)."""
    return 100.0 * (1.0 - nrmse(measured, model))


def error_table_row(measured: np.ndarray, model: np.ndarray) -> dict[str, float]:
    """``rmse``, ``nrmse``, ``r2`` and ``fit_percent`` of one signal."""
    return {"rmse": rmse(measured, model), "nrmse": nrmse(measured, model),
            "r2": r2(measured, model), "fit_percent": fit_percent(measured, model)}
