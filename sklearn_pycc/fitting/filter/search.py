"""The search of the filter's likelihood over a skeleton's numbers and its noises.

The noises start at the likeliest of a grid filtered in one pass
(:func:`likeliest_noises`); a quasi-Newton search then moves the numbers and
the noises' logarithms together, each gradient from central differences
filtered side by side (:func:`fit_filter`), and the covariance is read from
the likelihood's curvature, bumps chosen by a pilot pass.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...skeleton.system import CompiledSystem
from .kalman import FilterPass, kalman_pass
from .noises import NoiseLayout

__all__ = ["GRID_VARIANTS", "NOISE_LOG_RANGE", "fit_filter", "likeliest_noises"]


#: process-noise intensities :func:`likeliest_noises` tries, in units of each state's RMS per
#: unit of time
INTENSITIES = (0.0, *np.logspace(-3, 0, 13))
#: measurement-noise levels it tries, in units of the given level
MEASUREMENT_FACTORS = (0.7, 1.0, 1.4)
#: variants :func:`likeliest_noises` filters side by side
GRID_VARIANTS = len(INTENSITIES) * len(MEASUREMENT_FACTORS)


def likeliest_noises(plan, system: CompiledSystem, noisy, measurement: np.ndarray):
    """The likeliest of a grid of noises under ``system``, all filtered in one pass.

    The process noise of the ``noisy`` states (indices, or a
    :class:`NoiseLayout`: a shared intensity at its states' mean scale, a
    held one at its value) over :data:`INTENSITIES` (times each state's
    scale), the measurement noise over :data:`MEASUREMENT_FACTORS` times
    ``measurement`` (a held one at its value).

    Returns
    -------
    process_sd : ndarray of shape (n_states,)
    measurement_sd : ndarray of shape (n_measured,)
    gain : float
        Log-likelihood per measured sample that the likeliest process noise
        adds to the likeliest without one.
    """
    layout = _layout(noisy, len(plan.states))
    grid = [(c, f) for c in INTENSITIES for f in MEASUREMENT_FACTORS]
    # a shared intensity is tried at its states' mean scale; a held one keeps its value
    scales = layout.fitted_of(np.asarray(plan.scale, dtype=float))
    q = np.array([layout.intensities(c * scales) for c, _ in grid])
    # a held measurement noise keeps its value
    fitted = layout.measurement_fitted_of(measurement)
    r = np.array([layout.measurement(f * fitted) for _, f in grid])
    run = kalman_pass(plan, [system] * len(grid), q, r)
    nll = np.where(np.isfinite(run.nll), run.nll, np.inf)
    best = int(np.argmin(nll))
    calm = min(nll[i] for i, (c, _) in enumerate(grid) if c == 0.0)
    samples = max(run.terms.shape[1], 1)
    gain = float((calm - nll[best]) / samples) if np.isfinite(nll[best]) else 0.0
    return q[best], r[best], gain


def _layout(noisy, n: int) -> NoiseLayout:
    """``noisy`` as a layout: itself, or states each with its own fitted intensity."""
    return noisy if isinstance(noisy, NoiseLayout) else NoiseLayout.each(noisy, n)


def _numbers(z: np.ndarray, p: int, layout: NoiseLayout):
    """``theta``, process and measurement standard deviations from the search vector."""
    g = layout.n_fitted
    return z[:p], layout.intensities(np.exp(z[p:p + g])), layout.measurement(np.exp(z[p + g:]))


def _variants(plan, system_for, points: np.ndarray, p: int, layout: NoiseLayout) -> FilterPass:
    """One pass of the filter at every row of ``points`` (search vectors)."""
    parts = [_numbers(z, p, layout) for z in points]
    return kalman_pass(plan, [system_for(theta) for theta, _, _ in parts],
                       np.array([q for _, q, _ in parts]), np.array([r for _, _, r in parts]))


#: the natural logarithms between which the filter searches each noise intensity
NOISE_LOG_RANGE = (-30.0, 10.0)


def fit_filter(plan, system_for: Callable[[np.ndarray], CompiledSystem], theta0: np.ndarray,
               process0: np.ndarray, measurement0: np.ndarray, *, noisy, bounds=None,
               typical: np.ndarray | None = None, max_iterations: int = 100,
               curvature: bool = True,
               step: Callable[[], object] | None = None,
               measurement_floor: np.ndarray | None = None,
               whole=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Maximise the filter's likelihood over the parameters and the noise intensities.

    Parameters
    ----------
    plan : ShootingPlan
        Segments and measurements, substeps chosen.
    system_for : callable
        Parameter vector -> compiled system.
    theta0 : ndarray
        Starting parameters (an output-error or equation-error fit).
    process0 : ndarray of shape (n_states,)
        Starting process-noise intensities (those ``noisy`` fits; a shared
        one starts at its states' mean).
    measurement0 : ndarray of shape (n_measured,)
        Starting measurement-noise standard deviations (a held one's value).
    noisy : sequence of int or NoiseLayout
        The states the process noise enters, each with its own fitted
        intensity; or a layout (intensities shared, or held at a value;
        measurement noises held).
    bounds : (ndarray, ndarray), optional
        Least and largest value of each parameter.
    typical : ndarray, optional
        Each parameter's typical size (default: its start's), a tenth of
        which is the search's unit.
    max_iterations : int, default=100
        Most quasi-Newton iterations.
    curvature : bool, default=True
        Read the covariance from the likelihood's curvature (else both
        covariances are None).
    step : callable, optional
        Called after each pass of the search (a progress bar's step).
    measurement_floor : ndarray of shape (n_measured,), optional
        The least each measurement noise may be (a quantised sensor's
        rounding, ``step / sqrt(12)``; 0: none).
    whole : ShootingPlan, optional
        The whole record's plan, where ``plan`` holds an even share of its
        segments (:func:`~sklearn_pycc.fitting.filter.stage.search_segments`):
        the search runs on ``plan``,
        then the whole record's likelihood gives its gradient and curvature
        at the result, takes one Newton step from there and is searched
        whole only where that step does not do what the curvature promised.

    Returns
    -------
    theta, process_sd, measurement_sd : ndarray
    info : dict
        ``nll`` (negative log-likelihood), ``iterations``, ``converged``,
        ``whole_step`` (with ``whole``: ``"newton"``, or ``"searched"`` where
        the Newton step fell short),
        ``covariance`` (of the parameters, from the likelihood's curvature;
        None where it is not positive definite) and ``search_covariance`` (of
        every fitted number, the noise intensities' logarithms included).
    """
    layout = _layout(noisy, len(plan.states))
    z0 = np.concatenate([
        np.asarray(theta0, float), np.log(np.maximum(layout.fitted_of(process0), 1e-12)),
        np.log(np.maximum(layout.measurement_fitted_of(measurement0), 1e-12))])
    space = _space(system_for, z0, len(theta0), layout, bounds=bounds, floor=measurement_floor,
                   typical=typical)
    z0 = np.clip(z0, space.low, space.high)
    p = space.p
    if not len(z0):  # every number given: the likelihood of that model
        nll = float(_variants(whole or plan, system_for, z0[None], p, layout).nll[0])
        theta, q, r = _numbers(z0, p, layout)
        return theta, q, r, {"nll": nll, "iterations": 0, "converged": True,
                             "search_covariance": np.zeros((0, 0)), "covariance": None}
    z, nll, iterations, converged = _quasi_newton(plan, space, z0, max_iterations=max_iterations,
                                                  step=step)
    H = _hessian(plan, space, z) if curvature or whole is not None else None
    info = {}
    if whole is not None:
        share = float(plan.own.sum()) / max(float(whole.own.sum()), 1.0)
        stepped = _whole_record_step(whole, space, z, H=H, share=share)
        info["whole_step"] = "newton" if stepped is not None else "searched"
        if stepped is None:  # the share misled: the whole record is searched from there
            z, nll, more, converged = _quasi_newton(whole, space, z,
                                                    max_iterations=max_iterations, step=step)
            iterations += more
            H = _hessian(whole, space, z) if curvature else None
        else:
            z, nll, H = stepped
    search_cov = None if H is None or not curvature else np.linalg.inv(H)
    theta, q, r = _numbers(z, p, layout)
    info.update({"nll": nll, "iterations": iterations, "converged": converged,
                 "search_covariance": search_cov,
                 "covariance": None if search_cov is None else search_cov[:p, :p]})
    return theta, q, r, info


@dataclass
class _Space:
    """What the search moves: the parameters, then the fitted noises' logarithms."""

    system_for: Callable[[np.ndarray], CompiledSystem]
    p: int
    layout: NoiseLayout
    low: np.ndarray
    high: np.ndarray
    #: the search's unit per number: a tenth of each parameter, half a factor e of each noise
    unit: np.ndarray


def _space(system_for, z0: np.ndarray, p: int, layout: NoiseLayout, *, bounds, floor,
           typical) -> _Space:
    """The search's space about its start ``z0`` (``p`` parameters first): ranges and units."""
    d = len(z0)
    low, high = np.full(d, -np.inf), np.full(d, np.inf)
    if bounds is not None:
        low[:p], high[:p] = bounds
    low[p:], high[p:] = NOISE_LOG_RANGE  # noise intensities from 1e-13 to 2e4
    if floor is not None:  # no sensor reads finer than it rounds
        fitted = layout.measurement_fitted_of(floor)
        with np.errstate(divide="ignore"):
            low[p + layout.n_fitted:] = np.maximum(low[p + layout.n_fitted:], np.log(fitted))
    # searched in units of a tenth of each parameter (half a factor e of each noise): the
    # quasi-Newton search's first step is then one of that size, not one that leaves the
    # states' range
    size = np.abs(np.clip(z0[:p], low[:p], high[:p])) if typical is None else \
        np.asarray(typical, dtype=float)
    unit = np.concatenate([0.1 * np.maximum(size, 1e-3), np.full(d - p, 0.5)])
    return _Space(system_for, p, layout, low, high, unit)


def _quasi_newton(plan, space: _Space, z0: np.ndarray, *, max_iterations: int,
                  step) -> tuple[np.ndarray, float, int, bool]:
    """L-BFGS-B over ``plan``'s likelihood from ``z0``: the numbers, their likelihood, iterations.

    Each gradient is from central differences, all filtered side by side;
    ``step`` is called after each pass.
    """
    from scipy.optimize import minimize

    d, unit = len(z0), space.unit
    failure = {"value": None}

    def value_and_gradient(u):
        z = z0 + unit * u
        s = 1e-6 * np.maximum(np.abs(z), 1.0)
        points = np.vstack([z, z + np.diag(s), z - np.diag(s)])
        nll = _variants(plan, space.system_for, points, space.p, space.layout).nll
        if step is not None:
            step()
        if not np.isfinite(nll[0]):  # worse than anything seen: the line search steps back
            return failure["value"] or 1e300, np.zeros(d)
        if failure["value"] is None:
            failure["value"] = abs(float(nll[0])) * 10.0 + 1e6
        grad = (nll[1:d + 1] - nll[d + 1:]) / (2 * s) * unit
        return float(nll[0]), np.where(np.isfinite(grad), grad, 0.0)

    result = minimize(value_and_gradient, np.zeros(d), jac=True, method="L-BFGS-B",
                      bounds=list(zip((space.low - z0) / unit, (space.high - z0) / unit)),
                      options={"maxiter": int(max_iterations), "ftol": 1e-10, "gtol": 1e-6})
    return z0 + unit * result.x, float(result.fun), int(result.nit), bool(result.success)


def _hessian(plan, space: _Space, z: np.ndarray) -> np.ndarray | None:
    """The likelihood's Hessian at ``z`` (bumps from a pilot pass), or None where it is no bowl."""
    steps = _curvature_steps(plan, space.system_for, z, space.p, layout=space.layout,
                             unit=space.unit)
    return _curvature(plan, space.system_for, z, space.p, layout=space.layout, s=steps)[2]


def _whole_record_step(whole, space: _Space, z: np.ndarray, *, H: np.ndarray | None,
                       share: float) -> tuple[np.ndarray, float, np.ndarray] | None:
    """From the optimum ``z`` of a ``share`` of the record, the whole record's by one Newton step.

    Where the share's likelihood is a bowl (its Hessian ``H``), the whole
    record is filtered at ``z`` and at each number bumped both ways by a
    tenth of its standard error (the share's, scaled by ``share``): its
    gradient, and its own curvature along each number, which with the
    share's correlations among the numbers make its Hessian. Otherwise its
    whole Hessian is read (:func:`_curvature`). The Newton step is taken
    within the numbers' ranges and kept where the likelihood falls by at
    least half what the curvature promised. Returns the numbers, their
    negative log-likelihood and the whole record's Hessian at ``z``; or None
    (no bowl, or the step fell short).
    """
    if H is None:
        steps = _curvature_steps(whole, space.system_for, z, space.p, layout=space.layout,
                                 unit=space.unit)
        nll, gradient, H = _curvature(whole, space.system_for, z, space.p,
                                      layout=space.layout, s=steps)
    else:
        nll, gradient, H = _scaled_curvature(whole, space, z, H=H, share=share)
    if H is None or not np.isfinite(gradient).all():
        return None
    moved = np.clip(z - np.linalg.solve(H, gradient), space.low, space.high)
    dz = moved - z
    promised = -(gradient @ dz + 0.5 * dz @ H @ dz)
    if promised <= WHOLE_STEP_NEGLIGIBLE:  # the share's optimum is the whole record's
        return z, nll, H
    reached = float(_variants(whole, space.system_for, moved[None], space.p,
                              space.layout).nll[0])
    if not nll - reached >= 0.5 * promised:
        return None
    return moved, reached, H


def _scaled_curvature(whole, space: _Space, z: np.ndarray, *, H: np.ndarray,
                      share: float) -> tuple[float, np.ndarray, np.ndarray | None]:
    """The whole record's likelihood at ``z``, its gradient and Hessian, in ``2 d + 1`` variants.

    Each number is bumped both ways by a tenth of the standard error the
    share's Hessian ``H`` gives it on the whole record; the curvature along
    each number is the whole record's own, the correlations among them the
    share's. The Hessian is None where a curvature is not positive.
    """
    d = len(z)
    steps = np.minimum(0.1 * np.sqrt(np.diag(np.linalg.inv(H)) * share), space.unit)
    points = np.vstack([z, z + np.diag(steps), z - np.diag(steps)])
    f = _variants(whole, space.system_for, points, space.p, space.layout).nll
    with np.errstate(all="ignore"):
        gradient = (f[1:d + 1] - f[d + 1:]) / (2 * steps)
        along = (f[1:d + 1] + f[d + 1:] - 2 * f[0]) / steps**2
    if not (np.isfinite(f).all() and (along > 0).all()):
        return float(f[0]), gradient, None
    size = np.sqrt(np.diag(H))
    root = np.sqrt(along)
    return float(f[0]), gradient, H / np.outer(size, size) * np.outer(root, root)


#: a Newton step on the whole record that promises less than this (log-likelihood) is not taken
WHOLE_STEP_NEGLIGIBLE = 1e-3


def _curvature_steps(plan, system_for, z: np.ndarray, p: int, *, layout: NoiseLayout,
                     unit: np.ndarray) -> np.ndarray:
    """Each number's bump for the curvature: a tenth of its standard error, as a pilot reads it.

    The pilot bumps each number by the search's ``unit``; a number whose
    curvature it cannot read keeps that unit. Bumps far below the standard
    error would read rounding, far above it the likelihood's bends.
    """
    d = len(z)
    points = np.vstack([z, z + np.diag(unit), z - np.diag(unit)])
    f = _variants(plan, system_for, points, p, layout).nll
    with np.errstate(all="ignore"):
        curvature = (f[1:d + 1] - 2 * f[0] + f[d + 1:]) / unit**2
        steps = 0.1 / np.sqrt(curvature)
    return np.where(np.isfinite(steps) & (steps > 0), np.minimum(steps, unit), unit)


#: how much farther than its own bump each number is bumped again, to check the curvature
CURVATURE_CHECK = 10.0
#: the most the curvature may change between the two bumps for the covariance to be given
CURVATURE_AGREEMENT = 1.5


def _curvature(plan, system_for, z: np.ndarray, p: int, *, layout: NoiseLayout,
               s: np.ndarray) -> tuple[float, np.ndarray, np.ndarray | None]:
    """The negative log-likelihood at ``z``, its gradient and its Hessian, from one pass of bumps.

    ``s`` is each number's bump (:func:`_curvature_steps`: a tenth of its
    standard error). Each pair of numbers is bumped together both ways
    (``f(z + b) + f(z - b)`` with ``b = s_i e_i + s_j e_j``), so that the
    cross curvature, like the diagonal, is exact to second order in the
    bumps. Each parameter is also bumped :data:`CURVATURE_CHECK` times as
    far: where its curvature there differs from the near one by more than a
    factor :data:`CURVATURE_AGREEMENT`, the likelihood is not the smooth
    bowl a covariance would describe (states held at their limits, sample
    after sample, leave it rippled) and the Hessian is None, as it is where
    it is not positive definite or a bump failed.
    """
    d = len(z)
    eye = np.eye(d)
    points, index = [z], {}
    for i in range(d):
        for sign in (1, -1):
            index[(i, sign)] = len(points)
            points.append(z + sign * s[i] * eye[i])
            if i < p:  # the parameters' curvature is checked (a noise's may well bend)
                index[(i, sign, "far")] = len(points)
                points.append(z + sign * CURVATURE_CHECK * s[i] * eye[i])
    for i in range(d):
        for j in range(i + 1, d):
            for sign in (1, -1):
                index[(i, j, sign)] = len(points)
                points.append(z + sign * (s[i] * eye[i] + s[j] * eye[j]))
    f = _variants(plan, system_for, np.array(points), p, layout).nll
    with np.errstate(all="ignore"):
        gradient = np.array([(f[index[(i, 1)]] - f[index[(i, -1)]]) / (2 * s[i])
                             for i in range(d)])
    if not np.isfinite(f).all():
        return float(f[0]), gradient, None
    pair = np.array([f[index[(i, 1)]] + f[index[(i, -1)]] for i in range(d)]) - 2 * f[0]
    H = np.diag(pair / s**2)
    for i in range(p):
        far = (f[index[(i, 1, "far")]] - 2 * f[0] + f[index[(i, -1, "far")]]) / (
            CURVATURE_CHECK * s[i]) ** 2
        if not (H[i, i] > 0 and far > 0
                and max(H[i, i], far) <= CURVATURE_AGREEMENT * min(H[i, i], far)):
            return float(f[0]), gradient, None
    for i in range(d):
        for j in range(i + 1, d):
            both = f[index[(i, j, 1)]] + f[index[(i, j, -1)]] - 2 * f[0]
            H[i, j] = H[j, i] = (both - pair[i] - pair[j]) / (2 * s[i] * s[j])
    try:
        np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        return float(f[0]), gradient, None
    return float(f[0]), gradient, H
