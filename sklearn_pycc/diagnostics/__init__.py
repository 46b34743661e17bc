"""Comparing fitted models with measurements: diagnose, compare_skeletons, the effect catalogue."""

from . import effects
from ._failures import ResidualMap
from ._open_curves import OpenCurve
from ._trajectories import Divergence
from .compare import compare_skeletons
from .diagnose import diagnose
from .loop import HypothesisLoop, Refinement, Round
from .report import Diagnosis, Suggestion

__all__ = ["Diagnosis", "Divergence", "HypothesisLoop", "OpenCurve", "Refinement", "ResidualMap",
           "Round", "Suggestion",
           "compare_skeletons", "diagnose", "effects"]
