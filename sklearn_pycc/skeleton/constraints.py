"""Prior knowledge in the skeleton language.

On characteristic curves: ``"f1 odd"``, ``"f1 even"``, ``"f2(0)=0"``,
``"f1 increasing"``, ``"f2 decreasing"``; on scalar parameters: bounds
``"a2 >= 0"``, ``"a2 <= 5"``, ``"0 <= a3 <= 10"``; on states: hard limits
``"x1 <= 12"``, ``"0 <= x2 <= 13"`` (a tank that overflows at its rim, an end
stop), which the state never leaves; an end may be a parameter to fit
(``"x1 <= a5"``: a rim whose height is not known).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from itertools import pairwise
from numbers import Real

from ..exceptions import SkeletonError
from .functions import is_param_name, is_unknown_name
from .lexer import Token, tokenize

__all__ = ["Bound", "Constraint", "StateLimit", "check_constraints", "limit_params",
           "merged_bounds", "merged_limits", "parse_constraint", "parse_constraints",
           "resolved_limits"]

#: kinds of curve constraints that are shapes rather than points
MONOTONE = ("increasing", "decreasing")
#: largest finite bound a parameter may have (a fit cannot place a number beyond it)
LARGEST_BOUND = 1e100
#: every kind of curve constraint
KINDS = ("odd", "even", "value", *MONOTONE)


@dataclass(frozen=True)
class Constraint:
    """One piece of prior knowledge about a curve.

    Attributes
    ----------
    function : str
        The curve it applies to, e.g. ``"f1"``.
    kind : {"odd", "even", "value", "increasing", "decreasing"}
        Symmetry, point value or monotony (over the range of the data).
    at, value : float or None
        For ``kind="value"``: the curve passes through ``(at, value)``.
    """

    function: str
    kind: str
    at: float | None = None
    value: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.function, str) or not is_unknown_name(self.function):
            raise SkeletonError(f"a constraint applies to a curve f1, f2, ..., got "
                                f"{self.function!r}")
        if self.kind not in KINDS:
            raise SkeletonError(f"constraint on {self.function}: kind must be one of "
                                f"{', '.join(KINDS)}, got {self.kind!r}")
        if self.kind == "value":
            for name, number in (("at", self.at), ("value", self.value)):
                if isinstance(number, bool) or not isinstance(number, Real) \
                        or not math.isfinite(number):
                    raise SkeletonError(f"constraint on {self.function}: {name} must be a "
                                        f"finite number, got {number!r}")

    def __str__(self) -> str:
        if self.kind == "value":
            return f"{self.function}({self.at:g})={self.value:g}"
        return f"{self.function} {self.kind}"


def _check_ends(what: str, low, high) -> None:
    """Refuse an end of a bound or a limit that is not a number (an infinity is) or is huge."""
    for name, number in (("low", low), ("high", high)):
        if isinstance(number, bool) or not isinstance(number, Real) or math.isnan(number):
            raise SkeletonError(f"{what}: {name} must be a number (or an infinity), got "
                                f"{number!r}")
        if math.isfinite(number) and abs(number) > LARGEST_BOUND:
            raise SkeletonError(f"{what}: {name} {number:g} is beyond {LARGEST_BOUND:g}, where "
                                "a fitted number loses its precision; rescale the quantity or "
                                "leave it unbounded")


def _end_text(end: float | str) -> str:
    return end if isinstance(end, str) else f"{end:.12g}"


def _interval_text(name: str, low: float | str, high: float | str) -> str:
    """``name <= high``, ``name >= low`` or ``low <= name <= high``."""
    if not isinstance(low, str) and math.isinf(low):
        return f"{name} <= {_end_text(high)}"
    if not isinstance(high, str) and math.isinf(high):
        return f"{name} >= {_end_text(low)}"
    return f"{_end_text(low)} <= {name} <= {_end_text(high)}"


@dataclass(frozen=True)
class Bound:
    """Bounds on a scalar parameter: ``low <= param <= high``.

    Attributes
    ----------
    param : str
        The parameter, e.g. ``"a2"``.
    low, high : float
        Least and largest value (``-inf`` / ``inf`` when open).
    """

    param: str
    low: float = -math.inf
    high: float = math.inf

    def __post_init__(self) -> None:
        if not isinstance(self.param, str) or not is_param_name(self.param):
            raise SkeletonError(f"a bound applies to a parameter a1, a2, ..., got "
                                f"{self.param!r}")
        _check_ends(f"bound on {self.param}", self.low, self.high)
        if self.low > self.high:
            raise SkeletonError(f"bound on {self.param}: low {self.low:g} exceeds high "
                                f"{self.high:g}")

    def __str__(self) -> str:
        return _interval_text(self.param, self.low, self.high)

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies within the bounds."""
        return self.low <= value <= self.high


@dataclass(frozen=True)
class StateLimit:
    """A hard limit on a state: ``low <= state <= high`` at every instant.

    At a limit the state's rate is held at zero while it would carry the
    state beyond (what spills over a rim is lost; an end stop stops).

    Attributes
    ----------
    state : str
        The state, e.g. ``"x1"``.
    low, high : float or str
        Least and largest value (``-inf`` / ``inf`` when open), or the name
        of a parameter whose fitted value it is (``"a5"``).
    """

    state: str
    low: float | str = -math.inf
    high: float | str = math.inf

    def __post_init__(self) -> None:
        if not isinstance(self.state, str) or is_param_name(self.state) \
                or is_unknown_name(self.state):
            raise SkeletonError(f"a limit applies to a state, got {self.state!r}")
        fitted = [end for end in (self.low, self.high) if isinstance(end, str)]
        for end in fitted:
            if not is_param_name(end):
                raise SkeletonError(f"limit on {self.state}: an end is a number or a "
                                    f"parameter aN, got {end!r}")
        if fitted:
            if len(fitted) == 2:
                raise SkeletonError(f"limit on {self.state}: one end at most is a parameter "
                                    "to fit; write the other as a number, or as a limit of "
                                    "its own")
            _check_ends(f"limit on {self.state}",
                        *(-math.inf if e is self.low else math.inf
                          if isinstance(e, str) else e for e in (self.low, self.high)))
            return
        _check_ends(f"limit on {self.state}", self.low, self.high)
        if self.low >= self.high:
            raise SkeletonError(f"limit on {self.state}: low {self.low:g} is not below high "
                                f"{self.high:g}")

    def __str__(self) -> str:
        return _interval_text(self.state, self.low, self.high)


def _signed_number(tokens: list[Token], i: int) -> tuple[float, int] | None:
    sign = 1.0
    if tokens[i].kind == "OP" and tokens[i].text in "+-":
        sign = -1.0 if tokens[i].text == "-" else 1.0
        i += 1
    if tokens[i].kind != "NUMBER":
        return None
    return sign * float(tokens[i].text), i + 1


def _constraint_text(item: object, index: int) -> str:
    if isinstance(item, str):
        return item
    if isinstance(item, Mapping):
        unknown = set(item) - {"constraint"}
        if unknown or "constraint" not in item:
            raise SkeletonError(
                "a constraint given as a dict must have the single key 'constraint', "
                f"got keys {sorted(map(str, item))}",
                equation=index,
                kind="constraints",
            )
        value = item["constraint"]
        if isinstance(value, str):
            return value
    raise SkeletonError(
        "a constraint must be a string such as 'f1 odd' or a dict "
        f"{{'constraint': 'f1 odd'}}, got {item!r}",
        equation=index,
        kind="constraints",
    )


def parse_constraint(item: str | Mapping, index: int = 0) -> Constraint | Bound:
    """Parse one constraint given as a string or as ``{"constraint": text}``.

    Raises
    ------
    SkeletonError
        Naming the constraint and the position of the problem.
    """
    text = _constraint_text(item, index)
    tokens = tokenize(text, index, kind="constraints")

    def fail(message: str, pos: int) -> SkeletonError:
        return SkeletonError(message, equation=index, position=pos, text=text, kind="constraints")

    usage = ("expected 'fN odd', 'fN even', 'fN increasing', 'fN decreasing', 'fN(c)=v', "
             "'aN >= c', 'aN <= c', 'c1 <= aN <= c2' or a state's limit 'x1 <= c' "
             "(or 'x1 <= aN' to fit)")
    first = tokens[0]
    compared = len(tokens) > 1 and tokens[1].kind == "OP" \
        and tokens[1].text in ("<=", ">=", "<", ">")
    if first.kind == "NUMBER" or (first.kind == "OP" and first.text in "+-") \
            or (first.kind == "NAME" and is_param_name(first.text)) \
            or (first.kind == "NAME" and not is_unknown_name(first.text) and compared):
        return _parse_bound(tokens, text, fail, usage)
    if first.kind != "NAME" or not is_unknown_name(first.text):
        raise fail(f"unknown constraint: {usage}", first.pos)
    name = first.text
    second = tokens[1]
    if second.kind == "NAME" and second.text in ("odd", "even", *MONOTONE):
        if tokens[2].kind != "END":
            raise fail(f"unexpected {tokens[2].text!r}: {usage}", tokens[2].pos)
        return Constraint(name, second.text)
    if second.kind == "OP" and second.text == "(":
        parsed = _signed_number(tokens, 2)
        if parsed is None:
            raise fail(f"expected a number inside {name}(...): {usage}", tokens[2].pos)
        at, i = parsed
        if not (tokens[i].kind == "OP" and tokens[i].text == ")"):
            raise fail(f"expected ')': {usage}", tokens[i].pos)
        if not (tokens[i + 1].kind == "OP" and tokens[i + 1].text == "="):
            raise fail(f"expected '=': {usage}", tokens[i + 1].pos)
        parsed = _signed_number(tokens, i + 2)
        if parsed is None:
            raise fail(f"expected a number after '=': {usage}", tokens[i + 2].pos)
        value, j = parsed
        if tokens[j].kind != "END":
            raise fail(f"unexpected {tokens[j].text!r}: {usage}", tokens[j].pos)
        return Constraint(name, "value", at=at, value=value)
    raise fail(f"unknown constraint: {usage}", second.pos)


def _parse_bound(tokens: list[Token], text: str, fail, usage: str) -> Bound | StateLimit:
    """``aN >= c``, ``aN <= c``, ``c <= aN``, ``c >= aN`` or ``c1 <= aN <= c2``.

    With a state's name in place of ``aN``, the state's limit.
    """
    items, i = [], 0  # alternating operands (float or name) and comparisons
    named = [t.text for t in tokens if t.kind == "NAME"]
    # a state's limit names a state (and perhaps a parameter as its end to fit)
    first_name = next((n for n in named if not is_param_name(n) and not is_unknown_name(n)),
                      named[0] if named else "")
    # a parameter's bound reads numbers and parameters; a state's limit, numbers and states
    if is_param_name(first_name):
        def readable(name: str) -> bool:
            return is_param_name(name)
    else:  # a state's limit may have a parameter to fit as an end: x1 <= a5
        def readable(name: str) -> bool:
            return not is_unknown_name(name)
    while True:
        token = tokens[i]
        if token.kind == "NAME" and readable(token.text):
            items.append((token.text, token.pos))
            i += 1
        else:
            parsed = _signed_number(tokens, i)
            if parsed is None:
                what = "a parameter aN" if is_param_name(first_name) else "a state"
                raise fail(f"expected a number or {what}: {usage}", token.pos)
            items.append((parsed[0], token.pos))
            i = parsed[1]
        token = tokens[i]
        if token.kind == "END":
            break
        if token.kind != "OP" or token.text not in ("<=", ">=", "<", ">"):
            raise fail(f"unexpected {token.text!r}: {usage}", token.pos)
        if token.text in ("<", ">"):
            raise fail(f"strict comparison {token.text!r}: write {token.text}= (a bound "
                       "includes its end)", token.pos)
        items.append((token.text, token.pos))
        i += 1
    operands, comparisons = items[0::2], [op for op, _ in items[1::2]]
    names = [(value, pos) for value, pos in operands if isinstance(value, str)]
    ends = [(value, pos) for value, pos in names if is_param_name(value)]
    if not is_param_name(first_name) and ends:
        # a state's limit to fit: the state's name, and parameters as ends
        names = [(value, pos) for value, pos in names if not is_param_name(value)]
        if not names:
            raise fail(f"a state's limit names a state: {usage}", operands[0][1])
    if len(names) != 1:
        where = names[1][1] if len(names) > 1 else operands[0][1]
        raise fail(f"a bound names exactly one parameter or state: {usage}", where)
    if len(comparisons) not in (1, 2) or len(set(comparisons)) != 1:
        raise fail(f"a bound is 'aN >= c', 'aN <= c' or 'c1 <= aN <= c2': {usage}",
                   items[1][1])
    name = names[0][0]
    values = [value for value, _ in operands]
    if comparisons[0] == ">=":
        values = values[::-1]  # read every bound as an ascending chain
    position = values.index(name)
    if len(values) == 3 and position != 1:
        raise fail(f"the parameter of a two-sided bound stands between its ends: {usage}",
                   names[0][1])
    if not all(math.isfinite(v) for v in values if not isinstance(v, str)):
        raise fail("the ends of a bound must be finite numbers", operands[0][1])
    low = values[position - 1] if position > 0 else -math.inf
    high = values[position + 1] if position + 1 < len(values) else math.inf
    if isinstance(low, str) or isinstance(high, str):
        if isinstance(low, str) and isinstance(high, str):
            raise fail(f"one end at most of {name}'s limit is a parameter to fit; write the "
                       "other as a number, or as a limit of its own", ends[-1][1])
        return StateLimit(name, low, high)
    if low >= high:
        raise fail(f"empty bound: {low:g} >= {high:g} leaves no interval (write a fixed "
                   "value as a number in the equation)", operands[0][1])
    if not is_param_name(name):
        return StateLimit(name, float(low), float(high))
    return Bound(name, float(low), float(high))


def parse_constraints(items: Iterable | None) -> tuple[Constraint, ...]:
    """Parse a list of constraints; ``None`` means none. Duplicates are merged."""
    if items is None:
        return ()
    if isinstance(items, (str, Mapping)):
        items = [items]
    out: list[Constraint] = []
    for index, item in enumerate(items):
        constraint = (item if isinstance(item, (Constraint, Bound, StateLimit))
                      else parse_constraint(item, index))
        if constraint not in out:
            out.append(constraint)
    return tuple(out)


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


def merged_bounds(constraints: Iterable) -> dict[str, tuple[float, float]]:
    """Parameter -> ``(low, high)``, the intersection of every bound on it.

    A limit's end to fit is bounded by the state's other end too: with
    ``x1 >= 0`` and ``x1 <= a5``, ``a5 >= 0`` (a rim below the floor leaves
    the level no value).
    """
    constraints = list(constraints)
    out: dict[str, tuple[float, float]] = {}
    for c in constraints:
        if isinstance(c, Bound):
            low, high = out.get(c.param, (-math.inf, math.inf))
            out[c.param] = (max(low, c.low), min(high, c.high))
    for param, (low, high) in _limit_bounds(constraints).items():
        own_low, own_high = out.get(param, (-math.inf, math.inf))
        out[param] = (max(low, own_low), min(high, own_high))
    return out


def _limit_bounds(constraints: list) -> dict[str, tuple[float, float]]:
    """Limit's parameter -> the bounds its state's other (numeric) end sets it."""
    limits = merged_limits(constraints)
    out = {}
    for param, (state, side) in limit_params(constraints).items():
        low, high = limits[state]
        if side == "high" and not isinstance(low, str) and math.isfinite(low):
            out[param] = (float(low), math.inf)
        elif side == "low" and not isinstance(high, str) and math.isfinite(high):
            out[param] = (-math.inf, float(high))
    return out


def merged_limits(constraints: Iterable) -> dict[str, tuple[float | str, float | str]]:
    """State -> ``(low, high)``, the intersection of every limit on it.

    An end to fit is the parameter's name (the skeleton allows no other
    limit on that side of that state).
    """
    out: dict[str, tuple] = {}
    for c in constraints:
        if isinstance(c, StateLimit):
            low, high = out.get(c.state, (-math.inf, math.inf))
            # an end to fit stands alone on its side (the other limits leave that side open)
            low = (c.low if isinstance(c.low, str) else low if isinstance(low, str)
                   else max(low, c.low))
            high = (c.high if isinstance(c.high, str) else high if isinstance(high, str)
                    else min(high, c.high))
            out[c.state] = (low, high)
    return out


def limit_params(constraints: Iterable) -> dict[str, tuple[str, str]]:
    """Parameter -> ``(state, side)`` for every limit end to fit (side "low" or "high")."""
    out = {}
    for c in constraints:
        if isinstance(c, StateLimit):
            for side, end in (("low", c.low), ("high", c.high)):
                if isinstance(end, str):
                    out[end] = (c.state, side)
    return out


def resolved_limits(limits: Mapping[str, tuple], params: Mapping[str, float]
                    ) -> dict[str, tuple[float, float]]:
    """``limits`` with each end to fit replaced by its parameter's value in ``params``."""
    def value(end):
        return float(params[end]) if isinstance(end, str) else float(end)

    return {s: (value(low), value(high)) for s, (low, high) in limits.items()}


def _check_monotone_points(name: str, shape: str, points: list[Constraint],
                           odd: bool) -> None:
    """Point values of a monotone curve (and their mirror images when odd) in order."""
    pairs = [(c.at, c.value) for c in points]
    if odd:
        pairs += [(0.0 - at, 0.0 - value) for at, value in pairs] + [(0.0, 0.0)]
    pairs.sort()
    for (a, u), (b, v) in pairwise(pairs):
        if a < b and (v < u if shape == "increasing" else v > u):
            raise SkeletonError(
                f"contradictory constraints on {name}: an {shape} curve cannot take "
                f"{name}({a:g})={u:g} and {name}({b:g})={v:g}", kind="constraints")


def check_constraints(constraints: Iterable, functions: Iterable[str],
                      params: Iterable[str] = (), states: Iterable[str] = ()) -> None:
    """Reject constraints on curves or parameters the skeleton lacks, and contradictory sets.

    Raises
    ------
    SkeletonError
        Naming the constraint(s) at fault.
    """
    constraints = list(constraints)
    functions, params, states = list(functions), list(params), list(states)
    for c in constraints:
        if isinstance(c, StateLimit) and c.state not in states:
            have = ", ".join(states) if states else "no states"
            raise SkeletonError(f"constraint '{c}' limits {c.state}, which is neither a "
                                f"parameter aN nor a state of the skeleton ({have})",
                                kind="constraints")
    fitted_ends: dict[tuple[str, str], int] = {}
    for c in constraints:
        if isinstance(c, StateLimit):
            for side, end in (("low", c.low), ("high", c.high)):
                if isinstance(end, str) or not math.isinf(end):
                    key = (c.state, side)
                    fitted_ends[key] = fitted_ends.get(key, 0) + (2 if isinstance(end, str)
                                                                  else 1)
    for c in constraints:
        if isinstance(c, StateLimit):
            for side, end in (("low", c.low), ("high", c.high)):
                if isinstance(end, str) and fitted_ends[(c.state, side)] > 2:
                    raise SkeletonError(f"constraint '{c}': a limit to fit is the only "
                                        f"{'upper' if side == 'high' else 'lower'} limit on "
                                        f"{c.state}; leave out the others",
                                        kind="constraints")
    owners = limit_params(constraints)
    for c in constraints:
        if isinstance(c, StateLimit):
            used = [e for e in (c.low, c.high) if isinstance(e, str)]
            if used and used[0] in owners and owners[used[0]] != (
                    c.state, "low" if c.low == used[0] else "high"):
                raise SkeletonError(f"{used[0]} is the end of more than one limit: give "
                                    "each limit to fit its own parameter", kind="constraints")
            if used and used[0] in params:
                raise SkeletonError(f"constraint '{c}': {used[0]} appears in the equations "
                                    "too; a limit to fit has a parameter of its own",
                                    kind="constraints")
    for name, (low, high) in merged_limits(constraints).items():
        if not isinstance(low, str) and not isinstance(high, str) and low >= high:
            limits = ", ".join(str(c) for c in constraints
                               if isinstance(c, StateLimit) and c.state == name)
            raise SkeletonError(f"contradictory limits on {name}: {limits} leave no value",
                                kind="constraints")
    params = [*params, *owners]  # a limit's parameter may have bounds too
    for c in constraints:
        if isinstance(c, Bound) and c.param not in params:
            have = ", ".join(params) if params else "no parameters"
            raise SkeletonError(f"constraint '{c}' names {c.param}, but the skeleton has {have}",
                                kind="constraints")
    for name, (low, high) in merged_bounds(constraints).items():
        if name in owners and low >= high:
            state = owners[name][0]
            involved = ", ".join(str(c) for c in constraints
                                 if (isinstance(c, StateLimit) and c.state == state)
                                 or (isinstance(c, Bound) and c.param == name))
            left = "no value" if low > high else f"the single value {low:.12g}"
            raise SkeletonError(f"contradictory limits on {state}: {involved} leave {state} "
                                f"{left}", kind="constraints")
        if low == high:
            raise SkeletonError(f"the bounds on {name} fix it at {low:.12g}: write the number "
                                "in the equation instead", kind="constraints")
        if low > high:
            bounds = ", ".join(str(c) for c in constraints
                               if isinstance(c, Bound) and c.param == name)
            raise SkeletonError(f"contradictory bounds on {name}: {bounds} leave no value",
                                kind="constraints")
    curves = [c for c in constraints if isinstance(c, Constraint)]
    by_function: dict[str, list[Constraint]] = {}
    for c in curves:
        if c.function not in functions:
            have = ", ".join(functions) if functions else "no curves"
            raise SkeletonError(
                f"constraint '{c}' names {c.function}, but the skeleton has {have}",
                kind="constraints",
            )
        by_function.setdefault(c.function, []).append(c)
    for name, group in by_function.items():
        kinds = {c.kind for c in group}
        if {"odd", "even"} <= kinds:
            raise SkeletonError(
                f"contradictory constraints: {name} cannot be both odd and even "
                "(only the zero function is)"
            )
        if set(MONOTONE) <= kinds:
            raise SkeletonError(
                f"contradictory constraints: {name} cannot be both increasing and decreasing "
                "(only a constant is)")
        if "even" in kinds and kinds & set(MONOTONE):
            raise SkeletonError(
                f"contradictory constraints: an even {name} cannot be "
                f"{(kinds & set(MONOTONE)).pop()} (only a constant is)")
        points = [c for c in group if c.kind == "value"]
        shape = kinds & set(MONOTONE)
        if shape and points:
            _check_monotone_points(name, shape.pop(), points, "odd" in kinds)
        # each symmetry maps a point constraint to a second, implied one; keep the
        # constraint each point comes from so that the message names the culprits
        # (0.0 - x rather than -x: no "-0" in messages)
        implied = [(c, c) for c in points]
        if "odd" in kinds:
            implied += [(Constraint(name, "value", 0.0 - c.at, 0.0 - c.value), c)
                        for c in points]
        if "even" in kinds:
            implied += [(Constraint(name, "value", 0.0 - c.at, c.value), c) for c in points]
        for i, (c, c_source) in enumerate(implied):
            for d, d_source in implied[:i]:
                if _close(c.at, d.at) and not _close(c.value, d.value):
                    source = [str(x) for x in group
                              if x.kind != "value" or x in (c_source, d_source)]
                    raise SkeletonError(
                        f"contradictory constraints on {name}: {', '.join(source)} "
                        f"require both {name}({c.at:g})={c.value:g} and "
                        f"{name}({d.at:g})={d.value:g}"
                    )
