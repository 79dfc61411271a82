"""A scene that records what its animation needs: the geometry effect on, its outputs kept."""

from __future__ import annotations

import copy
from pathlib import Path

from ...cosim.scene import Scene, SceneError
from ...runtime.fmi.geometry import GEOMETRY
from .columns import MECHANISMS, geometry_outputs


def with_geometry(scene: Scene) -> Scene:
    """A copy of ``scene`` with the geometry effect on in every component whose model has
    it (a registered mechanism model, named or as ``<Model>.fmu``) and its outputs added to
    the recorded ones. SceneError when no component has the effect."""
    chosen = copy.deepcopy(scene)
    added: list[str] = []
    for spec in chosen.components.values():
        outputs = geometry_outputs(Path(spec.fmu).stem)
        if not outputs:
            continue
        spec.parameters.pop(GEOMETRY, None)
        if GEOMETRY not in spec.effects:
            spec.effects.append(GEOMETRY)
        added += [f"{spec.name}.{name}" for name in outputs]
    if not added:
        raise SceneError(
            f"scene {scene.name}: no component has the {GEOMETRY!r} effect to animate (the "
            f"mechanism models have it: {', '.join(MECHANISMS)})"
        )
    if chosen.record is not None:
        chosen.record = chosen.record + [name for name in added if name not in chosen.record]
    return chosen
