"""A second minimum of an output-error fit: two stages' speeds swapped.

Two first-order stages in series pass the input on alike whichever of them
is the faster (two lags commute), so where one stage has no sensor the
record tells the two orders apart only through what is not linear in them:
the square-root outflows of a cascade of tanks, a rim one of them reaches.
Output error then has a minimum for each order, and a search that settles
in the wrong one (the upper tank fast and the lower slow, where the truth
is the other way round) follows the record nearly as well.

Multiplying an equation's right-hand side by ``c`` keeps its equilibria and
changes only how fast its state moves. Where an equation's own parameters
(those it alone uses) scale it so, as every rate of ``x1_dot = a1 u - a2
sqrt(x1)`` does, the fit's two stages are given each other's speed and
the model is polished by whole-record simulation from there; the better
fit wins.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np

from ...skeleton.equations import unknown_names
from ..problem import Problem
from .hidden import rates_on, settled_error
from .whole_record import WholeRecord, zero_curves

__all__ = ["speed_parameters", "swapped_starts"]

#: two stages whose speeds are closer than this ratio share one minimum: nothing to swap
LEAST_SWAP = 1.25
#: factors each swapped speed is nudged by, the start judged by simulating the record (the
#: speeds' ratio at the fit's course is only near the other minimum's)
NUDGES = (0.5, 0.71, 1.0, 1.41, 2.0)
#: an equation's own parameters scale its rate when doubling them doubles it to this share
SPEED_TOLERANCE = 1e-9


def speed_parameters(problem: Problem, params: Mapping[str, float],
                     course: Mapping[str, np.ndarray]) -> dict[str, list[str]]:
    """State -> the parameters that set its equation's speed alone.

    An equation's own free parameters (no other equation, output or limit
    uses them) set its speed where doubling all of them doubles its
    right-hand side on every row of ``course`` and leaves every other rate
    as it was; states without such parameters are left out.
    """
    skeleton = problem.skeleton
    states = list(skeleton.states)
    free = [a for a in problem.free_params if a not in skeleton.limit_params]
    used = {}
    for eq in problem.equations:
        for a in unknown_names(eq.residual)[1]:
            used.setdefault(a, set()).add(eq.state or eq.index)
    base = rates_on(problem, params, course)
    seen = np.all(np.isfinite(base), axis=1)
    found = {}
    for eq in problem.dynamic:
        own = [a for a in free if used.get(a) == {eq.state}]
        if not own or not seen.any():
            continue
        doubled = rates_on(problem, {**params, **{a: 2.0 * params[a] for a in own}}, course)
        expected = base.copy()
        q = states.index(eq.state)
        expected[:, q] *= 2.0
        size = np.abs(base[seen]).max(axis=0) + np.finfo(float).tiny
        if np.all(np.abs(doubled[seen] - expected[seen]) <= SPEED_TOLERANCE * size):
            found[eq.state] = own
    return found


def _self_rate(problem: Problem, params: Mapping[str, float],
               course: Mapping[str, np.ndarray], state: str) -> float:
    """The median over ``course``'s rows of how fast ``state``'s rate falls as it rises."""
    q = list(problem.skeleton.states).index(state)
    values = np.asarray(course[state], dtype=float)
    step = 1e-6 * np.maximum(np.abs(values), 1e-3)
    up, down = dict(course), dict(course)
    up[state], down[state] = values + step, values - step
    slope = (rates_on(problem, params, up)[:, q] - rates_on(problem, params, down)[:, q]) / (
        2 * step)
    slope = slope[np.isfinite(slope)]
    return float(np.median(slope)) if slope.size else np.nan


def swapped_starts(problem: Problem, params: Mapping[str, float], first: np.ndarray,
                   substeps: int) -> list[tuple[dict[str, float], np.ndarray]]:
    """Starts with an unmeasured stage and another given each other's speed.

    For each unmeasured state and each other state whose equations'
    speeds are set by parameters of their own (:func:`speed_parameters`),
    both stable, the two equations are scaled to each other's speed: the
    median slope of each one's rate in its own state, on the course the
    fit ``params`` runs from ``first``; each speed is then nudged by the
    factors of :data:`NUDGES` (the two still in the swapped order, at least
    :data:`LEAST_SWAP` apart), and the nudge whose simulation follows the
    record best (past each experiment's first rows, each started at rest)
    is the start, with those initial states. Stages within
    :data:`LEAST_SWAP` of each other's speed, or a start beyond the
    parameters' bounds, give none.
    """
    whole = WholeRecord(problem)
    whole.windows.substeps = int(substeps)
    system = problem.skeleton.compile(zero_curves(problem), {**problem.fixed_params, **params})
    course = whole.course(system, first)
    own = speed_parameters(problem, params, course)
    speeds = {state: _self_rate(problem, params, course, state) for state in own}
    starts = []
    for hidden in [s for s in problem.hidden if s in own and speeds[s] < 0]:
        for other in own:
            if other == hidden or not speeds[other] < 0:
                continue
            ratio = speeds[other] / speeds[hidden]
            if max(ratio, 1 / ratio) < LEAST_SWAP:
                continue
            best, best_error = None, np.inf
            for up, down in itertools.product(NUDGES, repeat=2):
                nudged = ratio * up / down
                if (nudged - 1) * (ratio - 1) <= 0 or max(nudged, 1 / nudged) < LEAST_SWAP:
                    continue  # a nudge back toward the fit's own order
                trial = dict(params)
                for state, factor in ((hidden, ratio * up), (other, down / ratio)):
                    trial.update({a: params[a] * factor for a in own[state]})
                if not all(lo <= trial[a] <= hi for a, (lo, hi) in problem.bounds.items()
                           if a in trial):
                    continue
                error, initial = settled_error(whole, problem, trial)
                if error < best_error:
                    best, best_error = (trial, initial), error
            if best is not None:
                starts.append(best)
    return starts
