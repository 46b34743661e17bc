"""The noise of the measured signals as a fit's output errors show it: ``noise_model``.

An output-error fit compares simulated states with measured ones. When the
measurement noise is coloured, consecutive errors are correlated and plain
least squares weighs the record as if it held many more independent
samples than it does. With ``noise_model`` the estimator fits, on the
whole-record errors of a first fit, an autoregressive (``"ar"``, order
chosen by the BIC) or ARMA(1,1) (``"arma"``) model of each measured state's
noise, and fits again with every output error whitened by it: the
prediction-error method, Box and Jenkins's idea, for grey-box ODEs.
``"auto"`` takes the white model too, and keeps the noise white when the
BIC says so.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import sparse

from .whole_record import WholeRecord

__all__ = ["NOISE_MODELS", "NoiseModel", "SignalNoiseModel", "fit_noise_model",
           "whitening_matrix"]

NOISE_MODELS = ("ar", "arma", "auto")
#: the highest AR order tried
MAX_AR_ORDER = 4
#: the order of the long AR whose innovations start an ARMA fit (Hannan and Rissanen)
LONG_AR_ORDER = 12
#: the whitening filter's taps are cut where they fall below this share of the first
TAP_TOLERANCE = 1e-3
#: and after this many
MAX_TAPS = 200


@dataclass(frozen=True)
class SignalNoiseModel:
    """One measured state's noise: ``e[n] = sum phi_k e[n-k] + w[n] + theta w[n-1]``.

    Attributes
    ----------
    name : str
    ar : tuple of float
        Autoregressive coefficients ``phi_k`` (empty: none).
    ma : tuple of float
        Moving-average coefficient ``theta`` (empty: none).
    innovation : float
        Standard deviation of ``w``.
    level : float
        Standard deviation of the errors themselves.
    """

    name: str
    ar: tuple[float, ...] = ()
    ma: tuple[float, ...] = ()
    innovation: float = 0.0
    level: float = 0.0

    @property
    def white(self) -> bool:
        """Whether the errors are modelled as white."""
        return not self.ar and not self.ma

    @property
    def poles(self) -> tuple[float, ...]:
        """Absolute values of the AR part's poles, largest first."""
        if not self.ar:
            return ()
        roots = np.roots(np.concatenate([[1.0], -np.asarray(self.ar)]))
        return tuple(sorted((float(abs(r)) for r in roots), reverse=True))

    def taps(self) -> np.ndarray:
        """The whitening filter ``A(z) / C(z)``, truncated: taps on ``e[n], e[n-1], ...``."""
        a = np.concatenate([[1.0], -np.asarray(self.ar, dtype=float)])
        theta = self.ma[0] if self.ma else 0.0
        taps = [a[0]]
        # h = a / (1 + theta z^-1): h[k] = a[k] - theta h[k-1]
        for k in range(1, MAX_TAPS):
            value = (a[k] if k < len(a) else 0.0) - theta * taps[-1]
            if k >= len(a) and abs(value) < TAP_TOLERANCE:
                break
            taps.append(value)
        return np.asarray(taps)

    def describe(self) -> str:
        """One line in words."""
        if self.white:
            return f"{self.name}: white, level {self.level:.3g}"
        parts = []
        if self.ar:
            poles = ", ".join(f"{p:.3f}" for p in self.poles)
            parts.append(f"AR({len(self.ar)}) with pole{'s' if len(self.ar) > 1 else ''} "
                         f"{poles}")
        if self.ma:
            parts.append(f"MA coefficient {self.ma[0]:.3f}")
        return (f"{self.name}: {' and '.join(parts)}, level {self.level:.3g} "
                f"(innovations {self.innovation:.3g})")


@dataclass(frozen=True)
class NoiseModel:
    """The noise model of every measured state (what ``noise_model_`` holds).

    Attributes
    ----------
    kind : {"ar", "arma", "auto"}
        The ``noise_model`` setting it was fitted under.
    signals : dict
        Measured state -> :class:`SignalNoiseModel`.
    """

    kind: str
    signals: dict

    @property
    def white(self) -> bool:
        """Whether every state's errors are modelled as white."""
        return all(s.white for s in self.signals.values())

    def __getitem__(self, name: str) -> SignalNoiseModel:
        return self.signals[name]

    def describe(self) -> str:
        """One line per measured state."""
        return "; ".join(s.describe() for s in self.signals.values())


def _lagged(runs: Sequence[np.ndarray], order: int) -> tuple[np.ndarray, np.ndarray]:
    """Targets ``e[n]`` and regressors ``e[n-1..n-order]`` within runs (none across)."""
    targets, rows = [], []
    for run in runs:
        if len(run) <= order:
            continue
        targets.append(run[order:])
        rows.append(np.column_stack([run[order - k:len(run) - k] for k in range(1, order + 1)])
                    if order else np.zeros((len(run) - order, 0)))
    if not targets:
        return np.zeros(0), np.zeros((0, order))
    return np.concatenate(targets), np.vstack(rows)


def _fit_ar(runs: Sequence[np.ndarray], order: int, skip: int) -> tuple[np.ndarray, float, int]:
    """AR(order) by least squares on samples after the first ``skip`` of each run."""
    target, lags = _lagged([r[skip - order:] for r in runs], order)
    if order:
        coef, *_ = np.linalg.lstsq(lags, target, rcond=None)
        target = target - lags @ coef
    else:
        coef = np.zeros(0)
    return coef, float(np.mean(target**2)), len(target)


def _stationary(ar: np.ndarray) -> bool:
    if len(ar) == 0:
        return True
    return bool(np.all(np.abs(np.roots(np.concatenate([[1.0], -ar]))) < 1.0))


def _fit_arma(runs: Sequence[np.ndarray]) -> tuple[float, float, float, int]:
    """ARMA(1,1) by Hannan and Rissanen: a long AR's innovations as the MA regressor."""
    long, _, _ = _fit_ar(runs, LONG_AR_ORDER, LONG_AR_ORDER)
    innovations = []
    for run in runs:
        w = np.zeros_like(run)
        if len(run) > LONG_AR_ORDER:
            _, lags = _lagged([run], LONG_AR_ORDER)
            w[LONG_AR_ORDER:] = run[LONG_AR_ORDER:] - lags @ long
        innovations.append(w)
    skip = LONG_AR_ORDER + 1
    target, regressors = [], []
    for run, w in zip(runs, innovations):
        if len(run) <= skip:
            continue
        target.append(run[skip:])
        regressors.append(np.column_stack([run[skip - 1:-1], w[skip - 1:-1]]))
    if not target:
        return 0.0, 0.0, 0.0, 0
    target, regressors = np.concatenate(target), np.vstack(regressors)
    (phi, theta), *_ = np.linalg.lstsq(regressors, target, rcond=None)
    phi, theta = float(np.clip(phi, -0.999, 0.999)), float(np.clip(theta, -0.95, 0.95))
    # the innovations of the fitted model, run recursively
    variance, count = 0.0, 0
    for run in runs:
        w_prev = 0.0
        for n in range(1, len(run)):
            w = run[n] - phi * run[n - 1] - theta * w_prev
            if n >= skip:
                variance += w * w
                count += 1
            w_prev = w
    return phi, theta, variance / max(count, 1), count


def fit_noise_model(errors: Mapping[str, Sequence[np.ndarray]], kind: str) -> NoiseModel:
    """Each state's noise model from its output errors, one array per experiment.

    Parameters
    ----------
    errors : dict
        Measured state -> its errors (measured minus simulated), one array
        per experiment, in time order.
    kind : {"ar", "arma", "auto"}
        ``"ar"``: AR of order 1 to ``MAX_AR_ORDER`` chosen by the BIC;
        ``"arma"``: ARMA(1,1); ``"auto"``: the best by the BIC of white
        noise, those AR orders and ARMA(1,1).
    """
    if kind not in NOISE_MODELS:
        raise ValueError(f"noise_model must be None or one of {', '.join(NOISE_MODELS)}, "
                         f"got {kind!r}")
    signals = {}
    for name, runs in errors.items():
        runs = [np.asarray(r, dtype=float) for r in runs if len(r)]
        runs = [r - np.mean(np.concatenate(runs)) for r in runs]
        level = float(np.sqrt(np.mean(np.concatenate(runs) ** 2)))
        skip = max(MAX_AR_ORDER, LONG_AR_ORDER + 1)  # every candidate on the same samples
        options = []
        orders = range(0 if kind == "auto" else 1, MAX_AR_ORDER + 1) if kind != "arma" else ()
        for order in orders:
            coef, variance, n = _fit_ar(runs, order, skip)
            if n and variance > 0 and _stationary(coef):
                options.append((n * np.log(variance) + order * np.log(n),
                                SignalNoiseModel(name, tuple(coef.tolist()), (),
                                                 float(np.sqrt(variance)), level)))
        if kind in ("arma", "auto"):
            phi, theta, variance, n = _fit_arma(runs)
            if n and variance > 0:
                options.append((n * np.log(variance) + 2 * np.log(n),
                                SignalNoiseModel(name, (phi,), (theta,),
                                                 float(np.sqrt(variance)), level)))
        if not options:
            signals[name] = SignalNoiseModel(name, innovation=level, level=level)
            continue
        signals[name] = min(options, key=lambda option: option[0])[1]
    return NoiseModel(kind, signals)


def whitening_matrix(taps: Sequence[np.ndarray], run_of_row: np.ndarray) -> sparse.csr_matrix:
    """The sparse filter that whitens row-major errors ``(n_rows, n_signals)``, raveled.

    ``taps[j]`` whitens signal ``j``; ``run_of_row`` says which experiment
    (or stretch) each row belongs to: no tap reaches across two of them.
    """
    n_rows, n_signals = len(run_of_row), len(taps)
    starts = np.r_[0, np.flatnonzero(np.diff(run_of_row)) + 1]
    first_of_row = np.repeat(starts, np.diff(np.r_[starts, n_rows]))
    rows, cols, values = [], [], []
    index = np.arange(n_rows)
    for j, h in enumerate(taps):
        for k, tap in enumerate(h):
            ok = index - k >= first_of_row
            rows.append(index[ok] * n_signals + j)
            cols.append((index[ok] - k) * n_signals + j)
            values.append(np.full(int(ok.sum()), tap))
    size = n_rows * n_signals
    return sparse.csr_matrix((np.concatenate(values), (np.concatenate(rows),
                                                       np.concatenate(cols))),
                             shape=(size, size))


def _whole_record(problem, result):
    """``(WholeRecord, system, first states)`` of a fit: every experiment simulated whole.

    The experiments start from the initial states the output-error fit
    found (``shooting_["initial_states"]``), else from the record's first
    samples.
    """
    system = problem.skeleton.compile(result.functions,
                                      {**problem.fixed_params, **result.params})
    whole = WholeRecord(problem)
    first = result.attributes.get("shooting_", {}).get("initial_states")
    if first is None or np.shape(first) != (len(problem.experiments),
                                            len(problem.skeleton.states)):
        first = whole.first_states(system)
    first = np.asarray(first, dtype=float)
    whole.choose_substeps(system, first)
    return whole, system, first


def output_errors(problem, result) -> dict[str, list[np.ndarray]]:
    """Each measured state's whole-record errors (measured minus simulated), per experiment."""
    whole, system, first = _whole_record(problem, result)
    course = whole.course(system, first)
    errors = {}
    for state in problem.skeleton.states:
        if state not in problem.measured:
            continue
        runs = []
        for experiment in problem.experiments:
            error = problem.measured[state][experiment.rows] - course[state][experiment.rows]
            runs.append(error[np.isfinite(error)])
        errors[state] = runs
    return errors


def whitened_polish(problem, result, noise: NoiseModel, steps: int = 4):
    """The whole-record fit of a parametric skeleton by its whitened errors, and its covariance.

    Multiple shooting joins its windows only up to a weighted defect, so
    its optimum is near, not at, that of the whole record. A few
    Gauss-Newton steps on the whole-record errors, whitened by ``noise``,
    move the free parameters and each experiment's initial state there (a
    step is kept only when it lowers the whitened error). The covariance is
    the sandwich ``B^-1 S B^-1`` of the whitened errors' Jacobian ``J``
    (finite differences of whole-record simulations), ``B = J^T J`` and
    ``S`` the Newey-West long-run covariance of the whitened scores: where
    the noise model is right that is ``s^2 B^-1``, and where the whitened
    errors keep some correlation (a model error, a second colour) it still
    holds.

    Returns ``(params, initial_states, covariance)``, the covariance of the
    parameters as a DataFrame; or None for a skeleton with curves (their
    coefficients are the backend's), or where the simulation or the
    Jacobian fails.
    """
    import pandas as pd

    from ..uncertainty.covariance import long_run_covariance

    if problem.free_functions or not problem.free_params:
        return None
    names = list(problem.free_params)
    p = len(names)
    whole, _, first = _whole_record(problem, result)
    bounds = problem.bounds
    starts = int(whole.free(first.shape).sum())  # the starts the user gave are held
    low = np.r_[[bounds.get(a, (-np.inf, np.inf))[0] for a in names], np.full(starts, -np.inf)]
    high = np.r_[[bounds.get(a, (-np.inf, np.inf))[1] for a in names], np.full(starts, np.inf)]

    def errors(z: np.ndarray) -> np.ndarray:
        values = {**problem.fixed_params, **dict(zip(names, z[:p]))}
        return whole.errors(problem.skeleton.compile(result.functions, values),
                            whole.first_of(z[p:], first.shape))

    windows = whole.windows
    segment = np.broadcast_to(np.arange(windows.n_segments)[:, None], windows.valid.shape)
    taps = [noise.signals[s].taps() if s in noise.signals else np.ones(1)
            for s in whole.states if s in problem.measured]
    W = whitening_matrix(taps, windows.segment_experiment[segment[windows.valid]])

    def jacobian(z: np.ndarray, base: np.ndarray) -> np.ndarray:
        J = np.empty((len(base), len(z)))
        for k in range(len(z)):
            step = 1e-6 * max(abs(z[k]), 1e-3)
            bumped = z.copy()
            bumped[k] += step
            J[:, k] = (errors(bumped) - base) / step
        return W @ J

    z = whole.packed([float(result.params[a]) for a in names], first)
    base = errors(z)
    if not np.all(np.isfinite(base)) or len(base) != W.shape[0]:
        return None
    rw = W @ base
    Jw = jacobian(z, base)
    for _ in range(steps):
        try:
            delta = np.linalg.lstsq(Jw, -rw, rcond=None)[0]
        except np.linalg.LinAlgError:
            break
        trial = np.clip(z + delta, low, high)
        trial_base = errors(trial)
        trial_rw = W @ trial_base
        if not np.all(np.isfinite(trial_rw)) or trial_rw @ trial_rw >= rw @ rw:
            break
        z, base, rw = trial, trial_base, trial_rw
        Jw = jacobian(z, base)
    try:
        inverse = np.linalg.inv(Jw.T @ Jw)
    except np.linalg.LinAlgError:
        return None
    # the sandwich over the whitened scores: what the noise model leaves correlated (a
    # model error, a second colour) still counts
    rows = windows.segment_experiment[segment[windows.valid]]
    runs = np.repeat(rows, len(taps))
    meat, _ = long_run_covariance(Jw * rw[:, None], runs)
    dof = len(rw) / max(len(rw) - len(z), 1)
    covariance = dof * (inverse @ meat @ inverse)[:p, :p]
    if not np.all(np.isfinite(covariance)):
        return None
    params = dict(zip(names, z[:p].tolist()))
    return params, whole.first_of(z[p:], first.shape), pd.DataFrame(covariance, index=names,
                                                                     columns=names)
