"""Measurements as they come: experiments, time grids and estimated derivatives.

This layer sits below the estimators and the diagnostics: it reads the
columns of ``X`` and ``y`` (:func:`read_record`, the one path every fit,
diagnosis and scorer takes), splits a data set into experiments
(``trajectory`` column), checks each experiment's time grid, and estimates
the derivatives (and states defined by kinematic equations) that were not
measured, and reads each signal's noise (:attr:`Measurement.noise`).
"""

from .differentiation import DIFFERENTIATION_METHODS, Differentiator, resolve_differentiation
from .experiments import Experiment, split_experiments
from .measurement import Measurement
from .noise import NoiseReading, SignalNoise, read_noise
from .reconstruct import Estimate, estimate_states, kinematic_chains
from .record import Record, read_record

__all__ = [
    "DIFFERENTIATION_METHODS",
    "Differentiator",
    "Estimate",
    "Experiment",
    "Measurement",
    "NoiseReading",
    "Record",
    "SignalNoise",
    "estimate_states",
    "kinematic_chains",
    "read_noise",
    "read_record",
    "resolve_differentiation",
    "split_experiments",
]
