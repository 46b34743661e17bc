"""What a newcomer reads first says plainly what happened."""

import pydoc
import warnings

import pytest

import sklearn_pycc
from sklearn_pycc import PolyCCRegressor, datasets, diagnose


@pytest.fixture(scope="module")
def pendulum_report():
    frame = datasets.make_pendulum(random_state=0)[["t", "x1"]]
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = - a1 x2 - a2 x1"]).fit(frame)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnose(model, frame, n_bootstrap=0), len(frame)


def test_the_first_line_says_which_samples_were_left_out(pendulum_report):
    report, n_given = pendulum_report
    assert report.left_out > 0
    assert report.left_out + len(report.residuals) == n_given
    first = report.summary().splitlines()[0]
    assert f"against {len(report.residuals)} samples" in first
    assert f"({report.left_out} more at the ends of the experiments left out" in first


def test_a_kinematic_identity_is_not_reported_as_a_perfect_fit(pendulum_report):
    report, _ = pendulum_report
    text = report.summary()
    assert "x1_dot: holds by construction (x2 was reconstructed as the derivative of x1)" \
        in text
    assert "x1_dot: R2 1.0000" not in text


def test_the_suggested_term_is_printed_as_it_acts():
    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    model = PolyCCRegressor(equations=truth.base_equations).fit(X)
    report = diagnose(model, X, n_bootstrap=0)
    value = report.best.param_init["a3"]
    sign = "-" if value > 0 else "+"
    assert f"acts as '{sign} {abs(value):.4g}*x1^3' in x2_dot" in report.summary()


def test_help_points_to_the_loop():
    text = pydoc.render_doc(sklearn_pycc, renderer=pydoc.plaintext)
    head = text[:3000]
    assert "HypothesisLoop" in head and "loop.summary()" in head and "diagnose" in head


@pytest.mark.slow
def test_later_rounds_say_whose_horizon_they_keep_and_runners_up_are_compared():
    from sklearn_pycc import HypothesisLoop

    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], return_truth=True)
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations),
                          frame[["t", "x1", "F_ext"]], n_bootstrap=0).run(max_rounds=2,
                                                                          refine=False)
    first, second = (r.diagnosis.horizon for r in loop.rounds)
    assert second.time == first.time and second.why == f"round 0's: {first.why}"
    assert "as given" not in loop.rounds[1].diagnosis.summary()
    best = loop.rounds[0].diagnosis.best
    summary = loop.rounds[0].diagnosis.summary()
    assert f"Runners-up (the winner scores {-best.delta_bic:.1f})" in summary
    # each runner-up is told from the others: what it acts through, and whether it replaces
    line = next(text for text in summary.splitlines() if "Runners-up" in text)
    named = [part.split(" (score")[0] for part in line.split("): ", 1)[1].split("; ")]
    assert len(set(named)) == len(named) and all(" through " in n for n in named)


def test_a_verbose_fit_says_its_stages_and_a_quiet_one_nothing(capsys):
    frame = datasets.make_oscillator(hidden=[], disturbance=0.08, noise=40.0,
                                     noise_columns=["x1"],
                                     n_samples=600, random_state=0)[["t", "x1", "F_ext"]]
    equations = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        PolyCCRegressor(equations=equations, fit_mode="filter").fit(frame)
        assert capsys.readouterr().out == ""
        PolyCCRegressor(equations=equations, fit_mode="filter", verbose=1).fit(frame)
    said = capsys.readouterr()
    stages = [line.split(" [")[0] for line in said.out.splitlines()]
    assert stages == ["PolyCCRegressor.fit: reading the record",
                      "PolyCCRegressor.fit: fitting by output error (600 samples)",
                      "PolyCCRegressor.fit: refining by the Kalman filter's likelihood",
                      "PolyCCRegressor.fit: fitted by the Kalman filter's likelihood"]
    assert "filter" in said.err and "pass" in said.err  # the search's bar


def test_a_verbose_loop_says_each_rounds_stages(capsys):
    from sklearn_pycc import HypothesisLoop

    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=800,
                                            return_truth=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), frame,
                       verbose=1).run(max_rounds=2, refine=False)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("HypothesisLoop round 0: fitting 800 samples")
    assert any(line.startswith("HypothesisLoop round 0: diagnosing") for line in lines)
    assert any("round 0: cubic_stiffness" in line or "round 0: cubic spring" in line
               for line in lines), lines
    assert any(line.startswith("HypothesisLoop round 1:") for line in lines)
