"""FMU layer: validation, model descriptions, stdlib-only runtime, direct runs and errors."""

import ast
import math
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from fmpy.fmi1 import FMICallException

from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from fmu_driver import Driven
from mechfmu.runtime.models import MODELS
from mechfmu.runtime.physics.landing_gear import DEFAULT_GEOMETRY, gear_motion
from mechfmu.runtime.physics.suspension import limit_point, make_spring


@pytest.mark.parametrize("model", list(MODELS))
def test_every_fmu_validates(fmu_dir, model):
    assert validate_fmu(str(fmu_dir / f"{model}.fmu")) == []


@pytest.mark.parametrize("model", list(MODELS))
def test_model_description_declares_units_structure_and_descriptions(fmu_dir, model):
    description = read_model_description(str(fmu_dir / f"{model}.fmu"))
    declared_units = {unit.name for unit in description.unitDefinitions}
    for variable in description.modelVariables:
        assert variable.description, variable.name
        if variable.type == "Real":
            assert variable.unit in declared_units, variable.name
    outputs = [v for v in description.modelVariables if v.causality == "output"]
    assert [u.variable for u in description.outputs] == outputs
    assert {u.variable.name for u in description.initialUnknowns} == {v.name for v in outputs}
    assert description.coSimulation.canGetAndSetFMUstate


def test_landing_gear_output_dependencies_follow_the_closed_form(fmu_dir):
    description = read_model_description(str(fmu_dir / "LandingGear.fmu"))
    depends = {u.variable.name: [d.name for d in u.dependencies] for u in description.outputs}
    assert depends["gear_angle"] == ["piston_extension"]
    assert depends["gear_angular_velocity"] == ["piston_extension", "piston_speed"]
    # in the dynamics drive the acceleration also follows the piston force and the drag
    assert depends["gear_angular_acceleration"] == [
        "piston_extension",
        "piston_speed",
        "piston_acceleration",
        "piston_force",
        "airspeed",
    ]
    assert depends["piston_work"] == []  # a state: no direct input dependency


def _imports(source):
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            yield from (alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            yield node.module.split(".")[0]


@pytest.mark.parametrize("model", list(MODELS))
def test_code_inside_the_fmu_imports_only_the_standard_library(fmu_dir, model):
    allowed = set(sys.stdlib_module_names) | {"pythonfmu", "pythonfmu3", f"mechfmu_fmu_{model}"}
    with zipfile.ZipFile(fmu_dir / f"{model}.fmu") as archive:
        ours = [
            n
            for n in archive.namelist()
            if n.endswith(".py") and not n.startswith("resources/pythonfmu/")
        ]
        assert any(n.startswith(f"resources/mechfmu_fmu_{model}/physics/") for n in ours)
        for name in ours:
            found = set(_imports(archive.read(name).decode()))
            assert found <= allowed, (name, found - allowed)


def test_fmu_runtime_runs_in_a_python_without_third_party_packages(fmu_dir, tmp_path):
    """Import and step a model from the FMU's own resources with site-packages hidden."""
    with zipfile.ZipFile(fmu_dir / "LandingGear.fmu") as archive:
        archive.extractall(tmp_path)
    script = (
        "import sys\n"
        "sys.path[:] = [p for p in sys.path if 'site-packages' not in p]\n"
        f"sys.path.insert(0, {str(tmp_path / 'resources')!r})\n"
        "from mechfmu_fmu_LandingGear.models.landing_gear import LandingGear\n"
        "slave = LandingGear(instance_name='probe')\n"
        "slave.exit_initialization_mode()\n"
        "assert slave.do_step(0.0, 0.1)\n"
        "assert 'numpy' not in sys.modules\n"
        "print(repr(slave.values['gear_angle']))\n"
    )
    done = subprocess.run(
        [sys.executable, "-S", "-c", script], capture_output=True, text=True, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert float(done.stdout) == pytest.approx(DEFAULT_GEOMETRY.start_angle, rel=1e-14)


def test_same_fmu_loads_repeatedly_in_one_process(fmu_dir):
    """pythonfmu 0.7 frees the entry module's namespace on each load; our entry keeps it."""
    for _ in range(4):
        result = simulate_fmu(
            str(fmu_dir / "Suspension.fmu"),
            stop_time=0.2,
            output_interval=0.1,
            start_values={"load": 2069.91},
        )
        assert result["deflection"][-1] == pytest.approx(0.1375, abs=5e-5)


# Loads one FMU `loads` times (fmpy's Driven), then prints, for its entry module's namespace,
# the interpreter's reference count and the references that objects hold, after each load.
NAMESPACE_PROBE = """
import gc, sys, types
sys.path.insert(0, {tests!r})
from fmu_driver import Driven

def references(namespace):
    held = 0
    for holder in gc.get_referrers(namespace):
        if isinstance(holder, (tuple, types.FrameType)):  # this call's own arguments
            continue
        if isinstance(holder, list):
            for item in holder:
                held += item is namespace
        else:
            held += 1
    return sys.getrefcount(namespace) - 2, held  # less this function's name and argument

for load in range({loads}):
    driven = Driven({path!r}, instance=f"load{{load}}")
    driven.step(0.01)
    driven.close()
    name = [module for module in sys.modules if module.startswith("mechfmu_entry")][0]
    namespace = sys.modules[name].__dict__
    print(*references(namespace))
    del namespace
"""


@pytest.mark.parametrize("fmi_version", [2, 3])
def test_repeated_loads_leave_the_entry_namespace_count_true(fmi_version, request):
    """pythonfmu's loader releases a reference to the entry module's namespace at each load
    that it never took; the entry takes one for it that nothing releases. A count short of
    the references held would free the namespace under its module when the interpreter shuts
    down (a segmentation fault at exit, seen in CI on CPython 3.10)."""
    folder = request.getfixturevalue("fmu_dir" if fmi_version == 2 else "fmu3_dir")
    script = NAMESPACE_PROBE.format(
        tests=str(Path(__file__).parent), loads=4, path=str(folder / "SliderCrank.fmu")
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    counts = [tuple(map(int, line.split())) for line in done.stdout.splitlines()]
    assert len(counts) == 4, done.stdout
    for counted, held in counts:
        assert counted == held, counts
    assert len(set(counts)) == 1, counts  # nothing gained or lost per load


def test_landing_gear_fmu_matches_closed_form_for_direct_inputs(fmu_dir):
    gear = Driven(fmu_dir / "LandingGear.fmu")
    try:
        for x, speed, accel in [(0.40, 0.1, 0.0), (0.5, -0.2, 0.3), (0.6, 0.05, -1.0)]:
            assert (
                gear.step(0.01, piston_extension=x, piston_speed=speed, piston_acceleration=accel)
                is True
            )
            exact = gear_motion(
                x, speed, accel, DEFAULT_GEOMETRY.attachment_distance, DEFAULT_GEOMETRY.pivot_height
            )
            assert gear.get("gear_angle") == exact.angle
            assert gear.get("gear_angular_velocity") == exact.angular_velocity
            assert gear.get("gear_angular_acceleration") == exact.angular_acceleration
    finally:
        gear.close()


def test_piston_outside_assembly_range_is_refused_with_variable_value_and_range(fmu_dir):
    gear = Driven(fmu_dir / "LandingGear.fmu")
    try:
        assert gear.step(0.01, piston_extension=0.5) is True
        before = gear.get("gear_angle")
        outcome = gear.step(0.01, piston_extension=0.9)
        assert "piston_extension = 0.9 m is outside the valid range" in outcome
        high = DEFAULT_GEOMETRY.attachment_distance + DEFAULT_GEOMETRY.pivot_height
        assert repr(high) in outcome and "discard" in outcome
        assert gear.get("gear_angle") == before  # last valid outputs kept, no NaN
        assert gear.step(0.01, piston_extension=0.5) is True  # still usable afterwards
    finally:
        gear.close()


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_inputs_are_refused(fmu_dir, bad):
    gear = Driven(fmu_dir / "LandingGear.fmu")
    try:
        outcome = gear.step(0.01, piston_extension=0.5, piston_speed=bad)
        assert "piston_speed" in outcome and "finite" in outcome
        assert math.isfinite(gear.get("gear_angular_velocity"))
    finally:
        gear.close()


def test_dead_centre_is_reported_as_singular(fmu_dir):
    gear = Driven(fmu_dir / "LandingGear.fmu")
    high = DEFAULT_GEOMETRY.attachment_distance + DEFAULT_GEOMETRY.pivot_height
    try:
        outcome = gear.step(0.01, piston_extension=high, piston_speed=0.1)
        assert "dead centre" in outcome and "angular velocity undefined" in outcome
    finally:
        gear.close()


@pytest.mark.parametrize(
    "model, parameters, words",
    [
        ("Suspension", {"spring_base_offset": 0.6}, ["spring_base_offset = 0.6", "(0, 0.5)"]),
        ("Suspension", {"spring_stiffness": -1.0}, ["spring_stiffness = -1.0", "positive"]),
        ("Suspension", {"spring_free_length": 0.0}, ["spring_free_length = 0.0"]),
        ("LandingGear", {"bar_length": 0.0}, ["bar_length = 0.0"]),
        ("LandingGear", {"attachment_distance": -0.1}, ["attachment_distance = -0.1"]),
        ("PistonActuator", {"stroke_time": 5.0}, ["stroke_time = 5.0", "(0, 4.0]", "under 4 s"]),
        ("PistonActuator", {"profile": "jerky"}, ["profile = 'jerky'", "constant_speed"]),
        ("LoadProfile", {"shape": "ramp", "duration": 0.0}, ["duration = 0.0"]),
        ("LoadProfile", {"shape": "table", "table_file": "/nonexistent.csv"}, ["/nonexistent.csv"]),
        # the integrator's settings, also where the configuration integrates nothing (the
        # kinematic gear, the suspension without its dynamics effect): they were ignored
        ("LandingGear", {"integrator": "x"}, ["integrator = 'x' is not a known method"]),
        ("LandingGear", {"max_substep": 0.0}, ["max_substep = 0.0"]),
        ("Suspension", {"rtol": -1.0}, ["rtol = -1.0"]),
    ],
)
def test_invalid_parameters_are_refused_at_initialisation(fmu_dir, model, parameters, words):
    # fmi2ExitInitializationMode answers fmi2Error naming the value and the range; the
    # instance is then in the error state, where no step is allowed.
    fmu = Driven(fmu_dir / f"{model}.fmu", parameters=parameters)
    try:
        assert fmu.init_error is not None and "status 3" in fmu.init_error
        for word in words:
            assert word in fmu.init_error, (word, fmu.init_error)
        assert "fmi2DoStep is not allowed in state error" in fmu.step(0.01)
    finally:
        fmu.close()


def test_fixed_parameter_cannot_change_after_initialisation(fmu_dir):
    gear = Driven(fmu_dir / "LandingGear.fmu")
    try:
        with pytest.raises(FMICallException, match="status 3"):
            gear.set(bar_length=2.0)
        problem = gear.logbook.last_problem("under_test")
        assert "bar_length (value reference 2, a parameter) is a fixed parameter" in problem
        assert "refused with fmi2Error in state stepComplete" in problem
        start = float(gear.variables["bar_length"].start)
        assert gear.get("bar_length") == start  # unchanged: pythonfmu never saw the set
    finally:
        gear.close()


def test_suspension_snap_through_is_flagged_logged_and_continued(fmu_dir):
    limit = limit_point(make_spring(0.5, 1e4, 0.2))
    suspension = Driven(fmu_dir / "Suspension.fmu")
    try:
        assert suspension.step(0.1, load=0.99 * limit.load) is True
        assert suspension.get("branch") == 0 and not suspension.get("snap_through")
        assert suspension.step(0.1, load=1.01 * limit.load) is True
        assert suspension.get("snap_through") and suspension.get("branch") == 1
        assert suspension.get("snap_through_count") == 1
        assert suspension.get("deflection") > 2 * 0.4582 - limit.deflection
        assert any("snap-through" in m for m in suspension.messages("warning"))
        assert suspension.step(0.1, load=1.01 * limit.load) is True
        assert not suspension.get("snap_through")  # the flag marks the step it happened in
    finally:
        suspension.close()


def test_suspension_at_the_limit_load_is_marginal_whatever_its_last_bits(fmu_dir):
    """The FMU's own limit_load output, and one rounding error either side of it, is the
    limit point: marginal, not stable, no snap-through; 1e-6 below it is stable."""
    limit = limit_point(make_spring(0.5, 1e4, 0.2))
    suspension = Driven(fmu_dir / "Suspension.fmu")
    try:
        assert suspension.step(0.1, load=(1.0 - 1e-6) * limit.load) is True
        assert suspension.get("stable") and not suspension.get("marginal")
        assert suspension.get("tangent_stiffness") > 1.0  # N/m, far outside the 2e-5 band
        at = suspension.get("limit_load")
        for load in (math.nextafter(at, 0.0), at, math.nextafter(at, math.inf)):
            assert suspension.step(0.1, load=load) is True
            assert suspension.get("marginal") and not suspension.get("stable")
            assert not suspension.get("snap_through") and suspension.get("branch") == 0
            assert abs(suspension.get("tangent_stiffness")) <= 1e-9 * 2.0 * 1e4
            assert math.isclose(suspension.get("deflection"), limit.deflection, rel_tol=1e-12)
        assert suspension.step(0.1, load=1.01 * limit.load) is True
        assert suspension.get("snap_through") and suspension.get("stable")
        assert not suspension.get("marginal")
    finally:
        suspension.close()


def test_suspension_can_stop_at_the_limit_load_instead(fmu_dir):
    limit = limit_point(make_spring(0.5, 1e4, 0.2))
    suspension = Driven(fmu_dir / "Suspension.fmu", parameters={"stop_on_snap_through": True})
    try:
        assert suspension.step(0.1, load=0.9 * limit.load) is True
        kept = suspension.get("deflection")
        outcome = suspension.step(0.1, load=1.1 * limit.load)
        assert "exceeds the limit load" in outcome and repr(limit.load) in outcome
        assert suspension.get("deflection") == kept
    finally:
        suspension.close()


def test_load_profile_reads_a_csv_table(fmu_dir, tmp_path):
    table = tmp_path / "loads.csv"
    table.write_text("time,load\n0,0\n1,1000\n2,500\n")
    source = Driven(
        fmu_dir / "LoadProfile.fmu", parameters={"shape": "table", "table_file": str(table)}
    )
    try:
        assert source.step(0.5) is True
        assert source.get("load") == 500.0 and source.get("load_rate") == 1000.0
        assert source.step(1.0) is True
        assert source.get("load") == 750.0 and source.get("load_rate") == -500.0
        assert source.step(5.0) is True
        assert source.get("load") == 500.0
    finally:
        source.close()


def test_step_size_must_be_positive(fmu_dir):
    gear = Driven(fmu_dir / "LandingGear.fmu")
    try:
        outcome = gear.step(0.0, piston_extension=0.5)
        assert "communicationStepSize = 0 s" in outcome and "must be > 0" in outcome, outcome
    finally:
        gear.close()
