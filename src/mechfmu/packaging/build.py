"""Build every model of the registry into an FMU with pythonfmu (host side).

Each FMU carries only the code that runs inside it: the standard-library package
``mechfmu.runtime`` (plus pythonfmu's own Python files, which its builder adds).

Its Linux binary is mechfmu's C loader (``c_loader/loader.c``, compiled here with the system C
compiler) when one is found: pythonfmu's library leaves the Python C API unresolved, so only a
host that already runs Python (fmpy) can load it; the loader finds and loads libpython first
and forwards every FMI call, so C and C++ hosts load the FMU too. pythonfmu's library (with
binary_patch's exit fix) then sits next to it as ``<Name>.pythonfmu.so``. Without a compiler
the FMU keeps pythonfmu's plain binary, and the build says so.
"""

import importlib
import importlib.util
import io
import os
import platform
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path

from pythonfmu import FmuBuilder

from .binary_patch import patch_exit_finaliser
from ..cosim.files import atomic_write
from ..runtime.models import MODELS

RUNTIME_ROOT = Path(__file__).resolve().parents[1] / "runtime"  # the FMU runtime; no numpy
LOADER_SOURCE = Path(__file__).resolve().parent / "c_loader" / "loader.c"
PYTHONFMU_SUFFIX = ".pythonfmu.so"  # pythonfmu's library, next to the loader <Name>.so
LOADER_FLAGS = ("-shared", "-fPIC", "-O2", "-Wall", "-Wextra", "-fvisibility=hidden")


def pythonfmu_library_name(name):
    """File name of pythonfmu's own library in binaries/linux64/ when the loader is installed."""
    return f"{name}{PYTHONFMU_SUFFIX}"


def fmi_headers():
    """fmpy's copy of the FMI 2.0 headers (fmi2Functions.h and its includes)."""
    spec = importlib.util.find_spec("fmpy")
    if spec is None or not spec.origin:
        return Path("fmpy-is-not-installed") / "c-code"
    return Path(spec.origin).resolve().parent / "c-code"


def python_runtime():
    """(soname, libdir, major.minor) of the libpython the FMUs are built for: this Python's."""
    version = sysconfig.get_config_var("py_version_short") or sysconfig.get_config_var("VERSION")
    soname = sysconfig.get_config_var("INSTSONAME") or ""
    if ".so" not in soname:  # a Python linked statically: name the standard shared library
        soname = f"libpython{version}{sysconfig.get_config_var('ABIFLAGS') or ''}.so.1.0"
    return soname, sysconfig.get_config_var("LIBDIR") or "", version


def _c_string(text):
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def compile_loader(folder, runtime=None):
    """Compile the C loader into ``folder``/loader.so; return (path or None, message).

    The compiler is $CC (may carry arguments) or ``cc``. On any failure the path is None and
    the message says why; the caller then ships pythonfmu's plain binary. ``runtime`` is
    (soname, libdir, major.minor) of the libpython to look for; default python_runtime().
    """
    if not sys.platform.startswith("linux") or platform.machine() not in ("x86_64", "AMD64"):
        return None, f"not built on Linux x86-64 ({sys.platform}, {platform.machine()})"
    compiler = os.environ.get("CC") or "cc"
    argv = shlex.split(compiler)
    if not argv or shutil.which(argv[0]) is None:
        return None, f"C compiler {compiler!r} not found (set CC or install cc)"
    headers = fmi_headers()
    if not (headers / "fmi2Functions.h").is_file():
        return None, f"FMI 2.0 headers not found in {headers}"
    soname, libdir, version = runtime or python_runtime()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    target = folder / "loader.so"
    command = [*argv, *LOADER_FLAGS, f"-I{headers}",
               f"-DPYTHON_SONAME={_c_string(soname)}", f"-DPYTHON_LIBDIR={_c_string(libdir)}",
               f"-DPYTHON_VERSION={_c_string(version)}",
               str(LOADER_SOURCE), "-o", str(target), "-ldl"]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.SubprocessError) as error:
        return None, f"C compiler {compiler!r} could not run: {error}"
    if done.returncode != 0 or not target.is_file():
        detail = " ".join((done.stderr or done.stdout).split())[:400]
        return None, f"C compiler {compiler!r} failed (exit {done.returncode}): {detail}"
    where = f" (first looked for in {libdir})" if libdir else ""
    warnings = " ".join(done.stderr.split())[:400]
    return target, (f"compiled with {compiler} for Python {version}: {soname}{where}"
                    + (f"; compiler warnings: {warnings}" if warnings else ""))


def runtime_package(name):
    """Private package name of the runtime inside ``name``.fmu.

    Every FMU carries its own copy under its own name: FMUs loaded into one Python process
    (fmpy runs them in the host interpreter) then never share modules, and a host's own
    mechfmu, or an FMU extracted earlier and since deleted, cannot shadow this one's code.
    """
    return f"mechfmu_fmu_{name}"


def _stage_runtime(target):
    """Copy the FMU runtime (mechfmu.runtime) into the package folder ``target``."""
    shutil.copytree(RUNTIME_ROOT, target, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))


def null_name(name):
    """FMU name of the null variant of model ``name`` (see build_model)."""
    return f"{name}Null"


def _entry_script(name, fmu_name, inner_module):
    """Source of the FMU's entry module: the model's class, or its null subclass."""
    # pythonfmu 0.7's loader (findClass) re-runs this file at every instantiation and then
    # releases one reference to the module namespace that it only borrowed: after the first
    # instance is freed the namespace is gone and the next load crashes or fails. Each run
    # of the file therefore keeps one reference of its own. Only the model may be a class here.
    header = (f'"""FMU entry point for {fmu_name}."""\n'
              "import sys\n"
              "sys.__dict__.setdefault('_mechfmu_kept_namespaces', []).append(globals())\n")
    if fmu_name == name:
        return header + f"from {inner_module} import {name}  # noqa: E402,F401\n"
    # The null variant: the model's module, not its class, enters the namespace, so the
    # loader finds exactly one slave class here (the subclass).
    return header + (f"import {inner_module} as model_module  # noqa: E402\n\n\n"
                     f"class {fmu_name}(model_module.{name}):\n"
                     f'    """{name} with a do_step that does nothing (benchmark baseline)."""\n\n'
                     "    def do_step(self, current_time, step_size):\n"
                     "        return True\n")


def build_model(name, out_dir, staging, null=False, loader=None):
    """Build ``name`` (a key of MODELS) into ``out_dir``/``name``.fmu; return its path.

    null=True builds ``out_dir``/``name``Null.fmu instead: the same variables, parameters and
    initialisation, but a do_step that returns at once, so its outputs keep the values of
    initialisation (the baseline of the model-cost benchmark, mechfmu.tools.bench).

    ``loader`` is compile_loader's (path or None, message); None compiles it here.
    """
    module = MODELS[name]
    importlib.import_module(module)  # fail early, with a Python traceback, on a broken model
    fmu_name = null_name(name) if null else name
    folder = staging / fmu_name
    folder.mkdir()
    package = folder / runtime_package(fmu_name)
    _stage_runtime(package)
    inner_module = module.replace("mechfmu.runtime.", f"{package.name}.", 1)
    # The entry module must not be named like the model: fmpy puts a module of its own
    # under sys.modules[model name], so a second load of the FMU would import that one.
    script = folder / f"mechfmu_entry_{fmu_name}.py"
    script.write_text(_entry_script(name, fmu_name, inner_module))
    built = FmuBuilder.build_FMU(script, dest=staging / f"out_{fmu_name}",
                                 project_files=[package], canGetAndSetFMUstate=True)
    if loader is None:
        loader = compile_loader(staging / f"loader_{fmu_name}")
    # atomic: a reader never sees a half-written FMU
    return atomic_write(Path(out_dir) / f"{fmu_name}.fmu",
                        _rewrite_linux_binary(built, fmu_name, loader))


def _rewrite_linux_binary(fmu, name, loader):
    """The FMU's bytes with its Linux binary patched (see binary_patch) and, when the loader
    was compiled, moved to <name>.pythonfmu.so with the loader as <name>.so; report both."""
    member = f"binaries/linux64/{name}.so"
    loader_path, loader_message = loader
    with zipfile.ZipFile(fmu) as archive:
        entries = [(info, archive.read(info)) for info in archive.infolist()]
    if member not in {info.filename for info, _ in entries}:
        raise RuntimeError(f"{fmu} has no {member}: not a pythonfmu 0.7 FMU?")
    patched_fmu = io.BytesIO()
    with zipfile.ZipFile(patched_fmu, "w", zipfile.ZIP_DEFLATED) as archive:
        for info, data in entries:
            if info.filename == member:
                data, message = patch_exit_finaliser(data)
                print(f"{name}: {message}")
                if loader_path is not None:
                    inner = zipfile.ZipInfo(f"binaries/linux64/{pythonfmu_library_name(name)}",
                                            info.date_time)
                    inner.external_attr = info.external_attr
                    archive.writestr(inner, data, zipfile.ZIP_DEFLATED)
                    data = Path(loader_path).read_bytes()
            archive.writestr(info, data)
    if loader_path is not None:
        print(f"{name}: C loader as {member} (loads libpython itself in hosts without Python), "
              f"pythonfmu's library as {pythonfmu_library_name(name)}")
    else:
        print(f"{name}: no C loader ({loader_message}): pythonfmu's plain binary, which loads "
              "only in hosts that already run Python (such as fmpy)")
    return patched_fmu.getvalue()


def build_all(out_dir, names=None, null=False):
    """Build the named models (default: all of MODELS); return the FMU paths.

    null=True builds their null variants (``<name>Null.fmu``, see build_model).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="mechfmu_build_", dir=out_dir) as temp:
        loader = compile_loader(Path(temp) / "c_loader")
        print(f"C loader: {loader[1]}" if loader[0] is not None else
              f"C loader not built: {loader[1]}; the FMUs keep pythonfmu's plain binary")
        return [build_model(name, out_dir, Path(temp), null, loader)
                for name in (names or MODELS)]
