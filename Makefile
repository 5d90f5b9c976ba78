# E-Lab — the two set-up commands are `make run` and `make test` (see README.md).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
NODE_STAMP := frontend/node_modules/.installed

.PHONY: install run test lint typecheck unit bench docs protocol clean

install: $(STAMP) $(NODE_STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

$(NODE_STAMP): frontend/package.json frontend/package-lock.json
	cd frontend && npm ci --no-audit --no-fund --loglevel=error
	touch $(NODE_STAMP)

# The lab server on http://127.0.0.1:8000 (data: $ELAB_DATA or ./data).
run: install
	$(VENV)/bin/elab serve --host 127.0.0.1 --port 8000

lint: install
	$(VENV)/bin/ruff check backend tests scripts

typecheck: install
	$(VENV)/bin/mypy

unit: install
	$(PY) -m pytest

test: lint typecheck unit

bench: install
	$(PY) tests/bench/run.py

docs: install
	$(PY) scripts/seed_reproduction.py > docs/seed-reproduction.md

# The wire schema from the pydantic models, then the app's TypeScript types from it.
protocol: install
	$(PY) scripts/wire_schema.py
	cd frontend && node scripts/gen-protocol.mjs

clean:
	rm -rf $(VENV) build *.egg-info backend/*.egg-info .pytest_cache .mypy_cache .ruff_cache \
	       frontend/node_modules
