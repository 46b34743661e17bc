"""The elementary functions and constants the skeleton language knows."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

__all__ = ["CONSTANTS", "ELEMENTARY", "Elementary", "is_param_name", "is_unknown_name"]


def _sign(x: float) -> float:
    return float((x > 0) - (x < 0))


def _log(x: float) -> float:
    """``math.log`` answering ``-inf`` at the edge of its domain (as numpy does), not raising."""
    return -math.inf if x == 0.0 else math.log(x)


def _log10(x: float) -> float:
    """``math.log10`` answering ``-inf`` at 0, as :func:`_log`."""
    return -math.inf if x == 0.0 else math.log10(x)


class Elementary(NamedTuple):
    """One elementary function of the skeleton language, in every representation.

    ``torch`` and ``sympy`` are names, resolved where those libraries are
    used (the skeleton layer imports neither); a SymPy name with an argument,
    such as ``("log", 10)``, means ``sympy.log(x, 10)``.
    """

    numpy: Callable
    math: Callable
    torch: str
    sympy: str | tuple[str, float]


#: name in the skeleton language -> its numpy, math, torch and sympy forms
ELEMENTARY: dict[str, Elementary] = {
    "sin": Elementary(np.sin, math.sin, "sin", "sin"),
    "cos": Elementary(np.cos, math.cos, "cos", "cos"),
    "tan": Elementary(np.tan, math.tan, "tan", "tan"),
    "sinh": Elementary(np.sinh, math.sinh, "sinh", "sinh"),
    "cosh": Elementary(np.cosh, math.cosh, "cosh", "cosh"),
    "tanh": Elementary(np.tanh, math.tanh, "tanh", "tanh"),
    "arcsin": Elementary(np.arcsin, math.asin, "asin", "asin"),
    "arccos": Elementary(np.arccos, math.acos, "acos", "acos"),
    "arctan": Elementary(np.arctan, math.atan, "atan", "atan"),
    "asin": Elementary(np.arcsin, math.asin, "asin", "asin"),
    "acos": Elementary(np.arccos, math.acos, "acos", "acos"),
    "atan": Elementary(np.arctan, math.atan, "atan", "atan"),
    "exp": Elementary(np.exp, math.exp, "exp", "exp"),
    "log": Elementary(np.log, _log, "log", "log"),
    "log10": Elementary(np.log10, _log10, "log10", ("log", 10.0)),
    "sqrt": Elementary(np.sqrt, math.sqrt, "sqrt", "sqrt"),
    "abs": Elementary(np.abs, abs, "abs", "Abs"),
    "sign": Elementary(np.sign, _sign, "sign", "sign"),
}

#: named constants
CONSTANTS: dict[str, float] = {"pi": math.pi}


def is_unknown_name(name: str) -> bool:
    """Return True for the reserved curve names ``f1``, ``f2``, ..."""
    return len(name) > 1 and name[0] == "f" and name[1:].isdigit()


def is_param_name(name: str) -> bool:
    """Return True for the reserved parameter names ``a1``, ``a2``, ..."""
    return len(name) > 1 and name[0] == "a" and name[1:].isdigit()
