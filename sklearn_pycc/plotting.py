"""Matplotlib figures of the hypothesis loop: diagnoses and skeleton comparisons.

matplotlib is imported when a figure is drawn, never on ``import sklearn_pycc``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["plot_comparison", "plot_diagnosis"]


def _pyplot():
    import matplotlib.pyplot as plt

    return plt


def plot_diagnosis(report) -> dict:
    """Figures of a :class:`~sklearn_pycc.diagnostics.Diagnosis`.

    Returns
    -------
    dict of str -> matplotlib.figure.Figure
        ``"trajectories"``: measured against simulated states (when the model
        was simulated), with divergences and the worst windows marked;
        ``"residual"``: each failing equation's derivative residual against
        the variable that explains it best, with the shape of the suggested
        effect; ``"map"``: the residual maps over position x velocity.
    """
    plt = _pyplot()
    figures = {}
    if not report.simulation.empty:
        figures["trajectories"] = _trajectory_figure(plt, report)
    figures["residual"] = _residual_figure(plt, report)
    if report.maps:
        figures["map"] = _map_figure(plt, report)
    return figures


def _trajectory_figure(plt, report):
    frame = report.simulation
    states = report.model.skeleton_.states
    fig, axes = plt.subplots(len(states), 1, figsize=(9, 2.4 * len(states)), sharex=True,
                             squeeze=False)
    groups = (frame.groupby("trajectory", sort=False) if "trajectory" in frame.columns
              else [(None, frame)])
    for ax, state in zip(axes[:, 0], states):
        for k, (_, part) in enumerate(groups):
            ax.plot(part["t"], part[state], color="0.4", lw=1.0,
                    label="measured" if k == 0 else None)
            ax.plot(part["t"], part[f"{state}_sim"], color="C3", lw=1.0, ls="--",
                    label="simulated" if k == 0 else None)
        for row in report.windows.itertuples():
            ax.axvspan(row.start, row.end, color="C1" if row.note == "" else "C3",
                       alpha=0.12)
        ax.set_ylabel(state)
    axes[0, 0].legend(loc="upper right", fontsize="small")
    axes[-1, 0].set_xlabel("t")
    title = "Measured and simulated states"
    if report.divergences:
        title += f" (simulation diverged at t={report.divergences[0].t_reached:.4g})"
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def _residual_figure(plt, report):
    equations = list(report.maps) or list(report.residuals.columns)
    fig, axes = plt.subplots(1, len(equations), figsize=(4.5 * len(equations), 3.6),
                             squeeze=False)
    best = report.best
    for ax, name in zip(axes[0], equations):
        part = report.explained[report.explained.equation == name]
        variable = part.variable.iloc[0] if not part.empty else None
        residual = report.residuals[name].to_numpy()
        known = report._variables.get(name, {})
        if best is not None and best.equation == name and best.variable in known:
            variable = best.variable
        values = known.get(variable)
        if values is None:
            values, variable = np.arange(residual.size), "sample"
        ax.plot(values, residual, ".", ms=2, color="0.5", label="residual")
        shift = _effect_shift(report, name)
        if shift is not None:
            ax.plot(values, shift, ".", ms=1.5, color="C3",
                    label=f"refit with - {best.term}")
            ax.legend(fontsize="small", markerscale=4)
        ax.set_xlabel(variable)
        ax.set_ylabel(f"{name}: measured - model")
        ax.set_title(name)
    fig.suptitle("Residuals and the suggested effect")
    fig.tight_layout()
    return fig


def _effect_shift(report, equation: str):
    """How the suggested refit changes the equation's prediction, along the data."""
    best = report.best
    if best is None:
        return None
    for c in report._candidates:
        if (c.effect.name == best.effect and c.roles.derivative == best.equation
                and c.variable == best.variable and c.shifts):
            index = list(report.residuals.columns).index(equation)
            return c.shifts.get(index)
    return None


def _map_figure(plt, report):
    maps = list(report.maps.values())
    fig, axes = plt.subplots(1, len(maps), figsize=(4.8 * len(maps), 3.8), squeeze=False)
    for ax, m in zip(axes[0], maps):
        limit = np.nanmax(np.abs(m.mean)) if np.isfinite(m.mean).any() else 1.0
        mesh = ax.pcolormesh(m.x_edges, m.y_edges, np.ma.masked_invalid(m.mean),
                             cmap="RdBu_r", vmin=-limit, vmax=limit, shading="flat")
        fig.colorbar(mesh, ax=ax, label=f"mean residual of {m.equation}")
        ax.set_xlabel(m.x)
        ax.set_ylabel(m.y)
        ax.set_title(m.equation)
    fig.suptitle("Where the model fails: residual maps")
    fig.tight_layout()
    return fig


def plot_comparison(table: pd.DataFrame):
    """Bar chart of a :func:`~sklearn_pycc.compare_skeletons` table ("watch the error fall").

    Returns
    -------
    matplotlib.figure.Figure
        Derivative and simulation RMSE of each skeleton on a log scale,
        with the number of fitted parameters on top of each bar.
    """
    plt = _pyplot()
    measures = [c for c in ("derivative_rmse", "simulation_rmse")
                if c in table.columns and np.isfinite(table[c].to_numpy(dtype=float)).any()]
    fig, axes = plt.subplots(1, len(measures), figsize=(4.5 * len(measures), 3.6),
                             squeeze=False)
    labels = [str(i) for i in table.index]
    positions = np.arange(len(labels))
    for ax, column in zip(axes[0], measures):
        values = table[column].to_numpy(dtype=float)
        shown = np.where(np.isfinite(values), values, np.nan)
        bars = ax.bar(positions, shown, color="C0")
        for bar, k, value in zip(bars, table["n_params"], values):
            text = f"{k} p" if np.isfinite(value) else "diverged"
            height = bar.get_height() if np.isfinite(value) else np.nanmax(shown)
            ax.annotate(text, (bar.get_x() + bar.get_width() / 2, height),
                        ha="center", va="bottom", fontsize="small")
        ax.set_yscale("log")
        ax.set_xticks(positions, labels, rotation=20, ha="right")
        ax.set_ylabel(column.replace("_", " "))
    fig.suptitle("Watch the error fall")
    fig.tight_layout()
    return fig
