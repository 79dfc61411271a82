"""A whole scene as one FMU: ``mechfmu export-fmu SCENE OUT.fmu`` (host side).

fmu-manipulation-toolbox's FMU Container (``fmutool``'s package) is an FMI 2.0 co-simulation
FMU whose binary is a small fixed-step master: it loads the FMUs packed inside it, links
their outputs to inputs and steps them. This module fills one from a scene: the scene's FMUs
(one copy per component, ``<component>.<Model>.fmu``, so two components of one model stay
apart), its
connections, its parameters, effects and fixed inputs as start values, its recorded variables
as the container's outputs (named ``component.variable``, as in our result CSVs), its
communication step as the container's step, its start and stop time as the default experiment.

How its results differ from our master's (measured in tests/test_container.py):

- It steps the FMUs at its own fixed step, which is the scene's step here; a host that
  calls the container with a longer step gets several inner steps per call, and outputs
  only at the host's points.
- Scheduling: a scene with ``coupling = "gauss_seidel"`` (the default) becomes a *sequential*
  container, with the FMUs in our master's stepping order: each FMU is stepped with the
  outputs just computed by those before it, as in our master. A scene with
  ``coupling = "jacobi"`` becomes a *parallel* container: every FMU gets the outputs of the
  previous communication point, so every link lags one step (``sequential=False`` forces that
  on any scene: the one-step delay of the container's default mode).
- Initialisation: the container propagates the links once, in the topological order of the
  FMUs, before leaving initialisation, as our master does; so the first row agrees.
"""

from typing import Any
import contextlib
import logging
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..cosim.master import Simulation
from ..cosim.scene import load_scene


@dataclass(frozen=True)
class ContainerSummary:
    """What export_scene_fmu wrote: the file, its FMUs in stepping order, its outputs."""

    path: Path
    components: tuple  # component names, in the order the container steps them
    outputs: tuple  # the container's outputs, "component.variable"
    sequential: bool  # True: Gauss-Seidel in that order; False: parallel (one-step lag)
    step: float  # the container's fixed step (s)


def _start_value(value: Any):
    """A scene value as the container's start-value text (floats round-trip exactly)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


class _StartValueFilter(logging.Filter):
    """Drops the builder's "Input ... is not connected" for inputs given a start value: the
    scene fixes them, they need no link."""

    def __init__(self, container: Any) -> None:
        super().__init__()
        self.fixed = {f"Input '{port}' is not connected" for port in container.start_values}

    def filter(self, record: Any) -> bool:
        return record.getMessage() not in self.fixed


@contextlib.contextmanager
def _quiet_builder(container: Any):
    """The toolbox's builder narrates every port at INFO level: keep its warnings and errors,
    less the false alarms of _StartValueFilter."""
    logger = logging.getLogger("fmu_manipulation_toolbox")
    level, start_values = logger.level, _StartValueFilter(container)
    logger.setLevel(logging.WARNING)
    logger.addFilter(start_values)
    try:
        yield
    finally:
        logger.removeFilter(start_values)
        logger.setLevel(level)


def export_scene_fmu(scene_file: Any, out: Any, fmu_dir: Any = None, sequential: Any = None) -> Any:
    """Pack the scene ``scene_file`` with its FMUs (from ``fmu_dir``, default fmus/) into the
    container FMU ``out``; return a ContainerSummary.

    ``sequential``: None follows the scene's coupling (gauss_seidel: sequential, jacobi:
    parallel); True or False forces it. Components that feed none of the recorded outputs are
    left out, as our master leaves them out.
    """
    from fmu_manipulation_toolbox.container import FMUContainer

    scene = load_scene(Path(scene_file))
    simulation = Simulation(scene, fmu_dir)  # checks the scene, orders and prunes components
    if sequential is None:
        sequential = scene.coupling == "gauss_seidel"
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="mechfmu_container_") as folder:
        work = Path(folder)
        files = {}
        for name in simulation.order:
            # not "<name>.fmu": the container names the buffer of each link "<FMU>.<output>",
            # which would clash with the output "<name>.<output>" exposed under our name
            model = simulation.components[name].description.modelName
            files[name] = f"{name}.{model}.fmu"
            shutil.copyfile(simulation.components[name].path, work / files[name])
        identifier = "".join(c if c.isalnum() else "_" for c in scene.name) or "scene"
        container = FMUContainer(identifier, work, fmi_version=2)
        container.start_time, container.stop_time = scene.start_time, scene.stop_time
        for name in simulation.order:
            container.get_fmu(files[name])
        for connection in simulation.connections:
            container.add_link(
                files[connection.source],
                connection.output,
                files[connection.target],
                connection.input,
            )
        for name in simulation.order:
            spec = simulation.components[name].spec
            values = {**spec.parameters, **{effect: True for effect in spec.effects}, **spec.inputs}
            for variable, value in values.items():
                container.add_start_value(files[name], variable, _start_value(value))
        outputs = []
        for full_name, component, variable in simulation.recorded:
            container.add_output(files[component.name], variable.name, full_name)
            outputs.append(full_name)
        used = {(c.source, c.output) for c in simulation.connections} | {
            (component.name, variable.name) for _, component, variable in simulation.recorded
        }
        for name in simulation.order:
            for variable in simulation.components[name].variables.values():
                if variable.causality == "output" and (name, variable.name) not in used:
                    container.drop_port(files[name], variable.name)  # neither linked nor recorded
        built = work / f"{identifier}.fmu"
        with _quiet_builder(container):
            container.make_fmu(built.name, step_size=scene.step, sequential=sequential)
        shutil.move(str(built), out)
    return ContainerSummary(out, tuple(simulation.order), tuple(outputs), sequential, scene.step)
