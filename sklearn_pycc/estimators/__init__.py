"""Estimators: the shared :class:`CCRegressor` base and one module per backend."""

from .base import CCRegressor
from .neural import NeuralCCRegressor
from .poly import PolyCCRegressor

__all__ = ["CCRegressor", "NeuralCCRegressor", "PolyCCRegressor"]
