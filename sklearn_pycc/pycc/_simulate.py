"""``simulate``: the paper's forward integration, by curve name."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from scipy.optimize import OptimizeResult

from ..estimators._symbolic_curves import VARIABLE
from ..estimators.conversion import from_tables
from ..estimators.interpolated import InterpolatedCurve
from ..exceptions import SimulationError
from ..skeleton import Skeleton
from ..skeleton.curves import as_curve
from ._params import Params
from ._shared import pair_evals

__all__ = ["simulate"]

COMMON = {"t_span": Params.REQUIRED, "y0": Params.REQUIRED, "t_eval": None, "method": "LSODA",
          "atol": 1e-8, "rtol": 1e-6, "check_nan": True, "local_funcs": None,
          "obtained_coefs": None, "print_models": False}
METHOD_KEYS = {
    "Theoretical": {},
    "NN": {"models": Params.REQUIRED},
    "Poly": {"models": Params.REQUIRED},
    "SymbR": {"models": None, "evals": None, "function_names": None, "pysr": None,
              "random_state": None},
    "Interp": {"evals": Params.REQUIRED, "function_names": None, "interp_method": "pchip"},
}
#: points of the output grid when no t_eval is given
DEFAULT_POINTS = 1001


def _curve(value, name: str, where: str) -> Callable:
    if isinstance(value, Mapping) and "func" in value:  # post_processing's entries
        value = value["func"]
    if not callable(value):
        raise TypeError(f"{where}: the model given for {name} is not callable "
                        f"({type(value).__name__})")
    return value


def _functions(skeleton: Skeleton, method: str, read: Params, local: dict, where: str) -> dict:
    names = skeleton.functions
    given: dict = {}
    if method in ("NN", "Poly", "SymbR") and read.given("models"):
        models = read["models"]
        unknown = [name for name in models if name not in names]
        if unknown:
            raise ValueError(f"{where}: models has the curve {unknown[0]!r}, which the "
                             f"equations do not use (they use {', '.join(names) or 'none'})")
        given = {name: _curve(value, name, where) for name, value in models.items()}
    elif method == "SymbR" and read.given("evals"):
        from ._post import post_processing

        settings = {"evals": read["evals"], "pysr": read["pysr"], "plot": False,
                    "function_names": read["function_names"],
                    "random_state": read["random_state"]}
        models, _ = post_processing(list(skeleton.equations), "SymbR", settings)
        given = {name: _curve(value, name, where) for name, value in models.items()}
    elif method == "SymbR":
        raise ValueError(f"{where}: params must give 'models' (from train or "
                         "post_processing) or 'evals' (to fit expressions first)")
    elif method == "Interp":
        order = read["function_names"] or names
        tables = pair_evals(read["evals"], list(order), where)
        given = {name: InterpolatedCurve(x, values, read["interp_method"], name)
                 for name, (x, values) in tables.items()}
    out = {}
    for name in names:
        if name in given:
            out[name] = given[name]
        elif name in local:
            out[name] = _curve(local[name], name, where)
        else:
            source = "local_funcs" if method == "Theoretical" else "models or local_funcs"
            raise ValueError(f"{where}: no curve for {name}; give it in {source}")
    return out


def _estimator(skeleton: Skeleton, method: str, read: Params, functions: dict, values: dict):
    """The fitted estimator behind a simulation, when there is one."""
    if method == "Interp":
        tables = {name: (curve.x, curve.y) for name, curve in functions.items()}
        return from_tables(list(skeleton.equations), tables, values,
                           method=read["interp_method"])
    models = read.get("models")
    return getattr(models, "estimator", None)


def _times(read: Params, where: str) -> tuple[np.ndarray, bool]:
    """Output times, and whether ``t_span[0]`` was prepended as the start."""
    try:
        t0, t1 = (float(v) for v in read["t_span"])
    except (TypeError, ValueError):
        raise ValueError(f"{where}: t_span must be a pair (t_start, t_end)") from None
    if read["t_eval"] is None:
        return np.linspace(t0, t1, DEFAULT_POINTS), False
    t = np.asarray(read["t_eval"], dtype=float)
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"{where}: t_eval must be a 1-D array of times")
    if t[0] < t0 or t[-1] > t1:
        raise ValueError(f"{where}: t_eval runs from {t[0]:.6g} to {t[-1]:.6g}, outside "
                         f"t_span ({t0:.6g}, {t1:.6g})")
    if t[0] > t0:
        return np.concatenate([[t0], t]), True
    return t, False


def simulate(equations, method: str = "Theoretical", params: dict | None = None):
    """Integrate ``equations`` forward (the paper's ``simulate``).

    Parameters
    ----------
    equations : list of str
        The skeleton.
    method : {"Theoretical", "NN", "Poly", "SymbR", "Interp"}
        Where the curves come from: ``local_funcs`` (Theoretical), the
        ``models`` of :func:`train` or :func:`post_processing` (NN, Poly,
        SymbR), expressions fitted first to ``evals`` (SymbR with
        ``evals``), or tables interpolated from ``evals`` (Interp).
    params : dict
        ``t_span`` and ``y0`` (required), ``t_eval`` (default 1001 evenly
        spaced times over ``t_span``), ``method`` (the SciPy solver, LSODA),
        ``atol`` (1e-8), ``rtol`` (1e-6), ``check_nan`` (True: a diverging
        trajectory raises :class:`~sklearn_pycc.SimulationError`, a
        ``RuntimeError``; False: it is returned with ``sol.success`` False),
        ``local_funcs`` (inputs such as ``F_ext`` and known curves, by
        name), ``obtained_coefs`` (the ``a_i``), ``print_models``; and per
        method ``models``, ``evals``, ``function_names``, ``pysr``,
        ``interp_method`` ("pchip", "akima", "cubic" or "linear").
        Curves are matched by name, never by position; ``evals`` lists them
        in the order of their names.

    Returns
    -------
    sol : OptimizeResult
        ``sol.t``, ``sol.y`` (one row per state, in the order of the
        equations), ``sol.success``, ``sol.message``, ``sol.frame`` (a
        DataFrame of the trajectory) and ``sol.estimator``: the fitted
        estimator simulated (that of ``models``, or for Interp an
        :class:`~sklearn_pycc.InterpolatedCCRegressor` of the tables; None
        for Theoretical).
    derivatives : ndarray of shape (n_states, n_times)
        The right-hand side along the trajectory.
    """
    where = f"simulate(method={method!r})"
    if method not in METHOD_KEYS:
        raise ValueError(f"simulate: method must be one of {sorted(METHOD_KEYS)}, "
                         f"got {method!r}")
    read = Params(params, {**COMMON, **METHOD_KEYS[method]}, where)
    skeleton = Skeleton(equations)
    local = dict(read["local_funcs"] or {})
    strays = [k for k in local if k not in skeleton.functions and k not in skeleton.inputs]
    if strays:
        raise ValueError(f"{where}: local_funcs has {strays[0]!r}, which is neither a curve "
                         f"nor an input of the equations (curves: "
                         f"{', '.join(skeleton.functions) or 'none'}; inputs: "
                         f"{', '.join(skeleton.inputs) or 'none'})")
    functions = _functions(skeleton, method, read, local, where)
    inputs = {name: local[name] for name in skeleton.inputs if name in local}
    missing = [name for name in skeleton.inputs if name not in inputs]
    if missing:
        raise ValueError(f"{where}: no signal for the input {missing[0]!r}; give it in "
                         "local_funcs")
    coefs = dict(read["obtained_coefs"] or {})
    values = {}
    for name in skeleton.params:
        if name not in coefs:
            raise ValueError(f"{where}: no value for the parameter {name!r}; give it in "
                             "obtained_coefs")
        value = coefs[name]
        values[name] = float(value.item() if hasattr(value, "item") else value)
    if read["print_models"]:
        for name, curve in functions.items():
            expression = as_curve(curve).to_sympy(VARIABLE)
            print(f"{name}: {curve if expression is None else expression}")
    t, prepended = _times(read, where)
    options = {"method": read["method"], "rtol": float(read["rtol"]),
               "atol": float(read["atol"])}
    try:
        frame = skeleton.simulate(t, read["y0"], functions, values, inputs,
                                  return_derivatives=True, **options)
        success, message = True, "The solver successfully reached the end of the interval."
    except SimulationError as error:
        if read["check_nan"]:
            raise
        frame, success, message = error.partial, False, str(error)
        for name in skeleton.derivatives:
            frame[name] = np.nan
    if prepended:
        frame = frame.iloc[1:].reset_index(drop=True)
    sol = OptimizeResult(t=frame["t"].to_numpy(), y=frame[skeleton.states].to_numpy().T,
                         success=success, status=0 if success else -1, message=message,
                         frame=frame, estimator=_estimator(skeleton, method, read, functions,
                                                           values))
    return sol, frame[skeleton.derivatives].to_numpy().T
