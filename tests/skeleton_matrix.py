"""Every skeleton kind x every constraint kind x every entry point x backend.

The cells of the matrix the fast and slow suites draw from
(``test_skeleton_matrix.py``). A cell *works* when the entry point gives
finite results, or *refuses* when it raises one of the package's documented
errors with a message that names the culprit (a curve, a parameter, a state,
an equation or the backend). Anything else (a KeyError from deep inside, a
NaN returned, a refusal that names nothing) is a defect.
"""

from __future__ import annotations

import pickle
import re
import warnings
from dataclasses import dataclass, field
from functools import cache

import numpy as np
import pandas as pd
from sklearn.base import clone

from sklearn_pycc import (
    HypothesisLoop,
    NeuralCCRegressor,
    PolyCCRegressor,
    SimulationError,
    SkeletonError,
    compare_skeletons,
    datasets,
    diagnose,
    to_interpolated,
    to_symbolic,
)
from sklearn_pycc.estimators.least_squares import LeastSquaresCCRegressor
from sklearn_pycc.model_selection import make_simulation_scorer
from sklearn_pycc.skeleton import Skeleton

# the errors a user may meet, each documented as the answer to some misuse
DOCUMENTED = (SkeletonError, SimulationError, ValueError, TypeError, NotImplementedError)
# errors that are always a defect, whatever they say
DEFECTS = (KeyError, IndexError, AttributeError, ZeroDivisionError, AssertionError,
           UnboundLocalError, NameError, RecursionError)


# -- the records ---------------------------------------------------------------------
@cache
def duffing_record() -> pd.DataFrame:
    """A forced Duffing oscillator, 300 samples at 40 dB, with a static output and a relation."""
    frame = datasets.make_duffing(n_samples=300, t_span=(0.0, 30.0), noise=40,
                                  noise_columns=["x1", "x2"], random_state=0)
    frame["F1"] = frame["x1"] ** 3          # a measured static output of x1
    frame["G"] = 2.0 * frame["x1"]          # a measured quantity bound to x1
    return frame


@cache
def two_dof_record() -> pd.DataFrame:
    """Two oscillators joined by a nonlinear spring, 300 samples at 40 dB."""
    return datasets.make_two_dof(n_samples=300, t_span=(0.0, 30.0), noise=40, random_state=0)


@cache
def tanks_record(measured: tuple[str, ...], overflowing: bool = True) -> pd.DataFrame:
    """The two-tank cascade, 200 samples every 4 s, overflowing at its rims or not."""
    rims = (12.0, 13.0) if overflowing else (100.0, 100.0)
    return datasets.make_two_tanks(n_samples=200, measured=measured, rims=rims,
                                   random_state=0)


# -- skeleton kinds ------------------------------------------------------------------
@dataclass(frozen=True)
class Kind:
    """One kind of skeleton, the record it is fitted to and the columns it reads."""

    name: str
    equations: tuple[str, ...]
    record: str
    columns: tuple[str, ...]
    targets: tuple[str, ...] = ()     # measured derivatives, when the record has them
    base_constraints: tuple[str, ...] = ()
    output_error: bool = False        # fitted by output error (unmeasured states): slower

    def X(self) -> pd.DataFrame:
        return _record(self.record)[list(self.columns)]

    def y(self) -> pd.DataFrame | None:
        return _record(self.record)[list(self.targets)] if self.targets else None

    @property
    def skeleton(self) -> Skeleton:
        return Skeleton(list(self.equations))


def _record(name: str) -> pd.DataFrame:
    if name == "duffing":
        return duffing_record()
    if name == "two_dof":
        return two_dof_record()
    if name == "tanks_lower":
        return tanks_record(("x2",), overflowing=False)
    if name == "tanks_both":
        return tanks_record(("x1", "x2"))
    raise KeyError(name)


DUFFING = ("t", "x1", "x2", "F_ext")
DUFFING_Y = ("x1_dot", "x2_dot")
KINDS = {
    "functional": Kind("functional", ("x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"),
                       "duffing", DUFFING, DUFFING_Y),
    "parametric": Kind("parametric",
                       ("x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"),
                       "duffing", DUFFING, DUFFING_Y),
    "hybrid": Kind("hybrid", ("x1_dot = x2", "x2_dot = F_ext - a1 x2 - f2(x1)"),
                   "duffing", DUFFING, DUFFING_Y),
    "implicit": Kind("implicit", ("x1_dot = x2", "F_ext = x2_dot + f1(x2) + f2(x1)"),
                     "duffing", DUFFING, DUFFING_Y),
    "denominator": Kind("denominator",
                        ("x1_dot = x2", "x2_dot = (F_ext - a1 x2 - f2(x1)) / (1 + a2 x1^2)"),
                        "duffing", DUFFING, DUFFING_Y),
    "curve_denominator": Kind("curve_denominator",
                              ("x1_dot = x2", "x2_dot = (F_ext - f1(x2) - f2(x1)) / f3(x1)"),
                              "duffing", DUFFING, DUFFING_Y),
    "static_output": Kind("static_output",
                          ("x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)", "F1 = f3(x1)"),
                          "duffing", (*DUFFING, "F1"), DUFFING_Y),
    "relation": Kind("relation",
                     ("x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)", "0 = G - a1 x1"),
                     "duffing", (*DUFFING, "G"), DUFFING_Y),
    "shared_multiarg": Kind(
        "shared_multiarg",
        ("x1_dot = x3", "x2_dot = x4", "x3_dot = F_ext - f1(x3) - f2(x1) - f3(x1 - x2)",
         "x4_dot = - f4(x4) - f5(x2) + f3(x1 - x2)"),
        "two_dof", ("t", "x1", "x2", "x3", "x4", "F_ext"),
        ("x1_dot", "x2_dot", "x3_dot", "x4_dot")),
    "position_only": Kind("position_only", ("x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"),
                          "duffing", ("t", "x1", "F_ext")),
    # curves are refused with an unmeasured state (no starting values): parametric
    "unmeasured_state": Kind("unmeasured_state",
                             ("x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a3 sqrt(x1) - a4 sqrt(x2)"),
                             "tanks_lower", ("t", "x2", "u"), output_error=True),
    "state_limits": Kind("state_limits",
                         ("x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a3 sqrt(x1) - f1(x2)"),
                         "tanks_both", ("t", "x1", "x2", "u"),
                         base_constraints=("x1 <= 12", "x2 <= 13")),
    "fitted_limit": Kind("fitted_limit",
                         ("x1_dot = a1 u - a2 sqrt(x1)", "x2_dot = a3 sqrt(x1) - a4 sqrt(x2)"),
                         "tanks_both", ("t", "x1", "x2", "u"),
                         base_constraints=("x1 <= 12", "x2 <= a5"), output_error=True),
}

# -- constraint kinds, placed on the kind's first curve, parameter or state -----------
CONSTRAINT_KINDS = ("none", "odd", "even", "point", "increasing", "decreasing", "bounds",
                    "limits")


def constraint_text(kind: Kind, constraint: str, target: int = 0) -> list[str] | None:
    """Constraints of one kind on ``kind``'s ``target``-th curve, parameter or state.

    None where the skeleton has nothing of that sort to constrain.
    """
    skeleton = kind.skeleton
    if constraint == "none":
        return []
    if constraint in ("odd", "even", "increasing", "decreasing", "point"):
        if not skeleton.functions:
            return None
        curve = skeleton.functions[target % len(skeleton.functions)]
        return [f"{curve}(0)=0" if constraint == "point" else f"{curve} {constraint}"]
    if constraint == "bounds":
        if not skeleton.params:
            return None
        param = skeleton.params[target % len(skeleton.params)]
        return [f"{param} >= 0", f"{param} <= 100"]
    if constraint == "limits":
        if kind.base_constraints:  # the kinds with limits have them already
            return None
        state = skeleton.states[target % len(skeleton.states)]
        record = _record(kind.record)
        spread = float(record[state].abs().max()) if state in record.columns else 10.0
        return [f"{state} <= {3 * spread:.3g}", f"{state} >= {-3 * spread:.3g}"]
    raise KeyError(constraint)


def constraint_for(kind: Kind, constraint: str) -> list[str] | None:
    """The kind's own constraints and one of kind ``constraint`` on its first target."""
    extra = constraint_text(kind, constraint)
    return None if extra is None else [*kind.base_constraints, *extra]


def combined_constraints(kind: Kind, drawn) -> list[str]:
    """The kind's own constraints and every applicable ``(constraint, target)`` drawn."""
    out = list(kind.base_constraints)
    for constraint, target in drawn:
        for text in constraint_text(kind, constraint, target) or []:
            if text not in out:
                out.append(text)
    return out


# -- backends --------------------------------------------------------------------------
def make_estimator(backend: str, kind: Kind, constraints: list[str]):
    equations = list(kind.equations)
    if backend == "poly":
        return PolyCCRegressor(equations=equations, constraints=constraints, degree=3)
    if backend == "least_squares":
        return LeastSquaresCCRegressor(equations=equations, constraints=constraints, degree=3)
    if backend == "neural":
        return NeuralCCRegressor(equations=equations, constraints=constraints,
                                 hidden_layer_sizes=(6,), max_epochs=6, random_state=0)
    raise KeyError(backend)


BACKENDS = ("poly", "least_squares", "neural")
ENTRY_POINTS = ("fit", "predict", "score", "simulate", "diagnose", "compare_skeletons",
                "loop_round", "simulation_scorer", "to_symbolic", "to_interpolated",
                "pickle", "clone")
# the entry points that refit or search: the expensive ones
HEAVY = frozenset({"diagnose", "compare_skeletons", "loop_round", "to_symbolic"})


# -- one cell ----------------------------------------------------------------------------
@dataclass
class Outcome:
    """What a cell did: "works", "refused" (with the message) or "defect"."""

    verdict: str
    detail: str = ""
    values: list = field(default_factory=list)


_FITTED: dict = {}


def _fitted(kind: Kind, constraints: list[str], backend: str):
    """The cell's model, fitted once per worker (no entry point modifies it)."""
    key = (kind.name, tuple(constraints), backend)
    if key not in _FITTED:
        estimator = make_estimator(backend, kind, constraints)
        _FITTED[key] = estimator.fit(kind.X(), kind.y())
    return _FITTED[key]


def _finite(value) -> bool:
    if isinstance(value, pd.DataFrame):
        numeric = value.select_dtypes("number")
        return bool(np.isfinite(numeric.to_numpy(dtype=float)).all())
    array = np.asarray(value, dtype=float)
    return bool(np.isfinite(array).all())


def _names(kind: Kind, backend: str) -> set[str]:
    skeleton = kind.skeleton
    names = {*skeleton.functions, *skeleton.params, *skeleton.states, *skeleton.inputs,
             *skeleton.derivatives}
    names |= {type(make_estimator(backend, kind, [])).__name__, "equations", "constraint"}
    return names


def refusal_names_culprit(exc: BaseException, kind: Kind, backend: str,
                          constraints: list[str]) -> bool:
    """Whether a documented error's message names something the user wrote."""
    text = str(exc)
    words = set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", text))
    return bool(words & _names(kind, backend)) or any(c in text for c in constraints)


def run_cells(kind: Kind, constraints: list[str], backend: str, entries) -> dict[str, Outcome]:
    """:func:`run_cell` for each entry point, on one fitted model."""
    return {entry: run_cell(kind, constraints, backend, entry) for entry in entries}


def run_cell(kind: Kind, constraints: list[str], backend: str, entry: str) -> Outcome:
    """Fit (unless the entry point is ``fit`` alone, fitting is its first step) and call it."""
    X, y = kind.X(), kind.y()
    estimator = make_estimator(backend, kind, constraints)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = _fitted(kind, constraints, backend) if entry != "fit" \
                else clone(estimator).fit(X, y)
            before = (dict(model.params_), repr(model.get_params()), X.copy())
            values = _call(entry, model, estimator, kind, X, y)
            after = (dict(model.params_), repr(model.get_params()))
            if after != before[:2] or not X.equals(before[2]):
                return Outcome("defect", f"{entry} modified the model or X")
    except DEFECTS as exc:
        return Outcome("defect", f"{type(exc).__name__}: {exc}")
    except DOCUMENTED as exc:
        if refusal_names_culprit(exc, kind, backend, constraints):
            return Outcome("refused", f"{type(exc).__name__}: {exc}")
        return Outcome("defect", f"unexplained {type(exc).__name__}: {exc}")
    except Exception as exc:  # anything else is a defect too
        return Outcome("defect", f"{type(exc).__name__}: {exc}")
    bad = [i for i, v in enumerate(values) if not _finite(v)]
    if bad:
        return Outcome("defect", f"{entry} gave non-finite values", values)
    return Outcome("works", values=values)


def _course(model, X) -> np.ndarray:
    """The model on X: its derivatives where X holds every state, else its simulation."""
    if all(s in X.columns for s in model.skeleton_.states):
        return model.predict(X)
    t = X["t"].to_numpy()[:60]
    inputs = {u: X[u].to_numpy()[:60] for u in model.skeleton_.inputs}
    sim = model.simulate(t, y0=model.estimate_initial_state(X), inputs=inputs)
    return sim[[s for s in model.skeleton_.states if s in X.columns]].to_numpy()


def _call(entry: str, model, estimator, kind: Kind, X, y) -> list:
    measured = [s for s in model.skeleton_.states if s in X.columns]
    if entry == "fit":
        return [list(model.params_.values()) or [0.0]]
    if entry == "predict":
        return [model.predict(X)]
    if entry == "score":
        return [model.score(X, y) if y is not None else model.score(X, None)]
    if entry == "simulate":
        t = X["t"].to_numpy()[:60]
        y0 = model.estimate_initial_state(X)
        inputs = {u: X[u].to_numpy()[:60] for u in model.skeleton_.inputs}
        sim = model.simulate(t, y0=y0, inputs=inputs)
        return [sim[measured]]
    if entry == "diagnose":
        report = diagnose(model, X, y, n_bootstrap=10, n_refit=2)
        assert isinstance(report.summary(), str)
        return [report.ranking.select_dtypes("number").fillna(0.0)]
    if entry == "compare_skeletons":
        table = compare_skeletons({"given": list(kind.equations)}, X, y,
                                  estimator=clone(estimator), held_out=False)
        numbers = table.select_dtypes("number").dropna(axis=1, how="all")
        # documented: a simulation that diverges has an infinite error
        diverged = [c for c in numbers.columns if "simulation" in c]
        numbers[diverged] = numbers[diverged].replace(np.inf, 0.0)
        return [numbers.fillna(0.0)]
    if entry == "loop_round":
        loop = HypothesisLoop(clone(estimator), X, y, n_bootstrap=10, n_refit=2)
        loop.step()
        assert isinstance(loop.summary(), str)
        return [loop.table()[["simulation_rmse"]]]
    if entry == "simulation_scorer":
        score = make_simulation_scorer()(model, X)
        # documented: a model whose simulation diverges scores -inf (never NaN)
        return [0.0 if score == -np.inf else score]
    if entry == "to_symbolic":
        converted = to_symbolic(model, population_size=60, generations=4, maxsize=8,
                                random_state=0)
        return [_course(converted, X)]
    if entry == "to_interpolated":
        return [_course(to_interpolated(model, n_points=40), X)]
    if entry == "pickle":
        again = pickle.loads(pickle.dumps(model))
        first, second = _course(model, X), _course(again, X)
        np.testing.assert_allclose(first, second, rtol=1e-9, atol=1e-12)
        return [second]
    if entry == "clone":
        again = clone(model)
        assert again.get_params()["equations"] == estimator.get_params()["equations"]
        return [_course(again.fit(X, y), X)]
    raise KeyError(entry)


def cells(kinds=None, constraints=CONSTRAINT_KINDS, backends=BACKENDS, entries=ENTRY_POINTS):
    """Every applicable (kind, constraint, backend, entry) combination."""
    for name in kinds or KINDS:
        kind = KINDS[name]
        for constraint in constraints:
            given = constraint_for(kind, constraint)
            if given is None:
                continue
            for backend in backends:
                if backend != "poly" and kind.output_error:
                    continue  # output-error fits are exercised on the fast backend only
                for entry in entries:
                    yield name, constraint, backend, entry
