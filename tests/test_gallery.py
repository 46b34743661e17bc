"""Every gallery example runs, with small settings, and draws its figures.

The documentation build runs the same scripts with their full settings;
``SKLEARN_PYCC_SMALL_EXAMPLES`` shortens the slow ones (fewer epochs or
generations) in a block the rendered gallery hides.
"""

import ast
import runpy
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
GALLERY = sorted(EXAMPLES.glob("plot_*.py"))
# the gallery the documentation promises (docs/index.rst links to it)
EXPECTED = {
    "plot_hidden_effect.py",
    "plot_gridsearch_skeletons.py",
    "plot_paper_example.py",
    "plot_position_only.py",
    "plot_two_dof.py",
    "plot_symbolic_post_processing.py",
    "plot_dask_sweep.py",
}


def docstring_of(path: Path) -> str:
    return ast.get_docstring(ast.parse(path.read_text()), clean=False) or ""


def test_the_gallery_holds_every_promised_example():
    assert {path.name for path in GALLERY} >= EXPECTED


def test_every_example_has_a_title_and_an_introduction():
    for path in GALLERY:
        docstring = docstring_of(path)
        lines = docstring.strip().splitlines()
        assert len(lines) >= 4, path.name
        assert set(lines[1].strip()) == {"="} and len(lines[1].strip()) >= len(lines[0].strip()), \
            f"{path.name}: the title must be underlined with '='"


# the documentation build (``make docs``, run by CI) executes every example with its
# full settings; here they run small, in the slow suite
@pytest.mark.slow
@pytest.mark.parametrize("path", GALLERY, ids=[path.stem for path in GALLERY])
def test_example_runs_and_draws_its_figures(path, tmp_path, monkeypatch):
    if path.name == "plot_dask_sweep.py":
        pytest.importorskip("distributed")
    monkeypatch.setenv("SKLEARN_PYCC_SMALL_EXAMPLES", "1")
    monkeypatch.chdir(tmp_path)
    plt.close("all")
    try:
        runpy.run_path(str(path), run_name="__main__")
        numbers = plt.get_fignums()
        assert numbers, f"{path.name} drew no figure"
        for number in numbers:
            figure = plt.figure(number)
            drawn = [ax for ax in figure.axes if ax.lines or ax.collections or ax.patches
                     or ax.images]
            assert drawn, f"{path.name}: figure {number} is empty"
            target = tmp_path / f"figure_{number}.png"
            figure.savefig(target, dpi=40)
            assert target.stat().st_size > 1000
    finally:
        plt.close("all")
