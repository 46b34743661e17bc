"""Comparing fitted models with measurements: the effect catalogue (and, next, diagnose)."""

from . import effects

__all__ = ["effects"]
