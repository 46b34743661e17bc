"""Candidate effects for a failing model: enumerate, screen on the residual, refit, judge."""

from __future__ import annotations

import functools
import math
import warnings
from collections import Counter
from dataclasses import dataclass, field, fields, replace

import numpy as np
import pandas as pd

from .. import effects as catalogue
from ..exceptions import RankDeficiencyWarning, SkeletonError
from ..measurements.record import Record
from ..simulation.delays import delayed_name, read_delayed
from ..skeleton import Skeleton
from ..skeleton.compiler import compile_expression
from ..skeleton.constraints import parse_constraints
from ..skeleton.nodes import (
    Apply,
    BinOp,
    Node,
    Number,
    Param,
    Symbol,
    Unknown,
    params_in,
    product_factors,
    rename,
    rename_symbols,
    signed_terms,
    substitute,
    sum_terms,
    walk,
)
from ..skeleton.parser import parse_expression
from ..skeleton.printer import to_text
from ._data import TIME, thin
from ._physics import implausible_terms
from ._refit import fit_rows, prepared
from ._roles import EquationRoles

__all__ = ["MOVES", "Candidate", "enumerate_candidates", "enumerate_input_moves",
           "enumerate_moves", "refit_candidate", "refit_candidates", "screen_candidates",
           "start_values"]

#: a term whose contribution is this many times the derivative it explains is absurd
ABSURD_RATIO = 10.0


#: what a candidate does to the skeleton
MOVES = ("add", "replace", "remove", "open")


@dataclass
class Candidate:
    """One move tried in one equation (or a coupled pair of equations).

    ``move`` is ``"add"`` (the effect's term joins the equation),
    ``"replace"`` (it takes the place of the terms in ``removals``, which
    play the same role) or ``"remove"`` (the terms in ``removals`` go and
    nothing comes in; ``effect`` is then the catalogue effect the removed
    term is an instance of, or an unnamed one).
    """

    effect: catalogue.Effect
    roles: EquationRoles
    variable: str
    additions: list[tuple[int, str]]
    curve_term: str | None
    move: str = "add"
    # (equation, term as written in the diagnosed skeleton) taken out by the move
    removals: list[tuple[int, str]] = field(default_factory=list)
    removed_params: list[str] = field(default_factory=list)
    # the removed terms with their signs, to evaluate them under the diagnosed model
    removed_nodes: list[tuple[int, float, Node]] = field(default_factory=list, repr=False)
    # the extended skeleton, the renumbered terms and the parameters they bring
    extended: Skeleton | None = None
    added: list[tuple[int, str]] = field(default_factory=list)
    new_params: list[str] = field(default_factory=list)
    # screening: the term fitted to the residual alone
    screen_bic: float = math.inf
    screen_removed: float = 0.0
    screen_params: dict[str, float] = field(default_factory=dict)
    # refit of the extended skeleton
    refit: object = None
    delta_bic: float = math.nan
    removed: float = math.nan
    rmse_before: float = math.nan
    rmse_after: float = math.nan
    plausible: bool | None = None
    redundant: bool = False
    note: str = ""
    shifts: dict[int, np.ndarray] = field(default_factory=dict)
    simulation_rmse: float = math.nan
    #: each state's simulation RMSE over the horizon (the leaders' only)
    state_rmse: np.ndarray | None = None
    # held-out comparison with the model without the effect (HeldOut), when checked
    held_out: object = None
    # a removal judged by the filter's held-out likelihood (LikelihoodJudgement), when it was
    likelihood: object = None
    # the output error (normalised) of its skeleton fitted by output error to the whole
    # record, when asked for
    whole_record: float | None = None
    # the refit's squared derivative residual per sample, in each equation it changes
    after_squares: np.ndarray | None = None
    # fitted numbers of the free curves the move brings (known once refitted)
    curve_numbers: int = 0
    # bounds of the parameters the move brings, in the names of its terms (None: the
    # effect's own)
    bounds: tuple[str, ...] | None = None
    # a reaction with the stoichiometry of a balance: one rate in every equation it enters
    # (A + B -> C, 1:1:1), not a yield of its own in each
    balanced: bool = False

    @property
    def equations(self) -> list[int]:
        """Indices of the equations the candidate changes."""
        return sorted({k for k, _ in (*self.additions, *self.removals)})

    @property
    def term_bounds(self) -> tuple[str, ...]:
        """Bounds of the parameters of the terms the move adds, in their names."""
        return self.effect.bounds if self.bounds is None else self.bounds

    @property
    def n_change(self) -> int:
        """Fitted numbers the move brings in less those it takes out."""
        return len(self.new_params) + self.curve_numbers - len(self.removed_params)

    @property
    def term(self) -> str:
        """The renumbered term added to the primary equation (the removed one for a removal)."""
        if self.move == "remove":
            return self.removals[0][1]
        for k, text in self.added:
            if k == self.roles.index:
                return text
        return self.additions[0][1]

    @property
    def key(self) -> tuple:
        """What identifies the move, the same after a copy or a pickle round trip."""
        return (self.move, self.effect.name, tuple(self.equations), self.variable,
                tuple(self.additions), tuple(self.removals), self.balanced)

    @property
    def replaces(self) -> tuple[str, ...]:
        """The terms the move takes out of the skeleton, as written there."""
        return tuple(text for _, text in self.removals)


# -- enumeration ------------------------------------------------------------------
def _assignments(effect: catalogue.Effect, roles: EquationRoles, has_time: bool):
    """``(variables, label, additions)`` for every way ``effect`` can enter the equation."""
    if not fits_field(effect, roles):
        return
    kind = effect.acts_through
    k = roles.index
    if kind == "state":
        yield roles.position, [(k, effect.term_for(s=roles.position))]
    elif kind == "interaction":
        # in the equation alone, in the other state's too and in a third's, with a
        # coefficient of each one's own: what one species loses to the reaction another
        # loses or gains, by a yield
        own = roles.position
        for other, partner in roles.partners:
            for variable, term in _interaction_readings(effect, own, other):
                yield variable, [(k, term)]
                yield variable, [(k, term), (partner, term)]
                # and what the two form, a third state (A + B -> C), by a yield of its own
                for _, third in roles.partners:
                    if third != partner:
                        yield variable, [(k, term), (partner, term), (third, term)]
    elif kind == "link":
        # the flow from the state to another leaves its equation and enters the other's,
        # each with a coefficient of its own (their capacities differ)
        own = roles.position
        for other, partner in roles.links:
            law = effect.term_for(s=own, r=other)
            if reverses(effect):
                yield " - ".join(sorted((own, other))), [
                    (k, law), (partner, effect.term_for(s=other, r=own))]
            else:
                # a one-way law (a diode passes current one way): the flow from this state
                # to the other leaves it and enters the other by the same law, either way
                # round a move of its own
                yield f"{own} - {other}", [(k, law), (partner, f"-({law})")]
    elif kind == "velocity":
        v = roles.velocity
        yield v, [(k, effect.term_for(v=v))]
    elif kind == "position":
        x = roles.position
        yield x, [(k, effect.term_for(x=x))]
    elif kind == "position_velocity" and roles.second_order:
        x, v = roles.position, roles.velocity
        yield f"{x}^2 {v}" if "{x}^2 {v}" in effect.term else f"{x}, {v}", \
            [(k, effect.term_for(x=x, v=v))]
    elif kind == "difference":
        x = roles.position
        for other, partner in roles.others:
            additions = [(k, effect.term_for(u=f"{x} - {other}"))]
            if partner is not None:
                additions.append((partner, effect.term_for(u=f"{other} - {x}")))
            yield f"{x} - {other}", additions
    elif kind == "time" and has_time:
        yield TIME, [(k, effect.term_for())]
    elif kind == "none":
        yield "", [(k, effect.term_for())]


def _interaction_readings(effect: catalogue.Effect, own: str, other: str):
    """``(variable, term)`` of an interaction of two states, each way it reads them.

    Once where the term is symmetric in the two (a product), else with each
    as ``{s}`` (the one a saturation levels off in); the variable names the
    two states in that order (sorted for a symmetric term).
    """
    term = effect.term_for(s=own, r=other)
    swapped = effect.term_for(s=other, r=own)
    if _shape_key(parse_expression(swapped, kind="term")) == _shape_key(
            parse_expression(term, kind="term")):
        yield " ".join(sorted((own, other))), term
        return
    yield f"{own} {other}", term
    yield f"{other} {own}", swapped


def fits_field(effect: catalogue.Effect, roles: EquationRoles) -> bool:
    """Whether ``effect`` may enter the equation of ``roles``, by field.

    A mechanical effect enters a position-velocity pair (named by its shape
    when the user says the pair is not mechanical: a charge and a current)
    and a first-order state the user says is mechanical; an effect acting
    through a first-order state's own value, or its interaction with another
    such state, enters the other first-order states, those of its field or of
    an unknown quantity; so does any other effect of one field (a valve's
    characteristic, in how a process's input is read).
    """
    if effect.field == "mechanics":
        return roles.second_order or roles.mechanical
    own_rate = effect.acts_through in catalogue.FIRST_ORDER_PLACES
    if own_rate and (roles.second_order or roles.mechanical):
        return False
    if not own_rate and effect.field == "any":
        return True
    return roles.position_quantity is None or roles.position_quantity in effect.quantities


def _curve_term(effect: catalogue.Effect, roles: EquationRoles, variable: str) -> str | None:
    if effect.curve is None:
        return None
    kind = effect.acts_through
    if kind == "state":
        return effect.curve_for(s=roles.position)
    if kind == "velocity":
        return effect.curve_for(v=roles.velocity)
    if kind == "position":
        return effect.curve_for(x=roles.position)
    if kind == "difference":
        return effect.curve_for(u=variable)
    return None


def enumerate_candidates(skeleton: Skeleton, roles: list[EquationRoles],
                         has_time: bool) -> list[Candidate]:
    """Every catalogue effect in every equation and through every variable it can use."""
    out, seen = [], set()
    for r in roles:
        present = {_effect_of(node, r, has_time)[0].name
                   for _, node in signed_terms(_equation(skeleton, r.index).rhs)}
        for effect in catalogue.catalogue():
            if effect.requires and not present & set(effect.requires):
                continue
            for variable, additions in _assignments(effect, r, has_time):
                # a coupling is proposed from both of its masses: keep it once (a one-way
                # path, a diode, once each way)
                equations = frozenset(k for k, _ in additions)
                key = (effect.name, equations, None if len(equations) > 1
                       and effect.acts_through != "interaction"
                       and (effect.acts_through != "link" or reverses(effect)) else variable)
                if key in seen:
                    continue
                seen.add(key)
                candidate = Candidate(effect, r, variable, additions,
                                      _curve_term(effect, r, variable))
                if not absorbed(skeleton, candidate):
                    out.append(candidate)
                    out.extend(_balanced(candidate, r))
    return out


#: what a state measures for a reaction's stoichiometry to hold between it and others: amounts
#: of species in one unit (a predator's catch feeds it by an efficiency of its own)
STOICHIOMETRIC = ("concentration", "amount")


def _balanced(candidate: Candidate, roles: EquationRoles) -> list[Candidate]:
    """The reaction of ``candidate`` at the stoichiometry of a balance, as a move of its own.

    A reaction ``A + B -> C`` consumes one A and one B for every C it forms:
    one rate, subtracted from the reactants' equations and added to the
    product's, where the free move fits a yield in each. Tried where the
    reaction enters two or three equations of species of one quantity in
    :data:`STOICHIOMETRIC` (the first two consumed, the third formed).
    """
    additions = candidate.additions
    joined = {k for _, k in roles.links} | {roles.index}
    if (candidate.effect.acts_through != "interaction" or len(additions) < 2
            or roles.position_quantity not in STOICHIOMETRIC
            or any(k not in joined for k, _ in additions)):
        return []
    (first, term), (second, _), *formed = additions
    balanced = [(first, term), (second, term), *((k, f"-({term})") for k, _ in formed)]
    return [replace(candidate, additions=balanced, balanced=True)]


def _equation(skeleton: Skeleton, index: int):
    return next(eq for eq in skeleton.parsed if eq.index == index)


def fitted_terms(skeleton: Skeleton, roles: EquationRoles, inputs: set[str]):
    """``(sign, node)`` of an equation's terms with fitted numbers and no input.

    Terms with a free curve are left alone: a curve already takes any shape.
    """
    for sign, node in signed_terms(_equation(skeleton, roles.index).rhs):
        items = list(walk(node))
        if any(isinstance(n, Unknown) for n in items) or \
                not any(isinstance(n, Param) for n in items):
            continue
        if symbols_in(node) & inputs:
            continue  # a gain: the skeleton's own input, not a physical effect to swap
        yield sign, node


def _shape_key(node: Node) -> Counter:
    """The term's factors other than coefficients, with every parameter named alike."""
    same = {n.name: "a" for n in walk(node) if isinstance(n, Param)}
    return Counter(to_text(rename(f, same)) for f in _shape(product_factors(node)))


#: the effect a removed term is reported as when it is no catalogue effect
UNNAMED = catalogue.Effect("skeleton_term", "a term of the skeleton that is no catalogue "
                           "effect", "none", "a1")


def _effect_of(node: Node, roles: EquationRoles, has_time: bool) -> tuple[catalogue.Effect, str]:
    """The catalogue effect ``node`` is an instance of, and its variable."""
    key = _shape_key(node)
    for effect in catalogue.catalogue():
        for variable, additions in _assignments(effect, roles, has_time):
            # a path is known by its flow either way round (the skeleton may write the
            # inflow of one state as the other's difference)
            terms = additions if effect.acts_through == "link" else additions[:1]
            if (len(additions) == 1 or effect.acts_through == "link") and any(
                    _shape_key(parse_expression(t, kind="term")) == key for _, t in terms):
                return effect, variable
    return UNNAMED, ", ".join(sorted(symbols_in(node)))


def enumerate_moves(skeleton: Skeleton, roles: list[EquationRoles],
                    has_time: bool) -> list[Candidate]:
    """Replacements and removals of the skeleton's own terms.

    A term that is an instance of a catalogue effect may be replaced by
    every effect that names it in :attr:`~sklearn_pycc.effects.Effect.replaces`
    (a linear spring by a pendulum's sine, viscous damping by quadratic
    drag); any term with fitted numbers and no input may be removed.
    """
    inputs = set(skeleton.inputs)
    by_index = {r.index: r for r in roles}
    out, seen = [], set()
    for r in roles:
        for sign, node in fitted_terms(skeleton, r, inputs):
            old, variable = _effect_of(node, r, has_time)
            removed = _removal(skeleton, [(r.index, sign, node)])
            out.append(Candidate(old, r, variable, [], None, move="remove", **removed))
            out.extend(_inflows(skeleton, r, sign, node, by_index=by_index,
                                has_time=has_time, removed=removed))
            for effect in catalogue.catalogue():
                if old.name not in effect.replaces:
                    continue
                moves = [(v, a, None) for v, a in _assignments(effect, r, has_time)]
                moves += _flows(effect, r, (sign, node), skeleton, by_index=by_index,
                                inputs=inputs, has_time=has_time)
                for variable, additions, nodes in moves:
                    removing = removed
                    if nodes is not None:
                        removing = _removal(skeleton, nodes)
                    elif len(additions) > 1 and effect.acts_through in ("interaction",
                                                                          "link"):
                        # an interaction or a path the user wrote in both states'
                        # equations is replaced in both at once
                        partner = additions[1][0]
                        twin = _twin(skeleton, by_index[partner], old, node, inputs=inputs,
                                     has_time=has_time)
                        if twin is None:
                            continue
                        removing = _removal(skeleton, [(r.index, sign, node), twin])
                    key = (effect.name, frozenset(removing["removals"]), variable,
                           frozenset(k for k, _ in additions))
                    if key in seen:
                        continue
                    seen.add(key)
                    candidate = Candidate(effect, r, variable, additions,
                                          _curve_term(effect, r, variable), move="replace",
                                          **removing)
                    reduced = skeleton
                    for k, term in removing["removals"]:
                        reduced = reduced.remove_term(k, term)
                    if not absorbed(reduced, candidate):
                        out.append(candidate)
    return out


def _removal(skeleton: Skeleton, terms: list[tuple[int, float, Node]]) -> dict:
    """The removal fields of a :class:`Candidate` taking ``(equation, sign, node)`` out."""
    reduced = skeleton
    for k, _, node in terms:
        reduced = reduced.remove_term(k, to_text(node))
    return dict(removals=[(k, to_text(node)) for k, _, node in terms],
                removed_params=[a for a in skeleton.params if a not in reduced.params],
                removed_nodes=list(terms))


def _flow_twin(skeleton: Skeleton, by_index: dict, k: int, node: Node,
               inputs: set[str]) -> tuple[int, float, Node] | None:
    """The term of equation ``k`` of the same shape as ``node`` (a storage's inflow)."""
    for sign, other in fitted_terms(skeleton, by_index[k], inputs):
        if _shape_key(other) == _shape_key(node):
            return k, sign, other
    return None


def _inflows(skeleton: Skeleton, roles: EquationRoles, sign: float, node: Node, *,
             by_index: dict, has_time: bool, removed: dict) -> list[Candidate]:
    """Another storage's inflow, read by each law of that storage's outflow.

    A term of the equation that reads only another first-order state
    (``a2 x1`` in ``x2_dot``) is that state's outflow coming in; it is
    replaced by each law that replaces the term as that state's own
    (``a sqrt(x1)``), keeping its sign.
    """
    out = []
    for other, k in roles.partners:
        if symbols_in(node) & set(skeleton.states) != {other}:
            continue
        source = by_index[k]
        old, _ = _effect_of(node, source, has_time)
        for effect in catalogue.catalogue():
            if old.name not in effect.replaces or effect.acts_through != "state":
                continue
            term = effect.term_for(s=other)
            added = f"-({term})" if sign > 0 else term
            out.append(Candidate(effect, roles, other, [(roles.index, added)], None,
                                 move="replace", **removed))
    return out


def _flows(effect: catalogue.Effect, roles: EquationRoles, own_term: tuple[float, Node],
           skeleton: Skeleton, *, by_index: dict, inputs: set[str], has_time: bool) -> list:
    """A storage's law of outflow replacing its own term and the next storage's inflow.

    Where the state's own term (``a2 x1`` in ``x1_dot``) has a twin of the
    same shape in another first-order state's equation (``a3 x1`` in
    ``x2_dot``: what the first storage loses the second gains), the law
    replaces both, subtracted from the first and added to the second, each
    with its own coefficient (a yield). Where that storage drains by a term
    of the same law as the first's (``a4 x2``), the law also replaces it,
    and so on down the chain: storages built alike (a cascade of tanks) drain
    alike, and one storage's law alone, written into a chain still linear
    further down, fits neither.

    Returns ``(variable, additions, removed)`` triples, ``removed`` the
    ``(equation, sign, node)`` terms each replaces.
    """
    sign, node = own_term
    own = roles.position
    if effect.acts_through != "state" or not roles.partners \
            or symbols_in(node) & set(skeleton.states) != {own}:
        return []
    old, _ = _effect_of(node, roles, has_time)
    term = effect.term_for(s=own)
    out = []
    for _, k in roles.partners:
        twin = _flow_twin(skeleton, by_index, k, node, inputs)
        if twin is None:
            continue
        additions = [(roles.index, term), (k, f"-({term})")]
        nodes = [(roles.index, sign, node), twin]
        out.append((own, list(additions), list(nodes)))
        # the chain: each next storage's own term of the same law, and its own inflow twin
        visited, current = {roles.index}, k
        while current not in visited and len(additions) < CHAIN_ADDITIONS:
            visited.add(current)
            drain = _own_term(skeleton, by_index[current], old, sign, inputs=inputs,
                              has_time=has_time)
            if drain is None:
                break
            state = by_index[current].position
            law = effect.term_for(s=state)
            additions.append((current, law))
            nodes.append(drain)
            out.append((own, list(additions), list(nodes)))
            following = [(j, t) for _, j in by_index[current].partners if j not in visited
                         for t in [_flow_twin(skeleton, by_index, j, drain[2], inputs)]
                         if t is not None]
            if len(following) != 1:
                break
            current, onward = following[0]
            additions.append((current, f"-({law})"))
            nodes.append(onward)
            out.append((own, list(additions), list(nodes)))
    return out


#: the most terms one law takes down a chain of storages (three storages): a longer chain is
#: changed over several rounds, each judged on its own
CHAIN_ADDITIONS = 5


def _own_term(skeleton: Skeleton, roles: EquationRoles, old: catalogue.Effect, sign: float, *,
              inputs: set[str], has_time: bool) -> tuple[int, float, Node] | None:
    """The term of ``roles``' equation that is ``old`` on its own state, with ``sign``."""
    for s, other in fitted_terms(skeleton, roles, inputs):
        if (s == sign and symbols_in(other) & set(skeleton.states) == {roles.position}
                and _effect_of(other, roles, has_time)[0].name == old.name):
            return roles.index, s, other
    return None


def _twin(skeleton: Skeleton, roles: EquationRoles, effect: catalogue.Effect, node: Node, *,
          inputs: set[str], has_time: bool) -> tuple[int, float, Node] | None:
    """The term of ``roles``' equation that is ``effect`` on the same states as ``node``."""
    for sign, other in fitted_terms(skeleton, roles, inputs):
        if (symbols_in(other) == symbols_in(node)
                and _effect_of(other, roles, has_time)[0].name == effect.name):
            return roles.index, sign, other
    return None


def enumerate_input_moves(skeleton: Skeleton,
                          roles: list[EquationRoles]) -> list[Candidate]:
    """Every term that reads an input as measured, reading it another way instead.

    The moves of the catalogue's effects acting through an input: the term
    keeps its shape and its coefficient's role, and the input in it is read
    late (``u`` -> ``u(t - a)``), levelled off (``a tanh(u/a)``) or past a
    dead zone. An input already read so, or inside a function, is left alone;
    the input's shape is changed only in the equations of states that are
    not mechanical.
    """
    inputs = {name for name in skeleton.inputs if read_delayed(name) is None}
    out = []
    for effect in catalogue.catalogue():
        if effect.acts_through != "input":
            continue
        for r in roles:
            if not fits_field(effect, r):
                continue
            if (r.second_order or r.mechanical) and not _keeps_shape(effect):
                # a forced mechanical record shows friction and springs in the shapes an
                # actuator's limit would take: the catalogue's own effects speak there
                continue
            for sign, node in signed_terms(_equation(skeleton, r.index).rhs):
                text = to_text(node)
                for name in sorted(_plainly_read(node) & inputs):
                    read, bounds = _input_reading(effect, name, skeleton)
                    changed = to_text(substitute(node, name, read))
                    # added terms are subtracted: an input's term keeps its own sign
                    term = f"-({changed})" if sign > 0 else changed
                    reduced = skeleton.remove_term(r.index, text)
                    gone = [a for a in skeleton.params if a not in reduced.params]
                    out.append(Candidate(
                        effect, r, name, [(r.index, term)], None, move="replace",
                        removals=[(r.index, text)], removed_params=gone,
                        removed_nodes=[(r.index, sign, node)], bounds=bounds))
    return out


def _keeps_shape(effect: catalogue.Effect) -> bool:
    """Whether ``effect`` reads its input unchanged in shape (late, as a delay does)."""
    return isinstance(parse_expression(effect.term_for(i="u"), kind="term"), Symbol)


def _plainly_read(node: Node) -> set[str]:
    """The variables a term reads as a factor or a sum's part, not inside a function."""
    inside = {n.name for f in walk(node) if isinstance(f, (Apply, Unknown))
              for n in walk(f.arg) if isinstance(n, Symbol)}
    return symbols_in(node) - inside


def _input_reading(effect: catalogue.Effect, name: str,
                   skeleton: Skeleton) -> tuple[Node, tuple[str, ...]]:
    """How ``effect`` reads the input ``name``, and the bounds of its parameters.

    Its parameters are numbered past the skeleton's, so that none is taken
    for the term's own; its bounds are renamed alike.
    """
    read = parse_expression(effect.term_for(i=name), kind="term")
    start = 1 + max((int(a[1:]) for a in skeleton.params), default=0) + 900
    mapping = {a: f"a{start + k}" for k, a in enumerate(params_in(read))}
    bounds = tuple(str(replace(b, param=mapping[b.param]))
                   for b in parse_constraints(list(effect.bounds)))
    return rename(read, mapping), bounds


@functools.cache
def reverses(effect: catalogue.Effect) -> bool:
    """Whether a path's law changes sign when its two states swap (a flow either way round).

    A linear, an orifice's or a radiating path does; a diode's does not: the
    flow from ``{s}`` into ``{r}`` is then written alike in both equations.
    Read at a few points, every number 0.7.
    """
    there = parse_expression(effect.term_for(s="x1", r="x2"), kind="term")
    back = parse_expression(effect.term_for(s="x2", r="x1"), kind="term")
    params = {n.name: 0.7 for n in walk(there) if isinstance(n, Param)}
    env = [np.array([0.3, 0.9, 1.7, -0.4]), np.array([1.1, -0.2, 0.4, 0.8])]
    with np.errstate(all="ignore"):
        values = [np.asarray(compile_expression(node, {"x1": 0, "x2": 1}, params, {})(env),
                             dtype=float) for node in (there, back)]
    return bool(np.allclose(values[0], -values[1]))


# -- redundancy with a free curve already in the equation -----------------------------
def symbols_in(node: Node) -> set[str]:
    return {n.name for n in walk(node) if isinstance(n, Symbol)}


def _parity_of(factors: list[Node], z: str) -> str | None:
    """``"odd"``, ``"even"`` or None for the product of ``factors`` as a function of ``z``.

    A factor with a curve of its own (an open curve's ``f1(x2)``) has no
    parity to promise: None.
    """
    if any(isinstance(n, Unknown) for f in factors for n in walk(f)):
        return None
    params = {n.name: 0.7 for f in factors for n in walk(f) if isinstance(n, Param)}
    points = np.array([0.3, 0.9, 1.7, 2.6])
    values = {}
    for sign in (1.0, -1.0):
        env = [sign * points]
        total = np.ones_like(points)
        for f in factors:
            with np.errstate(all="ignore"):
                total = total * np.broadcast_to(
                    np.asarray(compile_expression(f, {z: 0}, params, {})(env), dtype=float),
                    points.shape)
        values[sign] = total
    if np.allclose(values[1.0], values[-1.0]):
        return "even"
    if np.allclose(values[1.0], -values[-1.0]):
        return "odd"
    return None


def _shape(factors: list[Node]) -> list[Node]:
    """The factors that are not bare parameters or numbers."""
    return [f for f in factors if not isinstance(f, (Param, Number))]


def absorbed(skeleton: Skeleton, candidate: Candidate) -> bool:
    """Whether the equation can already take the term's shape.

    A term already present up to its coefficient (``a3 x2`` beside
    ``a1 x2``) is redundant; a free curve ``f1(x2)`` absorbs any term of
    ``x2`` alone (of its parity, if it has one), and ``f1(x1) x2`` absorbs
    any ``g(x1) x2``.
    """
    # a path's flow is the same term either way round, (x1 - x2) or (x2 - x1)
    link = candidate.effect.acts_through == "link"
    for k, text in candidate.additions:
        eq = skeleton.parsed[k]
        term_factors = product_factors(parse_expression(text, kind="term"))
        shapes = [Counter(_shape(product_factors(parse_expression(t, kind="term"))))
                  for _, t in candidate.additions] if link else [Counter(_shape(term_factors))]
        for existing in sum_terms(eq.rhs):
            factors = product_factors(existing)
            shape = _shape(factors)
            if shape and Counter(shape) in shapes:
                return True
            curves = [f for f in factors if isinstance(f, Unknown)]
            if len(curves) != 1 or not isinstance(curves[0].arg, Symbol):
                continue
            curve, z = curves[0], curves[0].arg.name
            others = [f for f in factors if f is not curve]
            if not all(isinstance(f, (Param, Number, Symbol)) for f in others):
                continue
            needed = [f.name for f in others if isinstance(f, Symbol)]
            rest = list(term_factors)
            for name in needed:
                match = next((f for f in rest if isinstance(f, Symbol) and f.name == name), None)
                if match is None:
                    break
                rest.remove(match)
            else:
                symbols = set().union(*(symbols_in(f) for f in rest)) if rest else set()
                if not symbols <= {z}:
                    continue
                kinds = {c.kind for c in skeleton.constraints_of(curve.name)}
                if not symbols:
                    if not kinds:
                        return True
                    continue
                parity = "odd" if "odd" in kinds else "even" if "even" in kinds else None
                if parity is None or _parity_of(rest, z) == parity:
                    return True
    return False


# -- screening: fit the term to the residual alone ------------------------------------
def _screen_skeleton(candidate: Candidate, states: list[str],
                     basis: list[list[str]]) -> tuple[Skeleton, list[str], list[str]]:
    """``z_i_dot = - terms_i + c1 b1 + c2 b2 ...`` per equation the candidate enters.

    One screening equation per equation the candidate adds to, in the order
    of its first addition there, holding every term it adds there.
    ``basis[i]`` names columns holding the fitted values of the equation's
    own terms: the screen may rescale them, as the refit will. Returns the
    skeleton, its state names and the parameters of the candidate's terms.
    """
    ks = list(dict.fromkeys(k for k, _ in candidate.additions))
    names = [f"{_prefix(states)}{i}" for i in range(len(ks))]
    skeleton = Skeleton([f"{name}_dot = 0" for name in names])
    rate: list[str] = []  # a balanced reaction's one rate, in the screen's names
    for k, term in candidate.additions:
        if rate:
            law, node, own = _law_of(term)
            text = term.replace(law, to_text(rename(node, dict(zip(own, rate)))))
            skeleton = skeleton.add_term(ks.index(k), text, shared=rate)
            continue
        taken = set(skeleton.params)
        skeleton = skeleton.add_term(ks.index(k), term, constraints=list(candidate.term_bounds))
        if candidate.balanced:
            rate = sorted(set(skeleton.params) - taken, key=lambda a: int(a[1:]))
    own = list(skeleton.params)
    for i, columns in enumerate(basis):
        for column in columns:
            skeleton = skeleton.add_term(i, f"a1 {column}", sign="+")
    return skeleton, names, own


def _prefix(states) -> str:
    prefix = "zscreen"
    while any(s.startswith(prefix) for s in states):
        prefix += "z"
    return prefix


def _term_values(model, data: Record, equations) -> dict[int, list]:
    """Per equation, ``(term text, fitted values)`` of its terms with fitted numbers."""
    slots, env = data.environment()
    out = {}
    for k in equations:
        items = []
        for sign, node in signed_terms(_equation(model.skeleton_, k).rhs):
            if not any(isinstance(n, (Param, Unknown)) for n in walk(node)):
                continue
            with np.errstate(all="ignore"):
                values = compile_expression(node, slots, model.params_, model.functions_)(env)
            values = sign * np.broadcast_to(np.asarray(values, dtype=float), (data.n_samples,))
            if np.isfinite(values).all() and np.any(values):
                items.append((to_text(node), values))
        out[k] = items
    return out


def _largest_other_term(model, data: Record, k: int, added: Node, *, slots, env) -> float:
    """RMS of the largest term of ``model``'s equation ``k`` on the data, but ``added``."""
    largest = 0.0
    for _, node in signed_terms(_equation(model.skeleton_, k).rhs):
        if to_text(node) == to_text(added):
            continue
        with np.errstate(all="ignore"):
            values = compile_expression(node, slots, model.params_, model.functions_)(env)
        values = np.broadcast_to(np.asarray(values, dtype=float), (data.n_samples,))
        if np.isfinite(values).all():
            largest = max(largest, float(np.sqrt(np.mean(values ** 2))))
    return largest


def _projected_rss(target: np.ndarray, columns: list[np.ndarray]) -> float:
    """Residual sum of squares of ``target`` once the best combination of ``columns`` is off."""
    if not columns:
        return float(target @ target)
    design = np.column_stack(columns)
    coef = np.linalg.lstsq(design, target, rcond=None)[0]
    rest = target - design @ coef
    return float(rest @ rest)


def _law_of(term: str) -> tuple[str, Node, list[str]]:
    """A term's law (``"-(law)"``, a flow entering, read as the law), parsed, and its numbers."""
    law = term[2:-1] if term.startswith("-(") and term.endswith(")") else term
    node = parse_expression(law, kind="term")
    return law, node, sorted(params_in(node), key=lambda a: int(a[1:]))


def extend(skeleton: Skeleton, candidate: Candidate) -> None:
    """Build the changed skeleton, its renumbered terms and its new parameters.

    Terms are added before any is removed, so a replacement's parameters get
    fresh names rather than those of the term it replaces.
    """
    extended = skeleton
    added = []
    shapes: dict[str, dict[str, str]] = {}  # a law's text -> its shape's names in extended
    for k, term in candidate.additions:
        before = extended.equations[k]
        law, node, own = _law_of(term)
        shape = shapes.get(law, {})
        if shape:  # the flow another equation carries: its own yield, the law's shape
            text = term.replace(law, to_text(rename(node, shape)))
            bounds = [b for b in parse_constraints(list(candidate.term_bounds))
                      if getattr(b, "param", None) not in shape]
            extended = extended.add_term(k, text, constraints=[str(b) for b in bounds],
                                         shared=shape.values())
        else:
            taken = set(extended.params)
            extended = extended.add_term(k, term, constraints=list(candidate.term_bounds))
            fresh = sorted(set(extended.params) - taken, key=lambda a: int(a[1:]))
            if candidate.balanced and len(fresh) == len(own):  # one rate: every number
                shapes[law] = dict(zip(own, fresh))
            elif len(fresh) == len(own) > 1:  # every number but the leading coefficient
                shapes[law] = dict(zip(own[1:], fresh[1:]))
        added.append((k, extended.equations[k][len(before) + 3:]))
    for k, term in candidate.removals:
        extended = extended.remove_term(k, term)
    candidate.extended = extended
    candidate.added = added
    candidate.new_params = [a for a in extended.params if a not in skeleton.params]


def removed_contribution(model, candidate: Candidate, data: Record) -> np.ndarray:
    """What the removed terms add to each equation's prediction, under ``model``'s fit."""
    out = np.zeros_like(data.derivatives)
    slots, env = data.environment()
    for k, sign, node in candidate.removed_nodes:
        with np.errstate(all="ignore"):
            values = compile_expression(node, slots, model.params_, model.functions_)(env)
        out[:, k] += sign * np.broadcast_to(np.asarray(values, dtype=float), (data.n_samples,))
    return out


def screen_candidates(candidates: list[Candidate], data: Record, residuals: np.ndarray,
                      states: list[str], max_rows: int = 2000, *, model=None) -> None:
    """Fit each candidate's term(s) to the residual of its equation(s) alone.

    A move that takes terms out (``model`` then gives their fitted values)
    is screened on the residual of the model without them: a removal by
    that residual itself, a replacement by fitting its term to it.
    """
    from ..estimators import PolyCCRegressor

    n = data.n_samples
    floors = rss_floor(data.derivatives)
    rows = np.arange(n) if n <= max_rows else np.linspace(0, n - 1, max_rows).astype(int)
    frame = pd.DataFrame({name: values[rows] for name, values in data.columns.items()
                          if not name.endswith("_dot")})
    scale = len(rows) / n
    own_terms = {} if model is None else _term_values(
        model, data, sorted({k for c in candidates for k in c.equations}))
    basis_names = {}
    prefix = _prefix([*states, *frame.columns]) + "basis"
    for k, items in own_terms.items():
        for j, (text, values) in enumerate(items):
            basis_names[(k, text)] = f"{prefix}{k}k{j}"
            frame[f"{prefix}{k}k{j}"] = values[rows]
    simpler = {id(c): _simpler_forms(c, candidates) for c in candidates}
    first = [c for c in candidates if not simpler[id(c)]]
    for candidate in [*first, *(c for c in candidates if simpler[id(c)])]:
        if simpler[id(candidate)] and not _worth_screening(simpler[id(candidate)], first):
            candidate.note = (f"not screened: {simpler[id(candidate)][0].effect.name}, its "
                              "simpler form, takes little of the residual")
            continue
        target = residuals
        if candidate.removed_nodes:
            target = residuals + removed_contribution(model, candidate, data)
        kept = {k: [(text, values) for text, values in own_terms.get(k, [])
                    if (k, text) not in candidate.removals] for k in candidate.equations}
        if candidate.move == "remove":
            # the other terms of the equation may take up what the removed one did
            ks = candidate.equations
            before = np.sum(residuals[:, ks] ** 2, axis=0)
            after = np.array([_projected_rss(target[:, k], [v for _, v in kept[k]])
                              for k in ks])
            candidate.screen_bic, candidate.screen_removed = _delta_bic(
                before, after, floors[ks], candidate.n_change, n)
            continue
        ks = list(dict.fromkeys(k for k, _ in candidate.additions))
        basis = [[basis_names[(k, text)] for text, _ in kept[k]] for k in ks]
        skeleton, names, own = _screen_skeleton(candidate, states, basis)
        # the residual (measured minus model) of a missing subtracted term is -term,
        # which is what the screening equation ``z_dot = 0 - term`` predicts; the
        # equation's own terms may change their scale, as they will when refitted
        targets = pd.DataFrame({f"{name}_dot": target[rows, k] for name, k in zip(names, ks)})
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fitted = PolyCCRegressor(equations=skeleton, gauge="auto").fit(frame, targets)
                predicted = np.asarray(fitted.predict(frame)).reshape(len(rows), -1)
        except (SkeletonError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            candidate.note = f"could not be fitted to the residual: {exc}"
            continue
        # what the equations' own terms take by a change of scale alone, the model's refit
        # takes too: only what the new terms take beyond it counts (a move that touches
        # more equations would otherwise collect each one's rescaling as its own gain)
        before = np.array([_projected_rss(residuals[rows, k],
                                          [v[rows] for _, v in own_terms.get(k, [])])
                           for k in ks]) / scale
        after = np.sum((targets.to_numpy() - predicted) ** 2, axis=0) / scale
        candidate.screen_bic, candidate.screen_removed = _delta_bic(
            before, after, floors[ks], len(own) - len(candidate.removed_params), n)
        candidate.screen_params = {a: float(fitted.params_[a]) for a in own}


#: an effect that holds a simpler one is screened only where one of its simpler forms is
#: among this many best of that effect's screens
SIMPLER_LEADERS = 4


def _simpler_forms(candidate: Candidate, candidates: list[Candidate]) -> list[Candidate]:
    """The candidates adding, to the same equations through the same states, a simpler effect."""
    if candidate.move != "add" or not candidate.effect.generalises:
        return []
    where = (frozenset(k for k, _ in candidate.additions),
             frozenset(candidate.variable.split()))
    return [c for c in candidates if c.move == "add"
            and c.effect.name in candidate.effect.generalises
            and (frozenset(k for k, _ in c.additions), frozenset(c.variable.split())) == where]


def _worth_screening(forms: list[Candidate], screened: list[Candidate]) -> bool:
    """Whether one of ``forms`` took some of the residual, among its effect's best screens."""
    for form in forms:
        rivals = sorted(c.screen_bic for c in screened if c.effect.name == form.effect.name
                        and math.isfinite(c.screen_bic))
        if form.screen_bic < 0 and form.screen_bic <= rivals[:SIMPLER_LEADERS][-1]:
            return True
    return False


#: residuals below this fraction of the derivative's RMS are rounding, not signal
PRECISION = 1e-9


def rss_floor(derivatives: np.ndarray) -> np.ndarray:
    """Per equation, the residual sum of squares that rounding alone explains."""
    n = derivatives.shape[0]
    scale = np.sqrt(np.mean(derivatives**2, axis=0))
    return np.maximum(n * (PRECISION * scale) ** 2, 1e-300)


def _delta_bic(before, after, floor, n_new: int, n: int) -> tuple[float, float]:
    """BIC change of adding ``n_new`` parameters, and the share of the residual removed.

    ``n sum(log(RSS'/RSS)) + n_new log n`` over the equations changed, with
    each RSS held above its rounding ``floor``.
    """
    before = np.maximum(np.asarray(before, dtype=float), floor)
    after = np.maximum(np.asarray(after, dtype=float), floor)
    bic = float(n * np.sum(np.log(after / before)) + n_new * math.log(n))
    return bic, float(1.0 - after.sum() / before.sum())


#: scores this close to the leader's (relative, absolute) count as a tie won by fewer parameters
TIE = (0.02, 10.0)


# -- refit of the extended skeleton -------------------------------------------------
def _concrete(node: Node, params: dict) -> Node:
    """``node`` with each fitted delay at its value in ``params``.

    ``u(t - a4)`` becomes ``u(t - 0.3)``, as the fitted skeleton writes it.
    """
    late = {}
    for n in walk(node):
        read = read_delayed(n.name) if isinstance(n, Symbol) else None
        if read is not None and isinstance(read[1], str):
            late[n.name] = delayed_name(read[0], float(params[read[1]]))
    return rename_symbols(node, late) if late else node


def start_values(model, candidate: Candidate) -> dict[str, float]:
    """Where a fit of ``candidate``'s skeleton starts: the model's numbers and the screen's.

    The user's ``param_init`` for the parameters the skeleton keeps, all
    within the skeleton's bounds.
    """
    init = {a: v for a, v in model.params_.items() if a in candidate.extended.params}
    init.update({a: candidate.screen_params[s]
                 for a, s in zip(candidate.new_params, list(candidate.screen_params))})
    user = model.get_params(deep=False).get("param_init") or {}
    init.update({a: v for a, v in user.items() if a in candidate.extended.params})
    bounds = candidate.extended.bounds
    return {a: float(np.clip(v, *bounds.get(a, (-np.inf, np.inf)))) for a, v in init.items()}


def refit_candidate(model, candidate: Candidate, data: Record, residuals: np.ndarray,
                    rss_before: np.ndarray, *, baseline: frozenset = frozenset()) -> None:
    """Fit the extended skeleton with a clone of ``model``; judge the added term.

    ``baseline`` holds the ``(equation, role)`` pairs the model itself already
    breaks (an inverted pendulum's spring pushes away by design): a refit is
    judged only on what it changes.
    """
    params = model.get_params(deep=False)
    init = start_values(model, candidate) if "param_init" in params else None
    other = {}
    if candidate.move == "open" and params.get("extrapolation") == "polynomial":
        # a free curve judged by simulations that may stray beyond its data
        other["extrapolation"] = "linear"
    # judged by its residuals: no refits on resamples
    estimator = prepared(model, equations=candidate.extended, param_init=init, **other)
    rows = None
    if params.get("fit_mode") != "simulation":  # an output-error fit needs every sample
        rows = thin(np.arange(data.n_samples))
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            fit_rows(estimator, data, rows)
            predicted = data.predict(estimator)
    except Exception as exc:  # any failure of a backend is a finding, not a crash
        candidate.note = f"the extended skeleton could not be fitted: {exc}"
        candidate.plausible = False
        return
    if any(issubclass(w.category, RankDeficiencyWarning) for w in caught):
        candidate.redundant = True
        candidate.plausible = False
        candidate.note = "redundant with the skeleton (the extended fit is rank deficient)"
    candidate.refit = estimator
    if candidate.move == "open":
        candidate.curve_numbers = max(
            int(estimator.n_parameters_) - int(model.n_parameters_)
            - len(candidate.new_params) + len(candidate.removed_params), 0)
    ks = candidate.equations
    # what the refit changes in each equation's prediction: the shape the residual should have
    base = data.derivatives - residuals
    candidate.shifts = {k: predicted[:, k] - base[:, k] for k in ks}
    candidate.after_squares = (data.derivatives[:, ks] - predicted[:, ks]) ** 2
    after = candidate.after_squares.sum(axis=0)
    before = rss_before[ks]
    n = data.n_samples
    _, candidate.removed = _delta_bic(before, after, rss_floor(data.derivatives)[ks],
                                      candidate.n_change, n)
    # judged on every equation: a refit by output error moves the numbers of all of them, and
    # a move that touches more equations would otherwise collect their change as its own
    every = np.sum((data.derivatives - predicted) ** 2, axis=0)
    candidate.delta_bic, _ = _delta_bic(rss_before, every, rss_floor(data.derivatives),
                                        candidate.n_change, n)
    candidate.rmse_before = float(np.sqrt(before.sum() / (n * len(ks))))
    candidate.rmse_after = float(np.sqrt(after.sum() / (n * len(ks))))
    _judge(candidate, estimator, data, baseline)


def _judge(candidate: Candidate, estimator, data: Record,
           baseline: frozenset = frozenset()) -> None:
    """Plausibility of the fitted term: energy balance and size.

    A term is absurdly large beside the derivative it explains; in a
    first-order balance (what flows in nearly equals what flows out, a growth
    its crowding, so the derivative is small beside both), beside the
    largest other term of the refitted equation. There a loss as large as
    the feed it balances is physics; whether the two only cancel each other
    is for the held-out data to tell.
    """
    if candidate.redundant:
        return
    nodes = [(k, _concrete(parse_expression(text, kind="term"), estimator.params_))
             for k, text in candidate.added]
    slots, env = data.environment([node for _, node in nodes] + [
        eq.rhs for eq in estimator.skeleton_.parsed if eq.index in candidate.equations])
    reasons = []
    for k, node in nodes:
        with np.errstate(all="ignore"):
            values = compile_expression(node, slots, estimator.params_,
                                        estimator.functions_)(env)
        values = np.broadcast_to(np.asarray(values, dtype=float), (data.n_samples,))
        if not np.isfinite(values).all():
            reasons.append("the fitted term is not finite on the data")
            continue
        if k == candidate.roles.index and candidate.effect.plausibility != "any":
            ok, why = candidate.effect.is_plausible(
                values, velocity=data.columns[candidate.roles.velocity],
                position=data.columns[candidate.roles.position])
            if not ok:
                reasons.append(why)
        if k == candidate.roles.index:
            why = _unresolved_oscillation(node, estimator.params_, data)
            if why:
                reasons.append(why)
        scale = float(np.sqrt(np.mean(data.derivatives[:, k] ** 2)))
        size = float(np.sqrt(np.mean(values**2)))
        balance = 0.0 if candidate.roles.second_order else \
            _largest_other_term(estimator, data, k, node, slots=slots, env=env)
        if scale > 0 and size > ABSURD_RATIO * max(scale, balance):
            beside = "derivative it should explain" if scale >= balance else \
                "largest other term of the equation"
            reasons.append(f"absurd size: the fitted term is {size / max(scale, balance):.3g} "
                           f"times the {beside} (terms cancel each other)")
    reasons.extend(_below_a_sample([node for _, node in nodes], data))
    # the rest of the refitted model must still play its physical roles
    reasons.extend(f"the refitted model is implausible: {item}"
                   for item in implausible_terms(estimator, data, nodes)
                   if (item.equation, item.role) not in baseline)
    candidate.plausible = not reasons
    if reasons:
        candidate.note = "; ".join(reasons)


def _below_a_sample(nodes: list[Node], data: Record) -> list[str]:
    """A fitted delay shorter than a sampling interval, in words: no transport delay.

    Between its samples an input is held, interpolated or band-limited, and
    a held input read as interpolated lags by half a sample: a delay that
    short is how the input is read, which the record cannot tell from physics.
    """
    if TIME not in data.columns:
        return []
    steps = np.diff(data.columns[TIME])
    steps = steps[steps > 0]
    if not steps.size:
        return []
    interval = float(np.median(steps))
    out = []
    for node in nodes:
        for n in walk(node):
            read = read_delayed(n.name) if isinstance(n, Symbol) else None
            if read is not None and not isinstance(read[1], str) and read[1] < interval:
                out.append(f"the delay fitted ({read[1]:.3g}) is shorter than the sampling "
                           f"interval ({interval:.3g}): that is how the input is held between "
                           "samples (say input_hold='zoh' for a held one), not a delay the "
                           "record can show")
    return out


#: fewest periods of a fitted oscillation in time that the record must hold to tell it
#: from a drift
MIN_PERIODS = 2.0


def _time_rates(node: Node, params: dict[str, float]) -> list[float]:
    """Angular frequencies ``w`` of the ``sin(w t)`` and ``cos(w t)`` in a term."""
    rates = []
    for item in walk(node):
        if not (isinstance(item, Apply) and item.func in ("sin", "cos")):
            continue
        arg = item.arg
        if isinstance(arg, Symbol) and arg.name == TIME:
            rates.append(1.0)
        elif isinstance(arg, BinOp) and arg.op == "*":
            sides = (arg.left, arg.right)
            if any(isinstance(x, Symbol) and x.name == TIME for x in sides):
                rates.extend(float(params[x.name]) for x in sides if isinstance(x, Param))
    return rates


def _unresolved_oscillation(node: Node, params: dict[str, float],
                            data: Record) -> str:
    """Why a fitted oscillation in time cannot be told from the record ("" when it can)."""
    rates = _time_rates(node, params)
    if not rates or not data.has_time:
        return ""
    t = data.columns[TIME]
    runs = [rows for _, rows in data.experiment_rows if len(rows) > 1]
    spans = [float(np.ptp(t[rows])) for rows in runs]
    steps = [float(np.median(np.diff(t[rows]))) for rows in runs]
    if not spans:
        return ""
    longest, step = max(spans), min(steps)
    for w in map(abs, rates):
        periods = w * longest / (2 * math.pi)
        if periods < MIN_PERIODS:
            return (f"the fitted oscillation (angular frequency {w:.3g}) completes "
                    f"{periods:.2g} periods in the longest experiment: the record cannot tell "
                    "it from a slow drift or offset")
        if w * step > math.pi:
            return (f"the fitted oscillation (angular frequency {w:.3g}) lies above the "
                    f"Nyquist frequency {math.pi / step:.3g} of the record")
    return ""


def _refitted(model, candidate: Candidate, data: Record, residuals: np.ndarray,
              rss_before: np.ndarray, *, baseline: frozenset) -> Candidate:
    refit_candidate(model, candidate, data, residuals, rss_before, baseline=baseline)
    return candidate


def refit_candidates(candidates: list[Candidate], model, data: Record,
                     residuals: np.ndarray, rss_before: np.ndarray, *, baseline: frozenset,
                     n_jobs: int | None) -> None:
    """Refit ``candidates`` in place, in parallel when ``n_jobs`` asks for it.

    A worker process refits a copy; its findings are written back onto the
    candidate the diagnosis holds.
    """
    if n_jobs is None or n_jobs == 1 or len(candidates) < 2:
        for candidate in candidates:
            refit_candidate(model, candidate, data, residuals, rss_before, baseline=baseline)
        return
    from joblib import Parallel, delayed

    done = Parallel(n_jobs=n_jobs)(
        delayed(_refitted)(model, c, data, residuals, rss_before, baseline=baseline)
        for c in candidates)
    for candidate, result in zip(candidates, done):
        if result is not candidate:
            for item in fields(Candidate):
                setattr(candidate, item.name, getattr(result, item.name))
