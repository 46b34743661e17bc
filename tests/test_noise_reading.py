"""The noise of a record read as a process: level, colour, quantisation (Measurement.noise)."""

import matplotlib
import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import PolyCCRegressor, datasets
from sklearn_pycc.measurements import Measurement
from sklearn_pycc.measurements.noise import read_noise, slow_memory
from sklearn_pycc.measurements.spectral import find_quantum

matplotlib.use("Agg")

LINEAR = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1 - a3 x1^3"]


def _record(pole, snr=40.0, seed=0, n=6000, bits=12):
    clean = datasets.make_oscillator(hidden=["cubic_stiffness"], n_samples=n, t_span=(0, 60),
                                     random_state=seed)
    noisy = datasets.add_sensor_noise(clean[["t", "x1", "F_ext"]], ["x1"], snr=snr, pole=pole,
                                      bits=bits, random_state=seed)
    return clean, noisy


@pytest.mark.parametrize("pole", [0.0, 0.8, 0.9])
@pytest.mark.parametrize("seed", [0, 1])
def test_the_noise_level_and_colour_are_read_from_the_record(pole, seed):
    clean, noisy = _record(pole, seed=seed)
    x = noisy["x1"].to_numpy()
    truth = float(np.std(x - clean["x1"].to_numpy()))
    reading = read_noise(x, 60 / 5999, name="x1", quantum=find_quantum(x))
    assert reading.level == pytest.approx(truth, rel=0.2)
    if pole == 0:
        assert not reading.coloured and reading.poles == ()
    else:
        assert reading.coloured and reading.poles[0] == pytest.approx(pole, abs=0.05)
        # about -1 / ln(pole) samples
        assert 0.3 < reading.correlation_time / (-1 / np.log(pole) * 0.01) < 3
    assert reading.quantum == pytest.approx(np.ptp(clean["x1"]) / 4096, rel=0.05)
    assert reading.snr_db == pytest.approx(40.0, abs=3.0)


@pytest.mark.parametrize("ar, innovation, white", [((0.9,), 0.3, 1.0), ((1.2, -0.5), 0.5, 0.2),
                                                     ((0.6,), 1.0, 0.0), ((), 0.0, 0.7)])
def test_the_reading_is_also_one_arma_process_with_the_same_spectrum(ar, innovation, white):
    from sklearn_pycc.measurements.noise import SignalNoise

    noise = SignalNoise("x1", level=1.0, ar=ar, innovation=innovation, white=white, step=0.01)
    phi, theta, sigma = noise.arma
    assert phi == ar and len(theta) == (len(ar) if white and ar else 0)
    assert np.all(np.abs(np.roots([1.0, *theta])) < 1)  # invertible: the innovations exist
    z = np.exp(-2j * np.pi * np.linspace(0, 50, 101) * 0.01)
    numerator = np.abs(np.polyval([*theta[::-1], 1.0], z)) ** 2
    denominator = np.abs(np.polyval([*(-np.asarray(phi))[::-1], 1.0], z)) ** 2
    np.testing.assert_allclose(2 * 0.01 * sigma**2 * numerator / denominator,
                               noise.density(np.linspace(0, 50, 101)), rtol=1e-10)


def test_a_signal_read_again_gives_the_same_reading_under_its_own_name():
    _, noisy = _record(0.9, n=2000)
    x = noisy["x1"].to_numpy().copy()
    kept = x.copy()
    first = read_noise(x, 0.03, name="x1")
    again = read_noise(x.copy(), 0.03, name="position")
    assert again.name == "position" and first.name == "x1"
    assert (again.level, again.ar, again.band) == (first.level, first.ar, first.band)
    np.testing.assert_array_equal(x, kept)
    # the spectrum kept with a reading cannot be changed under another's feet
    with pytest.raises(ValueError):
        again.spectrum[1][0] = 0.0
    # one changed sample or another step is another signal
    x[100] += 1.0
    assert read_noise(x, 0.03).level != first.level
    assert read_noise(kept, 0.06).band != first.band


def test_a_noise_free_record_reads_no_noise():
    frame = datasets.make_oscillator(hidden=[], n_samples=3000, t_span=(0, 60))
    reading = Measurement(frame[["t", "x1", "x2", "F_ext"]]).noise
    assert set(reading) == {"x1", "x2", "F_ext"}
    # what the integrator and the tapers leave is far below any sensor's noise
    assert all(noise.level == 0 or noise.snr_db > 70 for noise in reading.values())
    assert reading["x1"].level == 0 and reading["F_ext"].level == 0
    assert "x1: no noise" in reading.summary()


def test_auto_differentiation_cuts_below_coloured_noise_not_at_its_top():
    # read from the spectrum's top, AR(1) noise looked small and its rise like signal:
    # the cutoff stayed at 25 Hz and the derivatives were noise
    _, noisy = _record(0.9)
    model = PolyCCRegressor(equations=LINEAR).fit(noisy)
    source = model.derivative_source_
    cutoff = float(source.split("low-pass at ")[1].split(" Hz")[0])
    assert cutoff < 3.0, source
    assert "coloured: AR(1)" in source
    assert model.fit_mode_ == "simulation"  # 40 dB: refined by output error
    truth = {"a1": 0.1, "a2": 1.0, "a3": 1.0}
    for name, value in truth.items():
        assert model.params_[name] == pytest.approx(value, rel=0.1, abs=0.02), name


def test_white_noise_is_differentiated_as_before():
    _, noisy = _record(0.0)
    source = PolyCCRegressor(equations=LINEAR).fit(noisy).derivative_source_
    assert "coloured" not in source and "x1: noise" in source


def test_the_reading_is_kept_summarised_tabled_and_drawn():
    _, noisy = _record(0.9, n=3000)
    record = Measurement(noisy, units={"x1": "m"})
    reading = record.noise
    assert record.noise is reading  # kept like the derivatives
    assert list(reading) == ["x1", "F_ext"]
    assert reading["F_ext"].level == 0
    table = reading.to_frame()
    assert table.loc["x1", "ar_order"] >= 1 and table.loc["x1", "level"] > 0
    assert reading.summary().startswith("x1: noise")
    figure = reading.plot()
    assert len(figure.axes) == 1  # the noise-free input is not drawn
    labels = [line.get_label() for line in figure.axes[0].get_lines()]
    assert any(label.startswith("noise model (AR(") for label in labels)
    assert any(label.startswith("signal band ends") for label in labels)
    assert any(label.startswith("rounding of steps") for label in labels)
    with pytest.raises(KeyError, match=r"'x9'.*'x1'"):
        reading["x9"]


def test_the_noise_needs_the_time_column():
    frame = datasets.make_oscillator(n_samples=200).drop(columns="t")
    with pytest.raises(ValueError, match="time column 't'"):
        _ = Measurement(frame).noise


def test_sensor_noise_has_the_level_colour_and_steps_asked_for():
    frame = datasets.make_oscillator(hidden=[], n_samples=20000, t_span=(0, 200))
    before = frame.copy()
    noisy = datasets.add_sensor_noise(frame, ["x1"], snr=30.0, pole=0.9, bits=10,
                                      random_state=3)
    pd.testing.assert_frame_equal(frame, before)  # the user's frame is left alone
    assert (noisy["x2"] == frame["x2"]).all()
    error = (noisy["x1"] - frame["x1"]).to_numpy()
    rms = np.sqrt(np.mean(frame["x1"] ** 2))
    assert np.std(error) == pytest.approx(rms / 10**1.5, rel=0.15)
    assert np.corrcoef(error[:-1], error[1:])[0, 1] == pytest.approx(0.9, abs=0.05)
    steps = np.diff(np.unique(noisy["x1"]))
    assert steps.min() == pytest.approx(np.ptp(frame["x1"]) / 2**10, rel=1e-6)
    drifting = datasets.add_sensor_noise(frame, ["x1"], snr=60.0, drift=0.05, random_state=3)
    wander = (drifting["x1"] - frame["x1"]).to_numpy()
    assert np.std(wander) == pytest.approx(0.05 * rms, rel=0.2)


@pytest.mark.parametrize("bad, match", [
    ({"pole": 1.0}, "pole must be in"), ({"bits": 1}, "bits must be"),
    ({"drift": -1.0}, "drift must be"), ({"snr": np.inf}, "snr must be"),
    ({"columns": ["t"]}, "'t'"), ({"columns": ["x7"]}, "'x7'")])
def test_sensor_noise_names_what_is_wrong(bad, match):
    frame = datasets.make_oscillator(n_samples=100)
    with pytest.raises(ValueError, match=match):
        datasets.add_sensor_noise(frame, **{"columns": ["x1"], **bad})


def test_a_missing_sample_stays_missing_and_the_others_get_their_noise():
    frame = datasets.make_oscillator(hidden=[], n_samples=2000, t_span=(0, 100))
    gappy = frame.assign(x1=frame["x1"].mask(frame.index % 97 == 5))
    noisy = datasets.add_sensor_noise(gappy, ["x1"], snr=30.0, pole=0.9, bits=10,
                                      random_state=3)
    missing = gappy["x1"].isna().to_numpy()
    assert missing.sum() == 21 and np.array_equal(noisy["x1"].isna().to_numpy(), missing)
    error = (noisy["x1"] - frame["x1"]).to_numpy()[~missing]
    rms = np.sqrt(np.mean(frame["x1"] ** 2))
    assert np.std(error) == pytest.approx(rms / 10**1.5, rel=0.25)
    for column, culprit in (([np.nan] * 100, "no number"), ([np.inf] + [0.0] * 99, "infinite")):
        with pytest.raises(ValueError, match=f"'x1' holds .*{culprit}"):
            datasets.add_sensor_noise(frame.iloc[:100].assign(x1=column), ["x1"])


def test_nothing_missing_says_what_the_record_could_have_shown():
    from sklearn_pycc import diagnose

    limits = {}
    for pole in (0.0, 0.9):
        _, X = _record(pole, n=3000)
        report = diagnose(PolyCCRegressor(equations=LINEAR).fit(X), X, n_bootstrap=0,
                          open_curves=False, held_out=False)
        assert report.best is None
        limits[pole] = report.detection_limit["x1"]
        line = next(line for line in report.summary().splitlines() if "Detection limit" in line)
        assert f"{limits[pole]:.3g}" in line
    noise = 0.01 * np.sqrt(np.mean(_record(0.0, n=3000)[0]["x1"] ** 2))
    assert 0 < limits[0.0] < 0.2 * noise
    # coloured noise is worth fewer independent samples: the same record is blinder
    assert limits[0.9] > 3 * limits[0.0]


def test_a_found_effect_has_no_detection_limit():
    from sklearn_pycc import diagnose

    _, X = _record(0.0, n=1500)
    linear = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
    report = diagnose(PolyCCRegressor(equations=linear).fit(X), X, n_bootstrap=0,
                      held_out=False)
    assert report.best is not None and report.detection_limit == {}
    assert "Detection limit" not in report.summary()


def test_the_slow_memory_of_a_residual_shows_what_wanders_below_the_noise_band():
    from scipy import signal

    rng = np.random.default_rng(3)
    n = 3000
    white = rng.standard_normal((n, 40))
    # white: about 1 (a mean of three periodogram values per column)
    assert np.median([slow_memory(white[:, j]) for j in range(40)]) == pytest.approx(1.0, rel=0.3)
    # AR(1) 0.9: (1 + 0.9) / (1 - 0.9) = 19 samples to one
    ar = signal.lfilter([1.0], [1.0, -0.9], white, axis=0)
    assert 12 < np.median([slow_memory(ar[:, j]) for j in range(40)]) < 28
    # a sensor's slow drift, twice the noise's spread: far more than the noise alone
    drift = signal.lfilter([1.0], [1.0, -np.exp(-5.0 / n)], rng.standard_normal(n))
    drifting = ar[:, 0] + 2 * np.std(ar[:, 0]) * drift / np.std(drift)
    assert slow_memory(drifting) > 5 * 19
    # the largest of the columns; too short a residual says nothing
    assert slow_memory(np.column_stack([white[:, 0], drifting])) == pytest.approx(
        slow_memory(drifting))
    assert slow_memory(np.ones(n)) == 1.0 and slow_memory(white[:5, 0]) == 1.0


def test_a_signal_with_a_missing_sample_is_read_on_its_longest_stretch():
    clean = datasets.make_oscillator(n_samples=2000)[["t", "x1", "F_ext"]]
    noisy = datasets.add_sensor_noise(clean, ["x1"], snr=40.0, random_state=0)
    whole = Measurement(noisy).noise["x1"].level
    gappy = Measurement(noisy.assign(x1=noisy["x1"].mask(noisy.index == 100))).noise
    assert "x1" in gappy  # it was left out without a word
    assert gappy["x1"].level == pytest.approx(whole, rel=0.1)


@pytest.mark.parametrize("clock", ["jittered", "random", "two_rates"])
def test_an_unevenly_sampled_record_has_its_noise_read_from_its_samples(clock):
    # resampled on an even grid the noise was smoothed or folded: read 13 % low on a
    # jittered clock, 30 times too high (and coloured) on a random one
    rng = np.random.default_rng(0)
    n = 3000
    steps = {"jittered": rng.uniform(0.005, 0.015, n), "random": rng.exponential(0.01, n),
             "two_rates": np.where(np.arange(n) % 2 == 0, 0.005, 0.015)}[clock]
    t = np.cumsum(steps)
    signal = np.sin(13 * t) + 0.5 * np.sin(4 * t)
    X = pd.DataFrame({"t": t, "x1": signal + 0.05 * rng.standard_normal(n)})
    reading = Measurement(X).noise["x1"]
    assert reading.level == pytest.approx(0.05, rel=0.1)
    assert not reading.coloured and reading.snr_db == pytest.approx(
        20 * np.log10(np.std(signal) / 0.05), abs=1.5)
