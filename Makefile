# The two commands of the README: `make demo` and `make test` set everything up themselves.
# Both are idempotent: the venv is built once and reinstalled only when pyproject.toml changes.

PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
PIP     = $(BIN)/python -m pip
# pytest workers: the notebook and grading tests are independent and slow; use both cores
# (each worker serves its own JupyterLab to the tests of tests/test_browser.py it gets, one browser at a time)
JOBS   ?= 2

.PHONY: demo test lab data release grade lint clean help sandbox chromium docs benchmark-tables

help:
	@echo "make demo     set up .venv and run the demo on the bundled hall bag (out/demo.rrd, out/demo.png)"
	@echo "make test     set up .venv with the dev tools and run every test (the docs build last)"
	@echo "make lab      open JupyterLab on the course notebooks"
	@echo "make data     regenerate the bundled recordings in data/ (bit-for-bit identical)"
	@echo "make release  regenerate the student copies of the exercises (exercises/release/)"
	@echo "make grade    grade exercises/submitted/ into the gradebook and exercises/grades.csv (EX=ex01 for one)"
	@echo "make lint     ruff, mypy and numpydoc's validation of every public docstring"
	@echo "make docs     build the documentation into docs/_build/html (warnings are errors)"

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

# ENGINES: compile labkit's numba engines once into their cache (labkit/**/__pycache__), so that no
# notebook, test or command pays it on its first scan
ENGINES = $(BIN)/python -c "from labkit.lines._split_merge_engine import compile_all; compile_all(); from labkit.tracking import _compile_engine; _compile_engine()"

# BYTECODE: labkit's modules (and the tests') compiled into __pycache__ before a run. Python writes no bytecode
# when PYTHONDONTWRITEBYTECODE is set (it is on some machines and CI runners); then every process that imports
# labkit compiled its ~75 modules from source again (0.4-0.5 s of CPU each), and make test starts hundreds of
# them (commands, kernels, grading processes, sandboxed workers). Reading bytecode is allowed either way.
BYTECODE = $(BIN)/python -m compileall -q -j 0 labkit tests docs exercises benchmarks > /dev/null

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(PIP) install --quiet -e ".[research]"
	$(ENGINES)
	touch $@

$(VENV)/.installed-dev: pyproject.toml | $(BIN)/python
	$(PIP) install --quiet -e ".[dev,research]"
	$(ENGINES)
	touch $@ $(VENV)/.installed

demo: $(VENV)/.installed
	$(BYTECODE)
	$(BIN)/labkit demo data/hall.bag -o out

# bubblewrap, the sandbox `labkit grade` runs student code in, is a Debian package: installed here when
# missing and this is root with apt-get (as in CI); otherwise one line says how (the tests needing it skip)
sandbox:
	@command -v bwrap >/dev/null || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    apt-get update -qq && apt-get install -y -qq bubblewrap >/dev/null; \
	  else \
	    echo "note: bubblewrap is missing: 'sudo apt-get install bubblewrap' (labkit grade and its tests need it)"; \
	  fi; }

# Debian's chromium, the browser tests/test_browser.py drives headless (through the playwright package
# of the dev extra, no browser download): installed here when missing and this is root with apt-get
chromium:
	@command -v chromium >/dev/null || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    apt-get update -qq && apt-get install -y -qq chromium >/dev/null; \
	  else \
	    echo "note: chromium is missing: 'sudo apt-get install chromium' (the browser test needs it)"; \
	  fi; }

# The docs are built last (tests/test_docs_site.py: the build with warnings as errors, then its pages in
# chromium), from the notebook outputs the first run kept: the course is executed once, not twice
test: $(VENV)/.installed-dev sandbox chromium
	$(ENGINES)
	$(BYTECODE)
	$(BIN)/python -m pytest -n $(JOBS) --dist loadgroup --ignore=tests/test_docs_site.py
	$(BIN)/python -m pytest -n 0 -p no:cacheprovider tests/test_docs_site.py

# The students' JupyterLab: `labkit lab` (labkit/grading/lab.py) hides nbgrader's instructor tools, makes Validate
# run `labkit grade --check` (student code sandboxed) and serves the rerun viewer offline; any folder works the same,
# e.g. `labkit lab ~/labkit-exercises`
lab: $(VENV)/.installed sandbox
	$(BYTECODE)
	$(BIN)/labkit lab . --open notebooks/00_tour.ipynb

data: $(VENV)/.installed
	$(BIN)/labkit simulate --bundled -o data -f

release: $(VENV)/.installed
	cd exercises && PATH="$(abspath $(BIN)):$$PATH" ../$(BIN)/nbgrader generate_assignment "*" --force

# Student code runs in a bubblewrap sandbox; EX=ex01 grades one exercise
grade: $(VENV)/.installed sandbox
	$(BIN)/python -m labkit.grading $(or $(EX),all) --jobs $(JOBS)

lint: $(VENV)/.installed-dev
	$(BIN)/ruff check labkit tests benchmarks docs
	$(BIN)/mypy labkit
	$(BIN)/python -m docs.public_api

# The docs: user guides, the API reference, the course with its outputs (kept by the notebook tests in
# docs/_build/executed/, or executed here once when missing), the exercises' student copies. Warnings are
# errors, and every cross-reference must resolve (-n, nitpicky; docs/xref.py lists what may not: other projects'
# names, offline); --keep-going lists them all. tests/test_docs_site.py runs this; tests/test_docs.py checks -n.
SPHINX = $(BIN)/python -m sphinx -b html -E -n -W --keep-going -q -j 2
docs: $(VENV)/.installed-dev
	$(SPHINX) docs docs/_build/html
	@echo "docs: file://$(abspath docs/_build/html/index.html)"

# The benchmarks' tables for the docs (docs/benchmarks/*.txt, committed): minutes of both cores; run on a quiet machine
BENCHMARK_TABLES ?= dbscan1d lines pipeline
benchmark-tables: $(VENV)/.installed-dev
	@mkdir -p docs/benchmarks
	@for b in $(BENCHMARK_TABLES); do \
	  echo "benchmarks/$$b.py"; \
	  { echo "\$$ python benchmarks/$$b.py    # $$(date -u +%Y-%m-%d), $$(nproc) cores, load $$(cut -d' ' -f1-3 /proc/loadavg)"; \
	    $(BIN)/python benchmarks/$$b.py; } > docs/benchmarks/.$$b.txt.tmp && mv docs/benchmarks/.$$b.txt.tmp docs/benchmarks/$$b.txt \
	  || { rm -f docs/benchmarks/.$$b.txt.tmp; exit 1; }; \
	done

clean:
	rm -rf out .pytest_cache docs/_build docs/_generated
