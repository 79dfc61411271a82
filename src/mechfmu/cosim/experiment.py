"""The times of a run the scene does not give: the FMUs' DefaultExperiment (host side).

A scene may leave out ``start_time``, ``stop_time`` and ``step``; each missing time is then
the one its FMUs' model descriptions give in ``<DefaultExperiment>`` (startTime, stopTime,
stepSize), when every FMU that gives it agrees (start time 0 s when none does). An FMU that
gives none is no constraint. A missing stop time or step that no FMU gives, or FMUs that
disagree, is a SceneError naming the values.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

from .scene import SceneError, check_times

if TYPE_CHECKING:  # annotations only
    from fmpy.model_description import ModelDescription

    from .scene import Scene

# scene key -> DefaultExperiment attribute (fmpy's names)
ATTRIBUTES = {"start_time": "startTime", "stop_time": "stopTime", "step": "stepSize"}


def _given(descriptions: dict[str, ModelDescription], key: str) -> dict[str, float]:
    """component -> the DefaultExperiment value of scene time ``key`` it gives."""
    values = {}
    for name, description in descriptions.items():
        experiment = description.defaultExperiment
        value: Any = getattr(experiment, ATTRIBUTES[key], None) if experiment else None
        if value is not None:
            values[name] = float(value)
    return values


def resolved_times(scene: Scene, descriptions: dict[str, ModelDescription]) -> Scene:
    """``scene`` with every time it leaves out taken from the FMUs (``descriptions`` by
    component name), checked like the scene's own times."""
    if not scene.missing_times:
        return scene
    where = str(scene.path)
    times = {key: getattr(scene, key) for key in ATTRIBUTES}
    for key in scene.missing_times:
        given = _given(descriptions, key)
        if len(set(given.values())) > 1:
            listed = ", ".join(f"{name}: {value!r} s" for name, value in given.items())
            raise SceneError(
                f"{where}: no {key} in the scene, and the FMUs' DefaultExperiment disagree "
                f"({listed}); give {key} in the scene"
            )
        if given:
            times[key] = next(iter(given.values()))
        elif key == "start_time":
            times[key] = 0.0
        else:
            raise SceneError(
                f"{where}: no {key} in the scene, and no FMU gives one in its "
                f"DefaultExperiment ({ATTRIBUTES[key]}); give {key} in the scene"
            )
    start, stop, step = check_times(where, times["start_time"], times["stop_time"], times["step"])
    assert math.isfinite(start + stop + step)
    return dataclasses.replace(scene, start_time=start, stop_time=stop, step=step, missing_times=())
