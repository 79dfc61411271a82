"""Run the ``mechfmu`` command line, or a script of sims/, in a child process, as a user's
shell would."""

import subprocess
import sys
from pathlib import Path
from typing import Any

SIMS = Path(__file__).resolve().parents[1] / "sims"


def run_mechfmu(
    *arguments: Any, timeout: float = 120, **options: Any
) -> subprocess.CompletedProcess:
    """``python -m mechfmu ARGUMENTS`` (each argument str()-ed), its output captured as text;
    ``options`` go to subprocess.run (cwd, env, ...). Never raises for a non-zero exit."""
    return _run([sys.executable, "-m", "mechfmu", *arguments], timeout, options)


def run_script(
    name: str, *arguments: Any, timeout: float = 300, **options: Any
) -> subprocess.CompletedProcess:
    """``python sims/NAME ARGUMENTS``, as run_mechfmu runs the command line."""
    return _run([sys.executable, SIMS / name, *arguments], timeout, options)


def _run(
    command: list[Any], timeout: float, options: dict[str, Any]
) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(word) for word in command],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        **options,
    )
