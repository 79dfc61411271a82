"""Benchmark 4: the floor, the gear's closed form in numpy against its FMU run.

The same numbers two ways: references.landing_gear.retraction over every sample time of
gear_retraction (one vectorised numpy call), and the master's stepping loop over the same
scene (two FMUs, one Python round trip per FMI call). The ratio is what the FMI boundary
costs for a model this cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import time

from ...cosim.master import Simulation
from ...references import landing_gear
from .gear import KINEMATIC_SCENE, load_named_scene, retraction_arguments
from .report import Row, ratio_row
from .timing import side_by_side_medians

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from numpy import ndarray

BENCHMARK = "floor"
MILLI = 1e3
CLOSED_FORM_CALLS = 20  # per sample: one call takes ~0.1 ms, near the clock's resolution


def _closed_form_seconds(
    arguments: tuple[ndarray, float, float, float, float, float, str],
) -> float:
    started = time.perf_counter()
    for _ in range(CLOSED_FORM_CALLS):
        landing_gear.retraction(*arguments)
    return (time.perf_counter() - started) / CLOSED_FORM_CALLS


def _loop_seconds(simulation: Simulation) -> float:
    """The master's stepping loop over the scene (s), without extraction and set-up."""
    return simulation.run().meta["loop_time_s"]


def measure(scene_dir: str, fmu_dir: str, repeats: int) -> list[Row]:
    """Rows of benchmark 4: closed form (ms), FMU loop (ms), their ratio."""
    scene = load_named_scene(scene_dir, KINEMATIC_SCENE)
    arguments = retraction_arguments(scene)
    simulation = Simulation(scene, fmu_dir)
    medians = side_by_side_medians(
        {
            "closed form": lambda: {"time": _closed_form_seconds(arguments)},
            "fmu": lambda: {"time": _loop_seconds(simulation)},
        },
        repeats,
    )
    span = f"{scene.steps + 1} samples of {KINEMATIC_SCENE}"
    closed_form = Row(
        BENCHMARK,
        "closed form (numpy)",
        medians["closed form"]["time"] * MILLI,
        "ms",
        repeats,
        notes=f"references.landing_gear.retraction; {span}; "
        f"mean of {CLOSED_FORM_CALLS} calls per repeat",
    )
    fmu = Row(
        BENCHMARK,
        "FMU run (master loop)",
        medians["fmu"]["time"] * MILLI,
        "ms",
        repeats,
        notes=f"the stepping loop of Simulation.run (meta loop_time_s); {span}",
    )
    return [closed_form, fmu, ratio_row("FMU / closed form", fmu, closed_form)]
