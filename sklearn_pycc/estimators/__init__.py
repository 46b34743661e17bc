"""Estimators: the shared :class:`CCRegressor` base, one module per backend, conversions."""

from .base import CCRegressor
from .conversion import from_tables, to_interpolated, to_symbolic
from .interpolated import InterpolatedCCRegressor
from .neural import NeuralCCRegressor
from .poly import PolyCCRegressor
from .symbolic import SymbolicCCRegressor

__all__ = [
    "CCRegressor",
    "InterpolatedCCRegressor",
    "NeuralCCRegressor",
    "PolyCCRegressor",
    "SymbolicCCRegressor",
    "from_tables",
    "to_interpolated",
    "to_symbolic",
]
