"""What makes an FMU describe itself (host side, at build time).

For every model of the registry the build adds, from one source each:

- ``documentation/index.html``: the model's docs page (docs/models/<model>.md of a source
  checkout: its equations, the variable table with units generated from the declarations,
  the plot of its reference scene), or, where the package runs without the docs, the model's
  description, variable table and plot;
- a picture: ``model.png`` (FMI 2.0) or ``terminalsAndIcons/icon.png`` (FMI 3.0), the model's
  outputs in its reference scene;
- in modelDescription.xml, ``version`` (the package's version) and a ``DefaultExperiment``
  (start, stop time and step of the model's reference scene: REFERENCE_SCENES).

The reference scenes' CSVs are the closed forms (``mechfmu references``), never an FMU run.
"""

from __future__ import annotations

import csv
import functools
import html
import importlib
import re
import tempfile
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

from .. import __version__
from ..cosim.results import write_plot
from ..cosim.scene import SCENE_DIR, Scene, load_scene
from ..runtime.fmi.slave import MechSlave
from ..runtime.models import MODELS

# model -> its reference scene: the first scene plotted on its docs page (a test checks it)
REFERENCE_SCENES = {
    "LandingGear": "gear_retraction",
    "HydraulicActuator": "gear_retraction_dynamic",
    "PistonActuator": "gear_retraction",
    "Suspension": "suspension_load_ramp",
    "LoadProfile": "suspension_load_ramp",
    "RoadProfile": "suspension_road_bump",
    "CrankDrive": "four_bar_solver_crossed",
    "FourBar": "four_bar_crank_rocker",
    "SliderCrank": "slider_crank_offset",
    "CamshaftDrive": "valve_float",
    "ValveTrain": "valve_train",
    "ValveSpring": "valve_train_dynamic",
}
DOCS_MODELS = Path(__file__).resolve().parents[3] / "docs" / "models"  # in a source checkout
MARKER = re.compile(r"^<!-- mechfmu:(interface|reference-plot) (\S+) -->$", re.MULTILINE)
TYPES = {float: "Real", int: "Integer", bool: "Boolean", str: "String"}
TABLE_HEADER = (
    "| variable | causality | type | unit | range | default | meaning |\n"
    "|---|---|---|---|---|---|---|"
)
PICTURE = {2: "model.png", 3: "terminalsAndIcons/icon.png"}


# --- the variable table (also the docs site's, through tools/docs.py) ----------------------


def _range(variable: Any) -> str:
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


INDEX = "documentation/index.html"  # the page an FMU shows (FMI 2.0 and 3.0)


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


# --- modelDescription.xml -------------------------------------------------------------------


def default_experiment(name: str) -> dict[str, str]:
    """startTime, stopTime and stepSize (s) of the model's reference scene, as XML attributes
    (floats written exactly)."""
    scene = load_scene(SCENE_DIR / f"{REFERENCE_SCENES[name]}.toml")
    return {
        "startTime": repr(scene.start_time),
        "stopTime": repr(scene.stop_time),
        "stepSize": repr(scene.step),
    }


def described(description: bytes, name: str, experiment: dict[str, float] | None = None) -> bytes:
    """``description`` (a modelDescription.xml) with the package version as its model version
    and the reference scene's DefaultExperiment (``experiment``: attributes to use instead,
    e.g. a finer stepSize), placed where both schemas want it (after LogCategories, before
    the variables)."""
    root = ElementTree.fromstring(description)
    root.set("version", __version__)
    for old in root.findall("DefaultExperiment"):
        root.remove(old)
    attributes = {
        **default_experiment(name),
        **{key: repr(float(value)) for key, value in (experiment or {}).items()},
    }
    element = ElementTree.Element("DefaultExperiment", attributes)
    element.tail = "\n\t"
    anchor = root.find("ModelVariables")
    children = list(root)
    position = children.index(anchor) if anchor is not None else len(children)
    if position > 0 and children[position - 1].tag == "VendorAnnotations":
        position -= 1
    root.insert(position, element)
    text = ElementTree.tostring(root, encoding="unicode")
    return ('<?xml version="1.0" encoding="UTF-8"?>\n' + text + "\n").encode("utf-8")


# --- pictures and documentation ---------------------------------------------------------------


def _reference_table(scene_name: str) -> tuple[Scene, list[str], list[list[float]]]:
    """(scene, header, rows) of a shipped scene and its reference CSV (the rows as floats:
    time first, SI units)."""
    scene = load_scene(SCENE_DIR / f"{scene_name}.toml")
    assert scene.reference is not None, f"scene {scene_name} names no reference CSV"
    with open(scene.reference, newline="") as handle:
        rows = list(csv.reader(handle))
    return scene, rows[0], [[float(x) for x in row] for row in rows[1:] if row]


def _reference_columns(name: str) -> tuple[list[float], dict[str, list[float]], dict[str, str]]:
    """(times, columns, units) of the model's own outputs in its reference scene's CSV (every
    column when none is the model's)."""
    scene, header, values = _reference_table(REFERENCE_SCENES[name])
    components = [c.name for c in scene.components.values() if Path(c.fmu).stem == name]
    wanted = [
        i for i, column in enumerate(header) if column.split(".", 1)[0] in components
    ] or list(range(1, len(header)))
    units = {v.name: v.unit for v in model_class(name).VARIABLES if v.unit}
    columns = {header[i]: [row[i] for row in values] for i in wanted[:4]}
    column_units = {column: units.get(column.split(".", 1)[-1], "") for column in columns}
    return [row[0] for row in values], columns, column_units


def picture(name: str, folder: Path) -> bytes:
    """A PNG of the model's outputs in its reference scene (at most four panels)."""
    times, columns, units = _reference_columns(name)
    target = folder / f"{name}_reference.png"
    write_plot(target, times, columns, units, f"{name}: {REFERENCE_SCENES[name]} (reference)")
    return target.read_bytes()


def _page(name: str) -> str | None:
    """The model's docs page (markdown) from a source checkout, or None."""
    marker = f"<!-- mechfmu:interface {name} -->"
    if DOCS_MODELS.is_dir():
        for page in sorted(DOCS_MODELS.glob("*.md")):
            text = page.read_text()
            if marker in text:
                return text
    return None


def _markdown_to_html(text: str) -> str:
    """HTML of a markdown page: python-markdown where installed (the docs extra), else the
    text as it is."""
    try:
        import markdown  # type: ignore[import-untyped]
    except ImportError:
        return f"<pre>{html.escape(text)}</pre>"
    return str(markdown.markdown(text, extensions=["tables", "fenced_code"]))


def documentation(name: str, folder: Path) -> dict[str, bytes]:
    """The FMU's ``documentation/`` members: index.html (the docs page with its markers
    replaced: the variable table, the reference plots as pictures beside it) and the
    pictures."""
    page = _page(name) or (
        f"# {name}\n\n<!-- mechfmu:reference-plot {REFERENCE_SCENES[name]} -->\n\n"
        f"<!-- mechfmu:interface {name} -->\n"
    )
    members: dict[str, bytes] = {}

    def replaced(match: re.Match[str]) -> str:
        kind, argument = match.groups()
        if kind == "interface":
            return interface_table(argument)
        image = f"{argument}.png"
        if f"documentation/{image}" not in members:
            members[f"documentation/{image}"] = _scene_plot(argument, folder)
        return f"![{argument}]({image})"

    text = MARKER.sub(replaced, page)
    # links into the docs site do not resolve inside an FMU: keep their text
    text = re.sub(r"(?<!!)\[([^\]]+)\]\((?!https?:)[^)]*\)", r"\1", text)
    body = _markdown_to_html(text)
    members[INDEX] = _html_page(name, body)
    return members


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


def _scene_plot(scene_name: str, folder: Path) -> bytes:
    """A PNG of a shipped scene's reference CSV, every column against time."""
    scene, header, values = _reference_table(scene_name)
    columns = {column: [row[i] for row in values] for i, column in enumerate(header) if i}
    target = folder / f"{scene_name}.png"
    write_plot(
        target,
        [row[0] for row in values],
        columns,
        declared_units(scene),
        f"{scene_name}: reference",
    )
    return target.read_bytes()


def null_description(name: str) -> dict[str, bytes]:
    """The documentation of ``name``'s null variant (the model-cost benchmark's baseline):
    one page saying what it is."""
    body = (
        f"<h1>{html.escape(name)}Null</h1>\n<p>The null variant of {html.escape(name)}: the same "
        "variables, parameters and initialisation, and a step that does nothing (the baseline "
        "of mechfmu's model-cost benchmark).</p>"
    )
    return {INDEX: _html_page(f"{name}Null", body)}


def _html_page(title: str, body: str) -> bytes:
    """The FMU's documentation/index.html around ``body`` (HTML), UTF-8."""
    page = (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f"<title>{html.escape(title)}</title>\n"
        "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.4}"
        "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:2px 6px;"
        "font-size:90%}img{max-width:100%}code{background:#f4f4f4}</style>\n"
        f"</head>\n<body>\n{body}\n<p><small>mechfmu {__version__}</small></p>\n"
        "</body>\n</html>\n"
    )
    return page.encode("utf-8")


def self_description(name: str, fmi_version: int) -> dict[str, bytes]:
    """Every member that makes ``name``'s FMU describe itself, by its name in the archive
    (the documentation and the picture; the model description is changed by ``described``)."""
    members, image = _rendered(name)
    return {**members, PICTURE[fmi_version]: image}


@functools.lru_cache(maxsize=None)
def _rendered(name: str) -> tuple[dict[str, bytes], bytes]:
    """(documentation members, picture) of model ``name``, rendered once per process: they
    depend on the model alone, and drawing them costs about a second of CPU per model, paid
    otherwise again by each FMI version, variant and build in one process (a test session
    builds every model three times). Callers copy the dict."""
    with tempfile.TemporaryDirectory(prefix="mechfmu_describe_") as folder:
        return documentation(name, Path(folder)), picture(name, Path(folder))
