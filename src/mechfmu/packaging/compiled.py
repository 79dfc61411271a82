"""The valve's exact core compiled to C inside the FMUs that carry it (host side, mypyc).

``mechfmu build`` compiles the exact core of ValveSpring (CORE, ``physics/valve_exact.py``)
and the runtime modules its step calls (CORE_GROUP: the drive, the cam law, the valve
train's closed forms, the polynomials, the linear ODE's closed forms, the root finder) with
mypyc, the compiler of mypy's own code: each module's Python source, its annotations
checked, becomes a C extension module beside that source, and the group shares one library
(``<hash>__mypyc``, at the top of the FMU's resources). Python's import system prefers the
extension, so nothing in the runtime changes; an interpreter that cannot load it (another
CPython version, another platform: the extensions are built for the build interpreter's
ABI) imports the sources instead, with the same results, more slowly.

The results are the sources' to the bit: the C is compiled with ``-ffp-contract=off`` (no
fused multiply-add, which would round once where Python rounds twice) and calls the same
libm; tests/test_compiled_core.py compares the two on drawn valves and on the valve scenes.
A compile that fails (no mypy or setuptools, no compiler, no Python headers, a type error)
leaves the FMU with its sources, and the build says why in one line.
"""

import os
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

# The exact core: an FMU whose runtime carries CORE gets it compiled with the modules its step
# calls, as one group (their calls among themselves are then C calls), paths relative to the
# runtime package.
CORE = "physics/valve_exact.py"
CORE_GROUP = (
    CORE,
    "physics/valve_spring.py",
    "physics/cam_laws.py",
    "physics/valve_train.py",
    "numerics/linear_ode.py",
    "numerics/polynomials.py",
    "numerics/roots.py",
    "numerics/stepping.py",
)
COMPILE_TIMEOUT = 300  # s for the group's compile (about 23 s here, mostly the C compiler's)
# no contraction into fused multiply-adds: the compiled arithmetic rounds where Python's does
COMPILE_FLAGS = "-ffp-contract=off"
MESSAGE_QUOTE = 300  # characters of the compiler's output a build message quotes


def module_name(package: str, relative: str) -> str:
    """The import name of the runtime module at ``relative`` (e.g. physics/valve_exact.py)
    inside the runtime package named ``package``."""
    return ".".join((package, *Path(relative).with_suffix("").parts))


def core_extensions(carried: set[str], suffix: str) -> set[str]:
    """The extension files (paths relative to the runtime package, ``suffix`` the build
    interpreter's, e.g. ``.cpython-311-x86_64-linux-gnu.so``) that compile_core adds to a
    runtime carrying the modules ``carried``: none unless it carries CORE."""
    if CORE not in carried:
        return set()
    return {relative[: -len(".py")] + suffix for relative in CORE_GROUP if relative in carried}


# Run in a child process whose working folder holds the runtime package: mypyc names each
# module from its path there (<package>.physics.valve_exact) and writes the group's library
# there. setuptools is imported before mypyc.build, which then builds with it.
_DRIVER = """
import sys
from setuptools import setup
from mypyc.build import mypycify

work, sources = sys.argv[1], sys.argv[2:]
setup(
    name="mechfmu_compiled_core",
    script_args=["build_ext", "--inplace", "--quiet",
                 "--build-temp", work + "/temp", "--build-lib", work + "/lib"],
    ext_modules=mypycify(
        [*sources, "--config-file", work + "/mypy.ini", "--cache-dir", work + "/cache"],
        opt_level="3", debug_level="0", target_dir=work + "/c",
    ),
)
"""
# the staged runtime imports pythonfmu (no type information) through its FMI binding
_MYPY_CONFIG = "[mypy]\nignore_missing_imports = True\n"

# the extensions' import check, in a child process (a broken extension must not load here):
# the file each module was imported from, one per line
_IMPORT_CHECK = (
    "import importlib, sys\n"
    "for name in sys.argv[1:]:\n"
    "    print(importlib.import_module(name).__file__)\n"
)


def _quote(text: str) -> str:
    """The last MESSAGE_QUOTE characters of a compiler's output, on one line."""
    return " ".join(text.split())[-MESSAGE_QUOTE:]


def _built(folder: Path, before: set[Path]) -> list[Path]:
    """The extension files under ``folder`` that are not in ``before``."""
    return sorted(set(folder.rglob("*.so")) - before)


@dataclass(frozen=True)
class Compiled:
    """What compile_core did: whether it compiled, its one-line message, and the files it
    left outside the runtime package that the FMU must carry (the group's library, at the
    top of its resources)."""

    done: bool
    message: str
    outside: tuple[Path, ...] = ()


def compile_core(package: Path, work: Path) -> Compiled | None:
    """Compile CORE_GROUP's modules of the staged runtime ``package`` (those it carries) to C
    extensions beside their sources, building in the folder ``work``; None when ``package``
    does not carry CORE.

    A failure removes every extension the compile left, so the FMU carries the sources
    alone; it never raises."""
    package, work = package.resolve(), work.resolve()  # the compiler runs in another folder
    if not (package / CORE).is_file():
        return None
    relatives = [relative for relative in CORE_GROUP if (package / relative).is_file()]
    modules = [module_name(package.name, relative) for relative in relatives]
    stage = package.parent
    before = set(stage.rglob("*.so"))
    work.mkdir(parents=True, exist_ok=True)
    (work / "mypy.ini").write_text(_MYPY_CONFIG)
    environment = dict(os.environ)
    environment["CFLAGS"] = f"{environment.get('CFLAGS', '')} {COMPILE_FLAGS}".strip()
    started = time.monotonic()
    sources = [str((package / relative).relative_to(stage)) for relative in relatives]
    command = [sys.executable, "-c", _DRIVER, str(work), *sources]
    problem = None
    try:
        done = subprocess.run(
            command,
            cwd=stage,
            env=environment,
            capture_output=True,
            text=True,
            timeout=COMPILE_TIMEOUT,
        )
        if done.returncode != 0:
            problem = f"mypyc exited with {done.returncode}: {_quote(done.stdout + done.stderr)}"
        else:
            check = subprocess.run(
                [sys.executable, "-c", _IMPORT_CHECK, *modules],
                cwd=stage,
                capture_output=True,
                text=True,
                timeout=COMPILE_TIMEOUT,
            )
            loaded = check.stdout.split()
            if check.returncode != 0 or not all(path.endswith(".so") for path in loaded):
                problem = f"the extensions do not load: {_quote(check.stderr or check.stdout)}"
    except subprocess.TimeoutExpired:
        problem = f"mypyc took over {COMPILE_TIMEOUT} s"
    except OSError as error:
        problem = f"{shlex.join(command[:2])}: {error}"
    built = _built(stage, before)
    if problem is not None:
        for path in built:
            path.unlink()
        return Compiled(
            False,
            f"exact core not compiled ({problem}): the FMU runs its Python sources",
        )
    outside = tuple(path for path in built if package not in path.parents)
    return Compiled(
        True,
        f"exact core compiled by mypyc ({COMPILE_FLAGS}) in "
        f"{time.monotonic() - started:.1f} s: {len(relatives)} modules of {package.name} "
        f"({', '.join(Path(relative).stem for relative in relatives)}), "
        f"their library {', '.join(path.name for path in outside) or 'inside'}",
        outside,
    )
