# The two commands that do all the set-up on a fresh machine:
#   make book   -- build the HTML book into _build/html (with the library's wheel, made by `make dist`)
#   make test   -- run every test (unit, property, exercises, nbval, strict build, browser, PDF)
# and, once set up:  make lab (JupyterLab on the book and the exercises), make bench (benchmarks),
# make study (chapter 10's comparison table, written to uwtutor/data/), make study-real (chapter 11's study),
# make pdf (the PDF edition, _build/pdf/uwtutor.pdf; needs TeX Live from Debian: PDF_DEBIAN_PACKAGES below).

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
JB     := $(VENV)/bin/jupyter-book
STAMP  := $(VENV)/.installed-stamp
NODE_STAMP := node_modules/.installed-stamp

.PHONY: setup dist book pdf pdf-deps test lab bench study study-real study-schedules notebooks clean

# The environment: the book, JupyterLab for students (the lab extra), the tests, Dask. nbgrader comes with the tests
# (tests/test_labs_nbgrader.py) but its JupyterLab menu, sidebars and server extensions are an instructor's
# (pip install "uwtutor[instructor]"): they are disabled here, so that `make lab` shows what a student sees.
# jupytext was once in a dev extra; nothing uses it and its JupyterLab extension does not load under JupyterLab 4.5,
# so it is removed from an environment made before.
NBGRADER_SERVER_EXTENSIONS := formgrader validate_assignment assignment_list course_list

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade "pip>=24"
	$(PY) -m pip install --quiet -c constraints.txt -e ".[book,pdf,lab,test,scale,data]"
	$(PY) -m pip uninstall --quiet --yes jupytext 2>/dev/null || true
	$(VENV)/bin/jupyter labextension disable --level=sys_prefix @jupyter/nbgrader >/dev/null 2>&1
	for ext in $(NBGRADER_SERVER_EXTENSIONS); do \
	  $(VENV)/bin/jupyter server extension disable --sys-prefix nbgrader.server_extensions.$$ext >/dev/null 2>&1; \
	done
	touch $(STAMP)

# MathJax, require.js and the widget manager for the offline HTML (copied into the build by
# book/_ext/offline_assets.py). Exactly the versions of package-lock.json; no install scripts needed.
$(NODE_STAMP): package.json package-lock.json
	npm ci --no-audit --no-fund --ignore-scripts --loglevel=error
	touch $(NODE_STAMP)

setup: $(STAMP) $(NODE_STAMP)

# The library's wheel and source distribution in dist/ (the HTML book carries the wheel: book/_ext/reader_edition.py
# copies dist/uwtutor-VERSION-py3-none-any.whl into it, and builds it there if it is missing). Built without
# dependencies and without build isolation, from the set-up environment (no network).
dist: setup
	rm -f dist/uwtutor-*.whl dist/uwtutor-*.tar.gz
	$(PY) -m pip wheel --no-deps --no-build-isolation --quiet --wheel-dir dist .
	$(PY) -c "import setuptools.build_meta as b; print('dist/' + b.build_sdist('dist'))"
	rm -rf build

# The HTML book, with the wheel of `make dist` and the PDF edition as downloads (the PDF is built first where TeX Live
# is installed; BOOK_PDF=no leaves it out, and an HTML book without TeX says so and has no PDF in its menus).
BOOK_PDF ?= auto

book: dist
	@if [ "$(BOOK_PDF)" != no ] && command -v xelatex >/dev/null && command -v latexmk >/dev/null; then \
	  $(PY) tools/build_pdf.py >/dev/null && echo "The PDF edition is built: _build/pdf/uwtutor.pdf"; \
	else echo "No PDF edition in this HTML book (BOOK_PDF=$(BOOK_PDF); TeX Live: make pdf-deps)"; fi
	$(JB) build --all -W -n --keep-going .
	@echo
	@echo "The book is built: open $(CURDIR)/_build/html/index.html in a browser."

# The PDF edition: the same sources through Jupyter Book's LaTeX builder and xelatex, with _config_pdf.yml merged
# over _config.yml (tools/build_pdf.py); the PDF is _build/pdf/uwtutor.pdf. About 3 minutes on 2 cores.
# TeX Live, fonts and rsvg-convert come from Debian: `make pdf-deps` installs them (as root; .ci/run does the same).
PDF_DEBIAN_PACKAGES := texlive-xetex texlive-latex-extra texlive-fonts-recommended texlive-lang-cjk latexmk \
                       fonts-freefont-otf fonts-noto-cjk fonts-dejavu-core librsvg2-bin poppler-utils

pdf: setup
	@command -v xelatex >/dev/null && command -v latexmk >/dev/null && command -v rsvg-convert >/dev/null \
	  || { echo "make pdf needs TeX Live: run 'make pdf-deps' (as root) or apt-get install $(PDF_DEBIAN_PACKAGES)"; exit 1; }
	$(PY) tools/build_pdf.py

pdf-deps:
	apt-get update -qq
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(PDF_DEBIAN_PACKAGES)

# One pytest run, so that one exit code and one summary cover everything: tests/ (unit, property,
# exercises, the strict book build and the browser test over it, the PDF edition), every docstring example of
# the library (doctests), and every book notebook re-run by nbval in strict mode (text outputs compared with the
# committed ones, after tests/nbval_sanitize.cfg; its kernels play another CPU than the one that wrote
# the outputs, tools/cpu_variants.py). On every core (pytest-xdist); --dist loadfile keeps each file,
# and so each notebook's cells, in one worker. PYTEST_ARGS adds options (e.g. PYTEST_ARGS="-k ekf").
NBVAL := --nbval --nbval-current-env --nbval-sanitize-with tests/nbval_sanitize.cfg
WORKERS ?= auto

test: setup
	$(PY) -m pytest -n $(WORKERS) --dist loadfile $(NBVAL) --doctest-modules tests uwtutor book $(PYTEST_ARGS)

# JupyterLab on the chapters (book/) and on your own copies of the exercises and labs (my-work/, made
# on first use; existing notebooks there are never overwritten). Instructors find the sources in exercises/.
lab: setup
	$(VENV)/bin/uwtutor exercises my-work
	$(VENV)/bin/uwtutor labs my-work/labs
	$(VENV)/bin/jupyter lab --ServerApp.root_dir=. $(if $(filter 0,$(shell id -u)),--allow-root)

bench: setup
	$(PY) benchmarks/run.py

# Chapter 10's table (every method x scenario x error condition, 1000 runs each) into uwtutor/data/;
# commit the three files it writes. About 8 minutes on 2 cores.
study: setup
	$(PY) studies/comparison.py --overwrite

# Chapter 11's study (the book's methods, navigate and GTSAM on the CMU Plaza logs; the widget's grid) into
# uwtutor/data/; commit the two files it writes. About 15 minutes on 2 cores.
study-real: setup
	$(PY) studies/real_data.py --overwrite

# Chapter 11's schedule study (navigate, its candidates, the RTS smoother and the same-model GTSAM graph over every
# offset of the 10 s thinning; then 5 s and 30 s without the graph; about an hour of CPU): every run appended to studies/plaza_navigation_runs.jsonl as it is done
# (a run written twice counts once), then the chapter's uwtutor/data/real_data_schedules.csv; then navigate's
# lost-track warning on the same schedules (uwtutor/data/lost_track_guard.csv, about 10 minutes); commit them.
study-schedules: setup
	$(PY) studies/plaza_navigation.py --runs studies/plaza_navigation_runs.jsonl
	$(PY) studies/plaza_navigation.py --period 5 --no-full-rate --no-gtsam --runs studies/plaza_navigation_runs.jsonl
	$(PY) studies/plaza_navigation.py --period 30 --offset-step 3 --no-full-rate --no-gtsam \
		--runs studies/plaza_navigation_runs.jsonl
	$(PY) studies/plaza_navigation.py --summarize studies/plaza_navigation_runs.jsonl --complete-offsets \
		--csv uwtutor/data/real_data_schedules.csv --overwrite > studies/plaza_navigation_table.txt
	$(PY) studies/lost_track_guard.py --csv uwtutor/data/lost_track_guard.csv --overwrite \
		> studies/lost_track_guard_table.txt

# Re-execute every book notebook in place (after changing a chapter or the library); commit the result.
# The kernels run as the CPU of tools/cpu_variants.py's MAKE, so that `make test` checks them as another.
notebooks: setup
	$(PY) tools/execute_notebooks.py book

clean:
	rm -rf _build
