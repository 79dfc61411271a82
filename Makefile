# Two commands on a fresh clone: `make run` and `make test` (see README.md).
# Installs are exact: requirements.lock.txt pins every dependency (extras test, docs, cluster
# included) with its hashes, for every Python from 3.10 (`make lock` refreshes it).
# Another interpreter: `make test PYTHON=/path/to/python3.12` uses its own .venv-3.12 and
# fmus-3.12 (the FMUs are built for the interpreter that builds them), leaving .venv alone.
PYTHON ?= python3
PYVER := $(shell $(PYTHON) -c 'import sys; print("%d.%d" % sys.version_info[:2])')
ifeq ($(origin PYTHON),command line)
VENV := .venv-$(PYVER)
FMUS := fmus-$(PYVER)
else
VENV := .venv
FMUS := fmus
endif
PY := $(VENV)/bin/python
# The tests (and `mechfmu run` without --fmu-dir) find the FMUs here.
export MECHFMU_FMU_DIR := $(CURDIR)/$(FMUS)
FMU_SOURCES := $(shell find src/mechfmu/runtime src/mechfmu/packaging -name '*.py' -o -name '*.[ch]')

# The setup steps print one line each; their detail goes to a log shown when a step fails.
# `make V=1 ...` shows everything as it happens.
ifeq ($(V),1)
logged = $(2)
else
logged = @{ $(2); } > $(1) 2>&1 || { cat $(1); echo "make: failed; the whole output is in $(1)"; exit 1; }
endif

.PHONY: run test test-fast properties lint fmus references report study work-precision bench sweeps \
	docs clean lock test-latest test-portable test-other-python test-subset tolerances \
	boundary cross-check fuzz-inputs

$(VENV)/.installed: pyproject.toml requirements.lock.txt
	@echo "installing mechfmu and its locked dependencies into $(VENV)/ (log: $(VENV)/install.log)"
	@mkdir -p $(VENV)
	$(call logged,$(VENV)/install.log,$(PYTHON) -m venv $(VENV) && $(PY) -m pip install \
		--quiet --disable-pip-version-check --require-hashes -r requirements.lock.txt && \
		$(PY) -m pip install --quiet --disable-pip-version-check --no-deps -e .)
	@touch $@

$(FMUS)/.built: $(VENV)/.installed $(FMU_SOURCES)
	@echo "building the FMUs into $(FMUS)/ (log: $(FMUS)/build.log)"
	@mkdir -p $(FMUS)
	$(call logged,$(FMUS)/build.log,$(VENV)/bin/mechfmu build --out $(FMUS))
	@touch $@

fmus: $(VENV)/.installed
	@mkdir -p $(FMUS)
	$(call logged,$(FMUS)/build.log,$(VENV)/bin/mechfmu build --out $(FMUS))
	@touch $(FMUS)/.built
	@echo "built the FMUs into $(FMUS)/ (log: $(FMUS)/build.log)"

run: $(FMUS)/.built
	@$(PY) sims/run_gear.py
	@echo "mechfmu and python of $(VENV) in this shell: source $(VENV)/bin/activate"

# Everything: the lint gate, then every test layer (unit, fmu, hosts, slow), the test files
# shared among TEST_WORKERS processes (pytest-xdist; auto: one per CPU; 0: one process).
TEST_WORKERS ?= auto
PARALLEL = -n $(TEST_WORKERS) --dist loadfile
test: lint $(FMUS)/.built
	$(PY) -m pytest -q $(PARALLEL)

# The property tests (hypothesis) with new random examples instead of the suite's fixed ones.
properties: $(FMUS)/.built
	MECHFMU_HYPOTHESIS=explore $(PY) -m pytest -q -p no:cacheprovider $(PARALLEL) \
		$$(grep -l "@given" tests/test_*.py)

# The quick layers while working (under a minute): unit tests and the FMU tests that are not slow.
test-fast: $(FMUS)/.built
	$(PY) -m pytest -q $(PARALLEL) -m "(unit or fmu) and not slow"

# The gate: ruff (errors and annotations on every public function), ruff's formatting, mypy
# (configured in pyproject.toml).
lint: $(VENV)/.installed
	$(VENV)/bin/ruff check src tests sims docs
	$(VENV)/bin/ruff format --check src tests sims docs
	$(VENV)/bin/mypy

# Refresh the lock from pyproject.toml (needs the network): uv resolves once for every Python
# >= 3.10 (markers where versions differ) with the hashes of every platform's files. uv is
# installed into .venv-lock for this alone; installing from the lock needs only pip.
lock:
	$(PYTHON) -m venv .venv-lock
	.venv-lock/bin/python -m pip install --quiet --disable-pip-version-check uv
	.venv-lock/bin/uv pip compile pyproject.toml --universal --python-version 3.10 \
		--generate-hashes --extra test --extra docs --extra cluster --extra video --extra parquet --extra compile --no-header --quiet \
		-o requirements.lock.txt

# The suite against the newest releases pyproject.toml allows (not the lock): its own
# .venv-latest and fmus-latest.
test-latest:
	rm -rf .venv-latest fmus-latest
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/python -m pip install --quiet --disable-pip-version-check --upgrade \
		-e '.[test]'
	.venv-latest/bin/mechfmu build --out fmus-latest
	MECHFMU_FMU_DIR=$(CURDIR)/fmus-latest .venv-latest/bin/python -m pytest -q

# The numeric layers (physics, references, FMU runs against references, scenes, small
# studies and sweeps) with numpy's SIMD dispatch narrowed as on other CPUs: without AVX-512,
# then without AVX2 and FMA as well (tests/portable.py lists what this CPU has of them).
PORTABLE_TESTS := tests/test_physics_cam_valve.py tests/test_cam_geometry.py tests/test_camshaft.py \
	tests/test_physics_landing_gear.py \
	tests/test_physics_linkages.py tests/test_physics_profiles.py \
	tests/test_physics_suspension.py tests/test_references.py tests/test_hard_cases.py \
	tests/test_integrators.py tests/test_planar.py tests/test_four_bar_boundary.py \
	tests/test_gear_dynamics.py tests/test_suspension_dynamics.py tests/test_valve_spring.py \
	tests/test_exact_valve.py tests/test_link_forces.py tests/test_force_fmus.py \
	tests/test_scenes.py tests/test_outputs.py tests/test_fmus.py tests/test_linkage_fmus.py \
	tests/test_coupling.py tests/test_study.py tests/test_sweep.py \
	tests/test_sweep_references.py tests/test_portable.py tests/test_tolerances.py
test-portable: $(FMUS)/.built
	NPY_DISABLE_CPU_FEATURES="$$($(PY) tests/portable.py avx512)" $(PY) -m pytest -q \
		-p no:cacheprovider $(PARALLEL) $(PORTABLE_TESTS)
	NPY_DISABLE_CPU_FEATURES="$$($(PY) tests/portable.py avx2)" $(PY) -m pytest -q \
		-p no:cacheprovider $(PARALLEL) $(PORTABLE_TESTS)

# The fast numeric layer on the other CPythons that pyenv provides (OTHER_PYTHONS: versions
# under `pyenv root`/versions), each in its own .venv-X.Y and fmus-X.Y.
OTHER_PYTHONS ?= 3.10 3.12 3.13
PYENV_ROOT ?= $(shell pyenv root 2>/dev/null || echo $(HOME)/.pyenv)
OTHER_TESTS := tests/test_physics_cam_valve.py tests/test_cam_geometry.py \
	tests/test_physics_landing_gear.py \
	tests/test_physics_linkages.py tests/test_physics_profiles.py \
	tests/test_physics_suspension.py tests/test_references.py tests/test_integrators.py \
	tests/test_planar.py tests/test_scenes.py tests/test_outputs.py tests/test_libcosim.py \
	tests/test_portable.py tests/test_sweep_faults.py tests/test_exact_valve.py \
	tests/test_tolerances.py tests/test_compiled_core.py
test-other-python:
	@set -e; for version in $(OTHER_PYTHONS); do \
		python=$$(ls -d $(PYENV_ROOT)/versions/$$version.*/bin/python3 2>/dev/null \
			| sort -V | tail -n 1); \
		if [ -z "$$python" ]; then \
			echo "no CPython $$version under $(PYENV_ROOT)/versions"; exit 1; fi; \
		echo "== $$python"; \
		$(MAKE) --no-print-directory PYTHON=$$python \
			TESTS="$(OTHER_TESTS)" test-subset; \
	done

# (helper of test-other-python) the TESTS files with PYTHON's venv and FMUs
test-subset: $(FMUS)/.built
	$(PY) -m pytest -q -p no:cacheprovider $(PARALLEL) $(TESTS)

references: $(VENV)/.installed
	$(VENV)/bin/mechfmu references --out src/mechfmu/scenes/reference \
		--tables src/mechfmu/scenes/tables

# What each shipped scene's check tolerance rests on (docs/checks.md): every scene run on each
# CPython that has a venv here (and with the C library's FMA and AVX2 variants off), every
# reference regenerated under each narrowing of numpy's dispatch, then the measurements.
TOLERANCE_DIR := out/tolerances
tolerances: $(FMUS)/.built
	rm -rf $(TOLERANCE_DIR)
	$(VENV)/bin/mechfmu run --all --no-plot --out $(TOLERANCE_DIR)/run-$(PYVER) --fmu-dir $(FMUS) > /dev/null
	GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA $(VENV)/bin/mechfmu run --all --no-plot \
		--out $(TOLERANCE_DIR)/run-nofma --fmu-dir $(FMUS) > /dev/null
	@for venv in .venv-3.*; do [ -x $$venv/bin/mechfmu ] || continue; \
		version=$${venv#.venv-}; echo "run --all on $$venv"; \
		$$venv/bin/mechfmu run --all --no-plot --out $(TOLERANCE_DIR)/run-$$version \
			--fmu-dir fmus-$$version > /dev/null || exit 1; done
	$(VENV)/bin/mechfmu references --out $(TOLERANCE_DIR)/ref > /dev/null
	NPY_DISABLE_CPU_FEATURES="$$($(PY) tests/portable.py avx512)" $(VENV)/bin/mechfmu \
		references --out $(TOLERANCE_DIR)/ref-avx512 > /dev/null
	NPY_DISABLE_CPU_FEATURES="$$($(PY) tests/portable.py avx2)" $(VENV)/bin/mechfmu \
		references --out $(TOLERANCE_DIR)/ref-avx2 > /dev/null
	$(PY) -m mechfmu.tools.tolerances --results $(TOLERANCE_DIR)/run-* \
		--references $(TOLERANCE_DIR)/ref* | tee $(TOLERANCE_DIR)/tolerances.md

report: $(VENV)/.installed
	$(PY) sims/seed_report.py

# Long measurements, not tests (the suite runs small versions of them).
study: $(FMUS)/.built
	$(VENV)/bin/mechfmu study

work-precision: $(VENV)/.installed
	$(VENV)/bin/mechfmu study --work-precision

bench: $(FMUS)/.built
	$(VENV)/bin/mechfmu bench

# The FMI boundary's property test at length (make test runs 6 fixed sequences per model and
# FMI version): 300 freshly random call sequences per model and version.
BOUNDARY_EXAMPLES ?= 300
boundary: $(FMUS)/.built
	MECHFMU_BOUNDARY_EXAMPLES=$(BOUNDARY_EXAMPLES) $(PY) -m pytest -q -p no:cacheprovider \
		tests/test_fmi_boundary.py

# Every model with a reference of its own exported in the fmi-cross-check layout and run
# through fmpy's cross-check tooling (make test exports two of them).
CROSS_CHECK_MODELS := LandingGear PistonActuator Suspension LoadProfile RoadProfile CrankDrive \
	FourBar SliderCrank CamshaftDrive ValveTrain ValveSpring
cross-check: $(FMUS)/.built
	MECHFMU_CROSS_CHECK_MODELS="$(CROSS_CHECK_MODELS)" $(PY) -m pytest -q -p no:cacheprovider \
		tests/test_cross_check.py

# The hostile-input fuzzing at length (the suite runs a short budget of each): the hypothesis
# harness with 50 times the suite's examples, 1000 SIGKILLs of result writers, then atheris
# (coverage-guided; CPython 3.11-3.13) for FUZZ_SECONDS on scenes, results and FMU archives,
# its corpus and any failing input under out/fuzz-inputs/.
FUZZ_SECONDS ?= 600
fuzz-inputs: $(FMUS)/.built
	MECHFMU_FUZZ_EXAMPLES=50 $(PY) -m pytest -q -p no:cacheprovider tests/test_input_fuzz.py
	MECHFMU_PAIR_KILLS=1000 $(PY) -m pytest -q -p no:cacheprovider tests/test_result_pairs.py
	MECHFMU_FUZZ_SEQUENCES=1000 MECHFMU_INTERRUPTS=100 $(PY) -m pytest -q -p no:cacheprovider \
		tests/test_robustness.py tests/test_interrupts.py
	@if $(PY) -c 'import atheris' 2>/dev/null; then \
		mkdir -p out/fuzz-inputs/corpus && \
		$(PY) tests/atheris_inputs.py -max_total_time=$(FUZZ_SECONDS) -rss_limit_mb=4096 \
			-artifact_prefix=$(CURDIR)/out/fuzz-inputs/ $(CURDIR)/out/fuzz-inputs/corpus; \
	else echo "atheris is not installed for this Python (CPython 3.11-3.13 only): skipped"; fi

# The shipped parameter sweeps, checked against their references (out/sweeps/summary.md).
sweeps: $(FMUS)/.built
	$(PY) sims/run_sweeps.py

# The docs site into site/ (open site/index.html); strict: a broken link or reference fails.
# The FMUs run the model pages' animations. The variables hush a banner of the mkdocs 1.x
# plugins about a future mkdocs 2.
docs: $(FMUS)/.built
	NO_MKDOCS_2_WARNING=1 DISABLE_MKDOCS_2_WARNING=true $(VENV)/bin/mkdocs build --strict

clean:
	rm -rf $(VENV) $(FMUS)/*.fmu $(FMUS)/.built out site
