"""Where a model fails: worst time windows, explaining variables, residual maps."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..measurements.record import Record
from ._data import TIME
from ._roles import EquationRoles
from ._trajectories import Divergence

#: bins over time when measuring how much of a residual time explains
TIME_BINS = 6

__all__ = ["ResidualMap", "explained_fraction", "explaining_variables", "residual_map",
           "worst_windows"]


def explained_fraction(residual: np.ndarray, z: np.ndarray, bins: int = 20) -> float:
    """Share of the residual's variance that a function of ``z`` explains.

    The correlation ratio of the residual over ``bins`` quantile bins of
    ``z`` (any shape of dependence counts, steps included), adjusted for the
    number of bins so that an unrelated variable scores about zero.
    """
    residual = np.asarray(residual, dtype=float)
    z = np.asarray(z, dtype=float)
    n = residual.size
    total = float(np.sum((residual - residual.mean()) ** 2))
    if n < 3 * bins or total <= 0 or np.ptp(z) == 0:
        return 0.0
    edges = np.unique(np.quantile(z, np.linspace(0.0, 1.0, bins + 1)))
    if edges.size < 3:
        return 0.0
    which = np.clip(np.searchsorted(edges, z, side="right") - 1, 0, edges.size - 2)
    counts = np.bincount(which, minlength=edges.size - 1)
    sums = np.bincount(which, weights=residual, minlength=edges.size - 1)
    used = counts > 0
    means = sums[used] / counts[used]
    between = float(np.sum(counts[used] * (means - residual.mean()) ** 2))
    eta2 = between / total
    k = int(used.sum())
    adjusted = 1.0 - (1.0 - eta2) * (n - 1) / max(n - k, 1)
    return float(np.clip(adjusted, 0.0, 1.0))


def candidate_variables(roles: EquationRoles, data: Record, states: list[str],
                        inputs: list[str]) -> dict[str, np.ndarray]:
    """Variables that may explain an equation's residual, by their skeleton text."""
    columns = data.columns
    out = {name: columns[name] for name in [*states, *inputs] if name in columns}
    if roles.second_order:
        x, v = roles.position, roles.velocity
        for other, _ in roles.others:
            out[f"{x} - {other}"] = columns[x] - columns[other]
        out[f"{x}^2 {v}"] = columns[x] ** 2 * columns[v]
    if data.has_time:
        out[TIME] = columns[TIME]
    return out


def explaining_variables(residuals: np.ndarray, roles: list[EquationRoles],
                         data: Record, states: list[str], inputs: list[str]
                         ) -> tuple[pd.DataFrame, dict[str, dict[str, np.ndarray]]]:
    """For each equation, the share of its residual each variable explains (best first).

    Returns the table and the variables' values, by equation and label.
    """
    rows, values = [], {}
    for r in roles:
        residual = residuals[:, r.index]
        values[r.derivative] = candidate_variables(r, data, states, inputs)
        for name, z in values[r.derivative].items():
            # any residual of a deterministic system is some function of time: a few
            # wide bins keep to trends and drifts, which is what time can explain
            bins = TIME_BINS if name == TIME else 20
            rows.append({"equation": r.derivative, "variable": name,
                         "fraction": explained_fraction(residual, z, bins)})
    frame = pd.DataFrame(rows, columns=["equation", "variable", "fraction"])
    if frame.empty:
        return frame, values
    frame["_order"] = frame["equation"].map({r.derivative: i for i, r in enumerate(roles)})
    frame = frame.sort_values(["_order", "fraction"], ascending=[True, False], kind="stable")
    return frame.drop(columns="_order").reset_index(drop=True), values


def _rolling_mean(values: np.ndarray, width: int) -> np.ndarray:
    filled = np.where(np.isfinite(values), values, 0.0)
    sums = np.concatenate([[0.0], np.cumsum(filled)])
    return (sums[width:] - sums[:-width]) / width


def worst_windows(data: Record, simulation_error: np.ndarray | None,
                  derivative_error: np.ndarray, divergences: list[Divergence],
                  n_windows: int = 3, *, fraction: float = 0.1) -> pd.DataFrame:
    """The time windows where the model is furthest from the measurements.

    ``simulation_error`` and ``derivative_error`` are squared errors per
    row, already normalised by each signal's spread and averaged over
    signals. Windows span ``fraction`` of an experiment; a divergence is
    reported as a window from the time it stopped to the end.
    """
    columns = ["trajectory", "start", "end", "simulation_nrmse", "derivative_nrmse", "note"]
    rows = []
    for d in divergences:
        rows.append({"trajectory": d.trajectory, "start": d.t_reached, "end": d.t_end,
                     "simulation_nrmse": float("inf"), "derivative_nrmse": float("nan"),
                     "note": f"simulation diverged: {d.reason}"})
    primary = simulation_error if simulation_error is not None else derivative_error
    if not data.has_time:
        return pd.DataFrame(rows, columns=columns)
    t_all = data.columns[TIME]
    found = []
    for label, idx in data.experiment_rows:
        n = len(idx)
        width = max(3, round(fraction * n))
        if n < width:
            continue
        score = _rolling_mean(primary[idx], width)
        other = _rolling_mean(derivative_error[idx], width)
        sim = score if simulation_error is not None else np.full(score.shape, np.nan)
        finite_until = n
        if simulation_error is not None:
            bad = ~np.isfinite(simulation_error[idx])
            finite_until = int(np.argmax(bad)) if bad.any() else n
        for start in range(score.size):
            if start + width <= finite_until:
                found.append((score[start], label, idx, start, width, sim[start], other[start]))
    found.sort(key=lambda item: -item[0])
    taken: dict[object, list[tuple[int, int]]] = {}
    picked = 0
    for _, label, idx, start, width, sim, other in found:
        if picked >= n_windows:
            break
        spans = taken.setdefault(label, [])
        if any(start < b and a < start + width for a, b in spans):
            continue
        spans.append((start, start + width))
        rows.append({"trajectory": label, "start": float(t_all[idx[start]]),
                     "end": float(t_all[idx[start + width - 1]]),
                     "simulation_nrmse": float(np.sqrt(sim)),
                     "derivative_nrmse": float(np.sqrt(other)), "note": ""})
        picked += 1
    return pd.DataFrame(rows, columns=columns)


@dataclass(frozen=True)
class ResidualMap:
    """Mean residual of one equation over a grid of two variables.

    ``mean[i, j]`` is the mean residual where ``y`` falls in bin ``i`` and
    ``x`` in bin ``j`` (NaN where no sample falls).
    """

    equation: str
    x: str
    y: str
    x_edges: np.ndarray
    y_edges: np.ndarray
    mean: np.ndarray
    count: np.ndarray

    def to_frame(self) -> pd.DataFrame:
        """The map as a DataFrame indexed by ``y`` bin centres, columns ``x`` centres."""
        xc = 0.5 * (self.x_edges[1:] + self.x_edges[:-1])
        yc = 0.5 * (self.y_edges[1:] + self.y_edges[:-1])
        frame = pd.DataFrame(self.mean, index=pd.Index(yc, name=self.y),
                             columns=pd.Index(xc, name=self.x))
        frame.attrs["equation"] = self.equation
        return frame


def residual_map(equation: str, residual: np.ndarray, x_name: str, x: np.ndarray,
                 y_name: str, *, y: np.ndarray, bins: int = 15) -> ResidualMap:
    """Bin the residual over ``(x, y)`` on a regular grid."""
    def edges(values):
        lo, hi = float(np.min(values)), float(np.max(values))
        if hi <= lo:
            hi = lo + 1.0
        return np.linspace(lo, hi, bins + 1)

    xe, ye = edges(x), edges(y)
    counts, _, _ = np.histogram2d(y, x, bins=[ye, xe])
    sums, _, _ = np.histogram2d(y, x, bins=[ye, xe], weights=residual)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    return ResidualMap(equation, x_name, y_name, xe, ye, mean, counts.astype(int))
