"""Laws in place of a skeleton's terms, and effects added, for a model with states no sensor reads.

A model whose states are not all measured has no derivative residual to
screen a catalogue effect on: each move is judged by simulating the record.
The moves are the replacements of the skeleton's own terms by the laws the
catalogue says may take their place (a linear outflow by Torricelli's, with
the flow it carries into the next tank; a linear heat path by a radiating
one), the inputs read another way (a pump that levels off, a valve's
characteristic, a delay) and the catalogue's effects added (an offset, a
drift, another outflow), in the equations of measured and unmeasured states
alike. Each starts where the model is: its own numbers, and the new law's
matched to the terms it changes along the model's simulated course (an added
effect starts where it changes the least). Every move is refitted on
trial (a few evaluations of the record by output error), the few best to the
end, and :func:`~sklearn_pycc.diagnostics._unmeasured.diagnose_unmeasured`
weighs them beside the state limits.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ..measurements.noise import second_difference_level
from ._candidates import (
    Candidate,
    enumerate_candidates,
    enumerate_input_moves,
    enumerate_moves,
    extend,
)
from ._refit import prepared
from ._roles import equation_roles

__all__ = ["LEADERS", "MoveTrial", "law_trials", "noise_share", "special_case", "thinned"]

#: moves refitted to the end, the best on trial
LEADERS = 2

#: the output-error iterations of a trial refit
TRIAL_ITERATIONS = 3

#: a trial refit reads at most about this many samples (every k-th row of the record)
TRIAL_SAMPLES = 400

#: trial errors within this relative difference are one (the record cannot tell the moves apart)
TRIAL_TIE = 1e-3

#: what the catalogue's constant sources act through
SOURCES = ("none",)

#: a matched new number below this is zero (the fit then steps it by an absolute amount)
NEGLIGIBLE = 1e-12

#: no law is tried where the model simulates the record within this factor of its noise
AT_NOISE = 1.2


def thinned(X: pd.DataFrame) -> pd.DataFrame:
    """Every k-th row of the record, k the least that leaves about :data:`TRIAL_SAMPLES`."""
    return X.iloc[::max(1, len(X) // TRIAL_SAMPLES)]


def noise_share(X: pd.DataFrame, names) -> float:
    """The measured signals' white noise over their spread (as the simulation error reads them).

    Each signal's noise read from its second differences
    (:func:`~sklearn_pycc.measurements.noise.second_difference_level`); noise
    correlated in time reads low, so laws are never skipped on it. The root
    mean square over the signals.
    """
    shares = []
    for name in names:
        values = X[name].to_numpy(dtype=float)
        level = second_difference_level([values[np.isfinite(values)]])
        spread = float(np.nanstd(values))
        if np.isfinite(level) and spread > 0:
            shares.append((level / spread) ** 2)
    return float(np.sqrt(np.mean(shares))) if shares else 0.0


@dataclass
class MoveTrial:
    """One replacement tried: the candidate, its refitted model and its simulation errors."""

    candidate: Candidate
    refit: object | None
    nrmse: float
    delta_bic: float = math.nan
    removed: float = math.nan
    held_out: object = None
    failure: str = ""


def _matched_start(model, candidate: Candidate, course: pd.DataFrame) -> dict[str, float]:
    """The model's numbers, and the new law's fitted to the rates it replaces on ``course``.

    ``course`` holds every state simulated by the model, the inputs and
    ``t``. The new parameters are chosen so that the changed equations'
    rates follow the model's along that course (least squares, each
    equation over its spread); a parameter the law brings starts at 1
    where that fails.
    """
    skeleton, extended = model.skeleton_, candidate.extended
    kept = {a: float(v) for a, v in model.params_.items() if a in extended.params}
    new = list(candidate.new_params)
    if not new:
        return kept
    columns = {name: course[name].to_numpy(dtype=float) for name in course.columns}
    n = len(course)
    changed = sorted({k for k, _ in (*candidate.additions, *candidate.removals)})
    with np.errstate(all="ignore"):
        target = skeleton.compile(model.functions_, model.params_).evaluate(columns, n)[:, changed]
    spread = np.nanstd(target, axis=0)
    spread = np.where(spread > 0, spread, 1.0)
    bounds = extended.bounds
    low = np.array([bounds.get(a, (-np.inf, np.inf))[0] for a in new], dtype=float)
    high = np.array([bounds.get(a, (-np.inf, np.inf))[1] for a in new], dtype=float)

    def misfit(theta: np.ndarray) -> np.ndarray:
        values = {**kept, **dict(zip(new, theta))}
        with np.errstate(all="ignore"):
            rates = extended.compile({}, values).evaluate(columns, n)[:, changed]
        out = ((rates - target) / spread).ravel()
        return np.where(np.isfinite(out), out, 1e3)

    start = np.clip(np.ones(len(new)), low, high)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found = least_squares(misfit, start, bounds=(low, high), x_scale="jac",
                                  max_nfev=100 * len(new)).x
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        found = start
    # a term that only adds error is matched at a rounding error of zero (1e-25); the fit's
    # steps are shares of each number, and from there they would not move it at all
    found = np.where(np.abs(found) < NEGLIGIBLE, 0.0, found)
    return {**kept, **dict(zip(new, (float(v) for v in found)))}


def special_case(simple: Candidate, general: Candidate) -> bool:
    """Whether ``general``'s effect holds ``simple``'s, added to the same equations."""
    return (simple.effect.name in general.effect.generalises
            and simple.move == general.move == "add"
            and [k for k, _ in simple.additions] == [k for k, _ in general.additions])


def _kind(candidate: Candidate) -> str:
    """"law" (the skeleton's own terms replaced), "input" (an input read another way), "added"."""
    if candidate.move != "replace":
        return "added"
    return "input" if candidate.effect.acts_through == "input" else "law"


def _fit(model, X: pd.DataFrame, skeleton, init: dict, **settings):
    estimator = prepared(model, equations=skeleton, param_init=init, hold_as_fitted=True,
                         **settings)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return estimator.fit(X)


def law_trials(model, X: pd.DataFrame, course: pd.DataFrame | None, *, base: float, n: int,
               quantities, units: dict, nrmse) -> list[MoveTrial]:
    """Every law in place of the skeleton's terms, and every effect added, tried and refitted.

    Parameters
    ----------
    model : CCRegressor
        The fitted model with unmeasured states.
    X : DataFrame
        The record.
    course : DataFrame or None
        Every state simulated by the model over the record (None: it escaped,
        and nothing is tried).
    base : float
        The model's simulation error (normalised RMSE of what is measured).
    n : int
        The measured samples, for the information criterion.
    quantities, units : mapping
        What each state measures, naming the laws in its field's words.
    nrmse : callable
        ``nrmse(model, X)``: the simulation error a refit is judged by.

    Returns
    -------
    list of MoveTrial
        The :data:`LEADERS` best by their trial refit (on every k-th row,
        :data:`TRIAL_SAMPLES`), and the best of each kind of move (a law of
        the skeleton's terms, an input read another way, an effect added),
        each refitted to the whole record and scored
        (``delta_bic`` against the model, ``removed``: the share of its
        simulation error), then the others as tried; none where the model
        already simulates the record within :data:`AT_NOISE` of its noise
        (:func:`noise_share`).
    """
    skeleton = model.skeleton_
    if course is None or "t" not in X.columns:
        return []
    measured = [c for c in [*skeleton.states, *skeleton.outputs] if c in X.columns]
    if base <= AT_NOISE * noise_share(X, measured):
        return []  # the model follows the record to its noise: no law has anything to take
    # the trials read every k-th row (the few best are refitted on the whole record)
    trial_rows = thinned(X)
    roles = equation_roles(skeleton, quantities, units)
    # the own terms' laws everywhere; inputs read another way and effects added in the
    # equations of the states no sensor reads; a constant source (a load) in every equation:
    # a measured state's own source shows in no equation of the hidden ones (one changing
    # in time is not tried there: a drift follows noise correlated in time, and a record
    # whose model lacks nothing named one in the room's balance)
    inside = {eq.index for eq in skeleton.parsed
              if eq.state not in X.columns or not X[eq.state].notna().any()}
    candidates = [*(c for c in enumerate_moves(skeleton, roles, True) if c.move == "replace"),
                  *(c for c in [*enumerate_input_moves(skeleton, roles),
                                *enumerate_candidates(skeleton, roles, True)]
                    if {k for k, _ in c.additions} <= inside
                    or c.effect.acts_through in SOURCES)]
    trials = []
    for candidate in candidates:
        try:
            extend(skeleton, candidate)
            if candidate.extended.delay_params:
                continue  # a delay is searched by equation error, which no hidden state allows
            init = _matched_start(model, candidate, course)
            refit = _fit(model, trial_rows, candidate.extended, init,
                         shooting_iterations=TRIAL_ITERATIONS)
            error = float(refit.shooting_["nrmse_whole"])
        except Exception as exc:  # a move that cannot be fitted is reported, not raised
            trials.append(MoveTrial(candidate, None, math.nan, failure=str(exc)))
            continue
        trials.append(MoveTrial(candidate, refit, error))
    # trials the record cannot tell apart (a load on a room's air or on its unmeasured walls)
    # in the measured states' equations first
    measured = {eq.index for eq in skeleton.parsed} - inside

    def order(trial: MoveTrial) -> tuple:
        if not (math.isfinite(trial.nrmse) and trial.nrmse > 0):
            return True, 0, False
        return (False, round(math.log(trial.nrmse) / TRIAL_TIE),
                not {k for k, _ in trial.candidate.additions} <= measured)

    trials.sort(key=lambda t: (not math.isfinite(t.nrmse), t.nrmse))
    trials.sort(key=order)  # stable: ties alone reordered
    # the best few, and the best of each kind of move: a law of the skeleton's own terms, an
    # input read another way, an effect added (an offset may mimic a law's curvature on trial)
    leaders = trials[:LEADERS]
    for kind in ("law", "input", "added"):
        best = next((t for t in trials if t.refit is not None and _kind(t.candidate) == kind),
                    None)
        if best is not None and best not in leaders:
            leaders.append(best)
    # the special cases a leader holds (an offset beside a drift), judged beside it
    leaders += [t for t in trials if t.refit is not None and t not in leaders
                and any(special_case(t.candidate, leader.candidate) for leader in leaders)]
    for trial in leaders:
        if trial.refit is None:
            continue
        try:
            trial.refit = _fit(model, X, trial.candidate.extended,
                               {a: float(v) for a, v in trial.refit.params_.items()})
        except Exception as exc:
            trial.refit, trial.failure = None, str(exc)
            continue
        trial.nrmse = nrmse(trial.refit, X)
        comparable = math.isfinite(trial.nrmse) and math.isfinite(base) and base > 0
        if comparable and trial.nrmse > 0:
            trial.removed = 1 - trial.nrmse / base
            trial.delta_bic = (2 * n * math.log(trial.nrmse / base)
                               + trial.candidate.n_change * math.log(n))
    return trials
