"""Documentation generated from the model declarations (one source of truth).

``mechfmu docs`` prints the FMU interface tables; the docs site (``make docs``) calls the same
command for each model page's table and for the plot of each page's reference scene, drawn from
the committed reference CSV with the units the models declare.
"""

from typing import Any
from pathlib import Path

from ..cosim.results import write_plot
from ..cosim.scene import load_scene
from ..io import read_result
from ..packaging.describe import TYPES, declared_units, interface_table, model_class  # noqa: F401
from ..runtime.models import MODELS


def interface_tables(names: Any = None) -> str:
    """Markdown: the interface table of each named FMU (every registered FMU by default)."""
    return "\n\n".join(interface_table(name) for name in (names or MODELS))


def reference_plot(scene_path: Any, out_path: Any) -> Path:
    """Plot the committed reference CSV of the scene at ``scene_path`` into the PNG
    ``out_path``: one panel per column against time (s), labelled with its declared unit."""
    scene = load_scene(scene_path)
    if scene.reference is None:
        raise ValueError(f"scene {scene.name} ({scene_path}) names no reference CSV")
    table = read_result(scene.reference)
    return write_plot(
        out_path, table.index.to_numpy(), table, declared_units(scene), f"{scene.name}: reference"
    )
