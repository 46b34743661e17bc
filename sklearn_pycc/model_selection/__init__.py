"""Model selection on measured trajectories.

:func:`make_simulation_scorer` scores a fitted model by simulating it from
each experiment's start and comparing the states with the measurements;
:class:`ExperimentSplit` keeps experiments whole across folds and
:class:`BlockSplit` cuts long records into contiguous blocks.
"""

from ._scoring import SimulationScorer, make_simulation_scorer
from ._splitters import BlockSplit, ExperimentSplit

__all__ = ["BlockSplit", "ExperimentSplit", "SimulationScorer", "make_simulation_scorer"]
