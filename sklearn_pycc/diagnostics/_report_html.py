"""A diagnosis and a hypothesis loop as HTML: for notebooks and for a self-contained report."""

from __future__ import annotations

import html

import pandas as pd

from .._utils.html_pages import equations_html, figure_html, page, preformatted, table_html

__all__ = ["RANKING_NOTE", "diagnosis_html", "loop_page"]

#: the ranking's columns a reader needs, in reading order
RANKING_SHOWN = ["effect", "called", "move", "equation", "variable", "score", "error_removed",
                 "held_out_change", "stability", "plausible", "suggested_term"]
#: what the ranking's numbers mean
RANKING_NOTE = (
    "score: minus the change of the Bayesian information criterion of the derivative "
    "residual when the effect is refitted into the model (for an effect only screened, "
    "of its fit to the residual alone); higher is better, and refitted plausible effects "
    "come first. move: the term added beside the model's, or replacing one of them. "
    "error_removed: share of the residual the refit removes. held_out_change: "
    "relative change of the error on data the fit did not see (negative helps). "
    "stability: share of resamples of the record in which the effect wins. plausible: "
    "whether the fitted term plays its physical role (blank: only screened).")
#: the residual figure's caption when the diagnosis suggests nothing
NOTHING_MISSING_CAPTION = ("The derivative residual against a state or input of the skeleton: "
                           "nothing is suggested, so no term is drawn over it.")
#: captions of a diagnosis's figures
CAPTIONS = {
    "trajectories": "Measured and simulated states (each window restarted from the "
                    "measured state).",
    "residual": "The derivative residual against the variable that explains it best, "
                "with the suggested term's fit.",
    "map": "Mean residual over the states; grey cells hold fewer than 3 samples.",
    "simulation": "What is measured against its simulation, each experiment whole from the "
                  "initial state estimated on its first samples; the unmeasured states as "
                  "simulated.",
    "open_curve": "Outside the catalogue: the free curve (with its 95 % band where the "
                  "refit has one), the terms it would replace, and the formula proposed "
                  "for it.",
    "network": "The skeleton as a network: its states, a line where one's equation reads "
               "another, its inputs beside; a suggested path or reaction dashed in red.",
}


def _ranking_table(report, rows: int = 8) -> str:
    ranking = report.ranking
    shown = [c for c in RANKING_SHOWN if c in ranking.columns]
    frame = ranking[shown].head(rows).copy()
    if "plausible" in frame.columns:
        frame["plausible"] = [("" if v is None else "yes" if v else "no")
                              for v in frame.plausible]
    frame.index = pd.RangeIndex(1, len(frame) + 1, name="rank")
    return table_html(frame)


def diagnosis_html(report, heading: int = 3, figures: bool = True) -> str:
    """A diagnosis as an HTML fragment: its summary, ranking and figures."""
    h = f"h{heading}"
    parts = [preformatted(report.summary())]
    if len(report.ranking):
        parts.append(f"<{h}>Effects tried, best first</{h}>")
        parts.append(_ranking_table(report))
        parts.append(f'<p class="pycc-note">{html.escape(RANKING_NOTE)}</p>')
    if figures:
        for name, fig in report.plot().items():
            caption = CAPTIONS.get(name, "")
            if name == "residual" and report.best is None:
                caption = NOTHING_MISSING_CAPTION
            parts.append(figure_html(fig, caption))
    return "\n".join(parts)


def loop_page(loop, title: str = "Hypothesis loop") -> str:
    """The whole record of a hypothesis loop as one self-contained HTML document."""
    from ..plotting import plot_loop

    X = loop.X
    experiments = (X["trajectory"].nunique() if "trajectory" in X.columns else 1)
    columns = ", ".join(str(c) for c in X.columns)
    derivatives = ("measured (y given)" if loop.y is not None
                   else "estimated from the states")
    body = [f"<h1>{html.escape(title)}</h1>",
            f"<p>{len(X)} samples in {experiments} experiment"
            f"{'s' if experiments != 1 else ''}; columns {html.escape(columns)}; "
            f"derivatives {derivatives}. Estimator: "
            f"<code>{html.escape(repr(loop.estimator))}</code>.</p>"]
    if not loop.rounds:
        body.append("<p>The loop has not run yet.</p>")
        return page(title, "\n".join(body))
    body.append("<h2>The error, round by round</h2>")
    body.append(figure_html(plot_loop(loop), "The largest simulation and derivative NRMSE "
                                             "of each round's model (no units: each error "
                                             "over its state's spread)."))
    body.append(table_html(loop.table()))
    body.append(preformatted(loop.summary()))
    for r in loop.rounds:
        body.append(f"<h2>Round {r.index}: {html.escape(r.decision)}</h2>")
        body.append(f"<p>Judged by {html.escape(r.judge)}"
                    + (f": {html.escape(str(r.likelihood))}" if r.likelihood else "") + ".</p>")
        body.append("<p>The fitted model:</p>")
        body.append(equations_html(r.model))
        body.append(diagnosis_html(r.diagnosis))
    body.append("<h2>The loop's answer (<code>loop.model</code>)</h2>")
    body.append(f"<p>{html.escape(loop.answer())}.</p>")
    if loop.refinement is not None and loop.refinement.adopted:
        body.append(equations_html(loop.refinement.model))
    return page(title, "\n".join(body))
