"""Benchmark 3: what the effects cost, the kinematic gear scene against the full dynamics.

gear_retraction (PistonActuator -> LandingGear, closed forms) and gear_retraction_dynamic
(LandingGear alone, all six effects, radau) over the same simulated time at the same step:
wall time of Simulation.run (extraction and instantiation included, as a user sees it).
"""

from ...cosim.master import Simulation
from .gear import DYNAMIC_SCENE, KINEMATIC_SCENE, load_named_scene, with_stop_time
from .report import Row, Target, ratio_row
from .timing import seconds_of, side_by_side_medians

BENCHMARK = "effects"
TARGET = Target(1.0 / 3.0, "<= 1/3")  # the issue: kinematic at most a third of full dynamics
MILLI = 1e3


def measure(
    scene_dir: str, fmu_dir: str, repeats: int, stop_time: float | None = None
) -> list[Row]:
    """Rows of benchmark 3; ``stop_time`` (s) shortens both scenes (default: as written)."""
    scenes = [load_named_scene(scene_dir, name) for name in (KINEMATIC_SCENE, DYNAMIC_SCENE)]
    if stop_time is not None:
        scenes = [with_stop_time(scene, stop_time) for scene in scenes]
    kinematic, dynamic = scenes
    if (kinematic.start_time, kinematic.stop_time, kinematic.step) != (
        dynamic.start_time,
        dynamic.stop_time,
        dynamic.step,
    ):
        raise ValueError(
            f"{KINEMATIC_SCENE} and {DYNAMIC_SCENE} must cover the same time at "
            f"the same step to be compared"
        )
    simulations = {scene.name: Simulation(scene, fmu_dir) for scene in scenes}
    medians = side_by_side_medians(
        {
            name: (lambda simulation=simulation: {"wall": seconds_of(simulation.run)})
            for name, simulation in simulations.items()
        },
        repeats,
    )
    span = f"{kinematic.stop_time - kinematic.start_time:g} s, {kinematic.steps} steps"
    kinematic_row, dynamic_row = (
        Row(
            BENCHMARK,
            f"{scene.name} ({label})",
            medians[scene.name]["wall"] * MILLI,
            "ms",
            repeats,
            notes=f"wall time of Simulation.run; {span}",
        )
        for scene, label in ((kinematic, "kinematic, 2 FMUs"), (dynamic, "six effects, radau"))
    )
    return [
        kinematic_row,
        dynamic_row,
        ratio_row("kinematic / dynamic", kinematic_row, dynamic_row, TARGET),
    ]
