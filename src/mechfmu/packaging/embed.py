"""The build interpreter's own runtime inside an FMU: ``mechfmu build --embed-python``.

An FMU built this way runs in a host on a machine without any Python: it carries, under
``resources/python/`` (a Python prefix of its own),

- ``lib/libpython3.x.so.1.0``: the build interpreter's shared library (stripped of its debug
  symbols when ``strip`` is found);
- ``lib/python3x.zip``: the compiled modules of the standard library that the FMU imports,
  stored uncompressed (zipimport then needs no zlib, itself an extension module; the FMU's own
  deflate compresses them), plus the whole ``encodings`` package, which the interpreter
  needs at start-up for whatever locale the host runs in;
- ``lib/python3.x/lib-dynload/``: the extension modules among them (math, _struct, ...).

Which modules: those a fresh interpreter holds after a real run of the FMU's Python side,
traced at build time (``trace_modules``): the build's base interpreter (``-I``: no
user site, no PYTHONPATH; its ``site`` runs, as in the FMU) imports the FMU's entry module
from the built FMU's resources, as pythonfmu's library does, and drives the slave through the
calls pythonfmu's library makes (instantiation, initialisation with every variable read,
steps, getting and setting the FMU state, a refused input, termination). Frozen and built-in modules need no file.

The C loader looks in ``resources/python/lib`` first and takes the folder above as the
interpreter's home (PYTHONHOME), where the interpreter finds ``lib/python3x.zip`` on its
default path. In a host that already runs Python (fmpy) the FMU runs in that Python instead.
"""

import ast
import py_compile
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

PREFIX = "resources/python"  # the FMU's own Python prefix (the C loader's first folder)
ALWAYS = ("encodings",)  # packages shipped whole (see the module docstring)

# Run by the base interpreter in a fresh process: argv = resources folder, class name. It
# uses nothing but builtins and sys until it prints, so its own imports add nothing.
TRACE_DRIVER = r"""
import sys
resources, class_name = sys.argv[1], sys.argv[2]
sys.path.insert(0, resources)
with open(resources + "/slavemodule.txt") as file:
    module_name = file.read().strip()
slave_class = getattr(__import__(module_name), class_name)

def drive(slave, bad_input):
    slave.setup_experiment(0.0)
    slave.enter_initialization_mode()
    for variable in list(slave.vars.values()):
        slave.refresh_initial_outputs()
        variable.getter()
    slave.exit_initialization_mode()
    for k in range(3):
        slave.do_step(k * 1e-3, 1e-3)
    slave._set_fmu_state(slave._get_fmu_state())
    if bad_input is not None:
        bad_input.setter(float("nan"))
        slave.do_step(3e-3, 1e-3)  # refused: logged, step discarded
    slave.terminate()
    slave._get_log_queue()

slave = slave_class(instance_name="trace", resources=resources, visible=False)
inputs = [v for v in slave.declared.values() if v.causality == "input" and v.kind is float]
bad = ([v for v in slave.vars.values() if v.name == inputs[0].name][0] if inputs else None)
drive(slave, bad)
found = []
for name, module in list(sys.modules.items()):
    spec = getattr(module, "__spec__", None)
    found.append((name, getattr(module, "__file__", None), getattr(spec, "origin", None)))
sys.stdout.write(repr(found))
"""


def _strip(source: Path, target: Path) -> None:
    """Copy a shared library, without its debug symbols when ``strip`` is there."""
    strip = shutil.which("strip")
    if strip is not None:
        done = subprocess.run(
            [strip, "--strip-unneeded", "-o", str(target), str(source)],
            capture_output=True,
            text=True,
        )
        if done.returncode == 0:
            return
    shutil.copyfile(source, target)


def _compiled(source: Path, relative: str, folder: Path) -> bytes:
    """The .pyc bytes of a standard-library module, its tracebacks naming ``relative``
    (unchecked hash: the FMU carries no source to compare with)."""
    target = Path(folder) / "compiled.pyc"
    py_compile.compile(
        str(source),
        cfile=str(target),
        dfile=relative,
        doraise=True,
        invalidation_mode=py_compile.PycInvalidationMode.UNCHECKED_HASH,
    )
    return target.read_bytes()


@dataclass(frozen=True)
class EmbeddedPython:
    """The runtime of the interpreter running the build: what an FMU needs to carry."""

    version: str  # major.minor, e.g. "3.11"
    library: Path  # its libpython3.x.so.1.0
    stdlib: Path  # lib/python3.x
    dynload: Path  # lib/python3.x/lib-dynload
    executable: Path  # the base interpreter (not a venv's), for the trace

    @classmethod
    def of_this_interpreter(cls) -> "EmbeddedPython":
        """The build interpreter's runtime; RuntimeError when it has no shared library."""
        version = sysconfig.get_config_var("py_version_short")
        libdir = Path(sysconfig.get_config_var("LIBDIR") or "")
        soname = sysconfig.get_config_var("INSTSONAME") or ""
        library = libdir / soname
        if ".so" not in soname or not library.is_file():
            raise RuntimeError(
                f"--embed-python needs a Python built with a shared library "
                f"(--enable-shared); this one ({sys.executable}) has none at "
                f"{library}"
            )
        if sysconfig.get_config_var("Py_GIL_DISABLED"):
            raise RuntimeError(
                "--embed-python: a free-threaded Python cannot run pythonfmu's "
                "library; build with the default (GIL) build"
            )
        executable = Path(getattr(sys, "_base_executable", "") or sys.executable)
        return cls(
            version,
            library,
            Path(sysconfig.get_paths()["stdlib"]),
            Path(sysconfig.get_config_var("DESTSHARED")),
            executable,
        )

    @property
    def zip_name(self) -> str:
        """lib/python3x.zip: the name on the interpreter's default path."""
        return f"python{self.version.replace('.', '')}.zip"

    def trace_modules(self, fmu: Path) -> tuple[dict[str, Path], dict[str, Path]]:
        """(pure modules, extension modules) of the standard library that a run of ``fmu``
        imports: {dotted name: source file} and {dotted name: .so file}."""
        with tempfile.TemporaryDirectory(prefix="mechfmu_trace_") as folder:
            with zipfile.ZipFile(fmu) as archive:
                archive.extractall(folder)
            description = (Path(folder) / "modelDescription.xml").read_text()
            class_name = description.split('modelName="', 1)[1].split('"', 1)[0]
            done = subprocess.run(
                [
                    str(self.executable),
                    "-I",
                    "-c",
                    TRACE_DRIVER,
                    str(Path(folder) / "resources"),
                    class_name,
                ],
                capture_output=True,
                text=True,
                cwd=folder,
                timeout=300,
            )
        if done.returncode != 0:
            raise RuntimeError(f"tracing the imports of {fmu} failed: {done.stderr[-2000:]}")
        pure, extensions = {}, {}
        for name, file, origin in ast.literal_eval(done.stdout):
            if origin in ("frozen", "built-in") or not file:
                continue  # inside libpython
            path = Path(file)
            if path.parent == self.dynload:
                extensions[name] = path
            elif (
                path.suffix == ".py"
                and self.stdlib in path.parents
                and "site-packages" not in path.parts
            ):
                pure[name] = path
        return pure, extensions

    def _always(self) -> dict[str, Path]:
        """{dotted name: source} of the packages shipped whole (ALWAYS)."""
        found = {}
        for package in ALWAYS:
            for source in sorted((self.stdlib / package).rglob("*.py")):
                relative = source.relative_to(self.stdlib).with_suffix("")
                parts = relative.parts[:-1] if relative.name == "__init__" else relative.parts
                found[".".join(parts)] = source
        return found

    def files_for(self, fmu: Path, folder: Path) -> dict[str, bytes]:
        """{FMU member name: bytes} of the runtime that ``fmu`` (built, not yet embedded)
        needs; ``folder`` is scratch space."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        pure, extensions = self.trace_modules(fmu)
        pure.update(self._always())
        stdlib_zip = folder / self.zip_name
        with zipfile.ZipFile(stdlib_zip, "w", zipfile.ZIP_STORED) as archive:
            for source in sorted(set(pure.values())):
                relative = source.relative_to(self.stdlib)
                entry = zipfile.ZipInfo(
                    relative.with_suffix(".pyc").as_posix(), (2020, 1, 1, 0, 0, 0)
                )
                archive.writestr(entry, _compiled(source, relative.as_posix(), folder))
        files = {f"{PREFIX}/lib/{self.zip_name}": stdlib_zip.read_bytes()}
        shared = [(self.library, f"{PREFIX}/lib/{self.library.name}")]
        shared += [
            (path, f"{PREFIX}/lib/python{self.version}/lib-dynload/{path.name}")
            for path in sorted(extensions.values())
        ]
        for source, member in shared:
            target = folder / Path(member).name
            _strip(source, target)
            files[member] = target.read_bytes()
        return files
