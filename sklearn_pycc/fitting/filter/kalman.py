"""The continuous-discrete extended Kalman filter of a skeleton, and its likelihood.

A skeleton read as a stochastic differential equation,

    dx = f(x, u, a) dt + diag(q) dW,    y_k = x_k[measured] + e_k,    e_k ~ N(0, diag(r^2)),

is filtered over the segments of a shooting plan
(:class:`~sklearn_pycc.fitting.output_error.shooting.ShootingPlan`): between
samples the mean follows the right-hand side (fixed-step fourth-order
Runge-Kutta, as the shooting fits integrate it) and the covariance the
linearised flow, ``P <- F P F' + Q_h`` with ``F`` the step's own Jacobian
(every state bumped and integrated beside the mean) and ``Q_h`` the noise
the step adds, integrated exactly under the flow's Jacobian at the step's
start (:func:`~sklearn_pycc.fitting.filter.discrete.step_noise`: a linear
skeleton's filter is the exact discrete Kalman filter); at each sample
the measured states update both. Each segment starts from the plan's
initial states with a broad covariance (the states' own spread), so the
segments are filtered side by side, all in one pass of numpy calls, and the
likelihood is the sum of theirs: the information that crosses a segment's
boundary is all that is lost, little where the segments are far longer than
the states' memory under the process noise.

A state's hard limits hold inside the filter: each segment starts within them
(a truncated normal), the states a state feeds read it at its limits, and
after each step every state near a limit is read as a censored normal
(:func:`_censored`): the step moves it past the limit by as much as the flow
presses on it, and the state is the smaller of that normal and the limit,
held there where the flow presses hard, spread where it barely presses. The
reading is smooth in the prediction, so the likelihood is smooth in the
numbers the search moves. Each state is bumped away from its nearer limit.

Many variants of the system (the bumps of a finite-difference gradient) are
filtered in the same pass: the cost is in the calls, not in the rows; their
limits may differ (an end to fit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from ...skeleton.system import CompiledSystem, stack_systems
from .discrete import step_noise

__all__ = ["FilterPass", "kalman_pass", "rk4_step", "smoothed"]

#: relative size of the state bumps that give each step's Jacobian
BUMP = 1e-6
LOG_2PI = float(np.log(2 * np.pi))


@dataclass
class FilterPass:
    """What one pass of the filter gives, per variant of the system.

    Attributes
    ----------
    nll : ndarray of shape (copies,)
        Negative log-likelihood of the measured samples (inf where a
        variant's filter diverged).
    terms : ndarray of shape (copies, n_used)
        Each used sample's share of ``nll``, in the plan's order.
    innovations : ndarray of shape (copies, n_used, n_measured)
        One-step prediction errors of the measured states.
    variances : ndarray of shape (copies, n_used, n_measured)
        Their predicted variances (the diagonal of ``S``).
    means, covariances : ndarray or None
        Filtered states ``(copies, K, L + 1, n)`` and their covariances
        ``(copies, K, L + 1, n, n)``, when asked for.
    predicted, predicted_covariances, transitions : ndarray or None
        When asked for: the states predicted at each sample from the one
        before (and their covariances; at sample 0, the segment's start) and
        each step's Jacobian ``F`` ``(copies, K, L, n, n)``, which
        :func:`smoothed` runs back over.
    """

    nll: np.ndarray
    terms: np.ndarray
    innovations: np.ndarray
    variances: np.ndarray
    means: np.ndarray | None = None
    covariances: np.ndarray | None = None
    predicted: np.ndarray | None = None
    predicted_covariances: np.ndarray | None = None
    transitions: np.ndarray | None = None


def kalman_pass(plan, systems: list[CompiledSystem] | CompiledSystem,
                process_sd: np.ndarray, measurement_sd: np.ndarray, *,
                keep: bool = False) -> FilterPass:
    """Filter every segment of ``plan`` under each of ``systems``.

    Parameters
    ----------
    plan : ShootingPlan
        Segments, their measured samples (``own``) and their initial states.
    systems : CompiledSystem or list of them
        Variants that differ only in their numbers, filtered side by side.
    process_sd : ndarray of shape (copies, n_states)
        Each variant's process-noise intensity per state (standard deviation
        of the state's increment over a unit of time; 0 for none).
    measurement_sd : ndarray of shape (copies, n_measured)
        Each variant's measurement-noise standard deviation per measured state.
    keep : bool, default=False
        Keep the filtered means and covariances.

    Returns
    -------
    FilterPass
    """
    systems = [systems] if isinstance(systems, CompiledSystem) else list(systems)
    copies, n = len(systems), len(plan.states)
    K, L, m = plan.n_segments, plan.n_steps, plan.substeps
    mi = np.asarray(plan.measured_index, dtype=int)
    rows_per = (n + 1) * K  # a variant's rows: the mean and each state bumped, per segment
    stacked = systems[0] if copies == 1 else stack_systems(systems, rows_per,
                                                             limits_per_row=True)
    if stacked is None:
        raise ValueError("the systems filtered side by side must differ only in their numbers")
    rhs, columns, lefts = _rates(plan, stacked, copies * (n + 1), copies * rows_per)
    q = np.asarray(process_sd, dtype=float).reshape(copies, n) ** 2
    Q = np.repeat(q[:, None, :], K, axis=1).reshape(copies * K, n)  # diagonal, per segment
    r2 = np.repeat((np.asarray(measurement_sd, dtype=float).reshape(copies, -1) ** 2)[:, None],
                   K, axis=1).reshape(copies * K, len(mi))
    scale = np.asarray(plan.scale, dtype=float)
    targets = np.tile(plan.targets, (copies, 1, 1))  # (copies K, L + 1, n_measured)
    own = np.tile(plan.own, (copies, 1))
    h_all = np.tile(plan.h, (copies, 1))
    bound = np.asarray(plan.bound, dtype=float)
    limited = bool(stacked.limits)
    low_end, high_end = _limit_ends(systems, plan.states, K)  # (copies K, n)
    row_ends = [np.repeat(end.reshape(copies, 1, K, n), n + 1, axis=1).reshape(-1, n)
                for end in (low_end, high_end)]  # the integrated rows' order
    # each segment starts broad (or as the user said), within the states' limits (and
    # starts so again if it fails)
    spread = scale**2 if plan.start_variance is None else np.tile(plan.start_variance,
                                                                  (copies, 1))
    x0, P0 = _truncated_start(np.tile(np.asarray(plan.initial, dtype=float), (copies, 1)),
                              spread, low_end, high_end)  # (copies K, n), (copies K, n, n)
    x, P = x0, P0
    terms = np.zeros((copies * K, L + 1))
    innov = np.zeros((copies * K, L + 1, len(mi)))
    var = np.ones((copies * K, L + 1, len(mi)))
    failed = np.zeros(copies * K, dtype=bool)
    kept = _kept(copies * K, L, n) if keep else None

    def update_one(i: int) -> None:
        """The update for a single measured state: every matrix of the measurement a number."""
        nonlocal x, P
        present = np.isfinite(targets[:, i, 0])
        on = own[:, i] & present  # a missing sample: no update, and no innovation
        if not present.all():
            innov[:, i, 0] = var[:, i, 0] = np.where(present, 0.0, np.nan)
        if not on.any():
            return
        j = int(mi[0])
        nu = targets[:, i, 0] - x[:, j]
        S = P[:, j, j] + r2[:, 0]
        broken = ~(np.isfinite(S) & np.isfinite(nu) & (S > 0))
        if broken.any():
            failed[:] |= broken & on
            S = np.where(broken, 1.0, S)
            nu = np.where(broken, 0.0, nu)
        gain = P[:, :, j] / S[:, None]
        terms[:, i] = np.where(on, 0.5 * (nu * nu / S + np.log(S) + LOG_2PI), 0.0)
        innov[:, i, 0] = np.where(present, nu, np.nan)
        var[:, i, 0] = np.where(present, S, np.nan)
        x = np.where(on[:, None], x + gain * nu[:, None], x)
        # P - K S K' with K = P h / S: P - (P h)(P h)' / S
        P = np.where(on[:, None, None], P - gain[:, :, None] * P[:, None, j, :], P)
        P = 0.5 * (P + P.transpose(0, 2, 1))

    def update(i: int) -> None:
        nonlocal x, P
        on = own[:, i]
        if not on.any() or not len(mi):
            return
        if len(mi) == 1:
            update_one(i)
            return
        present = np.isfinite(targets[:, i])  # the signals this sample holds
        on = on & present.any(axis=1)
        nu = np.where(present, targets[:, i] - x[:, mi], 0.0)
        S = P[:, mi][:, :, mi] + r2[:, :, None] * np.eye(len(mi))
        seen = P[:, mi, :]
        gaps = not present.all()
        if gaps:  # a missing signal's row of S is the identity's, and it moves nothing
            both = present[:, :, None] & present[:, None, :]
            S = np.where(both, S, np.eye(len(mi)))
            seen = np.where(present[:, :, None], seen, 0.0)
        # a variant whose covariance lost its meaning (a bump too far) fails alone
        broken = ~(np.isfinite(S).all(axis=(1, 2)) & np.isfinite(nu).all(axis=1))
        broken[~broken] |= np.linalg.eigvalsh(S[~broken]).min(axis=1) <= 0
        if broken.any():
            failed[:] |= broken & on
            S[broken] = np.eye(len(mi))
            nu[broken] = 0.0
        chol = np.linalg.cholesky(S)
        white = np.linalg.solve(chol, nu[:, :, None])[:, :, 0]
        log_det = 2.0 * np.sum(np.log(np.abs(np.diagonal(chol, axis1=1, axis2=2))), axis=1)
        gain = np.linalg.solve(S, seen).transpose(0, 2, 1)  # P H' S^-1 (S symmetric)
        term = 0.5 * (np.sum(white**2, axis=1) + log_det + present.sum(axis=1) * LOG_2PI)
        terms[:, i] = np.where(on, term, 0.0)
        innov[:, i] = np.where(present, nu, np.nan) if gaps else nu
        var[:, i] = np.diagonal(S, axis1=1, axis2=2)
        if gaps:
            var[:, i] = np.where(present, var[:, i], np.nan)
        x = np.where(on[:, None], x + np.einsum("bij,bj->bi", gain, nu), x)
        P = np.where(on[:, None, None], P - gain @ S @ gain.transpose(0, 2, 1), P)
        P = 0.5 * (P + P.transpose(0, 2, 1))

    with np.errstate(all="ignore"):
        for i in range(L + 1):
            if keep:
                kept["predicted"][:, i], kept["predicted_covariances"][:, i] = x, P
            update(i)
            if limited:  # an update may carry a state a hair beyond its limit
                x = np.clip(x, low_end, high_end)
            if keep:
                kept["means"][:, i], kept["covariances"][:, i] = x, P
            if i == L:
                break
            h = h_all[:, i]
            z, step = _bumped(x, scale, (low_end, high_end) if limited else None, copies)
            hz = np.repeat(h.reshape(copies, K)[:, None, :], n + 1, axis=1).reshape(-1, 1)
            sub = hz / m
            # the flow's Jacobian at the step's start sets the noise the step adds
            rates = rhs(z, 2 * i * m, columns)
            A = _jacobian(rates, step, copies, K)
            for j in range(m):  # past a limit by as much as the flow presses on it
                z = rk4_step(rhs, z, sub, 2 * (i * m + j), right=columns, left=lefts,
                             first=rates if j == 0 else None)
            if limited:
                z = _pressed_past(z, rhs(z, 2 * (i + 1) * m, lefts), hz, *row_ends)
            x, F = _transition(z, step, copies)
            P = F @ P @ F.transpose(0, 2, 1) + step_noise(A, Q, h, F)
            if limited:  # the smoother carries a state back as far as it was not censored
                x, P, through = _censored(x, P, low=low_end, high=high_end,
                                          floor=(BUMP * scale) ** 2)
                F = F * through[:, :, None]
            if keep:
                kept["transitions"][:, i] = F
            bad = ~(np.isfinite(x).all(axis=1) & (np.abs(x) <= bound).all(axis=1)
                    & np.isfinite(P).all(axis=(1, 2)))
            if bad.any():  # a variant's segment that diverged fails, and starts again
                failed |= bad
                x = np.where(bad[:, None], x0, x)
                P = np.where(bad[:, None, None], P0, P)
    return _gathered(copies, plan.own, terms, innov, var, failed=failed, kept=kept)


def _gathered(copies: int, own: np.ndarray, terms: np.ndarray, innov: np.ndarray,
              var: np.ndarray, *, failed: np.ndarray, kept: dict | None) -> FilterPass:
    """A pass's results per variant: its rows ``(copies K, ...)`` gathered by copy.

    Only the samples a segment owns (``own``, ``(K, L + 1)``) are kept; a
    segment that failed makes its variant's likelihood infinite.
    """
    K, width = own.shape
    used = np.flatnonzero(own.ravel())
    nll = terms.sum(axis=1)
    nll[failed] = np.inf
    out = FilterPass(nll.reshape(copies, K).sum(axis=1),
                     terms.reshape(copies, K * width)[:, used],
                     innov.reshape(copies, K * width, -1)[:, used],
                     var.reshape(copies, K * width, -1)[:, used])
    for name, values in (kept or {}).items():
        setattr(out, name, values.reshape(copies, K, *values.shape[1:]))
    return out


def _kept(rows: int, L: int, n: int) -> dict[str, np.ndarray]:
    """Room for what a pass keeps: ``rows`` segments of ``L`` steps of ``n`` states."""
    return {"predicted": np.zeros((rows, L + 1, n)),
            "predicted_covariances": np.zeros((rows, L + 1, n, n)),
            "means": np.zeros((rows, L + 1, n)), "covariances": np.zeros((rows, L + 1, n, n)),
            "transitions": np.zeros((rows, L, n, n))}


def _bumped(x: np.ndarray, scale: np.ndarray, limits, copies: int):
    """The rows a step integrates (each mean, then it with each state bumped), and the bumps.

    Rows are ordered (copy, point, segment): each variant's rows stay
    together. Within ``limits`` (low and high ends per row), a state is
    bumped away from its nearer limit: beyond it the flow is flat.
    """
    rows, n = x.shape
    step = BUMP * np.maximum(np.abs(x), scale)  # (copies K, n)
    if limits is not None:
        low, high = limits
        step = np.where(high - x < x - low, -step, step)
    points = np.repeat(x[:, None, :], n + 1, axis=1)  # (copies K, n + 1, n)
    points[:, 1:] += step[:, :, None] * np.eye(n)
    K = rows // copies
    return points.reshape(copies, K, n + 1, n).transpose(0, 2, 1, 3).reshape(-1, n), step


def _transition(z: np.ndarray, step: np.ndarray, copies: int) -> tuple[np.ndarray, np.ndarray]:
    """The means after a step and its Jacobian ``F``, from the rows :func:`_bumped` made."""
    rows, n = step.shape
    z = z.reshape(copies, n + 1, rows // copies, n).transpose(0, 2, 1, 3).reshape(rows, n + 1, n)
    x = z[:, 0]
    return x, ((z[:, 1:] - x[:, None, :]) / step[:, :, None]).transpose(0, 2, 1)


def _jacobian(rates: np.ndarray, step: np.ndarray, copies: int, K: int) -> np.ndarray:
    """The flow's Jacobian ``(copies K, n, n)`` from the rates at the mean and each bumped row.

    ``rates`` are in the integrated rows' order (copy, point, segment);
    ``step`` is each state's bump per filtered row.
    """
    n = rates.shape[1]
    by_row = rates.reshape(copies, n + 1, K, n).transpose(0, 2, 1, 3).reshape(copies * K, n + 1, n)
    return ((by_row[:, 1:] - by_row[:, :1]) / step[:, :, None]).transpose(0, 2, 1)


def _rates(plan, stacked: CompiledSystem, repeat: int, rows: int):
    """``rhs(x, column, source)`` on the stacked rows, and the inputs it reads.

    The inputs are read at the plan's fine columns (``columns``, and
    ``lefts`` after a held input's step), each tiled ``repeat`` times. A
    state past a limit is read at the limit, and its rate is the one the
    equations give there: a state the flow presses on its limit moves past
    it by as much as the flow presses (:func:`_censored` reads that), while
    the states it feeds see it at the limit.
    """
    fine, ends = plan.fine_signals(), plan.fine_signals(left=True)
    signals = [name for name in fine if name in stacked.slots]
    columns = [fine[name].T.copy() for name in signals]
    lefts = columns if ends is fine else [ends[name].T.copy() for name in signals]
    evaluate = stacked.batch_rhs(rows, signals, hold=False)
    limits = bool(stacked.limits)

    def rhs(x, column, source):
        if limits:
            x = stacked.clip(x.copy())
        return evaluate(x, [np.tile(values[column], repeat) for values in source])

    return rhs, columns, lefts


def _pressed_past(z: np.ndarray, rates: np.ndarray, h: np.ndarray, low: np.ndarray,
                  high: np.ndarray) -> np.ndarray:
    """Rows a step carried past a limit, no farther than the flow at the limit presses them.

    The integration's stages overshoot a limit the flow reaches in finite
    time (a tank draining through a square root empties and stays empty),
    where the flow at the limit does not press at all; read as a push
    against the floor, that overshoot would hold the level there too
    firmly. ``rates`` are the rates at each row's end, read at the limit.
    """
    rates = np.where(np.isfinite(rates), rates, 0.0)
    z = np.minimum(z, high + np.maximum(rates, 0.0) * h)
    return np.maximum(z, low + np.minimum(rates, 0.0) * h)


#: a limit this many standard deviations away from a state's mean leaves it as it is
CENSOR_REACH = 8.0


def _censored(x: np.ndarray, P: np.ndarray, *, low: np.ndarray, high: np.ndarray,
              floor: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The predicted states read through their limits: each a censored normal.

    A step moves a state as the equations do, past a limit by as much as
    the flow presses on it. The state itself is ``min(Y, high)`` (``max``
    at a low limit) of the normal ``Y`` the step predicts: its mean and
    variance are those of the censored normal, and its covariances with the
    others are scaled by the chance that it is below the limit. A flow that
    presses hard holds it at the limit (nearly known, sharing nothing), one
    that barely presses leaves it spread, its mean a little inside; a state
    whose limit lies beyond :data:`CENSOR_REACH` standard deviations is left
    as it is. The censoring is smooth in the prediction, so the likelihood
    is smooth in the numbers (a state that a step leaves just short of its
    limit is read almost as one that reaches it). A variance is never below
    ``floor`` (per state): a state held without a push, or pressed hard, is
    never quite known, so the smoother can carry the others back beside it
    and a pass with no process noise stays finite.

    Returns the means, the covariances and each state's chance of lying
    within its limits: the factor its covariance with the state before the
    step was scaled by (the step's Jacobian, row by row, as the smoother
    reads it).
    """
    n = x.shape[1]
    diagonal = np.arange(n)
    through = np.ones_like(x)
    for limit, sign in ((high, 1.0), (low, -1.0)):
        sd = np.sqrt(np.maximum(P[:, diagonal, diagonal], floor))
        with np.errstate(invalid="ignore"):
            z = sign * (limit - x) / sd  # the limit in units of sd from the mean, inside > 0
        near = np.isfinite(z) & (z < CENSOR_REACH)
        if not near.any():
            continue
        z = np.where(near, z, CENSOR_REACH)
        mass, density = ndtr(z), np.exp(-0.5 * z * z) / np.sqrt(2.0 * np.pi)
        first = -z * mass - density  # E[min(W - z, 0)], W standard normal
        second = (z * z + 1.0) * mass + z * density
        variance = np.maximum((second - first**2) * sd * sd, floor)
        x = np.where(near, limit + sign * first * sd, x)
        keep = np.where(near, mass, 1.0)
        through = through * keep
        P = P * keep[:, :, None] * keep[:, None, :]
        P[:, diagonal, diagonal] = np.where(near, variance, P[:, diagonal, diagonal])
    return x, P, through


def _truncated_start(x: np.ndarray, variance: np.ndarray, low: np.ndarray,
                     high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A broad start ``N(x, diag(variance))`` within the limits: each state's truncated normal.

    A segment starts where a simulation put it, with the spread of the
    states over the record. Where that start lies on or near a limit (a
    level started at its rim), half the normal would lie where the state
    never goes; the first measurements would then be read through a mean
    and a spread no level can have. Its mean and variance are instead those
    of the normal truncated to the limits (the states independent at the
    start). Returns the means and the (diagonal) covariances.
    """
    variance = np.broadcast_to(np.asarray(variance, dtype=float), x.shape)
    sd = np.sqrt(variance)
    with np.errstate(all="ignore"):
        a, b = (low - x) / sd, (high - x) / sd
        phi_a = np.where(np.isfinite(a), np.exp(-0.5 * a * a), 0.0) / np.sqrt(2.0 * np.pi)
        phi_b = np.where(np.isfinite(b), np.exp(-0.5 * b * b), 0.0) / np.sqrt(2.0 * np.pi)
        mass = ndtr(b) - ndtr(a)
        shift = (phi_a - phi_b) / mass
        spread = 1.0 + (np.where(np.isfinite(a), a * phi_a, 0.0)
                        - np.where(np.isfinite(b), b * phi_b, 0.0)) / mass - shift**2
        limited = np.isfinite(low) | np.isfinite(high)
        sound = limited & (mass > 1e-12) & np.isfinite(shift) & (spread > 0)
        mean = np.where(sound, x + sd * shift, x)
        var = np.where(sound, variance * spread, variance)
    mean = np.clip(mean, low, high)  # a start beyond its range, where the normal says nothing
    P = np.zeros((*x.shape, x.shape[1]))
    P[:, np.arange(x.shape[1]), np.arange(x.shape[1])] = var
    return mean, P


def _limit_ends(systems: list[CompiledSystem], states,
                repeat: int) -> tuple[np.ndarray, np.ndarray]:
    """Each variant's hard limits, ``(len(systems) * repeat, n_states)`` each (infinite: none)."""
    states = list(states)
    low = np.full((len(systems), len(states)), -np.inf)
    high = np.full((len(systems), len(states)), np.inf)
    for b, system in enumerate(systems):
        for name, (lo, hi) in system.limits.items():
            low[b, states.index(name)], high[b, states.index(name)] = lo, hi
    return np.repeat(low, repeat, axis=0), np.repeat(high, repeat, axis=0)


def rk4_step(rhs, z: np.ndarray, h, column, *, right, left,
             first: np.ndarray | None = None) -> np.ndarray:
    """One fourth-order Runge-Kutta step of ``z`` over ``h``.

    ``rhs(z, column, source)`` reads the inputs at the step's stage
    ``column`` (start), ``column + 1`` (middle) and ``column + 2`` (end)
    of ``right`` at the start and of ``left`` after it (a held input's value
    before it steps); ``column`` may be one per row. ``first``: the rates
    at the start, where the caller has them.
    """
    k1 = rhs(z, column, right) if first is None else first
    k2 = rhs(z + 0.5 * h * k1, column + 1, left)
    k3 = rhs(z + 0.5 * h * k2, column + 1, left)
    k4 = rhs(z + h * k3, column + 2, left)
    return z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def smoothed(run: FilterPass) -> tuple[np.ndarray, np.ndarray]:
    """The states given every sample of their segment, and their covariances (Rauch-Tung-Striebel).

    ``run`` must come from :func:`kalman_pass` with ``keep=True``. Returns
    means ``(copies, K, L + 1, n)`` and covariances ``(copies, K, L + 1, n, n)``:
    the filter's, carried back from each segment's end through the steps'
    Jacobians. Where the filter could not tell a state (a padding step, a
    covariance that is not invertible) the filtered value stands.
    """
    if run.means is None:
        raise ValueError("smoothing needs a filter pass that kept its states (keep=True)")
    means, covs = run.means.copy(), run.covariances.copy()
    L = run.transitions.shape[2]
    for i in range(L - 1, -1, -1):
        F = run.transitions[:, :, i]
        P_next = run.predicted_covariances[:, :, i + 1]
        cross = covs[:, :, i] @ np.swapaxes(F, -1, -2)  # P_f F'
        try:
            gain = np.swapaxes(np.linalg.solve(P_next, np.swapaxes(cross, -1, -2)), -1, -2)
        except np.linalg.LinAlgError:
            gain = cross @ np.linalg.pinv(P_next)
        means[:, :, i] = run.means[:, :, i] + np.einsum(
            "...ij,...j->...i", gain, means[:, :, i + 1] - run.predicted[:, :, i + 1])
        covs[:, :, i] = run.covariances[:, :, i] + gain @ (
            covs[:, :, i + 1] - P_next) @ np.swapaxes(gain, -1, -2)
    return means, covs
