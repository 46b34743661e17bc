"""Convert the curves of a fitted model: to expressions (post-SR) or to interpolated tables."""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from numbers import Integral

import numpy as np
import pandas as pd
import sympy
from sklearn.base import clone
from sklearn.utils._param_validation import Interval, StrOptions, validate_params
from sklearn.utils.validation import check_is_fitted

from .._utils.randomness import seeds
from ..backends.symbolic.curves import FittedCurve, SymbolicCurve, Template
from ..backends.symbolic.engines import make_engine
from ..backends.symbolic.readable import Readability
from ..backends.symbolic.residuals import CurveResiduals
from ..exceptions import GaugeWarning
from ..fitting.problem import build_skeleton, gauge_skeleton, parity_of, points_of
from ..skeleton import Skeleton
from ..skeleton.curves import ZeroCurve
from .base import CCRegressor, adopt, backend_of, make_problem, set_fitted
from .interpolated import (
    InterpolatedCCRegressor,
    InterpolatedCurve,
    check_method,
    check_n_points,
    sample_curve,
    tabulate,
)
from .symbolic import MODEL_SELECTIONS, SymbolicCCRegressor, choose_candidate, polish

__all__ = ["from_tables", "to_interpolated", "to_symbolic"]

#: hyperparameters every backend shares, carried over to the converted model
SHARED = ("equations", "constraints", "gauge", "differentiation", "smooth_states")
#: residual evaluations per number when refining a candidate before comparing it
CANDIDATE_EFFORT = 30
#: candidates are compared with the learned curve on this many times the search's points
CHECK_DENSITY = 10


def _check_model(model, caller: str) -> dict:
    if not isinstance(model, CCRegressor):
        raise TypeError(f"{caller} converts a fitted CCRegressor (PolyCCRegressor, "
                        f"NeuralCCRegressor, ...), got {type(model).__name__}")
    check_is_fitted(model, "functions_")
    params = model.get_params(deep=False)
    return {name: params[name] for name in SHARED}


def _gauged(model: CCRegressor) -> tuple[dict, dict, set]:
    """Every curve's constraints, the pinned parameters and the curves pinned to zero."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GaugeWarning)
        constraints, fixed, zeroed, _ = gauge_skeleton(model.skeleton_, model.gauge)
    return constraints, fixed, zeroed


def _n_free_params(model: CCRegressor, fixed: Mapping) -> int:
    return len([a for a in model.skeleton_.params if a not in fixed])


def _grid(model: CCRegressor, name: str, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """The fitted curve ``name`` over its training range; it must be finite there."""
    x, values = sample_curve(model.functions_[name], *model.curve_ranges_[name], n_points)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise ValueError(f"the fitted curve {name} is not finite at {x[bad[0]]:.6g}, inside "
                         f"its training range [{x[0]:.6g}, {x[-1]:.6g}]")
    return x, values


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


@validate_params({
    "engine": [str],
    "binary_operators": [list, tuple],
    "unary_operators": [list, tuple],
    "maxsize": [Interval(Integral, 1, None, closed="left")],
    "max_nesting": [Interval(Integral, 0, None, closed="left"), None],
    "population_size": [Interval(Integral, 1, None, closed="left")],
    "generations": [Interval(Integral, 1, None, closed="left")],
    "n_points": [Integral],
    "model_selection": [StrOptions(set(MODEL_SELECTIONS))],
    "engine_options": [dict, None],
}, prefer_skip_nested_validation=True)
def to_symbolic(
    model: CCRegressor,
    X=None,
    y=None,
    *,
    engine: str = "operon",
    binary_operators: Sequence[str] = ("+", "-", "*"),
    unary_operators: Sequence[str] = ("tanh", "sin", "cos"),
    maxsize: int = 20,
    max_nesting: int | None = None,
    population_size: int = 500,
    generations: int = 50,
    n_points: int = 200,
    model_selection: str = "best",
    engine_options: Mapping | None = None,
    random_state=None,
) -> SymbolicCCRegressor:
    """Write the curves of a fitted model as analytic expressions (post-SR).

    Each fitted curve is sampled on ``n_points`` over the range of its
    argument in training, and a one-dimensional symbolic regression
    searches expressions for it, under the curve's constraints (an odd
    curve stays odd, point values hold). The learned curve is a smoothed
    picture of the data, so searching it is easier than searching the data.

    How an expression is chosen from each search's Pareto front:

    - without data, by its distance to the learned curve;
    - with ``X`` (and ``y``), the measurements decide: each candidate's
      numbers (and the skeleton's parameters) are refined by least squares
      on the equation residuals, the candidate is scored by that residual,
      and finally every number of every chosen expression and every
      parameter are refined jointly. This removes what the learned curve got
      wrong, not only what the search did.

    Parameters
    ----------
    model : CCRegressor
        A fitted model of any backend. It is not modified.
    X : DataFrame, optional
        Measurements to choose and refine the expressions on, as for
        ``fit`` (``t`` needed when ``y`` is None).
    y : DataFrame or array, optional
        Measured derivatives, as for ``fit``.
    engine, binary_operators, unary_operators, maxsize, max_nesting, population_size, generations
        The search, as for :class:`SymbolicCCRegressor`.
    n_points : int, default=200
        Samples of each learned curve given to the search.
    model_selection : {"best", "accuracy"}, default="best"
        See :class:`SymbolicCCRegressor`.
    engine_options : dict, optional
        Extra keyword arguments for the engine.
    random_state : int, RandomState or None
        Seeds every search.

    Returns
    -------
    SymbolicCCRegressor
        Fitted, with the model's skeleton and the hyperparameters above. It
        predicts and simulates with the compiled expressions. Besides
        ``expressions_`` and ``pareto_`` (one table of candidates per curve,
        with ``error``: the RMS distance to the learned curve on a grid ten
        times finer than the search's),
        ``conversion_`` is a DataFrame, one row per curve: ``expression``,
        ``complexity``, ``error`` and ``relative_error`` (``error`` over the
        RMS of the learned curve). Fitting it again runs the symbolic
        backend from scratch.
    """
    shared = _check_model(model, "to_symbolic")
    n_points = check_n_points(n_points)
    target = SymbolicCCRegressor(
        **shared, engine=engine, binary_operators=binary_operators,
        unary_operators=unary_operators, maxsize=maxsize, max_nesting=max_nesting,
        population_size=population_size,
        generations=generations, n_fit_points=n_points, model_selection=model_selection,
        engine_options=engine_options, random_state=random_state)
    search = make_engine(engine)
    backend = backend_of(target)
    rng = seeds(random_state)
    constraints, fixed, zeroed = _gauged(model)
    free = [f for f in model.skeleton_.functions if f not in zeroed]
    problem = residuals = None
    if X is not None:
        problem = make_problem(target, X, y)
        residuals = CurveResiduals(problem)
    functions = dict(model.functions_)
    params = dict(model.params_)
    curves: dict[str, FittedCurve] = {}
    checks: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    pareto, summary = {}, []
    for name in free:
        seed = next(rng)
        grid, learned = _grid(model, name, n_points)
        # candidates are judged between the search's points too: an expression that
        # swings between them (sin of a steep tanh) matches the samples, not the curve
        dense, dense_learned = checks[name] = _grid(model, name, CHECK_DENSITY * n_points)
        parity = parity_of(constraints[name])
        found = backend.search(search, grid, learned, parity, seed)
        template = Template(parity, points_of(constraints[name]))
        domain = (float(grid[0]), float(grid[-1]))
        monotone = next((c.kind for c in constraints[name]
                         if c.kind in ("increasing", "decreasing")), None)

        def score(curve, name=name, dense=dense, dense_learned=dense_learned, start=params):
            trial_params = start
            error = _rms(curve.function()(dense) - dense_learned)
            if residuals is None:
                loss, columns = error**2, {"error": error}
            else:
                trial_params = polish(
                    residuals, problem, {name: curve}, functions, start,
                    effort=CANDIDATE_EFFORT)
                loss = residuals.loss({**functions, name: curve.function()}, trial_params)
                columns = {"error": error, "loss": loss}
            if not (np.isfinite(loss) and np.isfinite(error)):
                return None
            return loss, columns, trial_params

        chosen = choose_candidate(found, template, domain, monotone, score, rule=model_selection,
                                  readability=Readability(max_nesting=max_nesting))
        if chosen is None:
            raise ValueError(f"the search found no finite expression for {name}"
                             + (f" that is {monotone}" if monotone else "")
                             + ": widen the operators or raise maxsize, population_size or "
                             "generations")
        curve, params, pareto[name] = chosen
        curves[name] = curve
        functions[name] = curve.function()
    if residuals is not None and curves:
        params = polish(residuals, problem, curves, functions, params)
    out = dict(model.functions_)
    for name, curve in curves.items():
        grid, learned = checks[name]
        expression = curve.expression()
        out[name] = SymbolicCurve(expression, curve.domain)
        error = _rms(out[name](grid) - learned)
        scale = _rms(learned)
        summary.append({"curve": name, "expression": expression,
                        "complexity": int(out[name].complexity()), "error": error,
                        "relative_error": error / scale if scale > 0 else np.inf})
    for name in model.skeleton_.functions:
        if name not in curves:
            out[name] = ZeroCurve()
    n_parameters = _n_free_params(model, fixed) + sum(len(c.expression.atoms(sympy.Float))
                                       for c in out.values() if isinstance(c, SymbolicCurve))
    conversion = pd.DataFrame(summary).set_index("curve") if summary else pd.DataFrame(
        columns=["expression", "complexity", "error", "relative_error"])
    adopt(target, model, out, params, n_parameters,
          attributes={"pareto_": pareto, "n_iterations_": 0, "conversion_": conversion})
    return set_fitted(target, {"loss_history_": [
        residuals.loss(target.functions_, target.params_)] if residuals is not None else []})


def _table(name: str, value) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(value, pd.DataFrame):
        missing = [c for c in ("x", name) if c not in value.columns]
        if missing:
            raise ValueError(f"the table given for {name} has no column {missing[0]!r}; "
                             f"expected columns 'x' and {name!r} (as cc_curves returns)")
        return value["x"].to_numpy(dtype=float), value[name].to_numpy(dtype=float)
    try:
        x, values = value
    except (TypeError, ValueError):
        raise ValueError(f"the table given for {name} must be a DataFrame with columns 'x' "
                         f"and {name!r}, or a pair (x, values)") from None
    return np.asarray(x, dtype=float), np.asarray(values, dtype=float)


@validate_params({"curves": [dict, None], "n_points": [Integral], "method": [str]},
                 prefer_skip_nested_validation=True)
def to_interpolated(model: CCRegressor, curves: Mapping | None = None, *,
                    n_points: int = 200, method: str = "pchip") -> InterpolatedCCRegressor:
    """Replace the curves of a fitted model by interpolated tables (the paper's ``Interp``).

    Parameters
    ----------
    model : CCRegressor
        A fitted model of any backend. It is not modified.
    curves : dict, optional
        Tables to use instead of the model's own curves, by curve name:
        a DataFrame with columns ``x`` and the name (as
        :meth:`CCRegressor.cc_curves` returns) or a pair ``(x, values)``.
        Curves not named are tabulated from the model.
    n_points : int, default=200
        Points of each table taken from the model, over the range of the
        curve's argument in training.
    method : {"pchip", "akima", "cubic", "linear"}, default="pchip"
        How tables are interpolated: PCHIP is monotone cubic.

    Returns
    -------
    InterpolatedCCRegressor
        Fitted, with the model's skeleton and parameters; it predicts and
        simulates from the tables, continuing each linearly beyond its ends.
    """
    shared = _check_model(model, "to_interpolated")
    n_points = check_n_points(n_points)
    check_method(method)
    curves = dict(curves or {})
    names = model.skeleton_.functions
    unknown = [name for name in curves if name not in names]
    if unknown:
        raise ValueError(f"curves names {unknown[0]!r}, which is not a curve of the skeleton "
                         f"({', '.join(names)})")
    target = InterpolatedCCRegressor(**shared, estimator=clone(model), n_points=n_points,
                                     method=method)
    out = {}
    for name in names:
        if name in curves:
            out[name] = InterpolatedCurve(*_table(name, curves[name]), method, name)
        else:
            lo, hi = model.curve_ranges_[name]
            out[name] = tabulate(model.functions_[name], lo, hi, n_points, method, name=name)
    n_parameters = _n_free_params(model, _gauged(model)[1]) + sum(c.x.size for c in out.values()
                                       if isinstance(c, InterpolatedCurve))
    return adopt(target, model, out, model.params_, n_parameters)


@validate_params({"equations": [list, tuple, Skeleton], "curves": [dict],
                  "params": [dict, None], "constraints": [list, tuple, None], "method": [str]},
                 prefer_skip_nested_validation=True)
def from_tables(equations, curves: Mapping, params: Mapping | None = None, constraints=None,
                *, method: str = "pchip") -> InterpolatedCCRegressor:
    """A fitted model whose curves are the given tables (no data needed).

    Parameters
    ----------
    equations : list of str or Skeleton
        The skeleton.
    curves : dict
        A table for every curve of the skeleton, by name: a DataFrame with
        columns ``x`` and the name, or a pair ``(x, values)``.
    params : dict, optional
        A value for every parameter ``a_i`` of the skeleton.
    constraints : list, optional
        The curves' constraints (kept for conversions such as
        :func:`to_symbolic`; the tables are used as given).
    method : {"pchip", "akima", "cubic", "linear"}, default="pchip"

    Returns
    -------
    InterpolatedCCRegressor
        Fitted: it predicts, simulates and converts like any fitted model;
        it has seen no data (no ``n_features_in_``).
    """
    check_method(method)
    model = InterpolatedCCRegressor(equations=equations, constraints=constraints,
                                    method=method)
    skeleton = build_skeleton(equations, constraints)
    functions = {name: InterpolatedCurve(*_table(name, table), method, name)
                 for name, table in curves.items()}
    functions, params = skeleton.check_values(functions, params)
    return set_fitted(model, {
        "skeleton_": skeleton, "gauge_": {},
        "curve_ranges_": {name: curve.domain for name, curve in functions.items()},
        "_y_1d": False, "params_": {a: float(params[a]) for a in skeleton.params},
        "functions_": {f: functions[f] for f in skeleton.functions},
        "n_parameters_": len(params) + sum(c.x.size for c in functions.values())})
