"""Run the ``mechfmu`` command line in a child process, as a user's shell would."""

import subprocess
import sys
from typing import Any


def run_mechfmu(
    *arguments: Any, timeout: float = 120, **options: Any
) -> subprocess.CompletedProcess:
    """``python -m mechfmu ARGUMENTS`` (each argument str()-ed), its output captured as text;
    ``options`` go to subprocess.run (cwd, env, ...). Never raises for a non-zero exit."""
    return subprocess.run(
        [sys.executable, "-m", "mechfmu", *(str(argument) for argument in arguments)],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        **options,
    )
