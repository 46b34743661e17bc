"""The README's python blocks run as written: each builds its own data and finishes.

A block preceded by ``<!-- readme-test: skip (why) -->`` is not run (a dask
cluster cannot start inside the test run), one preceded by
``<!-- readme-test: slow (why) -->`` runs in the slow suite (a loop of
several rounds); every other one runs here, in a fresh namespace, so a block
that relies on another's variables fails.
"""

import re
import warnings
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

README = Path(__file__).resolve().parents[1] / "README.md"
MARK = re.compile(r"<!-- readme-test: (?P<kind>skip|slow) \((?P<why>[^)]+)\) -->\s*$")


def _blocks() -> list:
    text = README.read_text()
    out = []
    for match in re.finditer(r"```python\n(.*?)```", text, flags=re.S):
        line = text[:match.start()].count("\n") + 1
        before = text[:match.start()].rstrip("\n").rsplit("\n", 1)[-1]
        mark = MARK.search(before)
        marks = ([] if mark is None else [pytest.mark.skip(reason=mark["why"])]
                 if mark["kind"] == "skip" else [pytest.mark.slow])
        out.append(pytest.param(match.group(1), line, id=f"line{line}", marks=marks))
    return out


def test_the_readme_has_python_blocks():
    assert len(_blocks()) >= 15


@pytest.mark.parametrize(("code", "line"), _blocks())
def test_a_readme_block_runs_as_written(code, line):
    import matplotlib.pyplot as plt

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exec(compile(code, f"README.md:{line}", "exec"), {"__name__": "readme"})
    plt.close("all")
