"""Structural identifiability (gauge) analysis of a skeleton.

Each kind of ambiguity is proposed from the structure of the equations and
then *verified* by evaluating the skeleton on random data with random curves
and parameters that respect the constraints: a transformation of the
unknowns that leaves every equation unchanged is an ambiguity.

Kinds found:

``additive_constant``
    curves (and offset parameters) that exchange a constant, e.g.
    ``F_ext - f1(x2) - f2(x1)``; removed by a point value such as ``f2(0)=0``.
``same_argument``
    two curves of the same argument in one sum: only their sum is identifiable.
``scale``
    a scale exchangeable between a parameter and the curves or parameters it
    multiplies (``a1 f1(x)``, ``a1 a2 x``); removed by fixing the parameter to 1.
``argument_scale`` / ``argument_shift``
    a parameter that only scales or shifts a curve's argument (``f1(a1 x)``,
    ``f1(x - a1)``); removed by fixing it to 1 or 0.
``redundant_parameter``
    a parameter that only enters in combination with others (``a1 x + a2 x``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .compiler import compile_expression
from .constraints import Constraint
from .equations import TIME
from .nodes import Node, Param, Unknown, product_factors, sum_terms, walk

__all__ = ["Ambiguity", "Fix", "IdentifiabilityReport", "analyse"]

_N_POINTS = 48


@dataclass(frozen=True)
class Fix:
    """What a gauge pins: a curve value, a curve to zero, or a parameter value."""

    kind: str  # "curve_value", "curve_zero", "param_value"
    name: str
    at: float = 0.0
    value: float = 0.0

    def __str__(self) -> str:
        if self.kind == "curve_value":
            return f"{self.name}({self.at:g})={self.value:g}"
        if self.kind == "curve_zero":
            return f"{self.name}=0"
        return f"{self.name}={self.value:g}"

    def as_constraint(self) -> Constraint | None:
        """The equivalent constraint, for curve values."""
        if self.kind == "curve_value":
            return Constraint(self.name, "value", self.at, self.value)
        return None


@dataclass(frozen=True)
class Ambiguity:
    """One structural ambiguity of a skeleton."""

    kind: str
    names: tuple[str, ...]
    description: str
    remedy: str
    fix: Fix | None

    def __str__(self) -> str:
        return f"{self.description} {self.remedy}"


@dataclass
class IdentifiabilityReport:
    """Result of :meth:`Skeleton.identifiability`.

    Attributes
    ----------
    ambiguities : list of Ambiguity
        Every ambiguity found, each with its remedy.
    """

    ambiguities: list[Ambiguity] = field(default_factory=list)

    @property
    def identifiable(self) -> bool:
        """True when no ambiguity was found."""
        return not self.ambiguities

    @property
    def fixes(self) -> list[Fix]:
        """The pins that make the skeleton identifiable (``gauge="auto"``)."""
        return [a.fix for a in self.ambiguities if a.fix is not None]

    def gauge(self) -> dict[str, str]:
        """``{pin: reason}`` for every automatic pin."""
        return {str(a.fix): a.description for a in self.ambiguities if a.fix is not None}

    def __str__(self) -> str:
        if not self.ambiguities:
            return "The skeleton is structurally identifiable with its constraints."
        lines = [f"The skeleton has {len(self.ambiguities)} ambiguit"
                 f"{'y' if len(self.ambiguities) == 1 else 'ies'}:"]
        for i, a in enumerate(self.ambiguities, 1):
            lines.append(f"  {i}. {a.description}")
            lines.append(f"     {a.remedy}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"IdentifiabilityReport(ambiguities={[str(a.fix) for a in self.ambiguities]})"


# -- random curves respecting constraints ---------------------------------------
def _parity(constraints: list[Constraint]) -> str | None:
    kinds = {c.kind for c in constraints}
    return "odd" if "odd" in kinds else "even" if "even" in kinds else None


def _random_curve(constraints: list[Constraint], rng, homogeneous: bool = False) -> Callable:
    """A random smooth curve satisfying ``constraints`` (values 0 if ``homogeneous``)."""
    c = rng.normal(size=6)

    def base(u):
        return (c[0] + c[1] * u + 0.5 * c[2] * u ** 2 + 0.3 * c[3] * u ** 3
                + c[4] * np.sin(1.7 * u + c[5]))

    parity = _parity(constraints)
    if parity == "odd":
        def shaped(u):
            return 0.5 * (base(u) - base(-u))
    elif parity == "even":
        def shaped(u):
            return 0.5 * (base(u) + base(-u))
    else:
        shaped = base
    points = [(x.at, 0.0 if homogeneous else x.value) for x in constraints if x.kind == "value"]
    if not points:
        return shaped
    powers = {"odd": [1, 3, 5, 7], "even": [0, 2, 4, 6]}.get(parity, [0, 1, 2, 3])
    at = np.array([p[0] for p in points])
    target = np.array([p[1] for p in points]) - shaped(at)
    basis = np.column_stack([at ** k for k in powers])
    coef = np.linalg.lstsq(basis, target, rcond=None)[0]

    def corrected(u):
        u = np.asarray(u, dtype=float)
        return shaped(u) + sum(w * u ** k for w, k in zip(coef, powers))

    return corrected


# -- structure helpers ----------------------------------------------------------
def _top_level_unknowns(node: Node) -> set[str]:
    """Curves and parameters of ``node`` that are not inside a curve argument."""
    names: set[str] = set()
    stack = [node]
    while stack:
        n = stack.pop()
        if isinstance(n, (Param, Unknown)):
            names.add(n.name)
        else:
            stack.extend(n.children())
    return names


class _Probe:
    """Evaluates every equation residual at random points for given curves and parameters.

    The points are drawn where the skeleton has a value: ``sqrt(x1)``,
    ``log(x1 + 1)`` or ``arcsin(x1/10)`` are only probed inside their domains
    (rows where the starting configuration is not finite are left out, and
    when too few remain the variables, then the parameters, are drawn
    positive). Configurations compared later are read on the same rows.
    """

    def __init__(self, skeleton, rng, curves: dict, params: dict) -> None:
        self.skeleton = skeleton
        self.nodes = [eq.residual for eq in skeleton.residual_equations]
        names = [*skeleton.states, *skeleton.inputs, TIME, *skeleton.derivatives,
                 *skeleton.outputs]
        self.slots = {name: i for i, name in enumerate(names)}
        self.rows = np.ones(_N_POINTS, dtype=bool)
        tries = [(-2.0, False), (0.05, False), (0.05, True)]
        for low, positive in tries:
            self.env = [rng.uniform(low, 2.0, size=_N_POINTS) for _ in names]
            if positive:
                params.update({a: abs(v) for a, v in params.items()})
            finite = np.isfinite(self._raw(curves, params)).reshape(len(self.nodes), -1)
            self.rows = finite.all(axis=0)
            if self.rows.sum() >= _N_POINTS // 2:
                break

    def _raw(self, functions: dict, params: dict) -> np.ndarray:
        out = []
        with np.errstate(all="ignore"):
            for node in self.nodes:
                fn = compile_expression(node, self.slots, params, functions, mode="array")
                out.append(np.broadcast_to(np.asarray(fn(self.env), dtype=float), (_N_POINTS,)))
        return np.concatenate(out)

    def __call__(self, functions: dict, params: dict) -> np.ndarray:
        return self._raw(functions, params).reshape(len(self.nodes), -1)[:, self.rows].ravel()


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        return False
    return float(np.max(np.abs(a - b))) <= 1e-9 * (1.0 + float(np.max(np.abs(a))))


def _reading_points(skeleton, probe: _Probe, curves: dict, params: dict) -> dict:
    """Where each equation reads each curve on the probe's rows, up to sign.

    ``{curve: {equation: sorted |argument| values}}``; None for a curve
    inside another's argument or with one inside its own, which may trade a
    curve with any other.
    """
    found: dict = {f: {} for f in skeleton.functions}
    for e, node in enumerate(probe.nodes):
        for unknown in walk(node):
            if not isinstance(unknown, Unknown):
                continue
            inner = [n.name for n in walk(unknown.arg) if isinstance(n, Unknown)]
            for name in inner:
                found[name] = found[unknown.name] = None
            if inner or found[unknown.name] is None:
                continue
            with np.errstate(all="ignore"):
                value = compile_expression(unknown.arg, probe.slots, params, curves)(probe.env)
            value = np.abs(np.broadcast_to(np.asarray(value, dtype=float), (_N_POINTS,)))
            found[unknown.name].setdefault(e, []).append(value[probe.rows])
    return {f: None if where is None else {e: np.sort(np.stack(v), axis=0)
                                           for e, v in where.items()}
            for f, where in found.items()}


def _read_alike(a: dict | None, b: dict | None) -> bool:
    """Whether two curves are read at the same points in the same equations (up to sign).

    Only such curves can trade a curve between them: a curve read at other
    points changes the residual wherever it moves.
    """
    if a is None or b is None:
        return True
    if a.keys() != b.keys() or any(a[e].shape != b[e].shape for e in a):
        return False
    # a point that is not finite says nothing: it does not set the pair apart
    with np.errstate(invalid="ignore"):
        return not any(np.any(np.abs(a[e] - b[e]) > 1e-9 * (1.0 + np.abs(a[e]))) for e in a)


def _where(skeleton, names) -> str:
    idx = []
    for eq in skeleton.residual_equations:
        found = {n.name for n in walk(eq.residual) if isinstance(n, (Unknown, Param))}
        if found & set(names):
            idx.append(f"equations[{eq.index}]")
    return ", ".join(idx)


def _and(names) -> str:
    names = list(names)
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def analyse(skeleton, seed: int = 0) -> IdentifiabilityReport:
    """Find the structural ambiguities of ``skeleton`` (see module docstring)."""
    rng = np.random.default_rng(seed)
    cons = {f: skeleton.constraints_of(f) for f in skeleton.functions}
    curves = {f: _random_curve(cons[f], rng) for f in skeleton.functions}
    params = {a: float(rng.uniform(0.5, 1.5) * rng.choice([-1.0, 1.0])) for a in skeleton.params}
    probe = _Probe(skeleton, rng, curves, params)
    report = IdentifiabilityReport()
    fixed_params: set[str] = set()
    zeroed: set[str] = set()

    def scalable(f: str) -> bool:
        return all(c.kind != "value" or c.value == 0.0 for c in cons[f])

    def pin_param(name: str, value: float) -> None:
        params[name] = value
        fixed_params.add(name)

    # 1. scale between a parameter and what it multiplies --------------------------
    for a in reversed(skeleton.params):
        cofactors: set[str] = set()
        for eq in skeleton.residual_equations:
            for term in sum_terms(eq.residual):
                factors = product_factors(term)
                if any(isinstance(x, Param) and x.name == a for x in factors):
                    for x in factors:
                        if not (isinstance(x, Param) and x.name == a):
                            cofactors |= _top_level_unknowns(x)
        cofactors -= fixed_params | zeroed | {a}
        if not cofactors or not all(scalable(u) for u in cofactors if u in curves):
            continue
        reference = probe(curves, params)
        scaled_curves = {k: (lambda u, g=g: 0.5 * g(u)) if k in cofactors else g
                         for k, g in curves.items()}
        scaled_params = {k: (0.5 * v if k in cofactors else v) for k, v in params.items()}
        scaled_params[a] = 2.0 * params[a]
        if _same(reference, probe(scaled_curves, scaled_params)):
            others = _and(sorted(cofactors))
            report.ambiguities.append(Ambiguity(
                "scale", (a, *sorted(cofactors)),
                f"{a} multiplies {others} in {_where(skeleton, [a])}: scaling {a} up and "
                f"{others} down by the same factor changes nothing.",
                f"Fixed {a}=1 (or give {others} a scale through a point value).",
                Fix("param_value", a, value=1.0)))
            pin_param(a, 1.0)

    # 2. parameters that only scale or shift a curve's argument -------------------------
    for eq in skeleton.residual_equations:
        for node in walk(eq.residual):
            if not isinstance(node, Unknown):
                continue
            inside = sorted({n.name for n in walk(node.arg) if isinstance(n, Param)}
                            - fixed_params)
            f = node.name
            for a in inside:
                reference = probe(curves, params)
                g = curves[f]
                tests = []
                if all(c.kind != "value" or c.at == 0.0 for c in cons[f]):
                    tests.append(("argument_scale", 1.0, {**params, a: 2.0 * params[a]},
                                  lambda u, g=g: g(0.5 * u)))
                if not cons[f]:
                    for s in (1.0, -1.0):
                        tests.append(("argument_shift", 0.0, {**params, a: params[a] + 1.0},
                                      lambda u, g=g, s=s: g(u + s)))
                for kind, value, new_params, new_curve in tests:
                    if _same(reference, probe({**curves, f: new_curve}, new_params)):
                        what = "scales" if kind == "argument_scale" else "shifts"
                        report.ambiguities.append(Ambiguity(
                            kind, (a, f),
                            f"{a} only {what} the argument of {f} in equations[{eq.index}]: "
                            f"{f} can absorb any change of {a}.",
                            f"Fixed {a}={value:g} (or remove {a} from the argument).",
                            Fix("param_value", a, value=value)))
                        pin_param(a, value)
                        break

    # 3. two curves of the same argument in one sum ---------------------------------------
    fs = skeleton.functions
    read_at = _reading_points(skeleton, probe, curves, params)
    for i, fj in enumerate(fs):
        for fk in fs[i + 1:]:
            if fj in zeroed or fk in zeroed:
                continue
            joint = cons[fj] + cons[fk]
            if {c.kind for c in joint} >= {"odd", "even"}:
                continue
            g = _random_curve(joint, rng, homogeneous=True)
            if not _read_alike(read_at[fj], read_at[fk]):
                continue  # no trade is possible; probing it would cost a cube of the curves
            reference = probe(curves, params)
            for s in (1.0, -1.0):
                moved = {**curves,
                         fj: lambda u, h=curves[fj], g=g: h(u) + g(u),
                         fk: lambda u, h=curves[fk], s=s, g=g: h(u) + s * g(u)}
                if not _same(reference, probe(moved, params)):
                    continue
                target = fk if scalable(fk) else fj if scalable(fj) else None
                where = _where(skeleton, [fj, fk])
                report.ambiguities.append(Ambiguity(
                    "same_argument", (fj, fk),
                    f"{fj} and {fk} have the same argument in {where}: only their "
                    f"{'sum' if s < 0 else 'difference'} is identifiable.",
                    "Separate them with parity constraints (for instance "
                    f"'{fj} odd' and '{fk} even') or merge them into one curve."
                    + (f" Fixed {target}=0." if target else ""),
                    Fix("curve_zero", target) if target else None))
                if target:
                    zeroed.add(target)
                    curves[target] = lambda u: np.zeros_like(np.asarray(u, dtype=float))
                break

    # 4. additive constants exchanged between curves and offsets ----------------------------
    report.ambiguities += _additive_constants(skeleton, probe, curves=curves, params=params,
                                              cons=cons, fixed_params=fixed_params,
                                              zeroed=zeroed)
    return report


def _additive_constants(skeleton, probe, *, curves: dict, params: dict, cons: dict,
                        fixed_params: set[str], zeroed: set[str]) -> list[Ambiguity]:
    """Additive constants a curve trades with offsets, and parameters nothing tells apart.

    The sensitivities of the residuals to each free parameter and to a
    constant added to each curve, and where one is a combination of those
    before it, the ambiguity that makes it so.
    """
    found: list[Ambiguity] = []
    fs = skeleton.functions
    reference = probe(curves, params)
    columns, labels = [], []
    for a in skeleton.params:
        if a in fixed_params or a in skeleton.limit_params:  # a limit acts in no equation
            continue
        h = 1e-4 * max(1.0, abs(params[a]))
        up = probe(curves, {**params, a: params[a] + h})
        down = probe(curves, {**params, a: params[a] - h})
        columns.append((up - down) / (2 * h))
        labels.append(a)
    for f in fs:
        if f in zeroed or any(c.kind in ("odd", "value") for c in cons[f]):
            continue
        shifted = probe({**curves, f: lambda u, g=curves[f]: g(u) + 1.0}, params)
        columns.append(shifted - reference)
        labels.append(f)
    if columns:  # a point where a finite difference leaves a domain says nothing
        usable = np.all(np.isfinite(np.column_stack(columns)), axis=1)
        columns = [column[usable] for column in columns]
    kept: list[int] = []
    scale = max((float(np.linalg.norm(c)) for c in columns), default=1.0) or 1.0
    for j, column in enumerate(columns):
        trial = np.column_stack([columns[k] for k in kept] + [column])
        rank = np.linalg.matrix_rank(trial / scale, tol=1e-8)
        if rank > len(kept):
            kept.append(j)
            continue
        base = np.column_stack([columns[k] for k in kept]) if kept else np.zeros((len(column), 0))
        coef = np.linalg.lstsq(base, column, rcond=None)[0] if kept else np.zeros(0)
        partners = [labels[k] for k, w in zip(kept, coef) if abs(w) > 1e-6]
        name = labels[j]
        if name in skeleton.functions:
            others = _and(partners) if partners else "the data"
            found.append(Ambiguity(
                "additive_constant", (name, *partners),
                f"{name} exchanges an additive constant with {others} in "
                f"{_where(skeleton, [name, *partners])}: adding a constant to {name} can be "
                f"compensated by {others}.",
                f"Fixed {name}(0)=0 (or add a constraint such as '{name}(0)=0' or "
                f"'{name} odd').",
                Fix("curve_value", name, at=0.0, value=0.0)))
        else:
            others = _and(partners) if partners else "nothing"
            found.append(Ambiguity(
                "redundant_parameter", (name, *partners),
                f"{name} enters {_where(skeleton, [name])} only in combination with "
                f"{others}: it cannot be told apart from them.",
                f"Fixed {name}=0 (or remove it from the skeleton).",
                Fix("param_value", name, value=0.0)))
    return found
