"""Neural backend: each curve is a small MLP trained through skorch."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from numbers import Integral, Real

import numpy as np
from scipy.linalg import null_space
from sklearn.utils._param_validation import Interval, StrOptions

from .._utils.randomness import seeds
from .._utils.threads import torch_threads
from ..backends.neural.activations import ACTIVATIONS
from ..backends.neural.numpy_mlp import EXTRAPOLATIONS, NumpyCurve
from ..fitting.numbers import Numbers, parameters_only
from ..fitting.problem import FitResult, Problem, active_residuals
from ..skeleton.curves import ZeroCurve
from .backend import Backend
from .base import RANDOM_STATES, RESAMPLING, CCRegressor
from .poly import polynomial_stand_in

__all__ = ["NeuralBackend", "NeuralCCRegressor"]

#: optimizer name -> (torch.optim class name, default learning rate)
OPTIMIZERS: dict[str, tuple[str, float]] = {
    "lbfgs": ("LBFGS", 1.0),
    "adam": ("Adam", 1e-2),
    "adamw": ("AdamW", 1e-2),
    "rmsprop": ("RMSprop", 1e-3),
    "sgd": ("SGD", 1e-2),
}
DEVICES = ("cpu", "cuda", "xpu", "auto")
#: full-batch training on more rows than this starts on this many, evenly spread
COARSE_ROWS = 10_000
DTYPES = ("float32", "float64")
CONSTRAINT_MODES = ("exact", "penalty")
#: a last-layer direction the filter moves changes its curve by at least this share of the
#: strongest one's change
LAST_LAYER_RANK = 1e-3


def _int_or_none(value) -> int | None:
    return None if value is None else int(value)


def resolve_device(device) -> str:
    """Check ``device`` and turn ``"auto"`` into the best available one."""
    import torch

    if not isinstance(device, str) or device.split(":")[0] not in DEVICES:
        raise ValueError(f"device must be one of {DEVICES} (or 'cuda:N'), got {device!r}")
    kind = device.split(":")[0]
    has_xpu = hasattr(torch, "xpu") and torch.xpu.is_available()
    if kind == "auto":
        if torch.cuda.is_available():
            return "cuda"
        return "xpu" if has_xpu else "cpu"
    if kind == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device={device!r}, but torch finds no CUDA GPU "
                         "(torch.cuda.is_available() is False); use 'cpu' or 'auto'")
    if kind == "xpu" and not has_xpu:
        raise ValueError(f"device={device!r}, but torch finds no XPU "
                         "(torch.xpu is missing or unavailable); use 'cpu' or 'auto'")
    return device


class NeuralBackend(Backend):
    """Curves as small multilayer perceptrons, trained with the parameters through skorch.

    The settings are :class:`NeuralCCRegressor`'s, with the same meanings.
    """

    output_error = True
    #: every network continues its edge slope beyond the data, so their spread there
    #: says nothing: the ensemble's band stops at the measured range
    bands_beyond_data = False
    #: quasi-Newton iterations per epoch with optimizer="lbfgs" (torch's default)
    lbfgs_iterations = 20
    #: curvature pairs L-BFGS keeps (torch's default)
    lbfgs_history = 100

    settings = ("hidden_layer_sizes", "activation", "optimizer", "lr", "max_epochs",
                "batch_size", "early_stopping", "patience", "tol", "curve_tol",
                "validation_fraction", "constraint_mode", "constraint_weight", "param_init",
                "extrapolation", "dtype", "device", "n_threads", "callbacks",
                "shooting_start_epochs", "random_state", "verbose")

    # -- hyperparameter checks -----------------------------------------------------
    def _hidden(self) -> tuple[int, ...]:
        sizes = self.hidden_layer_sizes
        if isinstance(sizes, Integral) and not isinstance(sizes, bool):
            sizes = (sizes,)
        try:
            sizes = tuple(sizes)
        except TypeError:
            raise ValueError("hidden_layer_sizes must be a tuple of positive integers, "
                             f"got {self.hidden_layer_sizes!r}") from None
        if not sizes:
            raise ValueError("hidden_layer_sizes must name at least one hidden layer, got ()")
        for k, size in enumerate(sizes):
            if not isinstance(size, Integral) or isinstance(size, bool) or size < 1:
                raise ValueError(
                    f"hidden_layer_sizes must be positive integers; position {k} is "
                    f"{size!r} in {self.hidden_layer_sizes!r}")
        return tuple(int(s) for s in sizes)

    def _optimizer(self):
        import torch

        from ..backends.neural.lbfgs import CompactLBFGS

        if isinstance(self.optimizer, str):
            if self.optimizer not in OPTIMIZERS:
                raise ValueError(f"optimizer must be one of {sorted(OPTIMIZERS)} or a torch "
                                 f"optimizer class, got {self.optimizer!r}")
            name, default_lr = OPTIMIZERS[self.optimizer]
            if self.optimizer == "lbfgs":  # torch's L-BFGS, with a cheaper direction
                return CompactLBFGS, default_lr, True
            return getattr(torch.optim, name), default_lr, False
        if isinstance(self.optimizer, type) and issubclass(self.optimizer, torch.optim.Optimizer):
            lbfgs = issubclass(self.optimizer, torch.optim.LBFGS)
            return self.optimizer, 1.0 if lbfgs else 1e-3, lbfgs
        raise ValueError(f"optimizer must be one of {sorted(OPTIMIZERS)} or a torch optimizer "
                         f"class, got {self.optimizer!r}")

    def _resolved(self) -> dict:
        """The settings in the form training uses (defaults filled in, device found)."""
        checked = {"hidden": self._hidden()}
        checked["optimizer"], default_lr, checked["lbfgs"] = self._optimizer()
        checked["lr"] = float(default_lr if self.lr is None else self.lr)
        checked["max_epochs"] = int(self.max_epochs)
        checked["start_epochs"] = _int_or_none(self.shooting_start_epochs)
        checked["batch_size"] = _int_or_none(self.batch_size)
        checked["patience"] = int(self.patience)
        checked["tol"] = float(self.tol)
        checked["constraint_weight"] = float(self.constraint_weight)
        checked["n_threads"] = _int_or_none(self.n_threads)
        checked["device"] = resolve_device(self.device)
        return checked

    # -- fitting -----------------------------------------------------------------
    def fit(self, problem: Problem) -> FitResult:
        """Train every curve's network and the parameters jointly (skorch)."""
        checked = self._resolved()
        init = problem.starting_values(self.param_init)
        params0 = {a: float(init[a]) if a in init else _inside(problem.bounds.get(a))
                   for a in problem.free_params}
        functions: dict = {name: ZeroCurve() for name in problem.zeroed}
        residuals, weights = active_residuals(problem)
        if not residuals:
            return FitResult(functions, params0, {"history_": [], "n_epochs_": 0,
                                                  "loss_": 0.0, "device_": checked["device"]})
        if problem.fit_mode == "simulation" and checked["start_epochs"] is not None:
            # the output-error stage takes over from a short equation fit
            checked["max_epochs"] = min(checked["max_epochs"], checked["start_epochs"])
        with torch_threads(checked["n_threads"]):
            result = self._train(problem, residuals, weights, params0, checked)
        result.functions.update(functions)
        if problem.covariance and problem.fit_mode == "equation":
            from ..fitting.uncertainty.linearized import linearized_covariance

            features = {f: result.functions[f].features for f in problem.free_functions}
            result.attributes["covariance_"] = linearized_covariance(
                problem, result.functions, result.params, features)
        return result

    def _train(self, problem, residuals, weights, params0, checked):
        import torch

        from ..backends.neural.networks import SkeletonModule
        from ..backends.neural.skorch_net import CurvesSettled, EpochProgress, SkeletonNet

        dtype = getattr(torch, self.dtype)
        device = checked["device"]
        seed = next(seeds(self.random_state))
        slots, columns = problem.environment()
        curves = {f: self._curve_spec(problem, f, params0) for f in problem.free_functions}
        data = np.column_stack(columns)
        X = torch.as_tensor(data, dtype=dtype).to(device)
        y = torch.zeros((X.shape[0], len(residuals)), dtype=dtype, device=device)
        exact = self.constraint_mode == "exact"
        callbacks = []
        if self.early_stopping:
            from skorch.callbacks import EarlyStopping

            monitor = "valid_loss" if self.validation_fraction else "train_loss"
            callbacks.append(("early_stopping", EarlyStopping(
                monitor=monitor, patience=checked["patience"], threshold=checked["tol"],
                threshold_mode="rel", lower_is_better=True,
                sink=print if self.verbose >= 2 else _silent)))
            if checked["lbfgs"] and self.curve_tol > 0:
                # an L-BFGS epoch is many full-batch steps: once the curves stand
                # still from one epoch to the next, the fit has converged
                callbacks.append(("curves_settled", CurvesSettled(self.curve_tol)))
        if self.verbose == 1:
            callbacks.append(("progress", EpochProgress(checked["max_epochs"])))
        for k, callback in enumerate(self.callbacks or []):
            callbacks.append((f"user_{k}", callback))
        train_split = None
        if self.validation_fraction:
            from skorch.dataset import ValidSplit

            train_split = ValidSplit(self.validation_fraction, random_state=seed)
        optimizer_params = {}
        if checked["lbfgs"]:
            optimizer_params = {"optimizer__line_search_fn": "strong_wolfe",
                                "optimizer__max_iter": self.lbfgs_iterations,
                                "optimizer__history_size": self.lbfgs_history}
        if self.verbose < 2:
            optimizer_params["callbacks__print_log"] = None
        shuffle = None
        if checked["batch_size"] is not None:
            shuffle = torch.Generator().manual_seed(seed + 1)
        net = SkeletonNet(
            SkeletonModule,
            module__residuals=residuals, module__weights=weights, module__slots=slots,
            module__curves=curves, module__params=params0,
            module__fixed=problem.fixed_params, module__bounds=problem.bounds,
            module__hidden_layer_sizes=checked["hidden"],
            module__activation=self.activation, module__exact=exact, module__seed=seed,
            module__dtype=dtype,
            criterion=torch.nn.MSELoss,
            optimizer=checked["optimizer"], lr=checked["lr"], max_epochs=checked["max_epochs"],
            batch_size=-1 if checked["batch_size"] is None else checked["batch_size"],
            train_split=train_split, callbacks=callbacks, device=device,
            verbose=1 if self.verbose >= 2 else 0,
            penalty_weight=0.0 if exact else checked["constraint_weight"],
            shuffle_generator=shuffle,
            **optimizer_params,
        )
        n_rows = X.shape[0]
        if checked["batch_size"] is None and n_rows > COARSE_ROWS:
            # a long record: full-batch epochs first on evenly spread rows (neighbours of a
            # long record say nearly the same), then on every row from where they ended
            coarse = torch.as_tensor(np.linspace(0, n_rows - 1, COARSE_ROWS).round()
                                     .astype(np.int64), device=X.device)
            net.fit(X[coarse], y[coarse])
            net.partial_fit(X, y, epochs=max(checked["max_epochs"] - len(net.history), 1))
        else:
            net.fit(X, y)
        module = net.module_
        functions, params = self._export(module, X)
        history = net.history
        loss = float(history[-1, "train_loss"]) if len(history) else float("nan")
        if not np.isfinite(loss):
            raise FloatingPointError(
                "training diverged: the loss is not finite. Lower lr, scale the data, or "
                "give param_init values closer to the truth" + _domain_hint(problem))
        stage = (module, X, checked["n_threads"]) if problem.fit_mode == "simulation" else None
        return FitResult(functions, params, {"history_": history, "n_epochs_": len(history),
                                             "loss_": loss, "device_": device}, stage)

    def _export(self, module, X) -> tuple[dict, dict]:
        ranges = module.record_ranges(X)
        functions = {name: curve.export(ranges[name], self.extrapolation)
                     for name, curve in module.curves.items()}
        bounds = module.params.bounds  # float32 rounding must not step outside a bound
        params = {name: float(np.clip(float(p.detach().cpu()), *bounds[name]))
                  for name, p in module.params.items()}
        return functions, params

    # -- output error ----------------------------------------------------------
    def refine(self, problem: Problem, result: FitResult, plan) -> FitResult:
        """Refine the trained networks by multiple shooting through a torch RK4."""
        from ..backends.neural.torch_shooting import shoot_module

        if result.stage is None:  # nothing was trained: no free curve or parameter
            return FitResult(result.functions, result.params,
                             {**result.attributes, "shooting_": {}})
        module, X, n_threads = result.stage
        with torch_threads(n_threads):
            info = shoot_module(plan, problem, module, plan.iterations, X)
            refined, values = self._export(module, X)
        return FitResult({**result.functions, **refined}, {**result.params, **values},
                         {**result.attributes, "shooting_": info})

    def numbers(self, problem: Problem, result: FitResult) -> Numbers:
        """The free parameters and the curves' last layers as one vector.

        Near the fitted networks a curve changes mostly through its last
        layer, in which it is linear (its last hidden layer's outputs are the
        basis); the inner layers keep what training drew. The last layers
        move along the few directions that change the curve
        (:func:`_last_layer_directions`), in the null space of the point
        constraints (which then hold exactly); a monotone curve is held as
        training shaped it. The
        labelled numbers are the parameters alone, as ``covariance_`` names
        them for every neural fit: the curves are nuisances whose freedom
        their errors account for.
        """
        names = [f for f in problem.free_functions
                 if isinstance(result.functions.get(f), NumpyCurve)
                 and problem.monotone(f) is None]
        if not names:
            return parameters_only(problem, result)
        free_params = problem.free_params
        fixed = dict(problem.fixed_params)
        pieces = []  # (name, its fitted network, the directions its last layer moves in)
        for name in names:
            curve = result.functions[name]
            pieces.append((name, curve, _last_layer_directions(curve, problem.points(name))))
        p = len(free_params)
        sizes = [d.shape[1] for *_, d in pieces]

        def unpack(theta):
            values = {**fixed, **dict(zip(free_params, (float(v) for v in theta[:p])))}
            curves, offset = dict(result.functions), p
            for (name, curve, directions), size in zip(pieces, sizes):
                curves[name] = curve.with_last_layer(directions @ theta[offset:offset + size])
                offset += size
            return values, curves

        def system_for(theta):
            values, curves = unpack(theta)
            return problem.skeleton.compile(curves, values)

        def result_for(theta) -> FitResult:
            values, curves = unpack(theta)
            kept = {k: v for k, v in result.attributes.items() if k != "covariance_"}
            return FitResult(curves, {**result.params, **{a: values[a] for a in free_params}},
                             kept)

        bounds = problem.bounds
        # a direction moves its curve by its number's size (root mean square over the
        # domain): typically a share of the curve's own
        typical = np.concatenate([np.abs([result.params[a] for a in free_params])] + [
            np.full(size, np.sqrt(np.mean(np.square(curve(np.linspace(*curve.domain, 101))))))
            for (_, curve, _), size in zip(pieces, sizes)])
        total = p + sum(sizes)
        return Numbers(
            theta0=np.concatenate([[result.params[a] for a in free_params], np.zeros(sum(sizes))]),
            low=np.concatenate([[bounds.get(a, (-np.inf, np.inf))[0] for a in free_params],
                                np.full(sum(sizes), -np.inf)]),
            high=np.concatenate([[bounds.get(a, (-np.inf, np.inf))[1] for a in free_params],
                                 np.full(sum(sizes), np.inf)]),
            system_for=system_for,
            result_for=result_for, labels=list(free_params),
            to_labels=np.eye(p, total), typical=typical,
            held=[f for f in problem.free_functions if f not in names])

    def _curve_spec(self, problem: Problem, name: str, params: Mapping[str, float]) -> dict:
        """Input scaling and constraints of one curve's network."""
        parity = problem.parity(name)
        values = problem.argument_values(name, {**problem.fixed_params, **params})
        if values.size:
            lo, hi = float(values.min()), float(values.max())
        else:
            lo, hi = -1.0, 1.0
        if parity:
            center, scale = 0.0, max(abs(lo), abs(hi))
        else:
            center, scale = (lo + hi) / 2.0, (hi - lo) / 2.0
        if not np.isfinite(scale) or scale <= 0:
            scale = max(abs(center), 1.0)
        return {"center": center, "scale": scale, "parity": parity,
                "points": problem.points(name), "monotone": problem.monotone(name)}

    def curve_text(self, curve, variable: str, precision: int) -> str:
        """The network's shape: ``MLP(x2; hidden=(16, 16), activation=tanh)``."""
        if not isinstance(curve, NumpyCurve):
            return super().curve_text(curve, variable, precision)
        sizes = ", ".join(str(w.shape[0]) for w, _ in curve.layers[:-1])
        text = f"MLP({variable}; hidden=({sizes}), activation={curve.activation})"
        if curve.parity:
            text += f", {curve.parity}"
        return text


class NeuralCCRegressor(CCRegressor):
    """Characteristic curves as small neural networks (NN-CC), trained with skorch.

    Every unknown curve ``f_i`` is a multilayer perceptron of its (scaled)
    argument; unknown scalars ``a_i`` are trained jointly as torch
    parameters. The skeleton is compiled once from its parsed tree into a
    torch module returning the residual of each equation, scaled by the
    inverse RMS of its measured side; skorch minimises their mean square.
    Constraints hold by construction: an odd curve is ``(g(x) - g(-x)) / 2``,
    an even one ``(g(x) + g(-x)) / 2``, and point values are imposed by a
    low-order polynomial correction that respects the parity. After ``fit``
    the networks are exported to numpy, so ``predict`` and ``simulate`` never
    call torch.

    Parameters
    ----------
    equations : list of str or Skeleton
        The structural skeleton. After ``fit``, ``model.equations()`` returns
        the fitted model written out (:meth:`~CCRegressor.equations_text`).
    constraints : list of str or dict, optional
        ``"f1 odd"``, ``"f1 even"``, ``"f2(0)=0"``, ...
    hidden_layer_sizes : tuple of int, default=(16, 16)
        Hidden layers of each curve's network.
    activation : {"tanh", "relu", "leaky_relu", "silu", "elu", "softplus", "sigmoid", "gelu"}, \
default="tanh"
        Activation of the hidden layers.
    optimizer : {"lbfgs", "adam", "adamw", "rmsprop", "sgd"} or torch optimizer class, \
default="lbfgs"
        ``"lbfgs"`` runs up to 20 quasi-Newton iterations with a strong Wolfe
        line search per epoch (torch's L-BFGS, its direction found in the
        compact form: a few matrix products instead of hundreds of small
        vector operations); on these small full-batch problems it converges
        in far less time than first-order methods. Use
        a first-order optimizer (with more epochs and patience) for
        minibatches.
    lr : float, optional
        Learning rate; default 1.0 for lbfgs, 1e-2 for adam/adamw/sgd,
        1e-3 for rmsprop.
    max_epochs : int, default=100
        Maximum number of epochs (the paper's ``epochs``; with Adam, think
        in thousands).
    batch_size : int, optional
        Minibatch size; None trains on the full batch. A full batch of more
        than :data:`COARSE_ROWS` (10,000) rows starts on that many, evenly
        spread over the record, and goes on over every row from where they
        left off (``max_epochs`` in all, at least one over every row): the
        neighbours of a long record say nearly the same, and the epochs that
        only find the curves' shape cost a tenth as much.
    early_stopping : bool, default=True
        Stop when the monitored loss has not improved by a relative ``tol``
        for ``patience`` epochs. It monitors the training loss, unless
        ``validation_fraction`` holds out a validation set. With L-BFGS,
        training also stops once the model stands still (see ``curve_tol``).
    patience : int, default=5
        Epochs without improvement before stopping.
    tol : float, default=1e-4
        Relative improvement that counts.
    curve_tol : float, default=1e-3
        With ``early_stopping`` and L-BFGS: stop when, two epochs in a row,
        no curve moved by more than ``curve_tol`` of its range (RMS of the
        change across its argument's range) and no parameter by more than
        ``curve_tol`` of its value. The curves are then settled well below
        what the data can confirm; 0 trains until the loss stops improving.
    validation_fraction : float, optional
        Fraction of the samples held out (by skorch's ``ValidSplit``) to
        monitor ``valid_loss``; None trains on everything.
    constraint_mode : {"exact", "penalty"}, default="exact"
        Constraints by construction, or as a penalty added to the loss.
    constraint_weight : float, default=1.0
        Weight of the penalty when ``constraint_mode="penalty"``.
    param_init : dict, optional
        Starting values of the parameters ``a_i`` (1.0 otherwise).
    extrapolation : {"linear", "clip", "raise"}, default="linear"
        What a curve does outside the range of its argument in training:
        continue with the slope at the edge, hold the edge value, or raise.
        ``simulate`` warns once when the trajectory leaves that range.
    dtype : {"float32", "float64"}, default="float32"
        Precision of training (inputs of either type are accepted).
    device : {"cpu", "cuda", "xpu", "auto"}, default="cpu"
        Where to train; ``"auto"`` picks a GPU when there is one. The fitted
        model holds only numpy arrays, so it loads anywhere.
    n_threads : int or None, default=1
        Intra-op torch threads during ``fit`` (restored afterwards); small
        networks are fastest on one. None keeps torch's setting.
    callbacks : list of skorch callbacks, optional
        Extra callbacks for the skorch net.
    gauge : {"auto", "warn", "raise"}, default="auto"
        See :class:`CCRegressor`.
    differentiation, smooth_states, fit_mode, shooting_window, shooting_iterations, input_hold
        How measurements without derivatives are used, and output-error
        fitting: see :class:`CCRegressor`.
    noise_model : {"ar", "arma", "auto"} or None, default=None
        The measurement noise's model for output-error fits: see
        :class:`CCRegressor`.
    process_noise : dict or None, default=None
        Which states the filter's random push enters, each intensity fitted,
        shared or held: see :class:`CCRegressor`.
    measurement_noise, initial_state : dict or None, default=None
        The filter's held measurement noises and the experiments' starts:
        see :class:`CCRegressor`.
    equation_weights : list of float, optional
        One weight per equation: see :class:`CCRegressor`.
    quantities : dict, optional
        What each state measures, for the diagnosis: see :class:`CCRegressor`.
    shooting_start_epochs : int or None, default=10
        When the fit refines by output error, epochs of the equation-error fit that
        starts the output-error stage (at most ``max_epochs``; None uses
        ``max_epochs``). Derivatives estimated from noisy positions are
        noisy: networks trained on them to convergence learn wiggles that
        trajectory matching cannot take out again, so the start is kept
        short and the shooting stage does the fitting.
    n_bootstrap : int, default=0
        Refit on this many resamples of the record (blocks of consecutive
        samples within each experiment, or whole experiments when there are
        many; with unmeasured states, the fit's simulation errors drawn
        again in blocks, each resample refitted from the fit):
        ``params_std_``, ``params_interval``, the bands of ``cc_curves`` and
        ``simulate`` then come from their spread. 0 makes
        none (a fit without them has no uncertainty estimate); each refit
        trains its networks from its own seed, so the spread holds that of
        training too (with unmeasured states, a skeleton of parameters
        only, each refit polishes them from the fit).
    n_jobs : int or None, default=None
        Processes for the refits on resamples (joblib; None is one, -1
        every core). The result does not depend on it.
    random_state : int, RandomState or None
        Seeds the initial weights and the minibatch order (private
        generators; global random state is never touched).
    verbose : int, default=0
        0 silent, 1 a progress bar over epochs, 2 skorch's table per epoch.

    Attributes
    ----------
    history_ : skorch.History
        Loss per epoch.
    n_epochs_ : int
        Epochs run.
    loss_ : float
        Final training loss (mean squared scaled residual).
    device_ : str
        The device the model was trained on.
    bootstrap_params_ : DataFrame
        Only with ``n_bootstrap``: the free parameters of each refit on a
        resample, one row per refit (``bootstrap_`` holds their curves too,
        and ``bootstrap_method_`` says how the resamples were drawn).

    Examples
    --------
    >>> from sklearn_pycc import NeuralCCRegressor, datasets
    >>> df = datasets.make_duffing(n_samples=300)
    >>> model = NeuralCCRegressor(
    ...     equations=["x1_dot = x2", "x2_dot = F_ext - f1(x2) - f2(x1)"],
    ...     constraints=["f1 odd", "f2 odd"], max_epochs=300, random_state=0)
    >>> _ = model.fit(df[["x1", "x2", "F_ext"]], df[["x1_dot", "x2_dot"]])
    >>> model.score(df[["x1", "x2", "F_ext"]], df[["x1_dot", "x2_dot"]]) > 0.999
    True
    """

    _parameter_constraints: dict = {
        **CCRegressor._parameter_constraints,
        "hidden_layer_sizes": [tuple, list, Interval(Integral, 1, None, closed="left")],
        "activation": [StrOptions(set(ACTIVATIONS))],
        "optimizer": [StrOptions(set(OPTIMIZERS)), type],
        "lr": [Interval(Real, 0, None, closed="neither"), None],
        "max_epochs": [Interval(Integral, 1, None, closed="left")],
        "batch_size": [Interval(Integral, 1, None, closed="left"), None],
        "early_stopping": ["boolean"],
        "patience": [Interval(Integral, 1, None, closed="left")],
        "tol": [Interval(Real, 0, None, closed="left")],
        "curve_tol": [Interval(Real, 0, None, closed="left")],
        "validation_fraction": [Interval(Real, 0, 1, closed="neither"), None],
        "constraint_mode": [StrOptions(set(CONSTRAINT_MODES))],
        "constraint_weight": [Interval(Real, 0, None, closed="left")],
        "param_init": [dict, None],
        "extrapolation": [StrOptions(set(EXTRAPOLATIONS))],
        "dtype": [StrOptions(set(DTYPES))],
        "device": [str],
        "n_threads": [Interval(Integral, 1, None, closed="left"), None],
        "callbacks": [list, tuple, None],
        "shooting_start_epochs": [Interval(Integral, 1, None, closed="left"), None],
        "random_state": RANDOM_STATES,
        **RESAMPLING,
        "verbose": ["verbose"],
    }

    def __init__(self, *, equations=None, constraints=None, hidden_layer_sizes=(16, 16),
                 activation: str = "tanh", optimizer="lbfgs", lr: float | None = None,
                 max_epochs: int = 100, batch_size: int | None = None,
                 early_stopping: bool = True, patience: int = 5, tol: float = 1e-4,
                 curve_tol: float = 1e-3, validation_fraction: float | None = None,
                 constraint_mode: str = "exact",
                 constraint_weight: float = 1.0, param_init: Mapping | None = None,
                 extrapolation: str = "linear", dtype: str = "float32", device: str = "cpu",
                 n_threads: int | None = 1, callbacks: Sequence | None = None,
                 gauge: str = "auto", differentiation="auto", smooth_states: bool = True,
                 fit_mode: str = "auto", shooting_window: int = 40,
                 shooting_iterations: int = 30, shooting_start_epochs: int | None = 10,
                 equation_weights=None, random_state=None, n_bootstrap: int = 0,
                 n_jobs: int | None = None, verbose: int = 0,
                 input_hold: str = "auto",
                 noise_model: str | None = None,
                 quantities: Mapping[str, str] | None = None,
                 process_noise: Mapping | None = None,
                 measurement_noise: Mapping | None = None,
                 initial_state: Mapping | None = None) -> None:
        super().__init__(equations=equations, constraints=constraints, gauge=gauge,
                         differentiation=differentiation, smooth_states=smooth_states,
                         fit_mode=fit_mode, shooting_window=shooting_window,
                         shooting_iterations=shooting_iterations,
                         equation_weights=equation_weights, input_hold=input_hold,
                         noise_model=noise_model, quantities=quantities,
                         process_noise=process_noise, measurement_noise=measurement_noise,
                         initial_state=initial_state)
        self.hidden_layer_sizes = hidden_layer_sizes
        self.activation = activation
        self.optimizer = optimizer
        self.lr = lr
        self.max_epochs = max_epochs
        self.batch_size = batch_size
        self.early_stopping = early_stopping
        self.patience = patience
        self.tol = tol
        self.curve_tol = curve_tol
        self.validation_fraction = validation_fraction
        self.constraint_mode = constraint_mode
        self.constraint_weight = constraint_weight
        self.param_init = param_init
        self.extrapolation = extrapolation
        self.dtype = dtype
        self.device = device
        self.n_threads = n_threads
        self.callbacks = callbacks
        self.shooting_start_epochs = shooting_start_epochs
        self.random_state = random_state
        self.n_bootstrap = n_bootstrap
        self.n_jobs = n_jobs
        self.verbose = verbose

    def _delay_searcher(self) -> CCRegressor:
        # the delays' many fits with polynomial curves: seconds, where these take minutes
        return polynomial_stand_in(self)

    def _make_backend(self) -> NeuralBackend:
        return NeuralBackend(**self._backend_settings(NeuralBackend))


def _last_layer_directions(curve: NumpyCurve, points) -> np.ndarray:
    """The changes of ``curve``'s last layer a refinement moves, one per column.

    Within the null space of the features at the point values (those then
    hold), the principal directions of the features over the domain: each
    changes the curve by one unit, root mean square over the domain, and
    those that change it by less than :data:`LAST_LAYER_RANK` of the
    strongest are left out (a network's features are nearly collinear, and
    the likelihood has no curvature along what they barely change).
    """
    size = curve.features(np.zeros(1)).shape[1]
    if points:
        base = null_space(curve.features(np.array([at for at, _ in points])))
    else:
        base = np.eye(size)
    grid = curve.features(np.linspace(*curve.domain, 101)) @ base
    if not base.shape[1] or not np.any(grid):
        return np.zeros((size, 0))
    _, strengths, rows = np.linalg.svd(grid / np.sqrt(len(grid)), full_matrices=False)
    keep = strengths > LAST_LAYER_RANK * strengths[0]
    return base @ (rows[keep].T / strengths[keep])


def _silent(*args, **kwargs) -> None:
    return None


_LIMITED_DOMAINS = ("sqrt", "log", "log10", "arcsin", "arccos", "asin", "acos")


def _domain_hint(problem: Problem) -> str:
    """Advice when a parameter sits inside a function defined on part of the line only."""
    from ..skeleton.nodes import Apply, Param, walk

    inside = sorted({n.name for eq in problem.equations for node in walk(eq.residual)
                     if isinstance(node, Apply) and node.func in _LIMITED_DOMAINS
                     for n in walk(node.arg) if isinstance(n, Param)}
                    - set(problem.bounds) - set(problem.fixed_params))
    if not inside:
        return ""
    return (f"; {' and '.join(inside)} sit inside a function defined on part of the line only "
            f"(sqrt, log, arcsin, ...): a bound such as '{inside[0]} >= 0' keeps training "
            "inside its domain")


def _inside(bounds: tuple[float, float] | None) -> float:
    """A starting value of 1 moved within ``bounds`` (their middle when both are finite)."""
    if bounds is None:
        return 1.0
    low, high = bounds
    if np.isfinite(low) and np.isfinite(high):
        return 0.5 * (low + high) if not low <= 1.0 <= high else 1.0
    if np.isfinite(low):
        return max(1.0, low + 1.0)
    if np.isfinite(high):
        return min(1.0, high - 1.0)
    return 1.0
