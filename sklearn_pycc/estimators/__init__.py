"""Estimators: the shared :class:`CCRegressor` base and one module per backend."""

from .base import CCRegressor
from .neural import NeuralCCRegressor
from .poly import PolyCCRegressor
from .symbolic import SymbolicCCRegressor

__all__ = ["CCRegressor", "NeuralCCRegressor", "PolyCCRegressor", "SymbolicCCRegressor"]
