"""Is a model fitted by its Kalman filter right? Its innovations: :func:`check_innovations`.

Where the skeleton and its noises are right, the filter's innovations (each
measured state's one-step prediction error, divided by its predicted
standard deviation) are white with unit variance and unrelated to anything
the model knew when it predicted. Three readings test that:

- their **autocorrelation** at lags 1, 2, ..., within a band of
  ``z / sqrt(N)`` (and the Ljung-Box portmanteau of those lags);
- their **cumulative periodogram**, within the Kolmogorov-Smirnov band about
  the straight line of white noise (a slow drift bends it at the start, a
  missing oscillation steps it at its frequency);
- their **dependence** on each predicted state and input: how much of their
  variance a smooth function (a polynomial of degree 5) of that variable
  explains, with the F test's p-value. A missing effect sits where the
  innovations depend on a function of a state; in the equation of the state
  whose innovations show it, or, where that state's equation is a
  kinematic identity (``x1_dot = x2``), in the equation it integrates.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np
import pandas as pd
from scipy.stats import kstwobign, norm
from sklearn.utils._param_validation import Interval, validate_params

from ..fitting.filter.evidence import dependence, portmanteau
from ..skeleton.nodes import Symbol
from ._data import TIME

__all__ = ["InnovationCheck", "check_innovations"]

#: degree of the polynomial whose fit tells how much a variable explains the innovations
DEPENDENCE_DEGREE = 5


#: the fewest innovations whose whiteness is tested: on fewer, the Ljung-Box statistic of a
#: few lags and the cumulative periodogram's band pass any sequence
MIN_SAMPLES = 20


@dataclass
class InnovationCheck:
    """What the innovations of a filtered model say about it.

    Attributes
    ----------
    innovations : DataFrame
        ``t``, ``trajectory`` and each measured state's standardised
        innovation (error over its predicted standard deviation).
    autocorrelation : DataFrame
        One column per measured state, indexed by the lag (from 1).
    band : float
        Half-width of the autocorrelations' band.
    periodogram : dict
        Per measured state ``(frequency, cumulative share)``: the cumulative
        periodogram, in cycles per unit of time.
    periodogram_band : float
        Half-width of the band about the straight line of white noise.
    tests : DataFrame
        Per measured state: ``variance`` (of the standardised innovations,
        1 where the noises are right), ``ljung_box_p``, ``periodogram_distance``
        (the largest distance from the line), ``white``.
    variables : DataFrame
        At each row of :attr:`innovations`, the states the filter predicted
        it from and the inputs.
    states : list of str
        Which of :attr:`variables` are states (the others are inputs).
    dependence : DataFrame
        Per measured state and variable: ``explained`` (share of the
        variance), ``p_value`` and ``equation`` (where an effect of it would
        sit); sorted by ``explained``, largest first.
    level : float
        The level of the bands and tests.
    """

    innovations: pd.DataFrame
    autocorrelation: pd.DataFrame
    band: float
    periodogram: dict
    periodogram_band: float
    tests: pd.DataFrame
    variables: pd.DataFrame
    states: list
    dependence: pd.DataFrame
    level: float

    @property
    def white(self) -> bool:
        """Whether every measured state's innovations pass as white."""
        return bool(self.tests["white"].all())

    @property
    def depends(self) -> pd.DataFrame:
        """The rows of :attr:`dependence` too strong for chance (Bonferroni over them all).

        At fine sampling a missing effect moves one step's prediction by
        little: a share of a percent, sure on a long record, is a finding.
        """
        d = self.dependence
        return d[d["p_value"] < (1 - self.level) / max(len(d), 1)]

    def summary(self) -> str:
        """The check in words, one line per measured state."""
        lines = []
        for name, row in self.tests.iterrows():
            if row["white"]:
                text = (f"{name}: innovations white in time (Ljung-Box p = "
                        f"{row['ljung_box_p']:.2g}; cumulative periodogram within its band)")
            else:
                lag = int(self.autocorrelation[name].abs().idxmax())
                text = (f"{name}: innovations not white (Ljung-Box p = "
                        f"{row['ljung_box_p']:.2g}; autocorrelation "
                        f"{self.autocorrelation[name][lag]:+.2f} at lag {lag}, band "
                        f"+-{self.band:.2f}; cumulative periodogram "
                        f"{row['periodogram_distance']:.2f} from the line, band "
                        f"+-{self.periodogram_band:.2f})")
            if abs(row["variance"] - 1) > 0.5:
                text += (f"; their variance is {row['variance']:.2f} times the predicted: "
                         "the noises are misjudged")
            strong = self.depends[self.depends["measured"] == name]
            if len(strong):
                top = strong.iloc[0]
                text += (f"; they depend on {top['variable']} (a smooth function of it "
                         f"explains {100 * top['explained']:.1f} % of their variance, p = "
                         f"{top['p_value']:.1g}): an effect of {top['variable']} is missing "
                         f"from the equation of {top['equation']}")
            lines.append(text)
        return "\n".join(lines)


@validate_params({"level": [Interval(Real, 0, 1, closed="neither")],
                  "max_lag": [Interval(Integral, 1, None, closed="left"), None]},
                 prefer_skip_nested_validation=True)
def check_innovations(model, X, *, max_lag: int | None = None,
                      level: float = 0.95) -> InnovationCheck:
    """Test whether the one-step prediction errors of a filtered model are white.

    Parameters
    ----------
    model : CCRegressor
        Fitted with ``fit_mode="filter"``.
    X : DataFrame
        A record, with ``t`` and the inputs, as in ``fit`` (a fresh one
        judges best).
    max_lag : int, optional
        The longest lag of the autocorrelation (default: a twentieth of the
        samples, at least 5 and at most 30).
    level : float, default=0.95
        Level of the bands. A state's innovations pass as white when neither
        the Ljung-Box test nor the cumulative periodogram rejects them, each
        at half of ``1 - level``.

    Returns
    -------
    InnovationCheck

    Raises
    ------
    ValueError
        When the model was not fitted with ``fit_mode="filter"``, or ``X``
        gives fewer than :data:`MIN_SAMPLES` innovations.
    """
    X = X.reset_index(drop=True) if isinstance(X, pd.DataFrame) else X
    raw = model.innovations(X)
    measured = [c for c in raw.columns if f"{c}_sd" in raw.columns]
    frame = raw[[TIME, "trajectory"]].copy()
    for name in measured:
        frame[name] = raw[name] / raw[f"{name}_sd"]
    n = len(frame)
    if n < MIN_SAMPLES:
        raise ValueError(f"check_innovations needs at least {MIN_SAMPLES} innovations to test "
                         f"whether they are white; X gives {n}: a test on so few samples "
                         "passes anything")
    lags = int(max_lag) if max_lag is not None else int(np.clip(n // 20, 5, 30))
    lags = max(1, min(lags, n - 2))
    groups = [np.flatnonzero(frame["trajectory"].to_numpy() == k)
              for k in np.unique(frame["trajectory"])]
    alpha = (1 - level) / 2
    acf, periodograms, tests = {}, {}, {}
    band = float(norm.ppf(1 - (1 - level) / 2) / np.sqrt(n))
    step = float(np.median(np.diff(frame[TIME].to_numpy()))) if n > 1 else 1.0
    cp_band = float(kstwobign.ppf(1 - alpha) / np.sqrt(max((n - 1) // 2 - 1, 1)))
    for name in measured:
        e = frame[name].to_numpy()
        # a missing sample (no innovation) counts as one of zero, its neighbours as they are
        e = np.where(np.isfinite(e), e - np.nanmean(e), 0.0)
        acf[name] = _autocorrelation(e - e.mean(), groups, lags)
        frequency, share = _cumulative_periodogram(e - e.mean(), step)
        expected = np.arange(1, len(share) + 1) / len(share)
        distance = float(np.max(np.abs(share - expected))) if len(share) else 0.0
        p = portmanteau(acf[name], n)
        periodograms[name] = (frequency, share)
        tests[name] = {"variance": float(np.mean(e**2)), "ljung_box_p": p,
                       "periodogram_distance": distance,
                       "white": bool(p >= alpha and distance <= cp_band)}
    variables = _variables(model, X, raw.index.to_numpy())
    return InnovationCheck(
        innovations=frame,
        autocorrelation=pd.DataFrame(acf, index=pd.RangeIndex(1, lags + 1, name="lag")),
        band=band, periodogram=periodograms, periodogram_band=cp_band,
        tests=pd.DataFrame(tests).T.astype({"variance": float, "ljung_box_p": float,
                                            "periodogram_distance": float, "white": bool}),
        variables=variables, states=list(model.skeleton_.states),
        dependence=_dependence(model, variables, frame, measured),
        level=float(level))


def _autocorrelation(e: np.ndarray, groups: list[np.ndarray], lags: int) -> np.ndarray:
    """Autocorrelation at lags 1..``lags``, pooled over the experiments (never across them)."""
    total = float(np.sum(e**2)) or 1.0
    out = np.zeros(lags)
    for rows in groups:
        x = e[rows]
        for k in range(1, min(lags, len(x) - 1) + 1):
            out[k - 1] += float(np.dot(x[:-k], x[k:]))
    return out / total


def _cumulative_periodogram(e: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and the periodogram's cumulative share up to each (zero frequency left out)."""
    power = np.abs(np.fft.rfft(e)) ** 2
    m = (len(e) - 1) // 2
    power = power[1:m + 1]
    frequency = np.arange(1, m + 1) / (len(e) * step)
    total = float(power.sum())
    return frequency, (np.cumsum(power) / total if total > 0 else np.zeros(m))


def _equation_of(model, state: str) -> str:
    """Where an effect a state's innovations show sits: its equation, or the one it integrates."""
    seen = {state}
    while True:
        eq = next((e for e in model.skeleton_.parsed if e.dynamic and e.state == state), None)
        if eq is None or not isinstance(eq.rhs, Symbol) or eq.rhs.name not in \
                model.skeleton_.states or eq.rhs.name in seen:
            return state
        state = eq.rhs.name
        seen.add(state)


def _variables(model, X, rows: np.ndarray) -> pd.DataFrame:
    """The predicted states and the inputs at ``rows`` of ``X``."""
    ahead = model.predict_ahead(X, steps=1)  # what the filter predicted each sample from
    out = {s: ahead[s].to_numpy()[rows] for s in model.skeleton_.states}
    if isinstance(X, pd.DataFrame):
        out.update({u: X[u].to_numpy(dtype=float)[rows]
                    for u in model.skeleton_.inputs if u in X.columns})
    return pd.DataFrame(out)


def _dependence(model, variables: pd.DataFrame, frame: pd.DataFrame,
                measured: list[str]) -> pd.DataFrame:
    """How much of each state's innovations a smooth function of each variable explains."""
    out = []
    for name in measured:
        e = frame[name].to_numpy()
        for variable in variables.columns:
            v = variables[variable].to_numpy()
            ok = np.isfinite(v) & np.isfinite(e)
            explained, p = dependence(e[ok], v[ok], DEPENDENCE_DEGREE)
            out.append({"measured": name, "variable": variable, "explained": explained,
                        "p_value": p, "equation": _equation_of(model, name)})
    table = pd.DataFrame(out, columns=["measured", "variable", "explained", "p_value",
                                       "equation"])
    return table.sort_values("explained", ascending=False, kind="stable").reset_index(drop=True)
