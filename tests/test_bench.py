"""The benchmark command, quick mode: every row written, times finite and positive, each ratio
the quotient of its parts, the null FMUs doing nothing. The timing targets are reported by
the benchmark, never asserted here: they depend on the machine."""

import contextlib
import csv
import io
import json
import math

import pytest

from cli_process import run_script
from conftest import SCENES, SWEEPS
from mechfmu.cli import main as cli
from mechfmu.tools.bench import dynamic_scenes, growth, model_cost
from mechfmu.tools.bench.report import CSV_COLUMNS, RATIO_UNIT, Row, ratio_parts
from mechfmu.packaging.build import build_all

MASTER_CASES = [
    f"{master}: {what}"
    for master in ("ours", "fmpy")
    for what in ("wall per step", "set-up", "FMI calls per step", "overhead per step")
]
MASTER_CASES += ["total per step, ours / fmpy", "overhead per step, ours / fmpy"]
MASTER_CASES += [f"one FMU, {case}" for case in MASTER_CASES[:8]]
MASTER_CASES += ["one FMU: total per step, ours / fmpy", "one FMU: overhead per step, ours / fmpy"]
MASTER_CASES += ["one FMU, its calls alone: wall per step", "one FMU: its calls alone / fmpy"]
EXPECTED = {
    "master overhead": MASTER_CASES,
    "model cost": [
        f"{case.label}: {what}"
        for case in model_cost.CASES
        for what in ("model", "null", "model / null")
    ]
    + [f"{case.label}: effect on / off" for case in model_cost.CASES if case.effect_of],
    "effects": [
        "gear_retraction (kinematic, 2 FMUs)",
        "gear_retraction_dynamic (six effects, radau)",
        "kinematic / dynamic",
    ],
    "floor": ["closed form (numpy)", "FMU run (master loop)", "FMU / closed form"],
    "sweep": [
        "1 worker(s): wall time",
        "1 worker(s): throughput",
        "2 worker(s): wall time",
        "2 worker(s): throughput",
        "speed-up, 2 workers over 1",
    ],
    "dynamic scenes": [
        f"{name}: loop / simulated"
        for name in (
            "gear_extension_gravity",
            "gear_retraction_dynamic",
            "gear_retraction_external_hydraulics",
            "suspension_road_bump",
            "suspension_sudden_load",
            "valve_float_dynamic",
            "valve_train_dynamic",
        )
    ],
    "growth": [
        *(f"{k}x stop time: loop" for k in growth.FACTORS),
        *(f"{k}x / 1x stop time" for k in growth.FACTORS[1:]),
        "1x stop time: per step",
        "8x stop time: per step",
        "per step, 8x / 1x",
    ],
    # --quick plays 1 s at 10 frames/s; the MP4 with the video extra (in the test extra)
    "animation": [f"four_bar_crank_rocker, 1 s at 10 frames/s: {kind}" for kind in ("GIF", "MP4")],
    # --quick: 500, 5000 and 50000 steps
    "long runs": [
        *(f"run peak memory, {k}x ({500 * k} steps)" for k in (1, 10, 100)),
        "run peak memory, 100x / 1x",
        "valve_train_dynamic: loop CPU / simulated",
        "valve_float_dynamic: loop CPU / simulated",
    ],
    # --quick: result files of 1 and 5 MB, sweeps of 1e3 and 1e4 points
    "big_files": [
        *(
            f"check {case}: {what}"
            for case in (
                "1 MB pair (pointwise)",
                "5 MB pair (pointwise)",
                "5 MB pair (tube)",
                "5 MB pair, last line cut",
            )
            for what in ("peak resident", "throughput")
        ),
        *(
            f"5 MB result: {what}"
            for what in ("CSV size", "Parquet size", "read_result CSV", "read_result Parquet")
        ),
        "sweep of 1000 points: peak resident",
        "sweep of 10000 points: peak resident",
    ],
}
# Differences of two medians (wall - FMI time, intercept of the per-step line): on a busy
# machine noise can push them to or below zero, so they are only required to be finite.
DIFFERENCES = ("overhead per step", "set-up")


@pytest.fixture(scope="module")
def bench(fmu_dir, tmp_path_factory):
    """Run the quick benchmark once; (exit status, stdout, rows by (benchmark, case), out)."""
    out = tmp_path_factory.mktemp("bench")
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        status = cli(
            [
                "bench",
                "--quick",
                "--out",
                str(out),
                "--fmu-dir",
                str(fmu_dir),
                "--scenes",
                str(SCENES),
                "--sweeps",
                str(SWEEPS),
            ]
        )
    with open(out / "bench.csv", newline="", encoding="utf-8") as handle:
        records = list(csv.DictReader(handle))
    return status, stdout.getvalue(), records, out


def _rows(records):
    return {(r["benchmark"], r["case"]): r for r in records}


def test_every_expected_row_once(bench):
    status, _, records, _ = bench
    assert status == 0
    found = [(r["benchmark"], r["case"]) for r in records]
    expected = [(benchmark, case) for benchmark, cases in EXPECTED.items() for case in cases]
    assert sorted(found) == sorted(expected)
    assert list(records[0]) == list(CSV_COLUMNS)


def test_model_cost_covers_every_kinematic_configuration():
    labels = {case.label for case in model_cost.CASES}
    assert labels == {
        "LandingGear (motion drive)",
        "PistonActuator",
        "Suspension (static)",
        "LoadProfile (ramp)",
        "RoadProfile (bump)",
        "CrankDrive",
        "CamshaftDrive",
        *(
            f"{model} ({solver})"
            for model in ("FourBar", "SliderCrank", "ValveTrain")
            for solver in ("closed_form", "constraint_solver")
        ),
        # the forces effect on (issue 29), each against its case with it off
        "LandingGear (motion drive, forces)",
        "FourBar (closed_form, forces)",
        "FourBar (constraint_solver, forces)",
        "SliderCrank (closed_form, forces)",
        "ValveTrain (constraint_solver, forces)",
    }
    for case in model_cost.CASES:
        if case.effect_of:
            assert case.parameters["forces"] and case.effect_of in labels


def test_times_finite_and_positive(bench):
    _, _, records, _ = bench
    for record in records:
        value = float(record["value"])
        assert math.isfinite(value), record
        if (
            record["benchmark"] in ("sweep", "big_files")  # measured once (big files: a child)
            or "peak memory" in record["case"]
        ):
            assert int(record["repeats"]) == 1 and value > 0.0, record
            continue
        assert int(record["repeats"]) == 2
        if record["unit"] != RATIO_UNIT and not record["case"].endswith(DIFFERENCES):
            assert record["unit"] in ("us", "ms", "s", "s/s", "MiB") and value > 0.0, record


def test_ratios_are_the_quotients_of_their_parts(bench):
    _, _, records, _ = bench
    rows = _rows(records)
    ratios = [r for r in records if r["unit"] == RATIO_UNIT]
    effects = [case for case in model_cost.CASES if case.effect_of]  # their on / off rows
    assert (
        len(ratios)
        == 2 + 3 + len(model_cost.CASES) + len(effects) + 2 + 1 + len(growth.FACTORS) + 1
    )
    for record in ratios:
        row = Row(
            record["benchmark"],
            record["case"],
            float(record["value"]),
            record["unit"],
            int(record["repeats"]),
            notes=record["notes"],
        )
        numerator, denominator = (rows[(record["benchmark"], case)] for case in ratio_parts(row))
        assert numerator["unit"] == denominator["unit"]
        assert float(record["value"]) == pytest.approx(
            float(numerator["value"]) / float(denominator["value"]), rel=1e-12
        )


def test_wall_time_is_fmi_time_plus_overhead(bench):
    _, _, records, _ = bench
    rows = _rows(records)
    for master in ("ours", "fmpy", "one FMU, ours", "one FMU, fmpy"):

        def value(what):
            return float(rows[("master overhead", f"{master}: {what}")]["value"])

        assert value("overhead per step") == pytest.approx(
            value("wall per step") - value("FMI calls per step"), rel=1e-9, abs=1e-9
        )


def test_targets_reported_not_asserted(bench):
    _, _, records, _ = bench
    targets = {r["case"]: r["target"] for r in records if r["target"]}
    assert targets["total per step, ours / fmpy"] == "<= 0.5"
    assert targets["overhead per step, ours / fmpy"] == "<= 0.5"
    assert targets["kinematic / dynamic"] == "<= 1/3"
    assert targets["speed-up, 2 workers over 1"] == ">= 1.7"
    assert targets["one FMU: total per step, ours / fmpy"] == "<= 0.5"
    assert targets["per step, 8x / 1x"] == "<= 1.25"
    assert all(
        targets[case] == ("<= 0.25" if case.startswith("valve_") else "<= 1")
        for case in EXPECTED["dynamic scenes"]
    )
    assert all(targets[case] == "<= 30 s" for case in EXPECTED["animation"])
    assert all(
        targets[f"{case.label}: model / null"]
        == ("<= 6" if "constraint_solver" in case.label else "<= 1.3")
        for case in model_cost.CASES
        if not case.effect_of
    )
    # an effect's cost is reported without a target (the issue asks to show it)
    assert not any(
        f"{case.label}: {what}" in targets
        for case in model_cost.CASES
        if case.effect_of
        for what in ("model / null", "effect on / off")
    )
    for record in records:
        if record["target"]:
            if record["target"] == ">= 1.7":
                assert record["meets_target"] == str(float(record["value"]) >= 1.7).lower()
                continue
            limit = {
                "<= 0.5": 0.5,
                "<= 1.3": 1.3,
                "<= 6": 6.0,
                "<= 1/3": 1.0 / 3.0,
                "<= 1": 1.0,
                "<= 0.25": 0.25,
                "<= 1.25": 1.25,
                "<= 30 s": 30.0,
            }[record["target"]]
            assert record["meets_target"] == str(float(record["value"]) <= limit).lower()
        else:
            assert record["meets_target"] == ""


def test_markdown_and_machine_files(bench):
    _, stdout, records, out = bench
    table = (out / "bench.md").read_text(encoding="utf-8")
    assert table.startswith("| benchmark | case | value | unit | target | met |")
    assert table.count("\n| ") == len(records)  # one line per row below the header
    assert "Machine: " in table and "fmpy 0.3" in table
    assert table.split("\n\n")[0] in stdout
    machine = json.loads((out / "machine.json").read_text(encoding="utf-8"))
    assert set(machine) == {
        "cpu",
        "logical_cores",
        "os",
        "python",
        "numpy",
        "fmpy",
        "pythonfmu",
        "date",
    }
    assert machine["logical_cores"] >= 1 and machine["pythonfmu"] == "0.7.0"
    assert not list(out.glob(".*.tmp"))  # atomic writes leave no temporary files


def test_null_fmu_does_nothing_while_the_model_moves(fmu_dir, tmp_path):
    case = next(c for c in model_cost.CASES if c.model == "LandingGear")
    (null_fmu,) = build_all(tmp_path, [case.model], null=True)
    assert null_fmu.name == "LandingGearNull.fmu"
    null_run = model_cost.run_case(case, null_fmu, steps=50)
    model_run = model_cost.run_case(case, fmu_dir / "LandingGear.fmu", steps=50)
    # Same variables, same initialisation: both start from the model's initial outputs.
    assert null_run.initial_outputs == model_run.initial_outputs
    assert null_run.final_outputs == null_run.initial_outputs
    assert model_run.final_outputs != model_run.initial_outputs
    assert all(math.isfinite(value) for value in model_run.final_outputs)


def test_dynamic_scenes_are_those_that_integrate():
    from mechfmu.cosim.scene import load_scene

    found = {scene.name for scene in dynamic_scenes.dynamic_scenes(SCENES)}
    assert found == {case.split(":")[0] for case in EXPECTED["dynamic scenes"]}
    assert not dynamic_scenes.is_dynamic(load_scene(SCENES / "gear_retraction.toml"))


def test_missing_fmus_stop_with_the_build_command(tmp_path, capsys):
    assert (
        cli(
            [
                "bench",
                "--quick",
                "--fmu-dir",
                str(tmp_path / "none"),
                "--out",
                str(tmp_path / "out"),
            ]
        )
        == 2
    )
    assert "mechfmu build" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_effects_script_runs_the_effects_benchmark(fmu_dir):
    done = run_script("bench_effects.py", "--fmu-dir", fmu_dir, "--repeats", "1", timeout=120)
    assert done.returncode == 0, done.stderr
    assert "| effects | kinematic / dynamic |" in done.stdout


def test_valve_costs_script_measures_the_floor_under_the_valve(fmu_dir):
    # sims/valve_step_costs.py --floor: each valve scene as shipped and with ValveSpring's
    # null twin in its place; the twin's loop leaves out the valve's own computation
    done = run_script("valve_step_costs.py", "--fmu-dir", fmu_dir, "--repeats", "2", "--floor")
    assert done.returncode == 0, done.stderr
    rows = {}
    for line in done.stdout.splitlines():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if len(cells) == 3 and cells[0].startswith("valve_") and "," in cells[1]:
            rows[cells[0]] = [float(x) for x in (*cells[1].split(","), *cells[2].split(","))]
    assert set(rows) == {"valve_train_dynamic", "valve_float_dynamic"}
    for shipped_first, shipped, null_first, null in rows.values():
        assert 0.0 < null < shipped and 0.0 < null_first < shipped_first
    assert "| valve.fmi2DoStep |" in done.stdout
