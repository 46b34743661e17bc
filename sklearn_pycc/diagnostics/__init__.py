"""Comparing fitted models with measurements: diagnose, compare_skeletons, the effect catalogue."""

from . import effects
from ._failures import ResidualMap
from ._trajectories import Divergence
from .compare import compare_skeletons
from .diagnose import Diagnosis, Suggestion, diagnose

__all__ = ["Diagnosis", "Divergence", "ResidualMap", "Suggestion", "compare_skeletons",
           "diagnose", "effects"]
