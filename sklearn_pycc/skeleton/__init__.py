"""Skeleton language: parsing, constraints, compilation and identifiability analysis.

This subpackage knows nothing of estimators.
"""

from .constraints import Bound, Constraint, parse_constraints
from .curves import Curve, as_curve
from .nodes import Apply, BinOp, Neg, Node, Number, Param, Symbol, Unknown
from .parser import parse_equation, parse_expression
from .skeleton import Skeleton

__all__ = [
    "Apply",
    "BinOp",
    "Bound",
    "Constraint",
    "Curve",
    "Neg",
    "Node",
    "Number",
    "Param",
    "Skeleton",
    "Symbol",
    "Unknown",
    "as_curve",
    "parse_constraints",
    "parse_equation",
    "parse_expression",
]
