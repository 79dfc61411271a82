"""Imported by name inside sweep worker processes (tests/test_sweep_faults.py): a run_point
that kills its own worker process on chosen points, as the OOM killer or a crashing FMU
would."""

import os
from pathlib import Path

from mechfmu.tools import sweep

REAL_RUN_POINT = sweep.run_point  # bound before the test replaces sweep.run_point

ALWAYS = "MECHFMU_TEST_KILL_ALWAYS"  # comma-separated point indices: die on every attempt
ONCE = "MECHFMU_TEST_KILL_ONCE"  # "index:marker file": die the first time only


def run_point_or_die(index, *arguments):
    always = {int(text) for text in os.environ.get(ALWAYS, "").split(",") if text}
    if index in always:
        os._exit(70)
    once = os.environ.get(ONCE)
    if once:
        doomed, marker = once.split(":", 1)
        if index == int(doomed):
            try:
                os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            except FileExistsError:
                pass
            else:
                os._exit(70)
    return REAL_RUN_POINT(index, *arguments)


def marker_path(folder):
    return str(Path(folder) / "killed-once")
