# The README's two commands: `make test` and `make book`. Both set up first (idempotent).
SHELL := /bin/bash
PY    := .venv/bin/python
PIP   := .venv/bin/pip
JOBS  ?= 2

.PHONY: setup test lint unit notebooks book lab train bench videos clean

setup: .venv/.installed

.venv/.installed: requirements.txt pyproject.toml
	test -x $(PY) || python3 -m venv .venv
	$(PIP) install --disable-pip-version-check -q -r requirements.txt
	$(PIP) install --disable-pip-version-check -q --no-deps --no-build-isolation -e .
	touch $@

# Unit tests, short learning runs and CLI errors, the browser tests (tests/test_browser.py: Debian's
# /usr/bin/chromium, skipped with one line without it, kept on one worker by --dist loadgroup), then
# every notebook under nbmake, all with ACDER_FAST=1 (smaller budgets, same code path).
# tests/test_video.py renders with MuJoCo through headless EGL (MUJOCO_GL=egl), skipped with one line
# without it; Debian: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 (.ci/run does).
test: setup lint
	ACDER_FAST=1 $(PY) -m pytest -n $(JOBS) --dist loadgroup -rs -q tests
	@if ls notebooks/*.ipynb >/dev/null 2>&1; then \
	  ACDER_FAST=1 $(PY) -m pytest -n $(JOBS) -q --nbmake --nbmake-timeout=180 notebooks; fi

# Code lines fit the book's column (88, pyproject.toml): `ruff format` to fix what this finds.
LINTED := acder_lite tests experiments notebooks jupyter-config
lint: setup
	.venv/bin/ruff format --check --no-cache $(LINTED)
	.venv/bin/ruff check --no-cache $(LINTED)

# Execute the notebooks and build the HTML book into _build/html (offline, warnings are errors).
# --all: every page, every time. Sphinx rebuilds only the pages whose own file changed, so a
# change to acder_lite/ alone would leave the chapters it feeds with their old outputs.
# Then book/check_built.py reads the built pages as a reader sees them: each chapter's prose
# outweighs its code and output, every exercise has a solution, every image has alt text,
# chapter 8 stays a results page (tests/test_book_checks.py tests the checks).
book: setup
	.venv/bin/jupyter-book build --all --warningiserror --keep-going .
	$(PY) book/check_built.py _build/html

# The chapters in JupyterLab (jupyter-config/): 127.0.0.1 only, a fresh token in the URL it prints,
# the venv's Python as the kernel, no news or update checks. `ACDER_FAST=1 make lab` for the fast
# budgets; more options with ARGS="--port=8899 --no-browser".
lab: setup
	.venv/bin/jupyter lab --config=jupyter-config/jupyter_lab_config.py $(if $(filter 0,$(shell id -u)),--allow-root) $(ARGS)

# make train ARGS="--env FetchPush-v4 --method acder --seed 0 --out results/FetchPush-v4/acder/seed0"
train: setup
	$(PY) -m acder_lite train $(ARGS)

bench: setup
	$(PY) -m acder_lite bench $(ARGS)

# The book's videos of the trained policies (book/_static/videos/*.gif), rendered offline by MuJoCo
# through headless EGL (the Debian packages of the `test` target's note): experiments/videos/.
videos: setup
	experiments/videos/make.sh

clean:
	rm -rf _build .pytest_cache book/apidocs
