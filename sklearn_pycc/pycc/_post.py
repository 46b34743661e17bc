"""``post_processing``: expressions for the curves of ``evals`` (the paper's post-SR)."""

from __future__ import annotations

import numpy as np

from ..estimators.conversion import from_tables, to_symbolic
from ..skeleton import Skeleton
from ._params import Params
from ._shared import Models, equation_list, pair_evals, symbolic_settings
from ._symbolic import symbolic_entries

__all__ = ["post_processing"]

KEYS = {"evals": Params.REQUIRED, "pysr": None, "plot": True, "n_eval": 200,
        "function_names": None, "constraints": None, "obtained_coefs": None,
        "random_state": None}


def _figure(tables: dict, evals_sr: dict, models: Models):
    import matplotlib
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tables), squeeze=False, figsize=(5 * len(tables), 4),
                             layout="constrained")
    for ax, (name, (x, values)) in zip(axes[0], tables.items()):
        ax.plot(x, values, ".", markersize=3, label=f"{name} given")
        ax.plot(*evals_sr[name], "-", label=f"{name} post-SR")
        ax.set_title(models[name]["expr"], fontsize="small", wrap=True)
        ax.set_xlabel("x")
        ax.set_ylabel(name)
        ax.legend(fontsize="small")
    if "agg" not in matplotlib.get_backend().lower():  # a display: show without blocking
        plt.show(block=False)
    return fig


def _coefficients(skeleton: Skeleton, read: Params) -> dict:
    """The skeleton's ``a_i`` from ``obtained_coefs``, each one finite number."""
    coefs = dict(read.get("obtained_coefs") or {})
    missing = [name for name in skeleton.params if name not in coefs]
    if missing:
        raise ValueError(
            f"{read.where}: the equations have the parameter(s) {', '.join(missing)} but "
            "params['obtained_coefs'] gives no value for them: pass the coefficients "
            "pycc.train returned (its third value)")
    values = {}
    for name in skeleton.params:
        value = np.asarray(coefs[name], dtype=float)
        if value.size != 1 or not np.isfinite(value).all():
            raise ValueError(f"{read.where}: obtained_coefs[{name!r}] must be one finite "
                             f"number, got {coefs[name]!r}")
        values[name] = float(value.reshape(()))
    return values


def post_processing(equations, method: str = "SymbR", params: dict | None = None):
    """Fit expressions to the curves of ``evals`` (the paper's ``post_processing``).

    Parameters
    ----------
    equations : list of str or str
        The skeleton; it names the curves (``f1, f2, ...``). One string is
        one equation (one per line when it has several lines).
    method : {"SymbR"}
        Symbolic regression (the offline engine unless PySR is installed).
    params : dict
        ``evals`` (required: ``[x_f1, f1, x_f2, f2, ...]`` in the order of
        the names, or of ``function_names``), ``pysr`` (settings of the
        search), ``plot`` (True: a figure of each fit, shown without
        blocking when there is a display), ``n_eval`` (200 points in
        ``evals_sr``), ``constraints`` (kept by the expressions),
        ``obtained_coefs`` (the skeleton's ``a_i``, carried by the
        estimator) and ``random_state``. What is read differently here is
        said in one warning.

    Returns
    -------
    models_sr : Models
        ``{"f1": entry, ...}``: each entry is the fitted curve (callable)
        and answers ``entry["expr"]``, ``entry["func"]``, ``entry["sympy"]``
        and ``entry["pysr_model"]`` (the search's Pareto front, answering
        ``get_best()``, ``sympy()`` and ``equations_`` as a PySR model
        does); see :class:`~sklearn_pycc.pycc.SymbolicEntry`.
        ``models_sr.estimator`` is the fitted
        :class:`~sklearn_pycc.SymbolicCCRegressor` and ``models_sr.figure``
        the figure (None without ``plot``).
    evals_sr : list of ndarray
        The expressions on ``n_eval`` points over each table's range.
    """
    where = f"post_processing(method={method!r})"
    if method != "SymbR":
        raise ValueError(f"post_processing: method must be 'SymbR', got {method!r}")
    read = Params(params, KEYS, where)
    out = fit_expressions(equation_list(equations, where), read)
    read.warn()
    return out


def fit_expressions(equations, read: Params, values: dict | None = None):
    """:func:`post_processing` on checked ``params`` (notes are left on ``read``).

    ``values`` are the skeleton's ``a_i`` when the caller has read them
    already; otherwise they come from ``obtained_coefs``.
    """
    where = read.where
    skeleton = Skeleton(equations)
    names = list(read["function_names"] or skeleton.functions)
    if sorted(names) != sorted(skeleton.functions):
        raise ValueError(f"{where}: function_names {names} must name each curve of the "
                         f"equations once ({', '.join(skeleton.functions)})")
    tables = pair_evals(read["evals"], names, where)
    if values is None:
        values = _coefficients(skeleton, read)
    tabulated = from_tables(list(skeleton.equations), tables, values,
                            read.get("constraints"))
    settings = symbolic_settings(read["pysr"], read)
    model = to_symbolic(tabulated, random_state=read["random_state"], **settings)
    evals_sr, grids = [], {}
    for name in names:
        x = np.linspace(*model.curve_ranges_[name], int(read.get("n_eval", 200)))
        y = np.broadcast_to(np.asarray(model.functions_[name](x), dtype=float), x.shape)
        grids[name] = (x, np.array(y))
        evals_sr += [x, np.array(y)]
    models = Models(symbolic_entries(model), model)
    models.figure = _figure(tables, grids, models) if read.get("plot", False) else None
    return models, evals_sr
