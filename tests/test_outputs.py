"""Where results go and how they are written: scene names that are plain file names, every
file inside --out, the output folder checked before anything runs, CSV and JSON as a pair
(both or neither, also on a full disk), the umask's permissions, and an older complete
result moved aside by a failed run."""

import errno
import json
import os
import stat
import subprocess
from pathlib import Path

import pytest

from mechfmu.cli import main as cli_main
from mechfmu.cosim import files
from mechfmu.cosim.master import Result, Simulation
from mechfmu.cosim.results import write_result
from mechfmu.io import read_result
from mechfmu.cosim.scene import SceneError, parse_scene
from test_robustness import _FAILING_SCENE

PAST_THE_STROKE = 2.1 * 0.3048  # m: test_robustness's scene leaves the gear's assembly range

STROKE_END = 2.0 * 0.3048  # m: the coursework's stroke, retracts within the scene


def write_scene(
    folder, name="same", stop_time=1.0, end_extension=STROKE_END, file_name="scene.toml"
):
    """test_robustness's gear scene, which fails past the stroke (end_extension 2.1 ft, near
    t = 2.8 s), renamed and with its stop time and stroke end replaced."""
    text = (
        _FAILING_SCENE.replace('name = "failing"', f"name = {json.dumps(name)}")
        .replace("stop_time = 3.0", f"stop_time = {stop_time!r}")
        .replace(f"end_extension = {PAST_THE_STROKE!r}", f"end_extension = {end_extension!r}")
    )
    path = Path(folder) / file_name
    path.write_text(text)
    return path


def run(scene, out, fmu_dir, capsys):
    code = cli_main(["run", str(scene), "--out", str(out), "--fmu-dir", str(fmu_dir), "--no-plot"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def no_simulation(monkeypatch):
    """Make any simulation fail the test: the checks must come first."""

    def refuse(*arguments, **keywords):
        raise AssertionError("a simulation ran although the output folder is unusable")

    monkeypatch.setattr(Simulation, "run", refuse)


# --- scene names --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name",
    [
        "../escaped",
        "/tmp/absolute",
        "",
        ".",
        "..",
        ".hidden",
        "sub/dir",
        "back\\slash",
        "line\nbreak",
        "x" * 201,
    ],
)
def test_a_scene_name_must_be_a_plain_file_name(tmp_path, name):
    data = {
        "name": name,
        "stop_time": 1.0,
        "step": 0.1,
        "components": {"actuator": {"fmu": "PistonActuator"}},
    }
    with pytest.raises(SceneError, match="name = .* must be a plain file name"):
        parse_scene(data, tmp_path / "scene.toml")


def test_a_scene_named_outside_the_output_folder_writes_nothing(fmu_dir, tmp_path, capsys):
    out = tmp_path / "out"
    scene = write_scene(tmp_path, name="../escaped")
    code, _, err = run(scene, out, fmu_dir, capsys)
    assert code == 2 and "scene error:" in err and "'../escaped'" in err, err
    assert not (tmp_path / "escaped.csv").exists() and not (tmp_path / "escaped.json").exists()
    assert not out.exists() or list(out.iterdir()) == []


def test_the_writer_refuses_a_file_outside_the_output_folder(tmp_path):
    """The second line of defence: a Scene built in Python without parse_scene."""
    scene = parse_scene(
        {
            "name": "fine",
            "stop_time": 1.0,
            "step": 0.1,
            "components": {"a": {"fmu": "PistonActuator"}},
        },
        tmp_path / "s.toml",
    )
    scene.name = "../outside"
    result = Result(scene=scene, times=[0.0], columns={"a.x": [1.0]}, units={"a.x": "m"})
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(files.OutputError, match="outside the output folder"):
        write_result(result, out, plot=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert list(out.iterdir()) == []


# --- the output folder, checked first ------------------------------------------------------------


def test_out_that_is_a_regular_file_stops_before_the_simulation(
    fmu_dir, tmp_path, capsys, monkeypatch
):
    no_simulation(monkeypatch)
    out = tmp_path / "out"
    out.write_text("not a folder")
    code, _, err = run(write_scene(tmp_path), out, fmu_dir, capsys)
    assert code == 2, err
    assert err.strip().splitlines() == [f"output error: output folder {out} is not a directory"], (
        err
    )
    assert out.read_text() == "not a folder"


def _deny_writes_below(folder, monkeypatch):
    """Make ``folder`` read-only: by its mode, or for root (who ignores modes) by the
    immutable attribute, or where neither holds (root on a file system without chattr) by
    refusing, as the kernel would, to create files below it."""
    folder.chmod(0o555)
    probe = folder / "probe"
    try:
        probe.touch()
    except PermissionError:
        return lambda: folder.chmod(0o755)
    probe.unlink()
    if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode == 0:
        return lambda: subprocess.run(["chattr", "-i", str(folder)], check=True)
    original = os.open

    def refusing(path, flags, *arguments, **keywords):
        if Path(path).parent == folder and flags & os.O_CREAT:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return original(path, flags, *arguments, **keywords)

    monkeypatch.setattr(os, "open", refusing)
    return lambda: folder.chmod(0o755)


def test_read_only_out_stops_before_the_simulation(fmu_dir, tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    restore = _deny_writes_below(out, monkeypatch)
    no_simulation(monkeypatch)
    try:
        code, _, err = run(write_scene(tmp_path), out, fmu_dir, capsys)
    finally:
        restore()
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        f"output error: output folder {out} is not writable:"
    ), err
    assert list(out.iterdir()) == []


def test_a_missing_out_is_created_with_its_parents(fmu_dir, tmp_path, capsys):
    out = tmp_path / "a" / "b"
    code, _, err = run(write_scene(tmp_path), out, fmu_dir, capsys)
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["same.csv", "same.json"]


# --- how the files are written ----------------------------------------------------------------


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o027, 0o640), (0o002, 0o664)])
def test_files_get_the_permissions_the_umask_gives(fmu_dir, tmp_path, capsys, umask, mode):
    previous = os.umask(umask)
    try:
        code, _, err = run(write_scene(tmp_path), tmp_path / "out", fmu_dir, capsys)
        single = files.atomic_write(tmp_path / "single.txt", "text\n")
    finally:
        os.umask(previous)
    assert code == 0, err
    for path in [tmp_path / "out" / "same.csv", tmp_path / "out" / "same.json", single]:
        assert stat.S_IMODE(path.stat().st_mode) == mode, path


def test_a_group_is_written_all_or_none(tmp_path):
    first, second = tmp_path / "a.csv", tmp_path / "a.json"
    first.write_text("old csv\n")
    second.write_text("old json\n")

    def failing(handle):
        handle.write("half")
        raise RuntimeError("the JSON cannot be made")

    with pytest.raises(RuntimeError, match="cannot be made"):
        files.atomic_write_all({first: "new csv\n", second: failing})
    assert first.read_text() == "old csv\n" and second.read_text() == "old json\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "a.json"]
    files.atomic_write_all({first: "new csv\n", second: b"new json\n"})
    assert first.read_text() == "new csv\n" and second.read_text() == "new json\n"


def _disk_full_after(budget, monkeypatch):
    """os.write fails with ENOSPC once ``budget`` bytes have been written through it."""
    original, left = os.write, [budget]

    def write(fd, data):
        if len(data) > left[0]:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        left[0] -= len(data)
        return original(fd, data)

    monkeypatch.setattr(os, "write", write)


@pytest.mark.parametrize("budget", [0, 2000])  # nothing fits; the CSV fits, the JSON not
def test_a_full_disk_writes_neither_csv_nor_json(fmu_dir, tmp_path, capsys, monkeypatch, budget):
    out = tmp_path / "out"
    out.mkdir()
    scene = write_scene(tmp_path)
    _disk_full_after(budget, monkeypatch)
    code, _, err = run(scene, out, fmu_dir, capsys)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("output error: cannot write ") and "same." in lines[0]
    assert "No space left on device" in lines[0], err
    # no complete-looking CSV without its JSON, no temporary file; the rows streamed so far
    # stay readable as the unsealed <scene>.partial.csv (issue 33)
    assert [p.name for p in out.iterdir()] in ([], ["same.partial.csv"])
    if (out / "same.partial.csv").exists():
        assert len(read_result(out / "same.partial.csv")) > 0


def test_a_failed_run_moves_an_older_complete_result_aside(fmu_dir, tmp_path, capsys):
    out = tmp_path / "out"
    good = write_scene(tmp_path, stop_time=1.0)
    assert run(good, out, fmu_dir, capsys)[0] == 0
    complete = (out / "same.csv").read_text()
    failing = write_scene(
        tmp_path, stop_time=3.0, end_extension=PAST_THE_STROKE, file_name="failing.toml"
    )
    code, _, err = run(failing, out, fmu_dir, capsys)
    assert code == 1, err
    assert sorted(p.name for p in out.iterdir()) == [
        "same.partial.csv",
        "same.partial.json",
        "same.previous.csv",
        "same.previous.json",
    ]
    assert (out / "same.previous.csv").read_text() == complete
    assert f"older complete result moved aside: {out / 'same.previous.csv'}" in err
    meta = json.loads((out / "same.partial.json").read_text())
    assert meta["partial"] is True and meta["moved_aside"] == [
        str(out / "same.previous.csv"),
        str(out / "same.previous.json"),
    ]
    # a complete run again: the current result is back under its own name
    assert run(good, out, fmu_dir, capsys)[0] == 0
    assert (out / "same.csv").read_text() == complete
