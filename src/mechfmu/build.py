"""Build every model of the registry into an FMU with pythonfmu (host side).

Each FMU carries only the code that runs inside it: the standard-library packages
``mechfmu.physics``, ``mechfmu.fmi`` and ``mechfmu.models`` (plus pythonfmu's own
Python files, which its builder adds).
"""

import importlib
import os
import shutil
import tempfile
import zipfile
from pathlib import Path

from pythonfmu import FmuBuilder

from .binary_patch import patch_exit_finaliser
from .models import MODELS

PACKAGE_ROOT = Path(__file__).resolve().parent
FMU_PACKAGES = ("physics", "fmi", "models")  # the FMU runtime; no numpy below these


def runtime_package(name):
    """Private package name of the runtime inside ``name``.fmu.

    Every FMU carries its own copy under its own name: FMUs loaded into one Python process
    (fmpy runs them in the host interpreter) then never share modules, and a host's own
    mechfmu, or an FMU extracted earlier and since deleted, cannot shadow this one's code.
    """
    return f"mechfmu_fmu_{name}"


def _stage_runtime(target):
    """Copy the FMU runtime subset of mechfmu into the package folder ``target``."""
    target.mkdir()
    shutil.copy2(PACKAGE_ROOT / "__init__.py", target)
    for package in FMU_PACKAGES:
        shutil.copytree(PACKAGE_ROOT / package, target / package,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))


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


def build_model(name, out_dir, staging, null=False):
    """Build ``name`` (a key of MODELS) into ``out_dir``/``name``.fmu; return its path.

    null=True builds ``out_dir``/``name``Null.fmu instead: the same variables, parameters and
    initialisation, but a do_step that returns at once, so its outputs keep the values of
    initialisation (the baseline of the model-cost benchmark, mechfmu.bench).
    """
    module = MODELS[name]
    importlib.import_module(module)  # fail early, with a Python traceback, on a broken model
    fmu_name = null_name(name) if null else name
    folder = staging / fmu_name
    folder.mkdir()
    package = folder / runtime_package(fmu_name)
    _stage_runtime(package)
    inner_module = module.replace("mechfmu.", f"{package.name}.", 1)
    # The entry module must not be named like the model: fmpy puts a module of its own
    # under sys.modules[model name], so a second load of the FMU would import that one.
    script = folder / f"mechfmu_entry_{fmu_name}.py"
    script.write_text(_entry_script(name, fmu_name, inner_module))
    built = FmuBuilder.build_FMU(script, dest=staging / f"out_{fmu_name}",
                                 project_files=[package], canGetAndSetFMUstate=True)
    _patch_linux_binary(built, fmu_name)
    final = Path(out_dir) / f"{fmu_name}.fmu"
    os.replace(built, final)  # atomic: a reader never sees a half-written FMU
    return final


def _patch_linux_binary(fmu, name):
    """Rewrite the FMU with its Linux binary patched (see binary_patch); report the outcome."""
    member = f"binaries/linux64/{name}.so"
    with zipfile.ZipFile(fmu) as archive:
        entries = [(info, archive.read(info)) for info in archive.infolist()]
    patched_fmu = fmu.with_suffix(".patched")
    with zipfile.ZipFile(patched_fmu, "w", zipfile.ZIP_DEFLATED) as archive:
        for info, data in entries:
            if info.filename == member:
                data, message = patch_exit_finaliser(data)
                print(f"{name}: {message}")
            archive.writestr(info, data)
    os.replace(patched_fmu, fmu)


def build_all(out_dir, names=None, null=False):
    """Build the named models (default: all of MODELS); return the FMU paths.

    null=True builds their null variants (``<name>Null.fmu``, see build_model).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="mechfmu_build_", dir=out_dir) as temp:
        return [build_model(name, out_dir, Path(temp), null) for name in (names or MODELS)]
