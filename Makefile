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

# Until the live server lands this is the CLI's demo of the core library.
run: install
	$(VENV)/bin/elab plants
	$(VENV)/bin/elab analyze flexible_link
	$(VENV)/bin/elab simulate flexible_link --signal square --amplitude 30deg --period 4 \
		--duration 10 --out demo-flexible-link.csv

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
