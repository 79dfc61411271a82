"""Hostile input files, second round: every file mechfmu reads (scene TOML, CSV tables, the
JSON beside a result) is checked against the limits of mechfmu.cosim.limits before it is
parsed, and every violation is one line naming the file, the place and the limit (exit 2
from the command line, SceneError or ResultFileError from Python), never a traceback. What
``mechfmu check`` writes is safe for its format whatever the names in the files.

Each case below reproduced a failure of the attack on main (issue 32) before its fix."""

import json
import os
import re
import xml.etree.ElementTree as ET

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import mechfmu
from mechfmu.cli import main as cli
from mechfmu.cosim import limits
from mechfmu.cosim.scene import SceneError, load_scene
from mechfmu.cosim.text import one_line, plot_text
from mechfmu.io import ResultFileError, read_result, read_table, write_result
from mechfmu.tools.report.checks import plot_name

SCENE = """name = "hostile"
stop_time = 0.1
step = 0.01
record = ["actuator.piston_extension"]
[components.actuator]
fmu = "PistonActuator"
"""
ACTUATOR = "[components.actuator]\n"


def _component(extra):
    """SCENE with ``extra`` lines in the actuator's table."""
    return SCENE + extra


# (scene text or bytes, what the one line must say)
SCENES = {
    "nested arrays": (
        "stop_time = 0.1\nstep = 0.01\nx = " + "[" * 2000 + "]" * 2000 + "\n",
        "line 3, column 37: nested deeper than the limit of 32 levels",
    ),
    "nested inline tables": (
        "stop_time = 0.1\nstep = 0.01\nx = " + "{a = " * 500 + "1" + "}" * 500 + "\n",
        "nested deeper than the limit of 32 levels",
    ),
    "nested dotted keys": (
        "stop_time = 0.1\nstep = 0.01\n" + ".".join(["a"] * 200) + " = 1\n",
        "nested deeper than the limit of 32 levels",
    ),
    "nested table headers": (
        "stop_time = 0.1\nstep = 0.01\n[" + ".".join(["t"] * 100) + "]\n",
        "nested deeper than the limit of 32 levels",
    ),
    "invalid UTF-8": (
        b'stop_time = 0.1\nstep = 0.01\ndescription = "\xff\xfe"\n',
        "not UTF-8 text: byte 0xff at line 3, column 16",
    ),
    "5000-digit integer": (
        "stop_time = 0.1\nstep = 0.01\nx = " + "1" * 5000 + "\n",
        "line 3, column 5: a number of 5000 digits in a row, more than the limit of 100",
    ),
    "400-digit float parameter": (
        _component("parameters = { stroke_time = " + "1" * 400 + ".0 }\n"),
        "a number of 400 digits in a row, more than the limit of 100",
    ),
    "integer beyond 64 bits": (
        _component("parameters = { stroke_time = 123456789012345678901234567890 }\n"),
        "components.actuator.parameters.stroke_time = 123456789012345678901234567890 is "
        "outside the 64-bit integer range",
    ),
    "parameters a string": (
        _component('parameters = "abc"\n'),
        "component 'actuator': 'parameters' must be a table of name = value, got str 'abc'",
    ),
    "inputs an array": (
        _component("inputs = [1, 2]\n"),
        "component 'actuator': 'inputs' must be a table of name = value, got list [1, 2]",
    ),
    "a parameter that is a table": (
        _component("parameters = { stroke_time = { a = 1 } }\n"),
        "parameters.stroke_time = {'a': 1} is a dict; expected a number, a bool or a string",
    ),
    "a NUL in a string parameter": (
        _component('parameters = { profile = "a\\u0000b" }\n'),
        "parameters.profile = 'a\\x00b' holds a NUL character",
    ),
    "a name that is not a string": (
        SCENE.replace('name = "hostile"', "name = 5"),
        "name = 5 must be a string, got int",
    ),
    "a description that is not a string": (
        SCENE.replace('name = "hostile"', 'name = "hostile"\ndescription = 1'),
        "description = 1 must be a string, got int",
    ),
    "connections a string": (
        SCENE.replace("record =", 'connections = "a.b -> c.d"\nrecord ='),
        "'connections' must be a list of 'component.output -> component.input' strings",
    ),
    "reference a number": (
        SCENE.replace("record =", "reference = 3\nrecord ="),
        "reference = 3 must be a string, got int",
    ),
    "stop_time beyond a double": (
        SCENE.replace("stop_time = 0.1", "stop_time = 9223372036854775807e300"),
        "'stop_time' = inf must be a finite number",
    ),
    "a span beyond a double": (
        SCENE.replace("stop_time = 0.1", "start_time = -1.7e308\nstop_time = 1.7e308"),
        "(stop_time - start_time) / step = inf communication steps, more than the limit of 1e+09",
    ),
    "a trillion steps": (
        SCENE.replace("stop_time = 0.1", "stop_time = 1e6").replace("step = 0.01", "step = 1e-6"),
        "communication steps, more than the limit of 1e+09",
    ),
    "too large": (
        SCENE + "# " + "x" * limits.MAX_TOML_BYTES + "\n",
        f"more than the limit of {limits.MAX_TOML_BYTES // 1024 // 1024} MiB",
    ),
}


def run_cli(capsys, *arguments):
    code = cli([str(a) for a in arguments])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("case", list(SCENES))
def test_a_hostile_scene_is_one_line_naming_file_place_and_limit(fmu_dir, tmp_path, capsys, case):
    content, expected = SCENES[case]
    path = tmp_path / "hostile.toml"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    code, out, err = run_cli(capsys, "run", path, "--out", tmp_path / "out", "--fmu-dir", fmu_dir)
    assert code == 2, out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("scene error: "), lines[0]
    assert str(path) in lines[0], lines[0]
    assert expected in lines[0], lines[0]
    with pytest.raises(SceneError) as raised:  # the same from Python
        mechfmu.simulate(path, fmu_dir=fmu_dir)
    assert str(raised.value) == lines[0].removeprefix("scene error: ")


def test_a_folder_or_a_fifo_as_the_scene_is_named(fmu_dir, tmp_path, capsys):
    folder = tmp_path / "folder.toml"
    folder.mkdir()
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)  # reading it would block for ever
    for path, cause in ((folder, "is a directory, not a file"), (fifo, "not a regular file")):
        code, _, err = run_cli(capsys, "run", path, "--out", tmp_path / "out")
        assert code == 2 and err.count("\n") == 1, err
        assert err.startswith(f"scene error: scene file {path}: ") and cause in err, err


API_PARAMETERS = {
    "a list": ([1, 2], "parameters must map 'component.parameter' names to values, got list"),
    "an integer of 400 digits": (
        {"actuator.stroke_time": 10**400},
        "parameters: actuator.stroke_time = 100000000000000000000000000000...(401 "
        "characters)...0000000000 is outside the 64-bit integer range",
    ),
    "a key that is not a string": ({1: 2.0}, "parameters: 1 is not of the form"),
    "None": ({"actuator.stroke_time": None}, "is a NoneType; expected a number"),
    "a list value": ({"actuator.stroke_time": [1.0]}, "is a list; expected a number"),
    "a lone surrogate": ({"actuator.profile": "\ud800"}, "is not encodable as UTF-8"),
}


@pytest.mark.parametrize("case", list(API_PARAMETERS))
def test_api_parameters_of_the_wrong_kind_raise_scene_error(fmu_dir, tmp_path, case):
    parameters, expected = API_PARAMETERS[case]
    path = tmp_path / "s.toml"
    path.write_text(SCENE)
    with pytest.raises(SceneError) as raised:
        mechfmu.simulate(path, parameters=parameters, fmu_dir=fmu_dir)
    assert expected in str(raised.value)
    assert "\n" not in str(raised.value)


def test_api_times_beyond_a_double_raise_scene_error(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SCENE)
    scene = load_scene(path)
    for chosen in (path, scene):
        with pytest.raises(SceneError, match=r"'?stop_time'? = 1000.*must be a finite number"):
            mechfmu.simulate(chosen, stop_time=10**400)


# --- JSON beside a result, CSV tables ---------------------------------------------------------

GOOD = "time,a.x\n0.0,1.0\n1.0,2.0\n"
JSONS = {
    "nested arrays": ("[" * 100_000 + "]" * 100_000, "nested deeper than the limit of 64 levels"),
    "nested objects": ('{"a":' * 1000 + "1" + "}" * 1000, "nested deeper than the limit of 64"),
    "a 5000-digit number": ('{"step": ' + "9" * 5000 + "}", "a number of 5000 digits in a row"),
    "invalid UTF-8": (b'{"scene": "\xc3\x28"}', "not UTF-8 text: byte 0xc3 at line 1, column 12"),
    "not an object": ("[1, 2]", "must hold a JSON object, got list"),
    "malformed": ('{"units": ', "malformed JSON: Expecting value at line 1, column 11"),
    "too large": (
        '{"a": "' + "x" * limits.MAX_JSON_BYTES + '"}',
        "more than the limit of 16 MiB",
    ),
}


@pytest.mark.parametrize("case", list(JSONS))
def test_a_hostile_json_beside_a_result_is_one_line(tmp_path, case):
    content, expected = JSONS[case]
    (tmp_path / "r.csv").write_text(GOOD)
    meta = tmp_path / "r.json"
    meta.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(ResultFileError) as raised:
        read_result(tmp_path / "r.csv")
    assert str(raised.value).startswith(f"{meta}: ") and expected in str(raised.value)
    assert "\n" not in str(raised.value)


def test_csv_limits_columns_names_and_fifos(tmp_path):
    wide = tmp_path / "wide.csv"
    names = [f"c{i}" for i in range(limits.MAX_COLUMNS + 1)]
    wide.write_text("time," + ",".join(names) + "\n0.0," + ",".join("1" for _ in names) + "\n")
    with pytest.raises(ResultFileError, match="line 1: 10002 columns, more than the limit"):
        read_result(wide)
    long_name = tmp_path / "long.csv"
    long_name.write_text("time," + "x" * 1001 + "\n0.0,1.0\n")
    with pytest.raises(ResultFileError, match="column 2 has a name of 1001 characters"):
        read_result(long_name)
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    for read in (read_result, read_table):
        with pytest.raises(ResultFileError, match="is not a regular file"):
            read(fifo)


# --- result pairs ---------------------------------------------------------------------------


def _frame(stop, step=1.0):
    import numpy as np
    import pandas as pd

    times = np.arange(0.0, stop + step / 2, step)
    frame = pd.DataFrame({"a.x": times**2}, index=pd.Index(times, name="time"))
    frame.attrs.update(units={"a.x": "m"}, stop_time=stop)
    return frame


def test_a_result_pair_is_sealed_and_a_mixed_pair_refused(tmp_path):
    first = write_result(_frame(299.0), tmp_path / "a" / "k.csv")
    second = write_result(_frame(300.0), tmp_path / "b" / "k.csv")
    meta = json.loads(first.with_suffix(".json").read_text())
    assert len(meta["run_id"]) == 32 and meta["csv_bytes"] == first.stat().st_size
    import hashlib

    assert meta["csv_sha256"] == hashlib.sha256(first.read_bytes()).hexdigest()
    assert read_result(first).index[-1] == 299.0
    # the mixed pair: the CSV ends at 299 s, the JSON beside it says stop_time 300
    # (a writer of the second run killed between its two renames)
    os.replace(second.with_suffix(".json"), first.with_suffix(".json"))
    with pytest.raises(ResultFileError) as raised:
        read_result(first)
    message = str(raised.value)
    assert message.startswith(f"{first} and k.json are not one pair: the JSON (run ")
    assert "one of the two comes from another run" in message and "\n" not in message
    # a JSON without the seal (written before pairs were sealed, or by hand) still reads
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "k.csv").write_text(GOOD)
    (tmp_path / "c" / "k.json").write_text(json.dumps({"units": {"a.x": "m"}}))
    assert read_result(tmp_path / "c" / "k.csv").attrs["units"] == {"a.x": "m"}


def test_a_result_written_back_is_sealed_anew_and_keeps_its_run(tmp_path):
    path = write_result(_frame(3.0), tmp_path / "k.csv")
    frame = read_result(path)
    frame["a.x"] *= 2.0
    again = write_result(frame, tmp_path / "twice.csv")
    before = json.loads(path.with_suffix(".json").read_text())
    after = json.loads(again.with_suffix(".json").read_text())
    assert after["run_id"] == before["run_id"]
    assert after["csv_sha256"] != before["csv_sha256"]
    assert list(read_result(again)["a.x"]) == [0.0, 2.0, 8.0, 18.0]


def test_temporary_files_of_killed_writers_are_removed_by_the_next_writer(tmp_path):
    import subprocess
    import sys

    from mechfmu.cosim.files import HOST_TAG, output_folder

    gone = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        text=True,
        capture_output=True,
        check=True,
    )
    dead = int(gone.stdout)
    stale = tmp_path / f".k.json.{dead}.{HOST_TAG}.0123456789ab.tmp"
    alive = tmp_path / f".k.csv.{os.getpid()}.{HOST_TAG}.0123456789ab.tmp"
    other_host = "0" * 8 if HOST_TAG != "0" * 8 else "1" * 8
    elsewhere = tmp_path / f".k.csv.{dead}.{other_host}.0123456789ab.tmp"
    older = tmp_path / ".k.json.0123456789ab.tmp"  # the old format: whose, nobody knows
    for path in (stale, alive, elsewhere, older):
        path.write_text("half")
    output_folder(tmp_path)
    assert not stale.exists()
    assert alive.exists() and elsewhere.exists() and older.exists()
    alive.unlink()
    write_result(_frame(1.0), tmp_path / "k.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [elsewhere.name, older.name, "k.csv", "k.json"]
    )


# --- what check writes ----------------------------------------------------------------------


def _pair(folder, name, columns, value):
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    header = ",".join('"' + c.replace('"', '""') + '"' for c in columns)
    rows = "".join(f"{t}," + ",".join(str(value) for _ in columns) + "\n" for t in (0.0, 0.5, 1.0))
    path.write_text(f"time,{header}\n{rows}")
    return path


def test_check_writes_well_formed_junit_and_one_plot_per_file_and_column(tmp_path, capsys):
    results, references = tmp_path / "results", tmp_path / "references"
    columns = ["x y", "x_y", "c\x01d", "e$\\frac$f"]
    long_name = "L" * 245 + ".csv"
    for value, (name, cols) in enumerate(
        (("a.csv", columns), ("sub/x.csv", ["v"]), ("sub_x.csv", ["v"]), (long_name, ["v"])),
        start=1,
    ):
        _pair(results, name, cols, float(value))  # each file's plot its own
        _pair(references, name, cols, 0.0)
    junit, report = tmp_path / "junit.xml", tmp_path / "report"
    code, out, err = run_cli(
        capsys, "check", results, references, "--junit", junit, "--report", report
    )
    assert code == 1, err
    assert "Traceback" not in err and "\x01" not in out
    cases = ET.parse(junit).getroot().iter("testcase")  # well-formed: it parses
    names = {(case.get("classname"), case.get("name")) for case in cases}
    assert ("a.csv", "c\\x01d") in names and ("a.csv", "x_y") in names
    page = (report / "index.html").read_text()
    sources = re.findall(r'<img src="([^"]+)" alt="([^"]*)"', page)
    expected = {
        plot_name(file, column)
        for file, cols in (
            ("a.csv", columns),
            ("sub/x.csv", ["v"]),
            ("sub_x.csv", ["v"]),
            (long_name, ["v"]),
        )
        for column in cols
    }
    assert {source for source, _ in sources} == expected and len(sources) == 7
    assert all(len(source.encode()) <= 80 for source, _ in sources)
    pngs = {path.name: path.read_bytes() for path in report.glob("*.png")}
    assert set(pngs) == expected
    # 'x y' and 'x_y', 'sub/x.csv' and 'sub_x.csv': each plot its own (before, three of
    # four links showed another column's plot)
    assert len(set(pngs.values())) == len(pngs)


def test_check_names_a_nested_json_and_counts_missing_results_as_mismatches(tmp_path, capsys):
    results, references = tmp_path / "results", tmp_path / "references"
    _pair(results, "n.csv", ["v"], 1.0)
    _pair(references, "n.csv", ["v"], 1.0)
    (results / "n.json").write_text("[" * 100_000 + "]" * 100_000)
    code, out, err = run_cli(capsys, "check", results, references)
    assert code == 1 and "Traceback" not in err
    assert "n.csv: MISMATCH: malformed file: " in out and "nested deeper than" in out
    # a folder holding only what a failed and an older run leave: the result is missing
    only = tmp_path / "only"
    _pair(only, "k.partial.csv", ["v"], 1.0)
    _pair(only, "k.previous.csv", ["v"], 1.0)
    _pair(references, "k.csv", ["v"], 1.0)
    code, out, _ = run_cli(capsys, "check", only, references)
    assert code == 1 and "k.csv: MISMATCH: missing file" in out


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.text(min_size=1, max_size=300), st.text(min_size=1, max_size=300)),
        min_size=2,
        max_size=6,
        unique=True,
    )
)
def test_plot_names_are_short_ascii_and_distinct_for_distinct_pairs(pairs):
    names = [plot_name(file, column) for file, column in pairs]
    assert len(set(names)) == len(names)
    for name in names:
        assert name.isascii() and len(name) <= 80 and "/" not in name and name.endswith(".png")
        assert not name.startswith(".")


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=80))
def test_one_line_text_is_printable_xml_without_line_breaks(text):
    line = one_line(text)
    assert "\n" not in line and "\r" not in line
    line.encode("utf-8")  # no lone surrogate left
    element = ET.fromstring(ET.tostring(ET.Element("e", name=line)))
    assert element.get("name") == line
    assert "$" not in plot_text(text).replace(r"\$", "")
    if text.isprintable() and text.isascii():
        assert line == text


# --- the scans themselves -------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 120), st.sampled_from(["[", "{"]))
def test_json_nesting_is_refused_exactly_beyond_its_limit(depth, bracket):
    text = (
        ('{"a":' if bracket == "{" else "[") * depth
        + "1"
        + ("}" if bracket == "{" else "]") * depth
    )
    json.loads(text)  # well-formed at any depth this test makes
    problem = limits.scan_problem(text, limits.MAX_JSON_DEPTH, "json")
    assert (problem is not None) == (depth > limits.MAX_JSON_DEPTH), (depth, problem)


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 200), st.text(alphabet="[]{}\"#'\n 0123456789", max_size=40))
def test_toml_digits_and_brackets_inside_strings_and_comments_do_not_count(digits, noise):
    quoted = json.dumps(noise)  # a TOML basic string (JSON's escapes are TOML's)
    text = f"a = {quoted}\n# {noise.replace(chr(10), ' ')}\nb = {'1' * digits}\n"
    problem = limits.scan_problem(text, limits.MAX_TOML_DEPTH, "toml")
    assert (problem is not None) == (digits > limits.MAX_DIGITS), (text, problem)


@pytest.mark.parametrize(
    "value, expected",
    [
        ("[" * 3000, "nested deeper than the limit of 32 levels"),
        ("1" * 5000, "a number of 5000 digits in a row, more than the limit of 100"),
        ("123456789012345678901234567890", "is outside the 64-bit integer range"),
    ],
)
def test_a_hostile_set_value_is_one_line(fmu_dir, tmp_path, capsys, value, expected):
    """--set values are read as TOML (issue 27): the same limits before tomllib (before, a
    deep value raised RecursionError, a 5000-digit one ValueError's 4300-digit message)."""
    path = tmp_path / "s.toml"
    path.write_text(SCENE)
    code, _, err = run_cli(
        capsys, "run", path, "--out", tmp_path / "out", "--fmu-dir", fmu_dir, "--set",
        f"actuator.stroke_time={value}",
    )  # fmt: skip
    assert code == 2 and err.count("\n") == 1 and expected in err, err
