"""Formulas from the symbolic engine are readable: capped nesting, ties to the simpler."""


import numpy as np
import pandas as pd
import pytest
import sympy

from sklearn_pycc import SymbolicCCRegressor, from_tables
from sklearn_pycc.backends.symbolic.curves import VARIABLE, SymbolicCurve, Template
from sklearn_pycc.backends.symbolic.engines import Candidate
from sklearn_pycc.backends.symbolic.readable import (
    Readability,
    catalogue_like,
    complexity,
    n_numbers,
    nesting,
    rounded,
    tidy,
    without_negligible,
)
from sklearn_pycc.backends.symbolic.sympy_skeleton import to_sympy
from sklearn_pycc.diagnostics import _open_curves
from sklearn_pycc.diagnostics._candidates import extend
from sklearn_pycc.diagnostics._open_curves import formula_candidates, formula_text
from sklearn_pycc.diagnostics._roles import equation_roles
from sklearn_pycc.estimators.symbolic import choose_candidate, select
from sklearn_pycc.skeleton import Skeleton
from sklearn_pycc.skeleton.parser import parse_expression

F = sympy.Float
x = VARIABLE
#: the formula once proposed for a camera-tracked oscillator's damping
TANGLE = F(0.0805) * sympy.sin(sympy.exp(F(0.0071) * x) * sympy.tanh(
    sympy.cos(F(0.0227) * x))) - F(0.0183)
SATURATING = F(0.3) * x + F(0.5) * sympy.tanh(F(8.0) * x)


def front(*entries):
    """A hand-made Pareto front: ``(expression, engine size, loss)`` triples."""
    return [(Candidate(expression, size, loss), loss) for expression, size, loss in entries]


# -- (a) the measures ---------------------------------------------------------------------
@pytest.mark.parametrize("expression, depth", [
    (F(2.0) * x**3 - x, 0),
    (x**F(2.0), 0),
    (1 / (1 + x**2), 0),
    (SATURATING, 1),
    (sympy.exp(F(0.2) * x) * sympy.cos(x), 1),
    (sympy.sqrt(x), 1),
    (sympy.tanh(x)**2, 1),
    (sympy.sin(sympy.exp(x)), 2),
    (sympy.sqrt(sympy.Abs(x)), 2),
    (TANGLE, 3),
])
def test_nesting_counts_functions_on_the_deepest_path(expression, depth):
    assert nesting(expression) == depth


def test_complexity_counts_binary_nodes():
    assert complexity(x) == 1
    assert complexity(-x) == 2
    assert complexity(SATURATING) == 10  # 5 leaves, 3 products, 1 sum, 1 tanh
    assert complexity(TANGLE) > complexity(SATURATING)


@pytest.mark.parametrize("expression, expected", [
    (F(1.5) * x**3 - F(0.2) * x + 1, True),
    (SATURATING, True),
    (x * sympy.Abs(x) + F(0.1) * sympy.sign(x), True),
    (sympy.sqrt(F(2.0) * x + 1), True),
    (F(0.6) * sympy.sin(F(3.0) * x), False),
    (sympy.exp(-x**2), False),
    (sympy.tanh(x**2), False),
    (1 / (1 + x**2), False),
])
def test_catalogue_like_shapes(expression, expected):
    assert catalogue_like(expression, x) is expected


def test_caps_of_readability():
    default = Readability()
    assert default.allows(SATURATING) and not default.allows(sympy.sin(sympy.exp(x)))
    assert Readability(max_nesting=None).allows(TANGLE)
    small = Readability(max_complexity=9)
    assert not small.allows(SATURATING) and small.excess(SATURATING) == (0, 1)


# -- (a) the selection rule on hand-made fronts -------------------------------------------
def test_a_deeper_formula_is_passed_over_even_when_more_accurate():
    pareto = front((F(0.1), 1, 1.0), (F(0.9) * x, 3, 0.3), (SATURATING, 7, 0.010),
                   (TANGLE, 12, 0.004))
    for rule in ("best", "accuracy"):
        assert select(pareto, rule) == 2
    assert select(pareto, "accuracy", Readability(max_nesting=None)) == 3


def test_ties_go_to_the_simpler_and_catalogue_shapes_first():
    cubic = F(1.1) * x - F(0.2) * x**3
    ripple = F(1.0) * x + F(0.3) * sympy.sin(F(3.0) * x)
    # within 2 %: the polynomial wins over the free form, though longer and less accurate
    assert select(front((ripple, 6, 0.0100), (cubic, 9, 0.0101)), "accuracy") == 1
    # beyond the tolerance the data decide
    assert select(front((ripple, 6, 0.0100), (cubic, 9, 0.0130)), "accuracy") == 0
    longer = SATURATING + F(1e-3) * sympy.tanh(F(0.5) * x)
    assert select(front((longer, 11, 0.00995), (SATURATING, 7, 0.0100)), "accuracy") == 1
    # two exact fits tie whatever their ratio: the shorter wins
    assert select(front((F(0.4) * x, 3, 1.0), (longer, 11, 1e-25),
                        (SATURATING, 7, 1e-21)), "accuracy") == 2


def test_a_front_with_nothing_readable_answers_with_its_least_nested():
    deep = sympy.tanh(sympy.cos(F(0.02) * x))
    pareto = front((F(0.1) * deep, 5, 0.2), (TANGLE, 12, 0.01))
    assert select(pareto, "accuracy") == 0


# -- (a) simplification and display -------------------------------------------------------
def test_tidy_drops_a_redundant_factor_and_keeps_the_value():
    tangled = sympy.Mul(F(1.0), F(0.5) * x + F(2.0), sympy.tanh(F(3.0) * x), evaluate=False)
    tidied = tidy(tangled)
    assert n_numbers(tidied) == n_numbers(tangled) - 1
    grid = np.linspace(-2.0, 2.0, 9)
    np.testing.assert_allclose(sympy.lambdify(x, tidied)(grid),
                               sympy.lambdify(x, tangled)(grid), rtol=1e-12)
    assert tidy(SATURATING) == SATURATING


def test_numbers_that_do_nothing_are_dropped():
    grid = np.linspace(-1.5, 1.5, 31)

    def curve(c):
        return c[0] * grid + c[1] * np.tanh(c[2] * grid) + c[3]

    kept = without_negligible(np.array([0.3, 0.5, 8.0, 2e-9]), curve)
    np.testing.assert_array_equal(kept, [0.3, 0.5, 8.0, 0.0])
    kept = without_negligible(np.array([0.3, 0.5, 8.0, 2e-3]), curve)
    np.testing.assert_array_equal(kept, [0.3, 0.5, 8.0, 2e-3])


def test_a_chosen_curve_is_tidied_and_loses_its_idle_numbers():
    found = [Candidate(sympy.Mul(F(1.0), SATURATING + F(2e-9), evaluate=False), 7, 0.0)]
    curve, _, table = choose_candidate(found, Template(None, []), (-1.5, 1.5), None,
                                       lambda c: (1.0, {}, None), rule="best")
    assert curve.expression() == SATURATING and len(curve.values) == 3
    assert table["expression"].tolist() == [SATURATING] and table["nesting"].tolist() == [1]


def test_numbers_are_rounded_for_display():
    shown = rounded(F(1.0) * sympy.tanh(F(7.99999046) * x) + F(0.299999922) * x**F(2.0), 4)
    assert shown == sympy.tanh(8 * x) + F(0.3, 4) * x**2
    curve = SymbolicCurve(F(1.0000003) * x + F(0.123456789) * sympy.tanh(x), (-1.0, 1.0))
    assert curve.text("x2", precision=4) == "x2 + 0.1235*tanh(x2)"


def test_formula_parameters_are_numbered_as_they_are_read():
    v = sympy.Symbol("v")
    expression = F(0.9) + F(0.2) * sympy.cos(F(3.0) * v) * sympy.exp(F(0.05) * v)
    text, values = formula_text(expression, v, "x1")
    named = [text.index(f"a{k}") for k in range(1, 5)]
    assert named == sorted(named)
    at = to_sympy(parse_expression(text, kind="term"), dict(zip(["a1", "a2", "a3", "a4"],
                                                                values)), {})
    assert float(at.subs(sympy.Symbol("x1"), 0.7)) == pytest.approx(
        float(expression.subs(v, 0.7)))


# -- (b) end to end: the engine on a saturating curve ----------------------------------------
def _proposal_nesting(formula) -> int:
    node = parse_expression(formula.term, kind="term")
    return nesting(to_sympy(node, formula.screen_params, {}))


def test_the_proposal_for_a_saturating_friction_is_readable(monkeypatch):
    pytest.importorskip("pyoperon")
    monkeypatch.setitem(_open_curves.FORMULA_SEARCH, "population_size", 100)
    monkeypatch.setitem(_open_curves.FORMULA_SEARCH, "generations", 10)
    skeleton = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
    opened = {c.effect.name: c for c in _open_curves.open_candidates(
        skeleton, equation_roles(skeleton))}
    candidate = opened["free_friction_curve"]
    extend(skeleton, candidate)
    v = np.linspace(-1.5, 1.5, 301)
    candidate.refit = from_tables(candidate.extended, {"f1": (v, 0.3 * v + 0.5 * np.tanh(8 * v))},
                                  {"a2": 1.0})
    formulas = formula_candidates(candidate, random_state=0)
    assert formulas
    for formula in formulas:
        assert _proposal_nesting(formula) <= 1, formula.term
    fits = []
    for formula in formulas:
        expression = to_sympy(parse_expression(formula.term, kind="term"),
                              formula.screen_params, {})
        values = sympy.lambdify(sympy.Symbol("x2"), expression)(v)
        fits.append(np.max(np.abs(values - (0.3 * v + 0.5 * np.tanh(8 * v)))))
    assert min(fits) < 1e-3  # one of them is the curve itself, 0.3 x + 0.5 tanh(8 x)


def test_the_regressor_chooses_within_its_nesting_cap():
    pytest.importorskip("pyoperon")
    v = np.linspace(-1.0, 1.0, 120)
    X = pd.DataFrame({"v": v})
    y = pd.DataFrame({"z_dot": 0.3 * v + 0.5 * np.tanh(8 * v)})
    settings = dict(equations=["z_dot = f1(v)"], population_size=60, generations=8,
                    max_iterations=1, n_fit_points=40, start_degree=None, random_state=0)
    model = SymbolicCCRegressor(**settings, max_nesting=0).fit(X, y)
    table = model.pareto_["f1"]
    assert (table["nesting"] == table["expression"].map(nesting)).all()
    assert table["nesting"].max() >= 1  # the search found functions; the cap refused them
    assert table.loc[table["chosen"], "nesting"].item() == 0
    assert nesting(model.expressions_["f1"]) == 0
    with pytest.raises(ValueError, match="max_nesting"):
        SymbolicCCRegressor(**settings, max_nesting=-1).fit(X, y)
