"""``train``: the paper's identification call, translated onto the estimators."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import pandas as pd

from ..backends.neural.activations import ACTIVATIONS
from ..estimators import NeuralCCRegressor, PolyCCRegressor, SymbolicCCRegressor
from ..estimators.base import check_equation_weights
from ..skeleton import Skeleton
from ._fine_tuning import post_fine_tuning
from ._params import Params
from ._shared import Models, coefficients, equation_list, evals_of, symbolic_settings
from ._symbolic import symbolic_entries

__all__ = ["train"]

REFUSED = {
    "SparseR": "sparse regression over a library of terms is not offered; "
               "method='Poly' fits each curve by least squares on a polynomial basis "
               "(PolyCCRegressor, with alpha for a ridge penalty)",
    "GP": "genetic programming is what method='SymbR' runs (offline, with pyoperon)",
}
#: other names of the methods
POLY_METHODS = ("Poly", "Poly_linear")

NO_GAUSS_NEWTON = ("the coefficients are solved by linear least squares, and parameters "
                   "inside nonlinear terms by variable projection: there are no "
                   "Gauss-Newton steps to count, scale or stop")
#: keys every method reads
COMMON = {"n_eval": 200, "constraints": None, "initial_params": None,
          "initial_param_guess": None}
NN_KEYS = {**COMMON, "neurons": 100, "layers": 3, "lr": 1e-3, "epochs": 1000,
           "error_threshold": 1e-6, "device": "automatic", "extrapolation": None,
           "optimizer": "lbfgs", "activation": "tanh", "eq_weights": None,
           "random_state": None}
NN_IGNORED = {
    "weight_loss_param": "the parameters a_i are not penalised: the equations alone "
                         "decide their size",
    "scalar_lr": "one optimizer trains the networks and the parameters a_i together, "
                 "with 'lr'",
}
POLY_KEYS = {**COMMON, "N_order": 10, "scaling": True, "eq_weights": None,
             "print_poly_coeffs": False, "fitting_forw_sim": False, "n_iter_outer": None,
             "outer_tol": None, "params_simul": None}
POLY_IGNORED = {"n_iter": NO_GAUSS_NEWTON, "learning_rate": NO_GAUSS_NEWTON,
                "error_threshold": NO_GAUSS_NEWTON}
SYMBR_KEYS = {**COMMON, "pysr": None, "max_iterations": 15, "tol": 1e-10,
              "N_fit_points": 200, "scaling": False, "random_state": None}
#: the published package's device names -> the torch devices they search, in order
DEVICES = {"cpu": (), "cuda": ("cuda",), "xpu": ("xpu",), "gpu": ("cuda", "xpu"),
           "automatic": None, "auto": None}
#: activations of the published package that are not offered -> the nearest that is
ACTIVATION_STAND_INS = {
    "rrelu": ("leaky_relu", "its random slope below zero would make the curves differ "
                            "from one evaluation to the next during training"),
}
# -- keys shared by the methods --------------------------------------------------------
def _constraints(read: Params):
    """The paper's constraint dicts as our constraints (their extra keys noted once)."""
    given = read["constraints"]
    if given is None:
        return None
    if isinstance(given, (str, Mapping)):
        given = [given]
    out, extras = [], set()
    for item in given:
        if isinstance(item, Mapping) and "constraint" in item:
            extras |= set(item) - {"constraint"}
            out.append(item["constraint"])
        else:
            out.append(item)
    if extras:
        read.note(f"the per-constraint keys {sorted(extras)} have no effect: "
                  "constraints hold exactly (by construction), not as weighted penalties")
    return out


def _param_init(read: Params, skeleton: Skeleton) -> dict | None:
    """``initial_params`` / ``initial_param_guess``: a dict, or a list of one-key dicts."""
    out: dict[str, float] = {}
    for key in ("initial_params", "initial_param_guess"):
        value = read[key]
        if value is None:
            continue
        items = [value] if isinstance(value, Mapping) else value
        if isinstance(items, str) or not isinstance(items, Sequence):
            raise TypeError(f"{read.where}: {key} must be a dict {{'a1': value}} or a list "
                            f"of such dicts, got {type(value).__name__}")
        for position, item in enumerate(items):
            if not isinstance(item, Mapping):
                raise TypeError(f"{read.where}: {key}[{position}] must be a dict "
                                f"{{'a1': value}}, got {type(item).__name__}")
            for name, number in item.items():
                if name not in skeleton.params:
                    raise ValueError(f"{read.where}: {key} gives {name!r}, which is not a "
                                     f"parameter of the equations (they have "
                                     f"{', '.join(skeleton.params) or 'none'})")
                number = float(number)
                if name in out and out[name] != number:
                    raise ValueError(f"{read.where}: {key} starts {name} at {number!r}, but "
                                     f"it was already started at {out[name]!r}")
                out[name] = number
    return out or None


def _equation_weights(read: Params, skeleton: Skeleton) -> dict:
    """``eq_weights`` as the estimator's ``equation_weights`` (nothing when not given)."""
    if read["eq_weights"] is None:
        return {}
    try:
        weights = check_equation_weights(read["eq_weights"], skeleton,
                                         name="params['eq_weights']")
    except ValueError as exc:
        raise ValueError(f"{read.where}: {exc}") from None
    return {"equation_weights": list(weights)}


# -- NN ----------------------------------------------------------------------------------
def _device(read: Params) -> str:
    """The torch device for the published package's ``device`` (falling back to the CPU)."""
    device = read["device"]
    kind = device.split(":")[0] if isinstance(device, str) else device
    if kind not in DEVICES:
        raise ValueError(f"{read.where}: device={device!r} is not a device; use one of "
                         f"{sorted(DEVICES)}")
    search = DEVICES[kind]
    if search is None:
        return "auto"  # the estimator takes cuda, then xpu, then the CPU
    if not search:
        return "cpu"
    import torch

    for candidate in search:
        backend = getattr(torch, candidate, None)
        if backend is not None and backend.is_available():
            return device if kind == candidate else candidate
    read.note(f"device={device!r}: torch finds no {' or '.join(search)} device here, so "
              "the networks train on the CPU")
    return "cpu"


def _activation(read: Params) -> str:
    """One activation name NeuralCCRegressor offers, for the published package's names."""
    value = read["activation"]
    if not isinstance(value, str):
        names = {str(name) for name in value} if isinstance(value, Sequence) else {value}
        if len(names) != 1:
            raise ValueError(f"{read.where}: activation {value!r}: every hidden layer uses "
                             "one same activation here; give one name")
        value = names.pop()
    name = str(value).lower()
    if name in ACTIVATIONS:
        return name
    if name in ACTIVATION_STAND_INS:
        stand_in, why = ACTIVATION_STAND_INS[name]
        read.note(f"activation={value!r} is not offered, so {stand_in!r} is used ({why})")
        return stand_in
    raise ValueError(f"{read.where}: activation={value!r} is not offered; use one of "
                     f"{sorted([*ACTIVATIONS, *ACTIVATION_STAND_INS])}")


def _neural(equations, skeleton: Skeleton, read: Params) -> NeuralCCRegressor:
    from skorch.callbacks import Callback

    class StopBelow(Callback):
        """Stop when the training loss falls below the paper's ``error_threshold``."""

        def __init__(self, threshold: float) -> None:
            self.threshold = threshold

        def __repr__(self) -> str:
            return f"StopBelow(threshold={self.threshold!r})"

        def on_epoch_end(self, net, **kwargs):
            if net.history[-1, "train_loss"] < self.threshold:
                raise KeyboardInterrupt  # skorch ends training on this

    layers = read.integer("layers", 1)
    callbacks = [StopBelow(read.number("error_threshold"))] if read.given(
        "error_threshold") else None
    lbfgs = read["optimizer"] == "lbfgs"
    if lbfgs and read.supplied("lr"):
        read.note("'lr' has no effect under the default optimizer, L-BFGS, which finds its "
                  "own steps (the published package trains by Adam: 'optimizer': 'adam' "
                  "trains with Adam and this lr)")
    return NeuralCCRegressor(
        equations=equations, constraints=_constraints(read),
        hidden_layer_sizes=(read.integer("neurons", 1),) * layers, activation=_activation(read),
        optimizer=read["optimizer"], lr=None if lbfgs else read.number("lr", positive=True),
        max_epochs=read.integer("epochs", 1), early_stopping=lbfgs,
        extrapolation=read["extrapolation"] or "linear", device=_device(read),
        callbacks=callbacks, param_init=_param_init(read, skeleton),
        random_state=read["random_state"], **_equation_weights(read, skeleton))


# -- Poly ------------------------------------------------------------------------------
def _poly(equations, skeleton: Skeleton, read: Params, df: pd.DataFrame):
    if read.supplied("scaling") and not read["scaling"]:
        read.note("'scaling': False has no effect: the polynomial basis is always "
                  "scaled to the range of its argument, which keeps high orders "
                  "well conditioned")
    settings, df = post_fine_tuning(read, df, skeleton)
    estimator = PolyCCRegressor(
        equations=equations, constraints=_constraints(read), degree=read.integer("N_order"),
        param_init=_param_init(read, skeleton), **_equation_weights(read, skeleton),
        **settings)
    return estimator, df


def _print_coefficients(estimator, where: str) -> None:
    """What ``print_poly_coeffs`` asks for: the fitted parameters and curves."""
    print(f"{where}: the fitted model")
    for name, value in estimator.params_.items():
        print(f"  {name} = {value:.6g}")
    for line in estimator.equations():
        print(f"  {line}")


# -- SymbR -----------------------------------------------------------------------------
def _symbolic(equations, skeleton: Skeleton, read: Params) -> SymbolicCCRegressor:
    if read["scaling"]:
        read.note("'scaling': True has no effect: the search sees each curve's "
                  "argument as it is")
    settings = symbolic_settings(read["pysr"], read)
    return SymbolicCCRegressor(
        equations=equations, constraints=_constraints(read),
        max_iterations=read.integer("max_iterations", 1), tol=read.number("tol", positive=True),
        n_fit_points=read.integer("N_fit_points", 2), param_init=_param_init(read, skeleton),
        random_state=read["random_state"], **settings)


def _estimator(equations, skeleton: Skeleton, method: str, params, df: pd.DataFrame):
    """The estimator for ``method``, its checked params and the data it fits."""
    where = f"train(method={method!r})"
    if method == "NN":
        read = Params(params, NN_KEYS, where, NN_IGNORED)
        return _neural(equations, skeleton, read), read, df
    if method in POLY_METHODS:
        read = Params(params, POLY_KEYS, where, POLY_IGNORED)
        estimator, df = _poly(equations, skeleton, read, df)
        return estimator, read, df
    if method == "SymbR":
        read = Params(params, SYMBR_KEYS, where)
        return _symbolic(equations, skeleton, read), read, df
    if method in REFUSED:
        raise ValueError(f"train(method={method!r}): {REFUSED[method]}")
    raise ValueError(f"train: method must be 'NN', 'Poly', 'Poly_linear' or 'SymbR', "
                     f"got {method!r}")


def _split(df: pd.DataFrame, skeleton: Skeleton, where: str):
    """``X`` and the measured derivatives ``y`` (None: they are estimated)."""
    derivatives = skeleton.derivatives
    present = [name for name in derivatives if name in df.columns]
    if present and len(present) < len(derivatives):
        missing = [name for name in derivatives if name not in present]
        raise ValueError(f"{where}: df has the derivative column(s) {present} but not "
                         f"{missing}; give every derivative, or none (they are then "
                         "estimated from the time column 't')")
    y = df[derivatives] if present else None
    return df[[c for c in df.columns if c not in present]], y


def train(df: pd.DataFrame, equations, method: str = "NN", params: dict | None = None):
    """Identify the curves and parameters of ``equations`` from ``df`` (the paper's ``train``).

    Parameters
    ----------
    df : DataFrame
        The measurements: states, inputs and, when measured, the
        derivatives ``NAME_dot``. Without derivatives, ``df`` needs the time
        column ``t`` and they are estimated.
    equations : list of str or str
        The skeleton. One string is one equation (one per line when it has
        several lines).
    method : {"NN", "Poly", "Poly_linear", "SymbR"}
        :class:`~sklearn_pycc.NeuralCCRegressor`,
        :class:`~sklearn_pycc.PolyCCRegressor` or
        :class:`~sklearn_pycc.SymbolicCCRegressor`. ``"Poly_linear"`` is
        ``"Poly"``: the published package's variant that solves the
        polynomial coefficients by linear least squares is what
        PolyCCRegressor always does (parameters inside nonlinear terms are
        found by variable projection around that linear solve).
    params : dict, optional
        The paper's keys; :ref:`migration` lists each one and what it
        becomes. NN: ``neurons`` and ``layers`` (the hidden layers),
        ``epochs``, ``error_threshold`` (stops training below that loss),
        ``device`` (``'automatic'``: cuda, xpu, then the CPU; ``'gpu'``:
        cuda, then xpu; a device torch cannot find falls back to the CPU),
        ``activation`` (default tanh), ``extrapolation``, ``optimizer``
        (``'lbfgs'``, with which an epoch is about 20 iterations; ``'adam'``
        trains with ``lr``), ``random_state``. Poly (and Poly_linear):
        ``N_order``, ``print_poly_coeffs`` and the post-fine-tuning keys:
        ``'fitting_forw_sim': True`` refines the fit by output error
        (``fit_mode='simulation'``), ``n_iter_outer`` its iterations,
        ``params_simul`` (a dict or a list of one-key dicts) gives the times
        ``t_eval`` of the rows of ``df`` when it has no column ``t`` and
        inputs (``local_funcs``) it lacks. SymbR: ``pysr``,
        ``max_iterations``, ``tol``, ``N_fit_points``, ``random_state``.
        Every method: ``n_eval``, ``constraints`` (the paper's dicts),
        ``initial_params`` or ``initial_param_guess`` (a dict, or a list of
        one-key dicts: the starting values ``param_init``); NN and Poly:
        ``eq_weights`` (``equation_weights``, one per equation). Keys kept
        for compatibility that mean nothing here are named, with the
        reason, in one warning per call; an unknown key is an error naming
        the nearest known one.

    Returns
    -------
    models : Models
        ``{"f1": curve, ...}``; ``models.estimator`` is the fitted estimator.
        For SymbR each curve is a
        :class:`~sklearn_pycc.pycc.SymbolicEntry`: callable, and answering
        ``["expr"]``, ``["func"]``, ``["sympy"]`` and ``["pysr_model"]``.
    evals : list of ndarray
        ``[x_f1, f1, x_f2, f2, ...]`` on ``n_eval`` points, in the order of
        the curves' names.
    obtained_coefs : dict
        ``{"a1": value, ...}`` as numpy scalars.
    """
    where = f"train(method={method!r})"
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{where}: df must be a pandas DataFrame, got {type(df).__name__}")
    equations = equation_list(equations, where)
    skeleton = Skeleton(equations)
    estimator, read, df = _estimator(equations, skeleton, method, params, df)
    X, y = _split(df, skeleton, where)
    read.warn()
    estimator.fit(X, y)
    if read.get("print_poly_coeffs"):
        _print_coefficients(estimator, where)
    if method == "SymbR":
        curves = symbolic_entries(estimator)
    else:
        curves = {name: estimator.functions_[name] for name in estimator.skeleton_.functions}
    return (Models(curves, estimator), evals_of(estimator, read.integer("n_eval", 2)),
            coefficients(estimator))
