"""A host that is not Python (issue 7): a small C program loads and runs every FMU.

tests/c_host/host.c dlopens an extracted FMU's binaries/linux64/<id>.so with RTLD_LOCAL in a
process without Python and without LD_PRELOAD, in an environment that holds only PATH and
HOME: the FMU's C loader (src/mechfmu/packaging/c_loader/loader.c) has to find libpython and start the
interpreter itself (the host checks that the Python C API is not in the process before). Its outputs are compared with the same FMU run in this Python process
through fmpy, with the same inputs and steps: the same Python code runs, so they must agree
to 1e-12 relative (measured: bit-identical). The landing gear is also checked against the
numpy closed form.
"""

import math
import os
import re
import shlex
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from fmu_driver import Driven
from mechfmu.packaging import build
from mechfmu.packaging.binary_patch import ENDBR64, RET, SYMBOL, find_symbol_offset
from mechfmu.runtime.models import MODELS
from mechfmu.references.landing_gear import gear_from_piston

HOST_SOURCE = Path(__file__).resolve().parent / "c_host" / "host.c"
TWO_PI = 2.0 * math.pi
VALVE_LIFT, VALVE_OMEGA = 0.004, 2.0 * math.pi * 40.0  # rocker lift c (1 - cos w t)

# model -> (steps, step size, {input: (a, b, c, d, w)}): input = a + b t + c sin(w t) + d cos(w t).
# Inputs not named keep their declared start values, and so do all parameters.
CASES = {
    "LandingGear": (250, 0.01, {"piston_extension": (0.381, 0.0762),
                                "piston_speed": (0.0762,)}),
    "HydraulicActuator": (200, 0.01, {"valve_command": (1.0,),
                                      "piston_extension": (0.381, 0.05),
                                      "piston_speed": (0.05,)}),
    "PistonActuator": (300, 0.01, {}),
    "Suspension": (400, 0.01, {"load": (0.0, 1000.0)}),  # through the snap-through (3091 N)
    "LoadProfile": (200, 0.01, {}),
    "RoadProfile": (200, 0.01, {}),
    "CrankDrive": (200, 0.005, {}),
    "FourBar": (200, 0.005, {"crank_angle": (math.pi / 6, TWO_PI), "crank_speed": (TWO_PI,)}),
    "SliderCrank": (200, 1e-4, {"crank_angle": (0.0, 100 * math.pi),
                                "crank_speed": (100 * math.pi,)}),
    "CamshaftDrive": (200, 1e-4, {}),
    "ValveTrain": (400, 1e-4, {"camshaft_angle": (0.0, 50 * math.pi),
                               "camshaft_speed": (50 * math.pi,)}),
    "ValveSpring": (300, 1e-4, {
        "rocker_lift": (VALVE_LIFT, 0.0, 0.0, -VALVE_LIFT, VALVE_OMEGA),
        "rocker_velocity": (0.0, 0.0, VALVE_LIFT * VALVE_OMEGA, 0.0, VALVE_OMEGA),
        "rocker_acceleration": (0.0, 0.0, 0.0, VALVE_LIFT * VALVE_OMEGA ** 2, VALVE_OMEGA)}),
}
TYPE_LETTER = {"Real": "r", "Integer": "i", "Boolean": "b"}


def _coefficients(spec):
    a, b, c, d, w = (tuple(spec) + (0.0,) * 5)[:5]
    return a, b, c, d, w


def _input_value(spec, t):
    """Python's twin of host.c's input_value: the same operations in the same order."""
    a, b, c, d, w = _coefficients(spec)
    return a + b * t + c * math.sin(w * t) + d * math.cos(w * t)


def _clean_environment():
    """Only PATH and HOME: no LD_PRELOAD, no LD_LIBRARY_PATH, no PYTHON* variables. PATH is
    the system's: its python3, if any, need not be the Python the FMUs were built with (here
    it is Debian's 3.11.2, the FMUs are built with pyenv's 3.11.7), so the loader has to point
    the interpreter at the standard library of the libpython it loaded."""
    return {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/")}


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    compiler = shlex.split(os.environ.get("CC") or "cc")
    assert shutil.which(compiler[0]), f"no C compiler {compiler[0]!r} for the C host"
    target = tmp_path_factory.mktemp("c_host") / "host"
    done = subprocess.run([*compiler, "-O2", "-Wall", "-Wextra", "-ffp-contract=off",
                           f"-I{build.fmi_headers()}", str(HOST_SOURCE), "-o", str(target),
                           "-ldl", "-lm"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    return target


def _extract(fmu, folder):
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    return folder


def _run_host(host, folder, description, steps, step, inputs, outputs, **env):
    """Run the C host; return (completed process, rows of floats)."""
    variables = {v.name: v for v in description.modelVariables}
    command = [str(host), str(folder), description.coSimulation.modelIdentifier,
               description.guid, str(steps), repr(step)]
    for name, spec in inputs.items():
        command += ["-i", f"{variables[name].valueReference}="
                          + ",".join(repr(float(x)) for x in _coefficients(spec))]
    for variable in outputs:
        command += ["-o", f"{TYPE_LETTER[variable.type]}:{variable.valueReference}"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=60,
                          env={**_clean_environment(), **env})
    rows = [[float(x) for x in line.split(",")] for line in done.stdout.splitlines()]
    return done, rows


def _run_fmpy(fmu, steps, step, inputs, outputs):
    """The same run in this process through fmpy (tests/fmu_driver.py)."""
    driven = Driven(fmu, inputs={name: _input_value(spec, 0.0) for name, spec in inputs.items()})
    try:
        rows = [[driven.time] + [float(driven.get(v.name)) for v in outputs]]
        for _ in range(steps):
            t = driven.time
            result = driven.step(step, **{name: _input_value(spec, t)
                                          for name, spec in inputs.items()})
            assert result is True, result
            rows.append([driven.time] + [float(driven.get(v.name)) for v in outputs])
    finally:
        driven.close()
    return rows


def _largest_relative_difference(rows, expected):
    worst = 0.0
    for row, other in zip(rows, expected):
        for x, y in zip(row, other):
            if x != y:
                worst = max(worst, abs(x - y) / max(abs(x), abs(y)))
    return worst


def test_cases_cover_every_model():
    assert set(CASES) == set(MODELS)


@pytest.mark.parametrize("model", list(MODELS))
def test_c_host_runs_the_fmu_like_fmpy(host, fmu_dir, tmp_path, model):
    fmu = fmu_dir / f"{model}.fmu"
    folder = _extract(fmu, tmp_path / model)
    binaries = folder / "binaries" / "linux64"
    # the FMU's binary is the loader; pythonfmu's library, which needs the Python C API from
    # the host, is next to it
    assert b"_Py_NoneStruct" not in (binaries / f"{model}.so").read_bytes()
    inner = (binaries / build.pythonfmu_library_name(model)).read_bytes()
    assert b"_Py_NoneStruct" in inner
    offset = find_symbol_offset(inner, SYMBOL)  # and carries binary_patch's exit fix
    assert inner[offset:offset + 5] == ENDBR64 + bytes([RET])

    description = read_model_description(str(fmu))
    outputs = [v for v in description.modelVariables if v.causality == "output"]
    steps, step, inputs = CASES[model]
    done, rows = _run_host(host, folder, description, steps, step, inputs, outputs)
    assert done.returncode == 0, done.stderr[-3000:]
    assert len(rows) == steps + 1 and all(len(row) == len(outputs) + 1 for row in rows)

    expected = _run_fmpy(fmu, steps, step, inputs, outputs)
    assert [row[0] for row in rows] == [row[0] for row in expected]  # the same times
    assert _largest_relative_difference(rows, expected) <= 1e-12
    assert rows == expected  # measured: bit-identical (same interpreter, same code)
    # a run that moves: some output changes over the run
    assert any(len({row[i] for row in rows}) > 1 for i in range(1, len(outputs) + 1))


def test_c_host_landing_gear_matches_the_numpy_closed_form(host, fmu_dir, tmp_path):
    fmu = fmu_dir / "LandingGear.fmu"
    folder = _extract(fmu, tmp_path / "gear")
    description = read_model_description(str(fmu))
    variables = {v.name: v for v in description.modelVariables}
    outputs = [variables["gear_angle"], variables["gear_angular_velocity"],
               variables["gear_angular_acceleration"]]
    steps, step, inputs = CASES["LandingGear"]
    done, rows = _run_host(host, folder, description, steps, step, inputs, outputs)
    assert done.returncode == 0, done.stderr[-3000:]
    times = np.array([row[0] for row in rows])
    # a row after a step holds the outputs for the inputs set at the step's start
    input_times = np.concatenate([[0.0], times[:-1]])
    x = np.array([_input_value(inputs["piston_extension"], t) for t in input_times])
    xdot = np.full_like(x, _input_value(inputs["piston_speed"], 0.0))
    theta, omega, alpha = gear_from_piston(x, xdot, 0.0 * x,
                                           float(variables["attachment_distance"].start),
                                           float(variables["pivot_height"].start))
    got = np.array([row[1:] for row in rows])
    assert theta[-1] - theta[0] > 1.0  # the gear turns through most of its 90 degrees
    # measured: 2.2e-16, 7.4e-16 relative and 7.2e-16 rad/s^2 (of up to 0.43) absolute
    np.testing.assert_allclose(got[:, 0], theta, rtol=1e-14, atol=0)
    np.testing.assert_allclose(got[:, 1], omega, rtol=1e-14, atol=0)
    np.testing.assert_allclose(got[:, 2], alpha, rtol=1e-12, atol=1e-14)


def test_loader_reports_a_missing_pythonfmu_library_through_the_logger(host, fmu_dir, tmp_path):
    fmu = fmu_dir / "CrankDrive.fmu"
    folder = _extract(fmu, tmp_path / "crank")
    (folder / "binaries" / "linux64" / build.pythonfmu_library_name("CrankDrive")).unlink()
    done, rows = _run_host(host, folder, read_model_description(str(fmu)), 3, 0.01, {}, [])
    assert done.returncode == 2 and rows == []  # fmi2Instantiate returned NULL: no crash
    assert "status 4" in done.stderr  # fmi2Fatal, through the host's logger
    assert "cannot load pythonfmu's library" in done.stderr
    assert "CrankDrive.pythonfmu.so" in done.stderr
    assert "fmi2Instantiate returned NULL" in done.stderr


def test_loader_names_the_libpython_candidates_it_tried(host, fmu_dir, tmp_path):
    """A loader built for a Python that this machine lacks: a fatal log message, no crash."""
    fmu = fmu_dir / "CrankDrive.fmu"
    folder = _extract(fmu, tmp_path / "crank")
    loader, message = build.compile_loader(
        tmp_path / "loader", runtime=("libpython3.99.so.1.0", "/nonexistent/lib", "3.99"))
    assert loader is not None, message
    shutil.copyfile(loader, folder / "binaries" / "linux64" / "CrankDrive.so")
    done, rows = _run_host(host, folder, read_model_description(str(fmu)), 3, 0.01, {}, [],
                           MECHFMU_LIBPYTHON="/nowhere/libpython-explicit.so")
    assert done.returncode == 2 and rows == []
    assert "status 4" in done.stderr and "no Python 3.99 runtime found" in done.stderr
    for candidate in ("/nowhere/libpython-explicit.so", "/nonexistent/lib/libpython3.99.so.1.0",
                      " libpython3.99.so.1.0 (", " libpython3.99.so ("):
        assert candidate in done.stderr, candidate
    assert "cannot open shared object file" in done.stderr  # dlerror()'s own words


def test_build_without_a_c_compiler_keeps_the_plain_pythonfmu_binary(tmp_path, monkeypatch,
                                                                     capsys):
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
    folder = _extract(fmu, tmp_path / "null")
    assert (folder / "binaries" / "linux64" / "CrankDriveNull.pythonfmu.so").is_file()
    description = read_model_description(str(fmu))
    outputs = [v for v in description.modelVariables if v.causality == "output"]
    done, rows = _run_host(host, folder, description, 20, 0.01, {}, outputs)
    assert done.returncode == 0, done.stderr[-3000:]
    assert len(rows) == 21
    assert all(row[1:] == rows[0][1:] for row in rows)  # a null step changes nothing
    assert rows == _run_fmpy(fmu, 20, 0.01, {}, outputs)


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
