"""Scenes end to end: the master, result files, checks against references, scene errors."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import REFERENCES, ROOT, SCENES
from mechfmu.check import compare
from mechfmu.cli import main as cli
from mechfmu.cosim.master import Simulation, SimulationError, order_components
from mechfmu.io import read_csv
from mechfmu.cosim.run import run_scene
from mechfmu.cosim.scene import Connection, SceneError, load_scene, parse_scene, read_toml
from mechfmu.cosim.tolerances import parse_check
from mechfmu.tools.scene_references import INTEGRATED, REFERENCES as GENERATED, generate
from mechfmu.tools.tolerances import MARGIN
from cli_process import run_mechfmu, run_script


def gear_scene(**changes):
    data = {
        "name": "inline_gear",
        "stop_time": 0.5,
        "step": 0.1,
        "connections": [
            "actuator.piston_extension -> gear.piston_extension",
            "actuator.piston_speed -> gear.piston_speed",
            "actuator.piston_acceleration -> gear.piston_acceleration",
        ],
        "components": {
            "actuator": {"fmu": "PistonActuator"},
            "gear": {
                "fmu": "LandingGear",
                "inputs": {"piston_force": 0.0, "valve_command": 0.0, "airspeed": 0.0},
            },
        },
    }
    data.update(changes)
    return data


@pytest.fixture(scope="module")
def shipped_run(fmu_dir, tmp_path_factory):
    """Exactly the two commands a new user runs from an empty folder: every shipped scene
    checked against its reference, then the results against the shipped references. The
    FMUs are found by the one rule (MECHFMU_FMU_DIR when make runs the tests, else the
    checkout's fmus/)."""
    folder = tmp_path_factory.mktemp("empty")
    run = run_mechfmu("run", "--all", "--out", "D", "--check", cwd=folder, timeout=600)
    check = run_mechfmu("check", "D", REFERENCES, cwd=folder, timeout=300)
    return folder / "D", run, check


def test_every_shipped_scene_passes_its_own_check_and_mechfmu_check(shipped_run):
    out, run, check = shipped_run
    scenes = sorted(path.stem for path in SCENES.glob("*.toml"))
    assert run.returncode == 0, run.stdout + run.stderr
    assert f"ran {len(scenes)} shipped scene(s) into D: {len(scenes)} ok" in run.stdout
    assert check.returncode == 0, check.stdout + check.stderr
    references = len(list(REFERENCES.glob("*.csv")))
    unreferenced = len(scenes) - references
    assert (
        f"{len(scenes)} file(s): {references} match, 0 mismatch, {unreferenced} without "
        f"reference (not compared)"
    ) in check.stdout
    assert sorted(path.stem for path in out.glob("*.csv")) == scenes


@pytest.mark.parametrize("scene_name", sorted(GENERATED))
def test_a_shipped_scene_declares_its_tolerance_and_keeps_the_margin(shipped_run, scene_name):
    """Each reference's tolerance comes from its scene's [check] table (written in the JSON
    beside the reference), and the run uses at most 1/MARGIN of it in every column: the
    margin the table's measurement claims (tools/tolerances.py)."""
    out, _, _ = shipped_run
    scene = load_scene(SCENES / f"{scene_name}.toml")
    assert scene.check is not None and scene.check.why
    declared = json.loads((REFERENCES / f"{scene_name}.json").read_text())["check"]
    assert parse_check(declared, "reference") == scene.check
    comparison = compare(out / f"{scene_name}.csv", scene.reference)
    assert comparison.passed, str(comparison)
    assert comparison.declared == scene.check
    assert comparison.samples == scene.steps + 1
    assert comparison.summary["ratio"].max() <= 1 / MARGIN, comparison.summary
    meta = json.loads((out / f"{scene_name}.json").read_text())
    assert meta["steps"] == scene.steps and meta["partial"] is False
    assert meta["versions"]["fmpy"] and meta["wall_time_s"] > 0
    assert meta["units"]  # every recorded variable with its unit
    assert meta["check"] == declared
    assert (out / f"{scene_name}.png").stat().st_size > 10_000


def test_gear_columns_and_snap_through_in_the_suspension_run(fmu_dir, tmp_path):
    result, paths = run_scene(SCENES / "suspension_load_ramp.toml", tmp_path, fmu_dir, plot=False)
    times, columns = read_csv(paths["csv"])
    assert list(columns)[0] == "load.load" and len(times) == 401
    snaps = np.flatnonzero(columns["suspension.snap_through"])
    assert len(snaps) == 1 and times[snaps[0]] == pytest.approx(3.10)
    assert any("snap-through" in entry["message"] for entry in result.log)
    meta = json.loads(paths["json"].read_text())
    assert any("snap-through" in entry["message"] for entry in meta["log"])


def test_failed_run_keeps_the_rows_computed_before_as_partial(fmu_dir, tmp_path):
    # A constant piston speed past the stroke end would leave the assembly range; with a
    # stroke from 1.25 ft to 2.1 ft the piston passes h + d = 2.05 ft at about t = 2.8 s.
    data = gear_scene(stop_time=3.0, step=0.1)
    data["components"]["actuator"]["parameters"] = {"end_extension": 2.1 * 0.3048}
    scene = parse_scene(data, tmp_path / "inline.toml")
    with pytest.raises(SimulationError) as caught:
        run_scene(scene, tmp_path, fmu_dir)
    error = caught.value
    assert error.component == "gear"
    assert "piston_extension" in str(error) and "assembly range" in str(error)
    assert error.paths["csv"].name == "inline_gear.partial.csv"
    times, columns = read_csv(error.paths["csv"])
    assert 2.5 < times[-1] < 3.0 and all(np.isfinite(columns["gear.gear_angle"]))
    meta = json.loads(error.paths["json"].read_text())
    assert meta["partial"] is True and meta["failed_component"] == "gear"
    assert not (tmp_path / "inline_gear.csv").exists()


@pytest.mark.parametrize(
    "change, words",
    [
        (
            lambda d: d["components"].update(extra={"fmu": "NoSuchModel"}),
            ["NoSuchModel.fmu not found", "mechfmu build"],
        ),
        (
            lambda d: d["connections"].append("ghost.x -> gear.piston_speed"),
            ["unknown component 'ghost'"],
        ),
        (
            lambda d: d["connections"].__setitem__(
                0, "actuator.piston_extension -> gear.gear_anglez"
            ),
            ["has no variable 'gear_anglez'", "gear_angle"],
        ),
        (
            lambda d: d["connections"].__setitem__(0, "actuator.piston_speed -> gear.piston_speed"),
            ["connected twice"],
        ),
        (lambda d: d["connections"].pop(), ["piston_acceleration", "neither connected"]),
        (
            lambda d: d["components"]["gear"].update(parameters={"bar_length": "long"}),
            ["gear.bar_length is Real", "str 'long'"],
        ),
        (
            lambda d: d["components"]["gear"].update(parameters={"gear_angle": 1.0}),
            ["gear.gear_angle is a output, expected parameter"],
        ),
        (lambda d: d.update(record=["gear.nothing"]), ["has no variable 'nothing'"]),
        (lambda d: d.update(step=0.3), ["not a whole number of communication steps"]),
        (lambda d: d.update(stop_time=-1.0), ["stop_time = -1.0 s must exceed"]),
        (lambda d: d.update(colour="red"), ["unknown key(s) colour"]),
        (lambda d: d["connections"].append("gear piston"), ["component.output -> component.input"]),
    ],
)
def test_scene_errors_name_the_problem(fmu_dir, tmp_path, change, words):
    data = gear_scene()
    change(data)
    with pytest.raises(SceneError) as caught:
        Simulation(parse_scene(data, tmp_path / "inline.toml"), fmu_dir)
    for word in words:
        assert word in str(caught.value), str(caught.value)


def test_algebraic_loop_is_named():
    connections = [
        Connection("a", "y", "b", "u"),
        Connection("b", "y", "c", "u"),
        Connection("c", "y", "b", "v"),
    ]
    with pytest.raises(SceneError, match=r"algebraic loop.*b -> c -> b"):
        order_components(["a", "b", "c"], connections)
    assert order_components(["b", "a"], connections[:1]) == (["a", "b"], [])


def test_a_loop_through_a_state_output_lags_that_connection():
    # c.y depends on no input (a state): the loop b -> c -> b is not algebraic
    connections = [
        Connection("a", "y", "b", "u"),
        Connection("b", "y", "c", "u"),
        Connection("c", "y", "b", "v"),
    ]
    order, lagged = order_components(
        ["a", "b", "c"], connections, lambda connection: connection.source != "c"
    )
    assert order == ["a", "b", "c"] and lagged == [connections[2]]


def test_malformed_toml_is_reported_with_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("stop_time = [1,\n")
    with pytest.raises(SceneError, match="broken.toml: malformed TOML"):
        load_scene(path)


def test_committed_references_equal_freshly_generated_ones(tmp_path):
    generated = generate(SCENES, tmp_path)
    assert sorted(p.name for p in generated) == sorted(f"{n}.csv" for n in GENERATED)
    for path in generated:
        # the JSON (units, the scene's check tolerances) is text made of the scene: exact
        json_name = path.with_suffix(".json").name
        assert (tmp_path / json_name).read_text() == (REFERENCES / json_name).read_text()
        times, columns = read_csv(path)
        committed_times, committed = read_csv(REFERENCES / path.name)
        assert times == committed_times and list(columns) == list(committed)
        # Never bit for bit: numpy/scipy pick SIMD and BLAS kernels by CPU, so a fresh
        # reference differs from the committed one in the last bits. Each column is compared
        # with a tolerance scaled to its own magnitude (an element near zero in a column of
        # 1e4 N carries the rounding of 1e4 N, not of 0): closed forms are good to ~1e-15
        # relative, so 1e-12 of the column's largest |value| leaves a margin of ~1000 for the
        # kernels' differences; integrated references (solve_ivp at rtol = atol = 1e-12,
        # event times found by root finding) agree to ~1e-10 between CPUs, hence 1e-8. The
        # 1e-300 keeps an all-zero column's tolerance positive.
        tolerance = 1e-8 if path.stem in INTEGRATED else 1e-12
        for name in columns:
            fresh, stored = np.asarray(columns[name]), np.asarray(committed[name])
            atol = tolerance * float(np.max(np.abs(stored), initial=0.0)) + 1e-300
            np.testing.assert_allclose(
                fresh, stored, rtol=tolerance, atol=atol, err_msg=f"{path.name}: {name}"
            )


def test_check_command_exit_codes_and_worst_deviation(tmp_path, capsys):
    reference = REFERENCES / "gear_retraction.csv"
    times, columns = read_csv(reference)
    assert cli(["check", str(reference), str(reference)]) == 0
    columns["gear.gear_angle"][150] *= 1 + 1e-6
    from mechfmu.cosim.results import write_csv

    tampered = write_csv(tmp_path / "tampered.csv", times, columns)
    capsys.readouterr()
    assert cli(["check", str(tampered), str(reference)]) == 1
    out = capsys.readouterr().out
    assert "MISMATCH" in out and "gear.gear_angle at t = 1.5 s" in out
    assert cli(["check", str(tampered), str(reference), "--rtol", "1e-5"]) == 0
    assert cli(["check", str(tmp_path / "missing.csv"), str(reference)]) == 2


def test_cli_run_writes_outputs_and_checks_against_the_reference(fmu_dir, tmp_path, capsys):
    code = cli(
        [
            "run",
            str(SCENES / "gear_retraction.toml"),
            "--out",
            str(tmp_path),
            "--fmu-dir",
            str(fmu_dir),
            "--check",
            "--no-plot",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    assert "match: 6 column(s), 301 sample(s)" in out
    assert (tmp_path / "gear_retraction.csv").is_file()


def test_a_shipped_scene_runs_and_checks_by_name_from_any_directory(fmu_dir, tmp_path):
    """`mechfmu run gear_retraction --check` from a folder that is not the repository: the
    scene and its reference CSV are package data."""
    done = run_mechfmu(
        "run",
        "gear_retraction",
        "--check",
        "--no-plot",
        "--fmu-dir",
        str(fmu_dir),
        cwd=tmp_path,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "match: 6 column(s), 301 sample(s)" in done.stdout
    assert (tmp_path / "out" / "gear_retraction.csv").is_file()


def test_a_script_in_sims_writes_to_the_current_folder_and_is_named_in_its_usage(fmu_dir, tmp_path):
    """python sims/run_gear.py from any folder writes out/ there (not in the repository)
    and finds the FMUs by the one rule; its usage names the script."""
    done = run_script("run_gear.py", "--no-plot", cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (tmp_path / "out" / "gear_retraction.csv").is_file()
    usage = run_script("run_gear.py", "--help", timeout=60)
    assert usage.returncode == 0 and usage.stdout.startswith("usage: run_gear.py ")


def test_a_script_in_sims_run_by_a_python_without_mechfmu_uses_the_clones_venv(tmp_path):
    """python sims/run_gear.py typed without activating the venv that make run made: the script
    runs again under that venv's python; with no venv, one line says to run make run."""
    clone = tmp_path / "clone"
    (clone / "sims").mkdir(parents=True)
    for name in ("_venv.py", "run_gear.py"):
        shutil.copy(ROOT / "sims" / name, clone / "sims" / name)
    # -S: the base interpreter without site-packages, so mechfmu cannot be imported there
    bare = [getattr(sys, "_base_executable", sys.executable), "-S"]
    script = str(clone / "sims" / "run_gear.py")
    without = subprocess.run([*bare, script, "--help"], capture_output=True, text=True, timeout=60)
    assert without.returncode == 1
    assert without.stderr.strip().splitlines() == [
        f"run_gear.py: mechfmu is not installed for {bare[0]}; run 'make run' in "
        f"{clone.resolve()} first (it creates .venv), or activate the venv that has it"
    ]
    (clone / ".venv").symlink_to(sys.prefix, target_is_directory=True)
    within = subprocess.run([*bare, script, "--help"], capture_output=True, text=True, timeout=60)
    assert within.returncode == 0, within.stderr
    assert within.stdout.startswith("usage: run_gear.py ")


def test_package_data_ships_every_scene_sweep_and_reference():
    """pyproject's package-data patterns cover every shipped scene, sweep and reference
    CSV, so an installed wheel finds them as a clone does."""
    patterns = read_toml(ROOT / "pyproject.toml")["tool"]["setuptools"]["package-data"]["mechfmu"]
    package = ROOT / "src" / "mechfmu"
    shipped = {
        path
        for folder in ("scenes", "sweeps")
        for path in (package / folder).rglob("*")
        if path.is_file() and "__pycache__" not in path.parts
    }
    covered = {path for pattern in patterns for path in package.glob(pattern)}
    assert shipped and shipped <= covered, sorted(map(str, shipped - covered))
    assert {path.stem for path in REFERENCES.glob("*.csv")} == set(GENERATED)
    assert {path.stem for path in REFERENCES.glob("*.json")} == set(GENERATED)


@pytest.mark.parametrize(
    "script, expected",
    [
        ("run_gear.py", "against the reference CSV (declared by the reference: rtol 1e-13"),
        ("run_suspension.py", "snap-through at t = 3.10 s"),
        ("run_four_bar.py", "open     theta3 =    88.8372 deg, theta4 =   117.2861 deg"),
        ("run_slider_crank.py", "against the numpy closed form (declared by the reference: "),
        ("run_valve_train.py", "camshaft at 1.01 x the float speed: 8 loss(es) of contact"),
    ],
)
def test_runner_scripts(fmu_dir, tmp_path, script, expected):
    done = run_script(script, "--out", tmp_path, "--fmu-dir", fmu_dir)
    assert done.returncode == 0, done.stdout + done.stderr
    assert expected in done.stdout
    assert any(tmp_path.glob("*.png"))


def test_components_feeding_no_recorded_output_are_not_instantiated(fmu_dir, tmp_path):
    data = gear_scene(record=["actuator.piston_extension"])
    data["components"]["idle"] = {"fmu": "LoadProfile"}
    result, paths = run_scene(
        parse_scene(data, tmp_path / "inline.toml"), tmp_path, fmu_dir, plot=False
    )
    meta = json.loads(paths["json"].read_text())
    assert set(meta["pruned"]) == {"gear", "idle"}
    assert "not instantiated" in meta["pruned"]["gear"]
    assert meta["order"] == ["actuator"] and list(result.columns) == ["actuator.piston_extension"]
    assert not any(entry["instance"] in ("gear", "idle") for entry in result.log)


def test_unknown_effect_is_named_with_the_available_ones(fmu_dir, tmp_path):
    data = gear_scene()
    data["components"]["gear"]["effects"] = ["warp_drive"]
    with pytest.raises(SceneError, match="has no effect 'warp_drive'; its effects: "):
        Simulation(parse_scene(data, tmp_path / "inline.toml"), fmu_dir)
