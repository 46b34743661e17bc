"""Polynomial backend: curves as linear-basis expansions, parameters by variable projection."""

from __future__ import annotations

import inspect
import warnings
from collections.abc import Mapping
from numbers import Integral, Real

import numpy as np
from scipy.linalg import block_diag, null_space
from scipy.optimize import least_squares
from sklearn.utils._param_validation import Interval, StrOptions

from .._utils.randomness import seeds
from .._utils.threads import blas_threads
from ..backends.poly.basis import BASES, PolyBasis, PolyCurve
from ..backends.poly.linear import curve_arguments, linearize, split_parameters
from ..exceptions import IdentifiabilityError, RankDeficiencyWarning
from ..fitting.lstsq import LstsqResult, bounded_lstsq, constrained_lstsq
from ..fitting.numbers import Numbers, parameters_only
from ..fitting.output_error.hidden_curves import written_numbers
from ..fitting.output_error.shooting import ShootingPlan, fit_shooting
from ..fitting.problem import FitResult, Problem, residual_scale, thinned
from ..fitting.uncertainty.covariance import DeferredCovariance, sandwich
from ..skeleton.curves import ZeroCurve
from .backend import Backend
from .base import RANDOM_STATES, RESAMPLING, CCRegressor

__all__ = ["PolyBackend", "PolyCCRegressor", "polynomial_stand_in"]

# grid of starting magnitudes for nonlinear parameters: +-10^k
_LOG_GRID = np.arange(-2.0, 4.01, 0.5)
#: rows a long record's multi-start ranks its starts on (every k-th, :func:`thinned`)
_SEARCH_ROWS = 3000
#: most evaluations of a refinement, per nonlinear parameter and one: a smooth cost
#: converges in far fewer, and a threshold (a dead zone's) only creeps along its steps
_MAX_NFEV = 60
#: highest degree of the Bernstein form that keeps a monotone curve monotone
_MAX_BERNSTEIN = 24


class _Design:
    """Weighted linear system of a fit, rebuilt for each value of the nonlinear parameters."""

    def __init__(self, problem: Problem, linear: list[str], nonlinear: list[str],
                 degrees: Mapping[str, int], basis: str) -> None:
        self.problem = problem
        self.linear = linear
        self.nonlinear = nonlinear
        self.degrees = degrees
        self.basis = basis
        self.curves = problem.free_functions
        self.data = problem.data.columns
        self.n = problem.data.n_samples
        self.equations = problem.equations
        self.residuals = [eq.fit_residual for eq in self.equations]
        # only equations with something to fit take part
        self.active = problem.active
        self.weights = {}

    def bases(self, values: Mapping[str, float]) -> dict[str, PolyBasis]:
        ranges: dict[str, list[np.ndarray]] = {}
        for i in self.active:
            for name, args in curve_arguments(self.residuals[i], self.data, self.n,
                                              values).items():
                ranges.setdefault(name, []).extend(args)
        out = {}
        for name in self.curves:
            args = np.concatenate(ranges.get(name, [np.zeros(1)]))
            finite = args[np.isfinite(args)]
            lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (-1.0, 1.0)
            out[name] = PolyBasis(lo, hi, self.degrees[name], self.problem.parity(name),
                                  self.basis)
        return out

    def layout(self, bases: Mapping[str, PolyBasis]) -> list[tuple[str, int]]:
        return [(a, 1) for a in self.linear] + [(f, bases[f].size) for f in self.curves]

    def assemble(self, values: Mapping[str, float]):
        """Return ``A, b, C, d, layout, bases`` for fixed nonlinear/pinned parameter values."""
        bases = self.bases(values)
        layout = self.layout(bases)
        offsets, p = {}, 0
        for name, size in layout:
            offsets[name] = (p, p + size)
            p += size
        linear = set(self.linear)
        zeroed = self.problem.zeroed
        n = self.n
        A = np.zeros((n * len(self.active), p), order="F")
        b = np.empty(n * len(self.active))
        for row, i in enumerate(self.active):
            form = linearize(self.residuals[i], self.data, n, values, bases, linear=linear,
                             zeroed=zeroed)
            const = np.broadcast_to(np.asarray(form.const, dtype=float), (n,))
            if i not in self.weights:
                scale = float(np.sqrt(np.mean(const * const)))
                self.weights[i] = self.problem.weight(i) / (
                    scale if np.isfinite(scale) and scale > 0 else residual_scale(self.problem,
                                                                                  self.equations[i]))
            w = self.weights[i]
            rows = slice(row * n, (row + 1) * n)
            np.multiply(const, w, out=b[rows])
            for name in form.blocks:
                lo, hi = offsets[name]
                form.write(name, A[rows, lo:hi], w)
        C_rows, d = [], []
        for f in self.curves:
            for at, value in self.problem.points(f):
                row = np.zeros(p)
                lo, hi = offsets[f]
                row[lo:hi] = bases[f].design(np.array([at]))[0]
                C_rows.append(row)
                d.append(value)
        C = np.array(C_rows) if C_rows else None
        self._check_finite(A, b, layout, values)
        return A, b, C, (np.array(d) if d else None), layout, bases

    def _check_finite(self, A: np.ndarray, b: np.ndarray, layout, values) -> None:
        """Refuse a system with a value that is not finite, naming the equation and the sample.

        A sqrt, log, power or division whose argument leaves its domain on
        some sample (a level that noise reads below zero) would otherwise
        reach the solver as NaN.
        """
        rows = ~(np.isfinite(b) & np.isfinite(A).all(axis=1))
        if not rows.any():
            return
        first = int(np.flatnonzero(rows)[0])
        sample, eq = first % self.n, self.equations[self.active[first // self.n]]
        columns = np.flatnonzero(~np.isfinite(A[first]))
        names, at = [], 0
        for name, size in layout:
            if any(at <= c < at + size for c in columns):
                names.append(name)
            at += size
        what = f"the term of {', '.join(names)}" if names else "a term without a fitted number"
        read = ", ".join(f"{name}={self.data[name][sample]:.4g}" for name in
                         sorted(eq.symbols()) if name in self.data)
        where = f"t={self.data['t'][sample]:.6g}" if "t" in self.data else f"sample {sample}"
        numbers = ", ".join(f"{a}={v:.4g}" for a, v in values.items())
        raise ValueError(
            f"equations[{eq.index}] ({eq.derivative or eq.output}) is not finite at {where} "
            f"({read}{'; ' + numbers if numbers else ''}): {what} leaves the domain of a sqrt, "
            f"log, power or division there, on {int(rows.sum())} of the fitted rows. Write it "
            "so that it holds for every measured value (sqrt(abs(x1)) for a level that noise "
            "reads below zero), or leave those rows out")

    def inequalities(self, layout, bases: Mapping[str, PolyBasis]):
        """``G, h`` with ``G x >= h`` for bounded linear parameters and monotone curves.

        A monotone curve's Bernstein coefficients (of three times its degree,
        at most :data:`_MAX_BERNSTEIN`, over its basis's interval) must not
        decrease (not increase): sufficient for the curve to be monotone over
        the whole interval, exactly.
        """
        bounds = self.problem.bounds
        p = sum(size for _, size in layout)
        blocks, h = [], []
        offset = 0
        for name, size in layout:
            if name in bases:
                kind = self.problem.monotone(name)
                if kind is not None and size:
                    basis = bases[name]
                    steps = np.diff(basis.bernstein(min(3 * basis.degree, _MAX_BERNSTEIN)),
                                    axis=0)
                    block = np.zeros((len(steps), p))
                    block[:, offset:offset + size] = steps if kind == "increasing" else -steps
                    blocks.append(block)
                    h.extend([0.0] * len(steps))
            elif name in bounds:
                for value, sign in zip(bounds[name], (1.0, -1.0)):
                    if np.isfinite(value):
                        row = np.zeros((1, p))
                        row[0, offset] = sign
                        blocks.append(row)
                        h.append(sign * value)
            offset += size
        if not blocks:
            return None, None
        return np.vstack(blocks), np.array(h)


#: highest degree of a curve: beyond it the power series loses the fit to rounding
MAX_DEGREE = 60


class PolyBackend(Backend):
    """Curves as polynomial expansions, fitted by (constrained) linear least squares.

    Parameters that enter nonlinearly are found by variable projection. The
    settings are :class:`PolyCCRegressor`'s, with the same meanings.
    """

    output_error = True
    uncertainty = True
    hidden_curves = True
    #: the refits' least squares run in LAPACK, which releases the GIL
    resample_in = "threads"

    settings = ("degree", "basis", "alpha", "extrapolation", "param_init", "random_state",
                "gauge")

    def _degrees(self, functions: list[str]) -> dict[str, int]:
        def check(value, name) -> int:
            if not isinstance(value, Integral) or isinstance(value, bool) or value < 0:
                raise ValueError(f"degree of {name} must be a non-negative integer, got {value!r}")
            if value > MAX_DEGREE:
                raise ValueError(
                    f"degree of {name} is {value}, above {MAX_DEGREE}: a fitted polynomial is "
                    "evaluated as a power series, whose coefficients then cancel beyond the "
                    "precision of a float (at degree 90 the fit is worse than a constant); "
                    "use a lower degree, or NeuralCCRegressor for a curve of many wiggles")
            return int(value)

        if isinstance(self.degree, Mapping):
            unknown = [k for k in self.degree if k not in functions]
            if unknown:
                raise ValueError(f"degree names {unknown[0]!r}, which is not a curve of the "
                                 f"skeleton ({', '.join(functions) or 'none'})")
            return {f: check(self.degree.get(f, 7), f) for f in functions}
        return {f: check(self.degree, "every curve") for f in functions}

    @property
    def _beyond(self) -> str | None:
        """The fitted curves' policy beyond their domain (None: the polynomial)."""
        return None if self.extrapolation == "polynomial" else self.extrapolation

    def _design(self, problem: Problem) -> tuple[_Design, list[str]]:
        degrees = self._degrees(problem.free_functions)
        residuals = [(eq.index, eq.text, eq.fit_residual) for eq in problem.equations]
        linear, nonlinear = split_parameters(residuals, problem.free_params, type(self).__name__)
        return _Design(problem, linear, nonlinear, degrees, self.basis), nonlinear

    def design(self, problem: Problem, values: Mapping[str, float] | None = None):
        """The weighted linear system the fit solves: ``min ||A x + b||`` with ``C x = d``.

        ``values`` gives the parameters that enter nonlinearly (none are
        needed when every parameter enters linearly).

        Returns
        -------
        A : ndarray of shape (n_samples * n_equations, n_unknowns)
        b : ndarray of shape (n_samples * n_equations,)
        C : ndarray of shape (n_constraints, n_unknowns) or None
        """
        design, nonlinear = self._design(problem)
        missing = [a for a in nonlinear if a not in (values or {})]
        if missing:
            raise ValueError(f"the design depends on {', '.join(missing)}, which enter "
                             "nonlinearly: give their values")
        A, b, C, *_ = design.assemble({**problem.fixed_params, **dict(values or {})})
        return A, b, C

    def fit(self, problem: Problem) -> FitResult:
        """One constrained least-squares fit of every curve and linear parameter."""
        design, nonlinear = self._design(problem)
        fixed = dict(problem.fixed_params)
        init = problem.starting_values(self.param_init)

        def solver(design: _Design):
            def solve(theta: np.ndarray, keep: list | None = None):
                values = {**fixed, **dict(zip(nonlinear, theta))}
                A, b, C, d, layout, bases = design.assemble(values)
                # the system itself is kept for the covariance: the solve then leaves A as
                # it is
                overwrite = keep is None
                if keep is not None:
                    keep += [A, C]
                G, h = design.inequalities(layout, bases)
                if G is None:
                    result = constrained_lstsq(A, b, C, d, self.alpha, overwrite_a=overwrite)
                else:
                    result = bounded_lstsq(A, b, C, d, G, h=h, alpha=self.alpha,
                                           overwrite_a=overwrite)
                return result, layout, bases, values
            return solve

        solve = solver(design)
        # a long record's multi-start ranks its starting values on every k-th row
        screen = (solver(self._design(thinned(problem, _SEARCH_ROWS))[0])
                  if nonlinear and problem.data.n_samples > _SEARCH_ROWS else None)
        bounds = problem.bounds
        with blas_threads(1):
            theta = (self._search(solve, nonlinear, init, bounds, screen) if nonlinear
                     else np.zeros(0))
            system: list = []
            result, layout, bases, values = solve(theta, keep=system)
            self._report_rank(result, layout)
            covariance = (_covariance(problem, design, nonlinear, theta, fixed, result=result,
                                      layout=layout, bases=bases, system=system)
                          if problem.covariance else None)
        params = {a: v for a, v in values.items() if a in nonlinear}
        functions, coefficients = {}, {}
        offset = 0
        for name, size in layout:
            chunk = result.x[offset:offset + size]
            offset += size
            if name in bases:
                coefficients[name] = chunk.copy()
                functions[name] = bases[name].curve(chunk, self._beyond)
            else:  # a bound holds exactly, not up to rounding
                low, high = bounds.get(name, (-np.inf, np.inf))
                params[name] = float(np.clip(chunk[0], low, high))
        for name in problem.zeroed:
            functions[name] = ZeroCurve()
            coefficients[name] = np.zeros(0)
        return FitResult(functions, params, {"coefficients_": coefficients,
                                             "nonlinear_params_": list(nonlinear),
                                             "cost_": result.cost,
                                             "covariance_": covariance})

    # -- output error ----------------------------------------------------------
    def written_degrees(self, problem: Problem) -> dict[str, int]:
        """Each free curve's ``degree``, as through measured states."""
        return self._degrees(problem.free_functions)

    def written_curve(self, series: np.ndarray, center: float, half: float,
                      domain: tuple[float, float]) -> PolyCurve:
        """A :class:`PolyCurve` of the series, extrapolated as ``extrapolation`` says."""
        return PolyCurve(series, center, half, domain, self._beyond)

    def numbers(self, problem: Problem, result: FitResult) -> Numbers:
        """The free parameters and the curves' coefficients as one vector.

        The curves keep their bases; their coefficients move in the null
        space of their point constraints (which then hold exactly), from
        where ``result`` left them; a monotone curve is held as the equation
        fit shaped it. The labelled numbers are the parameters and each
        curve's power series (``f1[k]``), as ``covariance_`` names them.
        """
        if "written_curves_" in result.attributes:  # curves through unmeasured states
            return written_numbers(problem, result, self.written_curve)
        if not problem.free_functions:  # parameters alone (a fit with unmeasured states)
            return parameters_only(problem, result)
        functions, params = result.functions, result.params
        coefficients_at_start = result.attributes["coefficients_"]
        degrees = self._degrees(problem.free_functions)
        free_params = problem.free_params
        pieces = []  # (curve, basis, coefficients at start, null-space directions)
        for name in problem.free_functions:
            lo, hi = functions[name].domain
            basis = PolyBasis(lo, hi, degrees[name], problem.parity(name), self.basis)
            points = problem.points(name)
            if problem.monotone(name) is not None:
                directions = np.zeros((basis.size, 0))  # kept as the equation fit made it
            elif points:
                directions = null_space(basis.design(np.array([at for at, _ in points])))
            else:
                directions = np.eye(basis.size)
            pieces.append((name, basis, coefficients_at_start[name], directions))
        sizes = [d.shape[1] for *_, d in pieces]
        fixed = dict(problem.fixed_params)
        p = len(free_params)

        def unpack(theta):
            values = {**fixed, **dict(zip(free_params, (float(v) for v in theta[:p])))}
            curves, offset = dict(functions), p
            coefficients = dict(coefficients_at_start)
            for (name, basis, c0, directions), size in zip(pieces, sizes):
                coefficients[name] = c0 + directions @ theta[offset:offset + size]
                curves[name] = basis.curve(coefficients[name], self._beyond)
                offset += size
            return values, curves, coefficients

        def system_for(theta):
            values, curves, _ = unpack(theta)
            return problem.skeleton.compile(curves, values)

        def result_for(theta) -> FitResult:
            values, curves, coefficients = unpack(theta)
            kept = {k: v for k, v in result.attributes.items() if k != "covariance_"}
            return FitResult(curves, {**params, **{a: values[a] for a in free_params}},
                             {**kept, "coefficients_": coefficients})

        bounds = problem.bounds
        # the labelled numbers: the parameters, and each curve's power series
        labels = list(free_params)
        blocks = [np.eye(p)]
        for (name, basis, _, directions), _size in zip(pieces, sizes):
            to_series = basis.to_power() @ directions
            labels += [f"{name}[{k}]" for k in range(to_series.shape[0])]
            blocks.append(to_series)
        # a coefficient's typical size: the root mean square of its curve's at the start
        typical = np.concatenate([np.abs([params[a] for a in free_params])] + [
            np.full(size, np.sqrt(np.mean(np.square(c0))) if len(c0) else 0.0)
            for (_, _, c0, _), size in zip(pieces, sizes)])
        return Numbers(
            theta0=np.concatenate([[params[a] for a in free_params], np.zeros(sum(sizes))]),
            low=np.concatenate([[bounds.get(a, (-np.inf, np.inf))[0] for a in free_params],
                                np.full(sum(sizes), -np.inf)]),
            high=np.concatenate([[bounds.get(a, (-np.inf, np.inf))[1] for a in free_params],
                                 np.full(sum(sizes), np.inf)]),
            system_for=system_for,
            result_for=result_for, labels=labels, to_labels=block_diag(*blocks),
            typical=typical,
            held=[name for name in problem.free_functions if problem.monotone(name) is not None])

    def refine(self, problem: Problem, result: FitResult, plan: ShootingPlan) -> FitResult:
        """Refine the coefficients and parameters so that simulations match the states.

        The curves keep their bases; coefficients move in the null space of
        their point constraints, so constraints still hold exactly; bounded
        parameters stay within their bounds, and monotone curves keep the
        shape the equation fit gave them.
        """
        numbers = self.numbers(problem, result)
        with blas_threads(1):
            theta, info = fit_shooting(plan, numbers.system_for,
                                       np.clip(numbers.theta0, numbers.low, numbers.high),
                                       plan.iterations, bounds=(numbers.low, numbers.high))
        refined = numbers.result_for(theta)
        # the covariance was of the equation-error estimate, which this stage moved
        return FitResult(refined.functions, refined.params,
                         {**refined.attributes, "shooting_": info})

    # -- uncertainty (the covariance of the equation-error estimate) ------------------------
    @staticmethod
    def _curve_block(functions: Mapping, name: str) -> list[str]:
        curve = functions[name]
        return [f"{name}[{k}]" for k in range(len(curve.series))] \
            if isinstance(curve, PolyCurve) else []

    def curve_sd(self, model, name: str, x: np.ndarray) -> np.ndarray | None:
        """From the covariance of the equation-error estimate (``covariance_``)."""
        cov = getattr(model, "covariance_", None)
        if cov is None:
            return None
        curve = model.functions_[name]
        block = [k for k in self._curve_block(model.functions_, name) if k in cov.index]
        if not block:  # pinned to zero by the gauge: known exactly
            return np.zeros_like(np.asarray(x, dtype=float))
        u = (np.asarray(x, dtype=float) - curve.center) / curve.half
        V = u[:, None] ** np.arange(len(block))
        sigma = cov.loc[block, block].to_numpy()
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", V, sigma, V), 0.0))

    def draws(self, model, n: int, rng: np.random.Generator) -> list[tuple[dict, dict]] | None:
        """Coefficients and parameters drawn from a normal law with ``covariance_``."""
        cov = getattr(model, "covariance_", None)
        if cov is None:
            return None
        names = list(cov.index)
        mean = np.array([_estimate_of(model, name) for name in names])
        values, vectors = np.linalg.eigh(cov.to_numpy())
        root = vectors * np.sqrt(np.clip(values, 0.0, None))
        samples = mean + rng.standard_normal((n, len(names))) @ root.T
        out = []
        for sample in samples:
            drawn = dict(zip(names, sample))
            params = {a: float(drawn.get(a, v)) for a, v in model.params_.items()}
            functions = dict(model.functions_)
            for name, curve in model.functions_.items():
                block = self._curve_block(model.functions_, name)
                if block and block[0] in drawn:
                    functions[name] = PolyCurve(np.array([drawn[k] for k in block]),
                                                curve.center, curve.half, curve.domain,
                                                curve.extrapolation)
            out.append((functions, params))
        return out

    def n_numbers(self, problem: Problem, result: FitResult, name: str) -> int:
        """Coefficients of the basis, less one per point value they must satisfy."""
        written = result.attributes.get("written_curves_") or {}
        if name in written:  # written out through unmeasured states: its own numbers
            return len(written[name].numbers)
        coefficients = result.attributes["coefficients_"][name]
        return max(len(coefficients) - len(problem.points(name)), 0)

    # -- nonlinear parameters: variable projection with a multi-start --------------
    def _search(self, solve, names: list[str], init: Mapping[str, float],
                bounds: Mapping[str, tuple[float, float]], screen=None) -> np.ndarray:
        """The nonlinear parameters' values: a grid of starts, the best few refined.

        ``screen`` (a solve on a thinned record) ranks the starts and refines
        the best few; the winner is then refined on the whole record.
        """
        m = len(names)
        low = np.array([bounds.get(a, (-np.inf, np.inf))[0] for a in names])
        high = np.array([bounds.get(a, (-np.inf, np.inf))[1] for a in names])
        bounded = bool(np.isfinite(low).any() or np.isfinite(high).any())

        def residual_of(solve):
            size: list[int] = []

            def residual(theta):
                try:
                    r = solve(theta)[0].residual
                except ValueError:  # a term left its domain at these values: far off
                    if not size:
                        raise
                    return np.full(size[0], 1e150)
                size[:] = [len(r)]
                return r if np.isfinite(r).all() else np.full_like(r, 1e150)
            return residual

        def cost_of(solve):
            def cost(theta) -> float:
                try:
                    r = solve(theta)[0].residual
                except (np.linalg.LinAlgError, ValueError, FloatingPointError):
                    return np.inf
                c = float(r @ r)
                return c if np.isfinite(c) else np.inf
            return cost

        def refined(residual, start):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    return (_refine_bounded(residual, start, low, high, m) if bounded
                            else _refine(residual, start, m))
            except (np.linalg.LinAlgError, ValueError):
                return None

        free = [k for k, name in enumerate(names) if name not in init]
        base = np.array([float(init.get(name, 1.0)) for name in names])
        starts = [base]
        if free:
            grid = np.concatenate([-(10.0 ** _LOG_GRID), 10.0 ** _LOG_GRID])
            if len(free) <= 2:
                mesh = np.meshgrid(*[grid] * len(free), indexing="ij")
                combos = np.column_stack([g.ravel() for g in mesh])
            else:
                state = self.random_state
                # an integer seeds the starts itself; a generator gives a seed from its stream
                rng = np.random.default_rng(
                    state if state is None or isinstance(state, (Integral, np.integer))
                    else next(seeds(state)))
                combos = rng.choice(grid, size=(256, len(free)))
            for combo in combos:
                start = base.copy()
                start[free] = combo
                starts.append(start)
        if bounded:  # every start within the bounds (a bound is usually a sign)
            starts = list(np.unique(np.clip(np.array(starts), low, high), axis=0))
        quick = screen or solve
        quick_cost, quick_residual = cost_of(quick), residual_of(quick)
        costs = np.array([quick_cost(s) for s in starts])
        order = np.argsort(costs)
        best_theta, best_cost = starts[order[0]], costs[order[0]]
        for k in order[:3]:  # the best few starts
            if not np.isfinite(costs[k]):
                break
            theta = refined(quick_residual, starts[k])
            if theta is not None and (c := quick_cost(theta)) < best_cost:
                best_theta, best_cost = theta, c
        cost = cost_of(solve)
        if screen is not None:  # the best of them to the whole record's own optimum
            best_cost = cost(best_theta)
            theta = refined(residual_of(solve), best_theta) if np.isfinite(best_cost) \
                else None
            if theta is not None and (c := cost(theta)) < best_cost:
                best_theta, best_cost = theta, c
        if not np.isfinite(best_cost):
            raise ValueError(
                f"no value of the nonlinear parameters {names} gives a finite residual; "
                "give starting values with param_init")
        return _prefer_positive(best_theta, best_cost, cost, low, high)

    def _report_rank(self, result, layout) -> None:
        null = result.null_directions
        if null.shape[1] == 0:
            return
        names, offset = [], 0
        weight = np.abs(null).max(axis=1)
        for name, size in layout:
            if weight[offset:offset + size].max() > 1e-8 * weight.max():
                names.append(name)
            offset += size
        message = (f"the design is rank deficient on these data ({null.shape[1]} direction"
                   f"{'s' if null.shape[1] > 1 else ''} undetermined): "
                   f"{', '.join(names)} cannot be separated by the data. Lower the degree, "
                   "add constraints, or measure a wider range.")
        if self.gauge == "raise":
            raise IdentifiabilityError(message)
        warnings.warn(message, RankDeficiencyWarning, stacklevel=4)

    def curve_text(self, curve, variable: str, precision: int) -> str:
        """The curve's power series in ``variable``."""
        if not isinstance(curve, PolyCurve):
            return super().curve_text(curve, variable, precision)
        coefs = curve.polynomial().coef
        biggest = float(np.max(np.abs(coefs))) if coefs.size else 0.0
        terms = []
        for k, c in enumerate(coefs):
            if c == 0 or abs(c) < 1e-12 * biggest:
                continue
            mag = f"{abs(c):.{precision}g}"
            power = "" if k == 0 else variable if k == 1 else f"{variable}^{k}"
            body = mag if k == 0 else f"{mag}*{power}"
            terms.append((c < 0, body))
        if not terms:
            return "0"
        text = ("-" if terms[0][0] else "") + terms[0][1]
        for negative, body in terms[1:]:
            text += f" {'-' if negative else '+'} {body}"
        return text


def _estimate_of(model, name: str) -> float:
    """The fitted value of a ``covariance_`` entry (``a1`` or ``f1[k]``) of ``model``."""
    if name in model.params_:
        return float(model.params_[name])
    curve, k = name[:-1].split("[")
    return float(model.functions_[curve].series[int(k)])


class PolyCCRegressor(CCRegressor):
    """Characteristic curves as polynomial (linear-basis) expansions.

    Each unknown curve ``f_i`` is expanded in orthogonal polynomials over the
    range of its argument; parameters ``a_i`` that enter linearly are solved
    jointly with the curve coefficients by one least-squares problem over
    all equations, with constraints as exact linear equalities. Parameters
    that enter nonlinearly (``a3`` in ``a2 tanh(a3 x2)``) are found by
    variable projection: an outer nonlinear least-squares search, started
    from a grid of magnitudes, over the residual of the inner linear fit.

    Parameters
    ----------
    equations : list of str or Skeleton
        The structural skeleton. After ``fit``, ``model.equations()`` returns
        the fitted model written out (:meth:`~CCRegressor.equations_text`).
    constraints : list of str or dict, optional
        ``"f1 odd"``, ``"f1 even"``, ``"f2(0)=0"``, ...
    degree : int or dict, default=7
        Polynomial degree of every curve, or ``{"f1": 9, "f2": 3}``; at most
        :data:`MAX_DEGREE` (60).
    basis : {"legendre", "chebyshev", "power"}, default="legendre"
        Polynomial family in the argument scaled to ``[-1, 1]``.
    alpha : float, default=0.0
        Ridge penalty on the (scaled) coefficients.
    extrapolation : {"polynomial", "linear"}, default="polynomial"
        What a curve does beyond the range of its argument in training: go
        on as the polynomial, or continue in a straight line with the value
        and slope it has at the nearer end (a simulation that strays beyond
        the data then stays tame; fitted by equation error, the curves are
        the same within the range).
    param_init : dict, optional
        Starting values of nonlinear parameters; the others start from a grid.
    gauge : {"auto", "warn", "raise"}, default="auto"
        See :class:`CCRegressor`.
    differentiation, smooth_states, fit_mode, shooting_window, shooting_iterations, input_hold
        How measurements without derivatives are used, and output-error
        fitting: see :class:`CCRegressor`.
    noise_model : {"ar", "arma", "auto"} or None, default=None
        The measurement noise's model for output-error fits: see
        :class:`CCRegressor`.
    process_noise : dict or None, default=None
        Which states the filter's random push enters, each intensity fitted,
        shared or held: see :class:`CCRegressor`.
    measurement_noise, initial_state : dict or None, default=None
        The filter's held measurement noises and the experiments' starts:
        see :class:`CCRegressor`.
    equation_weights : list of float, optional
        One weight per equation: see :class:`CCRegressor`.
    quantities : dict, optional
        What each state measures, for the diagnosis: see :class:`CCRegressor`.
    n_bootstrap : int, default=0
        Refit on this many resamples of the record (blocks of consecutive
        samples within each experiment, or whole experiments when there are
        many; with unmeasured states, the fit's simulation errors drawn
        again in blocks, each resample refitted from the fit):
        ``params_std_``, ``params_interval``, the bands of ``cc_curves`` and
        ``simulate`` then come from their spread. 0 makes
        none: the covariance of the least-squares estimate answers then
        (equation-error fits), or that of the whole-record simulation
        linearised at the fit (unmeasured states).
    n_jobs : int or None, default=None
        Processes for the refits on resamples (joblib; None is one, -1
        every core). The result does not depend on it.
    verbose : int, default=0
        1: a fit says each stage as it starts (with the seconds since it
        began), the filter's search shows its passes and the refits on
        resamples their count.
    random_state : int, RandomState or None
        Seeds the multi-start search when there are three or more nonlinear
        parameters.

    Attributes
    ----------
    coefficients_ : dict
        Basis coefficients of each curve.
    nonlinear_params_ : list of str
        Parameters found by variable projection.
    cost_ : float
        Final weighted sum of squared equation residuals.
    bootstrap_params_ : DataFrame
        Only with ``n_bootstrap``: the free parameters of each refit on a
        resample, one row per refit (``bootstrap_`` holds their curves too,
        and ``bootstrap_method_`` says how the resamples were drawn).

    Examples
    --------
    >>> from sklearn_pycc import PolyCCRegressor, datasets
    >>> df = datasets.make_duffing(n_samples=500)
    >>> model = PolyCCRegressor(
    ...     equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
    ...     constraints=["f1 odd", "f2 odd"], degree=3)
    >>> _ = model.fit(df[["x1", "x2", "F_ext"]], df[["x1_dot", "x2_dot"]])
    >>> round(model.score(df[["x1", "x2", "F_ext"]], df[["x1_dot", "x2_dot"]]), 6)
    1.0
    """

    _parameter_constraints: dict = {
        **CCRegressor._parameter_constraints,
        "degree": [Interval(Integral, 0, None, closed="left"), dict],
        "basis": [StrOptions(set(BASES))],
        "alpha": [Interval(Real, 0, None, closed="left")],
        "extrapolation": [StrOptions({"polynomial", "linear"})],
        "param_init": [dict, None],
        "random_state": RANDOM_STATES,
        "verbose": ["verbose"],
        **RESAMPLING,
    }

    def __init__(self, *, equations=None, constraints=None, degree=7, basis: str = "legendre",
                 alpha: float = 0.0, extrapolation: str = "polynomial",
                 param_init: Mapping | None = None, gauge: str = "auto",
                 differentiation="auto", smooth_states: bool = True,
                 fit_mode: str = "auto", shooting_window: int = 40,
                 shooting_iterations: int = 30, equation_weights=None,
                 random_state=None, n_bootstrap: int = 0,
                 n_jobs: int | None = None, input_hold: str = "auto",
                 noise_model: str | None = None,
                 quantities: Mapping[str, str] | None = None,
                 process_noise: Mapping | None = None,
                 measurement_noise: Mapping | None = None,
                 initial_state: Mapping | None = None, verbose: int = 0) -> None:
        super().__init__(equations=equations, constraints=constraints, gauge=gauge,
                         differentiation=differentiation, smooth_states=smooth_states,
                         fit_mode=fit_mode, shooting_window=shooting_window,
                         shooting_iterations=shooting_iterations,
                         equation_weights=equation_weights, input_hold=input_hold,
                         noise_model=noise_model, quantities=quantities,
                         process_noise=process_noise, measurement_noise=measurement_noise,
                         initial_state=initial_state)
        self.degree = degree
        self.basis = basis
        self.alpha = alpha
        self.extrapolation = extrapolation
        self.param_init = param_init
        self.random_state = random_state
        self.verbose = verbose
        self.n_bootstrap = n_bootstrap
        self.n_jobs = n_jobs

    def _make_backend(self) -> PolyBackend:
        return PolyBackend(**self._backend_settings(PolyBackend))

def _covariance(problem: Problem, design: _Design, nonlinear: list[str], theta: np.ndarray,
                fixed: Mapping[str, float], *, result: LstsqResult, layout, bases,
                system: list) -> DeferredCovariance:
    """Covariance of the free parameters and of each curve's power-series coefficients.

    Returned deferred: the Newey-West part is worked out when the table is
    first read (``covariance_``).

    The sandwich with Newey-West scores
    (:func:`~sklearn_pycc.fitting.uncertainty.covariance.sandwich`) of the
    weighted equation residuals: the linear unknowns' columns are the
    design's, the nonlinear parameters' are central differences. Point
    values, active inequality rows and nonlinear parameters at a bound hold
    the estimate; it moves only where they let it. ``result`` is the solve at
    the estimate and ``system`` its ``[A, C]``. Indexed ``a1, ...`` and
    ``f1[k]``: the coefficient of ``u^k`` with ``u = (x - center) / half``
    of the fitted :class:`PolyCurve`.
    """
    def at(values_theta):
        A, b, *_ = design.assemble({**fixed, **dict(zip(nonlinear, values_theta))})
        return A, b

    A, C = system  # the design at the estimate
    x, r = result.x, result.residual
    columns = []
    for j, value in enumerate(theta):
        h = 1e-6 * max(1.0, abs(value))
        up, down = theta.copy(), theta.copy()
        up[j] += h
        down[j] -= h
        (Au, bu), (Ad, bd) = at(up), at(down)
        columns.append(((Au @ x + bu) - (Ad @ x + bd)) / (2 * h))
    m = len(nonlinear)
    J = np.hstack([np.column_stack(columns), A]) if columns else A
    rows = [] if C is None else [np.r_[np.zeros(m), c] for c in C]
    G, h = design.inequalities(layout, bases)
    if G is not None:
        active = np.abs(G @ x - h) <= 1e-9 * (1.0 + np.abs(h))
        rows += [np.r_[np.zeros(m), g] for g in G[active]]
    bounds = problem.bounds
    for j, name in enumerate(nonlinear):
        low, high = bounds.get(name, (-np.inf, np.inf))
        if np.isclose(theta[j], low) or np.isclose(theta[j], high):
            rows.append(np.eye(J.shape[1])[j])
    n = problem.data.n_samples
    parts = sandwich(J, r, n, problem.data.trajectory, np.array(rows) if rows else None,
                     gram=None if columns else result.gram)
    # from basis coefficients to the fitted curves' power series
    names, blocks = list(nonlinear), [np.eye(m)]
    for name, size in layout:
        if name in bases:
            basis = bases[name]
            blocks.append(basis.to_power())
            names += [f"{name}[{k}]" for k in range(basis.degree + 1)]
        else:
            blocks.append(np.eye(size))
            names.append(name)
    return DeferredCovariance(parts, block_diag(*blocks), names)


def _refine(residual, start: np.ndarray, m: int) -> np.ndarray:
    """Local least squares over the magnitudes (in logs) of parameters of fixed signs."""
    sign = np.where(start < 0, -1.0, 1.0)
    s0 = np.log(np.maximum(np.abs(start), 1e-12))

    def fun(s):
        return residual(sign * np.exp(np.clip(s, -700, 700)))

    sol = least_squares(fun, s0, method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                        max_nfev=_MAX_NFEV * (m + 1))
    return sign * np.exp(sol.x)


def _refine_bounded(residual, start: np.ndarray, low: np.ndarray, high: np.ndarray,
                    m: int) -> np.ndarray:
    """Local least squares over the parameters themselves, within their bounds."""
    sol = least_squares(residual, np.clip(start, low, high), bounds=(low, high), method="trf",
                        x_scale=np.maximum(np.abs(start), 1e-3), xtol=1e-12, ftol=1e-12,
                        gtol=1e-12, max_nfev=_MAX_NFEV * (m + 1))
    return np.clip(sol.x, low, high)


def _prefer_positive(theta: np.ndarray, best: float, cost, low: np.ndarray,
                     high: np.ndarray) -> np.ndarray:
    """Flip negative parameters whose sign the model cannot see.

    ``a2 tanh(a3 x)`` equals ``(-a2) tanh(-a3 x)``: such discrete symmetries
    leave the cost unchanged once the linear parameters are re-solved; the
    positive representative is reported (when its bounds admit it).
    """
    theta = theta.copy()
    for k in np.flatnonzero(theta < 0):
        if not low[k] <= -theta[k] <= high[k]:
            continue
        trial = theta.copy()
        trial[k] = -trial[k]
        c = cost(trial)
        # costs are of weighted residuals (each equation scaled to unit RMS)
        if c <= best * (1 + 1e-9) + 1e-12:
            theta, best = trial, min(best, c)
    return theta




def polynomial_stand_in(estimator: CCRegressor) -> PolyCCRegressor:
    """A :class:`PolyCCRegressor` with the settings every estimator shares.

    Taken from ``estimator``: a quick fit of the same skeleton where many are
    needed (the search for the delays of inputs read late).
    """
    shared = inspect.signature(CCRegressor.__init__).parameters
    return PolyCCRegressor(**{name: value for name, value
                              in estimator.get_params(deep=False).items() if name in shared})
