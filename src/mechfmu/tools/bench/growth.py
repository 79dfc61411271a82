"""Benchmark 7: how the cost grows with the simulated time.

The kinematic gear scene (gear_retraction: PistonActuator -> LandingGear; the actuator
holds its end after its stroke, so a longer scene keeps stepping in range) at 1, 2, 4 and
8 times a base stop time, at the scene's step: the wall time of the master's stepping loop
(``meta['loop_time_s']``) of each, and its ratio to the 1x run. Linear growth gives ratios
2, 4 and 8; the per-step ratio of the 8x run to the 1x run (target at most 1.25) says
whether a step gets dearer as a run gets longer (e.g. recording that copies its table).
"""

from typing import Any
from ...cosim.master import Simulation
from .gear import KINEMATIC_SCENE, load_named_scene, with_stop_time
from .report import Row, Target, ratio_row
from .timing import side_by_side_medians

BENCHMARK = "growth"
FACTORS = (1, 2, 4, 8)
TARGET = Target(1.25, "<= 1.25")  # linear: a step at 8x the length costs what it costs at 1x
MILLI, MICRO = 1e3, 1e6


def measure(scene_dir: Any, fmu_dir: Any, repeats: int, base_stop_time: float) -> list:
    """Rows of benchmark 7: loop wall time (ms) at each factor of ``base_stop_time`` (s),
    the ratios to the 1x run, and the per-step ratio 8x / 1x."""
    scene = load_named_scene(scene_dir, KINEMATIC_SCENE)
    scenes = {k: with_stop_time(scene, scene.start_time + k * base_stop_time) for k in FACTORS}
    simulations = {k: Simulation(s, fmu_dir) for k, s in scenes.items()}
    medians = side_by_side_medians(
        {
            k: (lambda simulation=simulation: {"loop": simulation.run().meta["loop_time_s"]})
            for k, simulation in simulations.items()
        },
        repeats,
    )
    times = {k: medians[k]["loop"] for k in FACTORS}
    loops = {
        k: Row(
            BENCHMARK,
            f"{k}x stop time: loop",
            times[k] * MILLI,
            "ms",
            repeats,
            notes=f"{KINEMATIC_SCENE} over {k * base_stop_time:g} s, "
            f"{scenes[k].steps} steps of {scene.step:g} s; stepping loop "
            f"(meta loop_time_s)",
        )
        for k in FACTORS
    }
    rows = list(loops.values())
    rows += [
        ratio_row(f"{k}x / 1x stop time", loops[k], loops[1], notes=f"linear: {k}")
        for k in FACTORS[1:]
    ]
    last = FACTORS[-1]
    per_step = {
        k: Row(
            BENCHMARK,
            f"{k}x stop time: per step",
            times[k] / scenes[k].steps * MICRO,
            "us",
            repeats,
            notes=f"{k}x stop time: loop / {scenes[k].steps} steps",
        )
        for k in (1, last)
    }
    rows += [
        per_step[1],
        per_step[last],
        ratio_row(f"per step, {last}x / 1x", per_step[last], per_step[1], TARGET, "linear: 1"),
    ]
    return rows
