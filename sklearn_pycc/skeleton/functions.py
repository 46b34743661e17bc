"""The elementary functions and constants the skeleton language knows."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CONSTANTS", "ELEMENTARY", "is_param_name", "is_unknown_name"]


def _sign(x: float) -> float:
    return float((x > 0) - (x < 0))


#: name -> (vectorised numpy function, fast scalar function, sympy name)
ELEMENTARY: dict[str, tuple] = {
    "sin": (np.sin, math.sin, "sin"),
    "cos": (np.cos, math.cos, "cos"),
    "tan": (np.tan, math.tan, "tan"),
    "sinh": (np.sinh, math.sinh, "sinh"),
    "cosh": (np.cosh, math.cosh, "cosh"),
    "tanh": (np.tanh, math.tanh, "tanh"),
    "arcsin": (np.arcsin, math.asin, "asin"),
    "arccos": (np.arccos, math.acos, "acos"),
    "arctan": (np.arctan, math.atan, "atan"),
    "asin": (np.arcsin, math.asin, "asin"),
    "acos": (np.arccos, math.acos, "acos"),
    "atan": (np.arctan, math.atan, "atan"),
    "exp": (np.exp, math.exp, "exp"),
    "log": (np.log, math.log, "log"),
    "log10": (np.log10, math.log10, "log10"),
    "sqrt": (np.sqrt, math.sqrt, "sqrt"),
    "abs": (np.abs, abs, "Abs"),
    "sign": (np.sign, _sign, "sign"),
}

#: named constants
CONSTANTS: dict[str, float] = {"pi": math.pi}


def is_unknown_name(name: str) -> bool:
    """Return True for the reserved curve names ``f1``, ``f2``, ..."""
    return len(name) > 1 and name[0] == "f" and name[1:].isdigit()


def is_param_name(name: str) -> bool:
    """Return True for the reserved parameter names ``a1``, ``a2``, ..."""
    return len(name) > 1 and name[0] == "a" and name[1:].isdigit()
