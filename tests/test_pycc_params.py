"""Every ``params`` key of the published functional API is known: mapped, or noted once.

Each mapped key is shown to take effect; keys without a counterpart are
named, with the reason, in one warning per call; a key the published
package never read is still an error naming the nearest known key.
"""

import pickle
import warnings

import matplotlib
import numpy as np
import pandas as pd
import pytest
import sympy

from sklearn_pycc import ExtrapolationWarning, NeuralCCRegressor, PolyCCRegressor, datasets, pycc
from sklearn_pycc.pycc import ParetoModel, SymbolicEntry

matplotlib.use("Agg")

STICK_SLIP = ["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"]
PARAMETRIC = ["x1_dot = x2", "x2_dot = F_ext - a1 * x2 - a2* tanh(a3*x2)- a4 * x1 - a5 * x1^3"]
TRUTH = {"a1": 0.1, "a2": 0.5, "a3": 500.0, "a4": 1.0, "a5": 0.2}
LORENZ = ["x1_dot = a1 * (x2 - x1)", "x2_dot = x1 * (a2 - x3) - x2", "x3_dot = x1 * x2 - a3 * x3"]
TINY_NN = {"neurons": 8, "layers": 1, "epochs": 5, "random_state": 0}
SMALL_SR = {"pysr": {"niterations": 5, "populations": 1}, "max_iterations": 1,
            "random_state": 0}


def F_ext(t):
    return np.cos(t)


def calls_warnings(function, *args, **kwargs):
    """``function(*args, **kwargs)`` and the UserWarnings the functional API said."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = function(*args, **kwargs)
    said = [str(w.message) for w in caught if issubclass(w.category, UserWarning)
            and str(w.message).startswith(("train(", "simulate(", "post_processing("))]
    return out, said


@pytest.fixture(scope="module")
def stick_slip():
    return datasets.make_stick_slip()


@pytest.fixture(scope="module")
def example5_df():
    """Example 5's data: the stick-slip record without a time column."""
    t_eval = np.linspace(0, 20, 1000)
    sol, derivatives = pycc.simulate(STICK_SLIP, "Theoretical", {
        "t_span": (0, 20), "y0": [0.0, 0.0], "t_eval": t_eval,
        "local_funcs": {"f1": lambda v: 0.1 * v + 0.5 * np.tanh(500 * v),
                        "f2": lambda x: x + 0.2 * x**3, "F_ext": F_ext}})
    df = pd.DataFrame({"x1": sol.y[0], "x2": sol.y[1], "x1_dot": derivatives[0],
                       "x2_dot": derivatives[1], "F_ext": F_ext(sol.t)})
    return df, t_eval


def params_simul(t_eval):
    return [{"local_funcs": {"F_ext": F_ext}}, {"t_span": (0, 20)}, {"y0": [0.0, 0.0]},
            {"t_eval": t_eval}, {"method": "LSODA"}]


# -- equations and methods ------------------------------------------------------------------
def test_equations_given_as_one_string(stick_slip):
    lines = "x1_dot = x2\n\n   x2_dot = F_ext - f1(x2) - f2(x1)\n"
    models, evals, _ = pycc.train(stick_slip, lines, "Poly", {"N_order": 5})
    assert list(models.estimator.equations) == STICK_SLIP and len(evals) == 4
    sol, _ = pycc.simulate("x_dot = -a1 x", "Theoretical",
                           {"t_span": (0, 1), "y0": [1.0], "obtained_coefs": {"a1": 2.0}})
    assert np.allclose(sol.y[0], np.exp(-2.0 * sol.t), rtol=1e-5)
    with pytest.warns(UserWarning, match="PySR is not installed"):
        models_sr, _ = pycc.post_processing(
            "x1_dot = x2\nx2_dot = F_ext - f1(x2) - f2(x1)", "SymbR",
            {"evals": evals, "plot": False,
             **{k: SMALL_SR[k] for k in ("pysr", "random_state")}})
    assert set(models_sr) == {"f1", "f2"}
    with pytest.raises(ValueError, match="equations is an empty string"):
        pycc.train(stick_slip, "  \n ", "Poly")


def test_poly_linear_is_poly(stick_slip):
    models, _, _ = pycc.train(stick_slip, STICK_SLIP, "Poly_linear", {"N_order": 5})
    assert isinstance(models.estimator, PolyCCRegressor)
    assert models.estimator.degree == 5
    with pytest.raises(ValueError, match="'NN', 'Poly', 'Poly_linear' or 'SymbR'"):
        pycc.train(stick_slip, STICK_SLIP, "Polynomial")


# -- starting values and weights -------------------------------------------------------------
@pytest.mark.parametrize("key, value", [("initial_param_guess", [{"a3": 100}]),
                                        ("initial_param_guess", {"a3": 100}),
                                        ("initial_params", {"a3": 100})])
def test_initial_values_become_param_init(stick_slip, key, value):
    models, _, coefs = pycc.train(stick_slip, PARAMETRIC, "Poly", {key: value})
    assert models.estimator.param_init == {"a3": 100.0}
    assert coefs["a3"].item() == pytest.approx(500.0, rel=1e-3)


def test_initial_params_reach_the_networks(stick_slip):
    eqs = ["x1_dot = x2", "x2_dot = F_ext - a1 * f1(x2) - f2(x1)"]
    models, _, _ = pycc.train(stick_slip, eqs, "NN", {**TINY_NN, "initial_params": {"a1": 1.5}})
    assert isinstance(models.estimator, NeuralCCRegressor)
    assert models.estimator.param_init == {"a1": 1.5}


def test_initial_values_name_the_key_when_wrong(stick_slip):
    with pytest.raises(ValueError, match="initial_param_guess gives 'a9', which is not a "
                                         "parameter"):
        pycc.train(stick_slip, PARAMETRIC, "Poly", {"initial_param_guess": [{"a9": 1}]})
    with pytest.raises(ValueError, match=r"initial_param_guess starts a3 at 100\.0, but it "
                                         r"was already started at 10\.0"):
        pycc.train(stick_slip, PARAMETRIC, "Poly", {"initial_param_guess": [{"a3": 100}],
                                                    "initial_params": {"a3": 10}})
    with pytest.raises(TypeError, match=r"initial_param_guess\[0\] must be a dict"):
        pycc.train(stick_slip, PARAMETRIC, "Poly", {"initial_param_guess": ["a3"]})


@pytest.mark.parametrize("method, extra", [("Poly", {}), ("NN", TINY_NN)])
def test_eq_weights_become_equation_weights(stick_slip, method, extra):
    models, _, _ = pycc.train(stick_slip, STICK_SLIP, method,
                              {**extra, "eq_weights": [1.0, 2.0]})
    assert list(models.estimator.equation_weights) == [1.0, 2.0]


def test_eq_weights_need_one_weight_per_equation(stick_slip):
    with pytest.raises(ValueError, match=r"eq_weights'\] holds 1 value"):
        pycc.train(stick_slip, STICK_SLIP, "Poly", {"eq_weights": [1.0]})


# -- simulate ---------------------------------------------------------------------------------
def lorenz(key_values):
    params = {"t_span": (0, 2), "y0": [0.5, 0.8, -0.3], "t_eval": np.linspace(0, 2, 300),
              "method": "LSODA", **key_values}
    return pycc.simulate(LORENZ, "Theoretical", params)


def test_scalar_params_is_obtained_coefs():
    values = {"a1": 10.0, "a2": 28.0, "a3": 8.0 / 3.0}
    by_scalar, d_scalar = lorenz({"scalar_params": values})
    by_coefs, d_coefs = lorenz({"obtained_coefs": values})
    (both, _), said = calls_warnings(lorenz, {"obtained_coefs": values,
                                                   "scalar_params": dict(values)})
    assert said == []
    assert np.array_equal(by_scalar.y, by_coefs.y) and np.array_equal(d_scalar, d_coefs)
    assert np.array_equal(both.y, by_coefs.y)


def test_scalar_params_and_obtained_coefs_must_agree():
    with pytest.raises(ValueError, match=r"obtained_coefs\['a2'\] = 28.0 but "
                                         r"scalar_params\['a2'\] = 27.0"):
        lorenz({"obtained_coefs": {"a1": 10.0, "a2": 28.0, "a3": 2.0},
                "scalar_params": {"a2": 27.0}})
    # together they may give the coefficients between them
    sol, _ = lorenz({"obtained_coefs": {"a1": 10.0}, "scalar_params": {"a2": 28.0, "a3": 2.0}})
    assert sol.success


def test_scaling_in_a_poly_simulation_is_noted_once(example5_df):
    df, t_eval = example5_df
    models, _, coefs = pycc.train(df, PARAMETRIC, "Poly", {"initial_param_guess": [{"a3": 100}]})
    params = {"models": models, "scaling": True, "obtained_coefs": coefs,
              "scalar_params": coefs, "local_funcs": {"F_ext": F_ext}, "t_span": (0, 20),
              "y0": [0.0, 0.0], "t_eval": t_eval, "method": "LSODA"}
    (sol, _), said = calls_warnings(pycc.simulate, PARAMETRIC, "Poly", params)
    assert len(said) == 1 and "'scaling' has no effect" in said[0]
    assert np.max(np.abs(sol.y[0] - df["x1"])) < 1e-3


def _table_system(interp_params):
    """``x_dot = f1(u)``, ``u = t``: f1 is a table of the identity on [0, 1], run to t = 2."""
    grid = np.linspace(0.0, 1.0, 21)
    params = {"evals": [grid, grid.copy()], "local_funcs": {"u": lambda t: t},
              "t_span": (0, 2), "y0": [0.0], "t_eval": np.linspace(0, 2, 41), **interp_params}
    return pycc.simulate(["x_dot = f1(u)"], "Interp", params)


def test_interp_extrapolate():
    (free, _), said = calls_warnings(_table_system, {"extrapolate": True})
    held, _ = _table_system({"extrapolate": False})
    assert said == []
    assert free.y[0][-1] == pytest.approx(2.0, rel=1e-5)  # continues along the tangent
    assert held.y[0][-1] == pytest.approx(1.5, rel=1e-5)  # holds f1(1) = 1 beyond t = 1
    assert held.estimator.functions_["f1"](np.array([2.0]))[0] == pytest.approx(1.0)
    with pytest.warns(ExtrapolationWarning, match="leaves the range"):
        beyond = held.estimator.simulate(np.linspace(0, 2, 41), [0.0], {"u": lambda t: t})
    assert beyond["x"].iloc[-1] == pytest.approx(1.5, 1e-5)


def test_interp_spline_and_smoothing():
    x = np.linspace(-2, 2, 41)
    noisy = np.sin(x) + 0.05 * np.random.default_rng(0).standard_normal(x.size)
    common = {"evals": [x, noisy], "local_funcs": {"u": np.sin}, "t_span": (0, 5),
              "y0": [0.0], "t_eval": np.linspace(0, 5, 51)}
    run = pycc.simulate
    spline, _ = run(["x_dot = f1(u)"], "Interp", {**common, "interp_method": "spline"})
    cubic, _ = run(["x_dot = f1(u)"], "Interp", {**common, "interp_method": "cubic"})
    # a spline through every point (smoothing 0, the default) is the cubic spline
    assert np.allclose(spline.y, cubic.y, rtol=1e-10, atol=1e-12)
    smooth, _ = run(["x_dot = f1(u)"], "Interp",
                    {**common, "interp_method": "spline", "smoothing": 0.1})
    table = smooth.estimator.functions_["f1"]
    assert np.std(np.diff(table.y, 2)) < 0.5 * np.std(np.diff(noisy, 2))
    (_, _), said = calls_warnings(run, ["x_dot = f1(u)"], "Interp",
                                  {**common, "smoothing": 0.1})
    assert len(said) == 1 and "'smoothing' has no effect" in said[0]
    with pytest.raises(ValueError, match="interp_method must be one of"):
        run(["x_dot = f1(u)"], "Interp", {**common, "interp_method": "quadratic"})


# -- NN device and activation -----------------------------------------------------------------
def _available(kind):
    import torch

    backend = getattr(torch, kind, None)
    return backend is not None and backend.is_available()


@pytest.mark.parametrize("device, search", [("xpu", ["xpu"]), ("gpu", ["cuda", "xpu"]),
                                            ("cuda", ["cuda"])])
def test_device_searches_then_falls_back_to_the_cpu(stick_slip, device, search):
    (models, _, _), said = calls_warnings(pycc.train, stick_slip, STICK_SLIP, "NN",
                                          {**TINY_NN, "device": device})
    found = [kind for kind in search if _available(kind)]
    if found:
        assert models.estimator.device_ == found[0] and said == []
    else:
        assert models.estimator.device_ == "cpu"
        assert len(said) == 1 and f"device={device!r}" in said[0] and "CPU" in said[0]


def test_device_automatic_and_unknown(stick_slip):
    models, _, _ = pycc.train(stick_slip, STICK_SLIP, "NN", {**TINY_NN, "device": "automatic"})
    assert models.estimator.device == "auto"
    with pytest.raises(ValueError, match="device='tpu' is not a device"):
        pycc.train(stick_slip, STICK_SLIP, "NN", {"device": "tpu"})


@pytest.mark.parametrize("given, used, noted", [("relu", "relu", False),
                                                ("tanh", "tanh", False),
                                                (["silu", "silu"], "silu", False),
                                                ("leaky_relu", "leaky_relu", False),
                                                ("rrelu", "leaky_relu", True)])
def test_activation_names_of_the_docs(stick_slip, given, used, noted):
    (models, _, _), said = calls_warnings(pycc.train, stick_slip, STICK_SLIP, "NN",
                                          {**TINY_NN, "activation": given})
    assert models.estimator.activation == used
    assert (len(said) == 1 and f"activation={given!r}" in said[0]) if noted else said == []


def test_activation_not_offered(stick_slip):
    with pytest.raises(ValueError, match=r"activation='selu' is not offered; use one of .*"
                                         r"'leaky_relu'"):
        pycc.train(stick_slip, STICK_SLIP, "NN", {"activation": "selu"})
    with pytest.raises(ValueError, match="one same activation"):
        pycc.train(stick_slip, STICK_SLIP, "NN", {"activation": ["relu", "tanh"]})


# -- one warning per call ---------------------------------------------------------------------
def test_several_ignorable_keys_make_one_warning(stick_slip):
    constraints = [{"constraint": "f1 odd", "penalty": 1e-1, "eval": "array",
                    "Nval_array": 100},
                   {"constraint": "f2(0)=0", "penalty": 1e-2}]
    params = {**TINY_NN, "lr": 1e-4, "scalar_lr": 1e-3, "weight_loss_param": 1e-3,
              "constraints": constraints}
    _, said = calls_warnings(pycc.train, stick_slip, STICK_SLIP, "NN", params)
    assert len(said) == 1
    for key in ("'lr'", "'scalar_lr'", "'weight_loss_param'", "'penalty'", "'eval'",
                "'Nval_array'"):
        assert key in said[0]
    poly = {"n_iter": 2000, "learning_rate": 1e-3, "error_threshold": 1e-8, "scaling": False}
    _, said = calls_warnings(pycc.train, stick_slip, STICK_SLIP, "Poly", poly)
    assert len(said) == 1 and all(f"'{key}'" in said[0] for key in poly)


@pytest.mark.slow
def test_nothing_is_said_for_what_matches(stick_slip):
    _, said = calls_warnings(pycc.train, stick_slip, STICK_SLIP, "Poly",
                             {"scaling": True, "N_order": 5, "fitting_forw_sim": False})
    assert said == []
    _, said = calls_warnings(pycc.train, stick_slip, STICK_SLIP, "SymbR",
                             {**SMALL_SR, "scaling": False})
    assert len(said) <= 1 and not any("scaling" in text for text in said)


@pytest.mark.slow
def test_symbr_scaling_true_is_noted(stick_slip):
    _, said = calls_warnings(pycc.train, stick_slip, STICK_SLIP, "SymbR",
                             {**SMALL_SR, "scaling": True})
    assert len(said) == 1 and "'scaling': True has no effect" in said[0]


@pytest.mark.parametrize("method, key, nearest", [
    ("Poly", "initial_param_gues", "initial_param_guess"),
    ("Poly", "fitting_forw_simm", "fitting_forw_sim"),
    ("Poly", "n_iter_outr", "n_iter_outer"),
    ("NN", "initial_param", "initial_params"),
    ("NN", "eq_weight", "eq_weights"),
])
def test_typo_keys_still_error_with_the_nearest(stick_slip, method, key, nearest):
    with pytest.raises(ValueError, match=f"unknown key '{key}'; did you mean '{nearest}'"):
        pycc.train(stick_slip, STICK_SLIP, method, {key: 1})


def test_typo_keys_of_simulate():
    with pytest.raises(ValueError, match="unknown key 'scalar_param'; did you mean "
                                         "'scalar_params'"):
        lorenz({"scalar_param": {}})
    with pytest.raises(ValueError, match="unknown key 'smooting'; did you mean 'smoothing'"):
        _table_system({"smooting": 0.1})


# -- Poly: print and the post-fine-tuning -----------------------------------------------------
def test_print_poly_coeffs(stick_slip, capsys):
    eqs = ["x1_dot = x2", "x2_dot = F_ext - a1 x2 - f2(x1)"]
    pycc.train(stick_slip, eqs, "Poly", {"N_order": 3, "print_poly_coeffs": True})
    out = capsys.readouterr().out
    assert "a1 = " in out and "f2(x1) = " in out
    pycc.train(stick_slip, eqs, "Poly", {"N_order": 3})
    assert capsys.readouterr().out == ""


def test_post_fine_tuning_runs_the_output_error_stage(example5_df):
    df, t_eval = example5_df
    params = {"learning_rate": 1e-3, "initial_param_guess": [{"a3": 100}], "N_order": 40,
              "n_iter": 4000, "fitting_forw_sim": True, "n_iter_outer": 7,
              "outer_tol": 1e-6, "params_simul": params_simul(t_eval), "eq_weights": [1.0, 1.0]}
    (models, _, coefs), said = calls_warnings(pycc.train, df, PARAMETRIC, "Poly", params)
    estimator = models.estimator
    assert "t" not in df.columns  # the user's frame is left as it was
    assert estimator.fit_mode == "simulation" and estimator.fit_mode_ == "simulation"
    assert estimator.shooting_iterations == 7
    assert estimator.shooting_["nrmse_after"] <= estimator.shooting_["nrmse_before"]
    for name, truth in TRUTH.items():
        assert coefs[name].item() == pytest.approx(truth, rel=1e-2)
    assert len(said) == 1
    for key in ("'learning_rate'", "'n_iter'", "'outer_tol'", "'method'"):
        assert key in said[0]


def test_post_fine_tuning_adds_missing_inputs_from_local_funcs(example5_df):
    df, t_eval = example5_df
    params = {"initial_param_guess": {"a3": 100}, "fitting_forw_sim": True,
              "n_iter_outer": 3, "params_simul": {"t_eval": t_eval,
                                                  "local_funcs": {"F_ext": F_ext}}}
    models, _, coefs = pycc.train(df.drop(columns="F_ext"), PARAMETRIC, "Poly", params)
    assert models.estimator.fit_mode_ == "simulation"
    assert coefs["a4"].item() == pytest.approx(1.0, rel=1e-2)


def test_post_fine_tuning_errors_name_the_culprit(example5_df):
    df, t_eval = example5_df
    base = {"fitting_forw_sim": True, "initial_param_guess": {"a3": 100}}
    with pytest.raises(ValueError, match="needs its times: give df a column 't', or "
                                         "params_simul's 't_eval'"):
        pycc.train(df, PARAMETRIC, "Poly", base)
    with pytest.raises(ValueError, match="t_eval has 999 times but df has 1000 rows"):
        pycc.train(df, PARAMETRIC, "Poly", {**base, "params_simul": {"t_eval": t_eval[1:]}})
    with pytest.raises(ValueError, match=r"local_funcs\['F_ext'\] disagrees with "
                                         r"df\['F_ext'\]"):
        pycc.train(df, PARAMETRIC, "Poly", {**base, "params_simul": {
            "t_eval": t_eval, "local_funcs": {"F_ext": lambda t: 2 * np.cos(t)}}})
    with pytest.raises(ValueError, match=r"params_simul\[1\] gives 't_eval' again"):
        pycc.train(df, PARAMETRIC, "Poly", {**base, "params_simul": [{"t_eval": t_eval},
                                                                     {"t_eval": t_eval}]})
    with pytest.raises(ValueError, match="params_simul has the unknown key 'teval'"):
        pycc.train(df, PARAMETRIC, "Poly", {**base, "params_simul": {"teval": t_eval}})


def test_outer_keys_without_fitting_forw_sim_are_noted(example5_df):
    df, t_eval = example5_df
    (models, _, _), said = calls_warnings(
        pycc.train, df, PARAMETRIC, "Poly",
        {"initial_param_guess": {"a3": 100}, "n_iter_outer": 5,
         "params_simul": {"t_eval": t_eval}})
    assert models.estimator.fit_mode_ == "equation"
    assert len(said) == 1 and "without 'fitting_forw_sim': True" in said[0]


# -- pysr_model ------------------------------------------------------------------------------
def check_pysr_model(entry, name):
    assert isinstance(entry, SymbolicEntry)
    model = entry["pysr_model"]
    assert isinstance(model, ParetoModel)
    best = model.get_best()
    for column in ("equation", "sympy_format", "lambda_format", "complexity", "loss"):
        assert column in best.index
    assert isinstance(best["equation"], str)
    expression = model.sympy()
    assert isinstance(expression, sympy.Expr) and expression == best["sympy_format"]
    assert expression.free_symbols <= {sympy.Symbol("x0")}
    front = model.equations_
    assert {"complexity", "loss", "equation", "sympy_format", "lambda_format",
            "score"} <= set(front.columns)
    assert front["complexity"].is_monotonic_increasing
    x = np.linspace(*entry.domain, 7)
    assert np.allclose(best["lambda_format"](x), entry(x))
    assert np.allclose(best["lambda_format"](x[:, None]), entry(x))
    assert np.allclose(model.predict(x), entry["func"](x))
    for k in range(len(front)):  # every expression of the front evaluates
        assert np.isfinite(front["lambda_format"].iloc[k](x)).all()
    assert np.allclose(entry(x), entry["func"](x))
    assert isinstance(entry["sympy"], sympy.Expr) and isinstance(entry["expr"], str)
    assert name in repr(model) and ">>>>" in str(model)
    assert set(entry.keys()) == {"expr", "func", "sympy", "pysr_model"}
    assert "pysr_model" in entry and dict(entry)["expr"] == entry["expr"]
    with pytest.raises(KeyError, match="'model'"):
        entry["model"]


@pytest.mark.slow
def test_pysr_model_of_train_and_post_processing(stick_slip):
    with pytest.warns(UserWarning, match="PySR is not installed"):
        models, evals, coefs = pycc.train(stick_slip, STICK_SLIP, "SymbR", SMALL_SR)
    for name in ("f1", "f2"):
        check_pysr_model(models[name], name)
    with pytest.warns(UserWarning, match="PySR is not installed"):
        models_sr, _ = pycc.post_processing(STICK_SLIP, "SymbR", {
            "evals": evals, "pysr": SMALL_SR["pysr"], "plot": False, "random_state": 0})
    for name in ("f1", "f2"):
        check_pysr_model(models_sr[name], name)
    # the entries simulate, pickle and print their expressions
    common = {"obtained_coefs": coefs, "local_funcs": {"F_ext": F_ext}, "t_span": (0, 5),
              "y0": [0.0, 0.0], "t_eval": np.linspace(0, 5, 101)}
    for found in (models, models_sr):
        sol, _ = pycc.simulate(STICK_SLIP, "SymbR", {"models": found, **common})
        assert sol.success
        copy = pickle.loads(pickle.dumps(found))
        x = np.linspace(-0.5, 0.5, 5)
        assert np.allclose(copy["f1"](x), found["f1"](x))
        assert copy["f1"]["pysr_model"].get_best()["equation"] == \
            found["f1"]["pysr_model"].get_best()["equation"]


@pytest.mark.parametrize("params, message", [
    ({"N_order": "five"}, r"'N_order' must be a whole number of at least 0, got 'five'"),
    ({"N_order": 2.7}, r"'N_order' must be a whole number of at least 0, got 2.7"),
    ({"N_order": float("nan")}, r"'N_order' must be a whole number"),
    ({"N_order": True}, r"'N_order' must be a whole number"),
])
def test_paper_params_of_the_wrong_kind_are_named_not_truncated(stick_slip, params, message):
    with pytest.raises(ValueError, match=message):
        pycc.train(stick_slip, STICK_SLIP, "Poly", params)


def test_a_whole_float_is_a_whole_number(stick_slip):
    models, _, _ = pycc.train(stick_slip, STICK_SLIP, "Poly", {"N_order": 5.0})
    assert models.estimator.degree == 5
