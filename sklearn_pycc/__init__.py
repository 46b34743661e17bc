"""sklearn-pycc: hypothesis-driven discovery of differential equations with characteristic curves.

Write a structural skeleton as text, with unknown one-dimensional curves
``f1, f2, ...`` and scalars ``a1, a2, ...``, and fit it with a scikit-learn
estimator; then let the loop compare the model with the measurements, name
the physical effect that is missing, add it and fit again::

    from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets

    frame = datasets.make_oscillator(hidden=["cubic_stiffness"])   # t, x1, x2, F_ext
    start = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
    loop = HypothesisLoop(start, frame[["t", "x1", "F_ext"]]).run()
    print(loop.summary())            # what was found, round by round
    loop.to_html("report.html")      # the whole story, with its figures

Where to look next:

- ``PolyCCRegressor``, ``NeuralCCRegressor``, ``SymbolicCCRegressor``: the
  backends (``help(PolyCCRegressor)`` for the hyperparameters);
- ``diagnose(model, X)``: one comparison with its suggestion, ``report.summary()``;
- ``check_innovations(model, X)``: whether a model fitted by its Kalman filter
  predicts one step ahead as well as its noises allow;
- ``compare_skeletons``: candidate skeletons side by side;
- ``sklearn_pycc.datasets``: generated records to try things on;
- ``sklearn_pycc.pycc``: the published PyCC package's functions and ``params``.

The documentation's getting-started page walks through all of it.
"""

from . import datasets, effects, pycc, quantities
from .diagnostics import HypothesisLoop, check_innovations, compare_skeletons, diagnose
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
    StartsWarning,
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
    "StartsWarning",
    "SymbolicCCRegressor",
    "check_innovations",
    "compare_skeletons",
    "datasets",
    "diagnose",
    "effects",
    "from_tables",
    "pycc",
    "quantities",
    "to_interpolated",
    "to_symbolic",
]
