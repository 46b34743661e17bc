"""Skeletons read as stochastic differential equations: the extended Kalman filter's likelihood."""

from .kalman import FilterPass, fit_filter, kalman_pass, smoothed

__all__ = ["FilterPass", "fit_filter", "kalman_pass", "smoothed"]
