"""What a diagnosis found, in one object: the suggestion, the ranking, the summary in words.

:class:`Suggestion` is the move the diagnosis proposes (an effect added,
replaced, removed, or a free curve); :class:`Diagnosis` gathers it with the
ranking of every candidate, the residual map, the failures and the
trajectories, and says it in words (:meth:`Diagnosis.summary`), as a table,
an HTML page and a figure. :func:`~sklearn_pycc.diagnose` makes them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..exceptions import SkeletonError
from ..measurements.record import Record
from ..skeleton import Skeleton
from ..skeleton.nodes import BinOp, Neg, Param, signed_terms, walk
from ..skeleton.parser import parse_expression
from ..skeleton.printer import to_text
from ._candidates import TIE, Candidate
from ._failures import ResidualMap
from ._held_out import HeldOut
from ._open_curves import OpenCurve
from ._physics import Implausibility
from ._roles import kinematic_states
from ._stability import Stability
from ._trajectories import Divergence, Horizon

__all__ = ["Diagnosis", "Suggestion"]


@dataclass(frozen=True)
class Suggestion:
    """The missing effect a diagnosis recommends adding.

    Attributes
    ----------
    effect : str
        Catalogue name, e.g. ``"coulomb_friction"``.
    description : str
        The effect's physics in one line.
    equation : str
        The derivative of the equation it enters (``"x2_dot"``).
    variable : str
        The variable it acts through (``"x2"``, ``"x1 - x2"``).
    term : str
        The term, with fresh parameter indices, subtracted from that equation.
    equations : Skeleton
        The skeleton with the term added, ready to fit.
    param_init : dict
        Values of the extended skeleton's parameters from the diagnosis's
        own refit (useful as ``param_init`` for nonlinear parameters).
    curve_term : str or None
        The free-curve alternative (``"f3(x2)"``), fresh index, with the
        catalogue's constraints in ``curve_constraints``.
    curve_constraints : tuple of str
        Constraints of that curve, already renamed.
    also : dict
        Other equations the effect enters (a coupling acts on both masses;
        a storage's outflow law also enters the next storage): derivative ->
        term, subtracted as ``term`` is (several terms entering one equation
        are written as their sum).
    error_removed : float
        Share of the equation's derivative residual the refit removes.
    delta_bic : float
        Change of the Bayesian information criterion (negative is better).
    simulation_rmse : float
        Simulation RMSE of the refitted model (NaN when not simulated).
    held_out : HeldOut or None
        The comparison with the model on data each fit did not see (None
        when ``diagnose(..., held_out=False)``).
    bounds : tuple of str
        The bounds the effect's physics puts on the new parameters (in
        ``equations`` too), e.g. ``("a3 >= 0", "a4 >= 0")``.
    move : {"add", "replace", "remove", "open", "limit"}
        What the suggestion does to the skeleton: add the effect's term
        (``"limit"``: a hard limit on a state, ``term`` the constraint
        ``"x1 <= a5"``, ``equation`` the state's),
        put it in place of the terms in ``replaces`` (a pendulum's sine for
        a linear spring), take the terms in ``replaces`` out (``term`` is
        then the removed term and ``effect`` what it stood for), or, when no
        catalogue effect helps, put a free curve (or the formula proposed
        for it) in place of the terms that play one role (``effect`` is then
        ``free_restoring_curve``, ``free_friction_curve``,
        ``free_damping_curve`` or ``free_state_curve``): something outside
        the catalogue is missing.
    replaces : tuple of str
        The terms of the diagnosed skeleton the move takes out, as written
        there (empty for an addition).
    replaced_in : dict
        For a move that takes terms out of several equations: derivative ->
        the terms of :attr:`replaces` taken out of that equation (empty when
        they all come from :attr:`equation`).
    intervals : dict
        95 % confidence interval of each new parameter, ``{"a3": (low,
        high)}``, from the diagnosis's refit (empty when its backend has no
        uncertainty estimate without resampling, and when the model was
        fitted by output error: its equation-error refit would be biased).
        The refit saw at most 20,000 samples of the record.
    formula : str or None
        For ``move="open"``: the formula the symbolic engine proposes for
        the free curve, as a term with fresh parameters (``"a3*x1 / (1 +
        a4*x1^2)"``); ``term`` and ``equations`` hold it when it too lowers
        the held-out error (``formula_held_out``), else they hold the free
        curve. None for other moves and when no formula was found.
    formula_held_out : HeldOut or None
        The held-out comparison of the formula with the diagnosed model.
    curve : DataFrame or None
        For ``move="open"``: the free curve on a grid of its variable, with
        ``lower``/``upper`` (95 % band), ``current`` (what the replaced
        terms subtract; for a damping ``g(x) v``, the factor ``g(x)``) and
        ``formula`` (the fitted formula, when there is one).
    settings : dict
        Hyperparameters the diagnosis refitted the suggestion with besides
        the skeleton and the starting values (``{"extrapolation": "linear"}``
        for a polynomial free curve); fit ``equations`` with them too.
    refit : CCRegressor or None
        The diagnosis's own fit of ``equations`` to the whole record with
        the diagnosed model's settings, where it is one (a limit suggested
        for a model with unmeasured states): :class:`HypothesisLoop` takes
        it as the next round's model rather than fit it again. None
        otherwise.
    called : str
        What the effect is called in the field of the state it acts on
        (``"Torricelli outflow"`` on a level, ``"square-root law"`` where
        the state's quantity is not known, ``"coulomb friction"`` on a
        mechanical velocity); see :meth:`sklearn_pycc.effects.Effect.called`
        and ``diagnose(..., quantities=...)``. Empty: the catalogue name.
    likelihood : LikelihoodJudgement or None
        For a removal from a model fitted by its Kalman filter (process
        noise recognised): the filter's held-out likelihood with and without
        the terms, which judged it in place of :attr:`held_out`. None
        otherwise.
    """

    effect: str
    description: str
    equation: str
    variable: str
    term: str
    equations: Skeleton
    param_init: dict
    curve_term: str | None
    curve_constraints: tuple[str, ...]
    also: dict
    error_removed: float
    delta_bic: float
    simulation_rmse: float
    held_out: HeldOut | None = None
    bounds: tuple[str, ...] = ()
    intervals: dict = field(default_factory=dict)
    move: str = "add"
    replaces: tuple[str, ...] = ()
    formula: str | None = None
    formula_held_out: HeldOut | None = None
    curve: pd.DataFrame | None = field(default=None, repr=False, compare=False)
    settings: dict = field(default_factory=dict)
    refit: object = field(default=None, repr=False, compare=False)
    called: str = ""
    replaced_in: dict = field(default_factory=dict)
    likelihood: object = field(default=None, compare=False)

    def __str__(self) -> str:
        return f"{self.action()} ({self.label} through {self.variable or 'nothing'})"

    @property
    def label(self) -> str:
        """The effect as the summary names it: its field's name, then the catalogue's.

        ``"Torricelli outflow (square_root_outflow)"``; the catalogue name
        alone where the field calls it the same (``"coulomb_friction"``).
        """
        return _named(self.effect, self.called)

    @property
    def written(self) -> str:
        """:attr:`term` as the equation reads it, with its sign: ``"+ a3*abs(u)^a4*sign(u)"``."""
        return _subtracted(self.term)

    def action(self) -> str:
        """What to do to the skeleton, in words: ``"replace 'a2*x1' in x2_dot by ..."``."""
        if self.move == "remove":
            return f"remove '{self.term}' from {self.equation}"
        if self.move == "limit":
            return f"add the limit '{self.term}'"
        if not self.replaces:
            return f"add '{_subtracted(self.term)}' to {self.equation}" + "".join(
                f" and '{_written(t)}' to {eq}" for eq, t in self.also.items())
        taken = self.replaced_in or {self.equation: self.replaces}
        words = [f"replace '{_joined(taken.get(self.equation, ()))}' in {self.equation} "
                 f"by '{_subtracted(self.term)}'"]
        for eq, old in taken.items():
            if eq == self.equation:
                continue
            words.append(f"'{_joined(old)}' in {eq} by '{_written(self.also[eq])}'"
                         if eq in self.also else f"remove '{_joined(old)}' from {eq}")
        words += [f"add '{_written(t)}' to {eq}" for eq, t in self.also.items()
                  if eq not in taken]
        return ", and ".join(words)


def _joined(terms) -> str:
    return "' and '".join(terms)


def _written(term: str) -> str:
    """A subtracted ``term`` (or sum of terms) as the equation reads it, each with its sign."""
    try:
        node = parse_expression(term, kind="terms")
    except SkeletonError:
        return f"- {term}"
    return " ".join(_subtracted(to_text(part)) if sign > 0 else f"+ {to_text(part)}"
                    for sign, part in signed_terms(node))


def _subtracted(term: str) -> str:
    """A term the skeleton subtracts, written with its sign (``- (-a3*u)`` is ``+ a3*u``)."""
    try:
        node = parse_expression(term, kind="term")
    except SkeletonError:
        return f"- {term}"
    if isinstance(node, Neg):
        return f"+ {to_text(node.operand)}"
    return f"- {term}"


@dataclass
class Diagnosis:
    """What :func:`diagnose` found. Read :meth:`summary` first.

    Attributes
    ----------
    model : CCRegressor
        The diagnosed model (not modified).
    derivatives : DataFrame
        Per equation: ``rmse``, ``nrmse``, ``r2``, ``fit_percent`` of the
        predicted derivatives.
    trajectories : DataFrame
        Per state: the same measures for the simulation with the measured
        inputs, over windows of :attr:`horizon` each restarted from the
        measured (estimated) state, or from each experiment's initial state
        when ``horizon=None`` (empty when there is no time column or
        ``simulate=False``).
    simulation : DataFrame
        ``t``, ``trajectory`` (when given), each state measured and
        simulated (``x1`` and ``x1_sim``); NaN after a divergence. The rows
        are those the derivatives can be trusted on (a filter's settling at
        the ends of each experiment left out), numbered afresh.
    residuals : DataFrame
        Measured minus predicted derivatives, one column per equation.
    divergences : list
        Simulations that stopped early (time reached and reason).
    windows : DataFrame
        The time windows with the largest errors (divergences first).
    explained : DataFrame
        ``equation, variable, fraction``: the share of each equation's
        residual variance that a function of each variable explains.
    maps : dict
        Equation -> :class:`ResidualMap` over position x velocity (or state
        x input for a first-order equation).
    ranking : DataFrame
        Every effect tried, best first (columns ``equation, variable,
        effect, score, suggested_term, ...``). ``stability`` is the share of
        resamples of the record in which the effect wins (see
        :func:`diagnose`'s ``n_bootstrap``).
    best : Suggestion or None
        What to add; None when nothing is missing.
    simulation_rmse : float
        RMSE of the simulated states over every experiment.
    notes : list of str
        Things worth knowing (estimated derivatives, extrapolation).
    horizon : Horizon or None
        How far each simulation ran before it was restarted from the
        measured state (``horizon.time`` None: whole experiments).
    implausible : list of Implausibility
        Terms of the diagnosed model that contradict their physical role
        (friction feeding energy in, a net spring pushing away, a gain of
        the wrong sign); empty when every term plays its role.
    units : dict
        Unit of each column that has one (``{"x1": "m", "F": "N"}``), from
        ``units=`` and ``X.attrs["units"]``; the tables' ``unit`` column
        and the figures' axes read it.
    measured : list of str
        The states with a column of their own in ``X`` (the others were
        reconstructed): the errors that matter are theirs.
    open_curves : list of OpenCurve
        The free curves tried in place of each role's terms once no
        catalogue move helped (see ``diagnose(..., open_curves=True)``):
        each with its curve and band, its held-out comparison and, for the
        confirmed one, the proposed formula. Empty when a catalogue move
        was chosen.
    candidates : list of Candidate
        Every term or move tried, with its screens and refits (``ranking``
        is their table).
    record : Record
        The record as the diagnosis read it: experiments, states (measured
        or reconstructed), inputs and derivatives, on the trusted samples.
    variable_values : dict
        Equation -> ``{label: values}`` of the variables that explain its
        residual (the figures' axes).
    left_out : int
        Samples of ``X`` the diagnosis did not judge: at the ends of each
        experiment, where estimated derivatives cannot be trusted while the
        differentiation filter settles (0 with measured derivatives). The
        summary's first line says so.
    """

    model: object
    derivatives: pd.DataFrame
    trajectories: pd.DataFrame
    simulation: pd.DataFrame
    residuals: pd.DataFrame
    divergences: list[Divergence]
    windows: pd.DataFrame
    explained: pd.DataFrame
    maps: dict[str, ResidualMap]
    ranking: pd.DataFrame
    best: Suggestion | None
    simulation_rmse: float
    notes: list[str] = field(default_factory=list)
    horizon: Horizon | None = None
    implausible: list[Implausibility] = field(default_factory=list)
    units: dict[str, str] = field(default_factory=dict)
    measured: list[str] = field(default_factory=list)
    open_curves: list[OpenCurve] = field(default_factory=list)
    candidates: list[Candidate] = field(default_factory=list, repr=False)
    record: Record | None = field(default=None, repr=False)
    variable_values: dict = field(default_factory=dict, repr=False)
    _stability: Stability | None = field(default=None, repr=False)
    left_out: int = 0
    _detection: dict = field(default_factory=dict, repr=False)

    @property
    def detection_limit(self) -> dict[str, float]:
        """The smallest effect this record could have shown, by measured state.

        The RMS change of the simulated state an effect must make to stand
        out of the noise (``DETECTION_Z`` standard errors over the samples
        that count as independent: coloured noise is worth fewer). Empty
        without a simulation. The summary says it when nothing is missing,
        with what the model's simulation still misses beyond the noise.
        """
        return {state: d.limit for state, d in self._detection.items()}

    def __repr__(self) -> str:
        best = "nothing missing" if self.best is None else str(self.best)
        return f"<Diagnosis: {best}>"

    # -- plain words ----------------------------------------------------------------
    def summary(self) -> str:
        """The diagnosis in plain words."""
        lines = []
        model = self.model
        n = len(self.residuals)
        experiments = 1 if self.record is None else len(self.record.experiment_rows)
        ends = ""
        if self.left_out:
            ends = (f" ({self.left_out} more at the ends of the experiments left out: their "
                    "estimated derivatives cannot be trusted while the filter settles)")
        lines.append(f"Model ({type(model).__name__}, {model.n_parameters_} fitted numbers) "
                     f"against {n} samples in {experiments} experiment"
                     f"{'s' if experiments != 1 else ''}{ends}:")
        for text in model.equations():
            lines.append(f"    {text}")
        for item in self.implausible:
            lines.append(f"    IMPLAUSIBLE: {item}")
        lines.append("")
        lines.append("Derivatives:")
        defined = {f"{position}_dot": velocity
                   for velocity, position in kinematic_states(model.skeleton_).items()}
        reconstructed = bool(self.record is not None and self.record.estimated)
        for name, row in self.derivatives.iterrows():
            if name in defined and reconstructed and row.rmse == 0:
                lines.append(f"    {name}: holds by construction ({defined[name]} was "
                             f"reconstructed as the derivative of {name[:-4]})")
                continue
            lines.append(f"    {name}: R2 {row.r2:.4f}, RMSE {row.rmse:.4g} "
                         f"(NRMSE {row.nrmse:.3g})")
        if not self.trajectories.empty:
            if self.horizon is None or self.horizon.time is None:
                lines.append("Simulation from the measured initial state with the measured "
                             "inputs:")
            else:
                lines.append(f"Simulation over {self.horizon}, each restarted from the "
                             "measured state, with the measured inputs:")
            for name, row in self.trajectories.iterrows():
                unit = f" {self.units[name]}" if self.units.get(name) else ""
                note = "" if name in self.measured or not self.measured else \
                    " (not measured: against its reconstruction)"
                lines.append(f"    {name}: fit {row.fit_percent:.1f} %, RMSE {row.rmse:.4g}"
                             f"{unit} (NRMSE {row.nrmse:.3g}){note}")
        for d in self.divergences:
            lines.append(f"    FAILURE: {d}")
        lines.append("")
        lines.extend(self._where_words())
        lines.append("")
        lines.extend(self._effect_words())
        if self.notes:
            lines.append("")
            lines.extend(f"Note: {note}" for note in self.notes)
        return "\n".join(lines)

    def _where_words(self) -> list[str]:
        lines = []
        if self.derivatives.empty:
            return lines
        failing = self.derivatives.loc[self.derivatives.index.isin(list(self.maps))]
        for name, row in failing.sort_values("nrmse", ascending=False).iterrows():
            part = self.explained[self.explained.equation == name].head(3)
            if part.empty:
                continue
            lead = ", then ".join(f"{v} ({100 * f:.0f} %)"
                                  for v, f in zip(part.variable, part.fraction))
            lines.append(f"Where it fails: the residual of {name} (NRMSE {row.nrmse:.3g}) is "
                         f"explained best by {lead} of its variance.")
        windows = self.windows[self.windows.note == ""].head(3)
        if not windows.empty:
            spans = ", ".join(f"t {row.start:.4g}-{row.end:.4g}"
                              + (f" (trajectory {row.trajectory!r})"
                                 if row.trajectory is not None else "")
                              for row in windows.itertuples())
            lines.append(f"Largest errors in time: {spans}.")
        return lines

    def _effect_words(self) -> list[str]:
        best = self.best
        tried = len(self.ranking)
        if best is None:
            leading = self.ranking.head(1)
            if leading.empty:
                return ["Missing effect: none of the catalogue's effects applies to this "
                        "skeleton."]
            row = leading.iloc[0]
            lines = [f"Missing effect: nothing. None of the {tried} effects tried lowers the "
                     f"error beyond what noise explains (the closest, {row.effect} in "
                     f"{row.equation}, removes {100 * max(row.error_removed, 0):.1f} % of the "
                     f"residual, change of BIC {row.delta_bic:+.1f}). The skeleton is "
                     "complete as far as the catalogue can tell."]
            opened = [c for c in self.candidates if c.move == "open"]
            if opened:
                lines.append("    Nor does a free curve in place of a role's terms ("
                             + ", ".join(sorted({f"{c.effect.name} in {c.roles.derivative}"
                                                 for c in opened}))
                             + "): nothing outside the catalogue is missing either.")
            for c in self.candidates:
                if c.held_out is not None:
                    lines.append(f"    Not confirmed: {c.effect.name} in {c.roles.derivative} "
                                 f"fits the record but not the data it did not see: "
                                 f"{c.held_out}.")
            lines.extend(self._stability_words())
            for detection in self._detection.values():
                lines.extend("    " + line
                             for line in detection.words(self.units.get(detection.state, "")))
            return lines
        if best.move == "open":
            return self._open_words()
        if best.move == "remove":
            lines = [f"Superfluous term: '{best.term}' in {best.equation} ({best.label}); "
                     "the model without it does as well on data its fit did not see."]
        elif best.move == "replace":
            places = (" and ".join(f"'{' + '.join(old)}' in {eq}"
                                   for eq, old in best.replaced_in.items())
                      or f"'{' + '.join(best.replaces)}'")
            lines = [f"Better physics: {best.label} ({best.description}) in "
                     f"{best.equation}, acting through {best.variable or 'nothing'}, in place "
                     f"of {places}."]
        else:
            lines = [f"Missing effect: {best.label} ({best.description}) in "
                     f"{best.equation}, acting through {best.variable or 'nothing'}."]
        lines.append(f"    {best.action()[0].upper()}{best.action()[1:]}"
                     + (f" (within {', '.join(best.bounds)})" if best.bounds else "")
                     + (f"; or a free curve '- {best.curve_term}' "
                        f"({', '.join(best.curve_constraints)})" if best.curve_term else "")
                     + ".")
        if best.likelihood is not None and best.likelihood.in_sample is not None:
            # chosen by the filter where the push hid it from the derivatives' ranking
            return [
                *lines,
                f"    Ranked first by the filter's likelihood (the push fills the derivative "
                f"residual the candidates are ranked by): {best.likelihood.in_sample}.",
                f"    Decided, as process noise pushes the record, by the filter: "
                f"{best.likelihood}.",
                "    Next: fit report.best.equations and diagnose again."]
        change = (f" and the simulation RMSE from {self.simulation_rmse:.4g} to "
                  f"{best.simulation_rmse:.4g}" if np.isfinite(best.simulation_rmse) else "")
        share = (f"removes {100 * best.error_removed:.1f} % of" if best.error_removed >= 0
                 else f"adds {-100 * best.error_removed:.2f} % to")
        lines.append(f"    Refitted, it {share} the derivative residual (change of BIC "
                     f"{best.delta_bic:+.1f}){change}.")
        if best.intervals:
            lines.append("    Its parameters, with 95 % intervals: " + ", ".join(
                f"{a} = {best.param_init[a]:.4g} ({low:.4g} to {high:.4g})"
                for a, (low, high) in best.intervals.items()) + ".")
        elif getattr(self.model, "fit_mode_", "equation") == "simulation":
            added = [a for a in best.param_init if a not in self.model.params_]
            lines.append("    Its parameters from the diagnosis's equation-error refit (a start "
                         "for the output-error fit, not its result; fit with n_bootstrap for "
                         "intervals): " + ", ".join(f"{a} = {best.param_init[a]:.4g}"
                                                    for a in added) + ".")
        acting = _as_fitted(best)
        if acting:
            lines.append(f"    As fitted, the new term acts as '{acting}' in {best.equation}.")
        if best.held_out is not None:
            lines.append(f"    Decided on data each fit did not see: {best.held_out}.")
        if best.likelihood is not None:
            lines.append(f"    Decided, as process noise pushes the record, by the filter: "
                         f"{best.likelihood}.")
        lines.extend(self._stability_words())
        runners = self.ranking.iloc[1:4]
        if len(runners):
            lead = -best.delta_bic
            lines.append(f"    Runners-up (the winner scores {lead:.1f}): " + "; ".join(
                f"{_named(r.effect, r.called)} in {r.equation}{_through(r.variable)}"
                f"{' in place of a term' if r.move == 'replace' else ''} (score {r.score:.1f}"
                + ("" if not r.refit or r.plausible else ", implausible")
                + ("" if r.refit else ", screened only")
                + (_why_below(r, lead, self.ranking.iloc[0].n_params)
                   if r.refit and r.plausible and r.score > lead else "")
                + ")"
                for r in runners.itertuples()) + ".")
        rejected = self.ranking[(self.ranking.refit) & (~self.ranking.plausible.astype(bool))]
        for r in rejected.head(2).itertuples():
            lines.append(f"    Rejected: {_named(r.effect, r.called)} in {r.equation}: {r.note}.")
        lines.append("    Next: fit report.best.equations and diagnose again.")
        return lines

    def _open_words(self) -> list[str]:
        """Something outside the catalogue: the free curve, its formula, what to fit next."""
        best = self.best
        place = (f"in place of '{' + '.join(best.replaces)}'" if best.replaces
                 else "added")
        lines = [f"Outside the catalogue: no catalogue effect lowers the error, but a free "
                 f"curve '- {best.curve_term}' in {best.equation}, {place}, does "
                 f"({best.effect}: {best.description})."]
        if best.held_out is not None:
            lines.append(f"    Decided on data each fit did not see: {best.held_out}.")
        if best.formula is None:
            lines.append("    The symbolic engine proposed no formula for it: fit the free "
                         "curve (report.best.equations) and look at its shape.")
        else:
            verdict = ("it is what report.best.equations holds" if best.term == best.formula
                       else "it does not lower the held-out error as the curve does, so "
                       "report.best.equations holds the free curve")
            lines.append(f"    The symbolic engine proposes '- {best.formula}' for it; "
                         f"{verdict}"
                         + (f" ({best.formula_held_out})" if best.formula_held_out else "")
                         + ".")
        lines.append(f"    {best.action()[0].upper()}{best.action()[1:]}.")
        lines.append("    The curve with its 95 % band beside the current terms: "
                     "report.best.curve, and report.plot()['open_curve'].")
        lines.append("    Next: fit report.best.equations and diagnose again.")
        return lines

    def _stability_words(self) -> list[str]:
        """How often the choice stands on resamples of the record, in words."""
        stability = self._stability
        if stability is None or stability.n_resamples == 0:
            return []
        total = stability.n_resamples
        others = [(stability.wins.get(c.key, 0), c) for c in self.candidates]
        others = sorted(((k, c) for k, c in others if k), key=lambda item: -item[0])
        parts = [f"{c.effect.name} in {c.roles.derivative} wins {k}" for k, c in others]
        if stability.nothing:
            parts.append(f"nothing is missing in {stability.nothing}")
        if self.best is None:
            lead = f"nothing is missing in {stability.nothing} of {total} resamples"
            parts = parts[:-1] if stability.nothing else parts
        else:
            # added beside the skeleton's terms or in their place, it is the same effect:
            # the held-out data, not the resamples' scores, chose between the two
            won = sum(k for k, c in others
                      if c.effect.name == self.best.effect and c.roles.derivative ==
                      self.best.equation and c.variable == self.best.variable
                      and (c.move == self.best.move or {c.move, self.best.move} <=
                           {"add", "replace"}))
            lead = f"{self.best.effect} wins in {won} of {total} resamples"
            parts = [p for p in parts
                     if not p.startswith(f"{self.best.effect} in {self.best.equation} ")]
        rest = f"; otherwise {', '.join(parts[:3])}" if parts else ""
        return [f"    Stability: {lead} of the record{rest} ({stability.method})."]

    def _repr_html_(self) -> str:
        """The summary, the ranking and the figures, for a notebook."""
        from ._report_html import diagnosis_html

        return diagnosis_html(self)

    # -- figures ---------------------------------------------------------------------
    def plot(self):
        """Figures of the diagnosis (see :func:`sklearn_pycc.plotting.plot_diagnosis`)."""
        from ..plotting import plot_diagnosis

        return plot_diagnosis(self)


def _why_below(row, lead: float, winner_params: int | None = None) -> str:
    """Why a plausible runner-up that scores higher than the winner ranks below it."""
    if row.score - lead <= max(TIE[0] * abs(row.score), TIE[1]):
        if winner_params is None or winner_params < row.n_params:
            return (f", a tie within {100 * TIE[0]:g} % that goes to the winner's fewer "
                    "parameters")
        return (f", a tie within {100 * TIE[0]:g} % that the data each fit did not see "
                "decided for the winner")
    if not math.isfinite(getattr(row, "held_out_change", math.nan)):
        return (", not held out: only the two best and the best move between two states "
                "are")
    return ", but the data each fit did not see preferred the winner"


def _through(variable) -> str:
    """``" through h1"``: what a runner-up acts through (nothing for a constant source)."""
    return f" through {variable}" if isinstance(variable, str) and variable else ""


def _as_fitted(best: Suggestion) -> str:
    """``"+ 1.341*x1^3"`` for ``"- a3*x1^3"`` with ``a3 = -1.341``: the sign worked out.

    Empty when the term is not one parameter times the rest.
    """
    node = parse_expression(best.term)
    if not (isinstance(node, BinOp) and node.op == "*" and isinstance(node.left, Param)) \
            or node.left.name not in best.param_init \
            or any(isinstance(n, Param) for n in walk(node.right)):
        return ""
    acting = -float(best.param_init[node.left.name])
    return f"{'+' if acting >= 0 else '-'} {abs(acting):.4g}*{to_text(node.right)}"


def _named(effect: str, called) -> str:
    """An effect by its field's name and its catalogue name (the latter alone when alike)."""
    if not isinstance(called, str) or not called or called == effect.replace("_", " "):
        return effect
    return f"{called} ({effect})"
