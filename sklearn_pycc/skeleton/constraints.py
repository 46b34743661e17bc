"""Constraints on characteristic curves: ``"f1 odd"``, ``"f1 even"``, ``"f2(0)=0"``."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from ..exceptions import SkeletonError
from .functions import is_unknown_name
from .lexer import Token, tokenize

__all__ = ["Constraint", "check_constraints", "parse_constraint", "parse_constraints"]


@dataclass(frozen=True)
class Constraint:
    """One piece of prior knowledge about a curve.

    Attributes
    ----------
    function : str
        The curve it applies to, e.g. ``"f1"``.
    kind : {"odd", "even", "value"}
        Symmetry or point value.
    at, value : float or None
        For ``kind="value"``: the curve passes through ``(at, value)``.
    """

    function: str
    kind: str
    at: float | None = None
    value: float | None = None

    def __str__(self) -> str:
        if self.kind == "value":
            return f"{self.function}({self.at:g})={self.value:g}"
        return f"{self.function} {self.kind}"


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


def parse_constraint(item: str | Mapping, index: int = 0) -> Constraint:
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

    usage = "expected 'fN odd', 'fN even' or 'fN(c)=v'"
    first = tokens[0]
    if first.kind != "NAME" or not is_unknown_name(first.text):
        raise fail(f"unknown constraint: {usage}", first.pos)
    name = first.text
    second = tokens[1]
    if second.kind == "NAME" and second.text in ("odd", "even"):
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


def parse_constraints(items: Iterable | None) -> tuple[Constraint, ...]:
    """Parse a list of constraints; ``None`` means none. Duplicates are merged."""
    if items is None:
        return ()
    if isinstance(items, (str, Mapping)):
        items = [items]
    out: list[Constraint] = []
    for index, item in enumerate(items):
        constraint = item if isinstance(item, Constraint) else parse_constraint(item, index)
        if constraint not in out:
            out.append(constraint)
    return tuple(out)


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


def check_constraints(constraints: Iterable[Constraint], functions: Iterable[str]) -> None:
    """Reject constraints on curves the skeleton lacks, and contradictory sets.

    Raises
    ------
    SkeletonError
        Naming the constraint(s) at fault.
    """
    functions = list(functions)
    by_function: dict[str, list[Constraint]] = {}
    for c in constraints:
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
        points = [c for c in group if c.kind == "value"]
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
