"""``simulate``: the paper's forward integration, by curve name."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from scipy.interpolate import UnivariateSpline
from scipy.optimize import OptimizeResult

from ..backends.symbolic.curves import VARIABLE
from ..estimators.base import set_fitted
from ..estimators.conversion import from_tables
from ..estimators.interpolated import INTERPOLATIONS, InterpolatedCurve
from ..exceptions import SimulationError
from ..skeleton import Skeleton
from ..skeleton.curves import Curve, as_curve
from ._params import Params
from ._shared import equation_list, pair_evals

__all__ = ["simulate"]

COMMON = {"t_span": Params.REQUIRED, "y0": Params.REQUIRED, "t_eval": None, "method": "LSODA",
          "atol": 1e-8, "rtol": 1e-6, "check_nan": True, "local_funcs": None,
          "obtained_coefs": None, "scalar_params": None, "print_models": False}
METHOD_KEYS = {
    "Theoretical": {},
    "NN": {"models": Params.REQUIRED},
    "Poly": {"models": Params.REQUIRED},
    "SymbR": {"models": None, "evals": None, "function_names": None, "pysr": None,
              "random_state": None},
    "Interp": {"evals": Params.REQUIRED, "function_names": None, "interp_method": "pchip",
               "smoothing": None, "extrapolate": True},
}
METHOD_IGNORED = {
    "Poly": {"scaling": "a fitted polynomial carries the scaling of its argument, so the "
                        "models are evaluated on the argument as it is"},
}
#: the published package's smoothing spline, besides our interpolations
SPLINE = "spline"
#: points of the output grid when no t_eval is given
DEFAULT_POINTS = 1001


class _HeldCurve(Curve):
    """A curve held at its end values beyond its domain (``extrapolate=False``).

    Parameters
    ----------
    curve : Curve
        The curve inside its domain.
    """

    extrapolation = "clip"

    def __init__(self, curve: Curve) -> None:
        self.curve = curve
        self.domain = curve.domain

    def __call__(self, x):
        """The curve at ``x`` clipped to the domain."""
        return self.curve(np.clip(np.asarray(x, dtype=float), *self.domain))

    def scalar(self, x: float) -> float:
        """The curve at one float clipped to the domain."""
        low, high = self.domain
        return self.curve.scalar(min(max(x, low), high))

    def text(self, variable: str, precision: int = 6) -> str:
        """The inner curve's text, held beyond its domain."""
        return f"{self.curve.text(variable, precision)}, held beyond its ends"

    @property
    def n_numbers(self) -> int:
        """The inner curve's count."""
        return self.curve.n_numbers

    def __repr__(self) -> str:
        return f"_HeldCurve({self.curve!r})"


def _curve(value, name: str, where: str) -> Callable:
    if isinstance(value, Mapping) and "func" in value:  # post_processing's entries as dicts
        value = value["func"]
    if not callable(value):
        raise TypeError(f"{where}: the model given for {name} is not callable "
                        f"({type(value).__name__})")
    return value


def _interpolation(read: Params) -> str:
    """The table interpolation for ``interp_method``; ``'spline'`` smooths, then cubic."""
    method = read["interp_method"]
    if method != SPLINE and method not in INTERPOLATIONS:
        raise ValueError(f"{read.where}: interp_method must be one of "
                         f"{[*INTERPOLATIONS, SPLINE]}, got {method!r}")
    if read.given("smoothing") and method != SPLINE:
        read.note("'smoothing' has no effect: it is the smoothing of "
                  "interp_method='spline' only")
    return "cubic" if method == SPLINE else method


def _tables(read: Params, names: list[str]) -> dict:
    """``{name: (x, values)}`` from ``evals``, smoothed for ``interp_method='spline'``."""
    tables = pair_evals(read["evals"], names, read.where)
    smoothing = float(read["smoothing"] or 0.0)
    if read["interp_method"] != SPLINE or smoothing == 0.0:
        # a spline through every point (no smoothing) is the not-a-knot cubic spline
        return tables
    if not np.isfinite(smoothing) or smoothing < 0:
        raise ValueError(f"{read.where}: smoothing must be a non-negative number, "
                         f"got {read['smoothing']!r}")
    out = {}
    for name, (x, values) in tables.items():
        try:
            spline = UnivariateSpline(x, values, k=3, s=smoothing)
        except ValueError as error:
            raise ValueError(f"{read.where}: the smoothing spline of {name} failed: "
                             f"{error}") from None
        out[name] = (x, spline(x))
    return out


def _functions(skeleton: Skeleton, method: str, read: Params, local: dict, values: dict
               ) -> dict:
    where = read.where
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
        from ._post import fit_expressions

        models, _ = fit_expressions(list(skeleton.equations), read, values)
        given = dict(models)
    elif method == "SymbR":
        raise ValueError(f"{where}: params must give 'models' (from train or "
                         "post_processing) or 'evals' (to fit expressions first)")
    elif method == "Interp":
        order = list(read["function_names"] or names)
        interpolation = _interpolation(read)
        given = {name: InterpolatedCurve(x, y, interpolation, name)
                 for name, (x, y) in _tables(read, order).items()}
        if not read["extrapolate"]:
            given = {name: _HeldCurve(curve) for name, curve in given.items()}
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
    if method != "Interp":
        return getattr(read.get("models"), "estimator", None)
    tables = {name: curve.curve if isinstance(curve, _HeldCurve) else curve
              for name, curve in functions.items()}
    if not all(isinstance(table, InterpolatedCurve) for table in tables.values()):
        return None  # some curves came from local_funcs: no tables to build a model of
    kinds = {table.method for table in tables.values()} or {"pchip"}
    model = from_tables(list(skeleton.equations),
                        {name: (table.x, table.y) for name, table in tables.items()},
                        values, method=kinds.pop())
    if not read["extrapolate"]:  # the estimator holds its tables as the simulation does
        set_fitted(model, {"functions_": dict(functions)})
    return model


def _number(value, name: str, where: str, key: str) -> float:
    try:
        number = float(value.item() if hasattr(value, "item") else value)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {key}[{name!r}] must be one number, got {value!r}") from None
    return number


def _coefficients(skeleton: Skeleton, read: Params) -> dict:
    """The ``a_i``: ``obtained_coefs`` and its other name ``scalar_params``, which must agree."""
    where = read.where
    given = {}
    for key in ("obtained_coefs", "scalar_params"):
        for name, value in dict(read[key] or {}).items():
            number = _number(value, name, where, key)
            if name in given and not np.isclose(given[name][1], number, rtol=1e-12, atol=0):
                raise ValueError(f"{where}: obtained_coefs[{name!r}] = {given[name][1]!r} "
                                 f"but scalar_params[{name!r}] = {number!r}; they are two "
                                 "names of the same coefficients: give one, or the same "
                                 "values")
            given.setdefault(name, (key, number))
    values = {}
    for name in skeleton.params:
        if name not in given:
            raise ValueError(f"{where}: no value for the parameter {name!r}; give it in "
                             "obtained_coefs (or scalar_params)")
        values[name] = given[name][1]
    return values


def _times(read: Params) -> tuple[np.ndarray, bool]:
    """Output times, and whether ``t_span[0]`` was prepended as the start."""
    where = read.where
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


def _local(skeleton: Skeleton, read: Params) -> dict:
    local = dict(read["local_funcs"] or {})
    strays = [k for k in local if k not in skeleton.functions and k not in skeleton.inputs]
    if strays:
        raise ValueError(f"{read.where}: local_funcs has {strays[0]!r}, which is neither a "
                         f"curve nor an input of the equations (curves: "
                         f"{', '.join(skeleton.functions) or 'none'}; inputs: "
                         f"{', '.join(skeleton.inputs) or 'none'})")
    return local


def simulate(equations, method: str = "Theoretical", params: dict | None = None):
    """Integrate ``equations`` forward (the paper's ``simulate``).

    Parameters
    ----------
    equations : list of str or str
        The skeleton. One string is one equation (one per line when it has
        several lines).
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
        name), ``obtained_coefs`` (the ``a_i``; ``scalar_params`` is another
        name for it: giving both, they must agree), ``print_models``; and
        per method ``models``, ``evals``, ``function_names``, ``pysr``,
        ``interp_method`` ("pchip", "akima", "cubic", "linear", or
        "spline": a smoothing spline with ``smoothing``, default 0, that
        is, the cubic spline through every point), ``extrapolate`` (True:
        tables continue along their end tangents; False: they hold their
        end values). ``scaling`` (Poly) has no effect: a fitted model
        evaluates its curves on their argument as it is. Curves are matched
        by name, never by position; ``evals`` lists them in the order of
        their names. What is read differently here is said in one warning.

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
    read = Params(params, {**COMMON, **METHOD_KEYS[method]}, where,
                  METHOD_IGNORED.get(method))
    skeleton = Skeleton(equation_list(equations, where))
    local = _local(skeleton, read)
    values = _coefficients(skeleton, read)
    functions = _functions(skeleton, method, read, local, values)
    inputs = {name: local[name] for name in skeleton.inputs if name in local}
    missing = [name for name in skeleton.inputs if name not in inputs]
    if missing:
        raise ValueError(f"{where}: no signal for the input {missing[0]!r}; give it in "
                         "local_funcs")
    if read["print_models"]:
        for name, curve in functions.items():
            expression = as_curve(curve).to_sympy(VARIABLE)
            print(f"{name}: {curve if expression is None else expression}")
    t, prepended = _times(read)
    options = {"method": read["method"], "rtol": float(read["rtol"]),
               "atol": float(read["atol"])}
    estimator = _estimator(skeleton, method, read, functions, values)
    read.warn()
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
                         frame=frame, estimator=estimator)
    return sol, frame[skeleton.derivatives].to_numpy().T
