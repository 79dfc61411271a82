"""Corrupt FMU files: checked before loading (zip integrity, modelDescription.xml, the binary
for this platform present and a complete shared library), every failure naming the file and
the cause in one line, never a traceback or a bus error; a broken Python file inside an FMU
reported with the FMU's own log (the Python error), not only "Failed to instantiate"."""

import zipfile
from pathlib import Path

import pytest
from cli_process import run_mechfmu

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = "binaries/linux64/PistonActuator.so"
PYTHON_LIBRARY = "binaries/linux64/PistonActuator.pythonfmu.so"
MODEL_SOURCE = "resources/mechfmu_fmu_PistonActuator/models/piston_actuator.py"

SCENE = """
name = "corrupt"
stop_time = 0.1
step = 0.01
record = ["actuator.piston_extension"]
[components.actuator]
fmu = "{fmu}"
"""


def rewritten(fmu_dir, target, change):
    """A copy of PistonActuator.fmu with each member's bytes passed through
    ``change(name, data)`` (None drops the member)."""
    with (
        zipfile.ZipFile(fmu_dir / "PistonActuator.fmu") as source,
        zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as copy,
    ):
        for info in source.infolist():
            data = change(info.filename, source.read(info))
            if data is not None:
                copy.writestr(info, data)
    return target


def run(tmp_path, fmu, fmu_dir):
    scene = tmp_path / "corrupt.toml"
    scene.write_text(SCENE.format(fmu=Path(fmu).as_posix()))
    return run_mechfmu(
        "run", str(scene), "--out", str(tmp_path / "out"), "--fmu-dir", str(fmu_dir), "--no-plot"
    )


def truncated_archive(fmu_dir, target):
    data = (fmu_dir / "PistonActuator.fmu").read_bytes()
    target.write_bytes(data[: len(data) // 2])
    return target


def damaged_member(fmu_dir, target):
    """modelDescription.xml stored, then one of its bytes flipped: a CRC mismatch."""
    with (
        zipfile.ZipFile(fmu_dir / "PistonActuator.fmu") as source,
        zipfile.ZipFile(target, "w", zipfile.ZIP_STORED) as copy,
    ):
        for info in source.infolist():
            copy.writestr(info.filename, source.read(info))
    with zipfile.ZipFile(target) as archive:
        info = archive.getinfo("modelDescription.xml")
    data = bytearray(target.read_bytes())
    name_length, extra_length = (
        int.from_bytes(data[info.header_offset + 26 : info.header_offset + 28], "little"),
        int.from_bytes(data[info.header_offset + 28 : info.header_offset + 30], "little"),
    )
    start = info.header_offset + 30 + name_length + extra_length  # the member's own bytes
    data[start + 100] ^= 0x20
    target.write_bytes(bytes(data))
    return target


CASES = {
    "truncated archive": (truncated_archive, "is not a valid FMU: not a zip archive"),
    "damaged member": (
        damaged_member,
        "is not a valid FMU: member modelDescription.xml is damaged (its checksum does not match)",
    ),
    "no model description": (
        lambda fmu_dir, target: rewritten(
            fmu_dir, target, lambda name, data: None if name == "modelDescription.xml" else data
        ),
        "is not a valid FMU: it has no modelDescription.xml",
    ),
    "malformed model description": (
        lambda fmu_dir, target: rewritten(
            fmu_dir,
            target,
            lambda name, data: data[:200] if name == "modelDescription.xml" else data,
        ),
        "is not a valid FMU: its modelDescription.xml cannot be read:",
    ),
    "no binary for this platform": (
        lambda fmu_dir, target: rewritten(
            fmu_dir,
            target,
            lambda name, data: None if name.startswith("binaries/linux64/") else data,
        ),
        f"is not a valid FMU: it has no binary for this platform ({LIBRARY}); it has: no binaries",
    ),
    "truncated loader": (
        lambda fmu_dir, target: rewritten(
            fmu_dir, target, lambda name, data: data[: len(data) // 2] if name == LIBRARY else data
        ),
        f"is not a valid FMU: its binary {LIBRARY} is truncated",
    ),
    "truncated pythonfmu library": (
        lambda fmu_dir, target: rewritten(
            fmu_dir,
            target,
            lambda name, data: data[: len(data) // 2] if name == PYTHON_LIBRARY else data,
        ),
        f"is not a valid FMU: its binary {PYTHON_LIBRARY} is truncated",
    ),
    "not a shared library": (
        lambda fmu_dir, target: rewritten(
            fmu_dir, target, lambda name, data: b"#!/bin/sh\n" if name == LIBRARY else data
        ),
        f"is not a valid FMU: its binary {LIBRARY} is not an ELF shared library",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_corrupt_fmu_is_named_with_its_cause_before_loading(fmu_dir, tmp_path, case):
    make, cause = CASES[case]
    fmu = make(fmu_dir, tmp_path / "Broken.fmu")
    done = run(tmp_path, fmu, fmu_dir)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr  # no traceback
    assert lines[0].startswith(f"scene error: component 'actuator': FMU file {fmu} "), lines[0]
    assert cause in lines[0], lines[0]
    assert not (tmp_path / "out").exists() or list((tmp_path / "out").iterdir()) == []


def test_a_broken_python_file_inside_reports_the_python_error(fmu_dir, tmp_path):
    fmu = rewritten(
        fmu_dir,
        tmp_path / "Broken.fmu",
        lambda name, data: data + b"\nthis is not python(\n" if name == MODEL_SOURCE else data,
    )
    done = run(tmp_path, fmu, fmu_dir)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert (
        "simulation failed: component 'actuator' failed at t = 0.0 s: the FMU could not "
        "be instantiated; its log: "
    ) in done.stderr, done.stderr
    assert "SyntaxError" in done.stderr and "piston_actuator.py" in done.stderr, done.stderr
    assert "was never closed" in done.stderr, done.stderr
