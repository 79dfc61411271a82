"""Corrupt FMU files: checked before loading (zip integrity, modelDescription.xml, the binary
for this platform present and a complete shared library), every failure naming the file and
the cause in one line, never a traceback or a bus error; a broken Python file inside an FMU
reported with the FMU's own log (the Python error), not only "Failed to instantiate"."""

import errno
import io
import os
import re
import shutil
import stat
import struct
import subprocess
import sys
import tempfile
import time
import tracemalloc
import warnings
import zipfile
from pathlib import Path

import pytest
from cli_process import run_mechfmu

import mechfmu
from mechfmu.cli import main as cli
from mechfmu.cosim import fmu_file
from mechfmu.cosim.files import HOST_TAG
from mechfmu.cosim.fmu_file import (
    UNPACK_MARKER,
    UNPACK_PREFIX,
    FmuError,
    checked_description,
    elf_problem,
)

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


def run(tmp_path, fmu, fmu_dir, **environment):
    scene = tmp_path / "corrupt.toml"
    scene.write_text(SCENE.format(fmu=Path(fmu).as_posix()))
    return run_mechfmu(
        "run",
        str(scene),
        "--out",
        str(tmp_path / "out"),
        "--fmu-dir",
        str(fmu_dir),
        "--no-plot",
        env=dict(os.environ, **environment),
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
    first = done.stderr.splitlines()[0]  # the FMU's multi-line log entry on one line
    assert "findClass; SyntaxError" in first and "piston_actuator.py" in first, done.stderr
    assert "was never closed" in first, done.stderr


# --- hostile archives (issue 32): checked before anything is unpacked -------------------------


def _added(fmu_dir, target, *members):
    """PistonActuator.fmu with ``members`` ((ZipInfo or name, bytes), ...) added."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # zipfile: "Duplicate name"
        with (
            zipfile.ZipFile(fmu_dir / "PistonActuator.fmu") as source,
            zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as copy,
        ):
            for info in source.infolist():
                copy.writestr(info, source.read(info))
            for info, data in members:
                copy.writestr(info, data, compress_type=zipfile.ZIP_DEFLATED, compresslevel=9)
    return target


def _link(name, target):
    info = zipfile.ZipInfo(name)
    info.create_system = 3
    info.external_attr = (stat.S_IFLNK | 0o777) << 16
    return info, target


MEMBERS = {
    "absolute path": (("/tmp/evil.txt", b"evil"), "member '/tmp/evil.txt' is an absolute path"),
    "parent folder": (
        ("resources/../../evil.txt", b"evil"),
        "member 'resources/../../evil.txt' holds a path part '..'",
    ),
    "drive letter": (("C:/evil.txt", b"evil"), "member 'C:/evil.txt' holds a colon"),
    "backslash": (("..\\evil.txt", b"evil"), "member '..\\\\evil.txt' holds a backslash"),
    "symbolic link": (
        _link("resources/link", b"/etc/passwd"),
        "member 'resources/link' is a symbolic link",
    ),
    "duplicate": (("modelDescription.xml", b"<x/>"), "member 'modelDescription.xml' appears twice"),
    "file and folder": (
        ("modelDescription.xml/inside", b"x"),
        "member 'modelDescription.xml' is both a file and a folder",
    ),
    "zip bomb in resources": (
        ("resources/bomb.bin", bytes(64 << 20)),
        "member 'resources/bomb.bin' unpacks to 67108864 bytes from ",
    ),
}


@pytest.fixture
def temporary(tmp_path, monkeypatch):
    """A temporary directory of its own for the test (tempfile's, TMPDIR's for children)."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    monkeypatch.setenv("TMPDIR", str(folder))
    return folder


@pytest.mark.parametrize("case", list(MEMBERS))
def test_a_hostile_member_is_refused_before_anything_is_unpacked(
    fmu_dir, tmp_path, temporary, capsys, case
):
    member, cause = MEMBERS[case]
    fmu = _added(fmu_dir, tmp_path / "Hostile.fmu", member)
    scene = tmp_path / "hostile.toml"
    scene.write_text(SCENE.format(fmu=fmu.as_posix()))
    for verb in ("run", "export-fmu"):
        extra = ["--out", tmp_path / "out"] if verb == "run" else [tmp_path / "packed.fmu"]
        code = cli([verb, str(scene), *map(str, extra), "--fmu-dir", str(fmu_dir)])
        out, err = capsys.readouterr()
        assert code == 2, out + err  # export-fmu repacked it with exit 0
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert lines[0].startswith(
            f"scene error: component 'actuator': FMU file {fmu} is not a valid FMU: {cause}"
        ), lines[0]
    with pytest.raises(FmuError, match=re.escape(cause)):  # was a bare Exception from fmpy
        mechfmu.simulate(scene, fmu_dir=fmu_dir)
    assert list(temporary.iterdir()) == [] and not (tmp_path / "packed.fmu").exists()


def _forged_size(path, name, size):
    """Rewrite the central directory's uncompressed size of member ``name`` to ``size``."""
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as archive:
        offset = archive.start_dir
    while data[offset : offset + 4] == b"PK\x01\x02":
        name_length, extra_length, comment_length = struct.unpack_from("<HHH", data, offset + 28)
        if data[offset + 46 : offset + 46 + name_length].decode() == name:
            struct.pack_into("<I", data, offset + 24, size)
        offset += 46 + name_length + extra_length + comment_length
    path.write_bytes(bytes(data))
    return path


def test_declared_sizes_and_ratios_are_refused_without_reading_the_member(
    fmu_dir, tmp_path, temporary
):
    forged = _forged_size(
        shutil.copyfile(fmu_dir / "PistonActuator.fmu", tmp_path / "Forged.fmu"), LIBRARY, 2**31
    )
    with pytest.raises(FmuError, match=f"member '{LIBRARY}' unpacks to 2147483648 bytes, more "):
        checked_description(str(forged))
    # a 64 MiB library of zeros packed into 64 KiB: before, read whole into memory (the
    # issue's 2 GB entry took 4.3 GB) before the ELF check refused it
    library = (fmu_dir / "PistonActuator.fmu").open("rb")
    with zipfile.ZipFile(library) as source:
        elf = source.read(LIBRARY)
    bomb = rewritten(
        fmu_dir,
        tmp_path / "Bomb.fmu",
        lambda name, data: elf + bytes(64 << 20) if name == LIBRARY else data,
    )
    tracemalloc.start()
    try:
        with pytest.raises(FmuError, match=f"member '{LIBRARY}' unpacks to 67.* a compression"):
            checked_description(str(bomb))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 << 20, peak
    assert list(temporary.iterdir()) == []


def test_a_large_library_is_checked_by_streaming_its_headers(fmu_dir, tmp_path):
    """16 MiB that do not compress after a good library: checked (and its checksum tested)
    in bounded memory, and the ELF check reads only its headers."""
    with zipfile.ZipFile(fmu_dir / "PistonActuator.fmu") as source:
        elf = source.read(LIBRARY)
    padded = elf + os.urandom(16 << 20)
    large = rewritten(
        fmu_dir, tmp_path / "Large.fmu", lambda name, data: padded if name == LIBRARY else data
    )
    tracemalloc.start()
    try:
        description = checked_description(str(large))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert description.modelName == "PistonActuator" and peak < 6 << 20, peak

    class Counting(io.BytesIO):
        read_bytes = 0

        def read(self, size=-1):
            data = super().read(size)
            Counting.read_bytes += len(data)
            return data

    assert elf_problem(Counting(padded), len(padded)) is None
    assert Counting.read_bytes < 4096, Counting.read_bytes  # the ELF and program headers
    assert "is truncated: its section headers end at byte" in elf_problem(
        Counting(elf), len(elf) // 2
    )


def test_a_full_temporary_directory_is_one_line_and_leaves_nothing(
    fmu_dir, tmp_path, temporary, capsys, monkeypatch
):
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE.format(fmu=(fmu_dir / "PistonActuator.fmu").as_posix()))
    usage = shutil.disk_usage(temporary)
    monkeypatch.setattr(fmu_file.shutil, "disk_usage", lambda path: usage._replace(free=10_000_000))
    with pytest.raises(FmuError, match=r"it needs \d+ bytes and 67108864 more kept free, the "):
        mechfmu.simulate(scene, fmu_dir=fmu_dir)
    monkeypatch.undo()
    monkeypatch.setattr(tempfile, "tempdir", str(temporary))
    copies = []

    def full(source, target, length=0):
        copies.append(target)
        if len(copies) > 10:  # the disk fills in the middle of the unpacking
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        shutil.copyfileobj(source, target, length)

    monkeypatch.setattr(fmu_file.shutil, "copyfileobj", full)
    code = cli(["run", str(scene), "--out", str(tmp_path / "out"), "--fmu-dir", str(fmu_dir)])
    out, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1, out + err  # was an OSError traceback
    assert f"FMU file {fmu_dir / 'PistonActuator.fmu'} cannot be unpacked into {temporary}/" in err
    assert err.strip().endswith(": No space left on device"), err
    assert list(temporary.iterdir()) == []  # was a half-unpacked folder


def _dead_pid():
    child = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    )
    return int(child.stdout)


def test_unpack_folders_of_killed_runs_are_removed_by_the_next_run(
    fmu_dir, tmp_path, temporary, monkeypatch
):
    dead = _dead_pid()
    other_host = "0" * 8 if HOST_TAG != "0" * 8 else "1" * 8
    folders = {
        "stale": f"{UNPACK_PREFIX}{dead}_{HOST_TAG}_abc",
        "alive": f"{UNPACK_PREFIX}{os.getpid()}_{HOST_TAG}_abc",
        "no marker": f"{UNPACK_PREFIX}{dead}_{HOST_TAG}_def",
        "other machine": f"{UNPACK_PREFIX}{dead}_{other_host}_abc",
        "not ours": "mechfmu_x8f3k2",
    }
    for key, name in folders.items():
        (temporary / name / "resources").mkdir(parents=True)
        if key != "no marker":
            (temporary / name / UNPACK_MARKER).write_text("")
    monkeypatch.setattr(fmu_file, "_cleaned", False)
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE.format(fmu=(fmu_dir / "PistonActuator.fmu").as_posix()))
    mechfmu.simulate(scene, fmu_dir=fmu_dir)
    left = sorted(path.name for path in temporary.iterdir())
    assert left == sorted(name for key, name in folders.items() if key != "stale")


def test_a_run_killed_while_its_fmus_are_unpacked_leaves_nothing_after_the_next(
    fmu_dir, tmp_path, temporary
):
    """SIGKILL (no handler can run) once the FMU is unpacked: its folder stays, and the
    next run removes it (before, 20 kills left 11 MB)."""
    slow = tmp_path / "slow.toml"
    slow.write_text(
        SCENE.format(fmu=(fmu_dir / "PistonActuator.fmu").as_posix())
        .replace("stop_time = 0.1", "stop_time = 3.0")
        .replace("step = 0.01", "step = 0.00001")
    )
    process = subprocess.Popen(
        [sys.executable, "-m", "mechfmu", "run", str(slow), "--out", str(tmp_path / "out")],
        env=dict(os.environ, TMPDIR=str(temporary)),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 60
    while not list(temporary.glob(f"{UNPACK_PREFIX}*/resources")):
        assert time.monotonic() < deadline and process.poll() is None
        time.sleep(0.02)
    time.sleep(0.2)
    process.kill()
    process.wait()
    assert len(list(temporary.glob(f"{UNPACK_PREFIX}*"))) == 1
    done = run(tmp_path, fmu_dir / "PistonActuator.fmu", fmu_dir, TMPDIR=str(temporary))
    assert done.returncode == 0, done.stderr
    assert list(temporary.iterdir()) == []


PYTHONFMU = {
    "no slavemodule.txt": (
        lambda name, data: None if name == "resources/slavemodule.txt" else data,
        "it is a PythonFMU FMU without resources/slavemodule.txt",
    ),
    "slavemodule.txt cut short": (
        lambda name, data: data[:14] if name == "resources/slavemodule.txt" else data,
        "its resources/slavemodule.txt names the module mechfmu_entry_, which is not in its "
        "resources",
    ),
    "no entry module": (
        lambda name, data: None if name == "resources/mechfmu_entry_PistonActuator.py" else data,
        "its resources/slavemodule.txt names the module mechfmu_entry_PistonActuator, which "
        "is not in its resources",
    ),
    "entry module that does not compile": (
        lambda name, data: (
            data.replace(b"ctypes.pythonapi", b"ctypes.pytho\xc4\x32napi")
            if name == "resources/mechfmu_entry_PistonActuator.py"
            else data
        ),
        "its entry module resources/mechfmu_entry_PistonActuator.py does not compile: "
        "(unicode error) 'utf-8' codec can't decode byte 0xc4",
    ),
    "slavemodule.txt not a module name": (
        lambda name, data: b"a b\n../x" if name == "resources/slavemodule.txt" else data,
        "its resources/slavemodule.txt names no Python module: 'a b\\n../x'",
    ),
}


@pytest.mark.parametrize("case", list(PYTHONFMU))
def test_a_pythonfmu_fmu_without_its_module_is_refused_before_loading(fmu_dir, tmp_path, case):
    """Found by the fuzz harness: pythonfmu's library crashes its host (SIGSEGV in
    fmi2Instantiate) when the module slavemodule.txt names cannot be found; a module that
    fails to import is reported in the FMU's log instead (the broken Python file above)."""
    change, cause = PYTHONFMU[case]
    fmu = rewritten(fmu_dir, tmp_path / "Broken.fmu", change)
    with pytest.raises(FmuError, match=re.escape(f"{fmu} is not a valid FMU: {cause}")):
        checked_description(str(fmu))


def test_an_entry_module_that_does_not_compile_no_longer_aborts_the_host_later(fmu_dir, tmp_path):
    """Found by atheris: pythonfmu's loader released a reference it never took when the entry
    module did not compile, and the host aborted at its next run of a good FMU (SIGABRT,
    "PyThreadState_Get: ... the GIL is released"). Now refused before loading."""
    broken = rewritten(
        fmu_dir, tmp_path / "Broken.fmu", PYTHONFMU["entry module that does not compile"][0]
    )
    for name, fmu in (("broken", broken), ("good", fmu_dir / "PistonActuator.fmu")):
        (tmp_path / f"{name}.toml").write_text(SCENE.format(fmu=fmu.as_posix()))
    script = (
        "import mechfmu, sys\n"
        "from mechfmu.cosim.master import SimulationError\n"
        "for _ in range(2):\n"
        "    try:\n"
        f"        mechfmu.simulate({str(tmp_path / 'broken.toml')!r}, fmu_dir={str(fmu_dir)!r})\n"
        "    except (mechfmu.cosim.scene.SceneError, SimulationError) as error:\n"
        "        print(type(error).__name__)\n"
        f"    mechfmu.simulate({str(tmp_path / 'good.toml')!r}, fmu_dir={str(fmu_dir)!r})\n"
        "print('done')\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["FmuError", "FmuError", "done"]
