"""Skeletons read as stochastic differential equations: the extended Kalman filter's likelihood."""

from .kalman import FilterPass, kalman_pass, smoothed
from .search import fit_filter

__all__ = ["FilterPass", "fit_filter", "kalman_pass", "smoothed"]
