"""The Python API: mechfmu.simulate, reference and sweep return DataFrames that agree with the
closed forms; parameter and time overrides change the run as the closed form says; bad
scenes, parameters and FMUs are one-line errors naming what is wrong; ``mechfmu run --all``
writes every shipped scene."""

import subprocess
import sys
import zipfile

import numpy as np
import pandas as pd
import pytest
from conftest import FMU_DIR, SCENES

import mechfmu
from mechfmu.cli import main as cli
from mechfmu.cosim.scene import SceneError, load_scene
from mechfmu.io import read_result, write_result

FOOT = 0.3048  # m


def assert_matches(frame, reference, rtol, atol):
    """Every column of ``reference`` in ``frame`` on the same time grid, within tolerance."""
    assert list(frame.columns) == list(reference.columns)
    np.testing.assert_allclose(frame.index, reference.index, rtol=0, atol=1e-12)
    np.testing.assert_allclose(frame.to_numpy(), reference.to_numpy(), rtol=rtol, atol=atol)


def test_simulate_a_shipped_scene_from_any_folder_equals_its_closed_form(
    fmu_dir, tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)  # no scene and no fmus/ here: both are found anyway
    frame = mechfmu.simulate("gear_retraction")
    reference = mechfmu.reference("gear_retraction")
    assert frame.index.name == "time" and len(frame) == 301
    assert_matches(frame, reference, rtol=1e-9, atol=1e-12)
    # 1.25 ft to 2.0 ft at 0.25 ft/s turns the gear through 90 degrees
    angle = frame["gear.gear_angle"]
    assert np.degrees(angle.iloc[-1] - angle.iloc[0]) == pytest.approx(90.0, abs=1e-9)
    assert frame["actuator.piston_speed"].iloc[100] == pytest.approx(0.25 * FOOT, rel=1e-12)
    assert frame.attrs["units"] == reference.attrs["units"]
    assert frame.attrs["units"]["gear.gear_angle"] == "rad"
    assert frame.attrs["units"]["actuator.piston_acceleration"] == "m/s2"
    assert frame.attrs["scene"] == "gear_retraction" and frame.attrs["step"] == 0.01
    assert frame.attrs["fmus"]["gear"]["file"] == str(FMU_DIR / "LandingGear.fmu")
    assert frame.attrs["fmus"]["gear"]["fmi_version"] == "2.0"
    assert frame.attrs["fmus"]["gear"]["generation_tool"].startswith("PythonFMU")
    assert frame.attrs["versions"]["pandas" if "pandas" in frame.attrs["versions"] else "fmpy"]
    assert 0 < frame.attrs["wall_time_s"] < 60 and frame.attrs["steps"] == 300


def test_parameters_change_the_run_as_the_closed_form_says(fmu_dir):
    faster = mechfmu.simulate(
        "gear_retraction", parameters={"actuator.stroke_time": 2.0}, fmu_dir=fmu_dir
    )
    expected = mechfmu.reference("gear_retraction", parameters={"actuator.stroke_time": 2.0})
    assert_matches(faster, expected, rtol=1e-9, atol=1e-12)
    assert faster.attrs["parameters"] == {"actuator.stroke_time": 2.0}
    assert faster.attrs["components"]["actuator"]["parameters"]["stroke_time"] == 2.0
    default = mechfmu.simulate("gear_retraction", fmu_dir=fmu_dir)
    # the same 0.75 ft stroke in 2 s: 0.375 ft/s, the full 90 degrees reached at t = 2 s
    assert faster["actuator.piston_speed"].iloc[50] == pytest.approx(0.375 * FOOT, rel=1e-12)
    assert faster["gear.gear_angle"].loc[2.0] == pytest.approx(
        default["gear.gear_angle"].loc[3.0], rel=1e-12
    )
    assert default["gear.gear_angle"].loc[2.0] < default["gear.gear_angle"].loc[3.0] - 0.2


def test_time_overrides_and_a_scene_file_path(fmu_dir, tmp_path):
    frame = mechfmu.simulate(
        SCENES / "gear_retraction.toml", stop_time=1.0, step=0.05, fmu_dir=fmu_dir
    )
    assert len(frame) == 21 and frame.index[-1] == pytest.approx(1.0, abs=1e-12)
    assert_matches(
        frame, mechfmu.reference("gear_retraction", stop_time=1.0, step=0.05), rtol=1e-9, atol=1e-12
    )
    scene = load_scene(SCENES / "gear_retraction.toml")  # a parsed scene, changed in memory
    scene.components["actuator"].parameters["stroke_time"] = 2.0
    frame = mechfmu.simulate(scene, stop_time=2.0, fmu_dir=fmu_dir)
    assert len(frame) == 201 and scene.stop_time == 3.0  # the caller's scene is left alone
    assert_matches(frame, mechfmu.reference(scene, stop_time=2.0), rtol=1e-9, atol=1e-12)
    with pytest.raises(
        SceneError,
        match=r"gear_retraction.toml: stop_time = 0.0 s must "
        r"exceed start_time = 0.0 s",
    ):
        mechfmu.simulate(scene, stop_time=0.0, fmu_dir=fmu_dir)
    with pytest.raises(
        SceneError,
        match=r"\(stop_time - start_time\) / step = .* is not a "
        r"whole number of communication steps",
    ):
        mechfmu.simulate("gear_retraction", step=0.07, fmu_dir=fmu_dir)


def test_simulate_result_written_and_read_back_keeps_units_and_scene(fmu_dir, tmp_path):
    frame = mechfmu.simulate("suspension_load_ramp", fmu_dir=fmu_dir)
    again = read_result(write_result(frame, tmp_path / "s.csv"))
    pd.testing.assert_frame_equal(again, frame, rtol=1e-15, atol=0.0)
    assert (
        again.attrs["units"] == frame.attrs["units"]
        and again.attrs["scene"] == "suspension_load_ramp"
    )
    assert_matches(
        frame, mechfmu.reference("suspension_load_ramp")[frame.columns], rtol=1e-9, atol=1e-9
    )


@pytest.mark.parametrize(
    "parameters, message",
    [
        (
            {"wheel.mass": 1.0},
            (
                "parameters: 'wheel.mass': scene gear_retraction has no component "
                "'wheel'; its components: actuator, gear"
            ),
        ),
        (
            {"gear.no_such": 1.0},
            (
                "parameters: 'gear.no_such': 'gear' (LandingGear) has no "
                "parameter 'no_such'; its parameters: aero_drag, "
            ),
        ),
        ({"stroke_time": 1.0}, "parameters: 'stroke_time' is not of the form component.parameter"),
        (
            {"actuator.stroke_time": "fast"},
            ("gear_retraction.toml: parameters: actuator.stroke_time is Real, got str 'fast'"),
        ),
    ],
)
def test_bad_parameters_are_named(fmu_dir, parameters, message):
    with pytest.raises(SceneError) as caught:
        mechfmu.simulate("gear_retraction", parameters=parameters, fmu_dir=fmu_dir)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_unknown_scene_and_missing_fmus_say_what_to_do(tmp_path):
    with pytest.raises(
        SceneError,
        match="no shipped scene named 'gear_retract' and no such "
        "file; shipped scenes: camshaft_inline_four, four_bar_crank_rocker, ",
    ):
        mechfmu.simulate("gear_retract")
    with pytest.raises(
        SceneError,
        match=r"FMU file .*PistonActuator.fmu not found; build the "
        r"FMUs with 'mechfmu build'",
    ):
        mechfmu.simulate("gear_retraction", fmu_dir=tmp_path)
    with pytest.raises(SceneError, match="has no closed-form reference; scenes with one: "):
        mechfmu.reference("gear_retraction_external_hydraulics")


BROKEN_TOML = 'name = "broken"\nstep = 0.1\nstop_time = = 1.0\n'


def test_a_malformed_scene_is_one_line_naming_the_file(tmp_path):
    scene = tmp_path / "broken.toml"
    scene.write_text(BROKEN_TOML)
    with pytest.raises(SceneError) as caught:
        mechfmu.simulate(scene)
    assert str(caught.value).startswith(f"{scene}: malformed TOML: ")
    assert "Invalid value (at line 3, column 13)" in str(caught.value)
    done = subprocess.run(
        [sys.executable, "-m", "mechfmu", "run", str(scene), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [f"scene error: {caught.value}"]


@pytest.mark.parametrize(
    "damage, cause",
    [
        (lambda data: data[: len(data) // 2], "is not a valid FMU: not a zip archive"),
        ("drop modelDescription.xml", "is not a valid FMU: it has no modelDescription.xml"),
    ],
)
def test_a_corrupt_fmu_given_to_simulate_is_named(fmu_dir, tmp_path, damage, cause):
    broken = tmp_path / "fmus"
    broken.mkdir()
    for name in ("LandingGear.fmu",):
        (broken / name).write_bytes((fmu_dir / name).read_bytes())
    target = broken / "PistonActuator.fmu"
    if callable(damage):
        target.write_bytes(damage((fmu_dir / "PistonActuator.fmu").read_bytes()))
    else:
        with (
            zipfile.ZipFile(fmu_dir / "PistonActuator.fmu") as source,
            zipfile.ZipFile(target, "w") as copy,
        ):
            for info in source.infolist():
                if info.filename != "modelDescription.xml":
                    copy.writestr(info, source.read(info))
    with pytest.raises(SceneError) as caught:
        mechfmu.simulate("gear_retraction", fmu_dir=broken)
    assert str(caught.value).startswith(f"component 'actuator': FMU file {target} {cause}")
    assert "\n" not in str(caught.value)


def test_sweep_returns_one_row_per_point_as_the_closed_form_says(fmu_dir):
    table = mechfmu.sweep(
        "gear_retraction",
        {"actuator.stroke_time": (2.0, 3.0, 3)},
        ["max:actuator.piston_speed", "final:gear.gear_angle"],
        jobs=1,
        fmu_dir=fmu_dir,
    )
    assert table.index.name == "index" and table.index.tolist() == [0, 1, 2]
    assert table["actuator.stroke_time"].tolist() == [2.0, 2.5, 3.0]
    np.testing.assert_allclose(
        table["max:actuator.piston_speed"], 0.75 * FOOT / table["actuator.stroke_time"], rtol=1e-12
    )
    final = mechfmu.reference("gear_retraction")["gear.gear_angle"].iloc[-1]
    np.testing.assert_allclose(table["final:gear.gear_angle"], final, rtol=1e-9)
    assert table["error"].isna().all()
    assert table.attrs["points"] == 3 and table.attrs["failed"] == 0


def test_run_all_writes_every_shipped_scene(fmu_dir, tmp_path, capsys):
    out = tmp_path / "baseline"
    assert cli(["run", "--all", "--out", str(out), "--fmu-dir", str(fmu_dir), "--no-plot"]) == 0
    shipped = sorted(path.stem for path in SCENES.glob("*.toml"))
    assert sorted(path.stem for path in out.glob("*.csv")) == shipped
    assert (
        f"ran {len(shipped)} shipped scene(s) into {out}: {len(shipped)} ok"
        in capsys.readouterr().out
    )
    gear = read_result(out / "gear_retraction.csv")
    assert_matches(gear, mechfmu.reference("gear_retraction"), rtol=1e-9, atol=1e-12)
    assert gear.attrs["units"]["gear.gear_angle"] == "rad"
    assert cli(["run", "gear_retraction", "--all", "--out", str(out)]) == 2
    assert "give a scene (gear_retraction) or --all, not both" in capsys.readouterr().err


def test_a_malformed_reference_given_to_run_is_one_line(fmu_dir, tmp_path):
    bad = tmp_path / "reference.csv"
    bad.write_text("time,gear.gear_angle\n0.0,1.0\n0.01,1.0x\n")
    command = [
        sys.executable,
        "-m",
        "mechfmu",
        "run",
        "--out",
        str(tmp_path / "out"),
        "--fmu-dir",
        str(fmu_dir),
        "--no-plot",
    ]
    done = subprocess.run(
        [*command, "gear_retraction", "--reference", str(bad)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2
    message = f"check error: {bad}: line 3, column 'gear.gear_angle': '1.0x' is not a number"
    assert done.stderr.strip().splitlines() == [message]
    assert not (tmp_path / "out").exists()  # read before the run: nothing written
    scene = tmp_path / "gear.toml"
    scene.write_text(
        (SCENES / "gear_retraction.toml")
        .read_text()
        .replace('reference = "reference/gear_retraction.csv"', 'reference = "reference.csv"')
    )
    done = subprocess.run(
        [*command, str(scene), "--check"], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.splitlines()[0] == message
    assert (tmp_path / "out" / "gear_retraction.csv").is_file()  # the run itself is kept


# SIGINT's default handler first: a process started in the background by a shell without job
# control inherits SIGINT ignored, and an ignored signal is left ignored (by Python and by us).
INTERRUPTED = """
import os, signal, threading, mechfmu
signal.signal(signal.SIGINT, signal.default_int_handler)
mechfmu.simulate("gear_retraction", fmu_dir={fmu_dir!r})  # imports and FMUs ready
threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
try:
    mechfmu.simulate("gear_retraction", step=1e-5, fmu_dir={fmu_dir!r})  # 300000 steps
except KeyboardInterrupt as stop:
    print("stopped:", stop)
print(mechfmu.simulate("gear_retraction", fmu_dir={fmu_dir!r}).shape)
"""


def test_ctrl_c_stops_simulate_between_steps_and_the_next_run_works(fmu_dir):
    done = subprocess.run(
        [sys.executable, "-c", INTERRUPTED.format(fmu_dir=str(fmu_dir))],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    first, second = done.stdout.strip().splitlines()
    assert first.startswith("stopped: interrupted by SIGINT at t = ") and " step(s)" in first
    assert second == "(301, 6)"
