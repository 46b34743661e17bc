"""Free curves in place of a role's terms: is something missing that the catalogue lacks.

When no catalogue move helps, the method's own idea is tried before a
diagnosis says "nothing is missing": the terms that play one role in an
equation (its restoring force, its friction, the damping that multiplies the
velocity) give way to one free characteristic curve, fitted with the
diagnosed model's backend. A curve that simulates held-out data clearly
better shows an effect the catalogue has no name for; the symbolic engine
then proposes a formula for it, ready to fit.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import sympy

from ..backends.symbolic.readable import Readability
from ..effects import Effect
from ..skeleton import Skeleton
from ..skeleton.compiler import compile_expression
from ..skeleton.nodes import Node, Number, Param, Symbol, Unknown, product_factors, walk
from ..skeleton.parser import parse_expression
from ..skeleton.printer import to_text
from ._candidates import Candidate, absorbed, fitted_terms, symbols_in
from ._roles import EquationRoles

__all__ = ["OPEN_EFFECTS", "OpenCurve", "formula_candidates", "formula_values",
           "open_candidates", "open_curve_frame", "probes"]

#: the free curves tried, by the variable they act through
OPEN_EFFECTS = {
    "restoring": Effect("free_restoring_curve", "a restoring force of a shape no catalogue "
                        "effect has", "position", "f1({x})"),
    "friction": Effect("free_friction_curve", "a friction law of a shape no catalogue effect "
                       "has", "velocity", "f1({v})", plausibility="dissipative"),
    "damping": Effect("free_damping_curve", "a damping that varies with the displacement in a "
                      "way no catalogue effect has", "position_velocity", "f1({x}) {v}"),
    "state": Effect("free_state_curve", "a dependence on the state of a shape no catalogue "
                    "effect has", "state", "f1({s})"),
}
#: the effect a proposed formula is reported as
OUTSIDE = Effect("outside_catalogue", "a formula the symbolic engine proposes for a free curve",
                 "none", "a1")


def _role_of(node: Node, roles: EquationRoles) -> str | None:
    """Which free curve would take the term's place (None: no curve does)."""
    x, v = roles.position, roles.velocity
    symbols = symbols_in(node)
    if not roles.second_order:
        return "state" if symbols == {x} else None
    if symbols == {x}:
        return "restoring"
    if symbols == {v}:
        return "friction"
    factors = product_factors(node)
    bare = [f for f in factors if isinstance(f, Symbol) and f.name == v]
    rest = [f for f in factors if f not in bare]
    if len(bare) == 1 and set().union(*(symbols_in(f) for f in rest)) == {x}:
        return "damping"
    return None


def open_candidates(skeleton: Skeleton, roles: list[EquationRoles]) -> list[Candidate]:
    """For every equation and role, its terms replaced by one free curve.

    A second-order equation opens its restoring force ``f(x)``, its friction
    ``f(v)`` and the damping ``g(x) v`` that multiplies the velocity (which
    takes the place of the viscous term too); a first-order equation its
    dependence on its own state. A role without terms gets the curve added;
    one a free curve already plays is left alone.
    """
    inputs = set(skeleton.inputs)
    out = []
    for r in roles:
        kinds = ("restoring", "friction", "damping") if r.second_order else ("state",)
        terms = {kind: [] for kind in kinds}
        for sign, node in fitted_terms(skeleton, r, inputs):
            kind = _role_of(node, r)
            if kind in terms:
                terms[kind].append((sign, node))
            if kind == "friction" and "damping" in terms and _viscous(node, r.velocity):
                terms["damping"].append((sign, node))  # g(x) v takes the viscous term's place
        for kind in kinds:
            effect = OPEN_EFFECTS[kind]
            x, v = r.position, r.velocity
            variables = {"position": {"x": x}, "velocity": {"v": v}, "state": {"s": x},
                         "position_velocity": {"x": x, "v": v}}[effect.acts_through]
            term = effect.term_for(**variables)
            reduced = skeleton
            for _, node in terms[kind]:
                reduced = reduced.remove_term(r.index, to_text(node))
            label = {"restoring": x, "state": x, "friction": v, "damping": f"{x}, {v}"}[kind]
            candidate = Candidate(
                effect, r, label, [(r.index, term)], term, move="open",
                removals=[(r.index, to_text(node)) for _, node in terms[kind]],
                removed_params=[a for a in skeleton.params if a not in reduced.params],
                removed_nodes=[(r.index, sign, node) for sign, node in terms[kind]])
            if not absorbed(reduced, candidate):
                out.append(candidate)
    return out


def _viscous(node: Node, velocity: str) -> bool:
    """Whether ``node`` is a coefficient times the velocity."""
    shape = [f for f in product_factors(node) if not isinstance(f, (Param, Number))]
    return len(shape) == 1 and isinstance(shape[0], Symbol) and shape[0].name == velocity


def curve_name(candidate: Candidate) -> str:
    """The free curve the candidate's refit fitted (``"f3"``)."""
    text = next(t for k, t in candidate.added if k == candidate.roles.index)
    return next(n.name for n in walk(parse_expression(text, kind="term"))
                if isinstance(n, Unknown))


def _grid_values(node: Node, variables: dict[str, np.ndarray], params, functions) -> np.ndarray:
    slots = {name: i for i, name in enumerate(variables)}
    with np.errstate(all="ignore"):
        values = compile_expression(node, slots, params, functions)(list(variables.values()))
    size = len(next(iter(variables.values())))
    return np.broadcast_to(np.asarray(values, dtype=float), (size,)).copy()


def open_curve_frame(candidate: Candidate, model, n: int = 200) -> pd.DataFrame:
    """The free curve on a grid, with its 95 % band and the terms it replaces.

    Columns: the curve's variable, ``curve``, ``lower``, ``upper`` (NaN when
    the backend has no uncertainty without resampling) and ``current``:
    what the replaced terms of ``model`` subtract from the equation (for a
    damping ``g(x) v``, the factor ``g(x)``), zero when the role had none.
    """
    refit = candidate.refit
    name = curve_name(candidate)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            frame = refit.cc_curves(n=n, level=0.95)[name]
    except (ValueError, AttributeError, NotImplementedError):
        frame = refit.cc_curves(n=n)[name]
        frame["lower"] = frame["upper"] = math.nan
    grid = frame["x"].to_numpy()
    r = candidate.roles
    variable = r.velocity if candidate.effect is OPEN_EFFECTS["friction"] else r.position
    variables = {variable: grid}
    if candidate.effect is OPEN_EFFECTS["damping"]:
        variables[r.velocity] = np.ones_like(grid)
    current = np.zeros_like(grid)
    for _, sign, node in candidate.removed_nodes:
        current -= sign * _grid_values(node, variables, model.params_, model.functions_)
    out = pd.DataFrame({variable: grid, "curve": frame[name].to_numpy(),
                        "lower": frame["lower"].to_numpy(), "upper": frame["upper"].to_numpy(),
                        "current": current})
    out.attrs["curve"] = name
    return out


def formula_values(formula: Candidate, frame: pd.DataFrame) -> np.ndarray:
    """The refitted formula on the grid of :func:`open_curve_frame` (same convention)."""
    r = formula.roles
    variable = frame.columns[0]
    variables = {variable: frame[variable].to_numpy()}
    if variable != r.velocity and r.velocity != r.position:
        variables[r.velocity] = np.ones(len(frame))
    node = parse_expression(formula.term, kind="term")
    return _grid_values(node, variables, formula.refit.params_, formula.refit.functions_)


@dataclass(frozen=True)
class OpenCurve:
    """One free curve a diagnosis tried in place of a role's terms.

    Attributes
    ----------
    equation : str
        The derivative of the equation (``"x2_dot"``).
    role : str
        ``"free_restoring_curve"``, ``"free_friction_curve"``,
        ``"free_damping_curve"`` or ``"free_state_curve"``.
    curve_term : str
        The free curve as it entered the equation (``"f3(x1)"``).
    replaces : tuple of str
        The terms of the diagnosed skeleton it took the place of.
    curve : DataFrame or None
        The fitted curve on a grid with its 95 % band and the replaced
        terms (see :attr:`Suggestion.curve`); None when it could not be fitted.
    held_out : HeldOut or None
        Its held-out comparison with the diagnosed model, when it was made
        (a curve that does not simulate the record itself 5 % better is not
        held out).
    confirmed : bool
        Whether it lowered the held-out error clearly: something outside
        the catalogue is missing.
    formula : str or None
        The formula the symbolic engine proposes for it (the confirmed curve
        only).
    note : str
        Why it was not confirmed, when it was not.
    """

    equation: str
    role: str
    curve_term: str
    replaces: tuple[str, ...]
    curve: pd.DataFrame | None = field(default=None, repr=False, compare=False)
    held_out: object = None
    confirmed: bool = False
    formula: str | None = None
    note: str = ""


def probes(opened: list[Candidate], model, chosen: Candidate | None,
           formula: Candidate | None) -> list[OpenCurve]:
    """Every free curve tried, as :class:`OpenCurve` records."""
    out = []
    for c in opened:
        frame = None
        if c.refit is not None:
            frame = open_curve_frame(c, model)
            if c is chosen and formula is not None and formula.refit is not None:
                frame["formula"] = formula_values(formula, frame)
        out.append(OpenCurve(
            equation=c.roles.derivative, role=c.effect.name, curve_term=c.term,
            replaces=c.replaces, curve=frame, held_out=c.held_out,
            confirmed=c is chosen,
            formula=formula.term if c is chosen and formula is not None else None,
            note=c.note))
    return out


# -- a formula for the curve ----------------------------------------------------------
_SYMPY_NAMES = {"sin": "sin", "cos": "cos", "tan": "tan", "tanh": "tanh", "sinh": "sinh",
                "cosh": "cosh", "exp": "exp", "log": "log", "Abs": "abs", "sign": "sign",
                "atan": "arctan", "asin": "arcsin", "acos": "arccos"}


def formula_text(expression: sympy.Expr, variable: sympy.Symbol, name: str) -> tuple[str, list]:
    """``expression`` in the skeleton language, each float a parameter ``a1, a2, ...``.

    Returns the text (in ``name`` for ``variable``), its parameters numbered
    in reading order, and their values in the order of their names.
    Integers and rationals (exponents) stay numbers.
    """
    floats = sorted(expression.atoms(sympy.Float), key=lambda c: (float(c), str(c)))
    names = {c: f"a{k + 1}" for k, c in enumerate(floats)}

    def go(e) -> str:
        if e == variable:
            return name
        if isinstance(e, sympy.Float):
            return names[e]
        if e.is_Rational:
            return f"({e.p})" if e.q == 1 else f"({e.p}/{e.q})"
        if e.is_Add:
            return "(" + " + ".join(go(a) for a in e.args) + ")"
        if e.is_Mul:
            return "(" + "*".join(go(a) for a in e.args) + ")"
        if e.is_Pow:
            base, power = e.args
            if power == sympy.Rational(1, 2):
                return f"sqrt({go(base)})"
            if power == -1:
                return f"(1/{go(base)})"
            return f"({go(base)})^{go(power)}"
        func = _SYMPY_NAMES.get(type(e).__name__)
        if func is not None and len(e.args) == 1:
            return f"{func}({go(e.args[0])})"
        raise ValueError(f"the expression {e} has no form in the skeleton language")

    text = to_text(parse_expression(go(expression), kind="term"))
    return _in_reading_order(text, [float(c) for c in floats])


def _in_reading_order(text: str, values: list[float]) -> tuple[str, list[float]]:
    """The parameters ``a<k>`` of ``text`` renamed ``a1, a2, ...`` as they are read."""
    order: dict[int, int] = {}
    for match in re.finditer(r"\ba(\d+)\b", text):
        order.setdefault(int(match.group(1)), len(order) + 1)
    renamed = re.sub(r"\ba(\d+)\b", lambda m: f"a{order[int(m.group(1))]}", text)
    by_new = sorted(order, key=order.get)
    return renamed, [values[old - 1] for old in by_new]


#: the symbolic search behind a proposed formula (small: a learned curve is smooth)
FORMULA_SEARCH = dict(binary_operators=("+", "-", "*", "/"),
                      unary_operators=("tanh", "exp", "sin", "cos"), population_size=300,
                      generations=40)
#: largest expression sizes searched; the data choose among what each finds (a search of
#: the learned curve alone rewards fitting its wiggles with ever longer expressions)
FORMULA_SIZES = (7, 10, 13)
#: what a proposed formula may look like: no function of a function, at most 20 nodes
FORMULA_READABILITY = Readability(max_nesting=1, max_complexity=20)


def formula_candidates(candidate: Candidate, random_state: int = 0) -> list[Candidate]:
    """Formulas for the candidate's free curve, each a candidate of its own.

    The learned curve is searched by the symbolic engine at each size of
    :data:`FORMULA_SIZES`, each search choosing its expression by the
    readability rule of :func:`~sklearn_pycc.estimators.symbolic.select`;
    an expression beyond :data:`FORMULA_READABILITY` (a function of a
    function, too many nodes) is never proposed. Each distinct expression
    becomes a parametric term in place of the same terms, its numbers the
    refit's starting values. Empty when the engine is not installed or finds
    nothing readable.
    """
    from ..estimators import to_symbolic

    name = curve_name(candidate)
    r = candidate.roles
    argument = r.velocity if candidate.effect is OPEN_EFFECTS["friction"] else r.position
    symbol = sympy.Symbol(argument)
    out, seen = [], set()
    for size in FORMULA_SIZES:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                converted = to_symbolic(candidate.refit, random_state=random_state,
                                        maxsize=size,
                                        max_nesting=FORMULA_READABILITY.max_nesting,
                                        **FORMULA_SEARCH)
            expression = converted.functions_[name].to_sympy(symbol)
            if not FORMULA_READABILITY.allows(expression):
                continue
            text, values = formula_text(expression, symbol, argument)
        except (ImportError, ValueError, TypeError, AttributeError, KeyError,
                ArithmeticError, RuntimeError):
            continue
        if not values or text in seen:
            continue
        seen.add(text)
        if candidate.effect is OPEN_EFFECTS["damping"]:
            text = f"({text})*{r.velocity}"
        formula = Candidate(OUTSIDE, r, candidate.variable, [(r.index, text)], candidate.term,
                            move="open", removals=list(candidate.removals),
                            removed_params=list(candidate.removed_params),
                            removed_nodes=list(candidate.removed_nodes))
        formula.screen_params = {f"a{k + 1}": v for k, v in enumerate(values)}
        out.append(formula)
    return out
