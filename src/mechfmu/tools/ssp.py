"""Scenes as SSP 1.0 packages: ``mechfmu export-ssp SCENE.toml OUT.ssp``.

An SSP (System Structure and Parameterization, Modelica Association, 1.0) is a zip with
``SystemStructure.ssd`` and the FMUs it names under ``resources/``. A scene becomes:

- one ``ssd:Component`` per scene component, ``source="resources/<Model>.fmu"`` (type
  application/x-fmu-sharedlibrary), in the master's stepping order (pruned components last);
- its ``ssd:Connectors``: the connected inputs and outputs, the recorded outputs and the
  parameters the scene sets (effects included), each with its FMI type (``ssc:Real`` with
  its unit, ``ssc:Integer``, ``ssc:Boolean``, ``ssc:String``); the units used are defined
  in ``ssd:Units`` from the FMUs' unit definitions;
- its ``ssd:ParameterBindings``: one inline ``ssv:ParameterSet`` (named after the component)
  with the scene's parameters, its effects (Boolean ``true``) and the constant values of its
  unconnected inputs (SSP: "parameter bindings ... set any initial values in the FMU which
  are legal to change", i.e. the inputs' start values). Constant inputs get no connector: a
  connector is an interface for connections, and a host that feeds every input connector
  (fmpy.ssp does) would overwrite the value;
- ``ssd:Connections``, one per scene connection, in the scene's order;
- ``ssd:DefaultExperiment`` with the start and stop time and the communication step as the
  Open Simulation Platform annotation libcosim reads (``osp:FixedStepAlgorithm
  baseStepSize``), and a ``mechfmu`` annotation on the SSD with the step, the scene's
  coupling, the master's order, the lagged connections and the recorded variables, so a
  runner knows what the scene compares (SSP has no notion of recorded signals).

What an SSP cannot say is refused with a SceneError before anything is written: a
``*_file`` parameter (the FMU opens that path on the host; SSP 1.0 has no way to hand an FMU
a path into the package), a non-finite Real value, an Integer outside 32 bits. The scene is
first checked against the FMUs exactly as ``mechfmu run`` checks it (``Simulation``).

The master algorithm is not part of SSP: an importing tool chooses it. libcosim's fixed-step
algorithm and fmpy's ``simulate_ssp`` both step every FMU with the inputs of the previous
communication point (Jacobi), like the master's ``coupling = "jacobi"``. libcosim initialises
all FMUs together: it reads the sources' outputs in initialization mode and passes them on
before any FMU leaves it, so it needs FMUs that compute their outputs (FMI 2.0 initial
unknowns) in initialization mode. fmpy.ssp is run through ``simulate_ssp_fmpy`` below, which
fills the gaps of fmpy 0.3.32's simulate_ssp for the duration of the call.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import io
import math
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from fmpy import read_model_description

from .. import __version__
from ..cosim.files import atomic_write
from ..cosim.locate import scene_fmu_folder
from ..cosim.master import Simulation, resolve_fmu
from ..cosim.scene import Scene, SceneError, load_scene

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from fmpy.model_description import ModelDescription
    from ..cosim.scene import ComponentSpec
    from numpy import ndarray
    from xml.etree.ElementTree import Element

SSD_NAME = "SystemStructure.ssd"
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
    "mechfmu": "urn:mechfmu:scene:1",
}
OSP_ANNOTATION = "com.opensimulationplatform"
MECHFMU_ANNOTATION = "org.mechfmu.scene"
FMU_TYPE = "application/x-fmu-sharedlibrary"
_BASE_UNIT = ("kg", "m", "s", "A", "K", "mol", "cd", "rad", "factor", "offset")
_INT32 = (-(2**31), 2**31 - 1)

for _prefix, _uri in NS.items():
    ET.register_namespace(_prefix, _uri)


def _tag(prefix: str, name: str) -> str:
    return f"{{{NS[prefix]}}}{name}"


def _sub(parent: Element, prefix: str, tag: str, **attributes: Any) -> Element:
    return ET.SubElement(
        parent,
        _tag(prefix, tag),
        {key: value for key, value in attributes.items() if value is not None},
    )


def format_value(fmi_type: str, value: float, where: str) -> str:
    """The SSP (XML Schema) literal of a scene value of FMI type ``fmi_type``."""
    if fmi_type == "Real":
        value = float(value)
        if not math.isfinite(value):
            raise SceneError(f"{where} = {value!r}: a non-finite Real is not exported to SSP")
        return repr(value)  # shortest round-trip form; xs:double reads it back exactly
    if fmi_type == "Integer":
        if not _INT32[0] <= value <= _INT32[1]:
            raise SceneError(f"{where} = {value!r} does not fit the 32-bit Integer of FMI and SSP")
        return str(int(value))
    if fmi_type == "Boolean":
        return "true" if value else "false"
    if fmi_type == "String":
        return str(value)
    raise SceneError(f"{where}: variables of type {fmi_type} are not exported to SSP")


class _Part:
    """One scene component as the SSD describes it."""

    def __init__(self, spec: ComponentSpec, description: ModelDescription) -> None:
        self.spec, self.description = spec, description
        self.variables = {v.name: v for v in description.modelVariables}
        self.connectors: set[str] = set()  # variable names
        self.resource: str | None = None  # resources/<Model>.fmu


def _refuse_unexpressible(scene: Scene) -> None:
    for name, spec in scene.components.items():
        for key, value in spec.parameters.items():
            if key.endswith("_file") and isinstance(value, str) and value:
                raise SceneError(
                    f"{scene.path}: component {name!r}: parameter {key} = {value!r} names a "
                    f"file the FMU opens on the host; SSP 1.0 cannot hand an FMU a path into "
                    f"the package, so a scene with a *_file parameter is not exported"
                )


def describe(
    scene: Path | Scene, fmu_dir: Path | str | None = None
) -> tuple[Element, dict[str, Path]]:
    """Check ``scene`` and return (SSD root element, {resource name: FMU path})."""
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    simulation = Simulation(scene, fmu_dir)  # the master's checks, with its messages
    _refuse_unexpressible(scene)
    fmu_dir = scene_fmu_folder(scene, fmu_dir)
    parts: dict[str, Any] = {}
    resources: dict[str, Path] = {}
    for name, spec in scene.components.items():
        path = resolve_fmu(spec, scene, fmu_dir).resolve()
        if name in simulation.components:
            description = simulation.components[name].description
        else:
            description = read_model_description(str(path))
        part = _Part(spec, description)
        stem = path.stem  # the model name for a component given by name
        resource, suffix = f"resources/{stem}.fmu", 2
        while resource in resources and resources[resource] != path:
            resource, suffix = f"resources/{stem}_{suffix}.fmu", suffix + 1
        resources[resource] = path
        part.resource = resource
        parts[name] = part
    for connection in scene.connections:
        parts[connection.source].connectors.add(connection.output)
        parts[connection.target].connectors.add(connection.input)
    recorded = [full_name for full_name, _, _ in simulation.recorded]
    for full_name, component, variable in simulation.recorded:
        # a recorded input gets a connector only when connected (a constant one is bound)
        if variable.causality in ("output", "parameter", "calculatedParameter"):
            parts[component.name].connectors.add(variable.name)
    for part in parts.values():
        part.connectors.update(part.spec.parameters)
        part.connectors.update(part.spec.effects)

    root = ET.Element(
        _tag("ssd", "SystemStructureDescription"),
        {"version": "1.0", "name": scene.name, "generationTool": f"mechfmu {__version__}"},
    )
    system = _sub(
        root,
        "ssd",
        "System",
        name=scene.name,
        description=" ".join(scene.description.split()) or None,
    )
    elements = _sub(system, "ssd", "Elements")
    order = simulation.order + [name for name in scene.components if name not in simulation.order]
    units: dict[str, Any] = {}
    for name in order:
        part = parts[name]
        element = _sub(
            elements,
            "ssd",
            "Component",
            name=name,
            type=FMU_TYPE,
            source=part.resource,
            implementation="CoSimulation",
        )
        names = sorted(part.connectors, key=lambda n: part.variables[n].valueReference)
        if names:
            connectors = _sub(element, "ssd", "Connectors")
            for variable_name in names:
                variable = part.variables[variable_name]
                connector = _sub(
                    connectors,
                    "ssd",
                    "Connector",
                    name=variable_name,
                    kind=variable.causality,
                    description=variable.description or None,
                )
                if variable.type == "Real":
                    _sub(connector, "ssc", "Real", unit=variable.unit or None)
                    if variable.unit:
                        _unit(units, part, variable.unit, f"{scene.path}: {name}.{variable_name}")
                elif variable.type in ("Integer", "Boolean", "String"):
                    _sub(connector, "ssc", variable.type)
                else:
                    raise SceneError(
                        f"{scene.path}: {name}.{variable_name} is of type "
                        f"{variable.type}, which is not exported to SSP"
                    )
        values = [(key, value) for key, value in part.spec.parameters.items()]
        values += [(key, True) for key in part.spec.effects]
        values += [(key, value) for key, value in part.spec.inputs.items()]
        if values:
            bindings = _sub(element, "ssd", "ParameterBindings")
            binding = _sub(bindings, "ssd", "ParameterBinding")
            holder = _sub(binding, "ssd", "ParameterValues")
            parameter_set = _sub(holder, "ssv", "ParameterSet", version="1.0", name=name)
            parameters = _sub(parameter_set, "ssv", "Parameters")
            for key, value in values:
                variable = part.variables[key]
                parameter = _sub(parameters, "ssv", "Parameter", name=key)
                _sub(
                    parameter,
                    "ssv",
                    variable.type,
                    value=format_value(variable.type, value, f"{scene.path}: {name}.{key}"),
                )
    if scene.connections:
        connections = _sub(system, "ssd", "Connections")
        for connection in scene.connections:
            _sub(
                connections,
                "ssd",
                "Connection",
                startElement=connection.source,
                startConnector=connection.output,
                endElement=connection.target,
                endConnector=connection.input,
            )
    if units:
        unit_list = _sub(root, "ssd", "Units")
        for unit_name, base in units.items():
            unit = _sub(unit_list, "ssc", "Unit", name=unit_name)
            _sub(unit, "ssc", "BaseUnit", **base)
    experiment = _sub(
        root,
        "ssd",
        "DefaultExperiment",
        startTime=repr(scene.start_time),
        stopTime=repr(scene.stop_time),
    )
    annotation = _sub(
        _sub(experiment, "ssd", "Annotations"), "ssc", "Annotation", type=OSP_ANNOTATION
    )
    _sub(
        _sub(annotation, "osp", "Algorithm"),
        "osp",
        "FixedStepAlgorithm",
        baseStepSize=repr(scene.step),
    )
    annotation = _sub(
        _sub(root, "ssd", "Annotations"), "ssc", "Annotation", type=MECHFMU_ANNOTATION
    )
    info = _sub(
        annotation,
        "mechfmu",
        "Scene",
        name=scene.name,
        step=repr(scene.step),
        coupling=scene.coupling,
        order=" ".join(simulation.order),
    )
    for connection in simulation.lagged:
        _sub(info, "mechfmu", "LaggedConnection", connection=str(connection))
    for name in simulation.pruned:
        _sub(info, "mechfmu", "Pruned", component=name)
    for full_name in recorded:
        _sub(info, "mechfmu", "Record", variable=full_name)
    return root, resources


def _unit(
    units: dict[str, dict[str, str] | dict[Any, Any]], part: _Part, unit_name: str, where: str
) -> None:
    definition = next((u for u in part.description.unitDefinitions if u.name == unit_name), None)
    base = {}
    if definition is not None and definition.baseUnit is not None:
        for key in _BASE_UNIT:
            value = getattr(definition.baseUnit, key)
            default = 1.0 if key == "factor" else 0
            if value != default:
                base[key] = repr(float(value)) if key in ("factor", "offset") else str(value)
    if unit_name in units and units[unit_name] != base:
        raise SceneError(
            f"{where}: unit {unit_name!r} is defined differently by two FMUs "
            f"({units[unit_name]} and {base}); an SSD has one definition per unit"
        )
    units[unit_name] = base


def ssd_bytes(root: Element) -> bytes:
    """The SSD document as UTF-8 bytes with an XML declaration, indented."""
    tree = ET.ElementTree(root)
    ET.indent(tree, space="  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def export_ssp(scene: Path | Scene, out: Path | str, fmu_dir: Path | str | None = None) -> Path:
    """Write ``scene`` (a Scene or a path) as the SSP package ``out``; return its path.

    The file is written to a temporary name and renamed, so a reader never sees half of it.
    """
    root, resources = describe(scene, fmu_dir)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as package:
        package.writestr(
            zipfile.ZipInfo(SSD_NAME, date_time=(1980, 1, 1, 0, 0, 0)),
            ssd_bytes(root),
            compress_type=zipfile.ZIP_DEFLATED,
        )
        for resource, path in resources.items():
            package.write(path, resource, compress_type=zipfile.ZIP_STORED)
    return atomic_write(out, buffer.getvalue())


def summary(ssp: Path) -> str:
    """One line on an SSP: components, connections, FMUs, parameter values."""
    with zipfile.ZipFile(ssp) as package:
        root = ET.fromstring(package.read(SSD_NAME))
        fmus = [name for name in package.namelist() if name.endswith(".fmu")]
    count = {
        key: len(list(root.iter(_tag(prefix, key))))
        for prefix, key in (("ssd", "Component"), ("ssd", "Connection"), ("ssv", "Parameter"))
    }
    return (
        f"{count['Component']} components, {count['Connection']} connections, "
        f"{len(fmus)} FMUs, {count['Parameter']} parameter values"
    )


def extract_ssp(ssp: Path, directory: Path) -> Path:
    """Unpack an SSP into ``directory`` (created); return it (hosts that read folders)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(ssp) as package:
        package.extractall(directory)
    return directory


# --- running an exported SSP in fmpy.ssp (host side) ---------------------------------------


def experiment(ssp: Path) -> tuple[float, float, float, list[str | None]]:
    """(start time, stop time, step, recorded 'component.variable' names) of an exported SSP.

    ``ssp``: the .ssp file or its extracted folder. The step and the recorded names come
    from the package's mechfmu annotation.
    """
    ssp = Path(ssp)
    if ssp.is_dir():
        text = (ssp / SSD_NAME).read_bytes()
    else:
        with zipfile.ZipFile(ssp) as package:
            text = package.read(SSD_NAME)
    root = ET.fromstring(text)
    default = root.find(_tag("ssd", "DefaultExperiment"))
    scene = root.find(
        f"{_tag('ssd', 'Annotations')}/{_tag('ssc', 'Annotation')}/{_tag('mechfmu', 'Scene')}"
    )
    if default is None or scene is None:
        raise ValueError(
            f"{ssp}: not an SSP exported by mechfmu (no DefaultExperiment or "
            f"no {MECHFMU_ANNOTATION} annotation)"
        )
    return (
        float(default.attrib["startTime"]),
        float(default.attrib["stopTime"]),
        float(scene.attrib["step"]),
        [item.get("variable") for item in scene.findall(_tag("mechfmu", "Record"))],
    )


def simulate_ssp_fmpy(ssp: Path, initialise_from_sources: bool = False) -> ndarray:
    """Run an exported SSP (.ssp file) in fmpy's ``fmpy.ssp.simulation.simulate_ssp``.

    Returns fmpy's structured array: ``time`` (the END of each step, see below), then one
    field per input and output connector, 'component.connector'.

    fmpy 0.3.32's simulate_ssp steps every component from the connector values of the
    previous communication point (Jacobi) and needs four things met, all done here for the
    duration of the call only (its module functions are restored afterwards):

    * it parses the components' ParameterBindings (``read_ssd``) but never applies them
      (only a ``parameter_set`` argument, matched by a bare name prefix, so 'valve' also
      catches 'valve_train.*'): ``set_parameters`` is replaced by one that applies each
      component's bindings;
    * its ``set_value`` has no String branch and reads a Boolean literal 'false' as true:
      both are added;
    * it starts every connector at 0.0 and feeds that to the inputs in the first step:
      before the first step the connectors take the values after initialisation (outputs
      read from the FMUs, inputs from their connections), as libcosim does;
    * it stamps each row with the step's start time but records the values after the
      step, and accumulates its time (``time += step_size``, ``while time < stop_time``):
      the stop time is passed half a step early so exactly the scene's steps run, and the
      time column is shifted by one step here. There is no row for the start time.

    fmpy initialises each component on its own, in the SSD's order, so a connected input
    still has its start value when its FMU leaves initialisation (the step from it uses the
    source's value). ``initialise_from_sources=True`` sets it from its source first, when
    the source comes earlier in the SSD (the SSD lists the components in the master's
    order, so that is every connection the master does not lag): the master's
    initialisation, for comparisons.
    """
    import numpy as np
    from fmpy.ssp import simulation
    from fmpy.ssp.ssd import ParameterSet
    from numpy.lib.recfunctions import repack_fields

    start, stop, step, _ = experiment(ssp)
    with zipfile.ZipFile(ssp) as package:
        root = ET.fromstring(package.read(SSD_NAME))
    signals = {
        f"{component.get('name')}.{connector.get('name')}"
        for component in root.iter(_tag("ssd", "Component"))
        for connector in component.iter(_tag("ssd", "Connector"))
        if connector.get("kind") in ("input", "output")
    }
    original = {
        name: getattr(simulation, name) for name in ("set_value", "set_parameters", "do_step")
    }
    started = set()

    def set_value(component: Any, name: str, value: Any) -> None:
        variable = component.variables[name]
        reference = [variable.valueReference]
        if variable.type == "String":
            component.fmu.setString(reference, [str(value)])
        elif variable.type == "Boolean" and isinstance(value, str):
            component.fmu.setBoolean(reference, [value.strip() in ("true", "1")])
        else:
            original["set_value"](component, name, value)

    def set_parameters(component: Any, parameter_set: Any) -> None:
        for binding in component.parameterBindings:
            for values in binding.parameterValues:
                for parameter in values.parameters:
                    set_value(component, (binding.prefix or "") + parameter.name, parameter.value)
        if initialise_from_sources:
            elements = {element.name: element for element in component.parent.elements}
            for connection in component.parent.connections:
                source = elements[connection.startElement]
                if connection.endElement == component.name and hasattr(source, "fmu"):
                    set_value(
                        component,
                        connection.endConnector,
                        simulation.get_value(source, connection.startConnector),
                    )

    def do_step(component: Any, time: float, step_size: float) -> None:
        system = component.parent
        if id(system) not in started:
            started.add(id(system))
            elements = {element.name: element for element in system.elements}
            for element in elements.values():
                for connector in element.connectors:
                    if connector.kind == "output":
                        connector.value = simulation.get_value(element, connector.name)
            for connection in system.connections:
                source = elements[connection.startElement]
                target = elements[connection.endElement]
                value = next(
                    c.value for c in source.connectors if c.name == connection.startConnector
                )
                for connector in target.connectors:
                    if connector.name == connection.endConnector:
                        connector.value = value
        original["do_step"](component, time, step_size)

    simulation.set_value, simulation.set_parameters, simulation.do_step = (
        set_value,
        set_parameters,
        do_step,
    )
    try:
        rows = simulation.simulate_ssp(
            str(ssp),
            start_time=start,
            stop_time=stop - step / 2,
            step_size=step,
            parameter_set=ParameterSet(name="unused"),
        )
    finally:
        for name, function in original.items():
            setattr(simulation, name, function)
    rows["time"] = start + step * np.arange(1, len(rows) + 1)
    # fmpy also lists the parameter connectors, always at 0.0 (it never reads them): left out
    return repack_fields(rows[["time"] + [name for name in rows.dtype.names if name in signals]])
