"""Build every model of the registry into an FMU, FMI 2.0 or FMI 3.0 (host side).

Each FMU carries only the code that runs inside it: the standard-library package
``mechfmu.runtime`` (plus pythonfmu's or pythonfmu3's own Python files, which their builders
add). The two versions come from the same model classes and declarations: the FMU's copy of
the runtime binds them to pythonfmu (FMI 2.0) or to pythonfmu3 (FMI 3.0; see
runtime/fmi/binding.py).

Its Linux binary is mechfmu's C loader (``c_loader/``: python_runtime.c with fmi2.c or fmi3.c,
compiled here with the system C compiler) when one is found: pythonfmu's library leaves the
Python C API unresolved, so only a host that already runs Python (fmpy) can load it; the
loader finds and loads a libpython first and forwards every FMI call, so C and C++ hosts load
the FMU too. pythonfmu's library (with binary_patch's exit fix where it applies) then sits
next to it as ``<Name>.pythonfmu.so``. Without a compiler the FMU keeps pythonfmu's plain
binary, and the build says so. ``embed_python`` adds the build interpreter's own runtime
(embed.py), for machines without Python.
"""

from typing import Any
from collections.abc import Iterator
import contextlib
import hashlib
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
from dataclasses import dataclass
from pathlib import Path

# Imported here, before any FMU runs in this process: an FMU run by fmpy puts its resources/
# first on sys.path, and its copy of pythonfmu (without the builder's binaries) would then
# shadow the installed one.
from pythonfmu import FmuBuilder as Fmi2Builder
from pythonfmu3 import FmuBuilder as Fmi3Builder

from .binary_patch import patch_exit_finaliser
from .boundary import c_string, table_source
from .closure import runtime_closure
from .compiled import compile_core as compile_exact_core
from .describe import described, null_description, self_description
from ..cosim.files import atomic_write
from ..runtime.models import MODELS

RUNTIME_ROOT = Path(__file__).resolve().parents[1] / "runtime"  # the FMU runtime; no numpy
LOADER_DIR = Path(__file__).resolve().parent / "c_loader"
LOADER_RUNTIME_SOURCE = LOADER_DIR / "python_runtime.c"  # finds and starts libpython
PYTHONFMU_SUFFIX = ".pythonfmu.so"  # pythonfmu's library, next to the loader <Name>.so
LOADER_FLAGS = ("-fPIC", "-O2", "-Wall", "-Wextra", "-fvisibility=hidden", "-pthread")
LOADER_LIBRARIES = ("-shared", "-ldl", "-pthread")
COMPILER_TIMEOUT = 120  # s for one compiler run (a loader source, or the link: seconds)
COMPILER_QUOTE = 400  # characters of the compiler's output a build message quotes
FMI_VERSIONS = (2, 3)
# binaries/<folder> of the Linux x86-64 binary, per FMI version
PLATFORM_FOLDER = {2: "linux64", 3: "x86_64-linux"}
# the FMU's copy of runtime/fmi/binding.py for FMI 3.0
FMI3_BINDING = (
    '"""FMI 3.0: this copy of the runtime binds to pythonfmu3 (written by mechfmu '
    'build)."""\n\nfrom .fmi3 import Fmi3Binding as Binding  # noqa: F401\n'
)


def pythonfmu_library_name(name: str) -> str:
    """File name of pythonfmu's own library in binaries/linux64/ when the loader is installed."""
    return f"{name}{PYTHONFMU_SUFFIX}"


def fmi_headers() -> Any:
    """fmpy's copy of the FMI 2.0 and 3.0 headers (fmi2Functions.h, fmi3Functions.h and their
    includes)."""
    spec = importlib.util.find_spec("fmpy")
    if spec is None or not spec.origin:
        return Path("fmpy-is-not-installed") / "c-code"
    return Path(spec.origin).resolve().parent / "c-code"


def python_runtime() -> Any:
    """(soname, libdir, major.minor) of the libpython the FMUs are built for: this Python's."""
    version = sysconfig.get_config_var("py_version_short") or sysconfig.get_config_var("VERSION")
    soname = sysconfig.get_config_var("INSTSONAME") or ""
    if ".so" not in soname:  # a Python linked statically: name the standard shared library
        soname = f"libpython{version}{sysconfig.get_config_var('ABIFLAGS') or ''}.so.1.0"
    return soname, sysconfig.get_config_var("LIBDIR") or "", version


@dataclass(frozen=True)
class Loader:
    """The C loader of one FMI version, compiled to objects once per build; ``link`` makes
    each FMU's binary from them and the table of that FMU's variables (boundary.py)."""

    objects: tuple[Path, ...]
    compiler: tuple[str, ...]
    headers: Path

    def link(self, description: bytes, folder: Path) -> Path:
        """The loader for the FMU whose modelDescription.xml is ``description``, linked in
        ``folder``; RuntimeError with the compiler's output when it fails."""
        folder.mkdir(parents=True, exist_ok=True)
        table = folder / "model_table.c"
        table.write_text(table_source(description))
        target = folder / "loader.so"
        command = [
            *self.compiler,
            *LOADER_FLAGS,
            f"-I{self.headers}",
            f"-I{LOADER_DIR}",
            str(table),
            *map(str, self.objects),
            "-o",
            str(target),
            *LOADER_LIBRARIES,
        ]
        done = subprocess.run(command, capture_output=True, text=True, timeout=COMPILER_TIMEOUT)
        failure = _compiler_failure(done, target)
        if failure:
            raise RuntimeError(f"linking the C loader failed {failure}")
        return target


def _compiler_failure(done: "subprocess.CompletedProcess[str]", target: Path) -> str | None:
    """Why the compiler run ``done`` wrote no ``target`` (its exit status and the start of its
    output, on one line), or None when it wrote it."""
    if done.returncode == 0 and target.is_file():
        return None
    detail = " ".join((done.stderr or done.stdout).split())[:COMPILER_QUOTE]
    return f"(exit {done.returncode}): {detail}"


def compile_loader(folder: Any, runtime: Any = None, fmi_version: Any = 2) -> Any:
    """Compile the C loader for FMI ``fmi_version`` into objects in ``folder``; return
    (Loader or None, message).

    The compiler is $CC (may carry arguments) or ``cc``. On any failure the Loader is None and
    the message says why; the caller then ships pythonfmu's plain binary. ``runtime`` is
    (soname, libdir, major.minor) of the libpython to look for first; default python_runtime().
    """
    if not sys.platform.startswith("linux") or platform.machine() not in ("x86_64", "AMD64"):
        return None, f"not built on Linux x86-64 ({sys.platform}, {platform.machine()})"
    compiler = os.environ.get("CC") or "cc"
    argv = shlex.split(compiler)
    if not argv or shutil.which(argv[0]) is None:
        return None, f"C compiler {compiler!r} not found (set CC or install cc)"
    headers = fmi_headers()
    if not (headers / f"fmi{fmi_version}Functions.h").is_file():
        return None, f"FMI {fmi_version}.0 headers not found in {headers}"
    soname, libdir, version = runtime or python_runtime()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    definitions = [
        f"-DPYTHON_SONAME={c_string(soname)}",
        f"-DPYTHON_LIBDIR={c_string(libdir)}",
        f"-DPYTHON_VERSION={c_string(version)}",
    ]
    objects, warnings = [], []
    for source in (
        LOADER_RUNTIME_SOURCE,
        LOADER_DIR / "boundary.c",
        LOADER_DIR / f"fmi{fmi_version}.c",
    ):
        target = folder / f"{source.stem}.o"
        command = [
            *argv,
            "-c",
            *LOADER_FLAGS,
            f"-I{headers}",
            *definitions,
            str(source),
            "-o",
            str(target),
        ]
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=COMPILER_TIMEOUT)
        except (OSError, subprocess.SubprocessError) as error:
            return None, f"C compiler {compiler!r} could not run: {error}"
        failure = _compiler_failure(done, target)
        if failure:
            return None, f"C compiler {compiler!r} failed {failure}"
        objects.append(target)
        warnings.append(" ".join(done.stderr.split()))
    where = f" (first looked for in {libdir})" if libdir else ""
    warned = " ".join(w for w in warnings if w)[:COMPILER_QUOTE]
    message = (
        f"compiled with {compiler} for FMI {fmi_version}.0, Python {version} first: "
        f"{soname}{where}, then any 3.x >= 3.10"
        + (f"; compiler warnings: {warned}" if warned else "")
    )
    return Loader(tuple(objects), tuple(argv), headers), message


def runtime_package(name: str, fmi_version: Any = 2) -> Any:
    """Private package name of the runtime inside ``name``.fmu.

    Every FMU carries its own copy under its own name: FMUs loaded into one Python process
    (fmpy runs them in the host interpreter) then never share modules, and a host's own
    mechfmu, or an FMU extracted earlier and since deleted, cannot shadow this one's code.
    FMI 3.0 FMUs use names of their own, so both versions of a model load side by side.
    """
    return f"mechfmu_fmu_{name}" if fmi_version == 2 else f"mechfmu_fmu{fmi_version}_{name}"


def _entry_module(fmu_name: Any, fmi_version: Any):
    """Name of the FMU's entry module (pythonfmu imports it by this name)."""
    # Not the model's name: fmpy puts a module of its own under sys.modules[model name], so a
    # second load of the FMU would import that one.
    return (
        f"mechfmu_entry_{fmu_name}"
        if fmi_version == 2
        else f"mechfmu_entry{fmi_version}_{fmu_name}"
    )


def _stage_runtime(target: Any, fmi_version: Any, module: str) -> None:
    """Copy the part of the FMU runtime (mechfmu.runtime) that ``module`` imports (its import
    closure, closure.py) into the package folder ``target``, bound to pythonfmu (FMI 2.0) or
    pythonfmu3 (FMI 3.0)."""
    for relative in runtime_closure(RUNTIME_ROOT, module, f"fmi{fmi_version}"):
        (target / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(RUNTIME_ROOT / relative, target / relative)
    if fmi_version == 3:
        (target / "fmi" / "binding.py").write_text(FMI3_BINDING)


def _variant_tag(starts: dict[str, Any] | None) -> str:
    """The suffix of the module names of an FMU built with other start values ('' for none):
    a digest of those values."""
    if not starts:
        return ""
    return "_" + hashlib.sha256(repr(sorted(starts.items())).encode()).hexdigest()[:10]


def null_name(name: str) -> str:
    """FMU name of the null variant of model ``name`` (see build_model)."""
    return f"{name}Null"


def _entry_script(
    name: str,
    fmu_name: Any,
    inner_module: Any,
    fmi_version: Any = 2,
    starts: dict[str, Any] | None = None,
) -> str:
    """Source of the FMU's entry module: the model's class, or a subclass: the null variant,
    or the model with other start values (``starts``: variable name -> value)."""
    # pythonfmu's loader (findClass) re-runs this file at every instantiation, with locals of
    # its own, then releases one reference to the module namespace that it only borrowed. The
    # run it makes therefore takes one reference that nothing ever releases: held in a Python
    # list, it would be released when the host's interpreter shuts down, and the namespace
    # freed under its module (a segmentation fault at exit, seen in CI on CPython 3.10).
    # ctypes is there in every Python host; a host without Python never finalises the
    # interpreter, so a list is enough where ctypes is missing (an FMU's own Python does not
    # ship it). Only the model may be a class here.
    header = (
        f'"""FMU entry point for {fmu_name} (FMI {fmi_version}.0)."""\n'
        "import sys\n"
        "if locals() is not globals():  # run by pythonfmu's findClass\n"
        "    try:\n"
        "        import ctypes\n"
        "        ctypes.pythonapi.Py_IncRef(ctypes.py_object(globals()))\n"
        "    except (ImportError, AttributeError, OSError):\n"
        "        sys.__dict__.setdefault('_mechfmu_kept_namespaces', []).append(globals())\n"
    )
    null_step = "    def do_step(self, current_time, step_size):\n        return True\n"
    body = ""
    if starts:
        package = inner_module.split(".", 1)[0]
        header += f"from {package}.fmi.declarations import with_starts  # noqa: E402\n"
        body += f"    VARIABLES = with_starts(model_module.{name}.VARIABLES, {starts!r})\n"
    if fmu_name != name:
        body += null_step
    what = (
        "with a do_step that does nothing (benchmark baseline)"
        if fmu_name != name
        else "with the start values of a scene"
        if starts
        else "as an FMI 3.0 slave"
    )
    if fmi_version == 3:
        # pythonfmu3 finds the class by a regular expression on its line, which must name
        # Fmi3Slave among the bases (it is already one of the model's, through the binding).
        return header + (
            "from pythonfmu3 import Fmi3Slave  # noqa: E402\n"
            f"import {inner_module} as model_module  # noqa: E402\n\n\n"
            f"class {fmu_name}(model_module.{name}, Fmi3Slave):\n"
            f'    """{name} {what}."""\n\n' + body
        )
    if not body:
        return header + f"from {inner_module} import {name}  # noqa: E402,F401\n"
    # A variant: the model's module, not its class, enters the namespace, so the loader
    # finds exactly one slave class here (the subclass).
    return header + (
        f"import {inner_module} as model_module  # noqa: E402\n\n\n"
        f"class {fmu_name}(model_module.{name}):\n"
        f'    """{name} {what}."""\n\n' + body
    )


@contextlib.contextmanager
def _own_modules(package: str) -> Iterator[None]:
    """While the builders import the staged runtime ``package``: without the modules of that
    name that an FMU loaded into this process left in sys.modules (another build of the same
    model, whose code would be taken instead); they are put back afterwards."""
    loaded = {
        name: module
        for name, module in sys.modules.items()
        if name == package or name.startswith(package + ".")
    }
    for name in loaded:
        del sys.modules[name]
    try:
        yield
    finally:
        for name in [n for n in sys.modules if n == package or n.startswith(package + ".")]:
            del sys.modules[name]
        sys.modules.update(loaded)


def _builder(fmi_version: Any):
    """pythonfmu's (FMI 2.0) or pythonfmu3's (FMI 3.0) FmuBuilder and its capability flags.
    FMU states serialise through runtime/fmi/state.py (bit-exact JSON), framed and checked by
    the C loader."""
    if fmi_version == 2:
        return Fmi2Builder, {"canGetAndSetFMUstate": True, "canSerializeFMUstate": True}
    return Fmi3Builder, {
        "canGetAndSetFMUState": True,
        "canSerializeFMUState": True,
        "canHandleVariableCommunicationStepSize": True,
    }


def build_model(
    name: str,
    out_dir: Any,
    staging: Any,
    null: bool = False,
    loader: Any = None,
    fmi_version: Any = 2,
    embed: Any = None,
    starts: dict[str, Any] | None = None,
    experiment: dict[str, float] | None = None,
    compile_core: bool = False,
) -> Any:
    """Build ``name`` (a key of MODELS) into ``out_dir``/``name``.fmu; return its path.

    null=True builds ``out_dir``/``name``Null.fmu instead: the same variables, parameters and
    initialisation, but a do_step that returns at once, so its outputs keep the values of
    initialisation (the baseline of the model-cost benchmark, mechfmu.tools.bench).

    ``loader`` is compile_loader's (path or None, message) for ``fmi_version``; None compiles
    it here. ``embed`` is an embed.EmbeddedPython: the FMU then carries that Python runtime.
    ``starts``: start values (variable name -> value) that replace the declared ones, e.g.
    the parameters and fixed inputs of a scene (the FMUs of ``mechfmu export-cross-check``);
    ``experiment``: DefaultExperiment attributes in place of the reference scene's.
    ``compile_core``: when the FMU carries the valve's exact core, it and the modules its step calls
    are compiled to C extensions beside their sources (compiled.py; not for a null variant,
    whose step computes nothing); a failed compile leaves the sources, and the build says
    why.
    """
    if fmi_version not in FMI_VERSIONS:
        raise ValueError(f"FMI version {fmi_version!r} is not one of {FMI_VERSIONS}")
    module = MODELS[name]
    importlib.import_module(module)  # fail early, with a Python traceback, on a broken model
    fmu_name = null_name(name) if null else name
    folder = staging / f"{fmu_name}_fmi{fmi_version}"
    folder.mkdir()
    # a variant with other start values gets module names of its own: a process that loads
    # it next to the plain FMU (both of model ``name``) must not mix their modules
    tag = _variant_tag(starts)
    package = folder / (runtime_package(fmu_name, fmi_version) + tag)
    _stage_runtime(package, fmi_version, module)
    core_build = (
        compile_exact_core(package, staging / f"compile_{folder.name}")
        if compile_core and not null
        else None
    )
    if core_build is not None:
        print(f"{fmu_name}: {core_build.message}")
    inner_module = module.replace("mechfmu.runtime.", f"{package.name}.", 1)
    script = folder / f"{_entry_module(fmu_name, fmi_version)}{tag}.py"
    script.write_text(_entry_script(name, fmu_name, inner_module, fmi_version, starts))
    builder, options = _builder(fmi_version)
    with _own_modules(package.name):
        built = builder.build_FMU(
            script,
            dest=staging / f"out_{fmu_name}_fmi{fmi_version}",
            project_files=[package, *(core_build.outside if core_build else ())],
            **options,
        )
    if loader is None:
        loader = compile_loader(staging / f"loader_{fmu_name}", fmi_version=fmi_version)
    extra = embed.files_for(built, staging / f"embed_{fmu_name}_fmi{fmi_version}") if embed else {}
    linking = staging / f"link_{fmu_name}_fmi{fmi_version}"
    # atomic: a reader never sees a half-written FMU
    return atomic_write(
        Path(out_dir) / f"{fmu_name}.fmu",
        _rewrite_fmu(built, fmu_name, loader, fmi_version, extra, linking, name, experiment, null),
    )


def _members(fmu: Any, fmi_version: int) -> dict[str, tuple[zipfile.ZipInfo, bytes]]:
    """The members the FMU keeps, by name: pythonfmu3's C++ sources are left out (they cannot
    rebuild this FMU's binary, the loader), and so are the binaries of every platform but
    this one (pythonfmu's builders add Windows DLLs that nothing here has ever run)."""
    own = f"binaries/{PLATFORM_FOLDER[fmi_version]}/"
    with zipfile.ZipFile(fmu) as archive:
        return {
            info.filename: (info, archive.read(info))
            for info in archive.infolist()
            if not info.filename.startswith("sources/")
            and (not info.filename.startswith("binaries/") or info.filename.startswith(own))
        }


def _rewrite_fmu(
    fmu: Any,
    name: str,
    loader: Any,
    fmi_version: Any,
    extra: Any,
    linking: Path,
    model: str | None = None,
    experiment: dict[str, float] | None = None,
    null: bool = False,
) -> bytes:
    """The FMU's bytes with its Linux binary patched (pythonfmu 0.7's and pythonfmu3's exit
    fix, see binary_patch) and, when the loader was compiled, moved to <name>.pythonfmu.so
    with the loader, linked with the table of this FMU's variables, as <name>.so. ``extra``
    maps further member names to their bytes (the embedded Python). ``model``: the
    registry's model the FMU is made of, whose documentation, picture, version and default
    experiment it then carries (describe.py); ``null``: the FMU is its null variant, whose
    page says so (no reference plots: its outputs never move)."""
    member = f"binaries/{PLATFORM_FOLDER[fmi_version]}/{name}.so"
    compiled, loader_message = loader
    members = _members(fmu, fmi_version)
    if member not in members:
        raise RuntimeError(f"{fmu} has no {member}: not a pythonfmu FMU?")
    if model is not None:
        info, description = members["modelDescription.xml"]
        members["modelDescription.xml"] = (info, described(description, model, experiment))
        described_members = (
            null_description(model) if null else self_description(model, fmi_version)
        )
    else:
        described_members = {}
    info, data = members[member]
    data, message = patch_exit_finaliser(data)
    print(f"{name}: {message}")
    members[member] = (info, data)
    if compiled is not None:
        inner = zipfile.ZipInfo(member[: -len(".so")] + PYTHONFMU_SUFFIX, info.date_time)
        inner.external_attr = info.external_attr
        members[inner.filename] = (inner, data)
        description = members["modelDescription.xml"][1]
        members[member] = (info, compiled.link(description, linking).read_bytes())
    for filename, content in {**extra, **described_members}.items():
        entry = zipfile.ZipInfo(filename, (2020, 1, 1, 0, 0, 0))
        entry.external_attr = (
            0o755 << 16 if filename.endswith(".so") or ".so." in filename else 0o644 << 16
        )
        # the stdlib zip stays uncompressed inside (zipimport reads it without zlib, which
        # is itself an extension module); the FMU's own deflate compresses it
        members[filename] = (entry, content)
    patched_fmu = io.BytesIO()
    with zipfile.ZipFile(patched_fmu, "w", zipfile.ZIP_DEFLATED) as archive:
        for entry, content in members.values():
            entry.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(entry, content)
    if compiled is not None:
        print(
            f"{name}: C loader as {member} (loads libpython itself in hosts without Python, "
            f"checks every call at the FMI boundary), pythonfmu's library as "
            f"{pythonfmu_library_name(name)}"
        )
    else:
        print(
            f"{name}: no C loader ({loader_message}): pythonfmu's plain binary, which loads "
            "only in hosts that already run Python (such as fmpy)"
        )
    if extra:
        print(
            f"{name}: embedded Python runtime, {len(extra)} files, "
            f"{sum(len(content) for content in extra.values()) / 1e6:.1f} MB before compression"
        )
    return patched_fmu.getvalue()


def build_all(
    out_dir: Any,
    names: Any = None,
    null: bool = False,
    fmi_version: Any = 2,
    embed_python: bool = False,
    compile_core: bool = True,
) -> Any:
    """Build the named models (default: all of MODELS); return the FMU paths.

    null=True builds their null variants (``<name>Null.fmu``, see build_model).
    fmi_version: 2 (FMI 2.0, pythonfmu) or 3 (FMI 3.0, pythonfmu3), from the same models.
    embed_python=True: each FMU carries this interpreter's libpython and the part of the
    standard library it imports (embed.py), so it runs where no Python is installed.
    compile_core=True: the valve's exact core compiled to C where an FMU carries it
    (compiled.py; build_model).
    """
    if fmi_version not in FMI_VERSIONS:
        raise ValueError(f"FMI version {fmi_version!r} is not one of {FMI_VERSIONS}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="mechfmu_build_", dir=out_dir) as temp:
        loader = compile_loader(Path(temp) / "c_loader", fmi_version=fmi_version)
        print(
            f"C loader: {loader[1]}"
            if loader[0] is not None
            else f"C loader not built: {loader[1]}; the FMUs keep pythonfmu's plain binary"
        )
        embed = None
        if embed_python:
            from .embed import EmbeddedPython

            if loader[0] is None:
                raise RuntimeError(
                    "--embed-python needs the C loader, which starts the "
                    f"embedded runtime: {loader[1]}"
                )
            embed = EmbeddedPython.of_this_interpreter()
        return [
            build_model(
                name,
                out_dir,
                Path(temp),
                null,
                loader,
                fmi_version,
                embed,
                compile_core=compile_core,
            )
            for name in (names or MODELS)
        ]
