"""States and derivatives estimated from measured samples, experiment by experiment."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..skeleton.nodes import Symbol
from .differentiation import Differentiator
from .experiments import Experiment

__all__ = ["Estimate", "estimate_states", "kinematic_chains", "unmeasured_states"]


def kinematic_chains(skeleton) -> dict[str, tuple[str, int]]:
    """States a kinematic equation defines as a derivative of another state.

    ``x1_dot = x2`` makes ``x2`` the first derivative of ``x1``; with
    ``x2_dot = x3`` as well, ``x3`` is its second derivative.

    Returns
    -------
    dict
        ``state -> (root state, order)`` for every state reached by such a chain.
    """
    parent: dict[str, str] = {}
    states = set(skeleton.states)
    for eq in skeleton.parsed:
        if not eq.solvable:
            continue
        rhs = eq.expression
        if isinstance(rhs, Symbol) and rhs.name in states and rhs.name != eq.state:
            parent.setdefault(rhs.name, eq.state)
    chains = {}
    for state in parent:
        root, order, seen = state, 0, {state}
        while root in parent:
            root = parent[root]
            order += 1
            if root in seen:  # a cycle x1_dot = x2, x2_dot = x1: no root to start from
                break
            seen.add(root)
        else:
            chains[state] = (root, order)
    return chains


@dataclass
class Estimate:
    """States and derivatives estimated from one data set.

    Attributes
    ----------
    states : dict
        State -> values used for fitting: smoothed (or raw, without
        smoothing) measurements, and reconstructed unmeasured states.
    smoothed : dict
        State -> smoothed or reconstructed values (initial states for simulation).
    derivatives : ndarray of shape (n_samples, n_states)
        Estimated ``NAME_dot``, in equation order.
    measured : list of str
        States that were measured (columns of ``X``).
    description : str
        How the estimate was made, in plain words.
    reconstructed : dict
        Unmeasured state -> how it was reconstructed.
    inputs : dict
        Input -> its values as the fit sees them, for the inputs the method
        filtered along with the states (the others are used as measured).
    trusted : ndarray of bool or None
        Rows whose estimate can be trusted: False within the method's
        settling time of an experiment's ends (None when every row can).
    snr_db : float or None
        The lowest signal-to-noise ratio (dB) the method read from any
        experiment (None when it read none).
    """

    states: dict[str, np.ndarray]
    smoothed: dict[str, np.ndarray]
    derivatives: np.ndarray
    measured: list[str]
    description: str = ""
    reconstructed: dict[str, str] = field(default_factory=dict)
    inputs: dict[str, np.ndarray] = field(default_factory=dict)
    trusted: np.ndarray | None = None
    snr_db: float | None = None


#: at most this share of an experiment's duration is left out at each end
MAX_SETTLING_SHARE = 0.05


def _settled(method: Differentiator, experiment: Experiment) -> np.ndarray:
    """Which of an experiment's rows lie beyond the method's settling time of both ends."""
    t = experiment.t
    margin = min(method.settling(t), MAX_SETTLING_SHARE * (t[-1] - t[0]))
    return (t >= t[0] + margin) & (t <= t[-1] - margin)


def _root(state: str, chains: Mapping[str, tuple[str, int]],
          columns) -> tuple[str | None, int]:
    """The measured state ``state`` is a derivative of, and its order (None: there is none)."""
    if state in columns:
        return state, 0
    root, order = chains.get(state, (None, 0))
    # climb past unmeasured intermediate states to a measured one
    while root is not None and root not in columns and root in chains:
        up, extra = chains[root]
        root, order = up, order + extra
    return (root, order) if root is not None and root in columns else (None, 0)


def unmeasured_states(skeleton, columns, reconstruct: bool = True) -> list[str]:
    """States of ``skeleton`` that ``columns`` neither holds nor lets be reconstructed.

    A state no column holds is reconstructed when a kinematic equation ties
    it to a measured one (``x1_dot = x2`` with ``x1`` measured), and only
    when ``reconstruct`` (the derivatives are estimated from the states).
    """
    chains = kinematic_chains(skeleton) if reconstruct else {}
    return [s for s in skeleton.states if _root(s, chains, columns)[0] is None]


def _plan(skeleton, columns: Mapping[str, np.ndarray],
          hidden=()) -> dict[str, tuple[str, int]]:
    """State -> (measured root state, order of the derivative it is), the ``hidden`` left out."""
    chains = kinematic_chains(skeleton)
    plan: dict[str, tuple[str, int]] = {}
    for state in skeleton.states:
        if state in hidden:
            continue
        root, order = _root(state, chains, columns)
        if root is None:
            raise ValueError(
                f"X has no column {state!r}, and no kinematic equation (NAME_dot = {state}) "
                f"ties it to a measured state; measure it, or give y with the derivatives "
                f"{skeleton.derivatives}")
        plan[state] = (root, order)
    return plan


def estimate_states(skeleton, columns: Mapping[str, np.ndarray],
                    experiments: Sequence[Experiment], differentiator: Differentiator,
                    *, smooth: bool = True,
                    inputs: Mapping[str, np.ndarray] | None = None,
                    hidden: Sequence[str] = ()) -> Estimate:
    """Estimate every state's derivative, and the states no column holds.

    Parameters
    ----------
    skeleton : Skeleton
        Gives the states, their order and the kinematic equations.
    columns : dict
        Measured columns by name (at least one state per kinematic chain).
    experiments : list of Experiment
        With times; each is differentiated on its own.
    differentiator : Differentiator
        The method; it may choose per experiment (``"auto"``).
    smooth : bool, default=True
        Fit on the smoothed measurements instead of the raw ones.
    inputs : dict, optional
        Measured inputs by name; a method that low-pass filters the states
        filters these too (see :attr:`Estimate.inputs`).
    hidden : sequence of str, optional
        States no column holds nor lets be reconstructed (see
        :func:`unmeasured_states`): they get no values, and NaN derivatives.

    Raises
    ------
    ValueError
        If a state is neither measured nor tied to a measured state by
        kinematic equations, if an experiment is too short or unevenly
        sampled for the method, or if the method fails on an experiment;
        the message names the state, the experiment and the method.
    """
    states = skeleton.states
    plan = _plan(skeleton, columns, hidden)
    depth: dict[str, int] = {}
    for root, order in plan.values():
        depth[root] = max(depth.get(root, 0), order + 1)
    n = (len(next(iter(columns.values()))) if columns
         else sum(e.n_samples for e in experiments))
    if not depth:  # every state unmeasured (a sensor's output is what is measured)
        return Estimate({}, {}, np.full((n, len(states)), np.nan), [],
                        f"no state measured ({', '.join(hidden)} unmeasured): nothing "
                        "differentiated", {}, {}, None, None)
    series = {root: [np.empty(n) for _ in range(k + 1)] for root, k in depth.items()}
    inputs = dict(inputs or {})
    filtered = {name: np.array(values, dtype=float) for name, values in inputs.items()}
    touched: set[str] = set()
    described: dict[str, list[str]] = {}
    trusted = np.ones(n, dtype=bool)
    snrs = []
    for experiment in experiments:
        chosen = _choose(differentiator, experiment, columns, depth)
        described.setdefault(chosen.describe(), []).append(experiment.where.strip())
        trusted[experiment.rows] = _settled(chosen, experiment)
        if chosen.snr_db is not None:
            snrs.append(chosen.snr_db)
        for root, k in depth.items():
            values = _differentiate(chosen, experiment, columns[root], root, k)
            for order, part in enumerate(values):
                series[root][order][experiment.rows] = part
        for name, values in inputs.items():
            smoothed_input = chosen.smooth_input(experiment.t, values[experiment.rows])
            if smoothed_input is not None:
                filtered[name][experiment.rows] = smoothed_input
                touched.add(name)
    fitted, smoothed, reconstructed = {}, {}, {}
    derivatives = np.empty((n, len(states)))
    for j, state in enumerate(states):
        if state in hidden:
            derivatives[:, j] = np.nan
            continue
        root, order = plan[state]
        smoothed[state] = series[root][order]
        derivatives[:, j] = series[root][order + 1]
        if state in columns:
            fitted[state] = smoothed[state] if smooth else np.array(columns[state], dtype=float)
        else:
            fitted[state] = smoothed[state]
            reconstructed[state] = (f"derivative of {root}" if order == 1
                                    else f"derivative of order {order} of {root}")
    text = _description(described)
    if touched:
        text += f"; the inputs {', '.join(sorted(touched))} filtered alike"
    if reconstructed:
        text += "; " + ", ".join(f"{s} as the {how}" for s, how in reconstructed.items())
    if hidden:
        text += f"; {', '.join(hidden)} unmeasured"
    left_out = int(n - np.count_nonzero(trusted))
    if left_out:
        text += (f"; {left_out} samples at the ends of the experiments left out while the "
                 "filter settles")
    measured = [s for s in states if s in columns and s not in hidden]
    return Estimate(fitted, smoothed, derivatives, measured, text, reconstructed,
                    {name: filtered[name] for name in touched},
                    None if left_out == 0 else trusted, min(snrs) if snrs else None)


def _description(described: dict[str, list[str]]) -> str:
    if len(described) == 1:
        return f"derivatives estimated per experiment by {next(iter(described))}"
    parts = []
    for text, where in described.items():
        places = ", ".join(w.removeprefix("in ") for w in where[:3])
        more = f" and {len(where) - 3} more" if len(where) > 3 else ""
        parts.append(f"{places}{more}: {text}")
    return "derivatives estimated per experiment; " + "; ".join(parts)


def _choose(differentiator: Differentiator, experiment: Experiment,
            columns: Mapping[str, np.ndarray], depth: Mapping[str, int]) -> Differentiator:
    _check_experiment(experiment, differentiator)
    samples = {root: np.asarray(columns[root], dtype=float)[experiment.rows] for root in depth}
    try:
        chosen = differentiator.for_experiment(experiment.t, samples, max(depth.values()))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        where = experiment.where or " in the data"
        raise ValueError(f"{differentiator.describe()} could not read the record{where}: "
                         f"{exc}") from exc
    if chosen is not differentiator:
        _check_experiment(experiment, chosen)
    return chosen


def _differentiate(method: Differentiator, experiment: Experiment, column: np.ndarray,
                   root: str, order: int) -> list[np.ndarray]:
    """One state's derivatives on one experiment, every failure named."""
    where = experiment.where or " in the data"
    try:
        values = method.derivatives(experiment.t, np.asarray(column, dtype=float)[
            experiment.rows], order)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        raise ValueError(
            f"{method.describe()} failed on {root!r}{where}: {exc or type(exc).__name__}. "
            "Try another differentiation setting (differentiation='auto' chooses from the "
            "record)") from exc
    out = []
    for k, part in enumerate(values):
        part = np.asarray(part, dtype=float)
        if part.shape != experiment.rows.shape or not np.isfinite(part).all():
            raise ValueError(
                f"{method.describe()} gave non-finite or misshapen values for the derivative "
                f"of order {k} of {root!r}{where}; try another differentiation setting "
                "(differentiation='auto' chooses from the record)")
        out.append(part)
    return out


def _check_experiment(experiment: Experiment, differentiator: Differentiator) -> None:
    need = differentiator.min_samples(experiment.n_samples)
    if experiment.n_samples < need:
        where = experiment.where or " in the data"
        raise ValueError(
            f"{experiment.n_samples} samples{where} are too few for "
            f"{differentiator.describe()}, which needs at least {need}; "
            "give a longer experiment or a smaller window")
    if differentiator.uniform_only and not experiment.is_uniform():
        steps = np.diff(experiment.t)
        where = experiment.where or " in the data"
        raise ValueError(
            f"{differentiator.describe()} needs evenly spaced samples, but the time steps"
            f"{where} range from {steps.min():.4g} to {steps.max():.4g}; resample, or use "
            "differentiation='spline', 'finite_difference' or 'kalman'")
