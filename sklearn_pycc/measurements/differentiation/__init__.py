"""Derivatives of noisy samples: the ``differentiation`` hyperparameter.

A differentiator turns one experiment's samples ``x(t)`` into a smoothed
``x`` and its derivatives up to a given order. The hyperparameter is a name
(``"auto"``, ``"lowpass"``, ``"spline"``, ``"savgol"``,
``"finite_difference"``, ``"kalman"``, ``"trend_filtered"``), a dict
``{"method": name, **options}``, an object of the ``derivative`` package
(anything with ``d(x, t)``), or a callable ``f(x, t) -> dx/dt``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from ._classic import (
    CallableDifferentiator,
    Differentiator,
    FiniteDifferences,
    PackageDifferentiator,
    SavgolDifferentiator,
    SplineDifferentiator,
    kalman,
    trend_filtered,
)
from ._lowpass import AutoDifferentiator, LowpassDifferentiator

__all__ = ["DIFFERENTIATION_METHODS", "Differentiator", "resolve_differentiation"]


def _auto() -> Differentiator:
    return AutoDifferentiator()


def _lowpass(cutoff: float | None = None, order: int = 6,
             filter_inputs: bool = True) -> Differentiator:
    return LowpassDifferentiator(cutoff, order, filter_inputs)


#: name -> factory of its default differentiator (options as keyword arguments)
DIFFERENTIATION_METHODS: dict[str, Callable[..., Differentiator]] = {
    "auto": _auto,
    "lowpass": _lowpass,
    "spline": SplineDifferentiator,
    "savgol": SavgolDifferentiator,
    "finite_difference": FiniteDifferences,
    "kalman": kalman,
    "trend_filtered": trend_filtered,
}


def resolve_differentiation(spec) -> Differentiator:
    """Turn the ``differentiation`` hyperparameter into a :class:`Differentiator`.

    Raises
    ------
    ValueError
        For an unknown name or option; the message lists the known ones.
    """
    if isinstance(spec, Differentiator):
        return spec
    if isinstance(spec, str):
        return _by_name(spec, {})
    if isinstance(spec, Mapping):
        options = dict(spec)
        name = options.pop("method", None)
        if not isinstance(name, str):
            raise ValueError("a differentiation dict needs a 'method' key naming one of "
                             f"{sorted(DIFFERENTIATION_METHODS)}, got {spec!r}")
        return _by_name(name, options)
    if hasattr(spec, "d") and callable(spec.d):
        return PackageDifferentiator(spec, type(spec).__name__)
    if callable(spec):
        return CallableDifferentiator(spec)
    raise ValueError(
        f"differentiation must be one of {sorted(DIFFERENTIATION_METHODS)}, a dict "
        f"{{'method': name, **options}}, a callable f(x, t) or an object with d(x, t); "
        f"got {spec!r}")


def _by_name(name: str, options: dict) -> Differentiator:
    if name not in DIFFERENTIATION_METHODS:
        raise ValueError(f"unknown differentiation method {name!r}; choose one of "
                         f"{sorted(DIFFERENTIATION_METHODS)}, a callable f(x, t) or an "
                         "object with d(x, t)")
    try:
        return DIFFERENTIATION_METHODS[name](**options)
    except TypeError as error:
        raise ValueError(f"bad options {options} for the differentiation method {name!r}: "
                         f"{error}") from None
