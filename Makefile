# iblcheck: two commands a newcomer needs, `make paper` and `make test`; both set up first.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
# Blender's Cycles (PyPI bpy, ~1 GB) in a virtual environment of its own: bpy pins numpy < 2, which must not
# change the numbers of iblcheck's own venv. engines/cycles/ runs in it as a command. Wheels exist for CPython
# 3.11 only; without it the Cycles tests and E12's Cycles rows say why they are absent.
CYCLES_VENV  := .venv-cycles
CYCLES_STAMP := $(CYCLES_VENV)/.installed
BPY_VERSION  := 5.0.1

.PHONY: setup web-engines test test-fast paper lint clean system-deps mutation shader-mutants

setup: $(STAMP) system-deps $(CYCLES_STAMP) web-engines

# three.js, Babylon.js and puppeteer-core for the web engines (engines/web), reinstalled when the lock changes;
# best effort: without npm (Debian's nodejs/npm) or the registry, the browser tests skip and say why
WEB_STAMP := engines/web/node_modules/.installed
web-engines: system-deps
	@if [ -f $(WEB_STAMP) ] && [ $(WEB_STAMP) -nt engines/web/package-lock.json ]; then :; \
	elif command -v npm >/dev/null; then \
		npm ci --prefix engines/web --no-audit --no-fund --loglevel=error && touch $(WEB_STAMP) \
		|| echo "warning: npm ci --prefix engines/web failed; the three.js/Babylon.js engines and their tests are unavailable" >&2; \
	else echo "warning: npm is missing (Debian's nodejs npm); the three.js/Babylon.js engines and their tests are unavailable" >&2; fi

$(CYCLES_STAMP):
	@$(PYTHON) -m venv $(CYCLES_VENV) && $(CYCLES_VENV)/bin/python -m pip install --quiet bpy==$(BPY_VERSION) \
		&& touch $(CYCLES_STAMP) \
		|| echo "warning: bpy $(BPY_VERSION) (Blender/Cycles) did not install for $$($(PYTHON) --version); the Cycles tests will skip"

# the virtual environment, rebuilt when pyproject.toml changes
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# Debian packages: libLLVM 19 for Mitsuba's llvm variant (Debian 12's LLVM 15 aborts)
system-deps:
	@bash .ci/system-deps.sh

# the import contracts of docs/architecture.md first (seconds), then the tests on two processes (pytest-xdist;
# `-n 0` runs them in one, e.g. `make test PYTEST_ARGS="-n 0"`); the 25 slowest are listed at the end, where
# the suite's time goes
PYTEST_ARGS ?= -n 2 --durations=25
test: setup
	@bash .ci/system-deps.sh --test
	$(VENV)/bin/lint-imports
	$(PY) -m pytest -q $(PYTEST_ARGS)

test-fast: setup
	$(VENV)/bin/lint-imports
	$(PY) -m pytest -q $(PYTEST_ARGS) -m "not slow"

paper: setup
	$(VENV)/bin/iblcheck paper --out reports/paper

lint: setup
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) $(CYCLES_VENV) .pytest_cache build *.egg-info

# Mutation testing of the core numerical modules (mutmut, configured in pyproject.toml [tool.mutmut]); slow,
# not in CI. Runs in a scratch copy of the working tree under build/ (git-ignored), so the tree itself is never
# mutated. `make mutation MUTMUT_ARGS='realtime.engine.levels*'` runs one module's mutants; the summary per module is
# in build/mutation/mutation-summary.txt.
MUTATION_DIR := build/mutation
MUTMUT_ARGS ?=
$(VENV)/.mutation: pyproject.toml $(STAMP)
	$(PY) -m pip install --quiet -e '.[dev,mutation]'
	touch $@

mutation: setup $(VENV)/.mutation
	rm -rf $(MUTATION_DIR) && mkdir -p $(MUTATION_DIR)
	git ls-files -co --exclude-standard -z | tar --null -cf - -T - | tar -xf - -C $(MUTATION_DIR)
	cd $(MUTATION_DIR) && $(abspath $(VENV))/bin/mutmut run $(MUTMUT_ARGS) > mutmut-run.log 2>&1; \
		tail -c 400 mutmut-run.log; echo; \
		$(abspath $(PY)) tests/mutants/mutation_summary.py --diffs | tee mutation-summary.txt

# Hand-made GLSL mutants (tests/mutants/shader_mutants.py): each must make the GL tests fail.
shader-mutants: setup
	$(PY) tests/mutants/shader_mutants.py

