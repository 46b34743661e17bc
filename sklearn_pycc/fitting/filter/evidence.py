"""Does a record show process noise? The filter under a grid of noises: process_noise_evidence.

A model that cannot follow a record without a random push (its likelihood
rises far when the filter may push it) either misses an effect or is pushed
by disturbances nobody measured. The two part where the filter's one-step
prediction errors are read: a missing effect is a function of the state,
so the errors it leaves last from one sample to the next and depend on the
predicted states; a random push leaves them white and unrelated to them.

The evidence costs a few passes of the filter, not a fit of the model: the
process noise tried over a grid of intensities (and the measurement noise
about the level the differentiation's smoothing took off the record), side
by side, the likeliest pass read again for its predicted states; and where a
push helps and leaves errors that last yet depend on no state, the noises
alone searched from the likeliest (a few iterations, the model's numbers
held) and that pass read too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2
from scipy.stats import f as f_law

from ...skeleton.system import CompiledSystem
from ..problem import Problem
from .kalman import kalman_pass
from .search import fit_filter, likeliest_noises
from .stage import (
    filter_plan,
    noisy_states,
    rounding_floor,
    search_segments,
    smoothing_level,
)

__all__ = ["ProcessNoiseEvidence", "dependence", "ljung_box", "portmanteau",
           "process_noise_evidence"]

#: least log-likelihood the push must add, per measured sample, for the record to need one
#: (parameters a little off, a model right otherwise, gain up to a few hundredths)
LEAST_GAIN = 0.02
#: lags of the Ljung-Box test of whiteness
LAGS = 20
#: significance of the whiteness test: strict, since a fit pushed by disturbances leaves its
#: parameters a little off, and that little is not a missing effect (which leaves p-values
#: far below it)
ALPHA = 1e-3
#: significance of the dependence tests, shared among them (as strict, for the same reason)
ALPHA_DEPENDENCE = 1e-4
#: degree of the polynomial of a predicted state the errors are regressed on
DEGREE = 5
#: most iterations of the search of the noises alone, from the grid's likeliest
NOISE_ITERATIONS = 15


@dataclass(frozen=True)
class ProcessNoiseEvidence:
    """What one look through the filter says about a record's process noise.

    Attributes
    ----------
    recognised : bool
        The record needs a random push (:attr:`gain`) and the errors it then
        leaves are white (:attr:`white_p`) and depend on no predicted state
        (:attr:`dependence_p`).
    gain : float
        Log-likelihood per measured sample the likeliest push adds to the
        filter without one.
    white_p : float
        The smallest Ljung-Box p-value of the measured states' standardised
        one-step errors at the likeliest push.
    dependence_p : float
        The smallest p-value of their dependence on a predicted state.
    depends_on : str or None
        The state of that smallest p-value, where it is below
        :data:`ALPHA_DEPENDENCE` shared among the tests.
    """

    recognised: bool
    gain: float
    white_p: float
    dependence_p: float
    depends_on: str | None

    @property
    def missing_under_push(self) -> bool:
        """A push, and a function of a state missing.

        The record needs a random push (:attr:`gain`), the one-step errors it
        leaves are white, yet they depend on a predicted state: a skeleton
        short of an effect, on a record that disturbances push (where they
        do not, a missing effect leaves its errors lasting from one sample to
        the next too).
        """
        return bool(self.gain >= LEAST_GAIN and self.white_p >= ALPHA
                    and self.depends_on is not None)

    def describe(self) -> str:
        """The evidence in words."""
        push = f"a random push adds {self.gain:.3f} to the log-likelihood per sample"
        if self.recognised:
            return (f"process noise recognised: {push}, and the one-step errors it leaves are "
                    f"white (Ljung-Box p = {self.white_p:.2g}) and depend on no state")
        if self.gain < LEAST_GAIN:
            return f"no process noise: {push}"
        why = [f"not white (Ljung-Box p = {self.white_p:.2g})"] if self.white_p < ALPHA else []
        if self.depends_on is not None:
            why.append(f"depend on {self.depends_on} (p = {self.dependence_p:.1g})")
        return (f"not process noise alone: {push}, but the one-step errors it leaves "
                f"{' and '.join(why)}: the skeleton misses something")


def process_noise_evidence(problem: Problem, system: CompiledSystem) -> ProcessNoiseEvidence:
    """Whether ``problem``'s record shows process noise under the fitted ``system``.

    Parameters
    ----------
    problem : Problem
        A problem with a time column, measured states and experiments.
    system : CompiledSystem
        The fitted right-hand side.

    Returns
    -------
    ProcessNoiseEvidence

    Notes
    -----
    A record long enough for the filter's fit to search a share of its
    segments (:func:`~sklearn_pycc.fitting.filter.stage.search_segments`)
    is read over the same share.
    """
    plan = filter_plan(problem, system, whole=bool(problem.hidden))
    share = search_segments(plan)  # a long record is read over a share of its segments
    plan = plan if share is None else plan.segments(share)
    # the noises as the filter's fit would hold and bound them
    layout = noisy_states(problem, list(plan.measured))
    floor = rounding_floor(problem, list(plan.measured))
    q, r, gain = likeliest_noises(plan, system, layout,
                                  np.maximum(smoothing_level(problem, plan), floor))
    read = [_errors_read(plan, system, q, r)]
    white_p, depends, dependence_p, state = _judged(read)
    if gain >= LEAST_GAIN and layout.n_fitted and white_p < ALPHA and not depends:
        # the grid moves every intensity by one factor: where the states' pushes stand in
        # another ratio its gains are off, and a filter with wrong gains leaves errors that
        # last from one sample to the next; the noises alone are searched from there
        q, r = fit_filter(plan, lambda _: system, np.zeros(0), q, r, noisy=layout,
                          max_iterations=NOISE_ITERATIONS, curvature=False,
                          measurement_floor=floor)[1:3]
        # white where either pass leaves white errors; dependent where either shows a state
        # (a filter tuned to a skeleton short of an effect follows it better, and hides it)
        read.append(_errors_read(plan, system, q, r))
        white_p, depends, dependence_p, state = _judged(read)
    return ProcessNoiseEvidence(
        recognised=bool(gain >= LEAST_GAIN and white_p >= ALPHA and not depends),
        gain=gain, white_p=float(white_p), dependence_p=float(dependence_p),
        depends_on=state if depends else None)


def _judged(read: list) -> tuple[float, bool, float, str | None]:
    """Whiteness and dependence over the passes read: the whitest, and the most dependent.

    Returns the largest whiteness p-value, whether a dependence passes the
    shared significance, its p-value and its state.
    """
    white_p = max(white for white, _ in read)
    tests = [test for _, tests in read for test in tests]
    dependence_p, state = min(tests) if tests else (1.0, None)
    return white_p, bool(dependence_p < ALPHA_DEPENDENCE / max(len(tests), 1)), \
        dependence_p, state


def _errors_read(plan, system: CompiledSystem, q: np.ndarray, r: np.ndarray):
    """One pass's standardised errors read: their least whiteness p-value, and dependence tests.

    The tests are ``(p-value, state)`` of each measured state's errors on a
    polynomial of each predicted state.
    """
    n = len(plan.states)
    kept = kalman_pass(plan, system, q[None], r[None], keep=True)
    errors = kept.innovations[0] / np.sqrt(kept.variances[0])
    predicted = kept.predicted[0].reshape(-1, n)[np.flatnonzero(plan.own.ravel())]
    white_p = min(ljung_box(e, LAGS) for e in errors.T) if errors.size else 1.0
    return white_p, [(dependence(e, predicted[:, j], DEGREE)[1], plan.states[j])
                     for e in errors.T for j in range(n)]


def ljung_box(e: np.ndarray, lags: int) -> float:
    """The Ljung-Box p-value of ``e`` (finite values, centred) over ``lags`` lags."""
    e = e[np.isfinite(e)]
    e = e - e.mean()
    n, total = len(e), float(e @ e)
    lags = min(int(lags), n - 2)
    if lags < 1 or total <= 0:
        return 1.0
    r = np.array([float(e[:-k] @ e[k:]) / total for k in range(1, lags + 1)])
    return portmanteau(r, n)


def portmanteau(autocorrelation: np.ndarray, n: int) -> float:
    """The Ljung-Box p-value of the autocorrelations at lags 1, 2, ... of ``n`` samples."""
    lags = len(autocorrelation)
    q = n * (n + 2) * float(np.sum(np.square(autocorrelation) / (n - np.arange(1, lags + 1))))
    return float(chi2.sf(q, lags))


def dependence(e: np.ndarray, v: np.ndarray, degree: int) -> tuple[float, float]:
    """The share of ``e``'s variance a polynomial of ``v`` explains, and its F test's p-value."""
    ok = np.isfinite(e) & np.isfinite(v)
    e, v = e[ok], v[ok]
    spread = float(np.ptp(v)) if len(v) else 0.0
    if len(e) <= degree + 2 or spread == 0.0:
        return 0.0, 1.0
    design = np.polynomial.legendre.legvander(2 * (v - v.min()) / spread - 1, degree)
    coef, *_ = np.linalg.lstsq(design, e, rcond=None)
    residual = e - design @ coef
    centred = e - e.mean()
    total = float(centred @ centred)
    if total <= 0:
        return 0.0, 1.0
    explained = max(0.0, 1.0 - float(residual @ residual) / total)
    df2 = len(e) - degree - 1
    statistic = (explained / degree) / max((1 - explained) / df2, 1e-300)
    return explained, float(f_law.sf(statistic, degree, df2))
