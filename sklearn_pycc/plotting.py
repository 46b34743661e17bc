"""Matplotlib figures of the hypothesis loop: fitted curves, diagnoses, skeleton comparisons.

matplotlib is imported when a figure is drawn, never on ``import sklearn_pycc``.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping

import numpy as np
import pandas as pd

from ._utils.figures import pyplot
from .skeleton.compiler import compile_expression
from .skeleton.nodes import Symbol, walk
from .skeleton.parser import parse_expression

__all__ = ["plot_comparison", "plot_curves", "plot_diagnosis", "plot_innovations", "plot_loop",
           "plot_network", "plot_noise"]


def label_axis(ax, axis: str, name: str, units: Mapping | None = None) -> None:
    r"""Label ``ax``'s ``axis`` (``"x"`` or ``"y"``) ``name [unit]``, as written.

    A unit (or name) is the user's text: it is never read as mathtext, so
    ``$\frac{m}{s$`` is drawn as those characters rather than failing
    when the figure is drawn.
    """
    unit = (units or {}).get(name)
    text = f"{name} [{unit}]" if unit else str(name)
    getattr(ax, f"set_{axis}label")(text, parse_math=False)


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
        True curves by name (``truth.functions`` of a dataset whose skeleton
        names its curves as the model does), drawn dashed; a name that is
        not a curve of the model is an error.
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
    plt = pyplot()
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
    unknown = [name for name in truth if name not in curves]
    if unknown:
        raise ValueError(f"truth names {unknown[0]!r}, which is not a curve of the model "
                         f"({', '.join(curves) or 'none'})")
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
        effect; ``"map"``: the residual maps over position x velocity;
        ``"open_curve"`` (when something outside the catalogue is suggested):
        the free curve with its 95 % band beside the terms it would replace
        and the formula proposed for it; ``"network"`` (three states or more,
        or a suggestion that joins two states): :func:`plot_network`.
    """
    plt = pyplot()
    figures = {}
    if not report.simulation.empty:
        figures["trajectories"] = _trajectory_figure(plt, report)
    figures["residual"] = _residual_figure(plt, report)
    if report.maps:
        figures["map"] = _map_figure(plt, report)
    best = report.best
    if best is not None and best.curve is not None:
        figures["open_curve"] = _open_curve_figure(plt, report)
    if len(report.model.skeleton_.states) >= 3 or _joins(best):
        figures["network"] = plot_network(report.model.skeleton_, best)
    return figures


def _joins(best) -> tuple[str, str] | None:
    """The two states a suggestion joins (a path, a reaction), or None."""
    if best is None:
        return None
    states = list(best.equations.states)
    named = [name for name in best.variable.replace("-", " ").split() if name in states]
    return (named[0], named[1]) if len(named) == 2 and named[0] != named[1] else None


def _edges(skeleton) -> tuple[set, set]:
    """Pairs of states one's equation reads the other in, and (input, state) pairs."""
    states, inputs = set(skeleton.states), set(skeleton.inputs) - {"t"}
    between, driven = set(), set()
    for eq in skeleton.parsed:
        read = {n.name for n in walk(eq.rhs) if isinstance(n, Symbol)}
        between |= {tuple(sorted((eq.state, other))) for other in read & states
                    if other != eq.state}
        driven |= {(name, eq.state) for name in read & inputs}
    return between, driven


def plot_network(skeleton, suggestion=None):
    """A skeleton as a network: its states in a ring, a line where an equation reads another.

    Inputs are small squares joined to the states whose equations read them
    (inside the ring when they drive several).
    A suggestion that joins two states (a path, a reaction; ``diagnose``'s
    ``best``) is drawn as a dashed red line between them, named in its
    field's words.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = pyplot()
    states = list(skeleton.states)
    between, driven = _edges(skeleton)
    angles = np.pi / 2 - 2 * np.pi * np.arange(len(states)) / max(len(states), 1)
    where = {name: (np.cos(a), np.sin(a)) for name, a in zip(states, angles)}
    inputs = sorted({name for name, _ in driven})
    shared = [name for name in inputs if sum(i == name for i, _ in driven) > 1]
    for k, name in enumerate(shared):  # an input of several states inside the ring
        where[name] = (0.0, 0.3 * (k - (len(shared) - 1) / 2))
    for name in inputs:  # one of a single state outside the ring, beside it
        if name not in shared:
            x, y = where[next(state for i, state in driven if i == name)]
            where[name] = (1.5 * x, 1.5 * y)
    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    for a, b in sorted(between):
        ax.plot(*zip(where[a], where[b]), color="0.45", lw=1.5, zorder=1)
    for name, state in sorted(driven):
        ax.plot(*zip(where[name], where[state]), color="0.7", lw=1, ls=":", zorder=1)
    joined = _joins(suggestion)
    if joined is not None:
        ax.plot(*zip(where[joined[0]], where[joined[1]]), color="tab:red", lw=2.5, ls="--",
                zorder=2, label=f"suggested: {suggestion.called or suggestion.effect}")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, 1.08), frameon=False,
                  fontsize="small")
    for name in states:
        ax.scatter(*where[name], s=900, color="white", edgecolor="tab:blue", lw=2, zorder=3)
        ax.annotate(name, where[name], ha="center", va="center", zorder=4)
    for name in inputs:
        ax.scatter(*where[name], s=350, marker="s", color="0.92", edgecolor="0.5", zorder=3)
        ax.annotate(name, where[name], ha="center", va="center", fontsize="small", zorder=4)
    # limits of their own: two states and their inputs lie on one vertical line, whose
    # width matplotlib's margins would leave at nothing
    reach = 0.45 + max(max(abs(x), abs(y)) for x, y in where.values())
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_aspect("equal")
    ax.axis("off")
    fig.tight_layout()
    return fig


def _open_curve_figure(plt, report):
    """The free curve with its band beside the terms it replaces (and the proposed formula)."""
    best = report.best
    frame = best.curve
    variable = frame.columns[0]
    x = frame[variable].to_numpy()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    if np.isfinite(frame["lower"]).any():
        ax.fill_between(x, frame["lower"], frame["upper"], color="C0", alpha=0.25, lw=0,
                        label="95 % band")
    name = frame.attrs.get("curve", "free curve")
    ax.plot(x, frame["curve"], color="C0", lw=1.8, label=f"free curve {name}")
    current = " + ".join(best.replaces) if best.replaces else "nothing"
    ax.plot(x, frame["current"], color="0.3", lw=1.2, ls="--",
            label=f"current: {current}")
    if "formula" in frame.columns:
        ax.plot(x, frame["formula"], color="C3", lw=1.2, ls=":",
                label=f"proposed: {best.formula}")
    label_axis(ax, "x", variable, getattr(report, "units", {}))
    per = (f" per unit of {best.variable.split(', ')[-1]}"
           if best.effect == "free_damping_curve" else "")
    ax.set_ylabel(f"subtracted from {best.equation}{per}")
    ax.legend(fontsize="small", loc="best")
    ax.set_title(f"Outside the catalogue: {best.effect} in {best.equation}")
    fig.tight_layout()
    return fig


def _model_is_wrong(report) -> bool:
    """Whether the diagnosis found something to show: a missing effect or a failure."""
    return report.best is not None or bool(report.divergences) or bool(report.implausible)


def _trajectory_figure(plt, report):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    frame = report.simulation
    states = report.model.skeleton_.states
    zoom = _zoom_span(report) if len(frame) > LONG_RECORD else None
    if zoom is None:
        fig, axes = plt.subplots(len(states), 1, figsize=(9, 2.4 * len(states) + 0.8),
                                 sharex=True, squeeze=False)
    else:  # a long record: the overview, and the worst stretch beside it where lines read
        fig, axes = plt.subplots(len(states), 2, figsize=(12, 2.4 * len(states) + 0.8),
                                 sharex="col", squeeze=False,
                                 gridspec_kw={"width_ratios": [2, 1]})
    groups = (list(frame.groupby("trajectory", sort=False)) if "trajectory" in frame.columns
              else [(None, frame)])
    horizon = report.horizon
    restarts = []  # times at which a window restarts from the measured state
    if horizon is not None and horizon.samples:
        for _, part in groups:
            restarts.extend(part["t"].to_numpy()[::horizon.samples][1:])
    show_restarts = 0 < len(restarts) <= 80
    show_windows = _model_is_wrong(report) and not report.windows.empty
    for ax, state in zip(axes[:, 0], states):
        for _, part in groups:
            ax.plot(part["t"], part[state], color="0.35", lw=1.0)
            ax.plot(part["t"], part[f"{state}_sim"], color="C3", lw=1.0, ls="--")
        if show_restarts:
            for t in restarts:
                ax.axvline(t, color="0.6", lw=0.6, ls=":")
        if show_windows:
            for row in report.windows.itertuples():
                ax.axvspan(row.start, row.end, color="C1" if row.note == "" else "C3",
                           alpha=0.15, lw=0)
        label_axis(ax, "y", state, getattr(report, "units", {}))
    if zoom is not None:
        start, end = zoom
        inside = (frame["t"] >= start) & (frame["t"] <= end)
        part = frame[inside]
        for row, state in enumerate(states):
            axes[row, 0].axvspan(start, end, color="C0", alpha=0.25, lw=0)
            ax = axes[row, 1]
            ax.plot(part["t"], part[state], color="0.35", lw=1.0)
            ax.plot(part["t"], part[f"{state}_sim"], color="C3", lw=1.0, ls="--")
            for t in restarts:
                if start <= t <= end:
                    ax.axvline(t, color="0.6", lw=0.6, ls=":")
        axes[0, 1].set_title(f"zoom: t {start:.4g} to {end:.4g} (shaded on the left)",
                             fontsize="small")
    handles = [Line2D([], [], color="0.35", lw=1.0, label="measured"),
               Line2D([], [], color="C3", lw=1.0, ls="--", label="simulated")]
    if show_restarts or (zoom is not None and restarts):
        handles.append(Line2D([], [], color="0.6", lw=0.6, ls=":",
                              label=f"restart from the measured state (every {horizon.time:.3g})"))
    if show_windows:
        handles.append(Patch(color="C1", alpha=0.3, label="largest errors"))
        if (report.windows.note != "").any():
            handles.append(Patch(color="C3", alpha=0.3, label="divergence"))
    for ax in axes[-1]:
        label_axis(ax, "x", "t", getattr(report, "units", {}))
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize="small",
               frameon=False)
    title = "Measured and simulated states"
    if horizon is not None and horizon.time is not None:
        title += f", simulated over windows of {horizon.time:.3g}"
    if report.divergences:
        title += f" (diverged at t={report.divergences[0].t_reached:.4g})"
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return fig


#: records longer than this many samples get a zoom beside their overview
LONG_RECORD = 5_000
#: a zoom shows this many windows of the horizon, within these many samples
ZOOM_WINDOWS, ZOOM_SAMPLES = 8, (100, 600)


def _zoom_span(report) -> tuple[float, float] | None:
    """The stretch of a long record to show closely: where the errors are largest."""
    t = report.simulation["t"].to_numpy()
    if t.size < 2:
        return None
    step = float(np.median(np.diff(t)))
    windows = report.windows[report.windows.note == ""] if not report.windows.empty \
        else report.windows
    horizon = report.horizon
    samples = ZOOM_SAMPLES[1] if horizon is None or not horizon.samples else int(
        np.clip(ZOOM_WINDOWS * horizon.samples, *ZOOM_SAMPLES))
    half = samples * step / 2
    centre = (float(windows.start.iloc[0] + windows.end.iloc[0]) / 2 if not windows.empty
              else float(t[0]) + half)
    start = max(float(t[0]), centre - half)
    return start, min(float(t[-1]), start + 2 * half)


def _residual_figure(plt, report):
    equations = list(report.maps) or list(report.residuals.columns)
    fig, axes = plt.subplots(1, len(equations), figsize=(max(4.8 * len(equations), 6.4), 4.0),
                             squeeze=False)
    best = report.best
    for ax, name in zip(axes[0], equations):
        part = report.explained[report.explained.equation == name]
        known = report.variable_values.get(name, {})
        if best is None:  # nothing to explain: the axis a physicist reads, a state or an input
            plain = set(report.model.skeleton_.variables)
            part = part[part.variable.isin(plain)]
        variable = part.variable.iloc[0] if not part.empty else None
        residual = report.residuals[name].to_numpy()
        if best is not None and best.equation == name and best.variable in known:
            variable = best.variable
        values = known.get(variable)
        if values is None:
            values, variable = np.arange(residual.size), "sample"
        shift = _effect_shift(report, name)
        # an open move's refit drawn here is the free curve's
        term = None if best is None else best.curve_term if best.move == "open" else best.term
        acting = None
        if shift is not None and best.move != "remove":
            acting = _term_values(report, name, term)
        if acting is not None:
            # the new term alone, against what it has to explain: the residual with the
            # refit's changes to the other terms (a gain, a damping) taken off
            # a move across equations (a chain of storages) takes out of this one its own
            taken = best.replaced_in.get(name, ()) if best.replaced_in else best.replaces
            where = f" in place of {' + '.join(taken)}" if taken else ""
            written = f"- {term}" if best.move == "open" else best.written
            # the term drawn broad and pale beneath, the residual it explains small on top:
            # where they agree the residual lies along the band, where not it leaves it
            ax.plot(values, acting, ".", ms=5, color="C3", alpha=0.35, zorder=1,
                    label=f"{written}{where}, as refitted")
            ax.plot(values, residual - shift + acting, ".", ms=1.5, color="0.2", zorder=2,
                    label="residual, the other terms as refitted")
        else:
            if shift is not None:
                written = name in best.also or name in best.replaced_in
                ax.plot(values, shift, ".", ms=5, color="C3", alpha=0.35, zorder=1,
                        label="change the suggestion makes here, as refitted" if written
                        else f"change of the model refitted without {best.term}")
            ax.plot(values, residual, ".", ms=1.5, color="0.2", zorder=2, label="residual")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.legend(fontsize="small", markerscale=2, loc="best")
        label_axis(ax, "x", variable, getattr(report, "units", {}))
        ax.set_ylabel(f"{name}: measured - model")
        ax.set_title(name)
    if best is None:
        fig.suptitle("Residuals: nothing missing")
    else:
        fig.suptitle(f"Residuals and the suggested effect ({_called(best)})")
    fig.tight_layout()
    return fig


def _term_values(report, equation: str, term: str):
    """``- term`` of the suggestion's refit on the diagnosis's rows (None if it cannot say)."""
    refit = next((c.refit for c in report.candidates
                  if c.effect.name == report.best.effect and c.roles.derivative == equation
                  and c.variable == report.best.variable and c.move == report.best.move
                  and c.refit is not None), None)
    if refit is None or report.record is None or not term:
        return None
    columns = report.record.columns
    names = list(columns)
    try:
        node = parse_expression(term)
        with np.errstate(all="ignore"):
            value = compile_expression(node, {n: i for i, n in enumerate(names)},
                                       refit.params_, refit.functions_)(
                [columns[n] for n in names])
    except (KeyError, ValueError, TypeError):
        return None
    value = np.broadcast_to(np.asarray(value, dtype=float), (report.record.n_samples,))
    return -value if np.isfinite(value).all() else None


def _effect_shift(report, equation: str):
    """How the suggested refit changes the equation's prediction, along the data."""
    best = report.best
    if best is None:
        return None
    for c in report.candidates:
        if (c.effect.name == best.effect and c.roles.derivative == best.equation
                and c.variable == best.variable and c.move == best.move and c.shifts):
            index = list(report.residuals.columns).index(equation)
            return c.shifts.get(index)
    return None


def _map_figure(plt, report):
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    maps = list(report.maps.values())
    fig, axes = plt.subplots(1, len(maps), figsize=(5.2 * len(maps), 4.2), squeeze=False)
    for ax, m in zip(axes[0], maps):
        # a cell of a sample or two is noise, not a place: grey, as a cell without any
        mean = np.where(m.count >= MAP_CELL_SAMPLES, m.mean, np.nan)
        finite = np.isfinite(mean)
        limit = _map_limit(mean, m.count)
        ax.add_patch(_no_data_patch(m))  # under the map, never a colour of the scale
        mesh = ax.pcolormesh(m.x_edges, m.y_edges, np.ma.masked_invalid(mean),
                             cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -limit, limit),
                             shading="flat")
        beyond = finite.any() and float(np.nanmax(np.abs(mean))) > limit
        fig.colorbar(mesh, ax=ax, label=f"mean residual of {m.equation} (0: white)",
                     extend="both" if beyond else "neither")
        ax.set_xlim(m.x_edges[0], m.x_edges[-1])
        ax.set_ylim(m.y_edges[0], m.y_edges[-1])
        label_axis(ax, "x", m.x, getattr(report, "units", {}))
        label_axis(ax, "y", m.y, getattr(report, "units", {}))
        ax.set_title(m.equation)
        # round ticks at about every sixth of the range, apart even for long labels
        ax.xaxis.set_major_locator(MaxNLocator(nbins=6, steps=[1, 2, 2.5, 5, 10]))
        if not finite.all():
            ax.legend(handles=[Patch(facecolor=NO_DATA_GREY,
                                     label=f"fewer than {MAP_CELL_SAMPLES} samples")],
                      loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize="small",
                      frameon=False)
    fig.suptitle("Where the model fails: mean residual over the states")
    fig.tight_layout()
    return fig


#: fewest samples a cell of a residual map is coloured by
MAP_CELL_SAMPLES = 3
#: the grey of a map's cells without enough samples
NO_DATA_GREY = "0.88"
#: share of a map's samples whose cells the colour scale spans (the rest saturate)
MAP_SCALE_SHARE = 0.98


def _map_limit(mean: np.ndarray, count: np.ndarray) -> float:
    """The colour scale's half-width: the cell mean :data:`MAP_SCALE_SHARE` of samples lie within.

    A few cells at the edge of the data, where the residual is largest,
    would otherwise set a scale that leaves every other cell white.
    """
    finite = np.isfinite(mean)
    if not finite.any():
        return 1.0
    size, weight = np.abs(mean[finite]), count[finite].astype(float)
    order = np.argsort(size)
    reached = np.cumsum(weight[order]) / weight.sum()
    limit = float(size[order][np.searchsorted(reached, MAP_SCALE_SHARE)])
    return limit if limit > 0 else float(size.max()) or 1.0


def _no_data_patch(m):
    from matplotlib.patches import Rectangle

    return Rectangle((m.x_edges[0], m.y_edges[0]), m.x_edges[-1] - m.x_edges[0],
                     m.y_edges[-1] - m.y_edges[0], facecolor=NO_DATA_GREY, lw=0, zorder=0)


#: held-out columns of a comparison table, with the words that label them
HELD_OUT_COLUMNS = {
    "held_out_nrmse": "derivatives",
    "held_out_simulation_nrmse": "simulation",
}


def plot_comparison(table: pd.DataFrame):
    """The error falling, skeleton by skeleton: a :func:`~sklearn_pycc.compare_skeletons` table.

    Returns
    -------
    matplotlib.figure.Figure
        Left: the derivative and simulation NRMSE of each skeleton (RMSE
        when the table has no NRMSE), points joined by lines on a log axis,
        each marked with how many numbers were fitted. Right (when the
        table has one): the held-out score of each skeleton, on data its
        fit did not see.
    """
    plt = pyplot()
    measures = [c for c in ("derivative_rmse", "derivative_nrmse", "simulation_rmse",
                            "simulation_nrmse")
                if c in table.columns and np.isfinite(table[c].to_numpy(dtype=float)).any()]
    if any(c.endswith("nrmse") for c in measures):  # errors without units share one axis
        measures = [c for c in measures if c.endswith("nrmse")]

    def present(column):
        return column in table.columns and np.isfinite(
            table[column].to_numpy(dtype=float)).any()

    held = [c for c in HELD_OUT_COLUMNS if present(c)]
    if not held and present("cv_score"):
        held = ["cv_score"]
    panels = 1 + bool(held)
    fig, axes = plt.subplots(1, panels, figsize=(5.4 * panels, 4.2), squeeze=False)
    labels = [str(i) for i in table.index]
    positions = np.arange(len(labels))
    ax = axes[0, 0]
    markers = {"derivative_rmse": "o", "derivative_nrmse": "o", "simulation_rmse": "s",
               "simulation_nrmse": "s"}
    for k, column in enumerate(measures):
        values = table[column].to_numpy(dtype=float)
        shown = np.where(np.isfinite(values) & (values > 0), values, np.nan)
        ax.plot(positions, shown, marker=markers[column], color=f"C{k}", lw=1.5,
                label=column.replace("_", " ").replace("nrmse", "NRMSE").replace("rmse", "RMSE"))
        for x, value in zip(positions, values):
            if not np.isfinite(value):
                ax.annotate("diverged", (x, np.nanmax(shown)), ha="center",
                            va="bottom", fontsize="small", color=f"C{k}")
    if measures:
        ax.set_yscale("log")
    top = table[measures].to_numpy(dtype=float) if measures else np.zeros((len(labels), 0))
    for x, n_params, values in zip(positions, table["n_params"], top):
        finite = values[np.isfinite(values) & (values > 0)]
        if finite.size:
            ax.annotate(f"{int(n_params)} fitted\nnumbers", (x, finite.max()),
                        xytext=(0, 8), textcoords="offset points", ha="center",
                        va="bottom", fontsize="x-small", color="0.3")
    normalised = bool(measures) and all(c.endswith("nrmse") for c in measures)
    ax.set_ylabel("normalised error, on the whole record (log scale)" if normalised
                  else "error on the whole record (log scale)")
    ax.set_title("In sample")
    ax.legend(fontsize="small", loc="lower left")
    if held:
        hx = axes[0, 1]
        for k, column in enumerate(held):
            values = table[column].to_numpy(dtype=float)
            hx.plot(positions, values, marker="D^"[k], color=f"C{k + 2}", lw=1.5,
                    label=HELD_OUT_COLUMNS.get(column, "R² of the derivatives"))
        if held == ["cv_score"]:
            hx.set_ylabel("cross-validated R² of the derivatives")
        else:
            hx.set_yscale("log")
            hx.set_ylabel("held-out NRMSE (log scale)")
        hx.legend(fontsize="small", loc="lower left")
        split = table.attrs.get("held_out")
        hx.set_title(f"Held out: {split}" if split else "On data each fit did not see",
                     fontsize="medium", parse_math=False)
    for a in axes[0]:
        # the skeletons' names are the user's: drawn as written, never as mathtext
        a.set_xticks(positions, labels, rotation=20, ha="right", parse_math=False)
        a.set_xlim(-0.5, len(labels) - 0.5)
        a.margins(y=0.25)
    fig.suptitle("Watch the error fall")
    fig.tight_layout()
    return fig


def plot_loop(loop):
    """The error of each round of a :class:`~sklearn_pycc.HypothesisLoop`.

    Returns
    -------
    matplotlib.figure.Figure
        Each round's largest derivative NRMSE and largest simulation NRMSE of
        a measured state, both without units, points joined by lines on a
        log axis (see :func:`plot_comparison`).
    """
    table = loop.table()
    states = [c for c in table.columns if c.endswith("_nrmse") and c != "derivative_nrmse"]
    simulated = (table[states].max(axis=1).to_numpy(dtype=float) if states
                 else np.full(len(table), np.nan))
    frame = pd.DataFrame({
        "derivative_nrmse": table["derivative_nrmse"].to_numpy(),
        "simulation_nrmse": simulated,
        "n_params": table["n_parameters"].to_numpy()},
        index=[f"round {r.index}" + ("" if r.index == 0 else
                                     f": {_move_label(loop.rounds[r.index - 1].added)}")
               for r in loop.rounds])
    fig = plot_comparison(frame)
    fig.suptitle("Watch the error fall, round by round")
    return fig


def _called(suggestion) -> str:
    """An effect as its field calls it (``Torricelli outflow``), else by its catalogue name."""
    called = getattr(suggestion, "called", "")
    return called if called and called != suggestion.effect.replace("_", " ") \
        else suggestion.effect


def _move_label(added) -> str:
    """A round's change in a few characters (``+cubic_stiffness``, ``pendulum for a2*x1``)."""
    if added.move == "remove":
        return f"-{added.term}"
    if added.move == "open":
        return f"outside: {added.effect}"
    if added.move == "limit":
        return f"+{added.term}"
    if added.replaces:
        return f"{_called(added)} for {' + '.join(added.replaces)}"
    return f"+{_called(added)}"


def plot_noise(noise, *, signals=None):
    """Each measured signal's spectrum with its noise model and the band the signal fills.

    Parameters
    ----------
    noise : Measurement or NoiseReading
        A record (its :attr:`~sklearn_pycc.measurements.Measurement.noise` is read)
        or a reading.
    signals : list of str, optional
        The signals to draw (default: every one with noise).

    Returns
    -------
    matplotlib.figure.Figure
        One panel per signal: the record's multitaper spectrum, the fitted
        noise model (white or coloured), the quantisation floor when the
        values are rounded, and a line where the signal's band ends.
    """
    reading = getattr(noise, "noise", noise)
    names = list(signals) if signals is not None else [
        name for name, n in reading.items() if n.level > 0] or list(reading)
    plt = pyplot()
    fig, axes = plt.subplots(len(names), 1, figsize=(7, 2.6 * len(names)), squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        n = reading[name]
        f, density = n.spectrum
        keep = f > 0
        ax.loglog(f[keep], density[keep], color="0.5", lw=0.8, label="record")
        if n.level > 0:
            kind = f"AR({len(n.ar)})" if n.coloured else "white"
            ax.loglog(f[keep], n.density(f[keep]), color="C3",
                      label=f"noise model ({kind}, level {n.level:.3g})")
        if n.quantum is not None:
            ax.axhline(2 * n.step * n.quantum**2 / 12, color="C2", ls=":", lw=1,
                       label=f"rounding of steps {n.quantum:.3g}")
        if np.isfinite(n.band):
            ax.axvline(n.band, color="C0", ls="--", lw=1, label=f"signal band ends {n.band:.3g}")
        label_axis(ax, "y", f"PSD of {name}", None)
        ax.set_title(textwrap.fill(n.describe(), 100), fontsize=8, loc="left")
        ax.legend(fontsize=7, loc="upper right")
    label_axis(axes[-1, 0], "x", "frequency (cycles per time unit)", None)
    fig.tight_layout()
    return fig


def plot_innovations(check):
    """The innovations of a filtered model: autocorrelation, cumulative periodogram, dependence.

    Parameters
    ----------
    check : InnovationCheck
        From :func:`~sklearn_pycc.diagnostics.check_innovations`.

    Returns
    -------
    matplotlib.figure.Figure
        One row per measured state: the autocorrelation of its standardised
        innovations by lag with the band white noise stays in; their
        cumulative periodogram with the band about the straight line of
        white noise; and the innovations against the variable they depend
        on most, with their mean in bins of it.
    """
    names = list(check.tests.index)
    plt = pyplot()
    fig, axes = plt.subplots(len(names), 3, figsize=(11, 3.0 * len(names)), squeeze=False)
    for row, name in zip(axes, names):
        acf = check.autocorrelation[name]
        row[0].vlines(acf.index, 0, acf.to_numpy(), color="C0")
        row[0].axhspan(-check.band, check.band, color="0.85", zorder=0,
                       label=f"{100 * check.level:g} % band of white noise")
        row[0].axhline(0, color="0.4", lw=0.8)
        label_axis(row[0], "x", "lag (samples)")
        label_axis(row[0], "y", f"autocorrelation of {name}'s innovations")
        row[0].legend(fontsize=7, loc="upper right")
        frequency, share = check.periodogram[name]
        line = np.arange(1, len(share) + 1) / max(len(share), 1)
        row[1].fill_between(frequency, line - check.periodogram_band,
                            line + check.periodogram_band, color="0.85", label="band")
        row[1].plot(frequency, share, color="C0", lw=1, label="innovations")
        label_axis(row[1], "x", "frequency (cycles per time unit)")
        label_axis(row[1], "y", "cumulative periodogram")
        verdict = "white" if check.tests.loc[name, "white"] else "not white"
        row[1].set_title(f"{name}: {verdict}", fontsize=9, loc="left")
        row[1].legend(fontsize=7, loc="lower right")
        _dependence_panel(row[2], check, name)
    fig.tight_layout()
    return fig


def _dependence_panel(ax, check, name: str) -> None:
    """The innovations of ``name`` against the variable they depend on most, binned."""
    rows = check.dependence[check.dependence["measured"] == name]
    if not len(rows):
        ax.set_axis_off()
        return
    top = rows.iloc[0]
    v = check.variables[top["variable"]].to_numpy()
    e = check.innovations[name].to_numpy()
    ok = np.isfinite(v) & np.isfinite(e)
    ax.plot(v[ok], e[ok], ".", ms=1.5, color="0.6", alpha=0.4)
    edges = np.quantile(v[ok], np.linspace(0, 1, 21))
    which = np.clip(np.searchsorted(edges, v[ok], side="right") - 1, 0, 19)
    centres = [v[ok][which == b].mean() for b in range(20) if np.any(which == b)]
    means = [e[ok][which == b].mean() for b in range(20) if np.any(which == b)]
    ax.plot(centres, means, "o-", color="C3", ms=3,
            label=f"mean in bins ({100 * top['explained']:.1f} % explained, "
                  f"p = {top['p_value']:.1g})")
    ax.axhline(0, color="0.4", lw=0.8)
    reach = max(0.5, 3 * float(np.max(np.abs(means))))  # zoomed on the means: a small shift
    ax.set_ylim(-reach, reach)
    ax.set_title("zoomed on the bins' means", fontsize=8, loc="left")
    predicted = " (predicted)" if top["variable"] in check.states else ""
    label_axis(ax, "x", f"{top['variable']}{predicted}")
    label_axis(ax, "y", f"{name}'s innovations (standardised)")
    ax.legend(fontsize=7, loc="upper right")
