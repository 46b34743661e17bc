"""Records pushed by disturbances nobody measured: recognised, fitted by the filter, judged by it.

The records are forced oscillators released from a displacement, position
only with 1 % noise, pushed by an unmeasured random force
(``make_oscillator(disturbance=...)``); a missing effect must still be told
from the push.
"""

import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, datasets, diagnose
from sklearn_pycc.diagnostics._data import read_measurements
from sklearn_pycc.diagnostics._decide import (
    eligible_candidates,
    residual_memory,
    significant_under_push,
)
from sklearn_pycc.diagnostics._likelihood_judge import (
    LikelihoodJudgement,
    likelihood_check,
    reconsidered,
    removal_check,
    whole_record,
)
from sklearn_pycc.fitting.filter.evidence import ProcessNoiseEvidence, process_noise_evidence

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
CUBIC = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]


def _record(hidden, push, seed=0, n=3000):
    frame = datasets.make_oscillator(hidden=hidden, disturbance=push, noise=40.0,
                                     noise_columns=["x1"], n_samples=n, t_span=(0.0, n / 50),
                                     random_state=seed)
    return frame[["t", "x1", "F_ext"]]


def _fit(equations, X, **settings):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return PolyCCRegressor(equations=equations, **settings).fit(X)


def _evidence(equations, X):
    model = _fit(equations, X, fit_mode="simulation")
    return process_noise_evidence(model._problem_of(X), model._system())


@pytest.mark.parametrize("push", [0.02, 0.05])
def test_a_push_on_the_right_skeleton_is_recognised(push):
    evidence = _evidence(LINEAR, _record([], push))
    assert evidence.recognised and evidence.gain > 0.1
    assert evidence.describe().startswith("process noise recognised")


def test_a_missing_effect_is_not_taken_for_a_push():
    pushed = _evidence(LINEAR, _record(["cubic_stiffness"], 0.05))
    assert not pushed.recognised and pushed.depends_on == "x1"
    assert "the skeleton misses something" in pushed.describe()
    calm = _evidence(LINEAR, _record(["cubic_stiffness"], None))
    assert not calm.recognised and calm.depends_on == "x1"


def test_a_record_nothing_pushes_shows_no_process_noise():
    evidence = _evidence(LINEAR, _record([], None))
    assert not evidence.recognised and evidence.gain < 0.02
    assert evidence.describe().startswith("no process noise")


def test_auto_mode_goes_on_by_the_filter_where_it_recognises_a_push():
    X = _record(["cubic_stiffness"], 0.05)
    model = _fit(CUBIC, X)
    assert model.fit_mode_ == "filter" and model.process_noise_["x2"] > 0
    assert "process noise recognised" in model.derivative_source_
    assert abs(model.params_["a3"] - 1.0) < 3 * model.params_std_["a3"]
    # a skeleton that misses the spring is refined by output error as before
    wrong = _fit(LINEAR, X)
    assert wrong.fit_mode_ == "simulation"
    assert "process noise" not in wrong.derivative_source_
    # and a record nothing pushes keeps the output-error fit
    calm = _record(["cubic_stiffness"], None)
    assert _fit(CUBIC, calm).fit_mode_ == "simulation"
    # a push the user lays out goes unused there: it is said, as for fit_mode="simulation"
    with pytest.warns(UserWarning, match="process_noise was not used: fit_mode='auto' fitted "
                                         "by 'simulation', as the filter recognised no random"):
        PolyCCRegressor(equations=CUBIC, process_noise={"x2": "push"}).fit(calm)


@pytest.fixture(scope="module")
def pushed_cubic():
    X = _record(["cubic_stiffness"], 0.05, n=2000)
    return read_measurements(_fit(LINEAR, X).skeleton_, X, None)


@pytest.mark.slow  # six filter fits (two skeletons, three folds): 9 s on a quiet machine
def test_the_held_out_likelihood_confirms_a_real_effect(pushed_cubic):
    real = likelihood_check(PolyCCRegressor(equations=LINEAR), PolyCCRegressor(equations=CUBIC),
                            pushed_cubic, n_added=1, n_jobs=2)
    assert real.confirmed and real.after > real.before and real.wins == real.n_folds
    assert "confirmed" in str(real) and real.folds.startswith("3 folds")


@pytest.mark.slow
def test_the_held_out_likelihood_does_not_confirm_a_spurious_effect():
    # a linear oscillator pushed hard: a cubic spring gains a little held-out likelihood by
    # chance in every fold (two thousandths per sample), below the bar
    X = datasets.make_oscillator(hidden=[], disturbance=0.05, noise=40.0, noise_columns=["x1"],
                                 n_samples=3000, t_span=(0.0, 60.0), random_state=0)
    record = read_measurements(_fit(LINEAR, X[["t", "x1", "F_ext"]]).skeleton_,
                               X[["t", "x1", "F_ext"]], None)
    extra = likelihood_check(PolyCCRegressor(equations=LINEAR), PolyCCRegressor(equations=CUBIC),
                             record, n_added=1)
    assert not extra.confirmed and abs(extra.after - extra.before) < 0.005


def test_the_loop_says_it_judged_a_pushed_record_by_the_likelihood():
    X = _record(["cubic_stiffness"], 0.05, seed=2, n=2000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR), X).run(max_rounds=3)
    first, last = loop.rounds[0], loop.rounds[-1]
    assert first.added is not None and first.added.effect == "cubic_stiffness"
    assert last.model.fit_mode_ == "filter" and last.judge == "held-out likelihood"
    assert last.added is None and loop.refinement is None
    assert loop.model is last.model and np.isfinite(loop.model.log_likelihood(X))
    assert "[judged by held-out likelihood]" in loop.summary()
    assert list(loop.table()["judge"])[-1] == "held-out likelihood"


def test_a_residuals_memory_counts_the_samples_one_independent_sample_is_worth():
    rng = np.random.default_rng(0)
    white = rng.standard_normal(20000)
    coloured = np.empty_like(white)
    coloured[0] = white[0]
    for k in range(1, len(white)):  # AR(1) at 0.8: (1 + 0.8) / (1 - 0.8) = 9 samples
        coloured[k] = 0.8 * coloured[k - 1] + white[k]
    memory = residual_memory(np.column_stack([white, coloured]))
    assert abs(memory[0] - 1.0) < 0.3
    assert 7.5 < memory[1] < 10.5


def _candidate(removed, n_change=1, *, n=2900, delta_bic=-150.0):
    return SimpleNamespace(removed=removed, n_change=n_change, equations=[1],
                           after_squares=np.ones((n, 1)), refit=object(), plausible=True,
                           delta_bic=delta_bic, simulation_rmse=np.nan)


def test_under_a_push_an_effect_that_removes_little_is_eligible_where_that_is_significant():
    # a light asymmetric damping under a strong push removed 6.7 % of the residual, whose
    # samples were each worth one of every 14; controls' leaders ~2-4 % at memories of 12-40
    memory = np.array([1.0, 14.0])
    weak, chance = _candidate(0.067), _candidate(0.03)
    assert significant_under_push(weak, memory)
    assert not significant_under_push(chance, memory)
    assert not significant_under_push(weak, np.array([1.0, 60.0]))  # fewer independent samples
    assert not significant_under_push(_candidate(0.067, n_change=4), memory)
    # without a push the derivatives' own rule stands: a tenth of the residual
    assert eligible_candidates([weak, chance], 0.1, 10.0, np.nan) == []
    assert eligible_candidates([weak, chance], 0.1, 10.0, np.nan, memory) == [weak]
    # and the information criterion still has to be cleared
    assert eligible_candidates([_candidate(0.067, delta_bic=-5.0)], 0.1, 10.0, np.nan,
                               memory) == []


@pytest.mark.parametrize("after, confirmed", [
    ((0.0030, 0.0050, 0.0040), True),   # every fold, 0.004 per sample
    ((0.0020, 0.0030, 0.0016), False),  # every fold, but 0.0022: what chance gave a control
    ((-0.0010, 0.0080, 0.0120), True),  # most folds, 0.0063
    ((-0.0010, 0.0050, 0.0065), False),  # most folds, 0.0035: only a clean sweep may be small
])
def test_the_likelihood_judge_lets_a_clean_sweep_win_by_less(pushed_cubic, monkeypatch, after,
                                                             confirmed):
    from sklearn_pycc.diagnostics import _likelihood_judge

    base, extended = PolyCCRegressor(equations=LINEAR), PolyCCRegressor(equations=CUBIC)
    calls = {"base": 0, "extended": 0}

    def scored(model, data, held):  # per held-out sample: 0 without the effect
        key = "base" if model is base else "extended"
        calls[key] += 1
        return (0.0 if key == "base" else after[calls[key] - 1] * len(held)), 0.0

    monkeypatch.setattr(_likelihood_judge, "_held_out_likelihood", scored)
    judgement = likelihood_check(base, extended, pushed_cubic, n_added=1)
    assert judgement.confirmed is confirmed
    assert judgement.wins == sum(a > 0 for a in after) and calls == {"base": 3, "extended": 3}


@pytest.mark.parametrize("after, n_removed, confirmed", [
    ((-0.0010, -0.0020, 0.0000), 1, True),    # costs 0.001 per sample: chance
    ((-0.0040, -0.0030, -0.0020), 1, False),  # costs 0.003: more than chance gives a term
    ((-0.0040, -0.0030, -0.0020), 2, True),   # ... for one number, not for two
    ((0.0010, 0.0005, 0.0020), 1, True),      # better without it
])
def test_a_removal_from_a_pushed_model_stands_where_the_likelihood_loses_no_more_than_chance(
        pushed_cubic, monkeypatch, after, n_removed, confirmed):
    from sklearn_pycc.diagnostics import _likelihood_judge

    base, reduced = PolyCCRegressor(equations=CUBIC), PolyCCRegressor(equations=LINEAR)
    seen = []

    def scored(model, data, held):  # (held-out log-likelihood, training nll)
        if model is base:
            return 0.0, 100.0
        seen.append(len(held))
        return after[len(seen) - 1] * len(held), 100.5

    monkeypatch.setattr(_likelihood_judge, "_held_out_likelihood", scored)
    judgement = removal_check(base, reduced, pushed_cubic, n_removed=n_removed)
    assert judgement.confirmed is confirmed and judgement.removal and not judgement.failed
    assert judgement.wins == sum(a > 0 for a in after)
    assert "without them" in str(judgement)


def test_a_removal_never_rests_on_a_failed_fit_of_the_larger_model(pushed_cubic, monkeypatch):
    # on one fold the fit with the cubic term ended worse on its own samples than the fit
    # without it, which it holds: that fit failed, and its poor held-out score is no evidence
    from sklearn_pycc.diagnostics import _likelihood_judge

    base, reduced = PolyCCRegressor(equations=CUBIC), PolyCCRegressor(equations=LINEAR)
    folds = []

    def scored(model, data, held):
        if model is base:
            folds.append(len(folds))
            return (-10.0 * len(held), 180.0) if len(folds) == 2 else (0.0, 100.0)
        return -0.001 * len(held), 101.0

    monkeypatch.setattr(_likelihood_judge, "_held_out_likelihood", scored)
    judgement = removal_check(base, reduced, pushed_cubic, n_removed=1)
    assert judgement.after > judgement.before  # the failed fold alone makes it look idle
    assert judgement.failed and not judgement.confirmed
    assert "a failed fit" in str(judgement)


@pytest.mark.parametrize("nested", [True, False])
def test_an_addition_is_not_held_against_a_failed_fit_with_it(pushed_cubic, monkeypatch,
                                                              nested):
    # on one fold the fit with the cubic term ended worse on its own samples than the fit
    # without it: with the term at zero it would have done as well, so that fit failed
    from sklearn_pycc.diagnostics import _likelihood_judge

    base, extended = PolyCCRegressor(equations=LINEAR), PolyCCRegressor(equations=CUBIC)
    folds = []

    def scored(model, data, held):
        if model is base:
            return 0.0, 100.0
        folds.append(len(folds))
        return (-10.0 * len(held), 180.0) if len(folds) == 2 else (0.01 * len(held), 99.0)

    monkeypatch.setattr(_likelihood_judge, "_held_out_likelihood", scored)
    judgement = likelihood_check(base, extended, pushed_cubic, n_added=1, nested=nested)
    assert judgement.wins == 2
    # nested, the failed fold scores as the model without the term; else it sinks the effect
    assert judgement.confirmed is nested and (judgement.after > judgement.before) is nested


def _pushed_tank(n=1500, seed=0, push=0.01):
    """A draining tank, level only every 2 s, pump held in steps, its inflow pushed."""
    rng = np.random.default_rng(seed)
    pump = np.repeat(rng.uniform(0.2, 1.0, size=n // 60 + 1), 60)[:n]
    level, x, fine = np.empty(n), 1.0, 20
    dt = 2.0 / fine
    for k in range(n):
        level[k] = x
        for _ in range(fine):
            x += (0.5 * pump[k] - 0.4 * np.sqrt(max(x, 0.0))) * dt
            x = max(x + push * np.sqrt(dt) * rng.standard_normal(), 0.0)
    noisy = level + 0.01 * rng.standard_normal(n)
    return pd.DataFrame({"t": 2.0 * np.arange(n), "x1": noisy, "u": pump})


@pytest.mark.slow
def test_a_term_a_pushed_record_does_not_need_is_removed_by_the_filters_judgement():
    # Torricelli's outflow beside the linear one the user started from: the push fills the
    # derivatives, so only the filter's held-out likelihood can say the linear term is idle
    X = _pushed_tank()
    model = _fit(["x1_dot = a1 u - a2 x1 - a3 sqrt(abs(x1))"], X, input_hold="zoh",
                 quantities={"x1": "level"})
    assert model.fit_mode_ == "filter"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = diagnose(model, X, n_jobs=2)
    best = report.best
    assert best is not None and best.move == "remove" and best.effect == "linear_rate"
    assert "sqrt" not in best.term and sorted(best.equations.params) == ["a1", "a3"]
    assert best.likelihood.confirmed and best.likelihood.removal
    assert "Decided, as process noise pushes the record, by the filter" in report.summary()


@pytest.mark.parametrize("after, in_sample_p, confirmed", [
    ((0.0010, 0.0020, -0.0005), 1e-6, True),    # a little, in most folds: chance ruled out
    ((0.0010, 0.0020, -0.0005), 1e-2, False),   # ... but not where the in-sample test is weak
    ((0.0010, -0.0020, -0.0005), 1e-6, False),  # the held-out samples must agree
    ((0.0030, 0.0050, 0.0040), None, True),     # without a test, the held-out bar stands
    ((0.0020, 0.0030, 0.0016), None, False),
])
def test_an_effect_significant_in_sample_needs_only_a_held_out_win(after, in_sample_p,
                                                                   confirmed):
    folds = len(after)
    held = LikelihoodJudgement("3 folds", 0.0, sum(after) / folds,
                               sum(a > 0 for a in after), folds, not confirmed)
    judged = reconsidered(held, n_added=1, in_sample_p=in_sample_p)
    assert judged.confirmed is confirmed
    assert (judged.before, judged.after, judged.wins) == (held.before, held.after, held.wins)


@pytest.mark.parametrize("gain, white_p, depends_on, missing", [
    (4.3, 0.2, "x2", True),     # a push, and errors that follow a state
    (4.3, 1e-8, "x2", False),   # errors that last: a missing effect, no sign of a push
    (0.01, 0.2, "x2", False),   # no push needed
    (4.3, 0.2, None, False),    # a push alone
])
def test_white_errors_that_follow_a_state_read_as_a_push_and_a_missing_effect(
        gain, white_p, depends_on, missing):
    evidence = ProcessNoiseEvidence(recognised=False, gain=gain, white_p=white_p,
                                    dependence_p=1e-19 if depends_on else 0.5,
                                    depends_on=depends_on)
    assert evidence.missing_under_push is missing


def test_auto_mode_keeps_what_the_filter_saw():
    X = _record(["cubic_stiffness"], 0.05)
    wrong = _fit(LINEAR, X)
    assert wrong.fit_mode_ == "simulation"
    seen = wrong.process_noise_evidence_
    assert seen is not None and not seen.recognised and seen.depends_on == "x1"
    assert _fit(CUBIC, X).process_noise_evidence_.recognised
    # where auto did not look, nothing is kept (a refit clears it)
    assert _fit(LINEAR, X, fit_mode="simulation").process_noise_evidence_ is None


def test_the_filter_judges_every_sample_of_the_record():
    X = _record(["cubic_stiffness"], 0.05, n=1500)
    model = _fit(LINEAR, X, fit_mode="simulation")
    diagnosed = read_measurements(model.skeleton_, X, None)
    whole = whole_record(model, X)
    assert diagnosed.n_samples < len(X) == whole.n_samples
    assert np.array_equal(whole.measured["x1"], X["x1"].to_numpy())


@pytest.fixture(scope="module")
def diagnosed_pushed_drag():
    X = _record(["quadratic_drag"], 0.05, n=1500)
    model = _fit(LINEAR, X, fit_mode="simulation")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = diagnose(model, X, n_bootstrap=0, open_curves=False, held_out=False)
    return model, report


def test_the_filter_ranks_candidates_by_their_likelihood_ratio(diagnosed_pushed_drag,
                                                                monkeypatch):
    from sklearn_pycc.diagnostics import _filter_search

    model, report = diagnosed_pushed_drag
    gains = {"quadratic_drag": 30.0, "cubic_stiffness": 12.0}
    asked = []

    def nll(estimator, data):  # the skeleton alone at 0; each effect lowers it by its gain
        text = str(estimator.get_params()["equations"])
        return -max((g for name, g in gains.items() if _TERMS[name] in text), default=0.0)

    def judged(base, extended, data, *, n_added, n_jobs=None, in_sample_p=None, nested=False):
        asked.append((str(extended.get_params()["equations"]), in_sample_p))
        return LikelihoodJudgement("3 folds", 1.0, 1.01, 2, 3, True)

    monkeypatch.setattr(_filter_search, "_in_sample_nll", nll)
    monkeypatch.setattr(_filter_search, "likelihood_check", judged)
    tried = _filter_search._tried(report.candidates)
    assert 2 <= len(tried) <= _filter_search.N_TRIED
    chosen, notes = _filter_search.likelihood_ratio_search(model, report.candidates,
                                                           report.record)
    assert chosen is not None and chosen.effect.name == "quadratic_drag"
    assert chosen.likelihood.confirmed and len(asked) == 1
    # the p-value counts every candidate tried
    assert asked[0][1] == pytest.approx(len(tried) * chi2.sf(60.0, 1))
    assert "gains 30 in the filter's log-likelihood" in notes[0]
    assert "gains 30" in chosen.likelihood.in_sample


def test_the_filter_names_nothing_that_chance_could_have_gained(diagnosed_pushed_drag,
                                                                monkeypatch):
    from sklearn_pycc.diagnostics import _filter_search

    model, report = diagnosed_pushed_drag
    monkeypatch.setattr(_filter_search, "_in_sample_nll",
                        lambda estimator, data: -2.3 * ("x2*abs(x2)" in str(
                            estimator.get_params()["equations"])))
    monkeypatch.setattr(_filter_search, "likelihood_check", None)  # never reached
    chosen, notes = _filter_search.likelihood_ratio_search(model, report.candidates,
                                                           report.record)
    assert chosen is None and "significant" in notes[0] and "quadratic_drag" in notes[0]


_TERMS = {"quadratic_drag": "x2*abs(x2)", "cubic_stiffness": "x1^3"}


@pytest.mark.slow
def test_the_loop_names_an_effect_the_push_hid_from_the_derivatives():
    # a pushed oscillator whose damping falls away from the centre, at 40 dB: the derivatives
    # and simulations are swamped and the output-error round finds nothing; the filter's
    # errors are white but follow a state, and its likelihood ratio names the damping
    X = datasets.make_oscillator(hidden={"falling_damping": None}, disturbance=0.05,
                                 noise=40.0, noise_columns=["x1"], n_samples=3000,
                                 t_span=(0.0, 60.0), random_state=1)[["t", "x1", "F_ext"]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = HypothesisLoop(PolyCCRegressor(equations=LINEAR), X).run(max_rounds=3)
    first = loop.rounds[0]
    assert first.model.fit_mode_ == "simulation"
    assert first.model.process_noise_evidence_.missing_under_push
    assert first.added is not None and first.added.effect == "falling_damping"
    assert first.judge == "held-out likelihood" and first.likelihood.confirmed
    assert first.likelihood.in_sample is not None
    summary = first.diagnosis.summary()
    assert "Ranked first by the filter's likelihood" in summary and "nan" not in summary
