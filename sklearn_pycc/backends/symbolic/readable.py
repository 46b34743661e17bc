"""Readable expressions: how deeply functions nest, how large a formula is, which to show.

A symbolic search rewards fitting every wiggle of its target with ever longer
expressions (``sin(exp(a x) tanh(cos(b x)))``). One rule decides what may be
shown, wherever an expression is chosen from a search (the fit of
:class:`~sklearn_pycc.SymbolicCCRegressor`, :func:`~sklearn_pycc.to_symbolic`,
and the formula a diagnosis proposes for a free curve):

- a cap: at most ``max_nesting`` elementary functions on any path of the tree
  (1: no function of a function), and at most ``max_complexity`` nodes;
- a tie rule: among the candidates whose loss is within a small tolerance of
  the chosen one, the simplest wins, catalogue-like shapes (polynomials,
  ``tanh(a x)``, ``sign``, ``|x|``, ``sqrt``) before free forms.

Expressions are the SymPy trees the package builds from the engine's own
trees; nothing here parses text.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sympy

__all__ = ["CATALOGUE_FUNCTIONS", "MAX_NESTING", "TIE_TOLERANCE", "Readability",
           "catalogue_like", "complexity", "n_numbers", "nesting", "rounded", "tidy",
           "without_negligible"]

#: deepest nesting of elementary functions shown by default: sin(x) is 1, sin(exp(x)) 2
MAX_NESTING = 1
#: losses within this fraction of the chosen one are a tie, settled by simplicity
TIE_TOLERANCE = 0.02
#: losses this close to zero, relative to the largest of a front, tie too (exact fits)
EXACT = 1e-12
#: a number whose removal moves an expression by less than this fraction of its size goes
NEGLIGIBLE = 1e-6
#: functions the catalogue's effects are built of (with sqrt), each of a multiple of x
CATALOGUE_FUNCTIONS = (sympy.tanh, sympy.sign, sympy.Abs)


def _integer_exponent(power: sympy.Expr) -> bool:
    exponent = power.exp
    return bool(exponent.is_number and float(exponent).is_integer())


def _applies_function(node: sympy.Basic) -> bool:
    """Whether ``node`` applies an elementary function (a non-integer power counts)."""
    if node.is_Pow:
        return not _integer_exponent(node)
    return isinstance(node, sympy.Function)


def nesting(expression: sympy.Expr) -> int:
    """Elementary functions on the deepest path of the tree.

    Integer powers are algebra, not functions: ``x**2 + tanh(3 x)`` is 1,
    ``sin(exp(x))`` is 2, ``sqrt(abs(x))`` is 2.

    Examples
    --------
    >>> import sympy
    >>> x = sympy.Symbol("x")
    >>> nesting(x**2), nesting(0.5 * sympy.tanh(8 * x)), nesting(sympy.sin(sympy.exp(x)))
    (0, 1, 2)
    """
    if expression.is_Atom:
        return 0
    inner = max(nesting(arg) for arg in expression.args)
    return inner + int(_applies_function(expression))


def complexity(expression: sympy.Expr) -> int:
    """Nodes of the expression as a binary tree (PySR's count).

    Each number, variable, function and binary operation is one node; a sum
    or product of ``n`` terms holds ``n - 1`` operations, a negation one.

    Examples
    --------
    >>> import sympy
    >>> x = sympy.Symbol("x")
    >>> complexity(0.3 * x + 0.5 * sympy.tanh(8 * x))
    10
    """
    if expression.is_Atom:
        return 1
    args = expression.args
    if expression.is_Mul and args[0] == -1:  # -x is a negation, not a product with -1
        return 1 + complexity(sympy.Mul(*args[1:]))
    own = len(args) - 1 if (expression.is_Add or expression.is_Mul) else 1
    return own + sum(complexity(arg) for arg in args)


def n_numbers(expression: sympy.Expr) -> int:
    """Floating-point numbers written in the expression (each place counts)."""
    return sum(isinstance(node, sympy.Float) for node in sympy.preorder_traversal(expression))


def _affine(argument: sympy.Expr, variable: sympy.Symbol) -> bool:
    if not argument.has(variable):
        return True
    return bool(argument.is_polynomial(variable)
                and sympy.Poly(argument, variable).degree() <= 1)


def catalogue_like(expression: sympy.Expr, variable: sympy.Symbol) -> bool:
    """Whether the expression has a shape the catalogue's effects have.

    Polynomials, and sums and products of ``tanh``, ``sign``, ``abs`` and
    ``sqrt`` of an affine function of ``variable``; any other function, or a
    division by the variable, is a free form.
    """
    for node in sympy.preorder_traversal(expression):
        if node.is_Pow and _integer_exponent(node):
            if node.base.has(variable) and float(node.exp) < 0:
                return False
            continue
        if not _applies_function(node):
            continue
        if node.is_Pow:
            if node.exp != sympy.Rational(1, 2) and not (node.exp.is_Float
                                                         and float(node.exp) == 0.5):
                return False
            argument = node.base
        elif isinstance(node, CATALOGUE_FUNCTIONS):
            argument = node.args[0]
        else:
            return False
        if not _affine(argument, variable):
            return False
    return True


def _absorb(expression: sympy.Expr) -> sympy.Expr:
    """Numeric factors of products moved into one of their sums, bottom up.

    ``1.0*(a x + b)*tanh(c x)`` becomes ``(a x + b)*tanh(c x)``: one number
    fewer, the same value.
    """
    if expression.is_Atom:
        return expression
    expression = expression.func(*(_absorb(arg) for arg in expression.args))
    if not expression.is_Mul:
        return expression
    coefficient, rest = expression.as_coeff_Mul()
    factors = sympy.Mul.make_args(rest)
    if coefficient == 1 or len(factors) < 2:
        return expression
    for k, factor in enumerate(factors):
        if factor.is_Add:
            merged = sympy.Mul(*factors[:k], sympy.Mul(coefficient, factor), *factors[k + 1:])
            if (n_numbers(merged), complexity(merged)) <= (n_numbers(expression),
                                                          complexity(expression)):
                return merged
    return expression


def tidy(expression: sympy.Expr) -> sympy.Expr:
    """The expression with fewer numbers and nodes where algebra allows; its value unchanged.

    Tries the numeric factors of products moved into their sums and the
    products multiplied out (exponentials and logarithms left whole), and
    keeps the form with the fewest numbers, then the fewest nodes.

    Examples
    --------
    >>> import sympy
    >>> x = sympy.Symbol("x")
    >>> tidy(sympy.Mul(1.0, 0.5 * x + 2.0, sympy.tanh(3.0 * x), evaluate=False))
    (0.5*x + 2.0)*tanh(3.0*x)
    """
    absorbed = _absorb(expression)
    forms = [expression, absorbed]
    if _has_product_of_sums(absorbed):
        forms.append(sympy.expand(absorbed, power_exp=False, power_base=False, log=False))
    return min(forms, key=lambda form: (n_numbers(form), complexity(form)))


def _has_product_of_sums(expression: sympy.Expr) -> bool:
    """Whether multiplying out could change the expression (expanding is slow in SymPy)."""
    for node in sympy.preorder_traversal(expression):
        if node.is_Mul and any(arg.is_Add for arg in node.args):
            return True
        if node.is_Pow and node.base.is_Add and node.exp.is_Integer and node.exp > 1:
            return True
    return False


def without_negligible(values: np.ndarray, evaluate, rtol: float = NEGLIGIBLE) -> np.ndarray:
    """``values`` with the numbers that do nothing set to zero.

    ``evaluate(values)`` gives the expression on a grid. Numbers are set to
    zero one at a time, smallest first, while the expression moves by at
    most ``rtol`` times its largest magnitude there (an engine's ``1e-9``
    offsets).
    """
    out = np.array(values, dtype=float)
    reference = np.asarray(evaluate(out), dtype=float)
    if not np.isfinite(reference).all():
        return out
    bound = rtol * float(np.max(np.abs(reference), initial=0.0))
    for k in np.argsort(np.abs(out), kind="stable"):
        trial = out.copy()
        trial[k] = 0.0
        moved = np.asarray(evaluate(trial), dtype=float)
        if np.isfinite(moved).all() and float(np.max(np.abs(moved - reference))) <= bound:
            out = trial
    return out


def rounded(expression: sympy.Expr, digits: int = 4) -> sympy.Expr:
    """The expression for display: each number to ``digits`` significant digits.

    A number that rounds to an integer is written as one, so ``1.0*x``
    reads ``x`` and ``x**2.0`` reads ``x**2``.
    """
    def shown(number: sympy.Float) -> sympy.Expr:
        value = float(f"{float(number):.{digits}g}")
        if value.is_integer() and abs(value) < 10.0 ** digits:
            return sympy.Integer(int(value))
        return sympy.Float(value, digits)

    return expression.xreplace({c: shown(c) for c in expression.atoms(sympy.Float)})


@dataclass(frozen=True)
class Readability:
    """What an expression chosen from a search may look like, and how ties are settled.

    Parameters
    ----------
    max_nesting : int or None, default=1
        Most elementary functions on one path of the tree (:func:`nesting`);
        None: any.
    max_complexity : int or None, default=None
        Most nodes (:func:`complexity`); None: any.
    tolerance : float, default=0.02
        Candidates whose loss is within this fraction of the chosen one's are
        a tie, which the simplest wins.
    """

    max_nesting: int | None = MAX_NESTING
    max_complexity: int | None = None
    tolerance: float = TIE_TOLERANCE

    def excess(self, expression: sympy.Expr) -> tuple[int, int]:
        """How far the expression is beyond each cap: (nesting, complexity); 0 within."""
        deep = 0 if self.max_nesting is None else max(nesting(expression) - self.max_nesting, 0)
        large = 0 if self.max_complexity is None else max(
            complexity(expression) - self.max_complexity, 0)
        return deep, large

    def allows(self, expression: sympy.Expr) -> bool:
        """Whether the expression is within both caps."""
        return self.excess(expression) == (0, 0)

    def admissible(self, expressions: Sequence[sympy.Expr]) -> list[int]:
        """Indices of the expressions within the caps.

        When none is, those the least beyond them: a search whose whole front
        nests deeper than allowed still answers, with its most readable.
        """
        excess = [self.excess(e) for e in expressions]
        least = min(excess, default=(0, 0))
        return [k for k, over in enumerate(excess) if over == least]

    @staticmethod
    def simplicity(expression: sympy.Expr, variable: sympy.Symbol | None = None) -> tuple:
        """Sort key, simplest first: catalogue-like, then fewer nodes, then shallower."""
        free = variable is not None and not catalogue_like(expression, variable)
        return free, complexity(expression), nesting(expression)

    def settle(self, expressions: Sequence[sympy.Expr], losses: Sequence[float],
               chosen: int, among: Sequence[int], variable: sympy.Symbol | None = None, *,
               sizes: Sequence[int] | None = None) -> int:
        """The simplest of the candidates ``among`` whose loss ties with ``chosen``'s.

        A tie is a loss within :attr:`tolerance` of the chosen one's (or
        within :data:`EXACT` of the largest loss, for exact fits). Sizes the
        engine gave, when any, break ties between equally simple shapes;
        the lower loss breaks the rest.
        """
        losses = np.asarray(losses, dtype=float)
        finite = losses[np.isfinite(losses)]
        slack = EXACT * float(np.max(np.abs(finite))) if finite.size else 0.0
        bar = losses[chosen] * (1.0 + self.tolerance) + slack
        tied = [k for k in among if losses[k] <= bar] or [chosen]
        return min(tied, key=lambda k: (self.simplicity(expressions[k], variable),
                                        0 if sizes is None else sizes[k], losses[k]))
