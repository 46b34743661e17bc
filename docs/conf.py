"""Sphinx configuration of the sklearn-pycc documentation.

Build with ``make docs`` (warnings are errors). The gallery runs every
``examples/plot_*.py`` script; ``make docs-noplot`` skips running them.
"""

from __future__ import annotations

import os
import warnings

import sklearn_pycc

project = "sklearn-pycc"
author = "the sklearn-pycc developers"
copyright = "2026, the sklearn-pycc developers"
release = sklearn_pycc.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    # MathJax served from the built site itself: the maths renders offline
    "sphinx-mathjax-offline",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "matplotlib.sphinxext.plot_directive",
]

# -- figures drawn while the docs build (the user guide's plot directives) ------
plot_include_source = False
plot_html_show_source_link = False
plot_html_show_formats = False
plot_formats = [("png", 100)]
plot_rcparams = {"savefig.bbox": "tight"}

templates_path = ["_templates"]
exclude_patterns = ["_build"]
default_role = "literal"
root_doc = "index"

# -- API reference -------------------------------------------------------------
autosummary_generate = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"          # numpydoc's Parameters sections carry the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True

# -- the gallery ----------------------------------------------------------------
# Every example seeds its own randomness through ``random_state``; figures are
# drawn with the non-interactive backend.
os.environ.setdefault("MPLBACKEND", "Agg")
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    # run the plot_ scripts; the other scripts of examples/ are command-line
    # programs (make demo) and stay out of the gallery
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"(^|/)(?!plot_)[^/]*\.py$",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "min_reported_time": 1,
    "abort_on_example_error": True,
    "reset_modules": ("matplotlib",),
    "plot_gallery": "True",
    # "Examples using X" under each entry of the API reference
    "doc_module": ("sklearn_pycc",),
    "backreferences_dir": "generated/backreferences",
}

# -- HTML ------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"sklearn-pycc {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_prev_next": True,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_static_path: list[str] = []
html_show_sourcelink = False


def _skip_member(app, what, name, obj, skip, options):
    """Leave scikit-learn's metadata-routing helpers out of every class page.

    ``set_fit_request`` and friends are generated on each estimator class by
    scikit-learn, so ``:inherited-members:`` cannot exclude them.
    """
    if name == "get_metadata_routing" or (name.startswith("set_") and name.endswith("_request")):
        return True
    return skip


def setup(app):
    """Connect the member filter."""
    app.connect("autodoc-skip-member", _skip_member)


# matplotlib and others emit deprecation chatter at import; it is not ours to fix
warnings.filterwarnings("ignore", category=DeprecationWarning)
