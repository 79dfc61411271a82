"""mechfmu.io: result CSVs as DataFrames. read_result reads what mechfmu run writes (units from
the JSON beside it), write_result writes the same format atomically with the umask's
permissions and round-trips exactly; every malformed file is one ResultFileError line naming
the file, and the line and column."""

import json
import os
import re

import numpy as np
import pandas as pd
import pytest
from conftest import REFERENCES, SCENES

from mechfmu.cosim.run import run_scene
from mechfmu.cosim.scene import load_scene
from cli_process import run_mechfmu
from mechfmu.io import (
    ResultFileError,
    companion_json,
    read_result,
    read_table,
    write_result,
)

GOOD = "time,a.x,b.y\n0.0,1.0,2.0\n0.5,1.5,-2.5\n1.0,2.0,3.0\n"


def bits(values):
    """The IEEE 754 bit patterns of ``values``: the round trip is exact by construction
    (shortest repr text, correctly rounded parsing), the same on every CPU."""
    return np.asarray(values, dtype=np.float64).view(np.int64)


def test_a_reference_csv_reads_as_a_frame_indexed_by_time():
    frame = read_result(REFERENCES / "gear_retraction.csv")
    assert frame.index.name == "time" and frame.index.dtype == np.float64
    assert list(frame.columns) == [
        "actuator.piston_extension",
        "actuator.piston_speed",
        "actuator.piston_acceleration",
        "gear.gear_angle",
        "gear.gear_angular_velocity",
        "gear.gear_angular_acceleration",
    ]
    assert len(frame) == 301 and frame.index[-1] == pytest.approx(3.0, abs=1e-12)
    assert (frame.dtypes == np.float64).all()
    # 1.25 ft to 2.0 ft in 3 s: the piston's extension and constant speed, in SI units
    assert frame["actuator.piston_extension"].iloc[0] == pytest.approx(1.25 * 0.3048, rel=1e-12)
    assert frame["actuator.piston_speed"].iloc[150] == pytest.approx(0.25 * 0.3048, rel=1e-12)
    # the JSON beside it: the declared units and its scene's check tolerances
    assert frame.attrs["units"]["gear.gear_angle"] == "rad"
    assert frame.attrs["units"]["actuator.piston_speed"] == "m/s"
    assert frame.attrs["check"]["rtol"] == load_scene(SCENES / "gear_retraction.toml").check.rtol
    assert frame.attrs["file"] == str(REFERENCES / "gear_retraction.csv")


def test_write_result_round_trips_exactly_and_writes_the_same_text(tmp_path):
    rng = np.random.default_rng(7)
    times = np.cumsum(rng.uniform(1e-6, 1e-2, 200))
    values = {
        "a.x": rng.normal(size=200) * 10.0 ** rng.integers(-300, 300, 200),
        "b.y": rng.uniform(-1, 1, 200),
        "c.flag": (rng.uniform(size=200) > 0.5) * 1.0,
    }
    frame = pd.DataFrame(values, index=pd.Index(times, name="time"))
    frame.attrs.update(units={"a.x": "m", "b.y": "rad", "gone": "s"}, scene="made_up", step=0.01)
    path = write_result(frame, tmp_path / "r.csv")
    again = read_result(path)
    assert list(again.columns) == list(frame.columns)
    assert (bits(again.index) == bits(frame.index)).all()
    for name in frame.columns:
        assert (bits(again[name]) == bits(frame[name])).all(), name
    assert again.attrs["units"] == {"a.x": "m", "b.y": "rad"}  # only the columns written
    assert again.attrs["scene"] == "made_up" and again.attrs["step"] == 0.01
    text = path.read_text()
    assert text.splitlines()[0] == "time,a.x,b.y,c.flag"
    write_result(again, tmp_path / "s.csv")
    assert (tmp_path / "s.csv").read_text() == text
    # the committed reference is written back byte for byte
    reference = read_result(REFERENCES / "valve_float.csv")
    written = write_result(reference, tmp_path / "valve_float.csv")
    assert written.read_bytes() == (REFERENCES / "valve_float.csv").read_bytes()


def test_write_result_takes_a_time_column_and_refuses_what_is_not_a_result(tmp_path):
    flat = pd.DataFrame({"time": [0.0, 0.1], "a.x": [1, 2]})
    assert read_result(write_result(flat, tmp_path / "f.csv"))["a.x"].tolist() == [1.0, 2.0]
    cases = [
        (pd.DataFrame({"a.x": [1.0, np.nan]}, index=[0.0, 0.1]), "finite numbers only"),
        (pd.DataFrame({"a.x": [1.0, 2.0]}, index=[0.1, 0.1]), "increase strictly"),
        (pd.DataFrame({"a.x": ["one", "two"]}, index=[0.0, 0.1]), "numbers only"),
        (pd.DataFrame({0: [1.0, 2.0]}, index=[0.0, 0.1]), "got 0"),
    ]
    for frame, words in cases:
        with pytest.raises(ValueError, match=words):
            write_result(frame, tmp_path / "bad.csv")
    assert not (tmp_path / "bad.csv").exists() and not (tmp_path / "bad.json").exists()


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600)])
def test_written_results_get_the_umasks_permissions(tmp_path, umask, mode):
    previous = os.umask(umask)
    try:
        path = write_result(read_result(REFERENCES / "gear_retraction.csv"), tmp_path / "g.csv")
    finally:
        os.umask(previous)
    assert path.stat().st_mode & 0o777 == mode
    assert companion_json(path).stat().st_mode & 0o777 == mode


def test_what_mechfmu_run_writes_reads_with_its_units_and_metadata(fmu_dir, tmp_path):
    result, paths = run_scene(SCENES / "gear_retraction.toml", tmp_path, fmu_dir, plot=False)
    frame = read_result(paths["csv"])
    assert list(frame.columns) == list(result.columns)
    assert frame.attrs["units"]["gear.gear_angle"] == "rad"
    assert frame.attrs["units"]["actuator.piston_speed"] == "m/s"
    assert frame.attrs["scene"] == "gear_retraction" and frame.attrs["steps"] == 300
    np.testing.assert_allclose(
        frame["gear.gear_angle"], result.columns["gear.gear_angle"], rtol=1e-15, atol=0.0
    )
    # 90 degrees of travel, as the scene says
    travel = frame["gear.gear_angle"].iloc[-1] - frame["gear.gear_angle"].iloc[0]
    assert abs(travel) == pytest.approx(np.pi / 2, abs=1e-3)


MALFORMED = {
    "empty file": ("", "{path}: empty file (no header, no data)"),
    "no header": (
        "0.0,1.0\n0.1,2.0\n",
        "{path}: line 1: the first column must be 'time', got '0.0' (no header?)",
    ),
    "header only": ("time,a.x\n", "{path}: no data rows (only the header)"),
    "cut last line": (
        "time,a.x,b.y\n0.0,1.0,2.0\n0.1,1.5",
        (
            "{path}: line 3, column 'b.y': empty field (the line has fewer values "
            "than the header: cut short?)"
        ),
    ),
    "cut inside a number": (
        "time,a.x,b.y\n0.0,1.0,2.0\n0.1,1.5,2.0\n0.2,1.",
        (
            "{path}: line 4, column 'b.y': empty field (the line has fewer "
            "values than the header: cut short?)"
        ),
    ),
    "text in a number": (
        "time,a.x,b.y\n0.0,1.0,2.0\n0.1,1.5,abc\n",
        "{path}: line 3, column 'b.y': 'abc' is not a number",
    ),
    "NaN": (
        "time,a.x,b.y\n0.0,1.0,2.0\n0.1,nan,2.5\n",
        "{path}: line 3, column 'a.x': 'nan' is not a finite number",
    ),
    "infinity": (
        "time,a.x\n0.0,1.0\n0.1,-inf\n",
        "{path}: line 3, column 'a.x': '-inf' is not a finite number",
    ),
    "repeated time": (
        "time,a.x\n0.0,1.0\n0.1,2.0\n0.1,3.0\n",
        ("{path}: line 4: time 0.1 s repeats the previous line's 0.1 s (times must increase)"),
    ),
    "time going back": (
        "time,a.x\n0.0,1.0\n0.2,2.0\n0.1,3.0\n",
        ("{path}: line 4: time 0.1 s is before the previous line's 0.2 s (times must increase)"),
    ),
    "extra value": (
        "time,a.x\n0.0,1.0\n0.1,2.0,3.0\n",
        "{path}: line 3 has 3 values, the header 2 columns",
    ),
    "repeated column": (
        "time,a.x,a.x\n0.0,1.0,2.0\n",
        "{path}: line 1: column 'a.x' appears twice",
    ),
    "unnamed column": ("time,,a.x\n0.0,1.0,2.0\n", "{path}: line 1: column 2 has no name"),
    "blank line": ("time,a.x\n0.0,1.0\n\n0.1,2.0\n", "{path}: line 3 is blank"),
    "not text": (b"time,a.x\n0.0,\xff\xfe\n", "{path}: not UTF-8 text"),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_each_malformed_result_is_one_line_naming_file_line_and_column(tmp_path, case):
    content, message = MALFORMED[case]
    path = tmp_path / "result.csv"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(ResultFileError) as caught:
        read_result(path)
    assert str(caught.value) == message.format(path=path)
    assert "\n" not in str(caught.value)


def test_trailing_blank_lines_and_windows_line_ends_are_accepted(tmp_path):
    path = tmp_path / "r.csv"
    path.write_bytes(GOOD.replace("\n", "\r\n").encode() + b"\r\n\r\n")
    frame = read_result(path)
    assert frame.index.tolist() == [0.0, 0.5, 1.0] and frame["b.y"].tolist() == [2.0, -2.5, 3.0]


def test_missing_paths_and_a_malformed_json_beside_are_named(tmp_path):
    with pytest.raises(
        ResultFileError, match=f"^{re.escape(str(tmp_path / 'none.csv'))}: file not found$"
    ):
        read_result(tmp_path / "none.csv")
    with pytest.raises(
        ResultFileError, match=f"^{re.escape(str(tmp_path))}: is a directory, not a CSV file$"
    ):
        read_result(tmp_path)
    (tmp_path / "r.csv").write_text(GOOD)
    (tmp_path / "r.json").write_text('{"units": {"a.x": "m",}}')
    with pytest.raises(ResultFileError) as caught:
        read_result(tmp_path / "r.csv")
    assert str(caught.value) == (
        f"{tmp_path / 'r.json'}: malformed JSON: Expecting property "
        f"name enclosed in double quotes at line 1, column 23"
    )
    (tmp_path / "r.json").write_text(json.dumps({"units": {"a.x": 3}}))
    with pytest.raises(ResultFileError, match="'units' must map column names to unit strings"):
        read_result(tmp_path / "r.csv")


def test_read_table_keeps_empty_cells_apart_and_names_bad_cells(tmp_path):
    path = tmp_path / "sweep.csv"
    path.write_text(
        "index,c.p,max:c.v,error,wall_time_s,worker\n"
        "0,1.5,2.25,,0.1,host:1\n"
        "1,2.5,,SceneError: too big,0.2,host:1\n"
        "2,3.5,nan,,0.3,host:2\n"
    )
    table = read_table(path, text=("error", "worker"), integers=("index",), required=("index",))
    assert table["index"].tolist() == [0, 1, 2] and table["index"].dtype == np.int64
    assert table["c.p"].tolist() == [1.5, 2.5, 3.5]
    assert table["error"].tolist() == [None, "SceneError: too big", None]
    assert np.isnan(table["max:c.v"].iloc[1]) and np.isnan(table["max:c.v"].iloc[2])
    rows = read_table(path, text=("error", "worker"), integers=("index",), missing=None)
    assert rows["max:c.v"].iloc[1] is None and np.isnan(rows["max:c.v"].iloc[2])
    path.write_text("index,c.p\n0,1.5\n1,x\n")
    with pytest.raises(
        ResultFileError,
        match=r"sweep.csv: line 3, column 'c.p': 'x' is not a "
        r"number$",
    ):
        read_table(path, integers=("index",))
    path.write_text("index,c.p\n0,1.5\n1.5,2\n")
    with pytest.raises(ResultFileError, match=r"line 3, column 'index': '1.5' is not a whole"):
        read_table(path, integers=("index",))
    with pytest.raises(ResultFileError, match=r"line 1: missing column\(s\) error"):
        read_table(path, required=("index", "error"))


def test_a_malformed_result_given_to_the_cli_is_one_line_without_traceback(tmp_path):
    bad = tmp_path / "cut.csv"
    bad.write_text((REFERENCES / "gear_retraction.csv").read_text()[:-20])
    done = run_mechfmu(
        "docs",
        "--reference-plot",
        str(_scene_with_reference(tmp_path, bad)),
        "--out",
        str(tmp_path / "p.png"),
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr
    # 301 rows after the header: the last, cut inside its last value, is line 302
    assert lines[0] == (
        f"docs error: {bad}: line 302, column 'gear.gear_angular_acceleration'"
        f": empty field (the line has fewer values than the header: cut short?)"
    )


def _scene_with_reference(tmp_path, reference):
    text = (SCENES / "gear_retraction.toml").read_text()
    text = text.replace(
        'reference = "reference/gear_retraction.csv"', f'reference = "{reference.as_posix()}"'
    )
    path = tmp_path / "gear_retraction.toml"
    path.write_text(text)
    return path


PROFILE_TABLES = {  # the cases of the FMU's own reader (tests/test_physics_profiles.py)
    "header": ("time,load\n0.0,1.5\n0.5,2.5\n2.0,-1.0\n", None),
    "comments and blank lines": (
        ("# load history\n0,10\n\n  # indented comment\n1e-3, 20\n2,30\n"),
        None,
    ),
    "one row": ("5,7\n", None),
    "more values per line": ("time,height,note\n0,1,a\n1,2,b,c\n", None),
    "repeated time": (
        "0,1\n1,2\n1,3\n",
        "line 3: time 1.0 s is not after 1.0 s (times must increase)",
    ),
    "time going back": (
        "time,load\n0,1\n2,2\n1,3\n",
        "line 4: time 1.0 s is not after 2.0 s (times must increase)",
    ),
    "text in time": ("0,1\nabc,2\n", "line 2, column 'time': 'abc' is not a number"),
    "text in value": ("time,load\n0,1\n1,x\n", "line 3, column 'load': 'x' is not a number"),
    "missing value": ("0,1\n1\n", "line 2: expected 'time,value', got only '1'"),
    "NaN": ("0,1\n1,nan\n", "line 2, column 'value': nan is not a finite number"),
    "infinity": ("0,1\ninf,2\n", "line 2, column 'time': inf is not a finite number"),
    "second header": (
        "time,value\ntime,value\n0,1\n",
        "line 2, column 'time': 'time' is not a number",
    ),
    "no data rows": ("time,value\n# nothing\n", "no data rows"),
}


@pytest.mark.parametrize("case", list(PROFILE_TABLES))
def test_profile_tables_read_on_the_host_as_the_fmu_reads_them(tmp_path, case):
    from mechfmu.io import read_profile_table
    from mechfmu.runtime.errors import MechanismError
    from mechfmu.runtime.physics.profiles import read_table as fmu_read_table

    text, problem = PROFILE_TABLES[case]
    path = tmp_path / "table.csv"
    path.write_text(text)
    if problem is None:
        table = read_profile_table(path)
        times, values = fmu_read_table(path)
        assert table.index.name == "time" and len(table.columns) == 1
        assert (bits(table.index) == bits(times)).all()
        assert (bits(table.iloc[:, 0]) == bits(values)).all()
        return
    with pytest.raises(ResultFileError) as caught:
        read_profile_table(path)
    assert str(caught.value) == f"{path}: {problem}"
    with pytest.raises(MechanismError) as fmu:
        fmu_read_table(path)
    line = problem.split(":")[0].split(",")[0]
    assert line in str(fmu.value) or "no data rows" in str(fmu.value)


def test_a_bad_table_is_a_scene_error_before_the_run(fmu_dir, tmp_path):
    table = tmp_path / "load.csv"
    table.write_text("time,load\n0,0\n1,12,5\n2,1e3x\n")
    scene = tmp_path / "table.toml"
    scene.write_text(
        'stop_time = 1.0\nstep = 0.1\nrecord = ["load.load"]\n'
        '[components.load]\nfmu = "LoadProfile"\n'
        'parameters = { shape = "table", table_file = "load.csv" }\n'
    )
    done = run_mechfmu(
        "run", str(scene), "--out", str(tmp_path / "out"), "--fmu-dir", str(fmu_dir), "--no-plot"
    )
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        (
            f"scene error: {scene}: component 'load': table_file: {table}: line 4, column 'load': "
            f"'1e3x' is not a number"
        )
    ]
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())
    table.write_text("time,load\n0,0\n1,12\n")
    import mechfmu

    frame = mechfmu.simulate(scene, fmu_dir=fmu_dir)
    np.testing.assert_allclose(frame["load.load"], 12.0 * frame.index, rtol=1e-12, atol=1e-12)


def test_a_malformed_previous_study_table_stops_the_study_before_it_runs(tmp_path, capsys):
    from mechfmu.cli import main as cli
    from mechfmu.tools.study import measure

    header = ",".join(measure.COLUMNS)
    row = [
        "gear",
        "dopri5",
        "1e-8",
        "0.001",
        "0.01",
        "gauss_seidel",
        "gear.gear_angle",
        "1e-9",
        "1e-10",
        "1e-9",
        "1e-9",
        "1.5",
        "0.1",
        "0.2",
        "3.0",
        "3",
        "300",
        "x",
        "9",
        "ok",
    ]
    (tmp_path / "accuracy_cost.csv").write_text(f"{header}\n{','.join(row)}\n")
    assert cli(["study", "--quick", "--out", str(tmp_path), "--fmu-dir", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"study error: {tmp_path / 'accuracy_cost.csv'}: line 2, column 'substeps': 'x' is "
        f"not a whole number"
    )
