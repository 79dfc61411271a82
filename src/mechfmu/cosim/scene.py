"""Scenes: declarative TOML files naming components, parameters, connections and outputs.

A scene file looks like::

    name = "gear_retraction"            # optional, defaults to the file name
    description = "..."
    start_time = 0.0                    # s, optional
    stop_time = 3.0                     # s   (all three times optional: what the scene does
    step = 0.01                         # s    not give comes from the FMUs' DefaultExperiment)
    connections = ["actuator.piston_extension -> gear.piston_extension"]
    record = ["gear.gear_angle"]        # optional, defaults to every output
    reference = "reference/gear_retraction.csv"   # optional, relative to the scene file
    coupling = "gauss_seidel"           # optional: gauss_seidel (default) or jacobi

    [check]                             # optional: tolerances against the reference
    rtol = 1e-9                         # (cosim/tolerances.py; default 1e-9, 1e-12)
    atol = 1e-12
    why = "what the tolerance rests on: the measured errors"

    [components.actuator]
    fmu = "PistonActuator"              # a model name (looked up in the FMU folder) or a path
    parameters = { stroke_time = 3.0 }
    inputs = { }                        # fixed values for inputs that are not connected
    effects = ["inertia", "gravity"]    # physical effects to switch on (all others stay off)

String parameters whose name ends in ``_file`` are paths relative to the scene file.
Files are read with tomllib and never evaluated.

The scenes and sweeps shipped with mechfmu are package data (SCENE_DIR, SWEEP_DIR, their
reference CSVs in REFERENCE_DIR); ``find_file`` turns a name such as ``gear_retraction``
into one of them, from any working directory.
"""

import math
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from . import limits
from .files import plain_file_name
from .tolerances import Check, parse_check, refuse_unknown
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib


def refuse_unknown_keys(
    table: dict[str, Any],
    allowed: set[str],
    where: Path | str,
    error: type[Exception] | None = None,
) -> None:
    """Raise ``error`` (default SceneError) naming the keys of the TOML ``table`` that are
    not ``allowed``, at ``where`` (the file, and the table in it)."""
    refuse_unknown(table, allowed, str(where), error or SceneError)


class SceneError(ValueError):
    """A scene that cannot run as written; the message names the offending item."""


@dataclass(frozen=True)
class Connection:
    source: str  # component name
    output: str  # variable name
    target: str
    input: str

    def __str__(self) -> str:
        return f"{self.source}.{self.output} -> {self.target}.{self.input}"


@dataclass
class ComponentSpec:
    name: str
    fmu: str
    parameters: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    effects: list = field(default_factory=list)


@dataclass
class Scene:
    name: str
    path: Path
    stop_time: float
    step: float
    components: dict
    connections: list
    record: list | None = None
    start_time: float = 0.0
    description: str = ""
    reference: Path | None = None
    coupling: str = "gauss_seidel"
    check: Check | None = None  # the [check] table: tolerances against its reference
    # the times the file does not give (NaN here until the master takes them from the FMUs'
    # DefaultExperiment: cosim/experiment.py)
    missing_times: tuple[str, ...] = ()

    @property
    def steps(self) -> int:
        """Number of communication steps from start_time to stop_time."""
        return round((self.stop_time - self.start_time) / self.step)

    def time(self, index: int) -> float:
        """Time of communication point ``index`` (computed, never accumulated)."""
        return self.start_time + index * self.step


_SCENE_KEYS = {
    "name",
    "description",
    "start_time",
    "stop_time",
    "step",
    "connections",
    "record",
    "reference",
    "components",
    "coupling",
    "check",
}
# How the master feeds inputs at each communication step: gauss_seidel gives each component
# the outputs of the components stepped before it in the same step (already at the step's
# end); jacobi gives every component the outputs at the step's start (all in parallel).
COUPLINGS = ("gauss_seidel", "jacobi")
_COMPONENT_KEYS = {"fmu", "parameters", "inputs", "effects"}
TIME_KEYS = ("start_time", "stop_time", "step")


def _number(data: dict[str, Any], key: str, where: str, default: float | None = None) -> float:
    value = data.get(key, default)
    if value is None:
        raise SceneError(f"{where}: missing '{key}'")
    number = limits.finite_float(value)
    if number is None:
        raise SceneError(f"{where}: '{key}' = {limits.shortened(value)} must be a finite number")
    return number


def _text(data: dict[str, Any], key: str, where: str, default: str) -> str:
    """The string ``data[key]`` (``default`` when absent); SceneError naming it otherwise."""
    value = data.get(key, default)
    problem = (
        limits.value_problem(value)
        if isinstance(value, str)
        else f"must be a string, got {type(value).__name__}"
    )
    if problem:
        raise SceneError(f"{where}: {key} = {limits.shortened(value)} {problem}")
    return value


def _values(spec: dict[str, Any], key: str, where: str) -> dict[str, Any]:
    """A copy of the table ``spec[key]`` ({} when absent) of name = value (a number, a bool
    or a string within mechfmu.cosim.limits); SceneError naming the item otherwise."""
    table = spec.get(key, {})
    if not isinstance(table, dict):
        raise SceneError(
            f"{where}: '{key}' must be a table of name = value, got "
            f"{type(table).__name__} {limits.shortened(table)}"
        )
    for name, value in table.items():
        problem = limits.value_problem(value)
        if problem:
            raise SceneError(f"{where}: {key}.{name} = {limits.shortened(value)} {problem}")
    return dict(table)


def split_name(text: str, where: str) -> tuple[str, str]:
    """'component.variable' -> (component, variable)."""
    if not isinstance(text, str) or "." not in text:
        raise SceneError(f"{where}: {text!r} is not of the form component.variable")
    component, variable = text.split(".", 1)
    if not component or not variable:
        raise SceneError(f"{where}: {text!r} is not of the form component.variable")
    return component, variable


def _connection(text: str, where: str) -> Connection:
    if not isinstance(text, str) or text.count("->") != 1:
        raise SceneError(
            f"{where}: {text!r} is not of the form 'component.output -> component.input'"
        )
    left, right = (part.strip() for part in text.split("->"))
    return Connection(*split_name(left, where), *split_name(right, where))


def check_times(
    where: str, start_time: float, stop_time: float, step: float
) -> tuple[float, float, float]:
    """(start_time, stop_time, step) in s, checked: step > 0, stop after start, a whole
    number of communication steps between them, at most mechfmu.cosim.limits.MAX_STEPS;
    SceneError naming ``where`` otherwise."""
    if step <= 0.0:
        raise SceneError(f"{where}: step = {step!r} s must be > 0")
    if stop_time <= start_time:
        raise SceneError(
            f"{where}: stop_time = {stop_time!r} s must exceed start_time = {start_time!r} s"
        )
    ratio = (stop_time - start_time) / step
    if not ratio <= limits.MAX_STEPS:  # also an infinite ratio (a span beyond a double)
        raise SceneError(
            f"{where}: (stop_time - start_time) / step = {ratio!r} communication steps, "
            f"more than the limit of {limits.MAX_STEPS:.0e}"
        )
    if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
        raise SceneError(
            f"{where}: (stop_time - start_time) / step = {ratio!r} is not a "
            f"whole number of communication steps"
        )
    return start_time, stop_time, step


def parse_scene(data: dict[str, Any], path: Path) -> Scene:
    """Build a Scene from parsed TOML ``data``; ``path`` locates relative files."""
    path = Path(path)
    where = str(path)
    refuse_unknown_keys(data, _SCENE_KEYS, where)
    # A scene with a stop time and a step starts at its start_time or 0 s; one without either
    # takes every time it leaves out from its FMUs (cosim/experiment.py).
    missing = tuple(key for key in TIME_KEYS if key not in data)
    if missing == ("start_time",):
        missing, data = (), {**data, "start_time": 0.0}
    if missing:
        start_time, stop_time, step = (
            math.nan if key in missing else _number(data, key, where) for key in TIME_KEYS
        )
    else:
        start_time, stop_time, step = check_times(
            where,
            _number(data, "start_time", where),
            _number(data, "stop_time", where),
            _number(data, "step", where),
        )
    components = {}
    raw_components = data.get("components")
    if not isinstance(raw_components, dict) or not raw_components:
        raise SceneError(f"{where}: needs at least one [components.NAME] table")
    for name, spec in raw_components.items():
        cwhere = f"{where}: component {name!r}"
        if not isinstance(spec, dict):
            raise SceneError(f"{cwhere} must be a table")
        refuse_unknown_keys(spec, _COMPONENT_KEYS, cwhere)
        if not isinstance(spec.get("fmu"), str) or not spec["fmu"]:
            raise SceneError(f"{cwhere}: missing 'fmu' (a model name or an .fmu path)")
        problem = limits.value_problem(spec["fmu"])
        if problem:
            raise SceneError(f"{cwhere}: fmu = {limits.shortened(spec['fmu'])} {problem}")
        parameters = _values(spec, "parameters", cwhere)
        for key, value in parameters.items():
            if key.endswith("_file") and isinstance(value, str) and value:
                parameters[key] = str((path.parent / value).resolve())
        inputs = _values(spec, "inputs", cwhere)
        effects = spec.get("effects", [])
        if not isinstance(effects, list) or not all(isinstance(e, str) for e in effects):
            raise SceneError(f"{cwhere}: 'effects' must be a list of effect names")
        components[name] = ComponentSpec(name, spec["fmu"], parameters, inputs, list(effects))
    raw_connections = data.get("connections", [])
    if not isinstance(raw_connections, list):
        raise SceneError(
            f"{where}: 'connections' must be a list of 'component.output -> "
            f"component.input' strings, got {limits.shortened(raw_connections)}"
        )
    connections = [
        _connection(text, f"{where}: connections[{i}]") for i, text in enumerate(raw_connections)
    ]
    record = data.get("record")
    if record is not None:
        if not isinstance(record, list) or not all(isinstance(r, str) for r in record):
            raise SceneError(f"{where}: 'record' must be a list of 'component.variable' names")
        for item in record:
            split_name(item, f"{where}: record")
    reference = _text(data, "reference", where, "")
    coupling = data.get("coupling", COUPLINGS[0])
    if coupling not in COUPLINGS:
        raise SceneError(
            f"{where}: coupling = {limits.shortened(coupling)} is not one of {', '.join(COUPLINGS)}"
        )
    name = _text(data, "name", where, path.stem)
    problem = plain_file_name(name)
    if problem:
        raise SceneError(
            f"{where}: name = {limits.shortened(name)} must be a plain file name (the result "
            f"files are named after it inside the output folder): {problem}"
        )
    return Scene(
        name=name,
        path=path,
        start_time=start_time,
        stop_time=stop_time,
        step=step,
        components=components,
        connections=connections,
        record=record,
        description=_text(data, "description", where, ""),
        coupling=coupling,
        reference=(path.parent / reference).resolve() if reference else None,
        check=parse_check(data["check"], where, SceneError) if "check" in data else None,
        missing_times=missing,
    )


PACKAGE_ROOT = Path(__file__).resolve().parents[1]
SCENE_DIR = PACKAGE_ROOT / "scenes"  # the shipped scenes
SWEEP_DIR = PACKAGE_ROOT / "sweeps"  # the shipped sweeps
REFERENCE_DIR = SCENE_DIR / "reference"  # the shipped scenes' reference CSVs


def find_file(text: str, folders: tuple = (SCENE_DIR,)) -> Path:
    """The scene or sweep file that ``text`` names.

    ``text`` is a path when it names an existing file or ends in .toml; otherwise the name
    of a shipped file, looked up as ``text``.toml in ``folders`` in order (default: the
    shipped scenes). A name found nowhere gives its path in the first folder, so the error
    of reading it says where it was looked for.
    """
    path = Path(text)
    if limits.exists(path) or path.suffix == ".toml":
        return path
    candidates = [Path(folder) / f"{text}.toml" for folder in folders]
    return next(
        (candidate for candidate in candidates if limits.file_problem(candidate, None) is None),
        candidates[0],
    )


def read_toml(
    path: Path, error: type[Exception] = SceneError, what: str = "scene file"
) -> dict[str, Any]:
    """The parsed TOML file at ``path``, checked against the limits of mechfmu.cosim.limits
    before and after parsing (size, UTF-8, nesting, digits, 64-bit integers); a missing,
    malformed or out-of-limits file raises ``error`` naming the file, the place and the
    problem, in one line."""
    text, problem = limits.read_text(path, limits.MAX_TOML_BYTES)
    if text is None:
        if problem == limits.NOT_FOUND:
            raise error(f"{what} {limits.message_text(path)} not found")
        raise error(f"{what} {limits.message_text(path)}: {problem}")
    problem = limits.scan_problem(text, limits.MAX_TOML_DEPTH, "toml")
    if problem:
        raise error(f"{path}: {problem}")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as malformed:
        raise error(f"{path}: malformed TOML: {malformed}") from None
    problem = limits.structure_problem(data, limits.MAX_TOML_DEPTH)
    if problem:
        raise error(f"{path}: {problem}")
    return data


def load_scene(path: Path | str, overrides: dict[str, Any] | None = None) -> Scene:
    """Read and parse a scene TOML file; errors name the file and the problem.
    ``overrides``: top-level keys (stop_time, step, ...) replacing the file's."""
    path = Path(path)
    return parse_scene({**read_toml(path), **(overrides or {})}, path)


def check_tables(scene: Scene) -> dict:
    """Read every table file of ``scene`` on the host before it runs: each ``*_file``
    parameter of a component whose ``shape`` is "table" (LoadProfile, RoadProfile), by
    cosim.tables.read_profile_table (pandas, the rules of the FMU's own reader). A missing or
    malformed table raises SceneError naming the scene, the component, the file, the line
    and the column, before any FMU is loaded. Returns {component.parameter: its DataFrame}."""
    from .tables import ResultFileError, read_profile_table

    tables = {}
    for name, spec in scene.components.items():
        if spec.parameters.get("shape") != "table":
            continue
        for key, value in spec.parameters.items():
            if key.endswith("_file") and isinstance(value, str) and value:
                try:
                    tables[f"{name}.{key}"] = read_profile_table(value)
                except ResultFileError as error:
                    raise SceneError(f"{scene.path}: component {name!r}: {key}: {error}") from None
    return tables


def apply_parameters(
    scene: Scene,
    parameters: dict[str, Any] | None,
    declared: Callable[[ComponentSpec], tuple[str, list[str]]],
) -> None:
    """Set ``parameters`` ({"component.parameter": value}) on ``scene``'s components, in
    place. A name may also be a constant input the scene gives a value, or an effect (True
    or False). ``declared(spec)``: the model name and parameter names of a component.
    SceneError naming the item for an unknown component or a name the component's model
    has no parameter of, or a value that is not a number, a bool or a string within
    mechfmu.cosim.limits (value_problem); the value's type is checked with the scene (by the
    master)."""
    for name, value in (parameters or {}).items():
        if not isinstance(name, str):
            raise SceneError(
                f"parameters: {limits.shortened(name)} is not of the form component.parameter"
            )
        component, dot, variable = name.partition(".")
        if not dot or not component or not variable:
            raise SceneError(f"parameters: {name!r} is not of the form component.parameter")
        spec = scene.components.get(component)
        if spec is None:
            raise SceneError(
                f"parameters: {name!r}: scene {scene.name} has no component "
                f"{component!r}; its components: {', '.join(scene.components)}"
            )
        problem = limits.value_problem(value)
        if problem:
            raise SceneError(f"parameters: {name} = {limits.shortened(value)} {problem}")
        if variable in spec.inputs:
            spec.inputs[variable] = value
            continue
        model, names = declared(spec)
        if variable not in names:
            raise SceneError(
                f"parameters: {name!r}: {component!r} ({model}) has no parameter "
                f"{variable!r}; its parameters: {', '.join(sorted(names))}"
            )
        if variable in spec.effects:
            spec.effects.remove(variable)
        spec.parameters[variable] = value
