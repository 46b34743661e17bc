"""Simulation: a compiled right-hand side integrated forward, whole or in windows.

:mod:`.integration` drives the ODE solvers (adaptive, or per sample interval
with held or band-limited inputs) and raises
:class:`~sklearn_pycc.SimulationError` where a simulation diverges;
:mod:`.windows` simulates a record in windows, the layout of multiple
shooting and of the diagnosis's trajectories. The integration's names import
from here as well.
"""

from .integration import (
    DEFAULT_MAX_STEPS,
    INPUT_HOLDS,
    STEP_BUDGET,
    Diverged,
    InputSignals,
    check_hold,
    check_time_grid,
    fitted_hold,
    given_hold,
    integrate_sampled,
    integrate_system,
    judged_step_limit,
    progress_bar,
    requested_hold,
    sampled_step_limit,
)

__all__ = ["DEFAULT_MAX_STEPS", "INPUT_HOLDS", "STEP_BUDGET", "Diverged", "InputSignals",
           "check_hold", "check_time_grid", "fitted_hold", "given_hold", "integrate_sampled",
           "integrate_system", "judged_step_limit", "progress_bar", "requested_hold",
           "sampled_step_limit"]
