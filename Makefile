# The two commands of the README: `make demo` and `make test` set everything up themselves.
# Both are idempotent: the venv is built once and reinstalled only when pyproject.toml changes.

PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
PIP     = $(BIN)/python -m pip
# pytest workers: the notebook and grading tests are independent and slow; use both cores
# (each worker serves its own JupyterLab to the tests of tests/test_browser.py it gets, one browser at a time)
JOBS   ?= 2

.PHONY: demo test lab data release grade lint clean help sandbox chromium

help:
	@echo "make demo     set up .venv and run the demo on the bundled hall bag (out/demo.rrd, out/demo.png)"
	@echo "make test     set up .venv with the dev tools and run every test"
	@echo "make lab      open JupyterLab on the course notebooks"
	@echo "make data     regenerate the bundled recordings in data/ (bit-for-bit identical)"
	@echo "make release  regenerate the student copies of the exercises (exercises/release/)"
	@echo "make grade    grade exercises/submitted/ into the gradebook and exercises/grades.csv (EX=ex01 for one)"
	@echo "make lint     ruff and mypy"

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

# ENGINES: compile labkit's numba engines once into their cache (labkit/**/__pycache__), so that no
# notebook, test or command pays it on its first scan
ENGINES = $(BIN)/python -c "from labkit.lines._split_merge_engine import compile_all; compile_all()"

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(PIP) install --quiet -e ".[research]"
	$(ENGINES)
	touch $@

$(VENV)/.installed-dev: pyproject.toml | $(BIN)/python
	$(PIP) install --quiet -e ".[dev,research]"
	$(ENGINES)
	touch $@ $(VENV)/.installed

demo: $(VENV)/.installed
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

test: $(VENV)/.installed-dev sandbox chromium
	$(ENGINES)
	$(BIN)/python -m pytest -n $(JOBS)

# The students' JupyterLab: `labkit lab` (labkit/grading/lab.py) hides nbgrader's instructor tools, makes Validate
# run `labkit grade --check` (student code sandboxed) and serves the rerun viewer offline; any folder works the same,
# e.g. `labkit lab ~/labkit-exercises`
lab: $(VENV)/.installed sandbox
	$(BIN)/labkit lab . --open notebooks/00_tour.ipynb

data: $(VENV)/.installed
	$(BIN)/labkit simulate --bundled -o data -f

release: $(VENV)/.installed
	cd exercises && PATH="$(abspath $(BIN)):$$PATH" ../$(BIN)/nbgrader generate_assignment "*" --force

# Student code runs in a bubblewrap sandbox; EX=ex01 grades one exercise
grade: $(VENV)/.installed sandbox
	$(BIN)/python -m labkit.grading $(or $(EX),all) --jobs $(JOBS)

lint: $(VENV)/.installed-dev
	$(BIN)/ruff check labkit tests benchmarks
	$(BIN)/mypy labkit

clean:
	rm -rf out .pytest_cache
