"""What the functional API's calls share: ``models``, ``evals``, coefficients, PySR settings."""

from __future__ import annotations

import importlib.util
from collections.abc import Mapping, Sequence

import numpy as np

from ..skeleton import Skeleton

__all__ = ["Models", "coefficients", "equation_list", "evals_of", "pair_evals",
           "symbolic_settings"]


class Models(dict):
    """The fitted curves by name (the paper's ``models``), and the estimator holding them.

    It is a dict ``{"f1": curve, ...}`` of numpy callables; ``estimator``
    is the fitted scikit-learn estimator, to go on with the estimator API.
    """

    def __init__(self, curves: Mapping, estimator) -> None:
        super().__init__(curves)
        self.estimator = estimator

    def __repr__(self) -> str:
        return f"Models({dict.__repr__(self)}, estimator={type(self.estimator).__name__})"


def equation_list(equations, where: str):
    """The skeleton's equations as a list of strings (a :class:`Skeleton` is kept as it is).

    One string is one equation; a string of several lines is one equation
    per non-empty line.
    """
    if isinstance(equations, Skeleton):
        return equations
    if isinstance(equations, str):
        lines = [line.strip() for line in equations.splitlines()]
        out = [line for line in lines if line]
        if not out:
            raise ValueError(f"{where}: equations is an empty string; give one equation "
                             "per string, e.g. ['x1_dot = x2', 'x2_dot = -f1(x1)']")
        return out
    try:
        return list(equations)
    except TypeError:
        raise TypeError(f"{where}: equations must be a list of strings, got "
                        f"{type(equations).__name__}") from None


def coefficients(estimator) -> dict:
    """The fitted ``a_i`` as numpy scalars (they answer ``.item()``, as the paper prints them)."""
    return {name: np.float64(value) for name, value in estimator.params_.items()}


def evals_of(estimator, n_eval: int) -> list[np.ndarray]:
    """``[x_f1, f1, x_f2, f2, ...]`` in the order of the curves' names."""
    curves = estimator.cc_curves(n=int(n_eval))
    out = []
    for name in estimator.skeleton_.functions:
        frame = curves[name]
        out += [frame["x"].to_numpy(), frame[name].to_numpy()]
    return out


def pair_evals(evals: Sequence, names: Sequence[str], where: str) -> dict:
    """``{name: (x, values)}`` from a flat ``evals`` list, in the order of ``names``."""
    if not isinstance(evals, Sequence) or isinstance(evals, str):
        raise TypeError(f"{where}: evals must be the flat list [x_f1, f1, x_f2, f2, ...]")
    if len(evals) != 2 * len(names):
        raise ValueError(
            f"{where}: evals holds {len(evals)} arrays but the equations have "
            f"{len(names)} curve(s) ({', '.join(names)}), which need {2 * len(names)}: "
            "[x_f1, f1, x_f2, f2, ...] in the order of the names")
    return {name: (np.asarray(evals[2 * k], dtype=float),
                   np.asarray(evals[2 * k + 1], dtype=float))
            for k, name in enumerate(names)}


#: PySR's defaults for the settings the translation reads
PYSR_POPULATION_SIZE = 33
#: PySR settings with no bearing on the result
PYSR_QUIET = ("verbosity", "progress", "deterministic", "parallelism", "procs",
              "random_state", "temp_equation_file", "delete_tempfiles")


def symbolic_settings(pysr: Mapping | None, read) -> dict:
    """Hyperparameters of the symbolic backend for the paper's ``pysr`` settings.

    PySR runs when it is installed; otherwise (PySR needs Julia) the settings
    go to the offline engine, and a note on ``read`` (a :class:`Params`)
    says so, naming those it cannot use.
    """
    if pysr is not None and not isinstance(pysr, Mapping):
        raise TypeError(f"{read.where}: params['pysr'] must be a dict of PySR settings, "
                        f"got {type(pysr).__name__}")
    pysr = dict(pysr or {})
    given = bool(pysr)
    out: dict = {}
    if "niterations" in pysr:
        out["generations"] = int(pysr.pop("niterations"))
    for key in ("binary_operators", "unary_operators", "maxsize"):
        if key in pysr:
            out[key] = pysr.pop(key)
    if "model_selection" in pysr:
        selection = pysr.pop("model_selection")
        out["model_selection"] = "best" if selection == "score" else selection
    populations = pysr.pop("populations", None)
    size = pysr.pop("population_size", None)
    if populations is not None or size is not None:
        out["population_size"] = int(populations or 1) * int(size or PYSR_POPULATION_SIZE)
    if importlib.util.find_spec("pysr") is not None:
        out["engine"] = "pysr"
        out["engine_options"] = pysr
        return out
    out["engine"] = "operon"
    if not given:  # nothing asked of PySR: nothing to say
        return out
    dropped = sorted(key for key in pysr if key not in PYSR_QUIET)
    unused = f" ({dropped} have no counterpart there and are not used)" if dropped else ""
    read.note(f"'pysr': PySR is not installed, so the PySR settings go to the offline "
              f"symbolic engine (pyoperon){unused}")
    return out
