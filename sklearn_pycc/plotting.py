"""Matplotlib figures of the hypothesis loop: fitted curves, diagnoses, skeleton comparisons.

matplotlib is imported when a figure is drawn, never on ``import sklearn_pycc``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["plot_comparison", "plot_curves", "plot_diagnosis"]


def _pyplot():
    import matplotlib.pyplot as plt

    return plt


def plot_curves(model, *, level="auto", truth=None, n: int = 200, domain=None):
    """The fitted curves of a model, with their confidence bands and the true curves.

    Parameters
    ----------
    model : CCRegressor
        A fitted model.
    level : float, "auto" or None, default="auto"
        Draw each curve's confidence band at this level (see
        :meth:`~sklearn_pycc.estimators.CCRegressor.cc_curves`); ``"auto"``
        draws the 95 % band when the model has an estimate of it (the
        polynomial backend's covariance, refits on resamples), None none.
    truth : dict of str -> callable, optional
        True curves by name (``truth.functions`` of a dataset), drawn
        dashed where they are known.
    n : int, default=200
        Points per curve.
    domain : (float, float) or dict, optional
        Range of each curve's argument (by default the measured range);
        beyond the measured range the axis is shaded.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per curve: the fitted curve against its argument, its
        band, the true curve and the measured range.
    """
    plt = _pyplot()
    if level == "auto":
        try:
            curves = model.cc_curves(n=n, level=0.95, domain=domain)
            level = 0.95
        except ValueError as error:
            if "no estimate of how uncertain" not in str(error):
                raise
            curves, level = model.cc_curves(n=n, domain=domain), None
    else:
        curves = model.cc_curves(n=n, level=level, domain=domain)
    truth = dict(truth or {})
    names = list(curves)
    if not names:
        raise ValueError("the model has no curves to plot (its skeleton has no f1, f2, ...)")
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.4), squeeze=False)
    for ax, name in zip(axes[0], names):
        frame = curves[name]
        x = frame["x"].to_numpy()
        if level is not None:
            ax.fill_between(x, frame["lower"], frame["upper"], color="C0", alpha=0.25, lw=0,
                            label=f"{100 * level:g} % band")
        ax.plot(x, frame[name], color="C0", lw=1.8, label="fitted")
        if name in truth:
            with np.errstate(all="ignore"):
                values = np.broadcast_to(np.asarray(truth[name](x), dtype=float), x.shape)
            ax.plot(x, values, color="k", lw=1.2, ls="--", label="true")
        lo, hi = model.curve_ranges_[name]
        for start, stop in ((x[0], lo), (hi, x[-1])):
            if stop > start:
                ax.axvspan(start, stop, color="0.5", alpha=0.12, lw=0)
        if x[0] < lo or x[-1] > hi:
            ax.axvspan(np.nan, np.nan, color="0.5", alpha=0.12, label="beyond the data")
        argument = frame.attrs.get("argument") or "u"
        ax.set_xlabel(argument)
        ax.set_ylabel(f"{name}({argument})")
        ax.set_title(name)
        ax.legend(fontsize="small")
    fig.tight_layout()
    return fig


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
