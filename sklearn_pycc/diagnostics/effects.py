"""The catalogue of physical effects, as the diagnosis reads it.

It lives in :mod:`sklearn_pycc.effects`; this module keeps the address the
diagnosis gave it, so that ``sklearn_pycc.diagnostics.effects`` still works.
"""

from ..effects import (
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
