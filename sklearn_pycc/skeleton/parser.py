"""Recursive-descent parser of the skeleton language.

Grammar (implicit multiplication binds like ``*``; ``^`` and ``**`` are
right associative and bind tighter than unary minus)::

    equation := expr "=" expr
    expr     := term (("+" | "-") term)*
    term     := unary (("*" | "/") unary | unary)*
    unary    := ("-" | "+") unary | power
    power    := primary (("^" | "**") unary)?
    primary  := NUMBER | NAME | NAME "(" expr ")" | "(" expr ")"

A name directly followed by ``(`` is a call (``tanh(x)``, ``f1(x)``); a
parameter or a variable followed by a space and ``(`` multiplies
(``a1 (x + y)``).
"""

from __future__ import annotations

import math

from ..exceptions import SkeletonError
from ..simulation.delays import delayed_name
from .equations import TIME
from .functions import CONSTANTS, ELEMENTARY, is_param_name, is_unknown_name
from .lexer import Token, tokenize
from .nodes import Apply, BinOp, Neg, Node, Number, Param, Symbol, Unknown

__all__ = ["MAX_DEPTH", "MAX_NESTING", "parse_equation", "parse_expression"]

#: most parentheses, calls and powers nested inside one another
MAX_NESTING = 40
#: deepest expression tree accepted (a sum or product of n factors is n levels
#: deep): every walk over a skeleton stays far from Python's recursion limit
MAX_DEPTH = 120


class _Parser:
    def __init__(self, text: str, index: int | None, kind: str) -> None:
        self.text = text
        self.index = index
        self.kind = kind
        self.tokens = tokenize(text, index, kind)
        self.i = 0
        self.nesting = 0

    # -- helpers -----------------------------------------------------------
    @property
    def tok(self) -> Token:
        return self.tokens[self.i]

    def error(self, message: str, pos: int) -> SkeletonError:
        return SkeletonError(
            message, equation=self.index, position=pos, text=self.text, kind=self.kind
        )

    def advance(self) -> Token:
        tok = self.tokens[self.i]
        self.i += 1
        return tok

    def is_op(self, *ops: str) -> bool:
        return self.tok.kind == "OP" and self.tok.text in ops

    def expect_close(self, open_pos: int) -> None:
        if self.is_op(")"):
            self.advance()
            return
        if self.tok.kind == "END":
            raise self.error("unbalanced parentheses: '(' is never closed", open_pos)
        if self.is_op(","):
            raise self.error("functions take exactly one argument", self.tok.pos)
        raise self.error(f"expected ')' but found {self.tok.text!r}", self.tok.pos)

    def enter(self, pos: int) -> None:
        self.nesting += 1
        if self.nesting > MAX_NESTING:
            raise self.error(f"nested more than {MAX_NESTING} levels deep (parentheses, "
                             "function calls and powers)", pos)

    # -- grammar -------------------------------------------------------------
    def equation(self) -> tuple[Node, Node]:
        if self.tok.kind == "END":
            raise self.error("empty equation", 0)
        lhs = self.expr()
        if not self.is_op("="):
            if self.tok.kind == "END":
                raise self.error("missing '=': write it as 'x1_dot = ...'", self.tok.pos)
            raise self.unexpected()
        eq_pos = self.advance().pos
        if self.tok.kind == "END":
            raise self.error("nothing after '='", eq_pos)
        rhs = self.expr()
        if self.is_op("="):
            raise self.error("more than one '='", self.tok.pos)
        if self.tok.kind != "END":
            raise self.unexpected()
        return lhs, rhs

    def expression_only(self) -> Node:
        if self.tok.kind == "END":
            raise self.error("empty expression", 0)
        node = self.expr()
        if self.tok.kind != "END":
            raise self.unexpected()
        return node

    def unexpected(self) -> SkeletonError:
        tok = self.tok
        if tok.kind == "OP" and tok.text == ")":
            return self.error("unbalanced parentheses: ')' without '('", tok.pos)
        if tok.kind == "END":
            return self.error("unexpected end of the equation", tok.pos)
        return self.error(f"unexpected {tok.text!r}", tok.pos)

    def expr(self) -> Node:
        node = self.term()
        while self.is_op("+", "-"):
            op = self.advance()
            node = BinOp(op.text, node, self.term(), pos=op.pos)
        return node

    def starts_primary(self) -> bool:
        tok = self.tok
        return tok.kind in ("NAME", "NUMBER") or (tok.kind == "OP" and tok.text == "(")

    def term(self) -> Node:
        node = self.unary()
        while True:
            if self.is_op("*", "/"):
                op = self.advance()
                node = BinOp(op.text, node, self.unary(), pos=op.pos)
            elif self.starts_primary():
                if self.tok.kind == "NUMBER":
                    raise self.error(
                        "a number cannot follow another factor: missing operator?", self.tok.pos
                    )
                pos = self.tok.pos
                node = BinOp("*", node, self.power(), pos=pos)
            else:
                return node

    def unary(self) -> Node:
        negative, first = False, None
        while self.is_op("-", "+"):  # a run of signs folds into at most one minus
            op = self.advance()
            first = op.pos if first is None else first
            negative ^= op.text == "-"
        node = self.power()
        return Neg(node, pos=first) if negative else node

    def power(self) -> Node:
        base = self.primary()
        if self.is_op("^"):
            op = self.advance()
            self.enter(op.pos)
            exponent = self.unary()
            self.nesting -= 1
            return BinOp("^", base, exponent, pos=op.pos)
        return base

    def primary(self) -> Node:
        tok = self.tok
        if tok.kind == "NUMBER":
            self.advance()
            return Number(float(tok.text), pos=tok.pos)
        if tok.kind == "NAME":
            return self.name()
        if self.is_op("("):
            self.advance()
            if self.is_op(")"):
                raise self.error("empty parentheses", tok.pos)
            self.enter(tok.pos)
            node = self.expr()
            self.nesting -= 1
            self.expect_close(tok.pos)
            return node
        raise self.unexpected()

    def call_argument(self, name_tok: Token) -> Node:
        open_tok = self.advance()  # '('
        if self.is_op(")"):
            raise self.error(f"{name_tok.text}() needs an argument", open_tok.pos)
        self.enter(open_tok.pos)
        arg = self.expr()
        self.nesting -= 1
        self.expect_close(open_tok.pos)
        return arg

    def name(self) -> Node:
        tok = self.advance()
        name = tok.text
        followed_by_paren = self.is_op("(")
        if is_unknown_name(name):
            if not followed_by_paren:
                raise self.error(
                    f"{name} is an unknown curve and needs an argument, e.g. {name}(x1)", tok.pos
                )
            return Unknown(name, self.call_argument(tok), pos=tok.pos)
        if name in ELEMENTARY:
            if not followed_by_paren:
                raise self.error(f"{name} needs parentheses: {name}(...)", tok.pos)
            return Apply(name, self.call_argument(tok), pos=tok.pos)
        adjacent = followed_by_paren and self.tok.pos == tok.pos + len(name)
        if is_param_name(name) or (followed_by_paren and not adjacent):
            # "a1 (x + y)" and "x1 (x2)" multiply; only "name(" is a call
            followed_by_paren = False
        if followed_by_paren:
            if name == "f":
                raise self.error("'f' needs an index: write f1, f2, ...", tok.pos)
            return self.delayed(tok)
        if is_param_name(name):
            return Param(name, pos=tok.pos)
        if name in CONSTANTS:
            return Number(CONSTANTS[name], pos=tok.pos)
        return Symbol(name, pos=tok.pos)

    def delayed(self, tok: Token) -> Node:
        """``u(t - a5)``: an input read a fitted (or a given) time late, as one symbol."""
        name = tok.text
        arg = self.call_argument(tok)
        if isinstance(arg, Symbol) and arg.name == TIME and name != TIME:
            return Symbol(name, pos=tok.pos)
        if (name != TIME and not name.endswith("_dot") and isinstance(arg, BinOp)
                and arg.op == "-" and isinstance(arg.left, Symbol) and arg.left.name == TIME):
            if isinstance(arg.right, Param):
                return Symbol(delayed_name(name, arg.right.name), pos=tok.pos)
            if isinstance(arg.right, Number) and arg.right.value >= 0:
                return Symbol(delayed_name(name, arg.right.value), pos=tok.pos)
            if isinstance(arg.right, Number):
                raise self.error(f"{name}(t - ...) reads {name} late: its delay must not be "
                                 "negative (the future is not measured)", tok.pos)
        known = ", ".join(sorted(set(ELEMENTARY)))
        raise self.error(
            f"unknown function {name!r}; known functions: {known}; unknown curves are "
            f"written f1, f2, ...; an input read late is written {name}(t - a5) (a fitted "
            f"delay) or {name}(t - 0.3)",
            tok.pos,
        )

    def checked(self, node: Node) -> Node:
        """``node`` once its depth and its constant parts are known to be sound."""
        depth = {}
        for current in _post_order(node):
            below = [depth[id(c)] for c in current.children()]
            depth[id(current)] = 1 + max(below, default=0)
            if depth[id(current)] > MAX_DEPTH:
                raise self.error(
                    f"the expression is more than {MAX_DEPTH} levels deep (each term of a "
                    "sum and each factor of a product is one level): split it or use "
                    "fewer terms", max(current.pos, 0))
        _check_constants(node, self.error)
        return node


def _post_order(node: Node) -> list[Node]:
    """Every node of ``node``, children before their parent, without recursion."""
    order, stack = [], [node]
    while stack:
        current = stack.pop()
        order.append(current)
        stack.extend(current.children())
    return order[::-1]


def _binary(op: str, left: float, right: float) -> float:
    if op == "+":
        return left + right
    if op == "-":
        return left - right
    if op == "*":
        return left * right
    if op == "/":
        return left / right
    return math.pow(left, right)


def _check_constants(node: Node, error) -> None:
    """Evaluate every part of ``node`` made of numbers only; refuse what has no value.

    ``log(-1)``, ``sqrt(-1)``, ``1/0``, ``exp(1000)`` or ``(-8)^(1/3)`` have no
    finite real value, so a skeleton containing them describes nothing.
    """
    values: dict[int, float] = {}
    for current in _post_order(node):
        children = current.children()
        if isinstance(current, Number):
            values[id(current)] = current.value
            continue
        if isinstance(current, BinOp) and current.op == "/" and \
                values.get(id(current.right)) == 0.0:
            raise error("division by a constant zero", max(current.pos, 0))
        if isinstance(current, (Symbol, Param, Unknown)) or \
                any(id(c) not in values for c in children):
            continue
        args = [values[id(c)] for c in children]
        try:
            if isinstance(current, Neg):
                value = -args[0]
            elif isinstance(current, Apply):
                value = ELEMENTARY[current.func].math(args[0])
            else:
                value = _binary(current.op, args[0], args[1])
        except (ValueError, ZeroDivisionError, OverflowError):
            value = math.nan
        if not (isinstance(value, float | int) and math.isfinite(value)):
            from .printer import to_text

            raise error(f"the constant {to_text(current)} has no finite real value",
                        max(current.pos, 0))
        values[id(current)] = float(value)

def parse_equation(
    text: str, index: int | None = None, kind: str = "equations"
) -> tuple[Node, Node]:
    """Parse ``"lhs = rhs"`` into two expression trees.

    Parameters
    ----------
    text : str
        The equation.
    index : int, optional
        Its index in the user's list, for error messages.
    kind : str
        What the list is called in error messages.

    Returns
    -------
    (Node, Node)
        Left- and right-hand sides.

    Raises
    ------
    SkeletonError
        Naming the equation and the position of the problem.
    """
    if not isinstance(text, str):
        raise SkeletonError(
            f"each equation must be a string, got {type(text).__name__}", equation=index
        )
    parser = _Parser(text, index, kind)
    lhs, rhs = parser.equation()
    return parser.checked(lhs), parser.checked(rhs)


def parse_expression(text: str, index: int | None = None, kind: str = "terms") -> Node:
    """Parse a bare expression such as ``"a7 sign(x2)"``."""
    if not isinstance(text, str):
        raise SkeletonError(f"expected a string, got {type(text).__name__}", equation=index)
    parser = _Parser(text, index, kind)
    return parser.checked(parser.expression_only())
