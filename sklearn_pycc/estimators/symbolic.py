"""Symbolic backend: each curve an analytic expression found by 1-D symbolic regression."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from numbers import Integral, Real

import numpy as np
import pandas as pd
import sympy
from scipy.optimize import least_squares
from sklearn.utils._param_validation import Interval, StrOptions

from .._utils.randomness import seeds
from ..backends.symbolic.curves import VARIABLE, FittedCurve, SymbolicCurve, Template
from ..backends.symbolic.engines import (
    BINARY_OPERATORS,
    ENGINES,
    UNARY_OPERATORS,
    Candidate,
    make_engine,
)
from ..backends.symbolic.readable import Readability, nesting, tidy
from ..backends.symbolic.residuals import CurveResiduals
from ..exceptions import SkeletonError
from ..fitting.problem import FitResult, Problem
from ..skeleton.curves import ZeroCurve
from .backend import Backend
from .base import OUTPUT_ERROR_SETTINGS, RANDOM_STATES, RESAMPLING, CCRegressor, backend_of
from .poly import polynomial_stand_in

__all__ = ["SymbolicBackend", "SymbolicCCRegressor", "polish", "refit_params"]

MODEL_SELECTIONS = ("best", "accuracy")
#: a curve constrained monotone is checked on this many points over its domain
MONOTONE_POINTS = 4001
#: a numbers whose removal changes the loss by less than this (relative) is dropped
PRUNE_TOLERANCE = 1e-9


def select(candidates: list[tuple[Candidate, float]], rule: str,
           readability: Readability | None = None) -> int:
    """Index of the chosen candidate among ``(candidate, loss)`` pairs.

    Only the candidates whose expression ``readability`` allows take part
    (by default no function nested in another; when none is allowed, the
    least nested). Among them ``"accuracy"`` takes the lowest loss and
    ``"best"`` (PySR's rule) the candidate whose loss fell most steeply (in
    log) per unit of added complexity, of those within 1.5 times the lowest.
    Last, a candidate whose loss ties with the chosen one's (within
    ``readability.tolerance``) and reads simpler wins: catalogue-like shapes
    first, then fewer nodes (see ``sklearn_pycc.backends.symbolic.readable``).
    """
    readability = Readability() if readability is None else readability
    expressions = [candidate.expression for candidate, _ in candidates]
    losses = [loss for _, loss in candidates]
    allowed = readability.admissible(expressions)
    k = allowed[_by_rule([candidates[j] for j in allowed], rule)]
    return readability.settle(expressions, losses, k, allowed, VARIABLE,
                              sizes=[candidate.complexity for candidate, _ in candidates])


def _by_rule(candidates: list[tuple[Candidate, float]], rule: str) -> int:
    """Index of the candidate ``rule`` ("best" or "accuracy") chooses, caps aside."""
    losses = np.array([loss for _, loss in candidates])
    if rule == "accuracy":
        return int(np.argmin(losses))
    order = sorted(range(len(candidates)), key=lambda k: (candidates[k][0].complexity,
                                                          losses[k]))
    floor = float(np.min(losses))
    best, best_score = order[0], -np.inf
    previous_loss, previous_size = None, None
    tiny = np.finfo(float).tiny
    for k in order:
        size, loss = candidates[k][0].complexity, max(losses[k], tiny)
        if previous_loss is None:
            score = 0.0
        elif size == previous_size or loss >= previous_loss:
            continue
        else:
            score = -(np.log(loss) - np.log(previous_loss)) / (size - previous_size)
        if losses[k] <= 1.5 * floor + tiny and score > best_score:
            best, best_score = k, score
        previous_loss, previous_size = loss, size
    return best


def keeps_monotone(function, domain: tuple[float, float], kind: str | None) -> bool:
    """Whether ``function`` is ``kind`` ("increasing" / "decreasing") on ``domain``.

    Checked on :data:`MONOTONE_POINTS` evenly spread points (None: always True).
    """
    if kind is None:
        return True
    x = np.linspace(domain[0], domain[1], MONOTONE_POINTS)
    with np.errstate(all="ignore"):
        y = np.broadcast_to(np.asarray(function(x), dtype=float), x.shape)
    if not np.isfinite(y).all():
        return False
    step = np.diff(y) if kind == "increasing" else -np.diff(y)
    return bool(step.min() >= -1e-12 * max(float(np.max(np.abs(y))), 1e-300))


def _monotone_after(curves: dict, current: dict, problem: Problem) -> bool:
    """Whether every monotone curve is still monotone with its refined numbers."""
    return all(keeps_monotone(current[name], curve.domain, problem.monotone(name))
               for name, curve in curves.items())


def _bounds_of(problem: Problem, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    bounds = problem.bounds
    low = np.array([bounds.get(a, (-np.inf, np.inf))[0] for a in names], dtype=float)
    high = np.array([bounds.get(a, (-np.inf, np.inf))[1] for a in names], dtype=float)
    return low, high


def _binned(x: np.ndarray, y: np.ndarray, w: np.ndarray, n_bins: int):
    """Weighted means of ``x`` and ``y`` over equal-count bins of ``x``."""
    order = np.argsort(x, kind="stable")
    if x.size <= n_bins:
        return x[order], y[order]
    xb, yb = [], []
    for chunk in np.array_split(order, n_bins):
        weight = w[chunk]
        total = weight.sum()
        if total <= 0:
            continue
        xb.append(float(weight @ x[chunk] / total))
        yb.append(float(weight @ y[chunk] / total))
    return np.array(xb), np.array(yb)


def choose_candidate(found, template: Template, domain: tuple[float, float],
                     monotone: str | None, score, *, rule: str,
                     readability: Readability | None = None):
    """Turn a search's candidates into curves, score them, and choose one.

    Each candidate, its numbers that do nothing over ``domain`` dropped and
    the rest tidied (:func:`sklearn_pycc.backends.symbolic.readable.tidy`), becomes a curve under
    ``template`` (parity and point values) over ``domain``; a curve that
    breaks the ``monotone`` shape asked for is dropped. ``score(curve)``
    returns ``(loss, columns, payload)``, or None to drop the candidate: the
    loss decides (by :func:`select` with ``rule`` and ``readability``,
    judged on the curve's expression), the columns go into the Pareto table,
    the payload comes back with the choice. Shared by
    :class:`SymbolicCCRegressor` and :func:`~sklearn_pycc.to_symbolic`.

    Returns
    -------
    (curve, payload, table) or None
        The chosen curve, its payload and the table of every scored
        candidate (``complexity``, ``nesting``, ``search_loss``, the columns,
        ``expression``, ``chosen``), by complexity; None when no candidate
        scored.
    """
    scored = []
    for candidate in found:
        curve = FittedCurve(tidy(candidate.expression), template, domain)
        curve.drop_negligible()
        if not keeps_monotone(curve.function(), domain, monotone):
            continue
        outcome = score(curve)
        if outcome is not None:
            scored.append((replace(candidate, expression=curve.expression()), curve, *outcome))
    if not scored:
        return None
    k = select([(candidate, loss) for candidate, _, loss, *_ in scored], rule, readability)
    rows = [{"complexity": candidate.complexity, "nesting": nesting(candidate.expression),
             "search_loss": candidate.loss, **columns, "expression": candidate.expression,
             "chosen": j == k}
            for j, (candidate, _, _, columns, _) in enumerate(scored)]
    table = pd.DataFrame(rows).sort_values("complexity", ignore_index=True)
    _, curve, _, _, payload = scored[k]
    return curve, payload, table


class SymbolicBackend(Backend):
    """Curves as analytic expressions found by one-dimensional symbolic regression.

    The settings are :class:`SymbolicCCRegressor`'s, with the same meanings;
    the operators are checked here, against the engine's tables.
    """

    settings = ("engine", "binary_operators", "unary_operators", "maxsize", "max_nesting",
                "population_size", "generations", "max_iterations", "tol", "n_fit_points",
                "model_selection", "start_degree", "engine_options", "param_init",
                "random_state")

    def __init__(self, **settings) -> None:
        super().__init__(**settings)
        for name, table in (("binary_operators", BINARY_OPERATORS),
                            ("unary_operators", UNARY_OPERATORS)):
            operators = getattr(self, name)
            if isinstance(operators, str):
                raise ValueError(f"{name} must be a list of operators, not the string "
                                 f"{operators!r}")
            for k, op in enumerate(operators):
                if op not in table:
                    raise ValueError(f"{name}[{k}] is {op!r}, which is not one of "
                                     f"{sorted(table)}")

    # -- fitting -----------------------------------------------------------------
    def _start(self, problem: Problem) -> tuple[dict, dict]:
        """Curves and parameters to start from: a polynomial fit when possible."""
        init = problem.starting_values(self.param_init)
        low, high = _bounds_of(problem, problem.free_params)
        params = {a: float(init[a]) if a in init else float(np.clip(1.0, lo, hi))
                  for a, lo, hi in zip(problem.free_params, low, high)}
        functions = {f: ZeroCurve() for f in problem.skeleton.functions}
        if self.start_degree is None:
            return functions, params
        from .poly import PolyCCRegressor

        poly = backend_of(PolyCCRegressor(degree=self.start_degree, param_init=self.param_init))
        try:  # the polynomial backend, on the same problem
            start = poly.fit(problem)
        except SkeletonError:  # a curve enters nonlinearly: start from zero curves
            return functions, params
        functions.update(start.functions)
        params.update({a: float(start.params[a]) for a in problem.free_params
                       if a in start.params})
        return functions, params

    def fit(self, problem: Problem) -> FitResult:
        """Search each curve's expression in turn, then refine every number jointly."""
        engine = make_engine(self.engine)
        rng = seeds(self.random_state)
        residuals = CurveResiduals(problem)
        functions, params = self._start(problem)
        free = problem.free_functions
        curves: dict[str, FittedCurve] = {}
        pareto: dict[str, pd.DataFrame] = {}
        history = []
        loss = residuals.loss(functions, params)
        n_rounds = 0
        for n_rounds in range(1, int(self.max_iterations) + 1):  # noqa: B007
            before = loss
            for name in free:
                seed = next(rng)
                chosen = self._search_curve(engine, problem, residuals, name, functions,
                                            params=params, seed=seed, pareto=pareto)
                if chosen is None:
                    continue
                trial = {**functions, name: chosen.function()}
                trial_params = refit_params(residuals, problem, trial, params)
                trial_loss = residuals.loss(trial, trial_params)
                # the first round replaces the polynomial start whatever it costs
                if name not in curves or trial_loss <= loss:
                    curves[name] = chosen
                    functions, params, loss = trial, trial_params, trial_loss
            history.append(loss)
            if not np.isfinite(before) or before - loss <= self.tol * before:
                break
        missing = [name for name in free if name not in curves]
        if missing:
            raise ValueError(
                f"no expression was found for {missing[0]}: no sample of the data constrains "
                "it (its equations do not change when it does), or every candidate of the "
                "search gave a non-finite residual or broke its monotony")
        params = polish(residuals, problem, curves, functions, params)
        out = {name: ZeroCurve() for name in problem.zeroed}
        for name, curve in curves.items():
            out[name] = SymbolicCurve(curve.expression(), curve.domain)
        return FitResult(out, params, {"pareto_": pareto, "n_iterations_": n_rounds,
                                       "loss_history_": history})

    def _search_curve(self, engine, problem, residuals, name, functions, *, params, seed,
                      pareto: dict):
        x, target, weight = residuals.isolated(name, functions, params)
        if x.size == 0:
            return None
        xb, yb = _binned(x, target, weight, int(self.n_fit_points))
        parity = problem.parity(name)
        found = self.search(engine, xb, yb, parity, seed)
        template = Template(parity, problem.points(name))
        domain = (float(np.min(x)), float(np.max(x)))

        def score(curve):
            loss = residuals.loss({**functions, name: curve.function()}, params)
            return (loss, {"loss": loss}, None) if np.isfinite(loss) else None

        chosen = choose_candidate(found, template, domain, problem.monotone(name), score,
                                  rule=self.model_selection,
                                  readability=Readability(max_nesting=self.max_nesting))
        if chosen is None:
            return None
        curve, _, pareto[name] = chosen
        return curve

    def search(self, engine, x: np.ndarray, y: np.ndarray, parity: str | None,
               seed: int) -> list[Candidate]:
        """Candidates ``y ~ g(x)``, the data mirrored for an odd or even curve."""
        if parity == "odd":
            x, y = np.concatenate([x, -x]), np.concatenate([y, -y])
        elif parity == "even":
            x, y = np.concatenate([x, -x]), np.concatenate([y, y])
        return engine.search(x, y, binary=tuple(self.binary_operators),
                             unary=tuple(self.unary_operators), maxsize=self.maxsize,
                             population_size=self.population_size,
                             generations=self.generations,
                             options=dict(self.engine_options or {}), seed=seed)

    # -- results -------------------------------------------------------------------
    def attributes_of(self, functions: Mapping, variables: Mapping[str, str]) -> dict:
        """``expressions_``: each curve as a sympy expression of its argument."""
        expressions = {}
        for name, curve in functions.items():
            expression = curve.to_sympy(sympy.Symbol(variables[name]))
            expressions[name] = sympy.Integer(0) if expression is None else expression
        return {"expressions_": expressions}


def refit_params(residuals: CurveResiduals, problem: Problem, functions, params) -> dict:
    """The free parameters refitted by least squares with the curves held."""
    names = problem.free_params
    if not names:
        return dict(params)

    def fun(theta):
        r = residuals(functions, dict(zip(names, theta)))
        return np.where(np.isfinite(r), r, 1e150)

    low, high = _bounds_of(problem, names)
    start = np.clip([params[a] for a in names], low, high)
    result = least_squares(fun, start, bounds=(low, high))
    return dict(zip(names, (float(v) for v in np.clip(result.x, low, high))))

def polish(residuals: CurveResiduals, problem: Problem, curves: dict, functions,
            params, *, effort: int = 200) -> dict:
    """Refine every number of every expression and every parameter jointly.

    At most ``effort`` residual evaluations per number are spent.
    """
    names = problem.free_params
    sizes = [len(curve.values) for curve in curves.values()]
    theta0 = np.concatenate([[params[a] for a in names],
                             *[curve.values for curve in curves.values()]])
    if theta0.size == 0:
        return params

    def unpack(theta):
        values = dict(zip(names, theta[:len(names)]))
        current, offset = dict(functions), len(names)
        for (name, curve), size in zip(curves.items(), sizes):
            current[name] = curve.function(theta[offset:offset + size])
            offset += size
        return values, current

    def fun(theta):
        values, current = unpack(theta)
        r = residuals(current, values)
        return np.where(np.isfinite(r), r, 1e150)

    low, high = _bounds_of(problem, names)
    low = np.concatenate([low, np.full(theta0.size - len(names), -np.inf)])
    high = np.concatenate([high, np.full(theta0.size - len(names), np.inf)])
    theta0 = np.clip(theta0, low, high)
    start = fun(theta0)
    result = least_squares(fun, theta0, x_scale="jac", bounds=(low, high),
                           max_nfev=effort * theta0.size)
    theta = np.clip(result.x, low, high)
    if result.cost > 0.5 * float(start @ start) or not _monotone_after(
            curves, unpack(theta)[1], problem):
        theta = theta0
    # drop numbers that do nothing (an engine's 1e-9 offsets)
    base = float(np.mean(fun(theta) ** 2))
    for k in range(len(names), theta.size):
        if abs(theta[k]) < 1e-6:
            trial = theta.copy()
            trial[k] = 0.0
            if float(np.mean(fun(trial) ** 2)) <= base * (1 + PRUNE_TOLERANCE) + 1e-300:
                theta = trial
    offset = len(names)
    for (_, curve), size in zip(curves.items(), sizes):
        curve.values = theta[offset:offset + size]
        offset += size
    return {**params, **dict(zip(names, (float(v) for v in theta[:len(names)])))}


class SymbolicCCRegressor(CCRegressor):
    """Characteristic curves as analytic expressions (symbolic regression, SymbR-CC).

    Each unknown curve ``f_i`` is found by one-dimensional symbolic
    regression on its *isolated target*: the values it would need for the
    equations applying it to hold, given the other curves and parameters.
    The curves are updated in turn (back-fitting) until the equation
    residual stops falling, with the skeleton's parameters ``a_i`` refitted
    by least squares after every update; finally every number of every
    expression and every parameter are refined jointly. The search starts
    from a polynomial fit when the skeleton allows one.

    Constraints hold by construction: an odd curve is fitted on mirrored
    data and written ``(g(x) - g(-x))/2``, an even one ``(g(x) + g(-x))/2``,
    and point values are met by a polynomial correction of the curve's
    parity.

    Parameters
    ----------
    equations : list of str or Skeleton
        The structural skeleton. After ``fit``, ``model.equations()`` returns
        the fitted model written out (:meth:`~CCRegressor.equations_text`).
    constraints : list of str or dict, optional
        ``"f1 odd"``, ``"f1 even"``, ``"f2(0)=0"``, ...
    engine : {"operon", "pysr"}, default="operon"
        Symbolic regression engine: pyoperon (offline, the default) or PySR
        (needs Julia; imported only when chosen).
    binary_operators : sequence of str, default=("+", "-", "*")
        Among ``"+", "-", "*", "/", "^"``.
    unary_operators : sequence of str, default=("tanh", "sin", "cos")
        Among ``"tanh", "sin", "cos", "exp", "log", "sqrt", "abs", "square",
        "sinh", "cosh", "atan", "tan"``.
    maxsize : int, default=20
        Largest expression size (nodes) the engine considers.
    max_nesting : int or None, default=None
        Most elementary functions nested on one path of a chosen expression:
        1 allows ``tanh(a x)`` and ``exp(a x) cos(b x)`` but not
        ``sin(exp(a x))`` (integer powers do not count). Deeper candidates
        are passed over (when a search found nothing else, the least nested
        is taken). None: any, as the search finds them (a composition such as
        ``tanh(a tanh(b x))`` may be what follows a curve best with the
        operators given); the diagnosis's formula proposals use 1.
    population_size : int, default=500
        Population of the engine's search.
    generations : int, default=50
        Generations (operon) or iterations (PySR) per search.
    max_iterations : int, default=4
        Rounds of back-fitting over the curves.
    tol : float, default=1e-3
        Back-fitting stops when a round lowers the loss by less than this
        fraction.
    n_fit_points : int, default=200
        Each search sees the isolated target averaged over this many
        equal-count bins of the curve's argument (the paper's
        ``N_fit_points``).
    model_selection : {"best", "accuracy"}, default="best"
        How the expression is chosen from each search's Pareto front, among
        the candidates within ``max_nesting``: ``"accuracy"`` takes the lowest
        loss; ``"best"`` the steepest fall of the loss per unit of complexity
        among those within 1.5 times the lowest. Then a candidate whose loss
        is within 2 % of the chosen one's and that reads simpler takes its
        place: polynomials and ``tanh``, ``sign``, ``abs``, ``sqrt`` of
        ``a x`` before other shapes, then the fewest nodes.
    start_degree : int or None, default=7
        Degree of the polynomial fit that gives the first isolated targets;
        None starts from zero curves.
    engine_options : dict, optional
        Extra keyword arguments for the engine (pyoperon's
        ``SymbolicRegressor`` or ``PySRRegressor``).
    param_init : dict, optional
        Starting values of the parameters (1.0 otherwise).
    gauge, differentiation, smooth_states, equation_weights, quantities
        See :class:`CCRegressor`.
    n_bootstrap : int, default=0
        Refit on this many resamples of the record (blocks of consecutive
        samples within each experiment, or whole experiments when there are
        many; with unmeasured states, the fit's simulation errors drawn
        again in blocks, each resample refitted from the fit):
        ``params_std_``, ``params_interval``, the bands of ``cc_curves`` and
        ``simulate`` then come from their spread. 0 makes
        none (a fit without them has no uncertainty estimate); each refit
        searches its own expressions (with unmeasured states, a skeleton of
        parameters only, each refit polishes them from the fit).
    n_jobs : int or None, default=None
        Processes for the refits on resamples (joblib; None is one, -1
        every core). The result does not depend on it.
    verbose : int, default=0
        1: a fit says each stage as it starts (with the seconds since it
        began), the filter's search shows its passes and the refits on
        resamples their count.
    random_state : int, RandomState or None
        Seeds every search.

    Attributes
    ----------
    expressions_ : dict of str -> sympy.Expr
        Each curve in its argument (``x2`` for ``f1(x2)``; ``u`` when the
        argument is not a single variable).
    pareto_ : dict of str -> DataFrame
        The last search's candidates per curve: ``complexity``, ``nesting``,
        ``search_loss`` (against the isolated target), ``loss`` (the
        model's equation loss with the candidate in place), ``expression``
        and ``chosen``.
    n_iterations_ : int
        Back-fitting rounds run.
    loss_history_ : list of float
        Equation loss after each round.
    bootstrap_params_ : DataFrame
        Only with ``n_bootstrap``: the free parameters of each refit on a
        resample, one row per refit (``bootstrap_`` holds their curves too,
        and ``bootstrap_method_`` says how the resamples were drawn).
    """

    _parameter_constraints: dict = {
        **{k: v for k, v in CCRegressor._parameter_constraints.items()
         if k not in OUTPUT_ERROR_SETTINGS},
        "engine": [StrOptions(set(ENGINES))],
        "binary_operators": [list, tuple],
        "unary_operators": [list, tuple],
        "maxsize": [Interval(Integral, 1, None, closed="left")],
        "max_nesting": [Interval(Integral, 0, None, closed="left"), None],
        "population_size": [Interval(Integral, 1, None, closed="left")],
        "generations": [Interval(Integral, 1, None, closed="left")],
        "max_iterations": [Interval(Integral, 1, None, closed="left")],
        "tol": [Interval(Real, 0, None, closed="left")],
        "n_fit_points": [Interval(Integral, 1, None, closed="left")],
        "model_selection": [StrOptions(set(MODEL_SELECTIONS))],
        "start_degree": [Interval(Integral, 0, None, closed="left"), None],
        "engine_options": [dict, None],
        "param_init": [dict, None],
        "random_state": RANDOM_STATES,
        "verbose": ["verbose"],
        **RESAMPLING,
    }

    def __init__(self, *, equations=None, constraints=None, engine: str = "operon",
                 binary_operators: Sequence[str] = ("+", "-", "*"),
                 unary_operators: Sequence[str] = ("tanh", "sin", "cos"),
                 maxsize: int = 20, max_nesting: int | None = None,
                 population_size: int = 500, generations: int = 50,
                 max_iterations: int = 4, tol: float = 1e-3, n_fit_points: int = 200,
                 model_selection: str = "best", start_degree: int | None = 7,
                 engine_options: Mapping | None = None, param_init: Mapping | None = None,
                 gauge: str = "auto", differentiation="auto", smooth_states: bool = True,
                 equation_weights=None, random_state=None, n_bootstrap: int = 0,
                 n_jobs: int | None = None,
                 quantities: Mapping[str, str] | None = None, verbose: int = 0) -> None:
        super().__init__(equations=equations, constraints=constraints, gauge=gauge,
                         differentiation=differentiation, smooth_states=smooth_states,
                         equation_weights=equation_weights, quantities=quantities)
        self.engine = engine
        self.binary_operators = binary_operators
        self.unary_operators = unary_operators
        self.maxsize = maxsize
        self.max_nesting = max_nesting
        self.population_size = population_size
        self.generations = generations
        self.max_iterations = max_iterations
        self.tol = tol
        self.n_fit_points = n_fit_points
        self.model_selection = model_selection
        self.start_degree = start_degree
        self.engine_options = engine_options
        self.param_init = param_init
        self.random_state = random_state
        self.verbose = verbose
        self.n_bootstrap = n_bootstrap
        self.n_jobs = n_jobs

    def _delay_searcher(self) -> CCRegressor:
        # the delays' many fits with polynomial curves: seconds, where these take minutes
        return polynomial_stand_in(self)

    def _make_backend(self) -> SymbolicBackend:
        return SymbolicBackend(**self._backend_settings(SymbolicBackend))
