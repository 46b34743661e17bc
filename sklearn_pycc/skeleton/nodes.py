"""Expression trees produced by the skeleton parser.

Nodes are immutable and compare structurally (the source position is kept
for error messages but ignored by ``==`` and ``hash``).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields, replace

from ..simulation.delays import delayed_name, read_delayed

__all__ = [
    "Apply",
    "BinOp",
    "Neg",
    "Node",
    "Number",
    "Param",
    "Symbol",
    "Unknown",
    "params_in",
    "product_factors",
    "rename",
    "rename_symbols",
    "signed_terms",
    "substitute",
    "sum_terms",
    "walk",
]


@dataclass(frozen=True)
class Node:
    """Base class of every expression node."""

    def children(self) -> tuple[Node, ...]:
        """Return the direct sub-expressions."""
        return ()


@dataclass(frozen=True)
class Number(Node):
    """A numeric literal."""

    value: float
    pos: int = field(default=-1, compare=False)


@dataclass(frozen=True)
class Symbol(Node):
    """A data variable: a state, an input, a derivative ``NAME_dot`` or ``t``."""

    name: str
    pos: int = field(default=-1, compare=False)


@dataclass(frozen=True)
class Param(Node):
    """An unknown scalar ``a<digits>``."""

    name: str
    pos: int = field(default=-1, compare=False)


@dataclass(frozen=True)
class Unknown(Node):
    """An unknown one-dimensional characteristic curve ``f<digits>(arg)``."""

    name: str
    arg: Node
    pos: int = field(default=-1, compare=False)

    def children(self) -> tuple[Node, ...]:
        return (self.arg,)


@dataclass(frozen=True)
class Apply(Node):
    """A known elementary function such as ``tanh(arg)``."""

    func: str
    arg: Node
    pos: int = field(default=-1, compare=False)

    def children(self) -> tuple[Node, ...]:
        return (self.arg,)


@dataclass(frozen=True)
class Neg(Node):
    """Unary minus."""

    operand: Node
    pos: int = field(default=-1, compare=False)

    def children(self) -> tuple[Node, ...]:
        return (self.operand,)


@dataclass(frozen=True)
class BinOp(Node):
    """A binary operation; ``op`` is one of ``+ - * / ^``."""

    op: str
    left: Node
    right: Node
    pos: int = field(default=-1, compare=False)

    def children(self) -> tuple[Node, ...]:
        return (self.left, self.right)


def sum_terms(node: Node) -> list[Node]:
    """The terms of a sum, signs dropped: ``F - a1 x2 - f1(x1)`` -> ``[F, a1 x2, f1(x1)]``."""
    if isinstance(node, BinOp) and node.op in "+-":
        return sum_terms(node.left) + sum_terms(node.right)
    if isinstance(node, Neg):
        return sum_terms(node.operand)
    return [node]


def signed_terms(node: Node, sign: float = 1.0) -> list[tuple[float, Node]]:
    """The terms of a sum with their signs: ``F - a1 x2`` -> ``[(1, F), (-1, a1 x2)]``."""
    if isinstance(node, BinOp) and node.op in "+-":
        right = sign if node.op == "+" else -sign
        return signed_terms(node.left, sign) + signed_terms(node.right, right)
    if isinstance(node, Neg):
        return signed_terms(node.operand, -sign)
    return [(sign, node)]


def product_factors(node: Node) -> list[Node]:
    """The factors of a product, signs dropped (a quotient ``p / q`` is one factor)."""
    if isinstance(node, BinOp) and node.op == "*":
        return product_factors(node.left) + product_factors(node.right)
    if isinstance(node, BinOp) and node.op == "/":
        return [*product_factors(node.left), node]
    if isinstance(node, Neg):
        return product_factors(node.operand)
    return [node]


def rename(node: Node, mapping: Mapping[str, str]) -> Node:
    """A copy of ``node`` with curves and parameters renamed by ``mapping``.

    The delay of an input read late (``u(t - a5)``) is a parameter too.
    """
    if isinstance(node, (Param, Unknown)) and node.name in mapping:
        node = replace(node, name=mapping[node.name])
    if isinstance(node, Symbol) and (read := read_delayed(node.name)) is not None \
            and read[1] in mapping:
        node = replace(node, name=delayed_name(read[0], mapping[read[1]]))
    changes = {f.name: rename(getattr(node, f.name), mapping) for f in fields(node)
               if isinstance(getattr(node, f.name), Node)}
    return replace(node, **changes) if changes else node


def rename_symbols(node: Node, mapping: Mapping[str, str]) -> Node:
    """A copy of ``node`` with data variables renamed by ``mapping``."""
    if isinstance(node, Symbol) and node.name in mapping:
        return replace(node, name=mapping[node.name])
    changes = {f.name: rename_symbols(getattr(node, f.name), mapping) for f in fields(node)
               if isinstance(getattr(node, f.name), Node)}
    return replace(node, **changes) if changes else node


def substitute(node: Node, name: str, replacement: Node) -> Node:
    """A copy of ``node`` with every data variable ``name`` replaced by ``replacement``."""
    if isinstance(node, Symbol) and node.name == name:
        return replacement
    changes = {f.name: substitute(getattr(node, f.name), name, replacement)
               for f in fields(node) if isinstance(getattr(node, f.name), Node)}
    return replace(node, **changes) if changes else node


def params_in(node: Node) -> list[str]:
    """The parameters ``node`` uses, delays of inputs read late included, in order met."""
    names: list[str] = []
    for n in walk(node):
        name = n.name if isinstance(n, Param) else None
        if isinstance(n, Symbol) and (read := read_delayed(n.name)) is not None \
                and isinstance(read[1], str):
            name = read[1]
        if name is not None and name not in names:
            names.append(name)
    return names


def walk(node: Node) -> Iterator[Node]:
    """Yield ``node`` and all its descendants, depth first."""
    stack = [node]
    while stack:
        current = stack.pop()
        yield current
        stack.extend(reversed(current.children()))
