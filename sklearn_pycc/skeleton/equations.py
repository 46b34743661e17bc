"""Classification of parsed equations: which derivative each one defines.

Most equations determine a derivative (``x2_dot = ...``, or an equation
linear in one ``NAME_dot`` no other equation defines). The others are
*algebraic*: a static equation whose left side is a measured column
(``F1 = f1(x1)``, ``y = a1 + f1(x)``), an implicit relation among measured
quantities (``0 = x1^2 + x2^2 - a1``), or a further relation among
derivatives other equations define (a conserved quantity,
``0 = x2 x2_dot + f2(x1) x2``). They are fitted with the others and take no
part in a simulation.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..exceptions import SkeletonError
from .functions import CONSTANTS, ELEMENTARY, is_param_name, is_unknown_name
from .nodes import BinOp, Node, Param, Symbol, Unknown, walk

__all__ = ["DOT", "Equation", "classify", "derivative_of", "state_of"]

DOT = "_dot"
TIME = "t"
RESERVED_COLUMNS = ("trajectory",)


def state_of(name: str) -> str | None:
    """``"x1_dot" -> "x1"``; None for a name that is not a derivative."""
    if name.endswith(DOT) and len(name) > len(DOT):
        return name[: -len(DOT)]
    return None


def derivative_of(state: str) -> str:
    """``"x1" -> "x1_dot"``."""
    return state + DOT


@dataclass(frozen=True)
class Equation:
    """One parsed equation.

    Attributes
    ----------
    index : int
        Position in the user's list.
    text : str
        The text as written.
    lhs, rhs : Node
        Parsed sides.
    derivative : str or None
        The derivative it determines, e.g. ``"x2_dot"``; None for an
        algebraic equation.
    explicit : bool
        True for ``NAME_dot = rhs`` with ``rhs`` free of that derivative;
        False for an equation to be solved for ``derivative`` (e.g. the
        first-order family ``F_ext = f1(x1) + f2(x1) x1_dot``) and for
        algebraic equations.
    output : str or None
        For a static equation ``NAME = rhs`` (no derivative anywhere, ``NAME``
        a measured column the right side does not read): ``NAME``, the
        quantity the equation predicts. None otherwise.
    """

    index: int
    text: str
    lhs: Node
    rhs: Node
    derivative: str | None
    explicit: bool
    output: str | None = None

    @property
    def dynamic(self) -> bool:
        """True when the equation determines a derivative (it is simulated)."""
        return self.derivative is not None

    @property
    def kind(self) -> str:
        """``"explicit"``, ``"implicit"``, ``"static"`` or ``"algebraic"``."""
        if self.dynamic:
            return "explicit" if self.explicit else "implicit"
        return "static" if self.output is not None else "algebraic"

    @property
    def state(self) -> str | None:
        """The state whose derivative this equation determines (None if algebraic)."""
        return None if self.derivative is None else state_of(self.derivative)

    @property
    def expression(self) -> Node:
        """The right-hand side (explicit, static) or the residual ``lhs - rhs``."""
        if self.explicit or self.output is not None:
            return self.rhs
        return BinOp("-", self.lhs, self.rhs)

    @property
    def solvable(self) -> bool:
        """True when the derivative can be computed: explicit, or entering linearly."""
        from .compiler import degree_in

        if self.derivative is None:
            return False
        return self.explicit or degree_in(self.residual, self.derivative) == 1

    @property
    def residual(self) -> Node:
        """``lhs - rhs``: zero when the equation holds."""
        return BinOp("-", self.lhs, self.rhs)

    @property
    def fit_residual(self) -> Node:
        """The residual a fit makes small, with curves taken out of a denominator.

        An equation ``lhs = N / D`` whose denominator ``D`` holds an unknown
        curve (``x_dot = (F_ext - f1(x)) / f2(x)``) is fitted as ``D lhs - N``
        (``f2(x) x_dot - (F_ext - f1(x))``): the same equation, with no pole
        where ``D`` crosses zero during training, and linear in the curves.
        Otherwise :attr:`residual`.
        """
        rhs = self.rhs
        if (isinstance(rhs, BinOp) and rhs.op == "/"
                and any(isinstance(n, Unknown) for n in walk(rhs.right))):
            return BinOp("-", BinOp("*", rhs.right, self.lhs), rhs.left)
        return self.residual

    def symbols(self) -> set[str]:
        """Every data variable named in the equation."""
        return {n.name for side in (self.lhs, self.rhs) for n in walk(side)
                if isinstance(n, Symbol)}

    def derivatives_used(self) -> set[str]:
        """Derivatives named anywhere in the equation except a bare explicit left side."""
        nodes = [self.rhs] if self.explicit else [self.lhs, self.rhs]
        return {n.name for side in nodes for n in walk(side)
                if isinstance(n, Symbol) and state_of(n.name) is not None}


def _positions(node: Node, name: str) -> int:
    for n in walk(node):
        if isinstance(n, Symbol) and n.name == name:
            return n.pos
    return -1


def _reserved_meaning(name: str) -> str | None:
    """What ``name`` already means in the skeleton language, if anything."""
    if name in CONSTANTS:
        return f"the constant {name} = {CONSTANTS[name]:.6g}"
    if name in ELEMENTARY:
        return f"the function {name}()"
    if is_param_name(name):
        return "an unknown parameter (a1, a2, ...)"
    if is_unknown_name(name):
        return "an unknown curve (f1, f2, ...)"
    return None


def classify(parsed: list[tuple[str, Node, Node]]) -> list[Equation]:
    """Decide which derivative each equation determines and check the system.

    Raises
    ------
    SkeletonError
        For duplicate left-hand sides, derivatives no equation defines,
        equations with more than one derivative to solve for, reserved
        names, and equations that depend on each other's derivatives in a
        cycle (raised by :func:`evaluation_order`).
    """
    explicit: dict[str, int] = {}
    for index, (text, lhs, rhs) in enumerate(parsed):
        for node in (*walk(lhs), *walk(rhs)):
            if isinstance(node, Symbol) and node.name in RESERVED_COLUMNS:
                raise SkeletonError(
                    f"{node.name!r} is the experiment label column and cannot appear "
                    "in an equation", equation=index, position=node.pos, text=text)
            if isinstance(node, Symbol) and state_of(node.name) == TIME:
                raise SkeletonError("'t' is time and has no derivative", equation=index,
                                    position=node.pos, text=text)
            if isinstance(node, Symbol) and state_of(node.name) is not None:
                clash = _reserved_meaning(state_of(node.name))
                if clash:
                    raise SkeletonError(
                        f"the state {state_of(node.name)!r} is named like {clash}, so the "
                        "right-hand sides could not read it: rename the state",
                        equation=index, position=node.pos, text=text)
        if isinstance(lhs, Symbol) and state_of(lhs.name) is not None:
            in_rhs = any(isinstance(n, Symbol) and n.name == lhs.name for n in walk(rhs))
            if not in_rhs:
                if lhs.name in explicit:
                    first = explicit[lhs.name]
                    raise SkeletonError(
                        f"duplicate left-hand side {lhs.name} (already defined by "
                        f"equations[{first}])", equation=index, position=lhs.pos, text=text)
                explicit[lhs.name] = index

    equations: list[Equation] = []
    defined: dict[str, int] = dict(explicit)
    for index, (text, lhs, rhs) in enumerate(parsed):
        if explicit.get(getattr(lhs, "name", None)) == index:
            equations.append(Equation(index, text, lhs, rhs, lhs.name, True))
            continue
        used = []
        for side in (lhs, rhs):
            for n in walk(side):
                if isinstance(n, Symbol) and state_of(n.name) and n.name not in used:
                    used.append(n.name)
        # a derivative no explicit equation defines is determined by the first
        # equation it appears in; later ones are further relations
        free = [d for d in used if d not in defined]
        if not free:
            # no derivative of its own: a static or algebraic equation, or a
            # further relation among derivatives other equations define
            curves, params = unknown_names(BinOp("-", lhs, rhs))
            if not curves and not params:
                hint = ("write 'NAME_dot = ...' or an equation containing one NAME_dot" if not used
                        else f"every derivative here ({', '.join(used)}) is already defined "
                        "by another equation")
                raise SkeletonError(
                    "this equation has no derivative of its own and nothing to fit (no "
                    f"f_i or a_i): {hint}", equation=index, position=0, text=text)
            _check_relation(index, text, lhs, rhs)
            equations.append(Equation(index, text, lhs, rhs, None, False))
            continue
        if len(free) > 1:
            raise SkeletonError(
                f"{' and '.join(free)} both appear here and no other equation defines "
                "them: write one equation per derivative", equation=index,
                position=_positions(rhs, free[1]) if _positions(rhs, free[1]) >= 0
                else _positions(lhs, free[1]), text=text)
        defined[free[0]] = index
        equations.append(Equation(index, text, lhs, rhs, free[0], False))
    equations = _mark_outputs(equations, {state_of(d) for d in defined})

    for eq in equations:
        for name in eq.derivatives_used():
            if name not in defined:
                pos = _positions(eq.rhs, name)
                state = state_of(name)
                raise SkeletonError(
                    f"{name} is used but no equation defines it: the state {state} needs "
                    f"its own '{name} = ...' equation", equation=eq.index,
                    position=pos if pos >= 0 else 0, text=eq.text)
    return equations


def _check_relation(index: int, text: str, lhs: Node, rhs: Node) -> None:
    """Refuse an equation without derivatives that no data could contradict.

    ``x2 = F_ext - f1(x2) - f2(x1)`` (``_dot`` forgotten) relates ``x2`` to
    itself: a curve or parameter takes any value that makes it hold, so it
    fits every record. ``0 = a1`` reads no measured quantity at all.
    """
    symbols = [n for side in (lhs, rhs) for n in walk(side) if isinstance(n, Symbol)]
    if not symbols:
        raise SkeletonError(
            "this equation reads no measured quantity (no state, input or output), so "
            "any record satisfies it: did you mean a derivative 'NAME_dot = ...'?",
            equation=index, position=0, text=text)
    if isinstance(lhs, Symbol) and lhs.name != TIME:
        again = _positions(rhs, lhs.name)
        if again >= 0:
            raise SkeletonError(
                f"{lhs.name} is on both sides of an equation without derivatives: a curve "
                f"or parameter can make such a relation of {lhs.name} to itself hold for any "
                f"data; did you mean '{lhs.name}_dot = ...'?", equation=index,
                position=again, text=text)


def _mark_outputs(equations: list[Equation], states: set[str]) -> list[Equation]:
    """Name the output of each static equation ``NAME = rhs`` (``NAME`` measured).

    ``NAME`` must be a bare name on the left that is no state, not ``t`` and
    not read by the right side, in an equation without derivatives; two
    static equations cannot predict the same quantity.
    """
    out: list[Equation] = []
    seen: dict[str, int] = {}
    for eq in equations:
        lhs = eq.lhs
        if (eq.derivative is None and isinstance(lhs, Symbol) and state_of(lhs.name) is None
                and lhs.name not in states and lhs.name != TIME
                and not eq.derivatives_used()
                and all(not (isinstance(n, Symbol) and n.name == lhs.name)
                        for n in walk(eq.rhs))):
            if lhs.name in seen:
                raise SkeletonError(
                    f"duplicate left-hand side {lhs.name} (already predicted by "
                    f"equations[{seen[lhs.name]}]): write the second relation as "
                    f"'0 = ...'", equation=eq.index, position=lhs.pos, text=eq.text)
            seen[lhs.name] = eq.index
            eq = Equation(eq.index, eq.text, eq.lhs, eq.rhs, None, False, lhs.name)
        out.append(eq)
    return out


def evaluation_order(equations: list[Equation]) -> list[int]:
    """Order in which derivatives can be computed (each after those it uses)."""
    by_derivative = {eq.derivative: i for i, eq in enumerate(equations)}
    order: list[int] = []
    state = [0] * len(equations)  # 0 new, 1 visiting, 2 done

    def visit(i: int) -> None:
        if state[i] == 2:
            return
        if state[i] == 1:
            eq = equations[i]
            raise SkeletonError(
                f"the equations depend on each other's derivatives in a cycle through "
                f"{eq.derivative}", equation=eq.index, position=0, text=eq.text)
        state[i] = 1
        for name in sorted(equations[i].derivatives_used()):
            if name != equations[i].derivative:
                visit(by_derivative[name])
        state[i] = 2
        order.append(i)

    for i in range(len(equations)):
        visit(i)
    return order


def unknown_names(node: Node) -> tuple[set[str], set[str]]:
    """Names of the curves and parameters in ``node``."""
    curves = {n.name for n in walk(node) if isinstance(n, Unknown)}
    params = {n.name for n in walk(node) if isinstance(n, Param)}
    return curves, params
