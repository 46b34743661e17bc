"""Free curves before "nothing is missing": an effect outside the catalogue is found and named."""

import pickle

import numpy as np
import pandas as pd
import pytest
import sympy
from scipy.integrate import solve_ivp

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, diagnose
from sklearn_pycc.backends.poly.basis import PolyBasis, PolyCurve
from sklearn_pycc.diagnostics._open_curves import formula_text, open_candidates
from sklearn_pycc.diagnostics._roles import equation_roles
from sklearn_pycc.skeleton import Skeleton

BASE = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
TRUE = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 sin(a4 x1)"]


def _cogging(x):
    """A spring with a detent: linear plus a ripple of three cycles per radian."""
    return 2.0 * x + 0.6 * np.sin(3.0 * x)


def _record(seed: int, *, y0=(1.5, 0.0), freqs=(0.5, 0.9, 1.7), snr=40.0):
    rng = np.random.default_rng(seed)
    phases = rng.uniform(0.0, 2 * np.pi, len(freqs))

    def force(t):
        return 1.25 * sum(np.sin(w * t + p) for w, p in zip(freqs, phases))

    t = np.linspace(0.0, 60.0, 3000)
    solution = solve_ivp(lambda s, y: [y[1], force(s) - 0.3 * y[1] - _cogging(y[0])],
                         (0.0, 60.0), y0, t_eval=t, rtol=1e-10, atol=1e-10)
    x = solution.y[0]
    noise = np.std(x) * 10 ** (-snr / 20)
    return pd.DataFrame({"t": t, "x1": x + rng.normal(0.0, noise, t.size), "F_ext": force(t)})


@pytest.fixture(scope="module")
def cogging_report():
    frame = _record(0)
    model = PolyCCRegressor(equations=BASE).fit(frame)
    return frame, diagnose(model, frame, n_bootstrap=0)


# -- pieces ---------------------------------------------------------------------------
def test_formula_text_turns_numbers_into_parameters():
    x = sympy.Symbol("x")
    text, values = formula_text(2.0 * x + 0.6 * sympy.sin(3.0 * x), x, "x1")
    assert sorted(values) == [0.6, 2.0, 3.0]
    names = {f"a{k + 1}": v for k, v in enumerate(values)}
    node = Skeleton([f"x1_dot = {text}"])
    assert set(node.params) == set(names)
    # the text evaluates to the expression at the found values
    expression = sympy.sympify(text.replace("^", "**"), locals={"x1": x})
    at = expression.subs({sympy.Symbol(k): v for k, v in names.items()})
    assert float(at.subs(x, 0.7)) == pytest.approx(2.0 * 0.7 + 0.6 * np.sin(2.1))


def test_formula_text_keeps_exponents_and_reads_division():
    x = sympy.Symbol("x")
    text, values = formula_text(1.5 * x / (1 + 0.25 * x**2) + sympy.Abs(x), x, "x2")
    assert "^2" in text and "abs(x2)" in text and "/" in text
    assert sorted(values) == [0.25, 1.5]


def test_open_candidates_take_each_role():
    skeleton = Skeleton(BASE)
    found = {c.effect.name: c for c in open_candidates(skeleton, equation_roles(skeleton))}
    assert set(found) == {"free_restoring_curve", "free_friction_curve", "free_damping_curve"}
    assert found["free_restoring_curve"].replaces == ("a2*x1",)
    assert found["free_friction_curve"].replaces == ("a1*x2",)
    # g(x) v takes the viscous term's place too
    assert found["free_damping_curve"].replaces == ("a1*x2",)
    # a role a free curve already plays is not opened again
    curved = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - f1(x1)"])
    names = {c.effect.name for c in open_candidates(curved, equation_roles(curved))}
    assert "free_restoring_curve" not in names


def test_linear_extrapolation_continues_the_edge():
    basis = PolyBasis(-1.0, 1.0, 5, None, "legendre")
    coefficients = np.array([0.1, 1.0, 0.0, 0.4, 0.0, -0.3])
    wild, tame = basis.curve(coefficients), basis.curve(coefficients, "linear")
    inside = np.linspace(-1.0, 1.0, 21)
    np.testing.assert_allclose(tame(inside), wild(inside))
    outside = np.array([1.5, 2.0, 3.0])
    steps = np.diff(tame(outside)) / np.diff(outside)
    assert steps[0] == pytest.approx(steps[1])  # a straight line
    assert tame(3.0) == pytest.approx(tame(np.array([3.0]))[0])  # floats as arrays
    again = pickle.loads(pickle.dumps(tame))
    assert again.extrapolation == "linear" and again(2.5) == pytest.approx(tame(2.5))
    with pytest.raises(ValueError, match="extrapolation"):
        PolyCurve(np.ones(2), 0.0, 1.0, (-1.0, 1.0), "cubic")


@pytest.mark.slow
def test_poly_extrapolation_parameter(cogging_report):
    frame, _ = cogging_report
    skeleton = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - f1(x1)"]
    model = PolyCCRegressor(equations=skeleton, extrapolation="linear",
                            fit_mode="equation").fit(frame)
    plain = PolyCCRegressor(equations=skeleton, fit_mode="equation").fit(frame)
    lo, hi = model.curve_ranges_["f1"]
    inside = np.linspace(lo, hi, 50)
    np.testing.assert_allclose(model.functions_["f1"](inside), plain.functions_["f1"](inside))
    far = np.array([hi + (hi - lo)])
    assert abs(model.functions_["f1"](far)[0]) < abs(plain.functions_["f1"](far)[0])
    with pytest.raises(ValueError, match="extrapolation"):
        PolyCCRegressor(equations=skeleton, extrapolation="cubic").fit(frame)


# -- the diagnosis ----------------------------------------------------------------------
@pytest.mark.slow
def test_a_spring_outside_the_catalogue_is_not_called_complete(cogging_report):
    _, report = cogging_report
    best = report.best
    assert best is not None and best.move == "open"
    assert best.effect == "free_restoring_curve" and best.replaces == ("a2*x1",)
    assert best.held_out.confirmed
    assert "Outside the catalogue" in report.summary()
    # the free curve follows the true spring within 5 % of its range, inside the data
    curve = best.curve
    x = curve["x1"].to_numpy()
    core = (x > np.quantile(x, 0.05)) & (x < np.quantile(x, 0.95))
    truth = _cogging(x[core])
    error = np.abs(curve["curve"].to_numpy()[core] - truth)
    assert error.max() < 0.05 * np.ptp(truth)
    assert (curve["lower"] <= curve["curve"]).all() and (curve["curve"] <= curve["upper"]).all()
    # the proposed formula holds a sine of the position, and is what the suggestion fits
    assert best.formula is not None and "sin(" in best.formula
    assert best.term == best.formula and best.formula_held_out.confirmed
    assert "sin(" in best.equations.equations[1] and "a2" not in best.equations.params
    figures = report.plot()
    assert "open_curve" in figures
    # every free curve tried is on record, the confirmed one with its formula
    tried = {p.role: p for p in report.open_curves}
    assert set(tried) == {"free_restoring_curve", "free_friction_curve", "free_damping_curve"}
    chosen = tried["free_restoring_curve"]
    assert chosen.confirmed and chosen.formula == best.formula and chosen.curve is best.curve
    assert not any(p.confirmed for p in report.open_curves if p is not chosen)


@pytest.mark.slow
def test_the_loop_finds_the_formula_and_simulates_a_fresh_record_as_the_truth_does():
    frame = _record(0)
    loop = HypothesisLoop(PolyCCRegressor(equations=BASE), frame, n_bootstrap=0).run(
        max_rounds=4)
    first = loop.rounds[0]
    assert first.added.move == "open" and "outside the catalogue" in first.decision
    # the next round's curves continue beyond their data as the diagnosis judged them
    assert loop.rounds[1].model.extrapolation == "linear"
    assert loop.stopped
    truth = PolyCCRegressor(equations=TRUE, param_init={"a3": 0.5, "a4": 2.5}).fit(frame)
    fresh = _record(7, y0=(-1.0, 0.5), freqs=(0.6, 1.1, 1.9))
    t = fresh["t"].to_numpy()

    def error(model):
        simulated = model.simulate(t, [-1.0, 0.5], inputs={"F_ext": fresh["F_ext"].to_numpy()})
        return float(np.sqrt(np.mean((simulated["x1"].to_numpy() - fresh["x1"]) ** 2)))

    assert error(loop.model) < 2.0 * error(truth)


def test_a_free_curve_the_whole_record_does_not_favour_spares_the_held_out_folds(monkeypatch):
    # a model fitted by output error: each free curve is first fitted to the whole
    # record, and only one that lowers its output error by OPEN_GAIN (as much as the folds
    # ask of it, more than an effect's WHOLE_RECORD_GAIN) is held out
    import importlib
    from types import SimpleNamespace

    decide = importlib.import_module("sklearn_pycc.diagnostics._decide")
    model = SimpleNamespace(fit_mode_="simulation")
    flat, slight, better = (SimpleNamespace(refit=name, note="", held_out=None,
                                            whole_record=None)
                            for name in ("flat", "slight", "better"))
    # the whole record's output error of each fit: the model's, then the curves'
    errors = {"flat": 0.0996, "slight": 0.097, "better": 0.08}
    monkeypatch.setattr(decide, "whole_record_error", lambda m, record, cache=None:
                        errors[m] if isinstance(m, str) else 0.1)
    held = []

    def held_out_check(base, extended, *args, **kwargs):
        held.append(extended)
        return SimpleNamespace(confirmed=True)

    monkeypatch.setattr(decide, "held_out_check", held_out_check)
    chosen = decide.decide_open([flat, better], model, None, None, [1], steps=100, held_out=True,
                                 record=pd.DataFrame())
    assert chosen is better and held == ["better"]
    assert "not confirmed by the whole record" in flat.note and "-0.4 %" in flat.note
    # 3 % would do for an effect of the catalogue, not for a free curve
    held.clear()
    assert decide.decide_open([slight], model, None, None, [1], steps=100, held_out=True,
                               record=pd.DataFrame()) is None and held == []
    assert "-3.0 %" in slight.note
    # asked again (a rival's check), it is not fitted again nor said twice
    assert decide._short_of_whole_record(flat, model, pd.DataFrame(), {})
    assert flat.note.count("not confirmed by the whole record") == 1
    # fitted by equation error, the folds alone judge
    held.clear()
    model.fit_mode_ = "equation"
    assert decide.decide_open([flat, better], model, None, None, [1], steps=100, held_out=True,
                               record=pd.DataFrame()) is flat and held == ["flat"]
