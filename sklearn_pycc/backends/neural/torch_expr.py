"""Compile parsed expression trees into torch closures, once per fit.

The closures take the list of data columns (1-D tensors, one per variable
slot) and return a tensor, or a Python float when the expression needs no
data. Curves and free parameters are looked up in ``nn.ModuleDict`` /
``nn.ParameterDict`` objects at call time, so the same closures follow the
module across devices and through training.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import torch

from ...skeleton.functions import ELEMENTARY
from ...skeleton.nodes import Apply, BinOp, Neg, Node, Number, Param, Symbol, Unknown

__all__ = ["TORCH_FUNCTIONS", "compile_torch"]

#: elementary function name of the skeleton language -> torch function
TORCH_FUNCTIONS: dict[str, Callable] = {name: getattr(torch, forms.torch)
                                        for name, forms in ELEMENTARY.items()}

_ARITHMETIC = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": lambda a, b: a / b,
    "^": lambda a, b: a**b,
}


def _apply(func: Callable, value):
    if isinstance(value, float):
        return float(func(torch.tensor(value, dtype=torch.float64)))
    return func(value)


def compile_torch(
    node: Node,
    slots: Mapping[str, int],
    curves: Mapping[str, Callable],
    params: Mapping[str, torch.Tensor],
    fixed: Mapping[str, float],
) -> Callable[[list], object]:
    """Compile ``node`` into ``fn(columns)`` over torch tensors.

    Parameters
    ----------
    node : Node
        Expression tree from the parser.
    slots : mapping
        Variable name -> position in the ``columns`` list.
    curves : mapping
        Curve name -> module (or callable) evaluated on a 1-D tensor; a curve
        pinned to zero by the gauge is absent and evaluates to 0.
    params : mapping
        Free parameter name -> scalar tensor (looked up at call time).
    fixed : mapping
        Parameter name -> value for the parameters pinned by the gauge.

    Returns
    -------
    callable
        ``fn(columns)`` returning a tensor or a float.
    """
    if isinstance(node, Number):
        value = float(node.value)
        return lambda cols: value
    if isinstance(node, Param):
        name = node.name
        if name in fixed:
            value = float(fixed[name])
            return lambda cols: value
        return lambda cols: params[name]
    if isinstance(node, Symbol):
        i = slots[node.name]
        return lambda cols: cols[i]
    if isinstance(node, Neg):
        inner = compile_torch(node.operand, slots, curves, params, fixed)
        return lambda cols: -inner(cols)
    if isinstance(node, Apply):
        func = TORCH_FUNCTIONS[node.func]
        inner = compile_torch(node.arg, slots, curves, params, fixed)
        return lambda cols: _apply(func, inner(cols))
    if isinstance(node, Unknown):
        name = node.name
        inner = compile_torch(node.arg, slots, curves, params, fixed)
        if name not in curves:
            return lambda cols: 0.0

        def curve(cols):
            arg = inner(cols)
            if not isinstance(arg, torch.Tensor) or arg.ndim == 0:
                arg = torch.as_tensor(arg, dtype=cols[0].dtype, device=cols[0].device)
                arg = arg.expand(cols[0].shape)
            return curves[name](arg)

        return curve
    if isinstance(node, BinOp):
        op = _ARITHMETIC[node.op]
        left = compile_torch(node.left, slots, curves, params, fixed)
        right = compile_torch(node.right, slots, curves, params, fixed)
        if node.op == "^" and isinstance(node.right, Number):
            exponent = float(node.right.value)
            if exponent.is_integer() and 0 <= exponent <= 64:
                k = int(exponent)
                return lambda cols: left(cols) ** k
        return lambda cols: op(left(cols), right(cols))
    raise TypeError(f"cannot compile node {node!r}")
