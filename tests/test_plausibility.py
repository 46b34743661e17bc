"""Whole-model plausibility: every fitted term against the physical role the skeleton gives it."""

import copy

import pytest

from sklearn_pycc import PolyCCRegressor, datasets, diagnose
from sklearn_pycc.diagnostics._data import read_measurements
from sklearn_pycc.diagnostics._physics import implausible_terms

FRICTION = ["x1_dot = x2", "x2_dot = a5 F_ext - a1 x2 - a2 x1 - a3 tanh(a4 x2)"]
SPRINGS = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]


@pytest.fixture(scope="module")
def record():
    frame = datasets.make_oscillator(hidden=["coulomb_friction"], random_state=0)
    return frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]


def judged(model, X, y, **params):
    """The model's implausible terms with some fitted values replaced."""
    changed = copy.deepcopy(model)
    changed.params_ = {**model.params_, **params}
    data = read_measurements(changed.skeleton_, X, y)
    return implausible_terms(changed, data)


@pytest.fixture(scope="module")
def friction_model(record):
    return PolyCCRegressor(equations=FRICTION, param_init={"a4": 5.0}).fit(*record)


def test_the_fitted_physical_model_is_plausible(record, friction_model):
    assert judged(friction_model, *record) == []


def test_negative_damping_held_up_by_dry_friction_is_named(record, friction_model):
    coulomb = friction_model.params_["a3"]
    found = judged(friction_model, *record, a1=-0.3, a3=3 * coulomb)
    assert [f.role for f in found] == ["dissipation"]
    assert "feeds energy in" in found[0].reason and "x2" in found[0].reason
    assert found[0].equation == "x2_dot"
    # both friction terms feeding energy in: each is named, and the sum too
    found = judged(friction_model, *record, a1=-0.3, a3=-coulomb)
    assert [f.role for f in found] == ["dissipation"] * 3


def test_a_tiny_negative_viscous_term_beside_dry_friction_is_tolerated(record, friction_model):
    assert judged(friction_model, *record, a1=-1e-4) == []


def test_a_gain_must_keep_the_sign_it_is_written_with(record, friction_model):
    found = judged(friction_model, *record, a5=-1.0)
    assert [f.role for f in found] == ["gain"]
    assert "F_ext" in found[0].reason


def test_springs_are_judged_together(record):
    model = PolyCCRegressor(equations=SPRINGS).fit(*record)
    # a softening cubic beside the linear spring is physical (a pendulum)
    assert judged(model, *record, a2=1.0, a3=-0.05) == []
    found = judged(model, *record, a2=-1.0, a3=0.0)
    assert [f.role for f in found] == ["stiffness"]
    assert "push away" in found[0].reason


def test_an_implicit_mass_must_stay_positive(record):
    implicit = ["x1_dot = x2", "a1 x2_dot = F_ext - a2 x2 - a3 x1"]
    model = PolyCCRegressor(equations=implicit).fit(*record)
    assert judged(model, *record) == []
    found = judged(model, *record, a1=-model.params_["a1"])
    assert found[0].role == "inertia"


def test_the_summary_flags_an_implausible_starting_model(record):
    X, y = record
    pumped = ["x1_dot = x2", "x2_dot = F_ext + 0.3 x2 - a1 x2 - a2 x1"]
    model = PolyCCRegressor(equations=pumped).fit(X, y)
    report = diagnose(model, X, y, n_refit=2)
    assert report.implausible and report.implausible[0].role == "dissipation"
    assert "IMPLAUSIBLE: x2_dot: the friction term '+ 0.3*x2' feeds energy in" \
        in report.summary()


def test_a_refit_that_breaks_another_term_is_rejected_in_words(record):
    from sklearn_pycc.diagnostics._candidates import _judge, enumerate_candidates, extend
    from sklearn_pycc.diagnostics._roles import equation_roles

    X, y = record
    base = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"])
    base.fit(X, y)
    skeleton = base.skeleton_
    candidate = next(c for c in enumerate_candidates(skeleton, equation_roles(skeleton), True)
                     if c.effect.name == "coulomb_friction")
    extend(skeleton, candidate)
    refit = PolyCCRegressor(equations=candidate.extended).fit(X, y)
    data = read_measurements(refit.skeleton_, X, y)
    _judge(candidate, refit, data)
    assert candidate.plausible
    # the same refit with the viscous term feeding energy in, held up by the dry friction
    broken = copy.deepcopy(refit)
    broken.params_ = {**refit.params_, "a1": -0.3, "a3": 3 * refit.params_["a3"]}
    _judge(candidate, broken, data)
    assert not candidate.plausible
    assert "the refitted model is implausible: x2_dot: the friction term '- a1*x2' " \
        "(a1 = -0.3) feeds energy in" in candidate.note
    # unless the model itself already fed energy in there
    _judge(candidate, broken, data, frozenset({("x2_dot", "dissipation")}))
    assert candidate.plausible


def test_a_role_the_model_breaks_by_design_does_not_block_suggestions(record):
    X, y = record
    # energy fed in on purpose (a self-excited oscillator): the summary says so, and the
    # missing dry friction is still named
    pumped = ["x1_dot = x2", "x2_dot = F_ext + 0.05 x2 - a1 x2 - a2 x1"]
    report = diagnose(PolyCCRegressor(equations=pumped).fit(X, y), X, y, n_refit=3)
    assert report.implausible and "IMPLAUSIBLE" in report.summary()
    assert report.best is not None and report.best.effect == "coulomb_friction"
    candidate = next(c for c in report.candidates if c.effect.name == "coulomb_friction")
    assert "the refitted model is implausible" not in candidate.note
