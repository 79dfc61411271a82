"""The plain C hosts of the suite (c_host/host.c: FMI 2.0, c_host/host3.c: FMI 3.0), how to
run them on an extracted FMU, with Pythons hidden, and the same run through fmpy.

Hiding: ``unshare -m`` gives the host a mount namespace of its own, where empty folders and
/dev/null are bind-mounted over the Python installations it must not find (pyenv's versions,
the system's libpython3.x and /usr/lib/python3.x, /usr/bin/python3*): the loader then finds
only what the test leaves, as on a machine without those Pythons. Needs root (CI runs as
root here).
"""

import functools
import glob
import math
import os
import shlex
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

from fmpy import read_model_description

from fmu_driver import Driven
from mechfmu.packaging import build

HOSTS = Path(__file__).resolve().parent / "c_host"
TWO_PI = 2.0 * math.pi
VALVE_LIFT, VALVE_OMEGA = 0.004, 2.0 * math.pi * 40.0  # rocker lift c (1 - cos w t)
TYPE_LETTER = {"Real": "r", "Float64": "r", "Integer": "i", "Int32": "i", "Boolean": "b"}
# The Python installations a test may hide: pyenv's (the build Python's parent folder when it
# is one of pyenv's) and the system's.
PYENV_VERSIONS = Path(sys.base_prefix).parent
SYSTEM_PYTHON_FILES = (
    "/usr/lib/x86_64-linux-gnu/libpython3*",
    "/usr/bin/python3*",
    "/usr/local/lib/libpython3*",
    "/usr/local/bin/python3*",
)
SYSTEM_PYTHON_FOLDERS = ("/usr/lib/python3*", "/usr/local/lib/python3*")

# model -> (steps, step size, {input: (a, b, c, d, w)}): input = a + b t + c sin(w t) + d cos(w t).
# Inputs not named keep their declared start values, and so do all parameters.
CASES = {
    "LandingGear": (250, 0.01, {"piston_extension": (0.381, 0.0762), "piston_speed": (0.0762,)}),
    "HydraulicActuator": (
        200,
        0.01,
        {"valve_command": (1.0,), "piston_extension": (0.381, 0.05), "piston_speed": (0.05,)},
    ),
    "PistonActuator": (300, 0.01, {}),
    "Suspension": (400, 0.01, {"load": (0.0, 1000.0)}),  # through the snap-through (3091 N)
    "LoadProfile": (200, 0.01, {}),
    "RoadProfile": (200, 0.01, {}),
    "CrankDrive": (200, 0.005, {}),
    "FourBar": (200, 0.005, {"crank_angle": (math.pi / 6, TWO_PI), "crank_speed": (TWO_PI,)}),
    "SliderCrank": (
        200,
        1e-4,
        {"crank_angle": (0.0, 100 * math.pi), "crank_speed": (100 * math.pi,)},
    ),
    "CamshaftDrive": (200, 1e-4, {}),
    "ValveTrain": (
        400,
        1e-4,
        {"camshaft_angle": (0.0, 50 * math.pi), "camshaft_speed": (50 * math.pi,)},
    ),
    "ValveSpring": (
        300,
        1e-4,
        {
            "rocker_lift": (VALVE_LIFT, 0.0, 0.0, -VALVE_LIFT, VALVE_OMEGA),
            "rocker_velocity": (0.0, 0.0, VALVE_LIFT * VALVE_OMEGA, 0.0, VALVE_OMEGA),
            "rocker_acceleration": (0.0, 0.0, 0.0, VALVE_LIFT * VALVE_OMEGA**2, VALVE_OMEGA),
        },
    ),
}


def compile_host(source, target):
    """Compile a C host (host.c or host3.c) with $CC or cc; return its path."""
    compiler = shlex.split(os.environ.get("CC") or "cc")
    assert shutil.which(compiler[0]), f"no C compiler {compiler[0]!r} for the C host"
    done = subprocess.run(
        [
            *compiler,
            "-O2",
            "-Wall",
            "-Wextra",
            "-ffp-contract=off",
            f"-I{build.fmi_headers()}",
            str(HOSTS / source),
            "-o",
            str(target),
            "-ldl",
            "-lm",
        ],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0 and done.stderr == "", done.stderr
    return target


def coefficients(spec):
    a, b, c, d, w = (tuple(spec) + (0.0,) * 5)[:5]
    return a, b, c, d, w


def input_value(spec, t):
    """Python's twin of the hosts' input_value: the same operations in the same order."""
    a, b, c, d, w = coefficients(spec)
    return a + b * t + c * math.sin(w * t) + d * math.cos(w * t)


def clean_environment():
    """Only PATH and HOME: no LD_PRELOAD, no LD_LIBRARY_PATH, no PYTHON* variables. PATH is
    the system's: its python3, if any, need not be the Python the FMUs were built with (here
    it is Debian's 3.11.2, the FMUs are built with pyenv's 3.11.7), so the loader has to point
    the interpreter at the standard library of the libpython it loaded."""
    return {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/")}


def extract(fmu, folder):
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    return Path(folder)


def hiding(empty, keep_pyenv=(), system=True):
    """The shell commands (for unshare -m) that hide every pyenv version but those whose
    folder name starts with one of ``keep_pyenv`` (e.g. "3.12."), and with ``system`` the
    system's Pythons; ``empty`` is an empty folder to mount over folders."""
    commands = []
    for folder in sorted(PYENV_VERSIONS.iterdir()):
        if folder.is_dir() and not any(folder.name.startswith(k) for k in keep_pyenv):
            commands.append(f"mount --bind {shlex.quote(str(empty))} {shlex.quote(str(folder))}")
    if system:
        for pattern in SYSTEM_PYTHON_FILES:
            commands += [
                f"mount --bind /dev/null {shlex.quote(path)}"
                for path in sorted(glob.glob(pattern))
                if os.path.isfile(path)
            ]
        for pattern in SYSTEM_PYTHON_FOLDERS:
            commands += [
                f"mount --bind {shlex.quote(str(empty))} {shlex.quote(path)}"
                for path in sorted(glob.glob(pattern))
                if os.path.isdir(path)
            ]
    return commands


def host_command(description, host, folder, steps, step, inputs, outputs):
    """argv of host.c (FMI 2.0) or host3.c (FMI 3.0) for one FMU."""
    variables = {v.name: v for v in description.modelVariables}
    specs = []
    for name, spec in inputs.items():
        specs += [
            "-i",
            f"{variables[name].valueReference}="
            + ",".join(repr(float(x)) for x in coefficients(spec)),
        ]
    for variable in outputs:
        specs += ["-o", f"{TYPE_LETTER[variable.type]}:{variable.valueReference}"]
    identifier = description.coSimulation.modelIdentifier
    if description.fmiVersion.startswith("3"):
        return [
            str(host),
            str(steps),
            repr(step),
            "-f",
            str(folder),
            identifier,
            description.guid,
            *specs,
        ]
    return [str(host), str(folder), identifier, description.guid, str(steps), repr(step), *specs]


def run_host(command, hide=(), timeout=120, labelled=False, **env):
    """Run a C host command, under ``unshare -m`` with the ``hide`` mounts when given; return
    (completed process, rows of floats, loaded libpythons). ``labelled``: host3's rows, whose
    first field (the FMU's index) is dropped."""
    if hide:
        script = "; ".join([*hide, 'exec "$@"'])
        command = ["unshare", "-m", "sh", "-c", script, "host", *command]
    done = subprocess.run(
        command, capture_output=True, text=True, timeout=timeout, env={**clean_environment(), **env}
    )
    rows = [
        [float(x) for x in line.split(",")[1 if labelled else 0 :]]
        for line in done.stdout.splitlines()
    ]
    loaded = [
        line.split("loaded ", 1)[1]
        for line in done.stderr.splitlines()
        if line.startswith(("host: loaded ", "host3: loaded "))
    ]
    return done, rows, loaded


def run_model(host, fmu, folder, hide=(), **env):
    """Run CASES[model] of ``fmu`` (extracted to ``folder``) in the C host; every output."""
    description = read_model_description(str(fmu))
    outputs = [v for v in description.modelVariables if v.causality == "output"]
    steps, step, inputs = CASES[description.modelName]
    command = host_command(description, host, extract(fmu, folder), steps, step, inputs, outputs)
    return run_host(command, hide, labelled=description.fmiVersion.startswith("3"), **env)


def run_fmpy(fmu, steps, step, inputs, outputs):
    """The same run in this process through fmpy (tests/fmu_driver.py)."""
    driven = Driven(fmu, inputs={name: input_value(spec, 0.0) for name, spec in inputs.items()})
    try:
        rows = [[driven.time] + [float(driven.get(v.name)) for v in outputs]]
        for _ in range(steps):
            t = driven.time
            result = driven.step(
                step, **{name: input_value(spec, t) for name, spec in inputs.items()}
            )
            assert result is True, result
            rows.append([driven.time] + [float(driven.get(v.name)) for v in outputs])
    finally:
        driven.close()
    return rows


@functools.lru_cache(maxsize=None)
def fmpy_rows(fmu):
    """CASES[model] of ``fmu`` (a path string) run through fmpy, every output; cached."""
    description = read_model_description(fmu)
    outputs = [v for v in description.modelVariables if v.causality == "output"]
    steps, step, inputs = CASES[description.modelName]
    return run_fmpy(fmu, steps, step, inputs, outputs)


def largest_relative_difference(rows, expected):
    worst = 0.0
    for row, other in zip(rows, expected):
        for x, y in zip(row, other):
            if x != y:
                worst = max(worst, abs(x - y) / max(abs(x), abs(y)))
    return worst
