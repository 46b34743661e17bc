"""Curves through unmeasured states: each written out as a polynomial of numbered coefficients.

A skeleton with unmeasured states is fitted by output error over its
parameters (:mod:`.hidden_fit`). A curve there (the outflow of a tank
nobody measures) has no measured argument to be fitted to, so it is written
out: a polynomial over the range its argument runs, whose coefficients are
parameters of a :class:`CurvesWrittenOut` skeleton, fitted by that same
path. The curve's constraints are kept by its form (:func:`curve_form`): an
odd or even curve has odd or even powers only; a monotone one is a sum of
Bernstein tails whose coefficients have one sign, so it is monotone over
that range; a point value holds exactly.

:func:`fit_hidden_curves` fits twice: every curve first a straight line (its
law), from the usual starts; then of the backend's degree, started on those
lines, over the range the first fit's states ran.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.polynomial import Polynomial
from scipy.linalg import null_space
from scipy.optimize import lsq_linear
from scipy.special import comb

from ...skeleton.compiler import compile_expression
from ...skeleton.constraints import Constraint
from ...skeleton.nodes import Symbol, Unknown, walk
from ...skeleton.printer import to_text
from ...skeleton.skeleton import Skeleton
from ..numbers import Numbers
from ..problem import FitResult, Problem
from .hidden import scale_family, scaled_start, starting_params
from .whole_record import WholeRecord

__all__ = ["CurveForm", "CurvesWrittenOut", "WrittenCurve", "curve_form", "fit_hidden_curves",
           "hidden_level_gauge", "line_laws", "written_numbers"]

#: ``make_curve(series, center, half, domain)``: the backend's curve for a power series in
#: ``u = (x - center) / half`` fitted over ``domain``
MakeCurve = Callable[[np.ndarray, float, float, tuple[float, float]], Callable]

#: share of the range a curve's argument ran in the first fit added at each end of the
#: second fit's range (the fit moves the unmeasured states a little)
MARGIN = 0.1


@dataclass(frozen=True)
class CurveForm:
    """One curve written as a power series in ``u = (x - center) / half``, linear in its numbers.

    Attributes
    ----------
    name : str
        The curve (``f1``).
    center, half : float
        The argument's map to ``u``.
    domain : tuple of float
        The range of the argument the form was laid over.
    constant : ndarray
        The series when every number is zero (a point value's part).
    directions : ndarray of shape (len(constant), len(names))
        How each number moves the series.
    names : list of str
        The numbers' names as parameters, ``f1:1``, ``f1:2``, ...
    sign : float or None
        +1 where every number is at least 0 (the curve increases), -1 where
        at most 0, None where free.
    """

    name: str
    center: float
    half: float
    domain: tuple[float, float]
    constant: np.ndarray
    directions: np.ndarray
    names: list[str]
    sign: float | None

    def series(self, values: Mapping[str, float]) -> np.ndarray:
        """The power series in ``u`` for the numbers in ``values``."""
        theta = np.array([values[n] for n in self.names], dtype=float)
        return self.constant + self.directions @ theta

    def bounds(self) -> dict[str, tuple[float, float]]:
        """Each number's bounds (those of a monotone curve's tails)."""
        if self.sign is None:
            return {}
        return {n: (0.0, np.inf) if self.sign > 0 else (-np.inf, 0.0) for n in self.names}

    def numbers_for(self, curve: Callable, x: np.ndarray) -> dict[str, float]:
        """The numbers whose series follows ``curve`` best at ``x``, within the bounds."""
        u = (np.asarray(x, dtype=float) - self.center) / self.half
        vander = np.vander(u, len(self.constant), increasing=True)
        target = np.asarray(curve(x), dtype=float) - vander @ self.constant
        A = vander @ self.directions
        low = np.full(len(self.names), -np.inf)
        high = np.full(len(self.names), np.inf)
        if self.sign is not None:
            (low if self.sign > 0 else high)[:] = 0.0
        theta = lsq_linear(A, target, bounds=(low, high)).x if len(self.names) else []
        return dict(zip(self.names, (float(v) for v in theta)))


@dataclass(frozen=True)
class WrittenCurve:
    """A fitted curve through unmeasured states: its form and its numbers.

    Attributes
    ----------
    form : CurveForm
        The polynomial form it was written as.
    numbers : dict
        The fitted value of each of the form's numbers.
    """

    form: CurveForm
    numbers: dict

    @property
    def domain(self) -> tuple[float, float]:
        """The range the form was laid over."""
        return self.form.domain

    @property
    def degree(self) -> int:
        """The polynomial's degree."""
        return len(self.form.constant) - 1


def _tails(degree: int) -> np.ndarray:
    """The constant and the Bernstein tails ``S_i = sum_{j >= i} B_j`` of ``degree`` over ``u``.

    Columns are power series in ``u`` on ``[-1, 1]`` (``t = (u + 1) / 2``);
    a sum of tails with non-negative coefficients does not decrease there.
    """
    t = Polynomial([0.5, 0.5])
    bernstein = [comb(degree, j) * t**j * (1 - t) ** (degree - j) for j in range(degree + 1)]
    columns = [Polynomial([1.0])]
    for i in range(1, degree + 1):
        columns.append(sum(bernstein[i:], Polynomial([0.0])))
    out = np.zeros((degree + 1, degree + 1))
    for k, column in enumerate(columns):
        coef = column.coef
        out[: len(coef), k] = coef
    return out


def curve_form(name: str, degree: int, domain: tuple[float, float], *,
               parity: str | None = None, points: Sequence[tuple[float, float]] = (),
               monotone: str | None = None) -> CurveForm:
    """The polynomial form of the curve ``name`` over ``domain``, its constraints built in.

    Odd and even curves are series of odd or even powers of ``x / half``; a
    monotone odd curve has numbers of one sign (each odd power is monotone).
    Any other curve is a constant plus Bernstein tails over ``domain``,
    monotone where the tails' numbers have one sign. One point value is
    held by the constant; more by the null space of their rows (and a
    monotone curve with several is then not held monotone: a warning says so).
    """
    lo, hi = (float(v) for v in domain)
    if parity is None:
        center, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        basis = _tails(degree)
    else:
        center, half = 0.0, max(abs(lo), abs(hi))
        kept = [k for k in range(degree + 1) if k % 2 == (1 if parity == "odd" else 0)]
        basis = np.eye(degree + 1)[:, kept]
    if not (np.isfinite(half) and half > 0):
        half = max(1.0, abs(center))
    sign = {"increasing": 1.0, "decreasing": -1.0}.get(monotone or "")
    if parity == "even":
        sign = None
    constant = np.zeros(degree + 1)
    directions = basis
    if points:
        at = np.array([(p - center) / half for p, _ in points])
        value = np.array([v for _, v in points], dtype=float)
        rows = np.vander(at, degree + 1, increasing=True) @ basis
        if parity is None and len(points) == 1:  # the constant takes the value
            constant = value[0] * basis[:, 0]
            directions = basis[:, 1:] - np.outer(basis[:, 0], rows[0, 1:])
        else:
            particular = np.linalg.lstsq(rows, value, rcond=None)[0]
            free = null_space(rows)
            constant, directions = basis @ particular, basis @ free
            if sign is not None and parity is None:
                warnings.warn(f"{name} is {monotone} with {len(points)} point values: written "
                              "out through an unmeasured state it is held to those values, "
                              "and its monotony is not enforced", UserWarning, stacklevel=3)
                sign = None
    names = [f"{name}:{k + 1}" for k in range(directions.shape[1])]
    return CurveForm(name, float(center), float(half), (lo, hi), constant, directions, names,
                     sign)


class CurvesWrittenOut(Skeleton):
    """A skeleton whose curves are polynomials of numbered parameters (:class:`CurveForm`).

    It has the original's equations, states and limits; its parameters are
    the original's and every form's numbers; it has no curves of its own
    (those the gauge pinned to zero stay as given). Compiling builds each
    curve by ``make_curve`` and compiles the original with them.
    """

    def __init__(self, skeleton: Skeleton, forms: Mapping[str, CurveForm],
                 make_curve: MakeCurve, held: Mapping[str, Callable]) -> None:
        self.__dict__.update(vars(skeleton))
        self.original = skeleton
        self.forms = dict(forms)
        self.make_curve = make_curve
        self.held = dict(held)
        self.functions = []
        self.params = [*skeleton.params, *(n for f in self.forms.values() for n in f.names)]

    @property
    def bounds(self) -> dict[str, tuple[float, float]]:
        """The original's bounds and those of the monotone forms' numbers."""
        out = dict(self.original.bounds)
        for form in self.forms.values():
            out.update(form.bounds())
        return out

    def curves(self, params: Mapping[str, float]) -> dict[str, Callable]:
        """Every curve of the original for the numbers in ``params``."""
        out = dict(self.held)
        for name, form in self.forms.items():
            out[name] = self.make_curve(form.series(params), form.center, form.half,
                                        form.domain)
        return out

    def compile(self, functions=None, params=None):
        """The original compiled with the curves ``params`` make (``functions`` unused)."""
        params = dict(params or {})
        own = {a: v for a, v in params.items() if a in self.original.params}
        return self.original.compile(self.curves(params), own)

    def __eq__(self, other: object) -> bool:
        return self is other

    def __hash__(self) -> int:
        return id(self)


def hidden_level_gauge(skeleton: Skeleton, hidden: Sequence[str], constraints: Mapping,
                       gauge: Mapping[str, str]) -> tuple[dict, dict]:
    """Pin the level of an unmeasured state seen only through curves of it.

    Where every use of an unmeasured state is as the whole argument of a
    curve (``f1(x1)``), a shift of the state with every such curve shifted
    alike fits any record as well: its level is not seen. Unless one of
    those curves has a point value or is odd already, the first is pinned to
    pass through zero at zero (a tank's outflow when it is empty). Returns
    the curves' constraints and the gauge, each with that pin added.
    """
    constraints = {f: list(c) for f, c in constraints.items()}
    gauge = dict(gauge)
    for state in hidden:
        uses, curves = 0, []  # every use of the state, and the curves applied to it alone
        for eq in [*skeleton.parsed, *skeleton.algebraic]:
            for node in walk(eq.rhs):
                if isinstance(node, Symbol) and node.name == state:
                    uses += 1
                elif (isinstance(node, Unknown) and isinstance(node.arg, Symbol)
                      and node.arg.name == state):
                    curves.append(node.name)
        if not curves or uses > len(curves):
            continue
        curves = list(dict.fromkeys(curves))
        if any(c.kind in ("value", "odd") for f in curves for c in constraints.get(f, [])):
            continue
        pinned = curves[0]
        constraints.setdefault(pinned, []).append(Constraint(pinned, "value", 0.0, 0.0))
        gauge[f"{pinned}(0)=0"] = (
            f"{state} is not measured and enters only through {', '.join(curves)}: a shift "
            f"of {state} with those curves shifted alike fits the record as well, so its "
            f"level is pinned by {pinned}(0) = 0.")
    return constraints, gauge


@dataclass(frozen=True)
class LineLaw:
    """A curve's straight line (a parabola in ``x^2`` where it is even), as parameters.

    ``level`` names the constant (None where a point value or oddness
    holds it); ``slope`` the slope, of the sign a monotone curve has.
    """

    name: str
    slope: str
    level: str | None
    at: float = 0.0
    value: float = 0.0
    square: bool = False

    def text(self, argument: str) -> str:
        """The law applied to ``argument`` (its text)."""
        x = f"({argument})^2" if self.square else f"({argument})"
        if self.level is not None:
            return f"({self.level} + {self.slope}*{x})"
        at = self.at ** 2 if self.square else self.at
        return f"({self.value!r} + {self.slope}*({x} - ({at!r})))"

    def __call__(self, x: np.ndarray, params: Mapping[str, float]) -> np.ndarray:
        """The law at ``x`` for the parameters ``params``."""
        x = np.asarray(x, dtype=float)
        g = x**2 if self.square else x
        if self.level is not None:
            return params[self.level] + params[self.slope] * g
        at = self.at**2 if self.square else self.at
        return self.value + params[self.slope] * (g - at)


def line_laws(problem: Problem) -> tuple[Skeleton, dict[str, LineLaw]]:
    """The skeleton with each free curve a straight line of new parameters ``a_k``.

    An odd curve is a line through zero, an even one a parabola, a curve
    with a point value a line through it (the first), a monotone one a line
    of that slope's sign; the curves the gauge pinned to zero are zero. The
    parameter bounds and state limits are the original's.
    """
    skeleton = problem.skeleton
    numbers = [int(re.sub(r"\D", "", a) or 0) for a in skeleton.params] or [0]
    counter = iter(range(max(numbers) + 1, max(numbers) + 1 + 2 * len(skeleton.functions)))
    laws, bounds = {}, []
    for f in problem.free_functions:
        parity, points = problem.parity(f), problem.points(f)
        slope = f"a{next(counter)}"
        if parity == "odd":
            law = LineLaw(f, slope, None)
        elif points:
            law = LineLaw(f, slope, None, float(points[0][0]), float(points[0][1]),
                          square=parity == "even")
        else:
            law = LineLaw(f, slope, f"a{next(counter)}", square=parity == "even")
        monotone = problem.monotone(f)
        if monotone is not None and parity != "even":
            bounds.append(f"{slope} {'>=' if monotone == 'increasing' else '<='} 0")
        laws[f] = law

    def curve(name: str, argument: str) -> str:
        return laws[name].text(argument) if name in laws else "0"

    texts = [f"{to_text(eq.lhs, {}, 17, curve)} = {to_text(eq.rhs, {}, 17, curve)}"
             for eq in skeleton.residual_equations]
    kept = [c for c in skeleton.constraints if not isinstance(c, Constraint)]
    written = Skeleton(texts, [*kept, *bounds])
    written.delays_given = dict(skeleton.delays_given)
    return written, laws


def _ranges_on(skeleton: Skeleton, course: Mapping[str, np.ndarray],
                     params: Mapping[str, float],
                     functions: Mapping[str, Callable]) -> dict[str, tuple[float, float]]:
    """The range of each curve's arguments over ``course`` (states, inputs and ``t`` by name)."""
    names = list(course)
    slots = {name: i for i, name in enumerate(names)}
    env = [np.asarray(course[n], dtype=float) for n in names]
    out = {}
    for f in skeleton.functions:
        chunks = []
        for arg in skeleton.curve_arguments(f):
            with np.errstate(all="ignore"):
                value = np.asarray(compile_expression(arg, slots, params, functions)(env),
                                   dtype=float)
            chunks.append(value[np.isfinite(value)].ravel())
        values = np.concatenate(chunks) if chunks else np.zeros(0)
        out[f] = (float(values.min()), float(values.max())) if values.size else (0.0, 1.0)
    return out


def _written_problem(problem: Problem, forms: Mapping[str, CurveForm],
                     make_curve: MakeCurve, held: Mapping[str, Callable]) -> Problem:
    written = CurvesWrittenOut(problem.skeleton, forms, make_curve, held)
    return replace(problem, skeleton=written, constraints={}, zeroed=set())


def _forms(problem: Problem, ranges: Mapping[str, tuple[float, float]],
           degrees: Mapping[str, int]) -> dict[str, CurveForm]:
    """Each free curve's form over its range and its point values (the pin at 0 among them)."""
    out = {}
    for f in problem.free_functions:
        points = problem.points(f)
        at = [p for p, _ in points]
        domain = (min([ranges[f][0], *at]), max([ranges[f][1], *at]))
        out[f] = curve_form(f, degrees[f], domain, parity=problem.parity(f), points=points,
                            monotone=problem.monotone(f))
    return out


def _renamed(message: str, forms: Mapping[str, CurveForm]) -> str:
    """A warning of the written-out fit in the user's words: a number is a curve's coefficient."""
    for form in forms.values():
        # the longest names first: f1:12 before f1:1
        for k, name in reversed(list(enumerate(form.names, start=1))):
            message = message.replace(name, f"coefficient {k} of {form.name}")
    return re.sub(r"\s+", " ", message)


def fit_hidden_curves(problem: Problem, *, degrees: Mapping[str, int],
                      make_curve: MakeCurve, held: Mapping[str, Callable],
                      param_init: Mapping[str, float] | None, window: int,
                      iterations: int) -> FitResult:
    """Output error for a skeleton whose curves run through unmeasured states.

    First every free curve is a straight line (even curves a parabola) over
    a guessed range, fitted from the usual starts with the parameters
    (:func:`~sklearn_pycc.fitting.output_error.hidden_fit.fit_hidden`); then
    each is a polynomial of its degree in ``degrees`` over the range its
    argument ran in that fit (widened by :data:`MARGIN`), started on the
    line, and the whole is fitted again from there. The curves returned
    are ``make_curve``'s; ``held`` are the curves the gauge pinned to zero.
    The result's attributes are the second fit's, with ``starts_`` of both
    and ``written_curves_`` (each curve's :class:`WrittenCurve`).
    """
    from .hidden_fit import fit_hidden

    init = {a: v for a, v in dict(param_init or {}).items()}
    # the law: each curve a straight line, its parameters fitted as any skeleton's
    lined, laws = line_laws(problem)
    first = replace(problem, skeleton=lined, constraints={}, zeroed=set(), covariance=False)
    start = scaled_start(first, starting_params(first, init), list(init))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the law is a step; the curves' fit speaks
        law = fit_hidden(first, FitResult({}, start), param_init=init, window=window,
                         iterations=iterations)
    # the curves: of their degree over the range their arguments ran with the law
    values = {**first.fixed_params, **law.params}
    whole = WholeRecord(first)
    system = lined.compile({}, values)
    first_states = np.asarray(law.attributes["shooting_"]["initial_states"], dtype=float)
    whole.choose_substeps(system, first_states)
    course = whole.course(system, first_states)
    pins, gauge = _scale_pins(problem, first, values, course)
    if pins:  # the law moved along each unseen scale to its pin: the same fit
        states = list(problem.skeleton.states)
        for state, factor in gauge.pop("factors").items():
            first_states[:, states.index(state)] *= factor
        problem = replace(problem, fixed_params={**problem.fixed_params, **pins})
        course = whole.course(lined.compile({}, values), first_states)
    curves = {**held, **{f: (lambda x, law=law_: law(x, values)) for f, law_ in laws.items()}}
    ranges = _ranges_on(problem.skeleton, course, {**problem.fixed_params, **values},
                              curves)
    widened = {f: (lo - MARGIN * (hi - lo), hi + MARGIN * (hi - lo))
               for f, (lo, hi) in ranges.items()}
    forms = _forms(problem, widened, degrees)
    # the input hold the law chose stands (the curves change the record's fit, not its input)
    second = replace(_written_problem(problem, forms, make_curve, held),
                     input_hold=law.attributes.get("input_hold_", problem.input_hold),
                     hold_chosen=False)
    start = {a: values[a] for a in problem.free_params}
    for name, form in forms.items():
        lo, hi = form.domain
        start.update(form.numbers_for(curves[name], np.linspace(lo, hi, 64)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fit_hidden(second, FitResult(dict(held), start), param_init=start,
                            window=window, iterations=iterations, initial=first_states)
    for w in caught:
        warnings.warn(_renamed(str(w.message), forms), w.category, stacklevel=5)
    out = _curves_result(problem, second, law, result, forms)
    out.params.update(pins)
    if gauge:
        out.attributes["written_gauge_"] = gauge
    return out


def _scale_pins(problem: Problem, lined: Problem, values: dict[str, float],
                course: Mapping[str, np.ndarray]) -> tuple[dict[str, float], dict]:
    """Pin the scale of each unmeasured state the record does not see, moving ``values`` there.

    Where scaling an unmeasured state, with some parameters scaled by
    powers of the same factor, leaves what is measured unchanged
    (:func:`~sklearn_pycc.fitting.output_error.hidden.scale_family`, on the
    straight lines' fit ``lined`` along its ``course``), one of the
    skeleton's own parameters in that family is pinned to 1 (-1 for a
    negative one), preferably one that reads the state into another
    equation. ``values`` are moved along the family to that pin (in place:
    the same fit). Returns the pins and the gauge's words, with
    ``"factors"``: each state's factor, for its initial values.
    """
    pins, gauge, factors = {}, {}, {}
    bounds = problem.skeleton.bounds
    course = dict(course)
    for state in problem.hidden:
        fitted = replace(lined, fixed_params={**lined.fixed_params, **pins})
        powers = scale_family(fitted, {a: values[a] for a in fitted.free_params}, state,
                              course)
        if powers is None:
            continue
        own = [a for a in problem.free_params if a not in pins and abs(powers.get(a, 0)) > 0.5]
        # a parameter that reads the state into another equation first (its power is -1)
        for pin in sorted(own, key=lambda a: powers[a] > 0):
            target = 1.0 if values[pin] > 0 else -1.0
            low, high = bounds.get(pin, (-np.inf, np.inf))
            if values[pin] != 0 and low <= target <= high:
                break
        else:
            continue
        factor = (target / values[pin]) ** (1.0 / powers[pin])
        for a, k in powers.items():
            values[a] *= factor ** k
        values[pin] = target
        pins[pin] = target
        factors[state] = factor
        course[state] = np.asarray(course[state], dtype=float) * factor
        moved = [a for a in own if a != pin]
        gauge[f"{pin}={target:g}"] = (
            f"{state} is not measured and its scale is not seen: {state} scaled by any "
            f"factor, with {', '.join(moved) or 'the curves'} and the curves moved alike, "
            f"fits the record as well; its scale is pinned by {pin} = {target:g}.")
    if pins:
        gauge["factors"] = factors
    return pins, gauge


def _curves_result(problem: Problem, written: Problem, law: FitResult, result: FitResult,
                   forms: Mapping[str, CurveForm]) -> FitResult:
    """The written-out fit as the original's curves and parameters."""
    values = {**written.fixed_params, **result.params}
    curves = written.skeleton.curves(values)
    params = {a: float(values[a]) for a in problem.free_params}
    attributes = {k: v for k, v in result.attributes.items() if k != "covariance_"}
    covariance = result.attributes.get("covariance_")
    if covariance is not None:
        attributes["covariance_"] = _series_covariance(covariance, problem.free_params, forms)
    starts = []
    for stage, fit in (("straight lines", law), ("curves", result)):
        table = fit.attributes.get("starts_")
        if table is not None:
            table = table.copy()
            table.insert(0, "stage", stage)
            starts.append(table)
    if starts:
        import pandas as pd

        attributes["starts_"] = pd.concat(starts, ignore_index=True)
    attributes["written_curves_"] = {
        name: WrittenCurve(form, {n: float(values[n]) for n in form.names})
        for name, form in forms.items()}
    return FitResult(curves, params, attributes)


def written_numbers(problem: Problem, result: FitResult, make_curve: MakeCurve) -> Numbers:
    """A fit with curves through unmeasured states as one vector, for the filter to move.

    The free parameters, then each curve's numbers (:class:`WrittenCurve`),
    within their bounds; the labelled numbers are the parameters and each
    curve's power series (``f1[k]``), as ``covariance_`` names them.
    """
    written = result.attributes["written_curves_"]
    forms = {name: w.form for name, w in written.items()}
    skeleton = CurvesWrittenOut(problem.skeleton, forms, make_curve,
                                {f: result.functions[f] for f in problem.zeroed})
    free = list(problem.free_params)
    names = [*free, *(n for form in forms.values() for n in form.names)]
    start = {**result.params, **{n: v for w in written.values() for n, v in w.numbers.items()}}
    bounds = skeleton.bounds
    fixed = dict(problem.fixed_params)

    def values(theta) -> dict:
        return {**fixed, **dict(zip(names, (float(v) for v in theta)))}

    def result_for(theta) -> FitResult:
        numbers = values(theta)
        kept = {k: v for k, v in result.attributes.items() if k != "covariance_"}
        kept["written_curves_"] = {
            name: WrittenCurve(form, {n: numbers[n] for n in form.names})
            for name, form in forms.items()}
        return FitResult(skeleton.curves(numbers), {a: numbers[a] for a in free}, kept)

    labels, to_labels = _series_labels(free, forms)
    return Numbers(
        theta0=np.array([start[n] for n in names], dtype=float),
        low=np.array([bounds.get(n, (-np.inf, np.inf))[0] for n in names], dtype=float),
        high=np.array([bounds.get(n, (-np.inf, np.inf))[1] for n in names], dtype=float),
        system_for=lambda theta: skeleton.compile({}, values(theta)),
        result_for=result_for, labels=labels, to_labels=to_labels)


def _series_labels(params: Sequence[str], forms: Mapping[str, CurveForm]):
    """The parameters and each curve's power series (``f1[k]``), and the map to them.

    The map is linear from the parameters, then each form's numbers in
    order: the series are the forms' directions times their numbers (plus
    a constant no covariance sees).
    """
    from scipy.linalg import block_diag

    labels = list(params)
    for name, form in forms.items():
        labels += [f"{name}[{k}]" for k in range(len(form.constant))]
    return labels, block_diag(np.eye(len(params)), *(f.directions for f in forms.values()))


def _series_covariance(covariance, params: Sequence[str], forms: Mapping[str, CurveForm]):
    """The covariance of the parameters and of each curve's power series (``f1[k]``).

    ``covariance`` is of the written-out fit's parameters and numbers; the
    series are linear in the numbers, so theirs follows exactly.
    """
    import pandas as pd

    order = [*params, *(n for form in forms.values() for n in form.names)]
    index = [list(covariance.index).index(n) for n in order]
    labels, to_labels = _series_labels(params, forms)
    out = to_labels @ covariance.to_numpy()[np.ix_(index, index)] @ to_labels.T
    frame = pd.DataFrame(0.5 * (out + out.T), index=labels, columns=labels)
    frame.attrs.update(covariance.attrs)
    return frame
