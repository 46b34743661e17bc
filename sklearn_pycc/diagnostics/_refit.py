"""The one way the diagnosis and the loop refit a model: a clone with what they change.

Every refit of the diagnosis (a candidate's extended skeleton, a held-out
fold, a whole-record check, a hidden-state limit) and of the loop (the next
round's model, the refinement by output error) goes through
:func:`prepared`, so that which of the user's settings a refit keeps or
drops is decided here once.
"""

from __future__ import annotations

from collections.abc import Mapping

from sklearn.base import clone

__all__ = ["prepared"]

#: ``n_bootstrap`` as the model has it (a refit otherwise makes no refits on resamples)
KEEP = None


def prepared(model, *, equations=None, param_init: Mapping[str, float] | None = None,
             fit_mode: str | None = None, n_bootstrap: int | None = 0,
             hold_as_fitted: bool = False, **settings):
    """An unfitted clone of ``model`` with the settings a refit changes.

    Parameters
    ----------
    model : CCRegressor
        The model to refit (fitted, where ``hold_as_fitted`` asks for it).
    equations : Skeleton or list of str, optional
        Another skeleton; its constraints are then its own (``constraints=None``).
    param_init : mapping, optional
        Starting values, for an estimator that takes them; with a
        :class:`~sklearn_pycc.Skeleton` as ``equations``, those of parameters
        it does not have are left out.
    fit_mode : str, optional
        Another fit mode, for an estimator that has one.
    n_bootstrap : int or None, default=0
        Refits on resamples: none by default (a refit is judged by its
        errors); :data:`KEEP` (None) keeps the model's own.
    hold_as_fitted : bool, default=False
        Keep the input hold an ``input_hold="auto"`` model chose.
    **settings
        Any other hyperparameters, set as given.
    """
    params = model.get_params()
    new = {}
    if equations is not None:
        new.update(equations=equations, constraints=None)
    if param_init is not None and "param_init" in params:
        # a skeleton says which parameters it has; text is read by the fit itself
        known = set(equations.params) if hasattr(equations, "params") else None
        new["param_init"] = {a: v for a, v in param_init.items()
                             if known is None or a in known}
    if fit_mode is not None and "fit_mode" in params:
        new["fit_mode"] = fit_mode
    if n_bootstrap is not KEEP and (params.get("n_bootstrap") or n_bootstrap):
        new["n_bootstrap"] = n_bootstrap
    if hold_as_fitted and params.get("input_hold") == "auto":
        new["input_hold"] = model.input_hold_
    new.update(settings)
    return clone(model).set_params(**new)
