"""A host that is not Python (issues 7 and 20): a small C program loads and runs every FMU.

tests/c_host/host.c dlopens an extracted FMU's binaries/linux64/<id>.so with RTLD_LOCAL in a
process without Python and without LD_PRELOAD, in an environment that holds only PATH and
HOME: the FMU's C loader (src/mechfmu/packaging/c_loader/) has to find a libpython and start
the interpreter itself (the host checks that the Python C API is not in the process before).
Its outputs are compared with the same FMU run in this Python process through fmpy, with the
same inputs and steps: the same Python code runs, so they must agree to 1e-12 relative
(measured: bit-identical). The landing gear is also checked against the numpy closed form.

Any CPython 3.10+: with the build's Python hidden (c_hosts.hiding: unshare -m and bind
mounts), the loader takes each of pyenv's 3.10, 3.12 and 3.13 in turn, newest first, and
the FMUs give the same numbers; a free-threaded or too old library is refused by name.
"""

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from fmu_driver import Driven
from c_hosts import (
    CASES,
    PYENV_VERSIONS,
    compile_host,
    extract,
    fmpy_rows,
    hiding,
    host_command,
    input_value,
    largest_relative_difference,
    run_fmpy,
    run_host,
    run_model,
)
from mechfmu.packaging import build
from mechfmu.packaging.binary_patch import ENDBR64, RET, SYMBOL, find_symbol_offset
from mechfmu.runtime.models import MODELS
from mechfmu.references.landing_gear import gear_from_piston

BUILD_VERSION = f"{sys.version_info.major}.{sys.version_info.minor}"
# the CPythons of pyenv's versions folder besides the build's (3.10 to 3.13 on our machines)
OTHER_MINORS = [minor for minor in (10, 11, 12, 13) if minor != sys.version_info.minor]


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    return compile_host("host.c", tmp_path_factory.mktemp("c_host") / "host")


def _pyenv_version(minor):
    """pyenv's folder of CPython 3.<minor> (the newest patch release there)."""
    found = sorted(
        (p for p in PYENV_VERSIONS.glob(f"3.{minor}.*") if p.name[len(f"3.{minor}.") :].isdigit()),
        key=lambda p: int(p.name.rsplit(".", 1)[1]),
    )
    assert found, f"no CPython 3.{minor} under {PYENV_VERSIONS} (pyenv install 3.{minor})"
    return found[-1]


def test_cases_cover_every_model():
    assert set(CASES) == set(MODELS)


@pytest.mark.parametrize("model", list(MODELS))
def test_c_host_runs_the_fmu_like_fmpy(host, fmu_dir, tmp_path, model):
    fmu = fmu_dir / f"{model}.fmu"
    done, rows, loaded = run_model(host, fmu, tmp_path / model)
    binaries = tmp_path / model / "binaries" / "linux64"
    # the FMU's binary is the loader; pythonfmu's library, which needs the Python C API from
    # the host, is next to it
    assert b"_Py_NoneStruct" not in (binaries / f"{model}.so").read_bytes()
    inner = (binaries / build.pythonfmu_library_name(model)).read_bytes()
    assert b"_Py_NoneStruct" in inner
    offset = find_symbol_offset(inner, SYMBOL)  # and carries binary_patch's exit fix
    assert inner[offset : offset + 5] == ENDBR64 + bytes([RET])

    assert done.returncode == 0, done.stderr[-3000:]
    assert loaded == [str(Path(sys.base_prefix) / "lib" / f"libpython{BUILD_VERSION}.so.1.0")]
    expected = fmpy_rows(str(fmu))
    assert len(rows) == CASES[model][0] + 1 and all(len(row) == len(expected[0]) for row in rows)
    assert [row[0] for row in rows] == [row[0] for row in expected]  # the same times
    assert largest_relative_difference(rows, expected) <= 1e-12
    assert rows == expected  # measured: bit-identical (same interpreter, same code)
    # a run that moves: some output changes over the run
    assert any(len({row[i] for row in rows}) > 1 for i in range(1, len(expected[0])))


def test_c_host_landing_gear_matches_the_numpy_closed_form(host, fmu_dir, tmp_path):
    fmu = fmu_dir / "LandingGear.fmu"
    description = read_model_description(str(fmu))
    variables = {v.name: v for v in description.modelVariables}
    outputs = [
        variables["gear_angle"],
        variables["gear_angular_velocity"],
        variables["gear_angular_acceleration"],
    ]
    steps, step, inputs = CASES["LandingGear"]
    command = host_command(
        description, host, extract(fmu, tmp_path / "gear"), steps, step, inputs, outputs
    )
    done, rows, _ = run_host(command)
    assert done.returncode == 0, done.stderr[-3000:]
    times = np.array([row[0] for row in rows])
    # a row after a step holds the outputs for the inputs set at the step's start
    input_times = np.concatenate([[0.0], times[:-1]])
    x = np.array([input_value(inputs["piston_extension"], t) for t in input_times])
    xdot = np.full_like(x, input_value(inputs["piston_speed"], 0.0))
    theta, omega, alpha = gear_from_piston(
        x,
        xdot,
        0.0 * x,
        float(variables["attachment_distance"].start),
        float(variables["pivot_height"].start),
    )
    got = np.array([row[1:] for row in rows])
    assert theta[-1] - theta[0] > 1.0  # the gear turns through most of its 90 degrees
    # measured: 2.2e-16, 7.4e-16 relative and 7.2e-16 rad/s^2 (of up to 0.43) absolute
    np.testing.assert_allclose(got[:, 0], theta, rtol=1e-14, atol=0)
    np.testing.assert_allclose(got[:, 1], omega, rtol=1e-14, atol=0)
    np.testing.assert_allclose(got[:, 2], alpha, rtol=1e-12, atol=1e-14)


def test_loader_reports_a_missing_pythonfmu_library_through_the_logger(host, fmu_dir, tmp_path):
    fmu = fmu_dir / "CrankDrive.fmu"
    folder = extract(fmu, tmp_path / "crank")
    (folder / "binaries" / "linux64" / build.pythonfmu_library_name("CrankDrive")).unlink()
    command = host_command(read_model_description(str(fmu)), host, folder, 3, 0.01, {}, [])
    done, rows, _ = run_host(command)
    assert done.returncode == 2 and rows == []  # fmi2Instantiate returned NULL: no crash
    assert "status 4" in done.stderr  # fmi2Fatal, through the host's logger
    assert "cannot load pythonfmu's library" in done.stderr
    assert "CrankDrive.pythonfmu.so" in done.stderr
    assert "fmi2Instantiate returned NULL" in done.stderr


# --- any CPython 3.10+ (issue 20) -----------------------------------------------------------


@pytest.mark.parametrize("minor", OTHER_MINORS)
def test_fmus_run_with_each_cpython_when_the_build_python_is_hidden(host, fmu_dir, tmp_path, minor):
    """Only pyenv's 3.<minor> left (the build's and the system's hidden): every model runs
    on it and gives fmpy's numbers (under the build Python) to 1e-12 (measured: identical)."""
    keep = _pyenv_version(minor)
    empty = tmp_path / "empty"
    empty.mkdir()
    hide = hiding(empty, keep_pyenv=(keep.name,))
    for model in MODELS:
        done, rows, loaded = run_model(host, fmu_dir / f"{model}.fmu", tmp_path / model, hide)
        assert done.returncode == 0, (model, done.stderr[-3000:])
        assert loaded == [str(keep / "lib" / f"libpython3.{minor}.so.1.0")], model
        expected = fmpy_rows(str(fmu_dir / f"{model}.fmu"))
        assert len(rows) == len(expected), model
        assert largest_relative_difference(rows, expected) <= 1e-12, model


def test_loader_takes_the_newest_python_after_the_build_s_own(host, fmu_dir, tmp_path):
    """The build's version hidden, every other pyenv version left: the newest 3.x wins."""
    empty = tmp_path / "empty"
    empty.mkdir()
    others = sorted(
        (
            p
            for p in PYENV_VERSIONS.iterdir()
            if p.name.startswith("3.")
            and not p.name.startswith(f"{BUILD_VERSION}.")
            and p.name.split(".")[1].isdigit()
            and int(p.name.split(".")[1]) >= 10
        ),
        key=lambda p: tuple(int(x) for x in p.name.split(".")[:2]),
    )
    assert len(others) >= 2, others
    hide = hiding(empty, keep_pyenv=tuple(p.name for p in others))
    done, rows, loaded = run_model(host, fmu_dir / "CrankDrive.fmu", tmp_path / "crank", hide)
    assert done.returncode == 0, done.stderr[-3000:]
    newest = others[-1]
    assert loaded == [
        str(newest / "lib" / f"libpython{'.'.join(newest.name.split('.')[:2])}.so.1.0")
    ]


def test_mechfmu_libpython_overrides_the_search(host, fmu_dir, tmp_path):
    """MECHFMU_LIBPYTHON names the oldest other version while the build's is there: it is
    taken."""
    minor = OTHER_MINORS[0]
    library = _pyenv_version(minor) / "lib" / f"libpython3.{minor}.so.1.0"
    done, rows, loaded = run_model(
        host, fmu_dir / "FourBar.fmu", tmp_path / "four_bar", MECHFMU_LIBPYTHON=str(library)
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert loaded == [str(library)]
    assert largest_relative_difference(rows, fmpy_rows(str(fmu_dir / "FourBar.fmu"))) <= 1e-12


def _fake_libpython(folder, name, version):
    """A shared library that answers Py_GetVersion() with ``version`` (CPython's own words,
    Python/getversion.c) and is no Python at all: the loader must refuse it before use."""
    source = folder / f"{name}.c"
    source.write_text(
        'const char *Py_GetVersion(void) { return "%s"; }\n'
        "int Py_IsInitialized(void) { return 0; }\n" % version
    )
    target = folder / name
    subprocess.run(["cc", "-shared", "-fPIC", str(source), "-o", str(target)], check=True)
    return target


def test_loader_refuses_free_threaded_and_old_pythons_and_names_every_path(host, fmu_dir, tmp_path):
    """Every Python hidden; a free-threaded 3.13t found on LD_LIBRARY_PATH and a 3.9 named by
    MECHFMU_LIBPYTHON: both refused with the reason, every path tried named through the FMI
    logger (status fmi2Fatal), no crash."""
    empty, fakes = tmp_path / "empty", tmp_path / "fakes"
    empty.mkdir()
    fakes.mkdir()
    free_threaded = _fake_libpython(
        fakes,
        "libpython3.13t.so.1.0",
        "3.13.0 experimental free-threading build (main, Oct  7 2024) [GCC 12.2.0]",
    )
    old = _fake_libpython(fakes, "libpython3.9.so.1.0", "3.9.18 (main, May  9 2026) [GCC]")
    done, rows, loaded = run_model(
        host,
        fmu_dir / "CrankDrive.fmu",
        tmp_path / "crank",
        hiding(empty),
        MECHFMU_LIBPYTHON=str(old),
        LD_LIBRARY_PATH=str(fakes),
    )
    assert done.returncode == 2 and rows == [] and loaded == []
    message = done.stderr
    assert "status 4" in message and "fmi2Instantiate returned NULL" in message
    assert "no usable Python runtime found" in message
    assert f"{old}: refused, older than Python 3.10 (version 3.9.18" in message
    assert f"{free_threaded}: refused, a free-threaded build" in message
    # the folders looked in, each named: the FMU's own, the build's LIBDIR, LD_LIBRARY_PATH,
    # the system's, pyenv's (hidden: none left)
    for folder in (
        tmp_path / "crank" / "resources" / "python" / "lib",
        Path(sys.base_prefix) / "lib",
        fakes,
        "/usr/lib/x86_64-linux-gnu",
        "/usr/local/lib",
    ):
        assert f"\n  {folder}\n" in message, folder
    assert "x = %d, then 40 down to 10" % sys.version_info.minor in message
    assert "MECHFMU_LIBPYTHON" in message and "--embed-python" in message


def test_build_without_a_c_compiler_keeps_the_plain_pythonfmu_binary(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    (fmu,) = build.build_all(tmp_path / "out", ["CrankDrive"])
    printed = capsys.readouterr().out
    assert f"C loader not built: C compiler '{tmp_path / 'no-such-cc'}' not found" in printed
    assert "CrankDrive: no C loader" in printed and "plain binary" in printed
    with zipfile.ZipFile(fmu) as archive:
        names = archive.namelist()
        binary = archive.read("binaries/linux64/CrankDrive.so")
    assert "binaries/linux64/CrankDrive.pythonfmu.so" not in names
    assert b"_Py_NoneStruct" in binary  # pythonfmu's own library, exit fix applied
    assert "CrankDrive: finalizePythonInterpreter at" in printed
    driven = Driven(fmu)  # still runs in a Python host
    try:
        assert driven.step(0.01) is True
    finally:
        driven.close()


def test_null_variant_gets_the_loader_and_runs_in_the_c_host(host, tmp_path, capsys):
    (fmu,) = build.build_all(tmp_path / "out", ["CrankDrive"], null=True)
    printed = capsys.readouterr().out
    assert "C loader: compiled with" in printed and "compiler warnings" not in printed
    assert "CrankDriveNull: C loader as binaries/linux64/CrankDriveNull.so" in printed
    folder = extract(fmu, tmp_path / "null")
    assert (folder / "binaries" / "linux64" / "CrankDriveNull.pythonfmu.so").is_file()
    description = read_model_description(str(fmu))
    outputs = [v for v in description.modelVariables if v.causality == "output"]
    done, rows, _ = run_host(host_command(description, host, folder, 20, 0.01, {}, outputs))
    assert done.returncode == 0, done.stderr[-3000:]
    assert len(rows) == 21
    assert all(row[1:] == rows[0][1:] for row in rows)  # a null step changes nothing
    assert rows == run_fmpy(fmu, 20, 0.01, {}, outputs)


def test_loader_exports_every_fmi2_function(fmu_dir):
    """All 44 functions of fmi2Functions.h: the common and co-simulation ones forwarded, the
    model-exchange ones stubs (these FMUs are co-simulation only)."""
    header = (build.fmi_headers() / "fmi2Functions.h").read_text()
    names = sorted(set(re.findall(r"#define (fmi2\w+)\s+fmi2FullName\(", header)))
    assert len(names) == 44
    with zipfile.ZipFile(fmu_dir / "LandingGear.fmu") as archive:
        loader = archive.read("binaries/linux64/LandingGear.so")
    missing = [name for name in names if find_symbol_offset(loader, name.encode()) is None]
    assert missing == []
