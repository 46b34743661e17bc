"""Every skeleton kind through every entry point, with every constraint kind and backend.

Each cell works (finite results, nothing the user gave modified) or refuses
with a documented error that names the culprit; see ``skeleton_matrix.py``.
The fast suite runs a slice that visits every kind, constraint kind, entry
point and backend; the slow suite draws thousands of further combinations,
several constraints at once, with ``hypothesis``.
"""

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from skeleton_matrix import (
    BACKENDS,
    CONSTRAINT_KINDS,
    ENTRY_POINTS,
    HEAVY,
    KINDS,
    combined_constraints,
    constraint_for,
    run_cell,
    run_cells,
)

from sklearn_pycc import (
    InterpolatedCCRegressor,
    NeuralCCRegressor,
    PolyCCRegressor,
    SymbolicCCRegressor,
    datasets,
    diagnose,
)
from sklearn_pycc.diagnostics import Diagnosis
from sklearn_pycc.estimators.least_squares import LeastSquaresCCRegressor

LIGHT = tuple(e for e in ENTRY_POINTS if e not in HEAVY)


def _rotated(kind_names, offset=0):
    """Each kind with one constraint kind, turning through them so that every one is met."""
    out = []
    for i, name in enumerate(kind_names):
        for k in range(len(CONSTRAINT_KINDS)):
            constraint = CONSTRAINT_KINDS[(i + offset + k) % len(CONSTRAINT_KINDS)]
            if constraint_for(KINDS[name], constraint) is not None:
                out.append((name, constraint))
                break
    return out


OUTPUT_ERROR = {name for name, kind in KINDS.items() if kind.output_error}
# (kind, constraint kind, backend, entry points): one fit per row
FAST_SLICE = [
    # every kind fitted by equation error, on Poly, every light entry point; the
    # constraint kind turns with the kind so that every one is met
    *[(name, constraint, "poly", LIGHT)
      for name, constraint in _rotated([k for k in KINDS if k not in OUTPUT_ERROR], offset=1)],
    # the refitting entry points where curves carry a constraint (the regression of
    # 'KeyError: f1': a constrained curve's role met the open curve), on quick kinds
    ("functional", "odd", "poly", ("diagnose", "loop_round")),
    ("hybrid", "odd", "poly", ("diagnose",)),          # 'f2 odd' on a1 x2 + f2(x1)
    ("position_only", "odd", "poly", ("diagnose",)),
    ("relation", "even", "poly", ("diagnose",)),
    ("static_output", "point", "poly", ("loop_round",)),
    ("implicit", "decreasing", "poly", ("compare_skeletons",)),
    ("shared_multiarg", "increasing", "poly", ("to_symbolic",)),
    ("curve_denominator", "limits", "poly", ("diagnose",)),
    # fitted by output error: a few entry points each
    ("unmeasured_state", "bounds", "poly", ("simulate", "pickle")),
    # the other backends
    ("functional", "odd", "least_squares", ("diagnose", *LIGHT)),
    ("hybrid", "bounds", "least_squares", LIGHT),
    ("static_output", "increasing", "least_squares", ("fit",)),  # refused: names f1
    ("functional", "odd", "neural", ("loop_round", "fit", "predict", "simulate", "pickle",
                                      "clone", "to_interpolated")),
    ("relation", "bounds", "neural", ("fit", "simulate", "score")),
]


def _check(name, constraint, backend, entries, constraints=None):
    kind = KINDS[name]
    given = constraints if constraints is not None else constraint_for(kind, constraint)
    outcomes = run_cells(kind, given, backend, entries)
    defects = {e: o.detail for e, o in outcomes.items() if o.verdict == "defect"}
    assert not defects, f"{name} with {given} on {backend}: {defects}"
    return outcomes


@pytest.mark.parametrize(("name", "constraint", "backend", "entries"), FAST_SLICE,
                         ids=[f"{c[0]}-{c[1]}-{c[2]}" + ("-light" if c[3] == LIGHT else
                                                         "-" + "-".join(c[3]))
                              for c in FAST_SLICE])
def test_every_kind_of_skeleton_works_or_names_the_culprit(name, constraint, backend,
                                                             entries):
    _check(name, constraint, backend, entries)


def test_the_slice_visits_every_kind_constraint_entry_point_and_backend():
    # a limit fitted on a measured state takes half a minute by output error: slow suite
    assert {cell[0] for cell in FAST_SLICE} == set(KINDS) - {"fitted_limit"}
    assert {cell[1] for cell in FAST_SLICE} == set(CONSTRAINT_KINDS)
    assert {cell[2] for cell in FAST_SLICE} == set(BACKENDS)
    assert {e for cell in FAST_SLICE for e in cell[3]} == set(ENTRY_POINTS)


def test_where_cells_work_the_matrix_is_not_only_refusals():
    # a matrix that only ever refuses would pass: the main kinds must really work
    for name in ("functional", "parametric", "hybrid", "implicit", "static_output",
                 "relation", "shared_multiarg"):
        outcome = _check(name, "none", "poly", ("simulate",))["simulate"]
        assert outcome.verdict == "works", (name, outcome.detail)


def test_a_cell_that_breaks_is_reported_as_a_defect(monkeypatch):
    # the harness itself: a KeyError from deep inside is a defect, never a refusal
    import skeleton_matrix

    def broken(*args, **kwargs):
        raise KeyError("f1")

    monkeypatch.setattr(skeleton_matrix, "diagnose", broken)
    outcome = run_cell(KINDS["functional"], [], "poly", "diagnose")
    assert outcome.verdict == "defect" and "KeyError" in outcome.detail


README_EQUATIONS = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
README_BACKENDS = {
    "poly": lambda: PolyCCRegressor(degree=3),
    "least_squares": lambda: LeastSquaresCCRegressor(degree=3),
    "interpolated": lambda: InterpolatedCCRegressor(estimator=PolyCCRegressor(degree=3)),
    # a diagnosis refits each candidate with the backend: these take 10-50 s
    "neural": pytest.param(lambda: NeuralCCRegressor(hidden_layer_sizes=(8,), max_epochs=20,
                                                     random_state=0),
                           marks=pytest.mark.slow),
    "symbolic": pytest.param(lambda: SymbolicCCRegressor(population_size=100, generations=10,
                                                         maxsize=10, random_state=0),
                             marks=pytest.mark.slow),
}


@pytest.mark.parametrize("measured", [["t", "x1", "x2", "F_ext"], ["t", "x1", "F_ext"]],
                         ids=["both", "position"])
@pytest.mark.parametrize("backend", list(README_BACKENDS.values()),
                         ids=list(README_BACKENDS))
def test_the_readme_model_with_its_constraints_is_diagnosed(measured, backend):
    # the regression: 'KeyError: f1' where a constrained curve's role met the open curve
    frame = datasets.make_duffing(n_samples=400, t_span=(0, 40))
    X = frame[measured]
    model = backend().set_params(equations=README_EQUATIONS,
                                 constraints=["f1 odd", "f2 odd"]).fit(X)
    report = diagnose(model, X, n_bootstrap=10)
    assert isinstance(report, Diagnosis)
    assert report.best is None  # the skeleton is the truth
    assert "free_damping_curve" in report.summary()  # the open curves were tried


# -- the slow suite: many more combinations ---------------------------------------------
CONSTRAINT_DRAWS = st.lists(
    st.tuples(st.sampled_from([c for c in CONSTRAINT_KINDS if c != "none"]),
              st.integers(0, 4)),
    min_size=0, max_size=3)


# thousands in the slow suite; PYCC_MATRIX_EXAMPLES=50 for a quick look
MATRIX_EXAMPLES = int(os.environ.get("PYCC_MATRIX_EXAMPLES", "1500"))


@pytest.mark.slow
@settings(max_examples=MATRIX_EXAMPLES, deadline=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(name=st.sampled_from(sorted(KINDS)), drawn=CONSTRAINT_DRAWS,
       backend=st.sampled_from(BACKENDS),
       entries=st.lists(st.sampled_from(ENTRY_POINTS), min_size=1, max_size=3, unique=True))
def test_drawn_combinations_work_or_name_the_culprit(name, drawn, backend, entries):
    kind = KINDS[name]
    _check(name, None, backend, entries, constraints=combined_constraints(kind, drawn))
