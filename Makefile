# E-Lab — the two set-up commands are `make run` and `make test` (see README.md).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
NODE_STAMP := frontend/node_modules/.installed
LINT_STAMP := frontend/lint/node_modules/.installed
APP    := backend/elab/api/static/index.html
APP_SRC := $(shell find frontend/src frontend/index.html frontend/vite.config.ts \
                        frontend/tsconfig.json -type f 2>/dev/null)

.PHONY: install run test test-postgres test-cluster ci lint typecheck unit frontend-test chromium test-debs bench docs protocol \
        screenshots clean

install: $(STAMP) $(NODE_STAMP) $(APP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

$(NODE_STAMP): frontend/package.json frontend/package-lock.json
	cd frontend && npm ci --no-audit --no-fund --loglevel=error
	touch $(NODE_STAMP)

# ESLint in a package of its own (frontend/lint/package.json says why).
$(LINT_STAMP): frontend/lint/package.json frontend/lint/package-lock.json
	cd frontend/lint && npm ci --no-audit --no-fund --loglevel=error
	touch $(LINT_STAMP)

# The browser app, built into the Python package (type-checked first).
$(APP): $(NODE_STAMP) $(APP_SRC)
	cd frontend && npm run build --silent

# Debian packages the tests use: Chromium (end-to-end tests), GNU Octave's control
# package (an independent identification cross-check), bubblewrap (the controller
# sandbox) and PostgreSQL (the store's second back-end; the tests start a server of their
# own as the unprivileged `postgres` user). Installed once, if missing.
TEST_DEBS := chromium octave octave-control bubblewrap postgresql redis-server
test-debs:
	@missing=$$(for p in $(TEST_DEBS); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then apt-get update -qq && DEBIAN_FRONTEND=noninteractive \
	  apt-get install -y -qq --no-install-recommends $$missing; fi

chromium: test-debs

# The lab server on http://127.0.0.1:8000 (data: $ELAB_DATA or ./data), with an emulated
# flexible-link rig unless ELAB_RIG says otherwise (none, or a real rig's host:port).
run: install
	$(PY) -m compileall -q backend/elab >/dev/null  # see scripts/test.sh
	ELAB_RIG=$${ELAB_RIG:-emulator} $(VENV)/bin/elab serve --host 127.0.0.1 --port 8000

# The house rules, held by tools: every import declared in pyproject.toml
# (scripts/check_deps.py: nothing relies on a package left on the machine), ruff (lint and
# format), the import layers (pyproject's [tool.importlinter]: nothing below api speaks
# HTTP, pydantic or msgpack; dependencies point inward), ESLint on the app (no any,
# exhaustive switches, no floating promises).
lint: install $(LINT_STAMP)
	$(PY) scripts/check_deps.py
	$(VENV)/bin/ruff check backend tests scripts
	$(VENV)/bin/ruff format --check backend tests scripts
	cd backend && ../$(VENV)/bin/lint-imports --config ../pyproject.toml
	cd frontend && lint/node_modules/.bin/eslint -c lint/eslint.config.js src

typecheck: install
	$(VENV)/bin/mypy
	$(PY) scripts/check_dispatch.py

# pytest on both cores (pytest-xdist; each test module on one worker, which keeps the
# servers of a module together)
unit: install test-debs
	$(PY) -m pytest -n 2 --dist loadscope

frontend-test: install
	cd frontend && npx vitest run

# Everything, the static checks beside pytest (scripts/test.sh).
test: install test-debs $(LINT_STAMP)
	scripts/test.sh

# The API and browser tests again with every test server's records in PostgreSQL (a
# database of its own on a server the tests start on loopback; docs/operations.md).
test-postgres: install test-debs
	$(PY) -m compileall -q backend/elab >/dev/null
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PY) -m pytest -n 3 --dist loadscope \
	  --no-loadscope-reorder tests/api tests/e2e --store postgres

# The API and browser tests against the lab as a cluster runs it: records in PostgreSQL,
# every test server's simulation engines two processes of their own on a Redis broker.
test-cluster: install test-debs
	$(PY) -m compileall -q backend/elab >/dev/null
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PY) -m pytest -n 3 --dist loadscope \
	  --no-loadscope-reorder tests/api tests/e2e --store postgres --engines broker

# What CI does, as a newcomer would: a clean clone of the last commit in build/ci, its own
# virtualenv and node_modules installed from nothing, then make test there.
ci:
	rm -rf build/ci
	git clone --quiet --no-hardlinks . build/ci
	$(MAKE) -C build/ci test test-cluster

bench: install chromium
	$(PY) tests/bench/run.py

docs: install
	$(PY) scripts/seed_reproduction.py > docs/seed-reproduction.md

# Every view of the app as the end-to-end tests see it.
screenshots: install chromium
	ELAB_SCREENSHOTS=docs/screenshots $(PY) -m pytest tests/e2e -q

# The wire schema from the pydantic models, then the app's TypeScript types and its
# precompiled wire checks (src/wire.validate.gen.js) from it.
protocol: install
	$(PY) scripts/wire_schema.py
	cd frontend && node scripts/gen-protocol.mjs

clean:
	rm -rf $(VENV) build *.egg-info backend/*.egg-info .pytest_cache .mypy_cache .ruff_cache \
	       frontend/node_modules frontend/lint/node_modules backend/elab/api/static
