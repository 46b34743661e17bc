"""Records as a laboratory hands them over: one measurement path, derivatives chosen from data."""

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, compare_skeletons, datasets, diagnose
from sklearn_pycc._utils.bandlimited import central_derivative, even_grid
from sklearn_pycc.measurements import resolve_differentiation
from sklearn_pycc.measurements.spectral import find_quantum
from sklearn_pycc.model_selection import make_simulation_scorer

AXIS = ["x1_dot = x2", "x2_dot = a1 F - a2 x2"]


def relative(estimate, truth):
    return abs(estimate / truth - 1)


@pytest.fixture(scope="module")
def axis():
    return datasets.make_positioning_axis(random_state=1, return_truth=True)


# -- a state on no right-hand side ---------------------------------------------------
@pytest.mark.slow
def test_a_state_no_right_hand_side_reads_is_read_everywhere(axis):
    frame, truth = axis
    X = frame.iloc[:5000]
    model = PolyCCRegressor(equations=AXIS).fit(X)
    assert model.measured_states_ == ["x1"]
    report = diagnose(model, X)
    assert np.isfinite(report.simulation_rmse)
    table = compare_skeletons({"viscous": AXIS}, X, estimator=PolyCCRegressor())
    assert np.isfinite(table.loc["viscous", "derivative_rmse"])
    assert np.isfinite(make_simulation_scorer()(model, X))
    simulated = PolyCCRegressor(equations=AXIS, fit_mode="simulation",
                                shooting_iterations=5).fit(X)
    assert simulated.shooting_["segments"] > 1
    # with y given, x1 (read by no right-hand side) is still read, and judged
    measured = X.assign(x2=truth.velocity[:5000])
    y = pd.DataFrame({"x1_dot": truth.velocity[:5000], "x2_dot": truth.acceleration[:5000]})
    fitted = PolyCCRegressor(equations=AXIS).fit(measured, y)
    assert fitted.measured_states_ == ["x1", "x2"]
    assert np.isfinite(diagnose(fitted, measured, y).simulation_rmse)
    table = compare_skeletons({"viscous": AXIS}, measured, y, estimator=PolyCCRegressor())
    assert np.isfinite(table.loc["viscous", "simulation_rmse"])


# -- derivatives chosen from the record ---------------------------------------------
@pytest.mark.slow
def test_auto_recovers_a_fast_clean_resonator():
    frame, truth = datasets.make_resonator(random_state=0, return_truth=True)
    model = PolyCCRegressor(equations=truth.equations).fit(frame)
    for name in ("a1", "a2", "a3"):
        assert relative(model.params_[name], truth.params[name]) < 0.01, name
    assert "616 Hz sampling" in model.derivative_source_
    # the smoothing spline, the former default, smooths the oscillation away
    spline = PolyCCRegressor(equations=truth.equations, differentiation="spline").fit(
        frame.iloc[:4000])
    assert relative(spline.params_["a3"], truth.params["a3"]) > 0.5


@pytest.mark.slow
@pytest.mark.parametrize("noise, drop", [(30.0, 0.0), (60.0, 0.02), (30.0, 0.02)])
def test_auto_recovers_the_resonator_with_noise_and_dropped_samples(noise, drop):
    frame, truth = datasets.make_resonator(noise=noise, drop_fraction=drop, random_state=0,
                                           return_truth=True)
    model = PolyCCRegressor(equations=truth.equations).fit(frame)
    for name in ("a1", "a2", "a3"):
        assert relative(model.params_[name], truth.params[name]) < 0.05, name
    if drop:
        assert "dropped samples filled" in model.derivative_source_


def _larger_resonator(truth, amplitude, noise):
    """A held-out record of the same resonator (same cubic coefficient), driven harder."""
    def make(hardening):
        return datasets.make_resonator(n_samples=3000, amplitude=amplitude, noise=noise,
                                       hardening=hardening, random_state=5, return_truth=True)

    probe = make(0.05)[1]
    return make(0.05 * truth.params["a4"] / probe.params["a4"])


@pytest.mark.parametrize("noise, drop", [
    (60.0, 0.0), pytest.param(30.0, 0.02, marks=pytest.mark.slow)])
def test_output_error_cubic_simulates_a_larger_held_out_record(noise, drop):
    frame, truth = datasets.make_resonator(n_samples=4000, noise=noise, drop_fraction=drop,
                                           random_state=0, return_truth=True)
    held, held_truth = _larger_resonator(truth, 1.5, noise)
    assert held_truth.params["a4"] == pytest.approx(truth.params["a4"])
    t, u = held["t"].to_numpy(), held["u"].to_numpy()
    y0 = held_truth.states.iloc[0].to_numpy()
    errors = {}
    for name, equations in (("linear", truth.base_equations), ("cubic", truth.equations)):
        model = PolyCCRegressor(equations=equations, fit_mode="simulation").fit(frame)
        simulated = model.simulate(t, y0, {"u": u})["x1"].to_numpy()
        errors[name] = np.sqrt(np.mean((simulated - held_truth.states["x1"]) ** 2))
        if name == "cubic":
            for param in ("a1", "a2", "a3"):
                assert relative(model.params_[param], truth.params[param]) < 0.01, param
    assert errors["cubic"] < errors["linear"] / 5


@pytest.mark.slow
@pytest.mark.parametrize("noise, drop", [(None, 0.0), (None, 0.02), (30.0, 0.0)])
def test_auto_reads_an_encoder_in_closed_loop(axis, noise, drop):
    frame, truth = axis
    if noise is not None:
        frame, truth = datasets.make_positioning_axis(random_state=1, noise=noise,
                                                      return_truth=True)
    if drop:
        rng = np.random.default_rng(0)
        gone = rng.choice(np.arange(1, len(frame) - 1), round(drop * len(frame)), replace=False)
        frame = frame.drop(index=gone).reset_index(drop=True)
    model = PolyCCRegressor(equations=truth.equations).fit(frame)
    mass = 1 / model.params_["a1"]
    viscous = model.params_["a2"] * mass
    coulomb = model.params_["a3"] * mass
    physical = truth.physical
    assert relative(mass, physical["mass"]) < 0.02
    assert relative(viscous, physical["viscous"]) < 0.02
    assert relative(coulomb, physical["coulomb"]) < 0.05
    source = model.derivative_source_
    # the controller switched on: the filter's settling at the ends is left out
    assert "samples at the ends of the experiments left out" in source
    assert "the inputs F filtered alike" in source
    if noise is None:
        assert "quantised in steps of 2e-05" in source and model.fit_mode_ == "equation"
    else:  # derivatives of such positions bias the equation fit: output error refines it
        assert model.fit_mode_ == "simulation" and "refined by output error" in source
    if drop:
        assert "dropped samples filled" in source


def test_auto_beats_the_spline_on_noisy_positions():
    frame = datasets.make_duffing(noise=40, noise_columns=["x1"], random_state=0)
    t, x = frame["t"].to_numpy(), frame["x1"].to_numpy()
    errors = {}
    for method in ("auto", "spline"):
        chosen = resolve_differentiation(method).for_experiment(t, {"x1": x}, 2)
        _, _, acceleration = chosen.derivatives(t, x, 2)
        truth = frame["x2_dot"].to_numpy()
        errors[method] = np.sqrt(np.mean((acceleration - truth) ** 2) / np.mean(truth**2))
    assert errors["auto"] < 0.8 * errors["spline"]


def test_band_limited_derivative_is_exact_near_nyquist():
    t = np.arange(400) * 0.1
    omega = 0.6 * np.pi / 0.1  # 0.6 of the Nyquist frequency
    d = central_derivative(np.sin(omega * t), 0.1)
    assert np.max(np.abs(d[20:-20] - omega * np.cos(omega * t[20:-20]))) < 1e-3 * omega


def test_grids_with_dropped_and_irregular_samples():
    t = np.arange(100) * 0.5
    kept = np.delete(t, [10, 11, 50])
    grid = even_grid(kept)
    assert grid.dropped == 3 and not grid.resampled
    irregular = np.cumsum(np.random.default_rng(0).uniform(0.5, 1.5, 100))
    assert even_grid(irregular).resampled
    x = np.sin(0.2 * irregular)
    method = resolve_differentiation("auto")
    _, d1 = method.for_experiment(irregular, {"x": x}, 1).derivatives(irregular, x, 1)
    inner = slice(10, -10)
    assert np.max(np.abs(d1[inner] - 0.2 * np.cos(0.2 * irregular[inner]))) < 2e-3


def test_quantum_is_found_only_on_a_lattice():
    x = np.round(np.sin(np.linspace(0, 20, 2000)) / 1e-3) * 1e-3
    assert find_quantum(x).step == pytest.approx(1e-3, rel=1e-6)
    assert find_quantum(np.sin(np.linspace(0, 20, 2000))) is None


def test_lowpass_options_and_errors_are_named():
    with pytest.raises(ValueError, match="lowpass cutoff must be a positive frequency"):
        resolve_differentiation({"method": "lowpass", "cutoff": -1})
    frame = datasets.make_duffing(n_samples=300, t_span=(0, 15))
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                            degree=3, differentiation={"method": "lowpass", "cutoff": 1.0})
    model.fit(frame[["t", "x1", "F_ext"]])
    assert "low-pass at 1 Hz" in model.derivative_source_


def test_a_failing_method_names_the_experiment_and_the_setting():
    frame = datasets.make_experiments(datasets.make_duffing, 2, n_samples=200, t_span=(0, 10))
    frame.loc[frame.trajectory == 1, "t"] += 100.0
    X = frame[["t", "trajectory", "x1", "F_ext"]]

    def broken(x, t):
        if t[0] > 0.0:  # only the second experiment's grid starts late
            raise np.linalg.LinAlgError("singular matrix")
        return np.gradient(x, t)

    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
                            degree=3, differentiation=broken)
    message = r"the callable broken failed on 'x1' in experiment 1: singular matrix"
    with pytest.raises(ValueError, match=message):
        model.fit(X)


# -- sampled inputs -----------------------------------------------------------------
def _integrator():
    from sklearn_pycc import Skeleton

    return Skeleton(["x1_dot = a1 u"])


def test_input_hold_zero_and_first_order_integrate_exactly():
    t = np.linspace(0.0, 2.0, 41)
    u = np.sin(3 * t) + (t > 1)
    skeleton = _integrator()
    h = t[1] - t[0]
    zoh = skeleton.simulate(t, [0.0], params={"a1": 1.0}, inputs={"u": u}, input_hold="zoh")
    foh = skeleton.simulate(t, [0.0], params={"a1": 1.0}, inputs={"u": u}, input_hold="foh")
    assert np.allclose(zoh["x1"], np.r_[0, np.cumsum(u[:-1] * h)], atol=1e-9)
    assert np.allclose(foh["x1"], np.r_[0, np.cumsum((u[:-1] + u[1:]) / 2 * h)], atol=1e-9)
    with pytest.raises(ValueError, match=r"input_hold must be one of .bandlimited., .foh"):
        skeleton.simulate(t, [0.0], params={"a1": 1.0}, inputs={"u": u}, input_hold="hold")


def test_bandlimited_input_follows_a_fast_record():
    # a multisine up to 0.15 of the sampling rate (6.7 samples per period of its top line)
    t = np.arange(2000) * 0.01
    omegas = 2 * np.pi * np.array([3.0, 7.0, 11.0, 15.0])

    def u(time):
        return sum(np.sin(w * time + k) for k, w in enumerate(omegas))

    def integral(time):
        return sum((np.cos(k) - np.cos(w * time + k)) / w for k, w in enumerate(omegas))

    skeleton = _integrator()
    errors = {}
    for hold in ("bandlimited", "foh"):
        sim = skeleton.simulate(t, [0.0], params={"a1": 1.0}, inputs={"u": u(t)},
                                input_hold=hold, rtol=1e-9, atol=1e-12)
        errors[hold] = np.max(np.abs(sim["x1"] - integral(t))[100:-100])
    assert errors["bandlimited"] < 2e-3 * np.ptp(integral(t))
    assert errors["bandlimited"] < 0.2 * errors["foh"]
    # the default reads an array input as band-limited
    default = skeleton.simulate(t, [0.0], params={"a1": 1.0}, inputs={"u": u(t)},
                                rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(default["x1"] - integral(t))[100:-100]) == pytest.approx(
        errors["bandlimited"])


def test_sampled_inputs_agree_with_lsoda_and_take_few_steps():
    from sklearn_pycc.simulation.integration import InputSignals, integrate_sampled

    frame, truth = datasets.make_resonator(n_samples=3000, noise=None, random_state=0,
                                           return_truth=True)
    from sklearn_pycc import Skeleton

    skeleton = Skeleton(truth.equations)
    t, u = frame["t"].to_numpy(), frame["u"].to_numpy()
    ours = skeleton.simulate(t, [0, 0], params=truth.params, inputs={"u": u})
    scipy = skeleton.simulate(t, [0, 0], params=truth.params, inputs={"u": u},
                              method="LSODA", rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(ours["x1"] - scipy["x1"])) < 1e-4 * np.ptp(scipy["x1"])
    # a slow model driven by a long sampled record: about one step per sample
    slow = Skeleton(["x1_dot = u - x1"]).compile({}, {})
    t = np.linspace(0, 100, 20_000)
    signals = InputSignals(["u"], {"u": np.sin(0.3 * t)}, t)
    calls = []
    rhs = slow.make_rhs(signals.at, list_states=True)

    def counted(time, state):
        calls.append(time)
        return rhs(time, state)

    integrate_sampled(counted, t, np.zeros(1), ["x1"], signals)
    assert len(calls) <= 7 * len(t)


def test_stiff_friction_with_sampled_inputs_is_finished_implicitly(monkeypatch):
    from sklearn_pycc import Skeleton
    from sklearn_pycc.simulation import integration as simulation

    implicit = []
    original = simulation._stiff_interval

    def counted(*args, **kwargs):
        implicit.append(args[1])
        return original(*args, **kwargs)

    monkeypatch.setattr(simulation, "_stiff_interval", counted)

    frame = datasets.make_stick_slip()
    skeleton = Skeleton(["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 tanh(a3 x2) - a4 x1"])
    params = {"a1": 0.1, "a2": 0.5, "a3": 1e4, "a4": 1.0}
    t, force = frame["t"].to_numpy(), frame["F_ext"].to_numpy()
    ours = skeleton.simulate(t, [0, 0], params=params, inputs={"F_ext": force})
    scipy = skeleton.simulate(t, [0, 0], params=params, inputs={"F_ext": force},
                              method="LSODA", rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(ours["x1"] - scipy["x1"])) < 1e-3 * np.ptp(scipy["x1"])
    assert 0 < len(implicit) < 0.1 * len(t)  # only the sticking stretches


def test_sampled_divergence_and_progress(capsys):
    from sklearn_pycc import SimulationError, Skeleton

    t = np.linspace(0, 10, 2001)
    skeleton = Skeleton(["x1_dot = x1^2 + u"])
    with pytest.raises(SimulationError) as caught:
        skeleton.simulate(t, [1.0], inputs={"u": np.zeros_like(t)})
    assert 0.9 < caught.value.t_reached < 1.0
    assert len(caught.value.partial) > 100
    model = PolyCCRegressor(equations=["x1_dot = a1 u - a2 x1"]).fit(
        pd.DataFrame({"x1": np.sin(t), "u": np.sin(t) + np.cos(t)}),
        pd.DataFrame({"x1_dot": np.cos(t)}))
    model.simulate(t, [0.0], inputs={"u": np.sin(t)}, verbose=True)
    assert "sample" in capsys.readouterr().err
