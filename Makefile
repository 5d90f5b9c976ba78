# E-Lab — the two set-up commands are `make run` and `make test` (see README.md).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: install run test lint typecheck unit bench docs clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# The lab server on http://127.0.0.1:8000 (data: $ELAB_DATA or ./data). The browser app
# is the next piece; until then / shows the API reference.
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

clean:
	rm -rf $(VENV) build *.egg-info backend/*.egg-info .pytest_cache .mypy_cache .ruff_cache
