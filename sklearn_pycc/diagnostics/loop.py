"""The hypothesis loop as an object: fit a skeleton, diagnose it, add what is missing, repeat."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from numbers import Integral

import numpy as np
import pandas as pd
from sklearn.base import clone

from .._utils.progress import Progress
from ..exceptions import SimulationError
from ..measurements.measurement import Measurement
from ..simulation.integration import judged_step_limit
from ..skeleton import Skeleton
from ..skeleton.nodes import Param, product_factors, rename, signed_terms, walk
from ..skeleton.printer import to_text
from ._decide import suggestion_for
from ._filter_search import likelihood_ratio_search
from ._likelihood_judge import LikelihoodJudgement, likelihood_check, whole_record
from ._refit import KEEP, prepared
from .diagnose import diagnose
from .report import Diagnosis, Suggestion

__all__ = ["HypothesisLoop", "Refinement", "Round"]


@dataclass(frozen=True)
class Round:
    """One round of the loop.

    Attributes
    ----------
    index : int
        0 for the starting skeleton.
    skeleton : Skeleton
        The skeleton fitted in this round.
    model : CCRegressor
        The fitted model.
    diagnosis : Diagnosis
        The model compared with the measurements.
    decision : str
        What the loop decided from this round's diagnosis, in words (the
        effect the next round adds, or why it stops).
    added : Suggestion or None
        This round's diagnosis's suggestion, which the next round adds (its
        model ``adds`` it in :meth:`HypothesisLoop.table`); None when the
        loop stops here.
    judge : str
        What decided: ``"held-out simulation"`` (the diagnosis's judge where
        the record has time), ``"held-out derivatives"``, or ``"held-out
        likelihood"`` where the round's model was fitted by its Kalman filter
        (process noise recognised, ``fit_mode_ == "filter"``): the
        suggestion then stands only if it raises the filter's likelihood of
        held-out samples (:attr:`likelihood`).
    likelihood : LikelihoodJudgement or None
        That judgement, where it was made.
    """

    index: int
    skeleton: Skeleton
    model: object
    diagnosis: Diagnosis
    decision: str
    added: Suggestion | None
    judge: str = "held-out simulation"
    likelihood: LikelihoodJudgement | None = None

    def __repr__(self) -> str:
        return f"<Round {self.index}: {self.decision}>"


@dataclass(frozen=True)
class Refinement:
    """The loop's last skeleton refitted by output error, and whether that pays.

    Attributes
    ----------
    model : CCRegressor
        The skeleton fitted with ``fit_mode="simulation"``, starting from the
        last round's parameters.
    before, after : float
        Held-out simulation NRMSE (pooled over the measured states, each
        normalised by its spread) of the last round's model and of ``model``,
        each refitted without every fold of the record.
    adopted : bool
        Whether ``model`` lowered it by at least 1 %: it is then the loop's
        answer, :attr:`HypothesisLoop.model`.
    folds : str
        How the record was split.
    """

    model: object
    before: float
    after: float
    adopted: bool
    folds: str

    def __str__(self) -> str:
        verdict = "adopted" if self.adopted else "not adopted"
        return (f"refined by output error: held-out simulation NRMSE {self.before:.4g} -> "
                f"{self.after:.4g} ({self.folds}): {verdict}")


def _column_meanings(columns, diagnosis: Diagnosis) -> dict[str, str]:
    """What each column of :meth:`HypothesisLoop.table` measures, in words."""
    compared = ", ".join(map(str, diagnosis.trajectories.index)) or "the states"
    meanings = {
        "n_parameters": "numbers the round's model fitted",
        "derivative_nrmse": "the worst equation's derivative error over its spread",
        "simulation_rmse": f"simulation error over the common horizon, pooled over {compared} "
                           "(measured and estimated states alike, in their own units)",
        "adds": "the effect this round's model has that the previous round's lacked",
        "suggests": "what this round's diagnosis found missing",
        "move": "add, replace, remove or open (a free curve)",
        "held_out_change": "the suggestion's relative change of the held-out error",
        "implausible": "physical implausibilities of the round's model",
        "decision": "what the loop did, in words", "judge": "what decided it",
        "answer": "the round whose skeleton gives the loop's answer"}
    for state in diagnosis.measured:
        meanings[f"{state}_rmse"] = f"{state}'s own simulation error (its sensor's units)"
        meanings[f"{state}_nrmse"] = f"{state}'s simulation error over its spread"
    return {column: meanings[column] for column in columns if column in meanings}


def _structure(skeleton: Skeleton) -> tuple:
    """The skeleton's terms per equation and its state limits, parameters unnamed.

    A term's factors are sorted, so that ``x1*a5`` and ``a2*x1`` are one term.
    """
    out = []
    for eq in skeleton.parsed:
        same = {n.name: "a" for n in walk(eq.rhs) if isinstance(n, Param)}
        out.append((eq.derivative, tuple(sorted(
            (sign, "*".join(sorted(to_text(f) for f in product_factors(rename(node, same)))))
            for sign, node in signed_terms(eq.rhs)))))
    limits = {state: tuple("a" if isinstance(end, str) else end for end in ends)
              for state, ends in skeleton.limits.items()}
    return (*out, tuple(sorted(limits.items())))


class HypothesisLoop:
    """Fit a skeleton, diagnose it, add the missing effect, and again, keeping every round.

    Each :meth:`step` fits the current skeleton with a clone of
    ``estimator``, runs :func:`~sklearn_pycc.diagnose` against the
    measurements and records the decision: the effect to add (then the next
    step fits the extended skeleton, starting from the diagnosis's own refit)
    or that nothing is missing (then the loop has stopped). Every round is
    judged over the horizon the first round chose, so their simulation
    errors can be compared.

    Parameters
    ----------
    estimator : CCRegressor
        A backend with the starting skeleton as ``equations``; it is cloned,
        never fitted itself.
    X : DataFrame or Measurement
        The measurements, as for ``fit`` and ``diagnose``.
    y : DataFrame or array, optional
        Measured derivatives; estimated from ``X`` when None (and given
        inside ``X`` when it is a Measurement).
    verbose : int, default=0
        1: each round says its stages as they start (fit, diagnosis, the
        filter's judgement, the decision) and the refinement; the rounds'
        own fits stay quiet.
    **diagnose_options
        Passed to :func:`~sklearn_pycc.diagnose` (``horizon``,
        ``n_refit``, ``min_improvement``, ``bic_threshold``, ``held_out``,
        ``units`` (else ``X.attrs["units"]``), ``quantities`` (what each
        state measures, ``{"x1": "level"}``, by default the estimator's
        own: effects are then named in its field's words), ``n_jobs``
        (the candidates' refits and held-out folds in parallel, the
        filter's held-out fits too), ...).

    Attributes
    ----------
    measurement : Measurement
        The record, read once: every round's fit and diagnosis reuses the
        derivatives estimated for the first.
    rounds : list of Round
        Every round so far, the starting skeleton first.
    stopped : bool
        Whether the last round found nothing missing.
    refinement : Refinement or None
        The last skeleton refitted by output error (see :meth:`refine`).
    model : CCRegressor or None
        The loop's answer: the refinement when it was adopted, else the last
        round's model (that one is always ``rounds[-1].model``).
    final_model : CCRegressor or None
        The same as :attr:`model` (the name earlier scripts use).

    Examples
    --------
    >>> from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets
    >>> frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], return_truth=True)
    >>> loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), frame)
    >>> loop = loop.run(max_rounds=3)
    >>> [r.added.effect if r.added else None for r in loop.rounds]
    ['cubic_stiffness', None]
    """

    def __init__(self, estimator, X, y=None, *, verbose: int = 0, **diagnose_options) -> None:
        if isinstance(estimator, type):
            raise TypeError(f"estimator must be an instance, got the class {estimator.__name__}:"
                            f" pass {estimator.__name__}(equations=[...])")
        if not hasattr(estimator, "get_params") or "equations" not in estimator.get_params():
            raise TypeError("estimator must be a CCRegressor backend with the starting "
                            f"skeleton as equations, got {type(estimator).__name__}")
        if isinstance(X, Measurement):
            if y is not None:
                raise ValueError("HypothesisLoop got y beside a Measurement: give y to the "
                                 "Measurement (Measurement(X, y))")
        elif not isinstance(X, pd.DataFrame):
            raise TypeError(f"X must be a pandas DataFrame, got {type(X).__name__}")
        if "horizon" in diagnose_options and diagnose_options["horizon"] is not None:
            horizon = diagnose_options["horizon"]
            if horizon != "auto" and not isinstance(horizon, (int, float)):
                raise ValueError(f"horizon must be 'auto', a time or None, got {horizon!r}")
        if isinstance(verbose, bool) or not isinstance(verbose, Integral) or verbose < 0:
            raise ValueError(f"verbose must be a non-negative integer, got {verbose!r}")
        self.estimator = estimator
        self.X = X
        self.y = y
        self.verbose = int(verbose)
        # read once: every round's fit and diagnosis reuses the derivatives estimated for the
        # first (the skeletons keep their states)
        self.measurement = X if isinstance(X, Measurement) else Measurement(X, y)
        self.diagnose_options = dict(diagnose_options)
        self.rounds: list[Round] = []
        self.refinement: Refinement | None = None

    # -- state ---------------------------------------------------------------------
    @property
    def stopped(self) -> bool:
        """Whether the last round found nothing missing."""
        return bool(self.rounds) and self.rounds[-1].added is None

    @property
    def model(self):
        """The loop's answer (None before the first step).

        The output-error refinement of the last skeleton when it was adopted
        (see :meth:`refine`), else the last round's model; the last round's
        model itself is ``rounds[-1].model``.
        """
        if not self.rounds:
            return None
        if self.refinement is not None and self.refinement.adopted:
            return self.refinement.model
        return self.rounds[-1].model

    @property
    def final_model(self):
        """The loop's answer: the same as :attr:`model`."""
        return self.model

    def __repr__(self) -> str:
        state = "stopped" if self.stopped else "running"
        return f"<HypothesisLoop: {len(self.rounds)} rounds, {state}>"

    # -- running -----------------------------------------------------------------------
    def _next_model(self):
        if not self.rounds:
            return clone(self.estimator)
        added = self.rounds[-1].added
        previous = self.rounds[-1].model
        # fitted as the diagnosis judged it (a free curve continues beyond its data linearly)
        # a replaced or removed term takes its parameters with it (prepared leaves out
        # those the new skeleton lacks); the user's refits on resamples are kept
        init = {**(previous.get_params().get("param_init") or {}), **added.param_init}
        return prepared(previous, equations=added.equations, param_init=init,
                        n_bootstrap=KEEP, **added.settings)

    def _options(self) -> dict:
        options = dict(self.diagnose_options)
        if self.rounds:  # every round over the first round's horizon
            horizon = self.rounds[0].diagnosis.horizon
            options["horizon"] = None if horizon is None else horizon.time
        return options

    def step(self) -> Round | None:
        """Run one round; None (and nothing run) when the loop has stopped.

        Returns
        -------
        Round or None
        """
        if self.stopped:
            return None
        progress = Progress(f"HypothesisLoop round {len(self.rounds)}", self.verbose)
        self.refinement = None  # a refinement judges the last round only
        added = self.rounds[-1].added if self.rounds else None
        if added is not None and added.refit is not None:
            model = added.refit  # the diagnosis fitted it to this record already
        else:
            progress.stage(f"fitting {len(self.measurement.X):,} samples")
            model = self._next_model().fit(self.measurement)
        progress.stage(f"diagnosing the model fitted by {model.fit_mode_}")
        report = diagnose(model, self.measurement, **self._options())
        first = self.rounds[0].diagnosis.horizon if self.rounds else None
        if first is not None and report.horizon is not None and report.horizon.time is not None \
                and "horizon" not in self.diagnose_options:
            # the same windows every round, so that their errors compare: say where they came from
            report.horizon = replace(report.horizon, why=f"round 0's: {first.why}")
        best = report.best
        # a model with unmeasured states is judged by simulating each experiment whole
        judge = ("held-out simulation" if report.horizon is not None
                 or getattr(report, "hidden", None) else "held-out derivatives")
        likelihood = None
        by_filter = getattr(model, "fit_mode_", None) == "filter"
        if by_filter:
            judge = "held-out likelihood"
            if best is not None:
                progress.stage(f"judging {best.label} by the filter's held-out likelihood")
                # a removal the diagnosis judged by the filter already
                likelihood = best.likelihood or self._likelihood_of(model, best, report)
                if not likelihood.confirmed:
                    report.notes.append(
                        f"process noise pushes this record: the suggestion ({best.action()}) "
                        f"is judged by the filter's likelihood of held-out samples, and "
                        f"{likelihood}")
        evidence = getattr(model, "process_noise_evidence_", None)
        if (by_filter and best is not None and not likelihood.confirmed) or (
                best is None and evidence is not None and evidence.missing_under_push):
            # the push fills the derivatives the diagnosis ranked by and wanders its
            # simulations: the filter ranks the candidates (on a round it fitted, where the
            # diagnosis saw something; a round it fitted with nothing seen was recognised by
            # errors that depend on no state)
            found = self._searched(model, best, likelihood, report)
            if found is not None:
                best, likelihood, judge = found, found.likelihood, "held-out likelihood"
        seen = None if best is None else next(
            (r.index for r in self.rounds
             if _structure(r.skeleton) == _structure(best.equations)), None)
        if seen is not None:
            report.notes.append(f"the suggestion ({best.action()}) returns to the skeleton of "
                                f"round {seen}: the loop stops rather than go round")
            decision = f"stop: the suggestion returns to round {seen}'s skeleton"
            best = None
        elif likelihood is not None and not likelihood.confirmed:
            decision = (f"stop: {best.label} does not raise the held-out likelihood (process "
                        "noise: judged by the filter)")
            best = None
        elif best is None:
            decision = "stop: nothing is missing"
            if report.implausible:
                decision += f" (but the model is implausible: {report.implausible[0]})"
        elif best.move == "open":
            decision = f"outside the catalogue ({best.effect}): {best.action()}"
        else:  # the action names the move: "add '- a3*x1^3' to x2_dot"
            decision = f"{best.label}: {best.action()}"
        current = Round(len(self.rounds), model.skeleton_, model, report, decision, best,
                        judge, likelihood)
        self.rounds.append(current)
        progress.stage(decision)
        return current

    def _searched(self, model, rejected: Suggestion | None,
                  judgement: LikelihoodJudgement | None,
                  report: Diagnosis) -> Suggestion | None:
        """The diagnosis's candidates ranked by the filter's likelihood ratio: one confirmed."""
        chosen, notes = likelihood_ratio_search(
            model, report.candidates, report.record,
            whole=whole_record(model, self.measurement),
            judged=None if rejected is None or judgement is None or judgement.removal
            else (rejected.equations, judgement),
            n_jobs=self.diagnose_options.get("n_jobs"))
        evidence = getattr(model, "process_noise_evidence_", None)
        why = ("process noise pushes this record" if getattr(model, "fit_mode_", None) == "filter"
               else f"the filter's one-step errors are white but depend on {evidence.depends_on} "
               "(a random push, and a function of the state missing)")
        report.notes.extend(f"{why}: {words}" for words in notes)
        if chosen is None:
            return None
        report.best = suggestion_for(chosen, model.skeleton_, model)
        return report.best

    def _likelihood_of(self, model, best: Suggestion, report: Diagnosis):
        """The suggestion judged by the filter's likelihood of held-out samples."""
        init = {**(model.get_params().get("param_init") or {}), **best.param_init}
        extended = prepared(model, equations=best.equations, param_init=init, **best.settings)
        added = len(best.equations.params) - len(model.skeleton_.params)
        return likelihood_check(model, extended, report.record,
                                n_added=max(added, 1), nested=best.move == "add",
                                n_jobs=self.diagnose_options.get("n_jobs"))

    def run(self, max_rounds: int = 5, refine: bool = True) -> HypothesisLoop:
        """Step until nothing is missing or ``max_rounds`` rounds are recorded.

        Parameters
        ----------
        max_rounds : int, default=5
            Most rounds in all (the starting skeleton counts as one).
        refine : bool, default=True
            Then :meth:`refine` the last skeleton by output error: it becomes
            the loop's answer, :attr:`model`, when it simulates held-out data
            better.

        Returns
        -------
        self : HypothesisLoop
        """
        if not isinstance(max_rounds, Integral) or isinstance(max_rounds, bool) \
                or max_rounds < 1:
            raise ValueError(f"max_rounds must be a positive integer, got {max_rounds!r}")
        if not isinstance(refine, bool):
            raise ValueError(f"refine must be True or False, got {refine!r}")
        while not self.stopped and len(self.rounds) < max_rounds:
            self.step()
        if refine:
            try:
                self.refine()
            except (SimulationError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
                # the loop's answer stands without it; say why
                self.refinement = None
                self.rounds[-1].diagnosis.notes.append(
                    f"the output-error refinement of the last skeleton failed ({exc}); the "
                    "final model is the last round's")
        return self

    def refine(self) -> Refinement | None:
        """Refit the last round's skeleton by output error and keep it if it simulates better.

        The rounds compare skeletons by equation error where the record is
        clean enough (``fit_mode="auto"``); on a fast, clean record the same
        skeleton fitted to its simulated trajectories often follows data it
        has not seen better still. Both fits are judged alike, refitted
        without each held-out fold and simulated over the first round's
        horizon; the output-error fit becomes the loop's answer, :attr:`model`, when it
        lowers that error by at least 1 %. A model already fitted by output
        error, or by its Kalman filter (process noise recognised), is left as
        it is (None is returned).

        Returns
        -------
        Refinement or None
            Also kept as :attr:`refinement`.
        """
        from ._held_out import HELD_OUT_GAIN, pooled_errors

        if not self.rounds:
            raise ValueError("the loop has not run yet: call step() or run() first")
        last = self.rounds[-1]
        model = last.model
        if getattr(model, "fit_mode_", "equation") in ("simulation", "filter") \
                or "fit_mode" not in model.get_params():
            self.refinement = None
            return None
        Progress("HypothesisLoop", self.verbose).stage(
            "refitting the last skeleton by output error (kept if it simulates held-out data "
            "better)")
        data = last.diagnosis.record
        refined = prepared(model, fit_mode="simulation", param_init=model.params_,
                           n_bootstrap=KEEP).fit(self.measurement)
        horizon = self.rounds[0].diagnosis.horizon
        equations = [k for k, d in enumerate(model.skeleton_.derivatives)
                     if d in last.diagnosis.maps] or list(range(len(model.skeleton_.states)))
        steps = judged_step_limit(data.n_samples)
        folds, before = pooled_errors(model, data, equations, horizon, steps)
        _, after = pooled_errors(refined, data, equations, horizon, steps)
        key = "held_out_simulation_nrmse" if "held_out_simulation_nrmse" in before \
            else "held_out_nrmse"
        adopted = after[key] <= (1 - HELD_OUT_GAIN) * before[key]
        self.refinement = Refinement(refined, before[key], after[key], bool(adopted), folds)
        return self.refinement

    # -- reading -------------------------------------------------------------------------
    def answer(self) -> str:
        """Which model :attr:`model` is, in words (the summary, the table and the HTML say it)."""
        if not self.rounds:
            return "none yet (the loop has not run)"
        last = self.rounds[-1].index
        refinement = self.refinement
        if refinement is not None and refinement.adopted:
            return f"round {last}'s skeleton {refinement}"
        if refinement is not None:
            return f"round {last}'s model (its skeleton {refinement})"
        if getattr(self.rounds[-1].model, "fit_mode_", None) == "simulation":
            return f"round {last}'s model (fitted by output error already)"
        return f"round {last}'s model"

    def _answer_mark(self, index: int) -> str:
        if index != self.rounds[-1].index:
            return ""
        if self.refinement is not None and self.refinement.adopted:
            return "loop.model: refitted by output error"
        return "loop.model"

    def table(self) -> pd.DataFrame:
        """One row per round's model: size, errors, what its diagnosis suggested, the decision.

        Rounds are numbered as :attr:`rounds` (0: the starting skeleton).
        ``adds`` is the effect this round's model has that the previous
        round's lacked (None for round 0); ``suggests`` and ``move`` what this
        round's diagnosis found missing (the next round ``adds`` it), with
        ``held_out_change``, its change of the held-out error; ``decision``
        says it in words and ``judge`` what decided; ``answer`` marks the
        round whose skeleton gives the loop's answer, :attr:`model` (and
        whether that was refitted by output error). Besides
        ``simulation_rmse`` (every state the diagnosis compared pooled,
        whatever their units: a velocity differentiated from a measured
        position counts beside the position, so with one sensor it differs
        from that sensor's error), each measured state has its own
        ``NAME_rmse`` and ``NAME_nrmse`` (simulated over the common horizon):
        the sensor's own errors. ``table.attrs["columns"]`` says what each
        column measures, ``table.attrs["units"]`` gives the units.
        """
        if not self.rounds:
            raise ValueError("the loop has not run yet: call step() or run() first")
        rows = []
        for r in self.rounds:
            d = r.diagnosis
            held = None if r.added is None else r.added.held_out
            row = {
                "round": r.index,
                "n_parameters": r.model.n_parameters_,
                "derivative_nrmse": float(d.derivatives["nrmse"].max()),
                "simulation_rmse": d.simulation_rmse,
            }
            for state in d.measured:
                if state in d.trajectories.index:
                    row[f"{state}_rmse"] = float(d.trajectories.loc[state, "rmse"])
                    row[f"{state}_nrmse"] = float(d.trajectories.loc[state, "nrmse"])
            before = self.rounds[r.index - 1].added if r.index else None
            row.update({
                "adds": None if before is None else before.effect,
                "suggests": None if r.added is None else r.added.effect,
                "move": None if r.added is None else r.added.move,
                "held_out_change": math.nan if held is None else held.change(),
                "implausible": len(d.implausible),
                "decision": r.decision,
                "judge": r.judge,
                "answer": self._answer_mark(r.index),
            })
            rows.append(row)
        table = pd.DataFrame(rows).set_index("round")
        table.attrs["units"] = dict(self.rounds[0].diagnosis.units)
        table.attrs["columns"] = _column_meanings(table.columns, self.rounds[0].diagnosis)
        return table

    def to_html(self, path=None, title: str = "Hypothesis loop") -> str:
        """The whole loop as one self-contained HTML report.

        Every round's fitted equations (as MathML), decision, diagnosis
        summary, ranking and figures (embedded PNG), and the error round by
        round: nothing is fetched from the network to view it.

        Parameters
        ----------
        path : str or path-like, optional
            Write the report there (UTF-8).
        title : str, default="Hypothesis loop"

        Returns
        -------
        str
            The HTML document.
        """
        from ._report_html import loop_page

        if not isinstance(title, str):
            raise TypeError(f"title must be a string, got {type(title).__name__}")
        document = loop_page(self, title)
        if path is not None:
            from pathlib import Path

            Path(path).write_text(document, encoding="utf-8")
        return document

    def _repr_html_(self) -> str:
        from .._utils.html_pages import preformatted, table_html

        if not self.rounds:
            return preformatted(repr(self))
        return table_html(self.table()) + preformatted(self.summary())

    def summary(self) -> str:
        """The loop in plain words: each round's model, errors and decision."""
        if not self.rounds:
            return "The loop has not run yet: call step() or run()."
        horizon = self.rounds[0].diagnosis.horizon
        lines = [f"Hypothesis loop, {len(self.rounds)} round"
                 f"{'s' if len(self.rounds) != 1 else ''}"
                 + (f"; simulations over {horizon}" if horizon and horizon.time else "")
                 + ":"]
        left_out = self.rounds[0].diagnosis.left_out
        if left_out:
            judged = len(self.rounds[0].diagnosis.residuals)
            lines.append(f"(judged on {judged} samples: {left_out} at the ends of the "
                         "experiments were left out, where the estimated derivatives cannot "
                         "be trusted while the filter settles)")
        for r in self.rounds:
            d = r.diagnosis
            errors = [f"{s} RMSE {d.trajectories.loc[s, 'rmse']:.4g}"
                      + (f" {d.units[s]}" if d.units.get(s) else "")
                      + f" (NRMSE {d.trajectories.loc[s, 'nrmse']:.3g})"
                      for s in d.measured if s in d.trajectories.index]
            lines.append(f"Round {r.index} ({r.model.n_parameters_} fitted numbers"
                         + (f"; simulation {', '.join(errors)}" if errors else "") + "):")
            lines.extend(f"    {text}" for text in r.model.equations())
            lines.extend(f"    IMPLAUSIBLE: {item}" for item in d.implausible)
            lines.append(f"    -> {r.decision} [judged by {r.judge}]")
            if r.added is not None and r.added.held_out is not None:
                lines.append(f"       ({r.added.held_out})")
            if r.likelihood is not None:
                lines.append(f"       ({r.likelihood})")
        lines.append(f"The loop's answer (loop.model): {self.answer()}.")
        if self.refinement is not None and self.refinement.adopted:
            lines.extend(f"    {text}" for text in self.refinement.model.equations())
        if not self.stopped:
            lines.append("The loop can go on: step() or run().")
        return "\n".join(lines)
