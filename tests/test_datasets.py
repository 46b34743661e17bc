"""Tests of the benchmark data sets in ``sklearn_pycc.datasets``."""

import ast
import inspect
import pickle

import numpy as np
import pandas as pd
import pytest

from sklearn_pycc import datasets
from sklearn_pycc.datasets import (
    make_duffing,
    make_first_order,
    make_stick_slip,
    make_two_dof,
    make_van_der_pol,
)
from sklearn_pycc.datasets._generation import add_noise
from sklearn_pycc.skeleton import Skeleton

SECOND_ORDER_COLUMNS = ["t", "x1", "x2", "F_ext", "x1_dot", "x2_dot"]
FIRST_ORDER_COLUMNS = ["t", "x1", "F_ext", "x1_dot"]
TWO_DOF_COLUMNS = ["t", "x1", "x2", "x3", "x4", "F_ext",
                   "x1_dot", "x2_dot", "x3_dot", "x4_dot"]

# (generator, extra keyword arguments, columns, default n_samples, default t_span)
CASES = [
    pytest.param(make_stick_slip, {}, SECOND_ORDER_COLUMNS, 1000, (0.0, 20.0), id="stick_slip"),
    pytest.param(make_duffing, {}, SECOND_ORDER_COLUMNS, 2000, (0.0, 100.0), id="duffing"),
    pytest.param(make_van_der_pol, {}, SECOND_ORDER_COLUMNS, 2000, (0.0, 60.0), id="vdp"),
    pytest.param(make_first_order, {"kind": "rc"}, FIRST_ORDER_COLUMNS, 1000, (0.0, 20.0),
                 id="rc"),
    pytest.param(make_first_order, {"kind": "rl"}, FIRST_ORDER_COLUMNS, 1000, (0.0, 20.0),
                 id="rl"),
    pytest.param(make_two_dof, {}, TWO_DOF_COLUMNS, 2000, (0.0, 50.0), id="two_dof"),
]

GENERATORS = [
    pytest.param(make_stick_slip, {}, id="stick_slip"),
    pytest.param(make_duffing, {}, id="duffing"),
    pytest.param(make_van_der_pol, {}, id="vdp"),
    pytest.param(make_first_order, {"kind": "rc"}, id="rc"),
    pytest.param(make_first_order, {"kind": "rl"}, id="rl"),
    pytest.param(make_two_dof, {}, id="two_dof"),
]

EXACT = 1e-10


def states_of(frame):
    return [c for c in frame.columns if c + "_dot" in frame.columns]


# -- shapes and columns ------------------------------------------------------------
@pytest.mark.parametrize(("make", "kwargs", "columns", "n_default", "span_default"), CASES)
def test_default_shape_and_columns(make, kwargs, columns, n_default, span_default):
    frame = make(**kwargs)
    assert isinstance(frame, pd.DataFrame)
    assert list(frame.columns) == columns
    assert frame.shape == (n_default, len(columns))
    np.testing.assert_array_equal(frame["t"].to_numpy(), np.linspace(*span_default, n_default))
    assert np.isfinite(frame.to_numpy()).all()
    assert list(frame.index) == list(range(n_default))


@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_custom_grid(make, kwargs):
    frame = make(n_samples=57, t_span=(1.0, 4.0), **kwargs)
    assert len(frame) == 57
    np.testing.assert_array_equal(frame["t"].to_numpy(), np.linspace(1.0, 4.0, 57))


@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_numpy_integer_n_samples(make, kwargs):
    frame = make(n_samples=np.int64(10), **kwargs)
    assert len(frame) == 10


# -- exact derivatives ---------------------------------------------------------------
def test_stick_slip_derivatives_exact():
    frame, truth = make_stick_slip(return_truth=True)
    f1, f2 = truth.functions["f1"], truth.functions["f2"]
    x1, x2, F = frame["x1"], frame["x2"], frame["F_ext"]
    np.testing.assert_allclose(frame["x1_dot"], x2, rtol=0, atol=EXACT)
    np.testing.assert_allclose(frame["x2_dot"], F - f1(x2) - f2(x1), rtol=0, atol=EXACT)
    np.testing.assert_allclose(F, np.cos(frame["t"]), rtol=0, atol=EXACT)


def test_stick_slip_curves_match_arguments():
    _, truth = make_stick_slip(alpha=2.0, beta=0.5, delta=0.3, mu=0.7, steepness=50.0,
                               return_truth=True)
    v = np.linspace(-2, 2, 41)
    np.testing.assert_allclose(truth.functions["f1"](v), 0.3 * v + 0.7 * np.tanh(50.0 * v))
    np.testing.assert_allclose(truth.functions["f2"](v), 2.0 * v + 0.5 * v**3)
    assert truth.params == {"a1": 0.3, "a2": 0.7, "a3": 50.0, "a4": 2.0, "a5": 0.5}


def test_stick_slip_parametric_form_reproduces_data():
    frame, truth = make_stick_slip(n_samples=400, t_span=(0.0, 10.0), return_truth=True)
    parametric = Skeleton(truth.parametric_equations)
    assert parametric.params == ["a1", "a2", "a3", "a4", "a5"]
    assert parametric.functions == []
    again = parametric.simulate(frame["t"].to_numpy(), truth.y0, params=truth.params,
                                inputs=truth.inputs, rtol=1e-10, atol=1e-12,
                                return_derivatives=True)
    for name in ["x1", "x2", "x1_dot", "x2_dot"]:
        np.testing.assert_allclose(again[name], frame[name], rtol=0, atol=1e-6)


def test_duffing_derivatives_exact():
    frame, truth = make_duffing(return_truth=True)
    f1, f2 = truth.functions["f1"], truth.functions["f2"]
    x1, x2, F = frame["x1"], frame["x2"], frame["F_ext"]
    np.testing.assert_allclose(frame["x1_dot"], x2, rtol=0, atol=EXACT)
    np.testing.assert_allclose(frame["x2_dot"], F - f1(x2) - f2(x1), rtol=0, atol=EXACT)
    np.testing.assert_allclose(F, 0.5 * np.cos(1.2 * frame["t"]), rtol=0, atol=EXACT)
    v = np.linspace(-2, 2, 21)
    np.testing.assert_allclose(f1(v), 0.3 * v)
    np.testing.assert_allclose(f2(v), -1.05 * v + 1.02 * v**3)
    # the default chaotic regime visits both wells
    assert frame["x1"].min() < -0.5 and frame["x1"].max() > 0.5


def test_van_der_pol_derivatives_exact():
    frame, truth = make_van_der_pol(mu=1.5, return_truth=True)
    f1, f2 = truth.functions["f1"], truth.functions["f2"]
    x1, x2, F = frame["x1"], frame["x2"], frame["F_ext"]
    np.testing.assert_allclose(frame["x1_dot"], x2, rtol=0, atol=EXACT)
    np.testing.assert_allclose(frame["x2_dot"], F - f1(x1) * x2 - f2(x1), rtol=0, atol=EXACT)
    x = np.linspace(-2, 2, 21)
    np.testing.assert_allclose(f1(x), 1.5 * (x**2 - 1))
    np.testing.assert_allclose(f2(x), x)
    np.testing.assert_allclose(F, 1.2 * np.cos(0.9 * frame["t"]), rtol=0, atol=EXACT)


@pytest.mark.parametrize("kind", ["rc", "rl"])
def test_first_order_derivatives_exact(kind):
    frame, truth = make_first_order(kind=kind, return_truth=True)
    f1, f2 = truth.functions["f1"], truth.functions["f2"]
    x1, x1_dot, F = frame["x1"], frame["x1_dot"], frame["F_ext"]
    np.testing.assert_allclose(f1(x1) + f2(x1) * x1_dot, F, rtol=0, atol=EXACT)
    np.testing.assert_allclose(x1_dot, (F - f1(x1)) / f2(x1), rtol=0, atol=EXACT)
    np.testing.assert_allclose(F, 1.5 * np.sin(0.5 * frame["t"]), rtol=0, atol=EXACT)


def test_two_dof_derivatives_exact():
    frame, truth = make_two_dof(return_truth=True)
    f = truth.functions
    x1, x2, x3, x4, F = (frame[c] for c in ["x1", "x2", "x3", "x4", "F_ext"])
    np.testing.assert_allclose(frame["x1_dot"], x3, rtol=0, atol=EXACT)
    np.testing.assert_allclose(frame["x2_dot"], x4, rtol=0, atol=EXACT)
    np.testing.assert_allclose(frame["x3_dot"],
                               F - f["f1"](x3) - f["f2"](x1) - f["f3"](x1 - x2),
                               rtol=0, atol=EXACT)
    np.testing.assert_allclose(frame["x4_dot"], -f["f4"](x4) - f["f5"](x2) + f["f3"](x1 - x2),
                               rtol=0, atol=EXACT)
    np.testing.assert_allclose(F, np.cos(0.8 * frame["t"]), rtol=0, atol=EXACT)
    d = np.linspace(-2, 2, 21)
    np.testing.assert_allclose(f["f3"](d), 0.5 * d + 0.3 * d**3)
    # the coupling is exercised: the masses do not move together
    assert np.ptp(frame["x1"] - frame["x2"]) > 0.5


# -- derivatives against finite differences ----------------------------------------
@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_derivatives_match_finite_differences(make, kwargs):
    frame = make(**kwargs)
    t = frame["t"].to_numpy()
    inner = slice(1, -1)  # np.gradient is one-sided, hence less accurate, at the ends
    for state in states_of(frame):
        x = frame[state].to_numpy()
        exact = frame[state + "_dot"].to_numpy()
        fd = np.gradient(x, t)
        scale = max(np.max(np.abs(exact)), 1.0)
        error = np.abs(fd - exact)[inner]
        if make is make_stick_slip and state == "x2":
            # x2_dot jumps when the mass sticks or slips; judge it on the bulk
            assert np.median(error) < 1e-3 * scale
        else:
            assert np.max(error) < 2e-2 * scale, state


# -- truth --------------------------------------------------------------------------
@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_truth_bunch_contents(make, kwargs):
    frame, truth = make(n_samples=300, return_truth=True, **kwargs)
    assert set(truth.keys()) == {"equations", "functions", "params", "parametric_equations",
                                 "inputs", "y0", "base_equations", "hidden"}
    skeleton = Skeleton(truth.equations)
    assert all(isinstance(e, str) for e in truth.equations)
    assert sorted(truth.functions) == skeleton.functions
    assert skeleton.params == []
    assert list(truth.inputs) == ["F_ext"] == skeleton.inputs
    assert isinstance(truth.y0, tuple)
    assert len(truth.y0) == len(skeleton.states)
    assert truth.y0 == tuple(frame.loc[0, skeleton.states])
    t = frame["t"].to_numpy()
    np.testing.assert_allclose(truth.inputs["F_ext"](t), frame["F_ext"], rtol=0, atol=EXACT)
    for curve in truth.functions.values():
        values = curve(np.linspace(-1.0, 1.0, 7))
        assert values.shape == (7,)
        assert isinstance(float(curve(0.25)), float)
    if make is make_stick_slip:
        assert set(truth.params) == {"a1", "a2", "a3", "a4", "a5"}
        assert isinstance(truth.parametric_equations, list)
    else:
        assert truth.params == {}
        assert truth.parametric_equations is None
    # the truth is plain data: it pickles
    restored = pickle.loads(pickle.dumps(truth))
    assert restored.equations == truth.equations
    x = np.linspace(-1, 1, 5)
    for name, curve in truth.functions.items():
        np.testing.assert_array_equal(restored.functions[name](x), curve(x))


@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_truth_resimulates_frame(make, kwargs):
    frame, truth = make(n_samples=300, return_truth=True, **kwargs)
    # the functional skeleton has no scalars (truth.params belong to the parametric form)
    again = Skeleton(truth.equations).simulate(
        frame["t"].to_numpy(), truth.y0, functions=truth.functions, inputs=truth.inputs,
        rtol=1e-10, atol=1e-12, return_derivatives=True)
    pd.testing.assert_frame_equal(again[list(frame.columns)], frame)


def test_two_dof_curves_pass_through_origin():
    _, truth = make_two_dof(return_truth=True)
    assert sorted(truth.functions) == ["f1", "f2", "f3", "f4", "f5"]
    for curve in truth.functions.values():
        assert curve(0.0) == 0.0
    assert truth.y0 == (0.5, -0.3, 0.0, 0.0)


def test_two_dof_parameters_are_used():
    _, truth = make_two_dof(damping1=0.4, stiffness1=2.0, coupling=0.1, coupling_cubic=0.05,
                            damping2=0.3, stiffness2=0.7, return_truth=True)
    x = np.linspace(-1, 1, 11)
    f = truth.functions
    np.testing.assert_allclose(f["f1"](x), 0.4 * x)
    np.testing.assert_allclose(f["f2"](x), 2.0 * x)
    np.testing.assert_allclose(f["f3"](x), 0.1 * x + 0.05 * x**3)
    np.testing.assert_allclose(f["f4"](x), 0.3 * x)
    np.testing.assert_allclose(f["f5"](x), 0.7 * x)


# -- first-order kinds --------------------------------------------------------------
def test_first_order_kinds_differ_and_f2_positive():
    rc, truth_rc = make_first_order(kind="rc", return_truth=True)
    rl, truth_rl = make_first_order(kind="rl", return_truth=True)
    assert truth_rc.equations == truth_rl.equations == ["F_ext = f1(x1) + f2(x1) x1_dot"]
    assert not np.allclose(rc["x1"], rl["x1"])
    x = np.linspace(-10, 10, 201)
    np.testing.assert_allclose(truth_rc.functions["f1"](x), x + 0.3 * x**3)
    np.testing.assert_allclose(truth_rc.functions["f2"](x), 1 + 0.5 * x**2 / (1 + x**2))
    np.testing.assert_allclose(truth_rl.functions["f1"](x), 0.8 * x + 0.2 * x**3)
    np.testing.assert_allclose(truth_rl.functions["f2"](x), 1.5 / (1 + x**2) + 0.3)
    for truth in (truth_rc, truth_rl):
        assert (truth.functions["f2"](x) > 0).all()
        assert truth.functions["f1"](0.0) == 0.0


def test_first_order_initial_state_and_input():
    frame = make_first_order(kind="rl", y0=(0.4,), amplitude=2.0, omega=1.0)
    assert frame.loc[0, "x1"] == 0.4
    np.testing.assert_allclose(frame["F_ext"], 2.0 * np.sin(frame["t"]), rtol=0, atol=EXACT)


def test_first_order_unknown_kind():
    with pytest.raises(ValueError, match=r"kind.*'rc'.*'rl'"):
        make_first_order(kind="rlc")


# -- noise ----------------------------------------------------------------------------
@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_reproducible_with_random_state(make, kwargs):
    a = make(n_samples=200, noise=20.0, random_state=3, **kwargs)
    b = make(n_samples=200, noise=20.0, random_state=3, **kwargs)
    c = make(n_samples=200, noise=20.0, random_state=4, **kwargs)
    pd.testing.assert_frame_equal(a, b)
    state = states_of(a)[0]
    assert not np.array_equal(a[state], c[state])


def test_random_state_generator_accepted():
    a = make_duffing(n_samples=200, noise=20.0, random_state=np.random.default_rng(7))
    b = make_duffing(n_samples=200, noise=20.0, random_state=np.random.default_rng(7))
    pd.testing.assert_frame_equal(a, b)


def test_no_global_random_state_used():
    # the legacy global generator must be left alone
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    make_duffing(n_samples=200, noise=20.0, random_state=None)
    np.testing.assert_array_equal(np.random.get_state()[1], before)  # noqa: NPY002


@pytest.mark.parametrize("snr_db", [5.0, 20.0, 40.0])
def test_noise_snr_matches_request(snr_db):
    kwargs = {"n_samples": 20000, "t_span": (0.0, 200.0)}
    clean = make_duffing(**kwargs)
    noisy = make_duffing(noise=snr_db, random_state=0, **kwargs)
    for column in ["x1", "x2"]:
        signal = clean[column].to_numpy()
        residual = noisy[column].to_numpy() - signal
        measured = 20 * np.log10(np.sqrt(np.mean(signal**2)) / np.sqrt(np.mean(residual**2)))
        assert abs(measured - snr_db) < 0.5, (column, measured)
        # zero-mean noise
        assert abs(residual.mean()) < 5 * residual.std() / np.sqrt(len(residual))


@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_default_noise_only_on_states(make, kwargs):
    clean = make(n_samples=200, **kwargs)
    noisy = make(n_samples=200, noise=10.0, random_state=0, **kwargs)
    states = states_of(clean)
    for column in clean.columns:
        if column in states:
            assert not np.array_equal(noisy[column], clean[column]), column
        else:
            np.testing.assert_array_equal(noisy[column], clean[column])


def test_noise_on_chosen_columns_only():
    clean = make_two_dof(n_samples=300)
    chosen = ["x3_dot", "F_ext", "x2"]
    noisy = make_two_dof(n_samples=300, noise=15.0, noise_columns=chosen, random_state=1)
    assert list(noisy.columns) == list(clean.columns)
    for column in clean.columns:
        if column in chosen:
            assert not np.array_equal(noisy[column], clean[column]), column
        else:
            np.testing.assert_array_equal(noisy[column], clean[column])


def test_noise_columns_single_string_and_empty():
    clean = make_duffing(n_samples=100)
    one = make_duffing(n_samples=100, noise=10.0, noise_columns="x2_dot", random_state=0)
    changed = [c for c in clean.columns if not np.array_equal(one[c], clean[c])]
    assert changed == ["x2_dot"]
    none = make_duffing(n_samples=100, noise=10.0, noise_columns=[], random_state=0)
    pd.testing.assert_frame_equal(none, clean)


def test_noise_none_leaves_data_clean():
    a = make_van_der_pol(n_samples=150, random_state=0)
    b = make_van_der_pol(n_samples=150, random_state=1, noise_columns=["x1"])
    pd.testing.assert_frame_equal(a, b)


def test_noise_with_truth():
    clean = make_stick_slip(n_samples=200)
    noisy, truth = make_stick_slip(n_samples=200, noise=30.0, random_state=0, return_truth=True)
    assert truth.y0 == (0.0, 0.0)
    np.testing.assert_array_equal(noisy["x2_dot"], clean["x2_dot"])
    assert not np.array_equal(noisy["x1"], clean["x1"])


def test_add_noise_helper():
    frame = pd.DataFrame({"t": np.arange(5000.0), "a": np.full(5000, 2.0),
                          "b": np.zeros(5000)})
    original = frame.copy()
    rng = np.random.default_rng(0)
    noisy = add_noise(frame, 20.0, ["a", "b"], rng)
    pd.testing.assert_frame_equal(frame, original)  # input untouched
    np.testing.assert_array_equal(noisy["t"], frame["t"])
    np.testing.assert_array_equal(noisy["b"], frame["b"])  # rms 0 -> no noise
    assert np.std(noisy["a"] - 2.0) == pytest.approx(0.2, rel=0.05)


# -- argument validation ---------------------------------------------------------------
@pytest.mark.parametrize("n_samples", [1, 0, -5, 2.5, "100", None, True])
@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_bad_n_samples(make, kwargs, n_samples):
    with pytest.raises(ValueError, match="n_samples"):
        make(n_samples=n_samples, **kwargs)


@pytest.mark.parametrize(
    "t_span",
    [(1.0, 0.0), (2.0, 2.0), (0.0, np.inf), (np.nan, 1.0), (0.0, 1.0, 2.0), (5.0,), "ab",
     None, ("a", "b")],
)
@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_bad_t_span(make, kwargs, t_span):
    with pytest.raises(ValueError, match="t_span"):
        make(t_span=t_span, **kwargs)


@pytest.mark.parametrize("noise", [np.inf, -np.inf, np.nan, "loud", [10.0], True])
@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_bad_noise(make, kwargs, noise):
    with pytest.raises(ValueError, match="noise"):
        make(n_samples=20, noise=noise, **kwargs)


@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_unknown_noise_column(make, kwargs):
    with pytest.raises(ValueError, match=r"noise_columns.*'velocity'"):
        make(n_samples=20, noise=10.0, noise_columns=["x1", "velocity"], **kwargs)


@pytest.mark.parametrize(("make", "kwargs"), GENERATORS)
def test_time_noise_column_refused(make, kwargs):
    with pytest.raises(ValueError, match=r"noise_columns.*'t'"):
        make(n_samples=20, noise=10.0, noise_columns=["t"], **kwargs)


def test_bad_noise_columns_type():
    with pytest.raises(ValueError, match="noise_columns"):
        make_duffing(n_samples=20, noise=10.0, noise_columns=5)


@pytest.mark.parametrize(
    ("make", "y0"),
    [(make_stick_slip, (0.0,)), (make_duffing, (1.0, 0.0, 0.0)), (make_van_der_pol, ()),
     (make_first_order, (0.0, 1.0)), (make_two_dof, (0.5, -0.3)),
     (make_duffing, (np.nan, 0.0)), (make_duffing, ("a", 0.0)), (make_duffing, 1.0)],
)
def test_bad_y0(make, y0):
    with pytest.raises(ValueError, match="y0"):
        make(n_samples=20, y0=y0)


@pytest.mark.parametrize(
    ("make", "name"),
    [(make_stick_slip, "alpha"), (make_stick_slip, "beta"), (make_stick_slip, "delta"),
     (make_stick_slip, "mu"), (make_stick_slip, "steepness"), (make_stick_slip, "amplitude"),
     (make_stick_slip, "omega"), (make_duffing, "alpha"), (make_duffing, "beta"),
     (make_duffing, "delta"), (make_duffing, "amplitude"), (make_duffing, "omega"),
     (make_van_der_pol, "mu"), (make_van_der_pol, "amplitude"), (make_van_der_pol, "omega"),
     (make_first_order, "amplitude"), (make_first_order, "omega"),
     (make_two_dof, "amplitude"), (make_two_dof, "omega"), (make_two_dof, "damping1"),
     (make_two_dof, "stiffness1"), (make_two_dof, "coupling"),
     (make_two_dof, "coupling_cubic"), (make_two_dof, "damping2"),
     (make_two_dof, "stiffness2")],
)
@pytest.mark.parametrize("value", [np.nan, np.inf, "1.0", None])
def test_bad_physical_parameter(make, name, value):
    with pytest.raises(ValueError, match=name):
        make(n_samples=20, **{name: value})


def test_bad_random_state():
    with pytest.raises(ValueError, match="random_state"):
        make_duffing(n_samples=20, noise=10.0, random_state="seed")


# -- module hygiene --------------------------------------------------------------------
def test_public_api():
    assert sorted(datasets.__all__) == ["add_sensor_noise",
                                        "make_duffing", "make_experiments", "make_first_order",
                                        "make_heated_tank", "make_oscillator", "make_pendulum",
                                        "make_positioning_axis", "make_resonator",
                                        "make_rooms", "make_stick_slip", "make_two_dof",
                                        "make_two_tanks", "make_van_der_pol"]
    assert datasets.__doc__
    for name in datasets.__all__:
        fn = getattr(datasets, name)
        doc = inspect.getdoc(fn)
        for section in ("Parameters", "Returns", "Raises"):
            assert section in doc, (name, section)
        if name in ("make_experiments", "add_sensor_noise"):
            continue
        signature = inspect.signature(fn)
        assert list(signature.parameters)[:2] == ["n_samples", "t_span"]
        for keyword in ("noise", "noise_columns", "random_state", "return_truth", "y0"):
            assert signature.parameters[keyword].kind is inspect.Parameter.KEYWORD_ONLY


def test_module_imports_only_skeleton_and_exceptions():
    from sklearn_pycc.datasets import (
        _buildings,
        _generation,
        _lab_records,
        _oscillators,
        _process_records,
        _sensor_noise,
    )

    for module in (datasets, _oscillators, _lab_records, _process_records, _generation,
                   _sensor_noise, _buildings):
        _check_imports(module)


def _check_imports(module):
    tree = ast.parse(inspect.getsource(module))
    for node in ast.walk(tree):
        # the effect catalogue (a leaf over the skeleton) names the hidden effects;
        # the laboratory records and the generators' shared checks are datasets' own
        # leaves, importing nothing else of the package
        if isinstance(node, ast.ImportFrom) and node.level > 0:
            allowed = ("_generation",)
            if module is datasets:  # the package gathers its modules' generators
                allowed = ("_oscillators", "_lab_records", "_process_records", "_sensor_noise",
                           "_buildings")
            if module.__name__.endswith("_oscillators"):
                allowed += ("skeleton", "effects")
            if module.__name__.endswith("_process_records"):  # the signals of the lab's
                allowed += ("_lab_records",)
            if module.__name__.endswith("_buildings"):  # the process records' held input
                allowed += ("_lab_records", "_process_records")
            assert node.module in allowed, (module.__name__, node.module)
        if isinstance(node, ast.ImportFrom) and node.module:
            assert "estimators" not in node.module
        if isinstance(node, ast.Import):
            for alias in node.names:
                assert not alias.name.startswith("sklearn_pycc"), alias.name


# -- hidden effects ------------------------------------------------------------------
def test_oscillator_hides_catalogue_effects():
    frame, truth = datasets.make_oscillator(
        hidden={"coulomb_friction": {"a1": 0.25, "a2": 30.0}, "cubic_stiffness": None},
        n_samples=400, return_truth=True)
    assert truth.hidden == ["coulomb_friction", "cubic_stiffness"]
    assert truth.base_equations == ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - a2 x1"]
    assert truth.parametric_equations[1] == (
        "x2_dot = F_ext - a1 x2 - a2 x1 - a3*tanh(a4*x2) - a5*x1^3")
    assert truth.params == {"a1": 0.1, "a2": 1.0, "a3": 0.25, "a4": 30.0,
                            "a5": datasets.HIDDEN_DEFAULTS["cubic_stiffness"]["a1"]}
    x1, x2 = frame["x1"].to_numpy(), frame["x2"].to_numpy()
    expected = (frame["F_ext"] - 0.1 * x2 - x1 - 0.25 * np.tanh(30.0 * x2) - 1.0 * x1**3)
    np.testing.assert_allclose(frame["x2_dot"], expected, rtol=0, atol=1e-12)
    assert truth.y0 == (3.0, 0.0)


def test_oscillator_without_hidden_effects_is_linear():
    frame, truth = datasets.make_oscillator(hidden=[], n_samples=300, return_truth=True)
    assert truth.parametric_equations == truth.base_equations and truth.hidden == []
    np.testing.assert_allclose(frame["x2_dot"],
                               frame["F_ext"] - 0.1 * frame["x2"] - frame["x1"], atol=1e-12)


@pytest.mark.parametrize(("hidden", "match"), [
    ("no_such_effect", "no effect named 'no_such_effect'"),
    (["coupling"], "acts through 'difference'"),
    (["stribeck_friction"], "no default strength"),
    ({"cubic_stiffness": {"a2": 1.0}}, r"has the parameters \['a1'\]"),
    ({"cubic_stiffness": {"a1": "big"}}, "must be a finite float"),
    (["offset", "offset"], "twice"),
    (3, "hidden must be"),
])
def test_oscillator_rejects_bad_hidden_effects(hidden, match):
    with pytest.raises(ValueError, match=match):
        datasets.make_oscillator(hidden=hidden, n_samples=50)


def test_the_filmed_pendulum_is_what_a_camera_logs():
    frame, truth = datasets.make_pendulum(random_state=0, return_truth=True)
    assert list(frame.columns) == ["t", "x1"]
    assert len(frame) == 1800 - round(0.03 * 1798)  # frames dropped, never the ends
    assert frame["t"].iloc[0] == 0 and frame["t"].iloc[-1] == pytest.approx(59.97)
    # the truth's states solve its skeleton, and the angle reaches the release of 2 rad
    exact = truth.states
    assert exact["x1"].abs().max() == pytest.approx(2.0, abs=1e-6)
    wave = np.sqrt(truth.params["a2"])
    assert wave == pytest.approx(2 * np.pi * 0.5)
    noise = frame["x1"].to_numpy() - exact["x1"].to_numpy()
    assert 0 < np.std(noise) < 0.02
    clean = datasets.make_pendulum(noise=None, pixel=0, drop_fraction=0, random_state=0)
    assert len(clean) == 1800 and np.allclose(clean["x1"].iloc[0], 2.0)
    with pytest.raises(ValueError, match="pixel"):
        datasets.make_pendulum(pixel=-1)
    with pytest.raises(ValueError, match="drop_fraction"):
        datasets.make_pendulum(drop_fraction=1.5)


def test_two_tanks_log_the_lower_level_every_four_seconds_and_both_overflow():
    frame, truth = datasets.make_two_tanks(random_state=0, return_truth=True)
    assert list(frame.columns) == ["t", "u", "x2"] and len(frame) == 1024
    np.testing.assert_allclose(np.diff(frame.t), 4.0)
    assert frame.u.min() >= 3.0 and frame.u.max() <= 10.0
    # both tanks overflow now and then, and spend most of the time below their rims
    for state in ("x1", "x2"):
        assert 0.01 < truth.overflowing[state] < 0.4
        assert truth.states[state].max() == pytest.approx(truth.rims[state])
    # 40 dB on the lower level: the noise is about a hundredth of its RMS
    noise = frame.x2 - truth.states.x2
    rms = float(np.sqrt(np.mean(truth.states.x2**2)))
    assert 0.7e-2 < float(noise.std()) / rms < 1.3e-2
    # the exact levels follow Torricelli's law away from the rims (the input is held)
    a = truth.params
    x1, x2 = truth.states.x1.to_numpy(), truth.states.x2.to_numpy()
    below = (x1[:-1] < truth.rims["x1"] - 1e-9) & (x1[1:] < truth.rims["x1"] - 1e-9)
    below &= (x2[:-1] < truth.rims["x2"] - 1e-9) & (x2[1:] < truth.rims["x2"] - 1e-9)
    slope = np.diff(x2) / 4.0
    mid = 0.5 * (x1[:-1] + x1[1:]), 0.5 * (x2[:-1] + x2[1:])
    model = a["a3"] * np.sqrt(mid[0]) - a["a4"] * np.sqrt(mid[1])
    assert np.median(np.abs(slope - model)[below]) < 0.02 * np.median(np.abs(model)[below]) + 1e-4
    np.testing.assert_array_equal(truth.input(frame.t.to_numpy() + 2.0), frame.u)


def test_two_tanks_settings_are_checked_and_seeded():
    a = datasets.make_two_tanks(n_samples=50, random_state=3, measured=("x1", "x2"))
    b = datasets.make_two_tanks(n_samples=50, random_state=3, measured=("x1", "x2"))
    pd.testing.assert_frame_equal(a, b)
    assert list(a.columns) == ["t", "u", "x1", "x2"]
    with pytest.raises(ValueError, match="measured must name some of 'x1' and 'x2'"):
        datasets.make_two_tanks(measured=("x3",))
    with pytest.raises(ValueError, match="params names 'a5'"):
        datasets.make_two_tanks(params={"a5": 1.0})
    with pytest.raises(ValueError, match="y0 must be two non-negative levels"):
        datasets.make_two_tanks(y0=(-1.0, 2.0))
    with pytest.raises(ValueError, match="pump must be"):
        datasets.make_two_tanks(pump=(5.0, 1.0))


def test_an_oscillator_pushed_by_an_unmeasured_random_force():
    options = dict(hidden=[], n_samples=1500, t_span=(0.0, 30.0), random_state=3)
    calm = datasets.make_oscillator(**options)
    frame, truth = datasets.make_oscillator(disturbance=0.05, return_truth=True, **options)
    again = datasets.make_oscillator(disturbance=0.05, **options)
    pd.testing.assert_frame_equal(frame, again)
    # the measured force is the cosine alone; the push moved the states
    np.testing.assert_allclose(frame.F_ext, calm.F_ext)
    assert len(truth.disturbance) == len(frame)
    wander = np.sqrt(np.mean((frame.x1 - calm.x1) ** 2)) / np.std(calm.x1)
    assert 0.05 < wander < 0.5
    # the derivative columns hold the pushed acceleration
    np.testing.assert_allclose(frame.x2_dot, frame.F_ext + truth.disturbance
                               - 0.1 * frame.x2 - frame.x1, atol=1e-8)
    with pytest.raises(ValueError, match="disturbance must be non-negative"):
        datasets.make_oscillator(disturbance=-1.0, **options)
