"""sklearn-pycc: hypothesis-driven discovery of differential equations with characteristic curves.

Write a structural skeleton as text, with unknown one-dimensional curves
``f1, f2, ...`` and scalars ``a1, a2, ...``, and fit it with a scikit-learn
estimator.
"""

from . import datasets, effects, pycc
from .diagnostics import HypothesisLoop, compare_skeletons, diagnose
from .estimators import (
    CCRegressor,
    InterpolatedCCRegressor,
    NeuralCCRegressor,
    PolyCCRegressor,
    SymbolicCCRegressor,
    from_tables,
    to_interpolated,
    to_symbolic,
)
from .exceptions import (
    DomainWarning,
    ExtrapolationWarning,
    GaugeWarning,
    IdentifiabilityError,
    RankDeficiencyWarning,
    SimulationError,
    SkeletonError,
)
from .skeleton import Skeleton

__version__ = "0.1.0.dev0"

__all__ = [
    "CCRegressor",
    "DomainWarning",
    "ExtrapolationWarning",
    "GaugeWarning",
    "HypothesisLoop",
    "IdentifiabilityError",
    "InterpolatedCCRegressor",
    "NeuralCCRegressor",
    "PolyCCRegressor",
    "RankDeficiencyWarning",
    "SimulationError",
    "Skeleton",
    "SkeletonError",
    "SymbolicCCRegressor",
    "compare_skeletons",
    "datasets",
    "diagnose",
    "effects",
    "from_tables",
    "pycc",
    "to_interpolated",
    "to_symbolic",
]
