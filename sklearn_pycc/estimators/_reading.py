"""Reading a fitted model: its equations as text, SymPy and LaTeX, its curves as tables."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
from sklearn.utils.validation import check_is_fitted

from ..fitting.uncertainty.intervals import check_level
from ..skeleton.nodes import Symbol
from ..skeleton.printer import to_text

__all__ = ["ReadingMixin"]


class ReadingMixin:
    """How a fitted :class:`~sklearn_pycc.estimators.base.CCRegressor` reads.

    The fitted equations written out (:meth:`equations_text`, :meth:`to_sympy`,
    :meth:`to_latex`, the notebook displays) and each curve on a grid
    (:meth:`cc_curves`). The host class gives ``skeleton_``, ``params_``,
    ``functions_``, ``backend_`` and ``_curve_band``.
    """

    def _variable(self, name: str) -> str:
        args = self._arguments(name)
        if len(args) == 1 and isinstance(args[0], Symbol):
            return args[0].name
        return "u"

    def equations_text(self, precision: int = 6) -> list[str]:
        """The fitted model written out; ``model.equations()`` returns the same.

        Parameters
        ----------
        precision : int, default=6
            Significant digits of the numbers.

        Returns
        -------
        list of str
            One line per equation with the fitted parameters substituted,
            then one line per curve with its fitted expression (a curve of
            an expression argument is written over ``u``, with ``u`` given),
            then one line per state with a hard limit (``x2 <= 13.0004``, a
            fitted end at its value).
        """
        check_is_fitted(self, "functions_")
        lines = []
        for eq in self.skeleton_.residual_equations:
            lhs = to_text(eq.lhs, self.params_, precision)
            rhs = to_text(eq.rhs, self.params_, precision)
            lines.append(f"{lhs} = {rhs}")
        for name in self.skeleton_.functions:
            variable = self._variable(name)
            body = self.backend_.curve_text(self.functions_[name], variable, precision)
            line = f"{name}({variable}) = {body}"
            if variable == "u":
                args = sorted({to_text(a) for a in self._arguments(name)})
                line += f"  with u = {' or '.join(args)}"
            lines.append(line)
        for state, (low, high) in self.skeleton_.limits_at(self.params_).items():
            ends = ([f"{low:.{precision}g} <="] if np.isfinite(low) else []) + [state] + (
                [f"<= {high:.{precision}g}"] if np.isfinite(high) else [])
            lines.append(" ".join(ends))
        return lines

    def to_sympy(self) -> list:
        """The fitted model as SymPy equations, one per equation of the skeleton.

        Curves with a closed form (polynomial, symbolic) are written out; the
        others (networks, tables) stay undefined functions ``f1(x2)``.
        """
        import sympy

        from ..backends.symbolic.curves import VARIABLE
        from ..backends.symbolic.sympy_skeleton import to_sympy

        check_is_fitted(self, "functions_")
        written = {name: curve.to_sympy(VARIABLE) for name, curve in self.functions_.items()}
        curves = {name: expression for name, expression in written.items()
                  if expression is not None}
        return [sympy.Eq(to_sympy(eq.lhs, self.params_, curves),
                         to_sympy(eq.rhs, self.params_, curves))
                for eq in self.skeleton_.residual_equations]

    def to_latex(self) -> list[str]:
        """The fitted model as LaTeX, one string per equation (see :meth:`to_sympy`)."""
        import sympy

        names = {}
        for state in self.skeleton_.states:
            names[sympy.Symbol(f"{state}_dot")] = rf"\dot{{{sympy.latex(sympy.Symbol(state))}}}"
        return [sympy.latex(eq.evalf(6), symbol_names=names) for eq in self.to_sympy()]

    def _html_repr(self) -> str:
        """scikit-learn's estimator display, then the fitted equations as rendered maths."""
        html = super()._html_repr()
        if not hasattr(self, "functions_"):
            return html
        from .._utils.html_pages import equations_html

        return equations_html(self) + html

    def _repr_latex_(self) -> str | None:
        """The fitted equations for a notebook (None before ``fit``)."""
        if not hasattr(self, "functions_"):
            return None
        rows = r" \\ ".join(line.replace("=", "&=", 1) for line in self.to_latex())
        return rf"$$\begin{{aligned}} {rows} \end{{aligned}}$$"

    def _arguments(self, name: str):
        return self.skeleton_.curve_arguments(name)

    def cc_curves(self, n: int = 200, level: float | None = None,
                  domain=None) -> dict[str, pd.DataFrame]:
        """Each fitted curve on ``n`` points over the range of its argument in training.

        Parameters
        ----------
        n : int, default=200
            Points per curve.
        level : float, optional
            Add ``lower`` and ``upper`` columns: the confidence band of each
            curve at that level (from the fit's ``covariance_`` or its refits
            on resamples). It widens where the data say less, beyond the
            measured range above all; a network ensemble's band is NaN
            beyond the measured range, where every network only continues
            its edge slope and their agreement proves nothing.
        domain : (float, float) or dict, optional
            Evaluate over this range instead of the training range (one pair
            for every curve, or ``{"f1": (lo, hi)}``).

        Returns
        -------
        dict of str -> DataFrame
            ``{"f1": DataFrame(columns=["x", "f1"]), ...}`` (the paper's
            ``evals``); ``frame.attrs["argument"]`` holds the argument's text.
        """
        check_is_fitted(self, "functions_")
        if int(n) < 2:
            raise ValueError(f"n must be at least 2, got {n}")
        level = None if level is None else check_level(level)
        spans = _domains(domain, self.curve_ranges_)
        out = {}
        for name, curve in self.functions_.items():
            lo, hi = spans[name]
            x = np.linspace(lo, hi, int(n))
            values = np.broadcast_to(np.asarray(curve(x), dtype=float), x.shape)
            frame = pd.DataFrame({"x": x, name: np.array(values)})
            if level is not None:
                frame["lower"], frame["upper"] = self._curve_band(name, x, np.array(values),
                                                                  level)
            frame.attrs["argument"] = " or ".join(sorted({to_text(a)
                                                          for a in self._arguments(name)}))
            out[name] = frame
        return out


def _domains(domain, trained: Mapping[str, tuple[float, float]]) -> dict:
    """The range to evaluate each curve over (``cc_curves``' ``domain``)."""
    if domain is None:
        return dict(trained)
    if isinstance(domain, Mapping):
        unknown = [k for k in domain if k not in trained]
        if unknown:
            raise ValueError(f"domain names {unknown[0]!r}, which is not a curve of the model "
                             f"({', '.join(trained) or 'none'})")
        return {name: _pair(domain[name]) if name in domain else span
                for name, span in trained.items()}
    pair = _pair(domain)
    return {name: pair for name in trained}


def _pair(domain) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in domain)
    except (TypeError, ValueError):
        raise ValueError(f"domain must be a pair (low, high) or a dict of pairs, got "
                         f"{domain!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ValueError(f"domain must run from a lower to a higher finite value, got {domain!r}")
    return lo, hi
