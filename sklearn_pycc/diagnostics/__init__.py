"""Comparing fitted models with measurements: diagnose, compare_skeletons, the effect catalogue."""

from . import effects
from ._failures import ResidualMap
from ._open_curves import OpenCurve
from ._trajectories import Divergence
from .compare import compare_skeletons
from .diagnose import diagnose
from .innovations import InnovationCheck, check_innovations
from .loop import HypothesisLoop, Refinement, Round
from .report import Diagnosis, Suggestion

__all__ = ["Diagnosis", "Divergence", "HypothesisLoop", "InnovationCheck", "OpenCurve",
           "Refinement", "ResidualMap", "Round", "Suggestion",
           "check_innovations", "compare_skeletons", "diagnose", "effects"]
