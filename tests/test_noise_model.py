"""Output-error fits with a model of coloured measurement noise (``noise_model``)."""

import numpy as np
import pytest
from scipy import signal
from sklearn.utils._param_validation import InvalidParameterError

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.fitting.output_error.noise_model import fit_noise_model, whitening_matrix

CUBIC = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]
TRUTH = {"a1": 0.1, "a2": 1.0, "a3": 1.0}


def _record(pole, seed=0, snr=40.0):
    clean = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=3000,
                                     t_span=(0, 60), random_state=seed)
    noisy = datasets.add_sensor_noise(clean[["t", "x1", "F_ext"]], ["x1"], snr=snr, pole=pole,
                                      bits=12, random_state=seed)
    return noisy, float(np.std(noisy["x1"] - clean["x1"]))


@pytest.mark.parametrize("kind", ["ar", "arma", "auto"])
def test_the_noise_model_is_read_from_the_fits_errors(kind):
    X, level = _record(0.9)
    model = PolyCCRegressor(equations=CUBIC, fit_mode="simulation", noise_model=kind).fit(X)
    noise = model.noise_model_["x1"]
    assert noise.poles[0] == pytest.approx(0.9, abs=0.05)
    assert noise.level == pytest.approx(level, rel=0.2)
    assert "AR(1)" in model.noise_model_.describe()
    for name, value in TRUTH.items():
        assert model.params_[name] == pytest.approx(value, rel=0.01), name
        # the whitened whole-record errors give the parameters' standard errors
        assert 0 < model.params_std_[name] < 0.01
        assert abs(model.params_[name] - value) < 4 * model.params_std_[name], name


@pytest.mark.slow
def test_whitening_brings_the_fit_closer_on_coloured_noise():
    # the prediction-error fit weighs the record by what its samples really tell
    errors = {None: [], "ar": []}
    for seed in range(3):
        X, _ = _record(0.95, seed=seed, snr=35.0)
        for kind in errors:
            model = PolyCCRegressor(equations=CUBIC, fit_mode="simulation",
                                    noise_model=kind).fit(X)
            errors[kind].append(abs(model.params_["a2"] - 1.0))
    assert np.mean(errors["ar"]) < np.mean(errors[None])


def test_auto_keeps_white_noise_white_and_polishes_the_fit_on_the_whole_record():
    clean = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=3000,
                                     t_span=(0, 60), noise=40, noise_columns=["x1"],
                                     random_state=0)
    X = clean[["t", "x1", "F_ext"]]
    plain = PolyCCRegressor(equations=CUBIC, fit_mode="simulation").fit(X)
    auto = PolyCCRegressor(equations=CUBIC, fit_mode="simulation", noise_model="auto").fit(X)
    assert auto.noise_model_.white
    assert plain.noise_model_ is None
    assert auto.params_ == pytest.approx(plain.params_, rel=1e-2)
    # no refit by whitened windows, but the whole-record polish gives standard errors
    assert np.isnan(plain.params_std_["a2"]) and 0 < auto.params_std_["a2"] < 0.01


def test_an_equation_fit_has_no_noise_model():
    X = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=600)
    with pytest.warns(UserWarning, match="noise_model='ar' was not used.*equation error"):
        model = PolyCCRegressor(equations=CUBIC, fit_mode="equation", noise_model="ar").fit(X)
    assert model.noise_model_ is None


def test_a_wrong_noise_model_is_named():
    X = datasets.make_oscillator(n_samples=200)
    with pytest.raises(InvalidParameterError, match="noise_model"):
        PolyCCRegressor(equations=CUBIC, noise_model="pink").fit(X)


def test_the_whitening_filter_whitens_and_never_crosses_experiments():
    rng = np.random.default_rng(0)
    runs = [signal.lfilter([1.0], [1.0, -0.8], rng.normal(size=n)) for n in (4000, 3000)]
    model = fit_noise_model({"x": runs}, "ar")["x"]
    assert model.ar == pytest.approx((0.8,), abs=0.03)
    run_of_row = np.repeat([0, 1], [4000, 3000])
    W = whitening_matrix([model.taps()], run_of_row)
    white = W @ np.concatenate(runs)
    assert abs(np.corrcoef(white[1:4000], white[:3999])[0, 1]) < 0.05
    assert white[4000] == runs[1][0]  # the second run starts afresh
    # two signals, row-major: each is filtered by its own taps
    W2 = whitening_matrix([np.array([1.0, -0.5]), np.array([1.0])], np.zeros(3, dtype=int))
    assert W2.toarray()[2, 0] == -0.5 and W2.toarray()[3, 1] == 0.0


def test_arma_noise_is_read_with_its_moving_average():
    rng = np.random.default_rng(1)
    e = signal.lfilter([1.0, 0.5], [1.0, -0.7], rng.normal(size=20000))
    model = fit_noise_model({"x": [e]}, "arma")["x"]
    assert model.ar[0] == pytest.approx(0.7, abs=0.05)
    assert model.ma[0] == pytest.approx(0.5, abs=0.07)
    assert model.innovation == pytest.approx(1.0, rel=0.05)


@pytest.mark.slow
def test_intervals_of_a_noise_model_fit_cover_the_truth():
    # 50 records with AR(1) noise of pole 0.9 at 40 dB, 12 bits: 95 % intervals of the
    # three parameters hold the truth 85-99 % of the time
    hits = []
    for seed in range(50):
        X, _ = _record(0.9, seed=100 + seed)
        model = PolyCCRegressor(equations=CUBIC, fit_mode="simulation",
                                noise_model="ar").fit(X)
        interval = model.params_interval(0.95)
        hits += [interval[a][0] <= v <= interval[a][1] for a, v in TRUTH.items()]
    assert 0.85 <= np.mean(hits) <= 0.99
