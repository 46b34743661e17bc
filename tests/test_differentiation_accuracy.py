"""Every differentiation method against exact derivatives, on even and uneven sampling.

Each method runs on the path a fit takes (:func:`estimate_states`, the second
derivative through a kinematic chain), on a smooth two-tone signal whose
derivatives are known. The tolerances sit about three times above what each
method reaches on these very signals (the module's tables give the measured
errors): a method that loses the sample times, an order of accuracy or its
ends fails, where a blanket 0.02 would let it pass.
"""

import numpy as np
import pytest

from sklearn_pycc import Skeleton
from sklearn_pycc.measurements import (
    DIFFERENTIATION_METHODS,
    estimate_states,
    resolve_differentiation,
    split_experiments,
)

#: x1 measured; x2 = x1_dot is reconstructed from it, and x2_dot is the second derivative
CHAIN = Skeleton(["x1_dot = x2", "x2_dot = a1 x1"])
#: interior times are moved by up to this share of the step (uniform, seed 0)
JITTER = 0.3


def signal(t):
    return np.sin(t) + 0.5 * np.cos(2.3 * t + 0.4)


def first(t):
    return np.cos(t) - 1.15 * np.sin(2.3 * t + 0.4)


def second(t):
    return -np.sin(t) - 2.645 * np.cos(2.3 * t + 0.4)


def nrmse(estimate, truth):
    return float(np.sqrt(np.mean((estimate - truth) ** 2) / np.mean(truth**2)))


def sample_times(spacing, n, duration, rng=None):
    t = np.linspace(0.0, duration, n)
    if spacing == "uneven":
        rng = np.random.default_rng(0) if rng is None else rng
        t[1:-1] += rng.uniform(-JITTER, JITTER, n - 2) * duration / (n - 1)
    return t


def estimate(spec, t, x):
    return estimate_states(CHAIN, {"x1": x}, split_experiments(len(t), t),
                           resolve_differentiation(spec))


def errors(est, t, clean, inner):
    """Errors of the smoothed values, and of both derivatives inside and over the record."""
    d1, d2 = est.derivatives[:, 0], est.derivatives[:, 1]
    return {"smooth": nrmse(est.smoothed["x1"][inner], clean(t)[inner]),
            "d1": nrmse(d1[inner], first(t)[inner]), "d2": nrmse(d2[inner], second(t)[inner]),
            "d1_all": nrmse(d1, first(t)), "d2_all": nrmse(d2, second(t))}


def needs_package(spec):
    name = spec if isinstance(spec, str) else spec["method"]
    if name in ("kalman", "trend_filtered"):
        pytest.importorskip("derivative")


# -- noise-free: 120 samples over 6 s (55 per period of the faster tone) -------------------
TREND = {"method": "trend_filtered", "alpha": 1e-5}  # the default alpha smooths the tones away
CLEAN = {"auto": "auto", "lowpass": "lowpass", "spline": "spline", "savgol": "savgol",
         "finite_difference": "finite_difference", "kalman": "kalman",
         "trend_filtered": TREND}
# measured (even | uneven), smooth / d1 / d2 inside 6 samples of the ends / d1 / d2 overall:
#   auto, lowpass  0 | 4e-7,      3.3e-5 | 3.6e-5, 6.1e-5 | 2.6e-4, 5.4e-4 | 1.5e-3, 0.011 | 0.015
#   spline         3.7e-6,        7.5e-6 | 2.8e-5, 1.1e-3 | 1.3e-3, 5.0e-3 | 5.2e-3, 0.12
#   savgol         3.5e-5,        3.0e-5,          0.010,           3.0e-4,          0.012
#   finite diff.   0,             1.8e-3,          4.3e-3 | 6.2e-3, 1.9e-3,          0.011
#   kalman         1.8e-5 | 1e-4, 3.6e-5 | 2.7e-4, 4.6e-4 | 5.7e-3, 7.7e-3 | 0.014, 0.076 | 0.094
#   trend_filtered 1.7e-3,        0.010,           0.023,           0.023,           0.083
# (savgol and trend_filtered assume one time step: uneven samples are refused, below)
CLEAN_TOLERANCES = {
    ("auto", "even"): (1e-6, 1e-4, 2e-4, 2e-3, 3e-2),
    ("auto", "uneven"): (3e-6, 1e-4, 1e-3, 5e-3, 5e-2),
    ("lowpass", "even"): (1e-6, 1e-4, 2e-4, 2e-3, 3e-2),
    ("lowpass", "uneven"): (3e-6, 1e-4, 1e-3, 5e-3, 5e-2),
    ("spline", "even"): (2e-5, 3e-5, 3e-3, 2e-2, 0.3),
    ("spline", "uneven"): (2e-5, 1e-4, 5e-3, 2e-2, 0.3),
    ("savgol", "even"): (1e-4, 1e-4, 3e-2, 1e-3, 3e-2),
    ("finite_difference", "even"): (1e-12, 5e-3, 1e-2, 5e-3, 3e-2),
    ("finite_difference", "uneven"): (1e-12, 5e-3, 2e-2, 5e-3, 3e-2),
    ("kalman", "even"): (1e-4, 1e-4, 2e-3, 2e-2, 0.2),
    ("kalman", "uneven"): (5e-4, 1e-3, 2e-2, 5e-2, 0.3),
    ("trend_filtered", "even"): (5e-3, 3e-2, 7e-2, 7e-2, 0.25),
}


def test_every_registered_method_is_measured():
    assert set(CLEAN) == set(DIFFERENTIATION_METHODS)
    measured = {name for name, _ in CLEAN_TOLERANCES}
    assert measured == set(DIFFERENTIATION_METHODS)


@pytest.mark.parametrize("name, spacing", list(CLEAN_TOLERANCES),
                         ids=[f"{n}-{s}" for n, s in CLEAN_TOLERANCES])
def test_a_smooth_signal_is_differentiated_to_the_methods_accuracy(name, spacing):
    needs_package(CLEAN[name])
    t = sample_times(spacing, 120, 6.0)
    est = estimate(CLEAN[name], t, signal(t))
    found = errors(est, t, signal, slice(6, -6))
    bounds = dict(zip(("smooth", "d1", "d2", "d1_all", "d2_all"),
                      CLEAN_TOLERANCES[(name, spacing)]))
    for what, bound in bounds.items():
        assert found[what] <= bound, (what, found)
    # the reconstructed velocity is the first derivative itself
    assert np.array_equal(est.states["x2"], est.derivatives[:, 0])


@pytest.mark.parametrize("name", ["savgol", "trend_filtered"])
def test_a_method_that_assumes_one_time_step_refuses_uneven_samples(name):
    needs_package(CLEAN[name])
    t = sample_times("uneven", 120, 6.0)
    with pytest.raises(ValueError, match="needs evenly spaced samples"):
        estimate(CLEAN[name], t, signal(t))


# -- noisy: 300 samples over 10 s, white noise of 1e-3 (SNR about 60 dB), seed 0 -----------
NOISE = 1e-3
NOISY = {"auto": "auto", "spline": "spline", "savgol": "savgol", "kalman": "kalman",
         "lowpass": {"method": "lowpass", "cutoff": 1.0}}
# measured at seed 0 (worst of seeds 0-5), smooth / d1 / d2 inside 15 samples of the ends:
#   auto even       5.1e-4, 3.0e-3, 0.017 (see the last test for the other seeds)
#   spline          6.0e-4 (6.4e-4), 5.9e-3 (6.3e-3), 0.089 (0.098), even or uneven
#   savgol even     7.5e-4, 0.015, 0.10
#   kalman          7.6e-4 | 4.2e-4, 0.012 | 3.8e-3 (5.5e-3), 0.12 | 0.018 (0.033)
#   lowpass at 1 Hz 1.9e-3 (2.0e-3), 7.2e-3 (7.5e-3), 0.034 (0.036), even or uneven
NOISY_TOLERANCES = {
    ("auto", "even"): (1.5e-3, 1e-2, 5e-2),
    ("spline", "even"): (1.5e-3, 1.5e-2, 0.2),
    ("spline", "uneven"): (1.5e-3, 1.5e-2, 0.2),
    ("savgol", "even"): (1.5e-3, 3e-2, 0.2),
    ("kalman", "even"): (1.5e-3, 3e-2, 0.25),
    ("kalman", "uneven"): (1.5e-3, 1.5e-2, 0.1),
    ("lowpass", "even"): (4e-3, 1.5e-2, 7e-2),
    ("lowpass", "uneven"): (4e-3, 1.5e-2, 7e-2),
}


def noisy_record(spacing, seed):
    rng = np.random.default_rng(seed)
    t = sample_times(spacing, 300, 10.0, rng)
    return t, signal(t) + NOISE * rng.standard_normal(len(t))


@pytest.mark.parametrize("name, spacing", list(NOISY_TOLERANCES),
                         ids=[f"{n}-{s}" for n, s in NOISY_TOLERANCES])
def test_a_noisy_signal_is_differentiated_to_the_methods_accuracy(name, spacing):
    needs_package(NOISY[name])
    t, x = noisy_record(spacing, 0)
    found = errors(estimate(NOISY[name], t, x), t, signal, slice(15, -15))
    for what, bound in zip(("smooth", "d1", "d2"), NOISY_TOLERANCES[(name, spacing)]):
        assert found[what] <= bound, (what, found)


@pytest.mark.xfail(strict=True, reason=(
    "'auto' reads too low a noise floor on some records and filters at 5 times the cutoff "
    "it picks on the others (or not at all): first-derivative error 0.025 at seed 5 of the "
    "even record, 0.029 / 0.025 / 0.040 at seeds 0 / 5 / 6 of the uneven one, against "
    "0.002-0.005 elsewhere"))
@pytest.mark.parametrize("spacing", ["even", "uneven"])
def test_auto_reaches_its_accuracy_on_every_noise_draw(spacing):
    worst = 0.0
    for seed in range(8):
        t, x = noisy_record(spacing, seed)
        found = errors(estimate("auto", t, x), t, signal, slice(15, -15))
        worst = max(worst, found["d1"])
    assert worst <= 1e-2
