"""``train``: the paper's identification call, translated onto the estimators."""

from __future__ import annotations

import warnings

import pandas as pd

from ..estimators import NeuralCCRegressor, PolyCCRegressor, SymbolicCCRegressor
from ..skeleton import Skeleton
from ._params import Params
from ._shared import Models, coefficients, evals_of, symbolic_settings

__all__ = ["train"]

REFUSED = {
    "SparseR": "sparse regression over a library of terms is not offered; "
               "method='Poly' fits each curve by least squares on a polynomial basis "
               "(PolyCCRegressor, with alpha for a ridge penalty)",
    "GP": "genetic programming is what method='SymbR' runs (offline, with pyoperon)",
}

NO_GAUSS_NEWTON = ("PolyCCRegressor solves its least-squares problem directly, without "
                   "Gauss-Newton steps")
NN_KEYS = {"neurons": 100, "layers": 3, "lr": 1e-3, "epochs": 1000, "error_threshold": 1e-6,
           "device": "automatic", "n_eval": 200, "constraints": None, "extrapolation": None,
           "optimizer": "lbfgs", "activation": "tanh", "random_state": None}
NN_IGNORED = {
    "weight_loss_param": "the parameters a_i are not penalised",
    "eq_weights": "each equation is weighted by the scale of its measured left-hand side",
}
POLY_KEYS = {"N_order": 10, "n_eval": 200, "constraints": None}
POLY_IGNORED = {"n_iter": NO_GAUSS_NEWTON, "learning_rate": NO_GAUSS_NEWTON,
                "error_threshold": NO_GAUSS_NEWTON,
                "scaling": "the polynomial basis is always scaled to the data range",
                "eq_weights": NN_IGNORED["eq_weights"]}
SYMBR_KEYS = {"pysr": None, "max_iterations": 15, "tol": 1e-10, "N_fit_points": 200,
              "n_eval": 200, "constraints": None, "random_state": None}
SYMBR_IGNORED = {"scaling": "the search sees the curve's argument as it is"}
DEVICES = {"cpu": "cpu", "cuda": "cuda", "gpu": "cuda", "automatic": "auto", "auto": "auto"}


def _constraints(given, where: str):
    """The paper's constraint dicts as our constraints (extra per-constraint keys warn)."""
    if given is None:
        return None
    out, extras = [], set()
    for item in given:
        if isinstance(item, dict) and "constraint" in item:
            extras |= set(item) - {"constraint"}
            out.append(item["constraint"])
        else:
            out.append(item)
    if extras:
        warnings.warn(f"{where}: constraints hold exactly here, so the per-constraint keys "
                      f"{sorted(extras)} are not used", UserWarning, stacklevel=4)
    return out


def _neural(equations, params: Params, where: str):
    from skorch.callbacks import Callback

    device = params["device"]
    if device not in DEVICES:
        raise ValueError(f"{where}: device={device!r} is not supported; use one of "
                         f"{sorted(DEVICES)}")

    class StopBelow(Callback):
        """Stop when the training loss falls below the paper's ``error_threshold``."""

        def __init__(self, threshold: float) -> None:
            self.threshold = threshold

        def __repr__(self) -> str:
            return f"StopBelow(threshold={self.threshold!r})"

        def on_epoch_end(self, net, **kwargs):
            if net.history[-1, "train_loss"] < self.threshold:
                raise KeyboardInterrupt  # skorch ends training on this

    layers = int(params["layers"])
    callbacks = [StopBelow(float(params["error_threshold"]))] if params.given(
        "error_threshold") else None
    lbfgs = params["optimizer"] == "lbfgs"
    if lbfgs and params.supplied("lr"):
        warnings.warn(f"{where}: 'lr' is the step of Adam, which the published package "
                      "trains with; here the networks are trained by L-BFGS (with its own "
                      "line search and early stopping), which does not use it. Pass "
                      "'optimizer': 'adam' to train with Adam and this lr", UserWarning,
                      stacklevel=4)
    return NeuralCCRegressor(
        equations=equations, constraints=_constraints(params["constraints"], where),
        hidden_layer_sizes=(int(params["neurons"]),) * layers, activation=params["activation"],
        optimizer=params["optimizer"], lr=None if lbfgs else float(params["lr"]),
        max_epochs=int(params["epochs"]), early_stopping=lbfgs,
        extrapolation=params["extrapolation"] or "linear", device=DEVICES[device],
        callbacks=callbacks, random_state=params["random_state"])


def _estimator(equations, method: str, params, where: str):
    if method == "NN":
        read = Params(params, NN_KEYS, where, NN_IGNORED)
        return _neural(equations, read, where), read
    if method == "Poly":
        read = Params(params, POLY_KEYS, where, POLY_IGNORED)
        return PolyCCRegressor(equations=equations,
                               constraints=_constraints(read["constraints"], where),
                               degree=int(read["N_order"])), read
    if method == "SymbR":
        read = Params(params, SYMBR_KEYS, where, SYMBR_IGNORED)
        settings = symbolic_settings(read["pysr"], where)
        return SymbolicCCRegressor(
            equations=equations, constraints=_constraints(read["constraints"], where),
            max_iterations=int(read["max_iterations"]), tol=float(read["tol"]),
            n_fit_points=int(read["N_fit_points"]), random_state=read["random_state"],
            **settings), read
    if method in REFUSED:
        raise ValueError(f"train(method={method!r}): {REFUSED[method]}")
    raise ValueError(f"train: method must be 'NN', 'Poly' or 'SymbR', got {method!r}")


def train(df: pd.DataFrame, equations, method: str = "NN", params: dict | None = None):
    """Identify the curves and parameters of ``equations`` from ``df`` (the paper's ``train``).

    Parameters
    ----------
    df : DataFrame
        The measurements: states, inputs and, when measured, the
        derivatives ``NAME_dot``. Without derivatives, ``df`` needs the time
        column ``t`` and they are estimated.
    equations : list of str
        The skeleton.
    method : {"NN", "Poly", "SymbR"}
        :class:`~sklearn_pycc.NeuralCCRegressor` (the paper's recipe: ReLU
        networks trained by Adam), :class:`~sklearn_pycc.PolyCCRegressor` or
        :class:`~sklearn_pycc.SymbolicCCRegressor`.
    params : dict, optional
        The paper's keys. NN: ``neurons``, ``layers``, ``lr``, ``epochs``,
        ``error_threshold``, ``device``, ``n_eval``, ``constraints``,
        ``extrapolation``, and ``optimizer``, ``activation``, ``random_state``.
        The networks have ``layers`` hidden layers of ``neurons``; they are
        trained by L-BFGS with early stopping (an epoch is about 20
        iterations), which reaches in tens of epochs what Adam reaches in
        thousands; ``'optimizer': 'adam'`` trains with Adam and ``lr``. Poly:
        ``N_order``, ``n_eval``, ``constraints``. SymbR: ``pysr``,
        ``max_iterations``, ``tol``, ``N_fit_points``, ``n_eval``,
        ``constraints``, ``random_state``. Keys kept for compatibility that
        mean nothing here warn; an unknown key is an error naming the
        nearest known one.

    Returns
    -------
    models : Models
        ``{"f1": curve, ...}``; ``models.estimator`` is the fitted estimator.
    evals : list of ndarray
        ``[x_f1, f1, x_f2, f2, ...]`` on ``n_eval`` points, in the order of
        the curves' names.
    obtained_coefs : dict
        ``{"a1": value, ...}`` as numpy scalars.
    """
    where = f"train(method={method!r})"
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{where}: df must be a pandas DataFrame, got {type(df).__name__}")
    skeleton = Skeleton(equations)
    estimator, read = _estimator(list(equations), method, params, where)
    derivatives = skeleton.derivatives
    present = [name for name in derivatives if name in df.columns]
    if present and len(present) < len(derivatives):
        missing = [name for name in derivatives if name not in present]
        raise ValueError(f"{where}: df has the derivative column(s) {present} but not "
                         f"{missing}; give every derivative, or none (they are then "
                         "estimated from the time column 't')")
    y = df[derivatives] if present else None
    X = df[[c for c in df.columns if c not in present]]
    estimator.fit(X, y)
    curves = {name: estimator.functions_[name] for name in estimator.skeleton_.functions}
    return (Models(curves, estimator), evals_of(estimator, int(read["n_eval"])),
            coefficients(estimator))
