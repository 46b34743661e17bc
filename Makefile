# Every target installs what it needs into .venv from nothing.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# torch is pinned by the constraints file for every pip call, so nothing can
# pull a CUDA build of it.
export PIP_CONSTRAINT := $(CURDIR)/requirements/constraints.txt
PIP := $(BIN)/python -m pip --disable-pip-version-check
# pip compiles the bytecode of every installed file one after the other (torch, scipy
# and sympy ship thousands); compileall does it on every core afterwards. Compiled it
# must be: with PYTHONDONTWRITEBYTECODE set, nothing is cached at import.
PIP_INSTALL := $(PIP) install --no-compile
COMPILE := $(BIN)/python -m compileall -q -j 0
SITE = $$($(BIN)/python -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
STAMP := $(VENV)/.installed
DIST_STAMP := $(VENV)/.dist-installed
DOCS_STAMP := $(VENV)/.docs-installed
NPROC := $(shell nproc 2>/dev/null || echo 2)
# Where the pinned torch comes from. Empty: wherever pip finds it (a machine that has
# the CPU build at hand). Elsewhere give the CPU index, so pip takes the CPU build and
# never the CUDA one: make test TORCH_INDEX=https://download.pytorch.org/whl/cpu
TORCH_INDEX ?=
TORCH_FROM := $(if $(TORCH_INDEX),--extra-index-url $(TORCH_INDEX),)

.PHONY: install test test-slow demo lint docs docs-noplot bench bench-full clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(BIN)/python pyproject.toml requirements/constraints.txt
	$(PIP_INSTALL) $(TORCH_FROM) "torch==2.13.0"
	$(PIP_INSTALL) -e ".[dev,differentiation,symbolic]"
	@# a file that does not compile (a template, a test fixture) is only left uncached
	$(COMPILE) "$(SITE)" > /dev/null || true
	touch $(STAMP)

# dask, for the sweeps on a cluster: the slow suite and the gallery use it
$(DIST_STAMP): $(STAMP)
	$(PIP_INSTALL) -e ".[dist]"
	$(COMPILE) "$(SITE)" > /dev/null || true
	touch $(DIST_STAMP)

install: $(STAMP)

test: $(STAMP)
	OMP_NUM_THREADS=1 MPLBACKEND=Agg $(BIN)/python -m pytest -n $(NPROC) -m "not slow" --durations=15 tests

test-slow: $(DIST_STAMP)
	OMP_NUM_THREADS=1 MPLBACKEND=Agg $(BIN)/python -m pytest -m slow tests

# the hypothesis loop walked through; figures go to demo-output/
demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python examples/hypothesis_loop.py demo-output

$(DOCS_STAMP): $(DIST_STAMP)
	$(PIP_INSTALL) -e ".[docs]"
	$(COMPILE) "$(SITE)" > /dev/null || true
	touch $(DOCS_STAMP)

# the documentation, warnings as errors; the gallery runs examples/plot_*.py.
# Open docs/_build/html/index.html. docs-noplot skips running the examples.
SPHINXBUILD = OMP_NUM_THREADS=1 MPLBACKEND=Agg $(BIN)/sphinx-build -W --keep-going -b html
docs: $(DOCS_STAMP)
	$(SPHINXBUILD) docs docs/_build/html

docs-noplot: $(DOCS_STAMP)
	$(SPHINXBUILD) -D plot_gallery=0 docs docs/_build/html

lint: $(STAMP)
	$(BIN)/ruff check sklearn_pycc tests examples asv_benchmarks docs

# compare.py: side-by-side timings against reference implementations (it
# reports, never fails): the main lines by default (under ten minutes on two
# cores with the asv run), every line with `make bench-full`; then the asv
# suite, once (--quick), in .venv itself ("existing" environment: nothing is
# built or downloaded), each benchmark forked from a process that imported the
# suite once (forkserver: spawning a fresh interpreter per benchmark took 12 of
# its 15 minutes). Results go to asv_benchmarks/results (saved under the
# current commit); see them again with `cd asv_benchmarks && ../.venv/bin/asv show`.
BENCH_FLAGS ?=
bench: $(STAMP)
	$(PIP) install -e ".[bench]"
	$(BIN)/python asv_benchmarks/compare.py $(BENCH_FLAGS)
	cd asv_benchmarks && $(CURDIR)/$(BIN)/asv machine --yes > /dev/null
	cd asv_benchmarks && commit=$$(git rev-parse HEAD 2>/dev/null); \
	  $(CURDIR)/$(BIN)/asv run -E existing:$(CURDIR)/$(BIN)/python --quick --show-stderr \
	    --launch-method forkserver \
	    $${commit:+--set-commit-hash $$commit}

bench-full:
	SKLEARN_PYCC_BENCH_FULL=1 $(MAKE) bench BENCH_FLAGS=--full

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache demo-output docs/_build docs/generated \
	  docs/auto_examples docs/sg_execution_times.rst
