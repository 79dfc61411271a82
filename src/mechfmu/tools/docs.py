"""Documentation generated from the model declarations (one source of truth).

``mechfmu docs`` prints the FMU interface tables; the docs site (``make docs``) calls the same
command for each model page's table and for the plot of each page's reference scene, drawn from
the committed reference CSV with the units the models declare.
"""

from typing import Any
import importlib
from pathlib import Path

from ..cosim.results import write_plot
from ..cosim.scene import load_scene
from ..runtime.fmi.slave import MechSlave
from ..io import read_result
from ..runtime.models import MODELS

TYPES = {float: "Real", int: "Integer", bool: "Boolean", str: "String"}
TABLE_HEADER = (
    "| variable | causality | type | unit | range | default | meaning |\n"
    "|---|---|---|---|---|---|---|"
)


def _range(variable: Any):
    if variable.values:
        return " / ".join(f"`{v}`" for v in variable.values)
    if variable.min is None and variable.max is None:
        return ""
    low = "-inf" if variable.min is None else f"{variable.min:g}"
    high = "inf" if variable.max is None else f"{variable.max:g}"
    return f"[{low}, {high}]"


def _start(variable: Any) -> str:
    if variable.causality == "output":
        return ""
    if variable.kind is float:
        return f"{variable.start:.6g}"
    return f"`{str(variable.start).lower() if variable.kind is bool else variable.start}`"


def model_class(name: str) -> type[MechSlave]:
    """The slave class of the FMU ``name`` (a key of the model registry)."""
    try:
        module = MODELS[name]
    except KeyError:
        raise ValueError(f"unknown model {name!r}; models: {', '.join(MODELS)}") from None
    return getattr(importlib.import_module(module), name)


def interface_table(name: str) -> str:
    """Markdown for one FMU: a heading, its description and one row per declared variable
    (name, causality, type, SI unit, range, default, meaning), in declaration order."""
    model = model_class(name)
    rows = [
        f"| `{v.name}` | {v.causality} | {TYPES[v.kind]} | {v.unit or ''} | {_range(v)} | "
        f"{_start(v)} | {v.description.replace('|', chr(92) + '|')} |"
        for v in model.VARIABLES
    ]
    return "\n".join([f"### `{name}.fmu`", "", model.description + ".", "", TABLE_HEADER, *rows])


def interface_tables(names: Any = None) -> str:
    """Markdown: the interface table of each named FMU (every registered FMU by default)."""
    return "\n\n".join(interface_table(name) for name in (names or MODELS))


def declared_units(scene: Any) -> dict:
    """``component.variable`` -> its declared unit, for every component of a parsed scene
    whose FMU is a registered model (named, or a path to ``<Model>.fmu``)."""
    units = {}
    for component in scene.components.values():
        model = Path(component.fmu).stem
        if model in MODELS:
            for variable in model_class(model).VARIABLES:
                if variable.unit:
                    units[f"{component.name}.{variable.name}"] = variable.unit
    return units


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
