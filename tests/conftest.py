"""Shared fixtures: the built FMUs and small helpers to run scenes written inline."""

import fcntl
import os
from pathlib import Path

import pytest
from hypothesis import settings

from mechfmu.cosim.locate import fmu_folder
from mechfmu.cosim.scene import REFERENCE_DIR, SCENE_DIR, SWEEP_DIR, SceneError
from mechfmu.packaging.build import build_all
from mechfmu.runtime.models import MODELS

ROOT = Path(__file__).resolve().parent.parent
FMU_DIR = Path(os.environ.get("MECHFMU_FMU_DIR") or ROOT / "fmus")  # make sets it
SCENES = SCENE_DIR  # the shipped scenes (package data)
REFERENCES = REFERENCE_DIR
SWEEPS = SWEEP_DIR

# The property tests draw the same examples on every run and machine (a CI run must not turn
# red because a new random draw found a case); `make properties` draws new ones.
settings.register_profile("reproducible", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("MECHFMU_HYPOTHESIS", "reproducible"))


@pytest.fixture(scope="session")
def fmu_dir():
    """The built FMUs, found by the rule every command follows (cosim/locate.py:
    $MECHFMU_FMU_DIR, which make sets, ./fmus, the checkout's, the user cache); built into
    FMU_DIR when none holds them all (e.g. a bare `pytest` on a fresh clone)."""
    try:
        return fmu_folder(MODELS)
    except SceneError:
        missing = [name for name in MODELS if not (FMU_DIR / f"{name}.fmu").is_file()]
        build_all(FMU_DIR, missing)
        return FMU_DIR


def _built_once(tmp_path_factory, name, **options):
    """``build_all(folder, **options)`` into a folder every pytest-xdist worker of this run
    shares: the first worker to ask builds (under a lock), the others wait and reuse it."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the workers' base folders sit side by side in the run's own
    folder = root / name
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / ".built").is_file():
            build_all(folder, **options)
            (folder / ".built").touch()
    return folder


@pytest.fixture(scope="session")
def fmu3_dir(tmp_path_factory):
    """Every model as an FMI 3.0 FMU (mechfmu build --fmi-version 3), built for this run."""
    return _built_once(tmp_path_factory, "fmi3", fmi_version=3)


@pytest.fixture(scope="session")
def embedded_dir(tmp_path_factory):
    """Every model as an FMI 2.0 FMU with its own Python runtime (mechfmu build
    --embed-python), built for this run."""
    return _built_once(tmp_path_factory, "embedded", embed_python=True)


# The test layers (markers registered in pyproject.toml; `make test-fast` runs
# `-m "(unit or fmu) and not slow"`, `make test` runs them all):
#   unit  - Python functions only: physics, numerics, references, tables; no FMU is loaded;
#   fmu   - the built FMUs (fmus/) through our master, fmpy or the command line;
#   hosts - other hosts and formats: libcosim, the C host, FMI 3.0, embedded Python, containers
#           (each builds or loads FMUs of its own);
#   slow  - more than a few seconds each (on top of its layer).
# A file's layer is its row below; a test of a unit file that asks for the built FMUs (fixture
# fmu_dir) is an fmu test, one that asks for fmu3_dir or embedded_dir a hosts test.
LAYERS = {
    "test_portable.py": "unit",  # numpy dispatch lists of make test-portable
    "test_integrators.py": "unit",
    "test_planar.py": "unit",
    "test_planar_kernel.py": "unit",
    "test_link_forces.py": "unit",
    "test_physics_cam_valve.py": "unit",
    "test_cam_geometry.py": "unit",
    "test_cam_design.py": "unit",
    "test_camshaft.py": "unit",
    "test_physics_landing_gear.py": "unit",
    "test_physics_linkages.py": "unit",
    "test_joint_positions.py": "unit",  # the geometry effect's points, drawings, frames
    "test_physics_profiles.py": "unit",
    "test_physics_suspension.py": "unit",
    "test_references.py": "unit",
    "test_sweep_references.py": "unit",
    "test_hard_cases.py": "unit",
    "test_gear_dynamics.py": "unit",
    "test_suspension_dynamics.py": "unit",
    "test_valve_spring.py": "unit",
    "test_exact_valve.py": "unit",
    "test_compiled_core.py": "fmu",  # the built ValveSpring FMU's compiled exact core
    "test_docs.py": "unit",
    "test_work_precision.py": "unit",
    "test_io.py": "unit",  # its tests with fmu_dir count as fmu (below)
    "test_hostile_inputs.py": "unit",
    "test_result_pairs.py": "unit",
    "test_input_fuzz.py": "fmu",
    "test_compare.py": "unit",
    "test_streamed_check.py": "unit",
    "test_sweep_scale.py": "fmu",
    "test_import_graph.py": "unit",
    "test_tolerances.py": "unit",
    "test_api.py": "fmu",
    "test_animate.py": "fmu",  # animations of the shipped scenes, files, the commands
    "test_baseline.py": "fmu",
    "test_check_cli.py": "fmu",
    "test_readme.py": "fmu",
    "test_command_line.py": "fmu",
    "test_pytest_plugin.py": "fmu",
    "test_bench.py": "fmu",
    "test_binary_patch.py": "fmu",
    "test_c_literals.py": "unit",
    "test_corrupt_fmus.py": "fmu",
    "test_coupling.py": "fmu",
    "test_four_bar_boundary.py": "fmu",
    "test_fmus.py": "fmu",
    "test_force_fmus.py": "fmu",
    "test_interrupts.py": "fmu",
    "test_long_runs.py": "fmu",
    "test_linkage_fmus.py": "fmu",
    "test_cam_fmu.py": "fmu",
    "test_outputs.py": "fmu",
    "test_robustness.py": "fmu",
    "test_scenes.py": "fmu",
    "test_shipped_sweeps.py": "fmu",
    "test_ssp.py": "fmu",
    "test_study.py": "fmu",
    "test_sweep.py": "fmu",
    "test_sweep_faults.py": "fmu",
    "test_validation.py": "fmu",
    "test_c_host.py": "hosts",
    "test_container.py": "hosts",
    "test_embedded.py": "hosts",
    "test_fmi3.py": "hosts",
    "test_fmi_boundary.py": "hosts",
    "test_foreign_fmus.py": "fmu",
    "test_fmu_state.py": "hosts",
    "test_self_description.py": "fmu",
    "test_cross_check.py": "fmu",
    "test_checkpoints.py": "fmu",
    "test_libcosim.py": "hosts",
}
# Whole files, then single tests (by name without parameters), that take more than a few
# seconds each or many seconds together (measured with `pytest --durations=0`).
SLOW_FILES = {
    "test_docs.py",
    "test_readme.py",
    "test_interrupts.py",
    "test_robustness.py",
    "test_scenes.py",
    "test_sweep.py",
    "test_sweep_faults.py",
    "test_study.py",
    "test_bench.py",
    "test_validation.py",
    "test_shipped_sweeps.py",
    "test_ssp.py",
    "test_sweep_references.py",
    "test_valve_spring.py",
    "test_suspension_dynamics.py",
    "test_work_precision.py",
}
SLOW_TESTS = {
    "test_both_solvers_give_the_same_verdict_on_boundary_linkages",
    "test_one_step_anywhere_in_the_crank_range_gets_the_same_verdict",
    "test_external_hydraulics_agree_with_built_in_up_to_the_coupling_error",
}


def pytest_collection_modifyitems(config, items):
    """Mark every test with its layer (and slow) from the tables above."""
    for item in items:
        name = item.path.name
        layer = LAYERS.get(name)
        if layer is None:
            raise pytest.UsageError(f"{name}: no layer in tests/conftest.py LAYERS")
        fixtures = set(getattr(item, "fixturenames", ()))
        if layer == "unit" and fixtures & {"fmu3_dir", "embedded_dir"}:
            layer = "hosts"
        elif layer == "unit" and "fmu_dir" in fixtures:
            layer = "fmu"
        item.add_marker(getattr(pytest.mark, layer))
        if name in SLOW_FILES or item.originalname in SLOW_TESTS:
            item.add_marker(pytest.mark.slow)
