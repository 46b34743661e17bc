"""Turn an estimator's hyperparameters into a checked, gauged fitting problem."""

from __future__ import annotations

import copy
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from ..exceptions import GaugeWarning, IdentifiabilityError, SkeletonError
from ..measurements.columns import FitData
from ..skeleton import Skeleton
from ..skeleton.compiler import compile_expression
from ..skeleton.constraints import Constraint, parse_constraints
from ..skeleton.equations import Equation, unknown_names
from ..skeleton.nodes import Node, Symbol, Unknown, walk

__all__ = ["GAUGES", "FitResult", "Problem", "active_residuals", "build_skeleton",
           "gauge_skeleton", "parity_of", "points_of", "residual_scale"]

GAUGES = ("auto", "warn", "raise")


def _freeze_constraints(constraints) -> tuple:
    return parse_constraints(constraints)


@lru_cache(maxsize=256)
def _cached_skeleton(equations: tuple, constraints: tuple) -> Skeleton:
    return Skeleton(list(equations), list(constraints))


def build_skeleton(equations, constraints) -> Skeleton:
    """Parse (with a cache) the ``equations`` and ``constraints`` hyperparameters.

    The skeleton returned is the caller's own: neither the user's
    :class:`Skeleton` nor the cache's copy is shared with a fitted model.
    """
    if equations is None:
        raise SkeletonError(
            "no skeleton given: pass equations=[...], e.g. "
            "['x1_dot = x2', 'x2_dot = F_ext - f1(x2) - f2(x1)']")
    if isinstance(equations, Skeleton):
        if constraints is None:
            return copy.deepcopy(equations)
        return Skeleton(equations, constraints)
    if isinstance(equations, str):
        raise SkeletonError(
            "equations must be a list of strings, one per state, not a single string")
    try:
        key = tuple(equations)
        hash(key)
    except TypeError:
        return Skeleton(equations, constraints)
    return copy.deepcopy(_cached_skeleton(key, _freeze_constraints(constraints)))


@dataclass
class FitResult:
    """What a backend's fit hands back; the base class alone stores it.

    Attributes
    ----------
    functions : dict
        Every curve of the skeleton by name: a callable on numpy arrays
        (``ZeroCurve`` for curves the gauge pinned to zero).
    params : dict
        The fitted free parameters by name.
    attributes : dict
        The backend's own fitted attributes by name, each ending in ``_``
        (``coefficients_``, ``history_``, ...).
    stage : object, optional
        What an output-error stage needs to continue from this fit (the
        trained networks, say); never stored on the estimator.
    """

    functions: dict
    params: dict
    attributes: dict = field(default_factory=dict)
    stage: object = None

    def __post_init__(self) -> None:
        # the types are checked where the estimator receives the result, naming the backend
        names = self.attributes if isinstance(self.attributes, Mapping) else ()
        odd = [name for name in names if not str(name).endswith("_")]
        if odd:
            raise ValueError(f"fitted attributes end in '_'; got {odd[0]!r}")


@lru_cache(maxsize=256)
def _cached_report(skeleton: Skeleton):
    return skeleton.identifiability()


@dataclass
class Problem:
    """Everything a backend needs to fit the unknowns of a skeleton.

    Attributes
    ----------
    skeleton : Skeleton
        The user's skeleton with its constraints.
    constraints : dict
        Curve -> effective constraints (the user's plus the gauge's point values).
    fixed_params : dict
        Parameters pinned by the gauge, with their values.
    zeroed : set
        Curves pinned to zero by the gauge.
    data : FitData
        Columns of X plus the measured derivatives.
    y : ndarray
        Measured derivatives, ``(n_samples, n_states)`` in equation order.
    experiments : list of Experiment or None
        The data's experiments with their times, when derivatives were
        estimated or the fit is by simulation.
    measured, smoothed : dict
        Measured states as given, and every state's smoothed or
        reconstructed values (the same as measured when ``y`` was given).
    signals : dict
        The inputs as measured, to drive simulations (``data`` holds them
        as the equation fit sees them, filtered when the differentiation
        filtered the states).
    fit_mode : {"equation", "simulation"}
        The mode of this fit: ``"simulation"`` when an output-error stage
        follows the equation fit.
    equation_weights : tuple of float or None
        The user's weight of each equation, in the order given (None: 1 for
        each); it multiplies the equation's residual after its own scaling.
    rows : ndarray of int or None
        Row of the record (of ``measured``, ``smoothed``, ``signals`` and
        the experiments' rows) of each row of ``data``; None when they are
        the same rows.
    covariance : bool
        Whether a backend should estimate the covariance of its estimate
        (not for the refits on resamples).
    hidden : tuple of str
        Unmeasured states: no column of the record holds them; they are
        fitted by output error (``fit_mode`` is then "simulation").
    input_hold : {"bandlimited", "foh", "zoh"}
        How an output-error stage reads the inputs between samples.
    hold_chosen : bool
        Whether the output-error fit with unmeasured states chooses the
        hold itself (the estimator's ``input_hold="auto"``), starting from
        ``input_hold``.
    observed : dict
        Static outputs (``y = ...``: what a sensor reads) as measured on
        every row of the record, compared with the simulated ones when
        states are unmeasured.
    whitening : dict or None
        Measured state -> the taps of the filter that whitens its output
        errors (the estimator's ``noise_model``); None for white noise.
    process_noise : dict or None
        The estimator's ``process_noise``: state -> a held intensity or the
        name of a fitted one (:func:`~sklearn_pycc.fitting.filter.stage.noisy_states`).
    measurement_noise : dict or None
        The estimator's ``measurement_noise``: measured state -> its held
        standard deviation (the filter fits the others').
    initial_state : dict
        State -> (mean, variance) of its value at the start of every
        experiment (:func:`~sklearn_pycc.fitting.initial_state.check_initial_state`):
        the filter starts there (output-error fits do not read it).
    missing : dict
        Measured state -> a mask of the record's rows where its sample is
        missing (the filter updates without it; the record's other
        readers see the straight line across the gap).
    """

    skeleton: Skeleton
    constraints: dict[str, list[Constraint]]
    fixed_params: dict[str, float]
    zeroed: set[str]
    data: FitData
    y: np.ndarray
    gauge: dict[str, str] = field(default_factory=dict)
    #: experiments with their times (when known); measured and smoothed states by name
    experiments: list | None = None
    measured: dict[str, np.ndarray] = field(default_factory=dict)
    smoothed: dict[str, np.ndarray] = field(default_factory=dict)
    signals: dict[str, np.ndarray] = field(default_factory=dict)
    fit_mode: str = "equation"
    equation_weights: tuple | None = None
    rows: np.ndarray | None = None
    covariance: bool = True
    hidden: tuple = ()
    input_hold: str = "bandlimited"
    hold_chosen: bool = False
    observed: dict[str, np.ndarray] = field(default_factory=dict)
    whitening: dict[str, np.ndarray] | None = None
    process_noise: dict | None = None
    measurement_noise: dict | None = None
    initial_state: dict = field(default_factory=dict)
    missing: dict = field(default_factory=dict)

    @property
    def equations(self) -> list[Equation]:
        """Every equation to make hold on the data, in the order given.

        The differential equations and the algebraic ones (static,
        implicit, conserved quantities); :attr:`dynamic` are those a
        simulation integrates.
        """
        return self.skeleton.residual_equations

    @property
    def dynamic(self) -> list[Equation]:
        """The differential equations."""
        return self.skeleton.parsed

    def weight(self, index: int) -> float:
        """The user's weight of ``equations[index]`` (1 by default)."""
        if self.equation_weights is None:
            return 1.0
        return float(self.equation_weights[index])

    @property
    def free_functions(self) -> list[str]:
        """Curves to fit."""
        return [f for f in self.skeleton.functions if f not in self.zeroed]

    @property
    def free_params(self) -> list[str]:
        """Parameters to fit."""
        return [a for a in self.skeleton.params if a not in self.fixed_params]

    def check_enough_rows(self) -> None:
        """Refuse data with fewer residual values than scalar unknowns.

        Every free parameter and every free curve needs at least one number
        of its own; fewer residual values (samples times equations with
        something to fit) leave the fit undetermined whatever the backend.
        """
        unknowns = [*self.free_params, *self.free_functions]
        n = self.data.n_samples
        values = n * len(self.active)
        if values < len(unknowns):
            raise ValueError(
                f"n_samples = {n}: {values} residual value(s) for {len(unknowns)} unknowns "
                f"({', '.join(unknowns)}), so the fit would be undetermined; give at least "
                f"{-(-len(unknowns) // max(len(self.active), 1))} samples")

    @property
    def active(self) -> list[int]:
        """Indices of the equations with a free curve or parameter (the others fit nothing)."""
        free = set(self.free_functions) | set(self.free_params)
        out = []
        for i, eq in enumerate(self.equations):
            curves, params = unknown_names(eq.residual)
            if (curves | params) & free:
                out.append(i)
        return out

    def environment(self) -> tuple[dict[str, int], list[np.ndarray]]:
        """``(slots, columns)`` of the data for :func:`compile_expression` closures."""
        names = list(self.data.columns)
        return {name: i for i, name in enumerate(names)}, [self.data[n] for n in names]

    def residual_values(self, params, functions) -> np.ndarray:
        """The fitted residual of each equation with something to fit, on the data.

        ``(n_samples, len(active))``, unweighted; ``params`` are the free
        parameters (the pinned ones are added).
        """
        slots, env = self.environment()
        values = {**self.fixed_params, **params}
        n = self.data.n_samples
        columns = []
        for i in self.active:
            with np.errstate(all="ignore"):
                value = compile_expression(self.equations[i].fit_residual, slots, values,
                                           functions)(env)
            columns.append(np.broadcast_to(np.asarray(value, dtype=float), (n,)))
        return np.column_stack(columns) if columns else np.zeros((n, 0))

    def residual_weights(self) -> np.ndarray:
        """The weight of each column of :meth:`residual_values`.

        The user's weight of the equation over the size of its residual on
        the data (:func:`residual_scale`): a least-squares fit minimises the
        sum of squares of ``residual_values(...) * residual_weights()``.
        """
        return np.array([self.weight(i) / residual_scale(self, self.equations[i])
                         for i in self.active])

    def argument_values(self, function: str, params, functions=None) -> np.ndarray:
        """Finite values of every argument of ``function`` on the data.

        Arguments that apply a curve missing from ``functions``, or read a
        state the data do not hold (an unmeasured one), are skipped.
        """
        slots, env = self.environment()
        functions = functions or {}
        chunks = []
        for arg in self.arguments(function):
            if any((isinstance(node, Unknown) and node.name not in functions)
                   or (isinstance(node, Symbol) and node.name in self.hidden)
                   for node in walk(arg)):
                continue
            with np.errstate(all="ignore"):
                value = compile_expression(arg, slots, params, functions)(env)
            value = np.broadcast_to(np.asarray(value, dtype=float), (self.data.n_samples,))
            chunks.append(value[np.isfinite(value)])
        return np.concatenate(chunks) if chunks else np.zeros(0)

    def arguments(self, function: str) -> list[Node]:
        """Every argument expression ``function`` is applied to."""
        return self.skeleton.curve_arguments(function)

    def starting_values(self, param_init) -> dict[str, float]:
        """The ``param_init`` hyperparameter, checked against the skeleton's parameters."""
        # a delay is searched over a grid, and is a number here already
        init = {k: v for k, v in dict(param_init or {}).items()
                if k not in self.skeleton.delays_given}
        params = self.skeleton.params
        bad = [k for k in init if k not in params]
        if bad:
            raise ValueError(f"param_init names {bad[0]!r}, which is not a parameter of the "
                             f"skeleton ({', '.join(params) or 'none'})")
        bounds = self.skeleton.bounds
        for name, value in init.items():
            low, high = bounds.get(name, (-np.inf, np.inf))
            if not low <= value <= high:
                raise ValueError(f"param_init gives {name} = {value!r}, outside its bounds "
                                 f"[{low:g}, {high:g}]")
        return init

    @property
    def bounds(self) -> dict[str, tuple[float, float]]:
        """Free parameter -> ``(low, high)``: the skeleton's bounds."""
        return {a: b for a, b in self.skeleton.bounds.items() if a not in self.fixed_params}

    def monotone(self, function: str) -> str | None:
        """``"increasing"``, ``"decreasing"`` or None."""
        return self.skeleton.monotone(function)

    def parity(self, function: str) -> str | None:
        """``"odd"``, ``"even"`` or None."""
        return parity_of(self.constraints[function])

    def points(self, function: str) -> list[tuple[float, float]]:
        """Point values ``(at, value)`` the curve must pass through."""
        return points_of(self.constraints[function])


def thinned(problem: Problem, rows: int) -> Problem:
    """``problem`` on every k-th row of its data, k the least that leaves at most ``rows``.

    For ranking starting values cheaply on a long record; the experiments,
    measured states and signals (what a simulation needs) are left out.
    """
    n = problem.data.n_samples
    step = -(-n // rows)
    keep = np.arange(0, n, step)

    def cut(values):
        return values[keep] if values is not None and np.ndim(values) and len(values) == n \
            else values

    data = FitData({name: cut(v) for name, v in problem.data.columns.items()}, len(keep),
                   cut(problem.data.trajectory))
    return replace(problem, data=data, y=cut(problem.y), experiments=None, measured={},
                   smoothed={}, signals={}, observed={}, rows=None, covariance=False)


def parity_of(constraints: list[Constraint]) -> str | None:
    """``"odd"``, ``"even"`` or None, from one curve's constraints."""
    kinds = {c.kind for c in constraints}
    return "odd" if "odd" in kinds else "even" if "even" in kinds else None


def points_of(constraints: list[Constraint]) -> list[tuple[float, float]]:
    """Point values ``(at, value)`` among one curve's constraints."""
    return [(c.at, c.value) for c in constraints if c.kind == "value"]


#: a skeleton with more curves than this is warned about: its analysis grows like their square
MANY_CURVES = 200


def gauge_skeleton(skeleton: Skeleton, gauge: str):
    """Apply the gauge policy; return ``(constraints, fixed_params, zeroed, gauge_dict)``."""
    if gauge not in GAUGES:
        raise ValueError(f"gauge must be one of {GAUGES}, got {gauge!r}")
    constraints = {f: list(skeleton.constraints_of(f)) for f in skeleton.functions}
    fixed: dict[str, float] = {}
    zeroed: set[str] = set()
    if len(skeleton.functions) > MANY_CURVES:
        warnings.warn(
            f"the skeleton has {len(skeleton.functions)} curves: its identifiability analysis "
            "grows like the square of that count (200 curves take a few seconds on one core, "
            "400 about 10 s); fewer curves, or shared ones, fit far faster",
            UserWarning, stacklevel=4)
    try:
        report = _cached_report(skeleton)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as error:
        # the analysis is advice: a skeleton it cannot probe is still fitted
        warnings.warn(f"the identifiability analysis could not probe this skeleton "
                      f"({type(error).__name__}: {error}); it is fitted without a gauge",
                      GaugeWarning, stacklevel=4)
        return constraints, fixed, zeroed, {}
    if report.identifiable:
        return constraints, fixed, zeroed, {}
    if gauge == "raise":
        raise IdentifiabilityError(
            f"{report}\nAdd the constraints above, or use gauge='auto' to pin them automatically.")
    if gauge == "warn":
        warnings.warn(f"{report}\nFitting without pinning (gauge='warn').", GaugeWarning,
                      stacklevel=4)
        return constraints, fixed, zeroed, {}
    for fix in report.fixes:
        if fix.kind == "curve_value":
            constraints[fix.name].append(fix.as_constraint())
        elif fix.kind == "curve_zero":
            zeroed.add(fix.name)
        else:
            fixed[fix.name] = fix.value
    gauge = report.gauge()
    for name, value in list(fixed.items()):
        low, high = skeleton.bounds.get(name, (-np.inf, np.inf))
        if not low <= value <= high and low <= -value <= high:
            # a scale's sign is the gauge's to choose as well: the one its bounds admit
            why = gauge.pop(f"{name}={value:g}", "")
            fixed[name] = value = -value
            gauge[f"{name}={value:g}"] = why + " Its bounds admit the negative sign only."
        if not low <= value <= high:
            raise IdentifiabilityError(
                f"the gauge pins {name} = {value:g} to make the skeleton identifiable, outside "
                f"its bounds [{low:g}, {high:g}]: pin another scale with a constraint, or use "
                "bounds that admit it")
    return constraints, fixed, zeroed, gauge


def residual_scale(problem: Problem, eq: Equation) -> float:
    """The size of an equation's residual on the data, to weight it by.

    The root mean square of its measured left side (``x2_dot``, ``F_ext``);
    for a left side that is constant or holds unknowns (``0 = x2 x2_dot +
    f2(x1) x2``), and for an equation fitted with its denominator multiplied
    out (:attr:`~sklearn_pycc.skeleton.equations.Equation.fit_residual`),
    that of the fitted residual with the free curves and parameters set to
    zero (``x2 x2_dot``). 1 when neither has a finite, nonzero size.
    """
    slots, env = problem.environment()
    fixed = problem.fixed_params
    n = problem.data.n_samples
    lhs_curves, lhs_params = unknown_names(eq.lhs)
    candidates = []
    as_written = eq.fit_residual == eq.residual
    if as_written and not lhs_curves and not (lhs_params - set(fixed)):
        candidates.append(compile_expression(eq.lhs, slots, fixed))
    candidates.append(lambda _: measured_part(problem, eq))
    for fn in candidates:
        try:
            with np.errstate(all="ignore"):
                value = np.broadcast_to(np.asarray(fn(env), dtype=float), (n,))
        except KeyError:  # a column the data do not hold
            continue
        rms = float(np.sqrt(np.mean(value * value)))
        if np.isfinite(rms) and rms > 0:
            return rms
    return 1.0


def measured_part(problem: Problem, eq) -> np.ndarray:
    """An equation's fitted residual with its free curves and parameters at zero, on the data.

    What the data alone put into the equation (``x2 x2_dot`` of ``0 = x2
    x2_dot + f2(x1) x2``, ``x1`` of ``0 = x1 - a1``). Raises ``KeyError``
    for a column the data do not hold.
    """
    slots, env = problem.environment()
    zero = {a: 0.0 for a in problem.free_params}
    curves = {f: _zero_curve for f in problem.skeleton.functions}
    with np.errstate(all="ignore"):
        value = compile_expression(eq.fit_residual, slots, {**zero, **problem.fixed_params},
                                   curves)(env)
    return np.broadcast_to(np.asarray(value, dtype=float), (problem.data.n_samples,))


def _zero_curve(u):
    return np.zeros_like(np.asarray(u, dtype=float))


def active_residuals(problem: Problem) -> tuple[list[Node], list[float]]:
    """Residuals of the equations with something to fit, and their weights.

    Each residual is divided by its size on the data
    (:func:`residual_scale`) and multiplied by the user's weight.
    """
    residuals = [problem.equations[i].fit_residual for i in problem.active]
    return residuals, [float(w) for w in problem.residual_weights()]
