"""Many starts, few polishes: the whole-record pass of an output-error fit with unmeasured states.

A fit with a state nobody measures has several starts (multiple shooting's
estimates, their rescalings, a start from the ratios, a cascade's stages
swapped, another input hold). Polishing each to convergence by
whole-record simulation costs tens of integrations an iteration, and most
end where the best one does. :class:`StartContest` polishes the start whose
simulation follows the record best to the end; every other is polished a
few evaluations, and to the end only where it then comes close to the best.
It keeps a row for every start, which the estimator shows as ``starts_``,
and says when two starts end equally well at different parameters.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ...measurements.noise import second_difference_level
from ..problem import Problem
from .hidden import single_shooting
from .whole_record import WholeRecord, zero_curves

__all__ = ["StartContest", "noise_floor"]

#: evaluations of the whole record a start is polished on trial; half as many for a start
#: at another's numbers (under another input hold), which has no way down left to go
TRIAL_EVALUATIONS = 4

#: a start polished on trial is polished to the end when its error is within this factor
#: of the leader's
CONTENDING = 1.25

#: two starts disagree when a parameter differs by more than this share of the larger
DISAGREEING = 0.1

#: rounds of trial a far start may have while its error falls by STILL_FALLING a round
TRIAL_ROUNDS = 6
STILL_FALLING = 0.1

#: a fit whose error is within this factor of the record's noise floor has nothing left
#: for another start to win
SETTLED = 1.1

#: a start polished on trial has joined the leader's minimum when no parameter differs
#: from the leader's by more than this share of the larger
JOINED = 0.01


def _residuals(problem: Problem) -> int:
    """How many errors a whole-record fit of ``problem`` compares: samples times signals."""
    signals = sum(s in problem.measured for s in problem.skeleton.states) + len(problem.observed)
    return sum(e.n_samples for e in problem.experiments) * max(signals, 1)


def _largest_gap(params: Mapping[str, float], other: Mapping[str, float],
                 forms: Mapping | None = None) -> tuple[float, str, float, float]:
    """The largest relative difference of a parameter both give: its name and both values.

    A curve written out through unmeasured states (``forms``, each a
    :class:`~sklearn_pycc.fitting.output_error.hidden_curves.CurveForm`) is
    compared as a curve, not number by number (many numbers make much the
    same curve): its largest difference over its range, relative to its
    largest value there, named at that point (``f1(3.2)``).
    """
    forms = forms or {}
    numbers = {n for form in forms.values() for n in form.names}
    gap, name, mine, theirs = 0.0, "", math.nan, math.nan
    for a, value in params.items():
        if a not in other or a in numbers:
            continue
        scale = max(abs(value), abs(other[a]))
        relative = abs(value - other[a]) / scale if scale > 0 else 0.0
        if relative > gap:
            gap, name, mine, theirs = relative, a, value, other[a]
    for form in forms.values():
        if not all(n in params and n in other for n in form.names):
            continue
        x = np.linspace(*form.domain, 50)
        u = (x - form.center) / form.half
        a = np.polynomial.Polynomial(form.series(params))(u)
        b = np.polynomial.Polynomial(form.series(other))(u)
        scale = max(float(np.max(np.abs(a))), float(np.max(np.abs(b))))
        k = int(np.argmax(np.abs(a - b)))
        relative = abs(a[k] - b[k]) / scale if scale > 0 else 0.0
        if relative > gap:
            gap, name, mine, theirs = relative, f"{form.name}({x[k]:.4g})", a[k], b[k]
    return gap, name, float(mine), float(theirs)


def noise_floor(problem: Problem) -> float | None:
    """The normalised RMSE a perfect model would leave: the measured states' white noise.

    Each measured state's noise level read from its second differences
    within each experiment
    (:func:`~sklearn_pycc.measurements.noise.second_difference_level`), over its
    RMS as :class:`~sklearn_pycc.fitting.output_error.whole_record.WholeRecord`
    scales the errors. Noise correlated in time reads low here (its second
    differences cancel), so a fit is never taken as settled too early; None
    where the skeleton reads a static output (a sensor's equation) or no
    experiment has three samples.
    """
    measured = [s for s in problem.skeleton.states if s in problem.measured]
    if problem.observed or not measured:
        return None
    shares = []
    for s in measured:
        values = np.asarray(problem.measured[s], dtype=float)
        level = second_difference_level([values[e.rows] for e in problem.experiments])
        if not np.isfinite(level):
            return None
        scale = float(np.sqrt(np.nanmean(values ** 2))) or 1.0
        shares.append((level / scale) ** 2)
    floor = float(np.sqrt(np.mean(shares)))
    return floor if np.isfinite(floor) and floor > 0 else None


@dataclass
class StartContest:
    """The starts of a whole-record fit, polished as far as each earns.

    Starts are entered in rounds (:meth:`try_all`): each is polished on
    trial (:data:`TRIAL_EVALUATIONS`) and waits; :meth:`decide` polishes the
    best of those to the end, and each other where it contends. A start
    entered alone later (:meth:`enter`) is tried and decided at once.

    Parameters
    ----------
    substeps, iterations : int
        The simulation's Runge-Kutta substeps per sample, and the most
        iterations of a whole polish
        (:func:`~sklearn_pycc.fitting.output_error.hidden.single_shooting`).
    floor : float, optional
        The record's noise floor (:func:`noise_floor`): a contest whose best
        start, tried or polished, is within :data:`SETTLED` of it is
        :attr:`settled`.
    """

    substeps: int
    iterations: int
    floor: float | None = None
    rows: list = field(default_factory=list)
    best: tuple | None = None
    #: the problem the leader was polished under (another input hold may win)
    problem: Problem | None = None
    #: every start polished to the end: (nrmse, params)
    finished: list = field(default_factory=list)
    #: starts tried and waiting for :meth:`decide`: (row, problem, found, near)
    waiting: list = field(default_factory=list)

    @property
    def leading_error(self) -> float:
        """The least error of a start so far, polished or waiting (inf before any)."""
        errors = [found[2] for _, _, found, _ in self.waiting]
        return min([*errors, np.inf if self.best is None else self.best[2]])

    @property
    def settled(self) -> bool:
        """Whether a start simulates the record about as well as its noise allows."""
        return self.floor is not None and self.leading_error <= SETTLED * self.floor

    def screen(self, problem: Problem, params: Mapping[str, float],
               first: np.ndarray) -> float:
        """The normalised RMSE of the record simulated whole from a start, unpolished."""
        whole = WholeRecord(problem)
        whole.windows.substeps = int(self.substeps)
        system = problem.skeleton.compile(zero_curves(problem),
                                          {**problem.fixed_params, **params})
        with np.errstate(all="ignore"):
            errors = whole.errors(system, np.asarray(first, dtype=float))
        return float(np.sqrt(np.mean(errors ** 2)))

    def try_all(self, entries: Sequence[tuple[str, Problem, Mapping[str, float],
                                              np.ndarray, bool]]) -> None:
        """Try ``(label, problem, params, first, near)`` starts; they wait for :meth:`decide`.

        ``near`` marks a start at the numbers of another (the same under
        another input hold): it has no way down left to go, and contends
        only within chance of the leader (twice the unknowns over the
        residuals, relative to the squared error).
        """
        for label, problem, params, first, near in entries:
            row = {"start": label, "nrmse_start": self.screen(problem, params, first)}
            found = single_shooting(problem, params, first, self.substeps, self.iterations,
                                    max_evaluations=min(TRIAL_EVALUATIONS // (1 + near),
                                                        self.iterations))
            row.update(nrmse=found[2], polished="trial", kept=False)
            self.rows.append(row)
            self.waiting.append((row, problem, found, near))

    def decide(self) -> None:
        """Polish the best waiting start to the end (if it may lead), then each that contends.

        A start contends when its trial ends within :data:`CONTENDING` of
        the leader's error away from the leader's minimum (it has not
        :data:`JOINED` it); a ``near`` one within chance of it. A far start
        still falling fast is tried further first (:meth:`_trial_rounds`).
        """
        waiting, self.waiting = sorted(self.waiting, key=lambda w: w[2][2]), []
        for row, problem, found, near in waiting:
            if self.best is not None:
                found = self._trial_rounds(row, problem, found, near)
                if found is None:
                    continue
            found = self._polish(problem, found[0], found[1])
            row.update(nrmse=found[2], polished="whole")
            if self.best is None or found[2] < self.best[2]:
                self.best, self.problem = found, problem
                for other in self.rows:
                    other["kept"] = other is row

    def _contends(self, problem: Problem, found: tuple, near: bool) -> bool:
        if near:
            unknowns = len(found[0]) + found[1].size
            chance = 2.0 * unknowns / max(_residuals(problem), 1)
            return found[2] ** 2 <= self.best[2] ** 2 * (1 + chance)
        joined = _largest_gap(found[0], self.best[0])[0] <= JOINED
        return found[2] <= CONTENDING * self.best[2] and not joined

    def _trial_rounds(self, row: dict, problem: Problem, found: tuple,
                      near: bool) -> tuple | None:
        """A tried start that contends with the leader, tried further while it falls fast.

        A far start (not ``near``) that does not contend yet but whose error
        fell by :data:`STILL_FALLING` or more in its last round of trial is
        tried another round, up to :data:`TRIAL_ROUNDS`. None where it drops
        out (the row keeps its last trial's error).
        """
        before = row["nrmse_start"]
        for _ in range(1 if near else TRIAL_ROUNDS):
            if self._contends(problem, found, near):
                return found
            if near or not found[2] <= (1 - STILL_FALLING) * before:
                break
            before = found[2]
            found = single_shooting(problem, found[0], found[1], self.substeps,
                                    self.iterations, max_evaluations=TRIAL_EVALUATIONS)
            row.update(nrmse=found[2])
        return found if self._contends(problem, found, near) else None

    def enter(self, problem: Problem, label: str, params: Mapping[str, float],
              first: np.ndarray) -> None:
        """Try one start and decide it at once (:meth:`try_all`, :meth:`decide`)."""
        self.try_all([(label, problem, params, first, False)])
        self.decide()

    def _polish(self, problem, params, first):
        found = single_shooting(problem, params, first, self.substeps, self.iterations)
        self.finished.append((found[2], dict(found[0])))
        return found

    def table(self) -> pd.DataFrame:
        """One row per start: its error before and after polishing, how far, and the one kept."""
        return pd.DataFrame(self.rows, columns=["start", "nrmse_start", "nrmse", "polished",
                                                "kept"])

    def disagreement(self) -> str | None:
        """Where two starts polished to the end fit equally well with different parameters.

        Equally well: the squared errors differ by less than chance would
        make them (twice the unknowns over the residuals, relative). Returns
        the words naming the parameter that differs most and its two
        values, or None.
        """
        if self.best is None:
            return None
        best_error, best_params = self.best[2], self.best[0]
        unknowns = len(best_params) + self.best[1].size
        chance = 2.0 * unknowns / max(_residuals(self.problem), 1)
        worst = None
        forms = getattr(self.problem.skeleton, "forms", None) if self.problem else None
        for error, params in self.finished:
            if not error ** 2 <= best_error ** 2 * (1 + chance):
                continue
            gap, name, mine, theirs = _largest_gap(best_params, params, forms)
            if gap > DISAGREEING and (worst is None or gap > worst[0]):
                worst = (gap, name, mine, theirs, error)
        if worst is None:
            return None
        _, name, mine, value, error = worst
        return (f"{name} is {mine:.4g} in the fit kept and {value:.4g} in another start's, "
                f"which simulates the record as well (NRMSE {error:.4g} against "
                f"{best_error:.4g})")
