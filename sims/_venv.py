"""The sims scripts' entry: ``mechfmu.cli.script_main``, found in this clone's ``.venv`` when
the python that runs the script does not have mechfmu.

``make run`` installs mechfmu into the clone's ``.venv``; a user who then types
``python sims/run_gear.py`` without activating it would get a ModuleNotFoundError. The script
is run again by the venv's python instead (the same arguments), or, without a venv, one line
says what to do. Standard library only: it runs before mechfmu is importable.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

VENV = Path(__file__).resolve().parent.parent / ".venv"


def _venv_python() -> Path | None:
    """The clone's venv python, or None when there is none or it is the one running."""
    python = VENV / "bin" / "python"
    if not python.exists() or Path(sys.prefix).resolve() == VENV.resolve():
        return None
    return python


try:
    from mechfmu.cli import script_main
except ModuleNotFoundError as missing:
    if missing.name != "mechfmu":
        raise
    python = _venv_python()
    if python is None:
        raise SystemExit(
            f"{Path(sys.argv[0]).name}: mechfmu is not installed for {sys.executable}; run "
            f"'make run' in {VENV.parent} first (it creates .venv), or activate the venv "
            f"that has it"
        ) from None
    os.execv(str(python), [str(python), *sys.argv])

__all__ = ["script_main"]
