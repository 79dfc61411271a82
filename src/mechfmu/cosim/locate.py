"""Where the built FMUs are: one rule for every command, the API, the scripts and sweeps.

A model named in a scene (``fmu = "LandingGear"``) is the file ``LandingGear.fmu`` in the
first of these folders that holds every model the run needs:

1. the folder given (``--fmu-dir DIR``, ``fmu_dir=DIR``): only there, when given;
2. ``$MECHFMU_FMU_DIR`` (the Makefile sets it: fmus-X.Y for another interpreter's venv);
3. ``./fmus`` in the current folder;
4. the FMUs ``make run`` built for the source checkout mechfmu runs from (an editable
   install): its ``fmus-X.Y`` for this Python, then its ``fmus``;
5. the user cache that ``mechfmu build`` fills by default:
   ``$XDG_CACHE_HOME/mechfmu/<version>-py<X.Y>`` (``~/.cache`` without XDG_CACHE_HOME), one
   per mechfmu version and Python version, since an FMU is built for the interpreter that
   builds it.

When none holds them, the SceneError lists every folder tried and how to build the FMUs.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from pathlib import Path

from .. import __version__
from . import limits
from .scene import PACKAGE_ROOT, Scene, SceneError

# the source checkout of an editable install (src/mechfmu -> the repository), or None
CHECKOUT = PACKAGE_ROOT.parents[1] if PACKAGE_ROOT.parent.name == "src" else None
PYTHON_VERSION = f"{sys.version_info[0]}.{sys.version_info[1]}"


def user_cache() -> Path:
    """The user's FMU cache for this mechfmu and this Python (``mechfmu build``'s default
    output): ``$XDG_CACHE_HOME/mechfmu/<version>-py<X.Y>``, ``~/.cache/...`` without it."""
    root = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "mechfmu" / f"{__version__}-py{PYTHON_VERSION}"


def search_path(fmu_dir: str | os.PathLike | None = None) -> list[tuple[str, Path]]:
    """The folders searched for FMUs, in order, each with what it is: only ``fmu_dir`` when
    given; otherwise $MECHFMU_FMU_DIR (when set), ./fmus, the checkout's, the user cache."""
    if fmu_dir is not None and str(fmu_dir) != "":
        return [("--fmu-dir", Path(fmu_dir))]
    folders = []
    if os.environ.get("MECHFMU_FMU_DIR"):
        folders.append(("$MECHFMU_FMU_DIR", Path(os.environ["MECHFMU_FMU_DIR"])))
    folders.append(("./fmus", Path.cwd() / "fmus"))
    if CHECKOUT is not None:
        folders.append(
            (f"this checkout's, Python {PYTHON_VERSION}", CHECKOUT / f"fmus-{PYTHON_VERSION}")
        )
        folders.append(("this checkout's (make run)", CHECKOUT / "fmus"))
    folders.append(("the user cache (mechfmu build)", user_cache()))
    return folders


def fmu_folder(
    models: Iterable[str], fmu_dir: str | os.PathLike | None = None, what: str = ""
) -> Path:
    """The first folder of ``search_path(fmu_dir)`` that holds ``<model>.fmu`` for every one
    of ``models``; SceneError listing each folder tried (and ``what`` needs them: 'scene
    gear_retraction') otherwise. Given ``fmu_dir``, that folder (its missing FMUs are named
    where they are loaded)."""
    models = sorted(set(models))
    folders = search_path(fmu_dir)
    if fmu_dir is not None and str(fmu_dir) != "":
        return folders[0][1]
    for _, folder in folders:
        # file_problem, not is_file(): a name too long for the file system raises OSError
        if all(limits.file_problem(folder / f"{model}.fmu", None) is None for model in models):
            return folder
    tried = "; ".join(f"{label}: {folder}" for label, folder in folders)
    needed = ", ".join(limits.message_text(f"{model}.fmu", 80) for model in models)
    raise SceneError(
        f"{what + ': ' if what else ''}FMU(s) {needed} not found in any of the folders "
        f"searched ({tried}); build them with 'mechfmu build' (into the user cache) or "
        f"'make run' in the source checkout, or give the folder with --fmu-dir DIR "
        f"(fmu_dir=DIR in Python)"
    )


def scene_models(scene: Scene) -> list[str]:
    """The models ``scene``'s components name (not those given as .fmu paths)."""
    return sorted({spec.fmu for spec in scene.components.values() if not spec.fmu.endswith(".fmu")})


def scene_fmu_folder(scene: Scene, fmu_dir: str | os.PathLike | None = None) -> Path:
    """fmu_folder for the models ``scene`` names."""
    return fmu_folder(scene_models(scene), fmu_dir, f"scene {scene.name}")
