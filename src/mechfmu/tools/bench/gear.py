"""The gear scenes the benchmarks share: loading, longer variants, the closed form's inputs."""

from __future__ import annotations

from typing import TYPE_CHECKING
import dataclasses

import numpy as np

from ...cosim.scene import find_file, load_scene
from ...references import landing_gear
from ..scene_references import retraction_arguments

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from ...cosim.scene import Scene
    from numpy import ndarray

KINEMATIC_SCENE = "gear_retraction"  # PistonActuator -> LandingGear, motion drive
DYNAMIC_SCENE = "gear_retraction_dynamic"  # LandingGear alone, all six effects, radau
PISTON_INPUTS = ("piston_extension", "piston_speed", "piston_acceleration")
GEAR_OUTPUTS = ("gear_angle", "gear_angular_velocity", "gear_angular_acceleration")


def load_named_scene(scene_dir: str, name: str) -> Scene:
    return load_scene(find_file(name, (scene_dir,)))


def with_stop_time(scene: Scene, stop_time: float) -> Scene:
    """The same scene over [start_time, stop_time] s (the actuator holds its end after
    its stroke, so a longer gear scene keeps stepping in range)."""
    return dataclasses.replace(scene, stop_time=float(stop_time))


def piston_table(scene: Scene) -> ndarray:
    """fmpy input table of a gear scene: time (s) and the piston's extension (m), speed
    (m/s) and acceleration (m/s^2) from the closed form at every communication point."""
    times, _, _, *stroke = retraction_arguments(scene)
    table = np.zeros(
        len(times), dtype=[("time", float)] + [(name, float) for name in PISTON_INPUTS]
    )
    table["time"] = times
    for name, values in zip(PISTON_INPUTS, landing_gear.stroke(times, *stroke)):
        table[name] = values
    return table
