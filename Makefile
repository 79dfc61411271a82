# Two commands on a fresh clone: `make run` and `make test` (see README.md).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
FMU_SOURCES := $(shell find src/mechfmu/runtime src/mechfmu/packaging -name '*.py' -o -name '*.[ch]')

.PHONY: run test test-fast lint fmus references report study work-precision bench sweeps docs clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test]'
	touch $@

fmus/.built: $(VENV)/.installed $(FMU_SOURCES)
	$(VENV)/bin/mechfmu build --out fmus
	touch $@

fmus: $(VENV)/.installed
	$(VENV)/bin/mechfmu build --out fmus
	touch fmus/.built

run: fmus/.built
	$(PY) sims/run_gear.py

# Everything: the lint gate, then every test layer (unit, fmu, hosts, slow).
test: lint fmus/.built
	$(PY) -m pytest -q

# The quick layers while working (under a minute): unit tests and the FMU tests that are not slow.
test-fast: fmus/.built
	$(PY) -m pytest -q -m "(unit or fmu) and not slow"

# The gate: ruff (errors and annotations on every public function), ruff's formatting, mypy
# (configured in pyproject.toml).
lint: $(VENV)/.installed
	$(VENV)/bin/ruff check src tests sims docs
	$(VENV)/bin/ruff format --check src tests sims docs
	$(VENV)/bin/mypy

references: $(VENV)/.installed
	$(VENV)/bin/mechfmu references

report: $(VENV)/.installed
	$(PY) sims/seed_report.py

# Long measurements, not tests (the suite runs small versions of them).
study: fmus/.built
	$(VENV)/bin/mechfmu study

work-precision: $(VENV)/.installed
	$(VENV)/bin/mechfmu study --work-precision

bench: fmus/.built
	$(VENV)/bin/mechfmu bench

# The shipped parameter sweeps, checked against their references (out/sweeps/summary.md).
sweeps: fmus/.built
	$(PY) sims/run_sweeps.py

# The docs site into site/ (open site/index.html); strict: a broken link or reference fails.
# The variables hush a banner of the mkdocs 1.x plugins about a future mkdocs 2.
docs: $(VENV)/.installed
	NO_MKDOCS_2_WARNING=1 DISABLE_MKDOCS_2_WARNING=true $(VENV)/bin/mkdocs build --strict

clean:
	rm -rf $(VENV) fmus/*.fmu fmus/.built out site
