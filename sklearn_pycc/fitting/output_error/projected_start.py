"""Where to start an output-error fit with unmeasured states: the measured equations projected.

A common factor on every parameter
(:func:`~sklearn_pycc.fitting.output_error.hidden.scaled_start`) finds
the record's time scale but keeps the default ratios between the
parameters, and with an unmeasured state those set the levels it runs at:
every rate 1 puts both tanks of a cascade at one level, far above the
record's, and the best start found is then a model that barely moves.

The parameters of the measured states' equations that enter them linearly
and appear nowhere else (``a3`` and ``a4`` of ``x2_dot = a3 sqrt(x1) - a4
sqrt(x2)``, ``x1`` unmeasured) need no search: once the unmeasured states'
course is known they follow from the measured states' estimated
derivatives by least squares, as in an equation-error fit. That course
depends on the few other parameters only (those of the unmeasured states'
equations), with the measured states read from the record: those are
searched on a grid of factors, each point completed by least squares; the
points the equation error ranks best are judged by simulating the whole
model over the record, and the grid is refined around the best.
"""

from __future__ import annotations

import itertools
import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from ...exceptions import SimulationError
from ...skeleton import Skeleton
from ...skeleton.equations import unknown_names
from ...skeleton.skeleton import simulate_system
from ..problem import Problem
from .whole_record import equilibrium

__all__ = ["projected_start"]

#: at most this many parameters of the unmeasured states' equations are searched on a grid
MAX_SEARCHED = 2

#: powers of ten the searched parameters are scaled by, coarse grid then refinement
COARSE = np.arange(-4.0, 2.01, 1.0)
FINE = (-0.5, 0.0, 0.5)

#: points of the coarse grid, best by the equation error, judged by simulation
JUDGED = 8


def projected_start(problem: Problem, params: Mapping[str, float], given: Sequence[str],
                    judge: Callable[[Mapping[str, float]], float], *,
                    grid: Sequence[float] | None = None
                    ) -> tuple[dict[str, float], float] | None:
    """The best start found by projecting out the measured equations' linear parameters.

    Parameters
    ----------
    problem : Problem
        A problem with unmeasured states and estimated derivatives of the
        measured ones (``problem.y``).
    params : dict
        Every free parameter's starting value.
    given : sequence of str
        Parameters ``param_init`` gave: they stay.
    judge : callable
        ``judge(params) -> error`` of a whole-record simulation.
    grid : sequence of float, optional
        Powers of ten the searched parameters' starting values are scaled
        by on the coarse grid (the rates the record can show); by default
        :data:`COARSE`.

    Returns
    -------
    (params, error) or None
        None when the skeleton has no such split (no measured equation with
        linear parameters of its own, or more than :data:`MAX_SEARCHED`
        others to search).
    """
    split = _split(problem, params, given)
    if split is None:
        return None
    linear, searched, hidden_course = split
    base = {a: float(params[a]) for a in searched}

    def completed(powers) -> tuple[float, dict, tuple] | None:
        """``(equation error, parameters, powers)`` of a grid point, None if it fails."""
        outer = {a: float(base[a] * 10.0 ** p) for a, p in zip(searched, powers)}
        if not _within(problem, outer):
            return None
        course = hidden_course(outer)
        found = None if course is None else linear(outer, course)
        return None if found is None else (found[1], {**params, **outer, **found[0]}, powers)

    grid = COARSE if grid is None else grid
    coarse = [point for point in map(completed, itertools.product(grid, repeat=len(searched)))
              if point is not None]
    # the equation error ranks the grid; the few best are judged by simulation
    coarse.sort(key=lambda point: point[0])
    judged = [(judge(trial), powers, trial) for _, trial, powers in coarse[:JUDGED]]
    if not judged:
        return None
    error, centre, best = min(judged, key=lambda found: found[0])
    for step in itertools.product(FINE, repeat=len(searched)):
        point = completed(tuple(c + s for c, s in zip(centre, step))) if any(step) else None
        if point is not None:
            trial_error = judge(point[1])
            if trial_error < error:
                error, best = trial_error, point[1]
    return best, error


def _within(problem: Problem, values: Mapping[str, float]) -> bool:
    bounds = problem.bounds
    return all(bounds.get(a, (-np.inf, np.inf))[0] <= v <= bounds.get(a, (-np.inf, np.inf))[1]
               for a, v in values.items())


def _split(problem: Problem, params: Mapping[str, float], given: Sequence[str]):
    """``(linear, searched, hidden_course)`` for :func:`projected_start`, or None."""
    skeleton = problem.skeleton
    measured = [i for i, eq in enumerate(problem.dynamic) if eq.state in problem.measured]
    hidden = [eq for eq in problem.dynamic if eq.state in problem.hidden]
    if not measured or not hidden or skeleton.functions:
        return None
    free = [a for a in params if a not in given and a not in skeleton.limit_params]
    in_hidden = set().union(*(unknown_names(eq.residual)[1] for eq in hidden))
    elsewhere = set().union(*(unknown_names(eq.residual)[1]
                                     for eq in problem.equations if getattr(eq, "output", None)))
    in_measured = set().union(*(unknown_names(problem.dynamic[i].residual)[1]
                                for i in measured))
    inner = [a for a in free if a in in_measured and a not in in_hidden | elsewhere]
    searched = [a for a in free if a in in_hidden]
    if not inner or not searched or len(searched) > MAX_SEARCHED or any(
            params[a] == 0 for a in searched):
        return None
    return (_least_squares(problem, params, inner, measured),
            searched, _hidden_course(problem, params, hidden))


def _hidden_course(problem: Problem, params: Mapping[str, float], hidden):
    """``course(values)``: the unmeasured states on the data's rows, the measured ones read.

    The unmeasured states' equations alone, the measured states in them
    read from the (smoothed) record as inputs, each experiment started at
    rest with its first sample; None where that cannot be integrated. (An
    adaptive integrator: the grid visits rates far faster than the record's.)
    """
    texts = [eq.text for eq in hidden]
    limits = problem.skeleton.limits
    ends = [f"{s} <= {hi:.17g}" for s, (_, hi) in limits.items()
            if s in problem.hidden and not isinstance(hi, str) and np.isfinite(hi)]
    ends += [f"{s} >= {lo:.17g}" for s, (lo, _) in limits.items()
             if s in problem.hidden and not isinstance(lo, str) and np.isfinite(lo)]
    sub = Skeleton(texts, constraints=ends)
    drive = {name: problem.smoothed.get(name, problem.signals.get(name))
             for name in sub.inputs if name != "t"}
    if any(values is None for values in drive.values()):
        return lambda values: None
    n = len(next(iter(problem.measured.values())))
    rows = np.arange(len(problem.y)) if problem.rows is None else problem.rows
    fixed = {a: v for a, v in {**problem.fixed_params, **params}.items() if a in sub.params}

    def course(values: Mapping[str, float]) -> dict[str, np.ndarray] | None:
        system = sub.compile({}, {**fixed, **{a: v for a, v in values.items()
                                              if a in sub.params}})
        out = {s: np.full(n, np.nan) for s in sub.states}
        for experiment in problem.experiments:
            at = experiment.rows
            first = {name: float(v[at[0]]) for name, v in drive.items()}
            first["t"] = float(experiment.t[0])
            rest = equilibrium(system, sub.states, first)
            start = [float(np.clip(rest[s], *system.limits.get(s, (-np.inf, np.inf))))
                     for s in sub.states]
            try:
                with warnings.catch_warnings(), np.errstate(all="ignore"):
                    warnings.simplefilter("ignore")
                    simulated = simulate_system(
                        system, experiment.t, start, {name: v[at] for name, v in drive.items()},
                        input_hold=problem.input_hold)
            except (SimulationError, ArithmeticError, ValueError):
                return None
            for s in sub.states:
                out[s][at] = simulated[s].to_numpy(dtype=float)
        if not all(np.all(np.isfinite(v)) for v in out.values()):
            return None
        return {s: v[rows] for s, v in out.items()}

    return course


def _least_squares(problem: Problem, params: Mapping[str, float], inner: Sequence[str],
                   measured: Sequence[int]):
    """``linear(values, course)``: ``inner`` fitted to the measured states' derivatives.

    Their equations are affine in ``inner`` (checked on the data); each
    equation's residuals are scaled by its derivative's spread. Returns the
    fitted values and the RMS of the scaled residuals; None where the
    equations are not affine or the fit fails.
    """
    data = {name: problem.data[name] for name in problem.data.columns}
    n = problem.data.n_samples
    targets = problem.y[:, measured]
    scale = np.nanstd(targets, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    skeleton = problem.skeleton
    functions = {name: (lambda v: 0.0 * v) for name in skeleton.functions}

    def rates(values: Mapping[str, float], columns) -> np.ndarray:
        system = skeleton.compile(functions, {**problem.fixed_params, **values})
        with np.errstate(all="ignore"):
            return system.evaluate(columns, n, hold=False)[:, measured]

    def linear(values: Mapping[str, float], course) -> tuple[dict[str, float], float] | None:
        columns = {**data, **course}
        point = {**params, **values}
        zero = rates({**point, **dict.fromkeys(inner, 0.0)}, columns)
        design = [rates({**point, **dict.fromkeys(inner, 0.0), a: 1.0}, columns) - zero
                  for a in inner]
        # affine: a point off the unit vectors lies on the plane through them
        probe = {a: 2.0 + k for k, a in enumerate(inner)}
        if not np.allclose(rates({**point, **probe}, columns),
                           zero + sum(v * d for v, d in zip(probe.values(), design)),
                           rtol=1e-6, atol=1e-9, equal_nan=True):
            return None
        A = np.stack([d / scale for d in design], axis=-1).reshape(-1, len(inner))
        b = ((targets - zero) / scale).ravel()
        keep = np.isfinite(b) & np.all(np.isfinite(A), axis=1)
        if keep.sum() <= len(inner):
            return None
        theta = np.linalg.lstsq(A[keep], b[keep], rcond=None)[0]
        bounds = problem.bounds
        theta = np.array([np.clip(v, *bounds.get(a, (-np.inf, np.inf)))
                          for a, v in zip(inner, theta)])
        error = float(np.sqrt(np.mean((A[keep] @ theta - b[keep]) ** 2)))
        return dict(zip(inner, theta.tolist())), error

    return linear
