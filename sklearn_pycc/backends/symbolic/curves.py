"""Curves written as SymPy expressions of one variable, and their constraint templates.

A symbolic curve is ``f = T(g)``: ``g`` is the expression a search found
(its numbers free to move), and ``T`` imposes the curve's constraints by
construction: an odd curve is ``(g(x) - g(-x)) / 2``, an even one
``(g(x) + g(-x)) / 2``, and point values ``f(a) = b`` are met by adding a
low-order polynomial of the curve's parity. Numbers are refined by least
squares through :class:`Template`, which evaluates ``T(g)`` in numpy with
the numbers of ``g`` as arguments.
"""

from __future__ import annotations

import math

import numpy as np
import sympy

from ...skeleton.curves import Curve
from .readable import rounded, tidy, without_negligible

__all__ = ["VARIABLE", "FittedCurve", "SymbolicCurve", "Template", "constants_of",
           "with_constants"]

#: the variable every curve expression is written in
VARIABLE = sympy.Symbol("x", real=True)


def _powers(parity: str | None, count: int) -> list[int]:
    """Exponents of the polynomial correction that keeps a curve's parity."""
    if parity == "odd":
        return [2 * k + 1 for k in range(count)]
    if parity == "even":
        return [2 * k for k in range(count)]
    return list(range(count))


class Template:
    """The constraints of one curve, applied to any ``g``.

    Parameters
    ----------
    parity : {"odd", "even"} or None
    points : list of (float, float)
        Values ``(at, value)`` the curve must take. For an odd curve, a
        point ``(0, 0)`` holds already and is skipped.
    """

    def __init__(self, parity: str | None, points) -> None:
        self.parity = parity
        self.points = [(float(a), float(v)) for a, v in points
                       if not (parity == "odd" and a == 0.0)]
        powers = _powers(parity, len(self.points))
        at = np.array([a for a, _ in self.points])
        self._powers = powers
        self._matrix = (at[:, None] ** np.array(powers)[None, :]) if self.points else None

    def _symmetric(self, g_of):
        if self.parity == "odd":
            return lambda x: (g_of(x) - g_of(-x)) / 2
        if self.parity == "even":
            return lambda x: (g_of(x) + g_of(-x)) / 2
        return g_of

    def _correction(self, h_at: np.ndarray) -> np.ndarray:
        wanted = np.array([v for _, v in self.points]) - h_at
        return np.linalg.lstsq(self._matrix, wanted, rcond=None)[0]

    def numeric(self, g_of):
        """``T(g)`` as a numpy function, ``g_of`` a numpy function of ``x``."""
        h = self._symmetric(g_of)
        if not self.points:
            return h
        at = np.array([a for a, _ in self.points])

        def f(x):
            b = self._correction(np.asarray(h(at), dtype=float) * np.ones_like(at))
            return h(x) + sum(c * x ** p for c, p in zip(b, self._powers))

        return f

    def symbolic(self, g: sympy.Expr) -> sympy.Expr:
        """``T(g)`` as a SymPy expression in :data:`VARIABLE`."""
        x = VARIABLE
        if self.parity == "odd":
            h = (g - g.subs(x, -x)) / 2
        elif self.parity == "even":
            h = (g + g.subs(x, -x)) / 2
        else:
            h = g
        if h.is_polynomial(x):
            h = sympy.expand(h)
        elif self.parity is not None:  # the two halves often combine when multiplied out
            expanded = sympy.expand(h)
            if sympy.count_ops(expanded) < sympy.count_ops(h):
                h = expanded
        if not self.points:
            return h
        h_at = np.array([float(h.subs(x, a)) for a, _ in self.points])
        b = self._correction(h_at)
        return h + sum(sympy.Float(c) * x ** p for c, p in zip(b, self._powers))


def constants_of(expression: sympy.Expr) -> list[sympy.Float]:
    """The floating-point numbers of ``expression``, in a stable order."""
    return sorted(expression.atoms(sympy.Float), key=lambda c: (float(c), str(c)))


def with_constants(expression: sympy.Expr) -> tuple[sympy.Expr, list[sympy.Symbol], np.ndarray]:
    """Replace every float of ``expression`` by a symbol ``c0, c1, ...``.

    Returns the expression in those symbols, the symbols and their values.
    Integers and rationals (exponents, the halves of templates) stay fixed.
    """
    floats = constants_of(expression)
    symbols = [sympy.Symbol(f"c{k}") for k in range(len(floats))]
    with sympy.evaluate(False):  # functions of symbols evaluate slowly and gain nothing
        shape = expression.xreplace(dict(zip(floats, symbols)))
    return shape, symbols, np.array([float(c) for c in floats])


class SymbolicCurve(Curve):
    """A fitted curve given by a SymPy expression of :data:`VARIABLE`.

    Calls evaluate a numpy function compiled once from the expression
    (rebuilt after unpickling); the expression itself is what pickles.

    Parameters
    ----------
    expression : sympy.Expr
        The curve as a function of :data:`VARIABLE`.
    domain : tuple of float
        Range of the argument in training.
    """

    def __init__(self, expression: sympy.Expr, domain: tuple[float, float]) -> None:
        if not isinstance(expression, sympy.Basic):
            raise TypeError(f"expression must be a SymPy expression, got {type(expression)}")
        self.expression = expression
        self.domain = (float(domain[0]), float(domain[1]))
        self._function = None
        self._scalar = None

    def _compiled(self):
        if self._function is None:
            self._function = sympy.lambdify(VARIABLE, self.expression, modules="numpy")
        return self._function

    def __call__(self, x):
        """The curve at ``x``."""
        x = np.asarray(x, dtype=float)
        with np.errstate(all="ignore"):
            out = self._compiled()(x)
        if np.ndim(out) == 0 or np.shape(out) != x.shape:
            return np.broadcast_to(np.asarray(out, dtype=float), x.shape).copy()
        return out

    def scalar(self, x: float) -> float:
        """The curve at one float, through the ``math`` module (for ODE right-hand sides).

        A domain error or an overflow gives NaN, as numpy would, so that a
        simulation reaching it stops with a clear error.
        """
        if self._scalar is None:
            self._scalar = sympy.lambdify(VARIABLE, self.expression, modules="math")
        try:
            return float(self._scalar(x))
        except (ValueError, OverflowError, ZeroDivisionError, TypeError):
            return math.nan

    def to_sympy(self, variable):
        """The expression written in ``variable``."""
        return self.expression.xreplace({VARIABLE: variable})

    @property
    def n_numbers(self) -> int:
        """Floating-point constants of the expression."""
        return len(self.expression.atoms(sympy.Float))

    def complexity(self) -> int:
        """Number of nodes of the expression tree."""
        return int(sympy.count_ops(self.expression, visual=False)) + len(
            self.expression.atoms(sympy.Symbol, sympy.Number))

    def text(self, variable: str, precision: int = 6) -> str:
        """The expression as text, written in ``variable``, to ``precision`` digits.

        A number that rounds to an integer is written as one (``x`` for ``1.0*x``).
        """
        shown = rounded(self.expression, precision)
        return str(shown.xreplace({VARIABLE: sympy.Symbol(variable)}))

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_function"] = None
        state["_scalar"] = None
        return state

    def __repr__(self) -> str:
        return f"SymbolicCurve({self.expression})"


class FittedCurve:
    """A curve during fitting: ``T(g)`` with the numbers of ``g`` free."""

    def __init__(self, g: sympy.Expr, template: Template, domain) -> None:
        self.template = template
        self.domain = domain
        self.set_g(g)

    def set_g(self, g: sympy.Expr) -> None:
        """Take ``g`` as the free part, its numbers as the values to fit."""
        self.g = g
        self.shape, self.symbols, self.values = with_constants(g)
        raw = sympy.lambdify([VARIABLE, *self.symbols], self.shape, modules="numpy")

        def g_of(x, c):
            with np.errstate(all="ignore"):
                out = raw(x, *c)
            return np.broadcast_to(np.asarray(out, dtype=float), np.shape(x))

        self._g_of = g_of

    def drop_negligible(self) -> None:
        """Drop the numbers of ``g`` that do nothing over the domain (and its mirror).

        The mirror counts only for an odd or even curve, which reads ``g(-x)``.
        """
        grid = np.linspace(self.domain[0], self.domain[1], 101)
        if self.template.parity is not None:
            grid = np.concatenate([grid, -grid])
        kept = without_negligible(self.values, lambda c: self._g_of(grid, c))
        if np.count_nonzero(kept) < np.count_nonzero(self.values):
            self.set_g(tidy(self.shape.xreplace({
                s: sympy.Float(v) if v else sympy.Integer(0)
                for s, v in zip(self.symbols, kept)})))

    def function(self, values: np.ndarray | None = None):
        """The curve ``T(g)`` as a function of x, with ``values`` (default: its own) in ``g``."""
        c = self.values if values is None else values
        return self.template.numeric(lambda x: self._g_of(np.asarray(x, dtype=float), c))

    def expression(self, values: np.ndarray | None = None) -> sympy.Expr:
        """``T(g)`` with its numbers, written with as few numbers and nodes as algebra allows."""
        c = self.values if values is None else values
        g = self.shape.xreplace({s: sympy.Float(v) for s, v in zip(self.symbols, c)})
        return tidy(self.template.symbolic(g))
