# e2v notebooks: `make lab` opens the lessons, `make test` checks the install in minutes (every
# lesson runs once), `make test-all` adds the slow tier (what CI runs).
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
QUICK_ENV := E2V_QUICK=1 PYVISTA_JUPYTER_BACKEND=static

.PHONY: venv lab test test-all unit notebooks imports browser book book-check lint format bench data real-data figures strip student clean

venv: $(STAMP)

$(STAMP): environment/requirements.txt pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --upgrade pip
	$(PY) -m pip install -r environment/requirements.txt
	$(PY) -m pip install --no-deps --no-build-isolation -e .
	$(PY) -m ipykernel install --sys-prefix --name python3 --display-name "Python 3 (e2v)"
	$(PY) tools/warm_caches.py
	touch $(STAMP)

lab: $(STAMP)
	$(VENV)/bin/jupyter lab notebooks/

# `make test`: ruff, the import contracts, the doctests, the unit tests and every lesson executed
# once in quick mode (tests/test_lessons.py: each exercise's check must fail on the student stub
# and on a wrong answer in that same run), with few Hypothesis examples. Tests marked `slow`
# (end-to-end training and CLI runs, long studies) wait for `make test-all`, which also draws
# the full Hypothesis example counts. PYTEST_ARGS passes more options (e.g. PYTEST_ARGS=-x).
# The tests run in TEST_WORKERS processes (pytest-xdist; TEST_WORKERS=0 runs them in this
# one), each test where a worker is free. OMP_WAIT_POLICY=PASSIVE: torch's idle threads sleep
# instead of spinning, which on 2 cores would take the other process's core (measured: 668 s
# spinning, 254 s passive, 452 s in one process). OMP_NUM_THREADS: each worker (and each
# lesson's kernel) gets its share of the cores, as torch threads; with more threads than
# cores a parallel step waits for a thread the other process holds (measured on 2 cores:
# 213 s at 2 threads a worker, 198 s at 1).
PYTEST := $(QUICK_ENV) $(PY) -m pytest
PYTEST_ARGS ?=
TEST_WORKERS ?= 2
CORES = $(shell $(PYTHON) -c "import os; print(len(os.sched_getaffinity(0)) if hasattr(os, \"sched_getaffinity\") else os.cpu_count() or 1)" 2>/dev/null || echo 1)
THREADS_PER_WORKER = $(shell expr $(CORES) / $(TEST_WORKERS) \| 1)
PARALLEL = $(if $(filter 0,$(TEST_WORKERS)),,OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=$(THREADS_PER_WORKER))
PARALLEL_ARGS := $(if $(filter 0,$(TEST_WORKERS)),,-n $(TEST_WORKERS) --dist worksteal)

test: $(STAMP) lint imports
	HYPOTHESIS_PROFILE=quick $(PARALLEL) $(PYTEST) --doctest-modules e2vlib tests -m "not slow" \
	  $(PARALLEL_ARGS) --durations=25 $(PYTEST_ARGS)

test-all: $(STAMP) lint imports
	HYPOTHESIS_PROFILE=full $(PARALLEL) $(PYTEST) --doctest-modules e2vlib tests \
	  $(PARALLEL_ARGS) --durations=25 $(PYTEST_ARGS)

unit: $(STAMP)
	HYPOTHESIS_PROFILE=quick $(PYTEST) --doctest-modules e2vlib tests -m "not slow" \
	  --ignore=tests/test_lessons.py

notebooks: $(STAMP)
	$(PYTEST) tests/test_lessons.py --durations=0

imports: $(STAMP)
	$(VENV)/bin/lint-imports --no-cache

# Lessons 00 and 08 in a real JupyterLab, driven by headless Chromium (Debian's chromium at
# /usr/bin/chromium) through Playwright: every cell runs without error, the 3D views draw, the
# explorer redraws. BROWSER_ARGS="--figures docs/figures" also renews the developer guide's
# screenshots.
BROWSER_STAMP := $(VENV)/.browser-installed

$(BROWSER_STAMP): environment/browser-requirements.txt $(STAMP)
	$(PY) -m pip install -r environment/browser-requirements.txt
	touch $(BROWSER_STAMP)

browser: $(BROWSER_STAMP)
	$(PY) tests/browser/run_lab.py $(BROWSER_ARGS)

# The book: every lesson executed (full mode; `make book QUICK=1` for quick mode, as CI builds it)
# and rendered with Sphinx + MyST-NB to build/book/ (open build/book/index.html). jupyter-cache
# (build/jupyter_cache, build/jupyter_cache_quick) re-runs only the lessons whose code changed,
# or all of them when the library, data_small/ or the recorded results changed;
# any cell error fails the build with the lesson and the cell named. `make book-check` opens
# every page in headless Chromium (tests/browser/check_book.py); BOOK_CHECK_ARGS="--figures
# docs/figures" also renews the screenshots of the book in docs/figures/.
BOOK_STAMP := $(VENV)/.book-installed
BOOK_MODE := $(if $(filter 1,$(QUICK)),quick,full)

$(BOOK_STAMP): environment/book-requirements.txt $(STAMP)
	$(PY) -m pip install -r environment/book-requirements.txt
	touch $(BOOK_STAMP)

book: $(BOOK_STAMP)
	$(if $(filter 1,$(QUICK)),E2V_QUICK=1) $(VENV)/bin/sphinx-build -b html -c book \
	  -d build/book-doctrees-$(BOOK_MODE) . build/book

book-check: $(BROWSER_STAMP)
	$(PY) tests/browser/check_book.py $(BOOK_CHECK_ARGS)

lint: $(STAMP)
	$(VENV)/bin/ruff check .

format: $(STAMP)
	$(VENV)/bin/ruff format e2vlib tests bench

bench: $(STAMP)
	$(PY) -m pip install -r environment/bench-requirements.txt
	$(PY) bench/run_all.py

data: $(STAMP)
	$(PY) -m e2vlib make-data --out data_small --preset small

# The real objects (lab) as samples: download and unpack the Debian packages
# under cache/real_objects (never installed), then build the catalogue's kept rows into
# cache/real_objects/data (resumable; nothing there is committed: GPL / CC-BY-SA models).
REAL_OBJECTS := $(PY) -m e2vlib.experiments.real_objects

real-data: $(STAMP)
	$(REAL_OBJECTS) download --cache cache/real_objects
	$(REAL_OBJECTS) extract --cache cache/real_objects
	$(REAL_OBJECTS) samples --cache cache/real_objects --out cache/real_objects/data

figures: $(STAMP)
	MPLBACKEND=Agg $(PY) -m e2vlib figures --out docs/figures

strip: $(STAMP)
	$(PY) tests/strip_notebooks.py notebooks/*.ipynb

student: $(STAMP)
	$(PY) tools/student.py --out student notebooks/*.ipynb

clean:
	rm -rf $(VENV) .pytest_cache
