"""``mechfmu check`` on files and folders: every failure kind named with its file, and its
line, column or time; exit codes; --tol; --method tube; the JUnit XML and the HTML report."""

import re
import shutil
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import REFERENCES

from mechfmu.cli import main as cli
from mechfmu.io import read_result, write_result
from mechfmu.tools.report.checks import plot_name

SCENES = ["gear_retraction", "suspension_load_ramp", "valve_train"]


@pytest.fixture
def trees(tmp_path):
    """(results, references): two folders holding the same three reference CSVs, one of
    them in a sub-folder."""
    results, references = tmp_path / "results", tmp_path / "references"
    for folder in (results, references):
        (folder / "valve").mkdir(parents=True)
        for scene in SCENES:
            target = folder / ("valve" if scene.startswith("valve") else "") / f"{scene}.csv"
            shutil.copy(REFERENCES / f"{scene}.csv", target)
    return results, references


def run(capsys, *arguments):
    code = cli(["check", *map(str, arguments)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def line_of(out, name):
    lines = [line for line in out.splitlines() if line.startswith(f"{name}: ")]
    assert len(lines) == 1, out
    return lines[0]


def test_matching_trees_exit_0_with_one_line_per_file(trees, capsys):
    code, out, _ = run(capsys, *trees)
    assert code == 0
    assert line_of(out, "gear_retraction.csv").startswith(
        "gear_retraction.csv: match: 6 column(s), 301 sample(s)"
    )
    assert line_of(out, "valve/valve_train.csv").startswith("valve/valve_train.csv: match:")
    assert out.splitlines()[-1] == "3 file(s): 3 match, 0 mismatch"


def test_a_changed_value_names_file_column_and_time(trees, capsys):
    results, references = trees
    frame = read_result(results / "gear_retraction.csv")
    frame.iloc[150, frame.columns.get_loc("gear.gear_angle")] *= 1 + 1e-6
    write_result(frame, results / "gear_retraction.csv")
    code, out, _ = run(capsys, results, references)
    assert code == 1
    line = line_of(out, "gear_retraction.csv")
    assert "MISMATCH" in line and "gear.gear_angle at t = 1.5 s" in line
    assert out.splitlines()[-1] == "3 file(s): 2 match, 1 mismatch"
    # a looser tolerance for that column (an fnmatch pattern) makes it pass
    assert run(capsys, results, references, "--tol", "gear.*=1e-5")[0] == 0
    assert run(capsys, results, references, "--tol", "gear.gear_angle=0,1e-5")[0] == 0
    assert run(capsys, results, references, "--rtol", "1e-5")[0] == 0
    code, _, err = run(capsys, results, references, "--tol", "gear.gear_angel=1")
    assert code == 1 and "--tol gear.gear_angel matches no column" in err


@pytest.mark.parametrize(
    "damage, expected",
    [
        ("cut", "line 101, column 'actuator.piston_speed': empty field"),
        ("text", "line 6, column 'gear.gear_angle': 'abc' is not a number"),
        ("empty", "empty file"),
    ],
)
def test_a_malformed_result_is_a_failure_naming_file_and_line(trees, capsys, damage, expected):
    results, references = trees
    path = results / "gear_retraction.csv"
    lines = path.read_text().splitlines()
    if damage == "cut":
        text = "\n".join(lines[:100] + [lines[100].split(",")[0] + ",0.1"]) + "\n"
    elif damage == "text":
        cells = lines[5].split(",")
        cells[4] = "abc"
        lines[5] = ",".join(cells)
        text = "\n".join(lines) + "\n"
    else:
        text = ""
    path.write_text(text)
    code, out, err = run(capsys, results, references)
    assert code == 1 and "Traceback" not in out + err
    line = line_of(out, "gear_retraction.csv")
    assert line.startswith("gear_retraction.csv: MISMATCH: malformed file: ")
    assert f"{path}: {expected}" in line
    assert line_of(out, "suspension_load_ramp.csv").startswith("suspension_load_ramp.csv: match")


def test_missing_file_and_result_without_reference(trees, capsys):
    results, references = trees
    (results / "valve" / "valve_train.csv").unlink()
    shutil.copy(REFERENCES / "valve_float.csv", results / "extra.csv")
    code, out, _ = run(capsys, results, references)
    assert code == 1
    line = line_of(out, "valve/valve_train.csv")
    assert "MISMATCH: missing file" in line and str(results / "valve" / "valve_train.csv") in line
    assert (
        line_of(out, "extra.csv")
        == f"extra.csv: not compared: no reference file for {results / 'extra.csv'}"
    )
    assert (
        out.splitlines()[-1] == "4 file(s): 2 match, 1 mismatch, 1 without reference (not compared)"
    )


def test_missing_and_extra_columns_and_time_grid(trees, capsys):
    results, references = trees
    gear = read_result(results / "gear_retraction.csv")
    write_result(
        gear.drop(columns=["gear.gear_angle"]).assign(**{"gear.spare": 1.0}),
        results / "gear_retraction.csv",
    )
    ramp = read_result(results / "suspension_load_ramp.csv")
    write_result(ramp.iloc[:250], results / "suspension_load_ramp.csv")  # cut at 2.49 s
    junit = results.parent / "junit.xml"
    code, out, _ = run(capsys, results, references, "--junit", junit)
    assert code == 1
    line = line_of(out, "gear_retraction.csv")
    assert "missing column gear.gear_angle" in line and "1 more failing column(s)" in line
    line = line_of(out, "suspension_load_ramp.csv")
    assert (
        "time grid: the result ends early, at t = 2.49 s (its file ends at line 251: cut "
        "short?); the reference goes on to t = 2.5 s" in line
    )
    cases = {
        (case.get("classname"), case.get("name")): case
        for case in ET.parse(junit).getroot().iter("testcase")
    }
    failure = cases["gear_retraction.csv", "gear.gear_angle"].find("failure")
    assert failure.get("type") == "missing column"
    failure = cases["gear_retraction.csv", "gear.spare"].find("failure")
    assert failure.get("type") == "extra column"
    failure = cases["suspension_load_ramp.csv", "(time grid)"].find("failure")
    assert failure.get("type") == "time grid" and "2.5 s" in failure.get("message")
    skipped = cases["suspension_load_ramp.csv", "suspension.deflection"].find("skipped")
    assert skipped.get("message") == "not compared: the time grids differ"
    suite = ET.parse(junit).getroot().find("testsuite")
    # every column of the cut ramp but the grid itself is skipped (not compared)
    assert suite.get("failures") == "3" and suite.get("skipped") == str(len(ramp.columns))
    code, out, _ = run(capsys, results, references, "--ignore-extra")
    assert "1 more failing" not in line_of(out, "gear_retraction.csv")
    assert code == 1


def test_tube_accepts_a_late_snap_through_that_pointwise_rejects(tmp_path, capsys):
    reference = read_result(REFERENCES / "suspension_load_ramp.csv")[["suspension.branch"]]
    times = reference.index.to_numpy()
    late = reference.copy()
    late["suspension.branch"] = np.interp(times - 0.01, times, reference["suspension.branch"])
    write_result(reference, tmp_path / "reference.csv")
    write_result(late, tmp_path / "late.csv")
    code, out, _ = run(capsys, tmp_path / "late.csv", tmp_path / "reference.csv")
    assert code == 1 and "suspension.branch at t = 3.1 s: " in out and "vs reference 1.0" in out
    assert (
        run(capsys, tmp_path / "late.csv", tmp_path / "reference.csv", "--method", "tube")[0] == 0
    )  # default tube: one step of the reference
    code, out, _ = run(
        capsys,
        tmp_path / "late.csv",
        tmp_path / "reference.csv",
        "--method",
        "tube",
        "--time-tolerance",
        "0.004",
    )
    assert code == 1 and "suspension.branch at t = 3.1 s" in out


def test_exit_2_when_nothing_is_comparable(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    code, _, err = run(capsys, tmp_path / "a", tmp_path / "b")
    assert code == 2 and "no CSV file in" in err
    code, _, err = run(capsys, tmp_path / "missing", REFERENCES)
    assert code == 2 and f"result {tmp_path / 'missing'} does not exist" in err
    code, _, err = run(capsys, REFERENCES, REFERENCES / "gear_retraction.csv")
    assert code == 2 and "is a folder but reference" in err
    code, _, err = run(capsys, REFERENCES, REFERENCES, "--tol", "gear.gear_angle")
    assert code == 2 and "expected COLUMN=RTOL or COLUMN=RTOL,ATOL" in err
    code, _, err = run(capsys, REFERENCES, REFERENCES, "--rtol", "-1")
    assert code == 2 and "--rtol must be a finite number >= 0" in err
    code, _, err = run(capsys, REFERENCES, REFERENCES, "--time-tolerance", "0.01")
    assert code == 2 and "give --method tube with it" in err
    # a file against the folder holding its namesake
    code, out, _ = run(capsys, REFERENCES / "gear_retraction.csv", REFERENCES)
    assert code == 0 and "gear_retraction.csv: match" in out


def test_junit_has_one_testcase_per_file_and_column(trees, capsys, tmp_path):
    results, references = trees
    frame = read_result(results / "gear_retraction.csv")
    frame.iloc[150, frame.columns.get_loc("gear.gear_angle")] += 1e-3
    write_result(frame, results / "gear_retraction.csv")
    (results / "valve" / "valve_train.csv").write_text("time,a\n0.0,1\n0.1")
    junit = tmp_path / "out" / "junit.xml"
    code, out, _ = run(capsys, results, references, "--junit", junit)
    assert code == 1 and f"junit: {junit}" in out
    root = ET.parse(junit).getroot()
    suite = root.find("testsuite")
    cases = suite.findall("testcase")
    ramp_columns = len(read_result(REFERENCES / "suspension_load_ramp.csv").columns)
    assert len(cases) == 6 + ramp_columns + 1
    assert suite.get("tests") == str(len(cases)) == root.get("tests")
    assert suite.get("failures") == "2" == root.get("failures")
    assert suite.get("skipped") == root.get("skipped") and root.get("errors") == "0"
    failed = {
        (case.get("classname"), case.get("name")): case.find("failure")
        for case in cases
        if case.find("failure") is not None
    }
    assert set(failed) == {
        ("gear_retraction.csv", "gear.gear_angle"),
        ("valve/valve_train.csv", "(file)"),
    }
    value = failed["gear_retraction.csv", "gear.gear_angle"]
    assert value.get("type") == "value" and "at t = 1.5 s" in value.get("message")
    malformed = failed["valve/valve_train.csv", "(file)"]
    assert malformed.get("type") == "malformed file" and "line 3" in malformed.get("message")


def test_report_has_a_plot_of_every_failing_column(trees, capsys, tmp_path):
    results, references = trees
    frame = read_result(results / "valve" / "valve_train.csv")
    for column in ("valve.valve_lift", "valve.contact_force"):
        frame[column] = frame[column] * 1.01
    write_result(frame, results / "valve" / "valve_train.csv")
    report = tmp_path / "report"
    code, out, _ = run(capsys, results, references, "--report", report)
    assert code == 1 and f"report: {report / 'index.html'}" in out
    page = (report / "index.html").read_text()
    pngs = sorted(path.name for path in report.glob("*.png"))
    assert pngs == sorted(
        plot_name("valve/valve_train.csv", column)
        for column in ("valve.contact_force", "valve.valve_lift")
    )
    assert pngs[0].startswith("valve_valve_train.csv__valve.contact_force-")
    for name in pngs:
        assert f'<img src="{name}"' in page
        assert (report / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "gear_retraction.csv: match" in page
    assert "valve/valve_train.csv: MISMATCH" in page
    # the failures come first, in a summary table; the files that match last, folded
    summary = page.index("<h2>Failures</h2>")
    rows = re.findall(r'<tr><td><a href="#(file-\d+)">([^<]+)</a></td><td>([^<]+)</td>', page)
    assert sorted((name, column) for _, name, column in rows) == [
        ("valve/valve_train.csv", "valve.contact_force"),
        ("valve/valve_train.csv", "valve.valve_lift"),
    ]
    anchor = rows[0][0]
    assert summary < page.index(f'id="{anchor}"') < page.index("file(s) that match</summary>")
    assert page.index("<details>") < page.index("gear_retraction.csv: match")


def test_a_malformed_reference_is_named_too(trees, capsys):
    results, references = trees
    path = references / "suspension_load_ramp.csv"
    path.write_text(path.read_text().replace("time,", "t,", 1))
    code, out, err = run(capsys, results, references)
    assert code == 1 and "Traceback" not in out + err
    assert f"{path}: line 1: the first column must be 'time'" in line_of(
        out, "suspension_load_ramp.csv"
    )
    # one pair, a file against a folder without its namesake: nothing comparable
    code, out, _ = run(capsys, results / "gear_retraction.csv", references / "valve")
    assert code == 2 and "gear_retraction.csv: not compared: no reference file" in out
