"""Output-error fitting by multiple shooting (fit_mode="simulation")."""

import numpy as np
import pytest
from sklearn.base import clone

from sklearn_pycc import PolyCCRegressor, datasets

SECOND_ORDER = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]


def curve_rmse(model, truth, name):
    frame = model.cc_curves()[name]
    return float(np.sqrt(np.mean((frame[name] - truth.functions[name](frame["x"])) ** 2)))


@pytest.mark.parametrize("snr, bound", [(40, 1.3e-2), (30, 2.5e-2)])
def test_duffing_position_only_output_error_beats_the_floor(snr, bound):
    frame, truth = datasets.make_duffing(noise=snr, noise_columns=["x1"], random_state=0,
                                         return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    equation = PolyCCRegressor(equations=SECOND_ORDER, degree=7, fit_mode="equation").fit(X)
    output = PolyCCRegressor(equations=SECOND_ORDER, degree=7, fit_mode="simulation").fit(X)
    assert curve_rmse(output, truth, "f2") <= bound
    assert curve_rmse(output, truth, "f2") < curve_rmse(equation, truth, "f2")
    info = output.shooting_
    assert info["nrmse_after"] < info["nrmse_before"]
    assert info["max_defect"] < 0.05
    assert info["segments"] == 50 and info["diverged"] == 0
    # the gauge pin f2(0)=0 still holds exactly
    assert abs(output.functions_["f2"](np.array([0.0]))[0]) < 1e-10


def test_the_jacobians_bumps_side_by_side_fit_as_one_at_a_time(monkeypatch):
    # the Jacobian's bumped simulations run in one pass of stacked systems; the fit is
    # the one a simulation per bump gives (curves and a scalar, few and many windows)
    from sklearn_pycc.fitting.output_error import shooting as _shooting

    frame = datasets.make_duffing(n_samples=600, noise=40, noise_columns=["x1"], random_state=1)
    X = frame[["t", "x1", "F_ext"]]
    skeleton = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - f1(x1)"]
    for window in (40, 600):
        settings = {"equations": skeleton, "fit_mode": "simulation", "shooting_window": window,
                    "shooting_iterations": 8}
        stacked = PolyCCRegressor(**settings).fit(X)
        with monkeypatch.context() as patch:
            patch.setattr(_shooting, "_side_by_side", lambda *args: None)
            alone = PolyCCRegressor(**settings).fit(X)
        assert stacked.shooting_["nrmse_after"] < stacked.shooting_["nrmse_before"]
        assert stacked.params_["a1"] == pytest.approx(alone.params_["a1"], rel=1e-6)
        np.testing.assert_allclose(stacked.coefficients_["f1"], alone.coefficients_["f1"],
                                   rtol=1e-6, atol=1e-9)


def test_a_refit_in_equation_mode_forgets_the_output_error_stage():
    frame = datasets.make_duffing(n_samples=400, noise=40, noise_columns=["x1"], random_state=0)
    X = frame[["t", "x1", "F_ext"]]
    model = PolyCCRegressor(equations=SECOND_ORDER, fit_mode="simulation",
                            shooting_iterations=2).fit(X)
    assert model.fit_mode_ == "simulation" and "segments" in model.shooting_
    model.set_params(fit_mode="equation").fit(X)
    assert model.fit_mode_ == "equation" and not hasattr(model, "shooting_")


@pytest.mark.slow
def test_output_error_on_several_experiments_with_parametric_skeleton():
    settings = [{"amplitude": 1.2, "omega": 1.0}, {"amplitude": 1.8, "omega": 0.8}]
    frame, truths = datasets.make_experiments(
        datasets.make_stick_slip, settings, n_samples=500, t_span=(0, 15), noise=35,
        noise_columns=["x1"], random_state=2, return_truth=True)
    X = frame[["t", "trajectory", "x1", "F_ext"]]
    skeleton = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1 - a5 x1^3"]
    model = PolyCCRegressor(equations=skeleton, fit_mode="simulation").fit(X)
    truth = truths[0].params
    for name in ("a2", "a4", "a5"):
        assert model.params_[name] == pytest.approx(truth[name], rel=0.1), name
    # no segment crosses from one experiment into the next
    assert model.shooting_["segments"] >= 2 * (500 // 40) - 2


def test_measured_velocity_is_used_when_given():
    frame, truth = datasets.make_duffing(n_samples=1000, t_span=(0, 50), noise=35,
                                         random_state=3, return_truth=True)
    X = frame[["t", "x1", "x2", "F_ext"]]
    model = PolyCCRegressor(equations=SECOND_ORDER, degree=5, fit_mode="simulation").fit(X)
    assert model.measured_states_ == ["x1", "x2"]
    assert curve_rmse(model, truth, "f2") < 0.03


@pytest.mark.parametrize("params, message", [
    ({"fit_mode": "trajectory"}, "fit_mode must be one of"),
    ({"fit_mode": "simulation", "shooting_window": 1}, "shooting_window must be an integer"),
    ({"fit_mode": "simulation", "shooting_iterations": 0}, "shooting_iterations must be"),
])
def test_bad_shooting_settings_are_named(params, message):
    frame = datasets.make_duffing(n_samples=200, t_span=(0, 10))
    name = list(params)[-1]
    with pytest.raises(ValueError, match=f"{message}|The '{name}' parameter of PolyCC"):
        PolyCCRegressor(equations=SECOND_ORDER, degree=3, **params).fit(frame[["t", "x1",
                                                                              "F_ext"]])


def test_auto_mode_refines_noisy_positions_by_output_error():
    frame = datasets.make_duffing(noise=30, noise_columns=["x1"], random_state=0)
    noisy = PolyCCRegressor(equations=SECOND_ORDER, degree=5).fit(frame[["t", "x1", "F_ext"]])
    assert noisy.fit_mode_ == "simulation" and noisy.shooting_["segments"] == 50
    assert "refined by output error (fit_mode='auto'" in noisy.derivative_source_
    clean = datasets.make_duffing(noise=60, noise_columns=["x1"], random_state=0)
    model = PolyCCRegressor(equations=SECOND_ORDER, degree=5).fit(clean[["t", "x1", "F_ext"]])
    assert model.fit_mode_ == "equation" and "refined" not in model.derivative_source_
    # measured derivatives, or a method that reads no noise level: the equation fit
    measured = PolyCCRegressor(equations=SECOND_ORDER, degree=5).fit(
        frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]])
    assert measured.fit_mode_ == "equation"
    spline = PolyCCRegressor(equations=SECOND_ORDER, degree=5, differentiation="spline")
    assert spline.fit(frame[["t", "x1", "F_ext"]]).fit_mode_ == "equation"


def test_simulation_mode_needs_time():
    frame = datasets.make_duffing(n_samples=200, t_span=(0, 10))
    with pytest.raises(ValueError, match="fit_mode='simulation' needs the time column 't'"):
        PolyCCRegressor(equations=SECOND_ORDER, degree=3, fit_mode="simulation").fit(
            frame[["x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]])


@pytest.mark.slow
def test_neural_output_error_refines_the_networks():
    from sklearn_pycc import NeuralCCRegressor

    frame, truth = datasets.make_duffing(n_samples=400, t_span=(0, 20), noise=40,
                                         noise_columns=["x1"], random_state=0,
                                         return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    settings = dict(equations=SECOND_ORDER, constraints=["f1 odd"], hidden_layer_sizes=(8,),
                    max_epochs=60, random_state=0)
    equation = NeuralCCRegressor(**settings, fit_mode="equation").fit(X)
    output = NeuralCCRegressor(**settings, fit_mode="simulation", shooting_window=20,
                               shooting_iterations=15).fit(X)
    info = output.shooting_
    assert info["nrmse_after"] < info["nrmse_before"]
    assert not info["reverted"] and info["diverged"] == 0
    assert curve_rmse(output, truth, "f2") < curve_rmse(equation, truth, "f2")
    sim = output.simulate(X["t"].to_numpy()[:100], [X["x1"].iloc[0], 0.0],
                          {"F_ext": X["F_ext"].to_numpy()[:100]})
    assert np.isfinite(sim[["x1", "x2"]].to_numpy()).all()


@pytest.mark.slow
def test_neural_stick_slip_position_only_at_30_db():
    """The friction curve from noisy positions alone, within 0.1 (published floor 0.3)."""
    from sklearn_pycc import NeuralCCRegressor

    frame, truth = datasets.make_stick_slip(noise=30, noise_columns=["x1"], random_state=0,
                                            return_truth=True)
    X = frame[["t", "x1", "F_ext"]]
    model = NeuralCCRegressor(equations=SECOND_ORDER, constraints=["f1 odd"],
                              fit_mode="simulation", random_state=0).fit(X)
    assert curve_rmse(model, truth, "f1") <= 0.1
    assert curve_rmse(model, truth, "f2") <= 0.1
    # the equation-error start is short; the shooting stage does the fitting
    assert model.n_epochs_ == 10
    info = model.shooting_
    assert info["nrmse_after"] < info["nrmse_before"] and not info["reverted"]


def test_neural_shooting_start_epochs_is_checked():
    from sklearn_pycc import NeuralCCRegressor

    frame = datasets.make_duffing(n_samples=200, t_span=(0, 10))
    model = NeuralCCRegressor(equations=SECOND_ORDER, fit_mode="simulation",
                              shooting_start_epochs=0)
    with pytest.raises(ValueError, match="'shooting_start_epochs' parameter of NeuralCC.* int "
                                         r"in the range \[1, inf\)"):
        model.fit(frame[["t", "x1", "F_ext"]])


@pytest.mark.slow
def test_neural_stick_slip_position_only_across_noise_draws():
    from sklearn_pycc import NeuralCCRegressor

    errors = []
    for seed in range(5):
        frame, truth = datasets.make_stick_slip(noise=30, noise_columns=["x1"],
                                                random_state=seed, return_truth=True)
        model = NeuralCCRegressor(equations=SECOND_ORDER, constraints=["f1 odd"],
                                  fit_mode="simulation", random_state=0)
        model.fit(frame[["t", "x1", "F_ext"]])
        errors.append(curve_rmse(model, truth, "f1"))
    assert max(errors) <= 0.1, errors


def test_neural_simulation_mode_needs_solved_equations():
    from sklearn_pycc import NeuralCCRegressor

    frame = datasets.make_duffing(n_samples=200, t_span=(0, 10))
    model = NeuralCCRegressor(equations=["x1_dot = x2", "F_ext = x2_dot + f1(x2) + f2(x1)"],
                              hidden_layer_sizes=(4,), max_epochs=5, fit_mode="simulation")
    with pytest.raises(ValueError, match="implicit or reads another derivative"):
        model.fit(frame[["t", "x1", "F_ext"]])


def test_a_fit_knows_the_record_and_settings_it_saw():
    # a refit on the same record with the same settings would repeat the estimate: the
    # diagnosis then reads the model's own output error instead of fitting it again
    from sklearn_pycc.diagnostics._decide import whole_record_error
    from sklearn_pycc.fitting.fingerprint import fitted_on
    from sklearn_pycc.measurements import Measurement

    frame = datasets.make_duffing(n_samples=400, noise=40, noise_columns=["x1"], random_state=0)
    X = frame[["t", "x1", "F_ext"]].copy()
    model = PolyCCRegressor(equations=SECOND_ORDER, fit_mode="simulation",
                            shooting_iterations=3).fit(X)
    assert fitted_on(model, X) and fitted_on(model, X.copy()) and fitted_on(model, Measurement(X))
    assert whole_record_error(model, X) == model.shooting_["nrmse_after"]
    # the mode it was chosen by and the refits on resamples do not change the estimate
    assert fitted_on(model.set_params(fit_mode="auto", n_bootstrap=5), X)
    assert not fitted_on(model, X.iloc[:-1])
    assert not fitted_on(model.set_params(shooting_window=20), X)
    assert not fitted_on(clone(model), X)  # unfitted
    model.set_params(shooting_window=40)
    changed = X.copy()
    changed.loc[7, "x1"] += 1e-9
    assert not fitted_on(model, changed)
    # a model that is not the fit of the record is fitted again
    assert whole_record_error(model, changed) == pytest.approx(model.shooting_["nrmse_after"],
                                                          rel=1e-3)
