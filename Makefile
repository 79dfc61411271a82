# Two commands on a fresh clone: `make run` and `make test` (see README.md).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
FMU_SOURCES := $(shell find src/mechfmu/runtime src/mechfmu/packaging -name '*.py' -o -name '*.[ch]')

.PHONY: run test fmus references report study work-precision bench sweeps docs clean

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

test: fmus/.built
	$(PY) -m pytest -q

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
