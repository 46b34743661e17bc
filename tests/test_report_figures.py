"""The loop as a lab notebook: its figures, notebook display and self-contained HTML report."""

import base64
import io
import itertools
import re
import xml.etree.ElementTree as ET

import matplotlib.image as mpimg
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import TwoSlopeNorm
from matplotlib.patches import Rectangle

from sklearn_pycc import HypothesisLoop, PolyCCRegressor, compare_skeletons, datasets, diagnose
from sklearn_pycc.plotting import plot_comparison, plot_loop


@pytest.fixture(scope="module")
def loop():
    """Two rounds: the cubic spring is missing, then nothing is."""
    frame, truth = datasets.make_oscillator(hidden=["cubic_stiffness"], noise=40.0,
                                            noise_columns=["x2_dot"], random_state=0,
                                            return_truth=True)
    X, y = frame[["t", "x1", "x2", "F_ext"]], frame[["x1_dot", "x2_dot"]]
    loop = HypothesisLoop(PolyCCRegressor(equations=truth.base_equations), X, y, n_refit=3)
    loop.run(max_rounds=3)
    assert [r.added.effect if r.added else None for r in loop.rounds] == \
        ["cubic_stiffness", None]
    return loop


def legend_texts(fig_or_ax):
    legends = fig_or_ax.legends if hasattr(fig_or_ax, "legends") else []
    legend = fig_or_ax.get_legend() if hasattr(fig_or_ax, "get_legend") else None
    legends = list(legends) + ([legend] if legend is not None else [])
    return [t.get_text() for lg in legends for t in lg.get_texts()]


def test_the_error_falls_as_points_on_a_log_axis_with_the_held_out_error_beside(loop):
    X, y = loop.X, loop.y
    skeletons = {"linear": loop.rounds[0].skeleton, "+cubic": loop.rounds[1].skeleton}
    table = compare_skeletons(skeletons, X, y)
    assert table.attrs["held_out"] == "3 folds of 4 interleaved blocks in time"
    assert (table.held_out_nrmse.iloc[1] < 0.5 * table.held_out_nrmse.iloc[0])
    assert (table.held_out_simulation_nrmse.iloc[1]
            < 0.5 * table.held_out_simulation_nrmse.iloc[0])
    fig = plot_comparison(table)
    in_sample, held_out = fig.axes
    for ax in (in_sample, held_out):
        assert ax.get_yscale() == "log"
        assert not [p for p in ax.patches if isinstance(p, Rectangle)]  # no bars
        assert len(ax.get_lines()) == 2 and all(len(line.get_xdata()) == 2
                                                 for line in ax.get_lines())
        assert [t.get_text() for t in ax.get_xticklabels()] == ["linear", "+cubic"]
    assert legend_texts(in_sample) == ["derivative NRMSE", "simulation NRMSE"]
    assert in_sample.get_ylabel().startswith("normalised error")
    assert legend_texts(held_out) == ["derivatives", "simulation"]
    assert held_out.get_title() == "Held out: 3 folds of 4 interleaved blocks in time"
    notes = [t.get_text() for t in in_sample.texts]
    assert notes == ["2 fitted\nnumbers", "3 fitted\nnumbers"]
    # every label inside the figure
    fig.canvas.draw()
    box = fig.bbox
    for text in in_sample.texts:
        extent = text.get_window_extent()
        assert box.x0 <= extent.x0 and extent.x1 <= box.x1 and extent.y1 <= box.y1
    plt.close(fig)
    loop_fig = plot_loop(loop)
    assert [t.get_text() for t in loop_fig.axes[0].get_xticklabels()] == \
        ["round 0", "round 1: +cubic_stiffness"]
    plt.close(loop_fig)


def test_the_diagnosis_figures_say_what_they_show(loop):
    wrong, right = (r.diagnosis for r in loop.rounds)
    figures = wrong.plot()
    trajectories = figures["trajectories"]
    assert legend_texts(trajectories)[:2] == ["measured", "simulated"]
    assert any(t.startswith("restart from the measured state") for t in
               legend_texts(trajectories))
    assert "largest errors" in legend_texts(trajectories)
    assert [ax.get_ylabel() for ax in trajectories.axes] == ["x1", "x2"]
    residual = figures["residual"]
    assert "suggested effect (cubic_stiffness)" in residual._suptitle.get_text()
    assert legend_texts(residual.axes[0]) == ["- a3*x1^3, as refitted",
                                              "residual, the other terms as refitted"]
    term, points = residual.axes[0].lines[:2]
    assert points.get_zorder() > term.get_zorder()  # the residual stays visible on the term
    assert residual.axes[0].get_xlabel() == "x1"
    residual_map = figures["map"]
    ax = residual_map.axes[0]
    mesh = ax.collections[0]
    assert isinstance(mesh.norm, TwoSlopeNorm) and mesh.norm.vcenter == 0
    assert mesh.norm.vmin == -mesh.norm.vmax
    assert mesh.get_cmap().name == "RdBu_r"
    # cells of too few samples: plain grey under the map, never white (a zero residual)
    grey = [p for p in ax.patches if p.get_facecolor()[:3] != (1.0, 1.0, 1.0)]
    assert grey and grey[0].zorder < mesh.zorder and not grey[0].get_hatch()
    assert legend_texts(ax) == ["fewer than 3 samples"]
    # the colour scale is set by where most samples lie, not by the largest edge cell
    assert mesh.norm.vmax < np.nanmax(np.abs(next(iter(wrong.maps.values())).mean))
    for fig in figures.values():
        plt.close(fig)
    # a model with nothing missing: no bands of largest errors, no suggested effect
    figures = right.plot()
    assert "largest errors" not in legend_texts(figures["trajectories"])
    assert figures["residual"]._suptitle.get_text() == "Residuals: nothing missing"
    assert legend_texts(figures["residual"].axes[0]) == ["residual"]
    for fig in figures.values():
        plt.close(fig)


def _png(src: str) -> np.ndarray:
    assert src.startswith("data:image/png;base64,")
    data = base64.b64decode(src.split(",", 1)[1], validate=True)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return mpimg.imread(io.BytesIO(data), format="png")


@pytest.mark.slow
def test_the_html_report_holds_everything_and_fetches_nothing(loop, tmp_path):
    path = tmp_path / "loop.html"
    document = loop.to_html(path, title="A loop")
    assert path.read_text(encoding="utf-8") == document
    root = ET.fromstring(document.replace("<!DOCTYPE html>", ""))  # well-formed
    images = root.findall(".//img")
    # the loop's figure, then three figures per round
    assert len(images) == 1 + 3 * len(loop.rounds)
    for image in images:
        pixels = _png(image.get("src"))
        assert pixels.shape[0] > 100 and pixels.shape[1] > 100
        assert image.get("alt")
    tables = root.findall(".//table")
    assert len(tables) == 1 + len(loop.rounds)  # the loop's table, each round's ranking
    header = [th.text for th in tables[1].iter("th")]
    for column in ("effect", "move", "score", "stability", "plausible", "suggested_term"):
        assert column in header
    # each heading says the round's decision once, with its verb
    headings = [h.text for h in root.iter("h2") if h.text.startswith("Round")]
    assert headings == ["Round 0: cubic_stiffness: add '- a3*x1^3' to x2_dot",
                        "Round 1: stop: nothing is missing"]
    captions = [c.text for c in root.iter("figcaption")]
    assert sum("with the suggested term's fit" in c for c in captions) == 1
    assert sum("nothing is suggested" in c for c in captions) == 1
    maths = root.findall(".//math")
    final = loop.refinement is not None and loop.refinement.adopted
    assert len(maths) == sum(len(r.model.skeleton_.residual_equations) for r in loop.rounds) \
        + (len(loop.model.skeleton_.residual_equations) if final else 0)
    assert "The loop's answer" in document
    if final:  # the output-error refinement, with its equations
        assert "refined by output error" in document
    assert "score: minus the change of the Bayesian information criterion" in document
    # nothing from the network: no script, stylesheet link or external address
    assert not root.findall(".//script") and not root.findall(".//link")
    for element in root.iter():
        for attribute in ("src", "href"):
            value = element.get(attribute)
            assert value is None or value.startswith("data:")
    assert not re.search(r"https?://|//cdn", document)


def test_estimators_and_diagnoses_show_themselves_in_a_notebook(loop):
    model = loop.rounds[1].model
    bundle = model._repr_mimebundle_()
    html = bundle["text/html"]
    assert html.startswith('<div class="pycc-equations">')
    assert html.count("<math") == 2
    assert "PolyCCRegressor" in html  # scikit-learn's display follows
    latex = model._repr_latex_()
    assert latex.startswith("$$\\begin{aligned}") and "\\dot{x_{2}} &=" in latex
    assert PolyCCRegressor(equations=["x1_dot = -a1 x1"])._repr_latex_() is None
    diagnosis = loop.rounds[0].diagnosis._repr_html_()
    assert diagnosis.count("<img") == 3 and "<table" in diagnosis
    assert "Missing effect: cubic_stiffness" in diagnosis
    assert "<table" in loop._repr_html_()


@pytest.mark.slow
def test_the_report_renders_in_headless_chromium_without_a_network(loop, tmp_path):
    import shutil
    import subprocess

    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("no Chromium on this machine (Debian: apt-get install chromium)")
    path = tmp_path / "loop.html"
    loop.to_html(path)
    shot = tmp_path / "shot.png"
    subprocess.run(
        [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1200,2400",
         f"--screenshot={shot}", path.as_uri()],
        check=True, capture_output=True, timeout=120)
    pixels = mpimg.imread(shot)
    assert pixels.shape[:2] == (2400, 1200)
    # text, tables and figures: far from a blank page
    assert pixels[..., :3].std() > 0.1
    dom = subprocess.run(
        [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", f"--user-data-dir={tmp_path / 'profile2'}",
         "--dump-dom", path.as_uri()], check=True, capture_output=True, timeout=120,
        text=True).stdout
    assert dom.count("<img") == 1 + 3 * len(loop.rounds) and "<math" in dom


@pytest.mark.slow
def test_a_long_record_is_drawn_with_a_zoom_beside_its_overview():
    from sklearn_pycc.plotting import LONG_RECORD

    frame = datasets.make_resonator(n_samples=LONG_RECORD + 1000, random_state=0)
    X = frame[["t", "x1", "u"]]
    model = PolyCCRegressor(equations=["x1_dot = x2", "x2_dot = a1 u - a2 x2 - a3 x1"]).fit(X)
    figures = diagnose(model, X, n_bootstrap=0, held_out=False).plot()
    try:
        axes = figures["trajectories"].axes
        assert len(axes) == 4  # x1 and x2: overview and zoom
        zoom = axes[1]
        start, end = zoom.get_xlim()
        samples = (end - start) / float(np.median(np.diff(X["t"])))
        assert 100 <= samples <= 700 and zoom.get_title().startswith("zoom: t ")
    finally:
        for fig in figures.values():
            plt.close(fig)


def test_the_residual_map_keeps_its_tick_labels_apart_on_a_narrow_range():
    from types import SimpleNamespace

    from sklearn_pycc.plotting import _map_figure

    mean = np.random.default_rng(0).normal(size=(12, 15))
    mean[0, :3] = np.nan
    cells = SimpleNamespace(x_edges=np.linspace(-0.0875, 0.0875, 16),
                            y_edges=np.linspace(-0.65, 0.65, 13), mean=mean,
                            count=np.where(np.isnan(mean), 0, 10),
                            equation="x2_dot", x="x1", y="x2")
    report = SimpleNamespace(maps={"x2_dot": cells}, units={"x1": "m"})
    fig = _map_figure(plt, report)
    try:
        fig.canvas.draw()
        ax = fig.axes[0]
        renderer = fig.canvas.get_renderer()
        boxes = [t.get_window_extent(renderer) for t in ax.get_xticklabels()
                 if t.get_text() and ax.get_xlim()[0] <= t.get_position()[0] <= ax.get_xlim()[1]]
        assert len(boxes) >= 3
        for left, right in itertools.pairwise(boxes):
            assert left.x1 < right.x0  # no label runs into the next
        assert ax.get_xlabel() == "x1 [m]"
    finally:
        plt.close(fig)
