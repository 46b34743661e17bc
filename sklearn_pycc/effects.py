"""The catalogue of physical effects, importable as ``sklearn_pycc.effects``.

It lives in :mod:`sklearn_pycc.diagnostics.effects`, next to the diagnosis
that uses it; this module gives it its public address, so that both
``from sklearn_pycc import effects`` and ``import sklearn_pycc.effects`` work.
"""

from .diagnostics.effects import (
    ACTS_THROUGH,
    PLAUSIBILITY,
    Effect,
    catalogue,
    get,
    names,
    register,
    unregister,
)

__all__ = ["ACTS_THROUGH", "PLAUSIBILITY", "Effect", "catalogue", "get", "names", "register",
           "unregister"]
