# iblcheck: two commands a newcomer needs, `make paper` and `make test`; both set up first.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup test test-fast paper lint clean system-deps

setup: $(STAMP) system-deps

# the virtual environment, rebuilt when pyproject.toml changes
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# Debian packages: libLLVM 19 for Mitsuba's llvm variant (Debian 12's LLVM 15 aborts)
system-deps:
	@bash .ci/system-deps.sh

test: setup
	@bash .ci/system-deps.sh --test
	$(PY) -m pytest -q

test-fast: setup
	$(PY) -m pytest -q -m "not slow"

paper: setup
	$(VENV)/bin/iblcheck paper --out reports/paper

lint: setup
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info
