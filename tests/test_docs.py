"""The documentation covers the public API: every public name has an entry and a docstring.

``make docs`` builds the pages themselves (warnings are errors); these checks
run without Sphinx, so a public name added without documentation fails the
test suite.
"""

import inspect
import re
from pathlib import Path

import pytest

import sklearn_pycc
from sklearn_pycc import (
    datasets,
    diagnostics,
    effects,
    measurements,
    model_selection,
    plotting,
    pycc,
    quantities,
)

DOCS = Path(__file__).resolve().parents[1] / "docs"
API = (DOCS / "api.rst").read_text()
# modules whose members are documented one by one
MODULES = {"datasets": datasets, "diagnostics": diagnostics, "effects": effects,
           "measurements": measurements, "model_selection": model_selection,
           "plotting": plotting, "pycc": pycc, "quantities": quantities}
# the public names of the design contract
DESIGN = ["CCRegressor", "PolyCCRegressor", "NeuralCCRegressor", "SymbolicCCRegressor",
          "Skeleton", "SkeletonError", "SimulationError", "diagnose", "compare_skeletons",
          "to_symbolic", "model_selection.make_simulation_scorer", "pycc.train",
          "pycc.simulate", "pycc.post_processing"]
# data, not functions or classes: documented in their module's page and the user guide
CONSTANTS = {"effects.ACTS_THROUGH", "effects.PLAUSIBILITY", "quantities.QUANTITIES",
             "quantities.MECHANICAL", "quantities.UNITS",
             "measurements.DIFFERENTIATION_METHODS", "diagnostics.effects"}


def documented_entries() -> set[str]:
    """Names listed in the autosummary tables of api.rst (relative to sklearn_pycc)."""
    entries = set()
    for block in re.findall(r"\.\. autosummary::\n((?:   .*\n|\n)+)", API):
        for line in block.splitlines():
            name = line.strip()
            if name and not name.startswith(":"):
                entries.add(name)
    return entries


def public_names() -> list[str]:
    names = [name for name in sklearn_pycc.__all__ if name not in MODULES]
    for prefix, module in MODULES.items():
        names += [f"{prefix}.{name}" for name in module.__all__
                  if f"{prefix}.{name}" not in CONSTANTS and name not in sklearn_pycc.__all__]
    return names


def resolve(name: str):
    obj = sklearn_pycc
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def test_every_public_name_is_in_the_api_reference():
    missing = sorted(set(public_names()) - documented_entries())
    assert not missing, f"public names missing from docs/api.rst: {missing}"


def test_every_name_of_the_design_contract_is_in_the_api_reference():
    assert set(DESIGN) <= documented_entries()


def test_every_api_entry_exists():
    for name in documented_entries():
        resolve(name)


@pytest.mark.parametrize("name", public_names())
def test_public_objects_and_their_methods_have_docstrings(name):
    obj = resolve(name)
    assert inspect.getdoc(obj), f"{name} has no docstring"
    if inspect.isclass(obj) and not issubclass(obj, BaseException | Warning):
        for attribute, member in vars(obj).items():
            if attribute.startswith("_") or not callable(member):
                continue
            assert inspect.getdoc(member), f"{name}.{attribute} has no docstring"


def test_estimator_docstrings_have_numpydoc_sections():
    for name in ["CCRegressor", "PolyCCRegressor", "NeuralCCRegressor", "SymbolicCCRegressor",
                 "InterpolatedCCRegressor"]:
        doc = inspect.getdoc(resolve(name))
        for section in ("Parameters\n----------", "Attributes\n----------"):
            assert section in doc, f"{name} lacks {section.splitlines()[0]}"
    for name in ["to_symbolic", "to_interpolated", "from_tables", "diagnose", "compare_skeletons"]:
        doc = inspect.getdoc(resolve(name))
        assert "Parameters\n----------" in doc and "Returns\n-------" in doc, name


def test_every_user_guide_page_is_in_its_table_of_contents():
    guide = DOCS / "user_guide"
    toctree = (guide / "index.rst").read_text()
    pages = {path.stem for path in guide.glob("*.rst")} - {"index"}
    listed = set(re.findall(r"^   (\w+)$", toctree, flags=re.MULTILINE))
    assert pages == listed
    assert {"skeletons", "constraints", "identifiability", "backends", "simulation",
            "hypothesis_loop", "measurements", "model_selection"} <= pages


def test_the_docs_render_maths_and_show_the_loop_without_a_network():
    conf = (DOCS / "conf.py").read_text()
    # MathJax is copied into the built site and loaded from there, not from a CDN
    assert '"sphinx-mathjax-offline"' in conf and "mathjax_path" not in conf
    guide = (DOCS / "user_guide" / "hypothesis_loop.rst").read_text()
    assert guide.count(".. plot::") >= 2  # the loop's figures, drawn while the docs build
    assert "score" in guide and "stability" in guide and "to_html" in guide
