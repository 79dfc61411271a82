"""The co-simulation master on fmpy's FMU2Slave.

It checks a scene against the FMUs' model descriptions (names, causalities, types, every
input fed), orders the components by their connections, initialises them in that order,
then steps them Gauss-Seidel: each component gets its inputs from components already
advanced to the end of the step. It records the requested variables at every
communication point and frees every instance, also on error. A step an FMU refuses
(fmi2Discard, fmi2Error, ...) stops the run with a SimulationError that names the
component, the time and the FMU's own log message, and carries the rows computed so far.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import ctypes
import math
import re
import functools
import shutil
from array import array
import time as clock
import weakref
from ctypes import byref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Callable

from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2True,
    fmi2ValueReference,
)
from fmpy import calloc, free
from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated
from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64

from .checkpoint import Checkpoint, CheckpointError, Checkpoints, check_matches
from .checkpoint import save as save_checkpoint
from .checkpoint import scene_digest
from .experiment import resolved_times
from .fmu_file import FmuError, checked_description, unpack
from .text import joined_lines
from .interrupt import signal_name
from . import limits
from .locate import scene_fmu_folder
from .scene import SceneError, split_name
from .variables import called_type, connectable, element, movable, recordable, scene_value
from .variables import start_value
from .variables import unit_of

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from fmpy.model_description import ModelDescription, ModelVariable
    from .interrupt import InterruptGuard
    from .scene import ComponentSpec, Connection, Scene

MAX_LOG_MESSAGES = 10_000  # FMU log messages a run keeps (then only its problems)
CHUNK_ROWS = 4096  # rows a run given a sink hands over at once (memory: CHUNK_ROWS rows)
FLUSH_SECONDS = 1.0  # ... or after this long (s, wall clock): a slow run's file keeps up
EFFECT_PREFIX = "Effect: "  # how a model marks its effect parameters (mechfmu.runtime.fmi.slave)
# how a model marks an input it reads only in one configuration ("Only with drive = camshaft:
# ..."; mechfmu.runtime.fmi.declarations.only_with): unfed, it is no mistake in the others
ONLY_WITH = re.compile(r"^Only with (\w+) = (\w+): ")
STATUS_NAMES = {0: "ok", 1: "warning", 2: "discard", 3: "error", 4: "fatal", 5: "pending"}


def _read(component: Any, variable: Any) -> bool:
    """Whether the component reads ``variable`` (an input) in the scene's configuration:
    always, unless its description says "Only with P = V: " and parameter P (the scene's
    value, True for an effect the scene lists, else its start value) is not V."""
    match = ONLY_WITH.match(variable.description or "")
    if match is None:
        return True
    name, wanted = match.groups()
    value = True if name in component.spec.effects else component.spec.parameters.get(name)
    if value is None and name in component.variables:
        value = component.variables[name].start
    return str(value) == wanted


class SimulationError(RuntimeError):
    """A component failed during the run; ``result`` holds the rows computed before."""

    def __init__(self, component: str | None, time: float, message: str, result: "Result") -> None:
        self.component, self.time, self.result = component, time, result
        self.paths: dict[str, Path] = {}  # set by run_scene
        self.moved_aside: list[Path] = []
        self.output_error: Exception | None = None
        super().__init__(f"component {component!r} failed at t = {time!r} s: {message}")


class SimulationInterrupted(SimulationError):
    """SIGINT or SIGTERM (``signum``) stopped the run between two steps at ``time``;
    ``result`` holds the rows computed before."""

    def __init__(self, signum: Any, time: float, result: Any) -> None:
        super().__init__(None, time, "", result)
        self.signum = signum
        RuntimeError.__init__(
            self,
            f"interrupted by {signal_name(signum)} at t = {time!r} s "
            f"after {max(result.rows - 1, 0)} step(s)",
        )


@dataclass
class Result:
    """Recorded signals of one run: ``columns`` maps 'component.variable' to values.

    ``rows``: the communication points recorded (the first included). A run given a
    ``sink`` that does not keep its rows (``Simulation.run(keep=False)``) has empty
    ``times`` and ``columns``: its rows went to the sink (a result file) as they came."""

    scene: Any
    times: list = field(default_factory=list)
    columns: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    log: list = field(default_factory=list)
    partial: bool = False
    rows: int = 0
    kept: bool = True  # whether times and columns hold every row


def resolve_fmu(spec: ComponentSpec, scene: Scene, fmu_dir: Path | str) -> Path:
    """Path of a component's FMU: a model name in ``fmu_dir`` or a path to an .fmu."""
    if spec.fmu.endswith(".fmu"):
        candidate = Path(spec.fmu)
        if not candidate.is_absolute():
            candidate = scene.path.parent / candidate
    else:
        candidate = Path(fmu_dir) / f"{spec.fmu}.fmu"
    # file_problem, not is_file(): a name too long for the file system raises OSError there
    problem = limits.file_problem(candidate, None)
    if problem is not None:
        raise SceneError(
            f"component {spec.name!r}: FMU file {limits.message_text(candidate)} "
            f"{'not found' if problem == limits.NOT_FOUND else problem}; build the "
            f"FMUs with 'mechfmu build' (or 'make fmus')"
        )
    return candidate


def file_version(path: Path) -> tuple[str, int, int]:
    """(path, modification time in ns, size): a rebuilt FMU is a new version."""
    stat = Path(path).stat()
    return str(path), stat.st_mtime_ns, stat.st_size


def model_description(path: Path) -> ModelDescription:
    """fmpy's ModelDescription of the FMU at ``path``, checked (fmu_file: FmuError names the
    file and what is wrong with it) and parsed once per file version."""
    return _parsed_description(*file_version(path))


@functools.lru_cache(maxsize=128)
def _parsed_description(path: str, mtime_ns: int, size: int) -> ModelDescription:
    return checked_description(path)


def _route(environment: int, instance: bytes, status: int, category: bytes, message: bytes) -> None:
    """The one logger every LogBook installs: hands the message to the book it belongs to."""
    book = LogBook._books.get(environment)
    if book is not None:
        book.record(instance, status, category, message)


_ROUTER = fmi2CallbackLoggerTYPE(_route)  # one C callback for the process, never collected


class LogBook:
    """FMI logger callback that keeps every message of the instances it was given to.

    fmpy's native proxy, which formats the variadic message, keeps ONE logger for the whole
    process (a C static: the last one installed wins). Every LogBook therefore installs the
    same module-level router and tells itself apart by the componentEnvironment pointer, which
    the FMU passes back with each message: two LogBooks in one process (two simulations, or
    two instances driven apart) each get their own messages.
    """

    _next_key = 1
    _books: weakref.WeakValueDictionary[int, Any] = (
        weakref.WeakValueDictionary()
    )  # componentEnvironment value -> LogBook

    def __init__(self) -> None:
        self.messages: list[Any] = []
        self.dropped = 0  # messages not kept (record)
        self.key = LogBook._next_key
        LogBook._next_key += 1
        LogBook._books[self.key] = self
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = _ROUTER
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.callbacks.componentEnvironment = ctypes.c_void_p(self.key)
        try:
            from fmpy.logging import addLoggerProxy

            addLoggerProxy(byref(self.callbacks))  # formats the variadic message in C
        except Exception:
            pass

    def fmi3_logger(self, instance: str) -> Callable:
        """An FMI 3.0 logMessage callback for ``instance`` (FMI 3.0 passes no instance name:
        each instance gets its own, and no variadic message needs fmpy's proxy)."""
        name = instance.encode()

        def log(environment: Any, status: int, category: bytes, message: bytes) -> None:
            self.record(name, status, category, message)

        return log

    def record(self, instance: bytes, status: int, category: bytes, message: bytes) -> None:
        """Keep one message; past MAX_LOG_MESSAGES only the problems (error, fatal,
        discard) are kept and the others counted in ``dropped`` (a long run that warns at
        every step stays in bounded memory)."""

        def text(raw: Any):
            return raw.decode("utf-8", "replace") if isinstance(raw, bytes) else str(raw)

        if len(self.messages) >= MAX_LOG_MESSAGES and status < _DISCARD:
            self.dropped += 1
            return
        self.messages.append(
            {
                "instance": text(instance),
                "status": STATUS_NAMES.get(status, status),
                "category": text(category),
                "message": text(message),
            }
        )

    def last_message(self, instance: str) -> str:
        """The last message ``instance`` logged, of any status ('' when none)."""
        for entry in reversed(self.messages):
            if entry["instance"] == instance:
                return str(entry["message"])
        return ""

    def last_problem(self, instance: str) -> str:
        """The last error of ``instance`` in the log, as one line (an FMU's message may span
        several, a Python traceback: its lines are joined with '; ')."""
        for entry in reversed(self.messages):
            if entry["instance"] == instance and entry["status"] in ("error", "fatal", "discard"):
                return joined_lines(entry["message"])
        return "no log message from the FMU"


class Instances:
    """Where a run takes its FMU instances from and gives them back.

    ``keep=False`` (one run): each FMU file is extracted, each instance created, and all are
    freed and deleted by ``close``. ``keep=True`` (a sweep worker running many short scenes):
    each FMU file is extracted once, and an instance given back is terminated and reset
    (fmi2Reset: back to its start values, as freshly instantiated) and kept for the next run
    of a component of the same name and FMU; one that fails to terminate or reset is freed.
    One pool serves one thread at a time: its LogBook is the log of the run in progress.
    ``created`` and ``reused`` count the instances made and the resets that saved one.
    """

    def __init__(self, keep: bool = False) -> None:
        self.keep = keep
        self.logbook = LogBook()  # instances log through the book they were created with
        self._folders: dict[tuple, Path] = {}  # (FMU path, mtime, size) -> extracted folder
        self._idle: dict[tuple, list] = {}  # (folder, instance name) -> [FMU2Slave ready to set up]
        self.created = self.reused = 0

    def acquire(self, component: "_Component") -> Any:
        """An instantiated FMU2Slave or FMU3Slave for ``component``, named after it."""
        version = file_version(component.path)
        folder = self._folders.get(version)
        if folder is None:
            try:
                folder = unpack(component.path)
            except FmuError as error:
                raise FmuError(f"component {component.name!r}: FMU file {error}") from None
            self._folders[version] = folder
        idle = self._idle.get((folder, component.name))
        if idle:
            self.reused += 1
            return idle.pop()
        options = dict(
            guid=component.description.guid,
            unzipDirectory=folder,
            modelIdentifier=component.description.coSimulation.modelIdentifier,
            instanceName=component.name,
        )
        slave: Any = (FMU3Slave if component.version == 3 else FMU2Slave)(**options)
        try:
            if component.version == 3:
                slave.instantiate(
                    loggingOn=True, logMessage=self.logbook.fmi3_logger(component.name)
                )
            else:
                slave.instantiate(callbacks=self.logbook.callbacks, loggingOn=True)
        except Exception:  # fmpy says only "Failed to instantiate model"; the FMU's log says why
            slave.freeLibrary()
            raise _InstantiationFailed(component.name) from None
        slave.mechfmu_folder = folder
        self.created += 1
        return slave

    def release(self, component: "_Component") -> None:
        """Take back ``component``'s instance: reset and keep it, or free it."""
        slave = component.slave
        try:
            slave.terminate()
        except Exception:
            pass  # an instance in error may refuse to terminate; fmi2Reset or free follows
        if self.keep:
            try:
                slave.reset()
            except Exception:
                pass  # not reusable: freed below
            else:
                self._idle.setdefault((slave.mechfmu_folder, component.name), []).append(slave)
                return
        slave.freeInstance()

    def close(self) -> None:
        """Free every kept instance and delete the extracted FMUs."""
        for slaves in self._idle.values():
            for slave in slaves:
                slave.freeInstance()
        self._idle.clear()
        for folder in self._folders.values():
            shutil.rmtree(folder, ignore_errors=True)
        self._folders.clear()


class _Component:
    """One FMU instance in a running scene, with its variables by name."""

    def __init__(self, spec: ComponentSpec, path: Path, description: ModelDescription) -> None:
        self.spec, self.name, self.path, self.description = spec, spec.name, path, description
        self.variables = {v.name: v for v in description.modelVariables}
        self.version = 3 if description.fmiVersion.startswith("3") else 2
        self.slave: Any = None  # fmpy's FMU2Slave or FMU3Slave, from Instances.acquire
        self.settings: list[tuple[Any, Any]] = []  # (variable, value): set at initialisation

    def variable(self, name: str, where: str, causality: tuple[str] | None = None) -> ModelVariable:
        variable = self.variables.get(name)
        if variable is None:
            names = ", ".join(sorted(self.variables))
            raise SceneError(
                f"{where}: {self.name!r} ({self.description.modelName}) has no "
                f"variable {name!r}; it has: {names}"
            )
        if causality is not None and variable.causality not in causality:
            raise SceneError(
                f"{where}: {self.name}.{name} is a {variable.causality}, "
                f"expected {' or '.join(causality)}"
            )
        return variable

    def getter(self, variable: ModelVariable) -> Callable:
        """A function returning the variable's current value (bound once, called per step)."""
        get, reference = accessor(self.slave, variable.type, "get"), [variable.valueReference]
        return lambda: get(reference)[0]

    def setter(self, variable: ModelVariable) -> Callable:
        """A function setting the variable (bound once, called per step)."""
        put, reference = accessor(self.slave, variable.type, "set"), [variable.valueReference]
        if variable.type == "String":
            return lambda value: put(
                reference, [value.decode() if isinstance(value, bytes) else value]
            )
        return lambda value: put(reference, [value])

    def set(self, variable: ModelVariable, value: Any) -> None:
        self.setter(variable)(value)

    def initialise(self, start_time: float, stop_time: float) -> None:
        """Into initialisation mode for a run from ``start_time`` to ``stop_time`` (s), as the
        FMU's version has it."""
        if self.version == 3:
            self.slave.enterInitializationMode(startTime=start_time, stopTime=stop_time)
        else:
            self.slave.setupExperiment(startTime=start_time, stopTime=stop_time)
            self.slave.enterInitializationMode()


def accessor(slave: Any, fmi_type: str, verb: str) -> Callable:
    """fmpy's get/set method of an FMU2Slave or FMU3Slave for an FMI type ('Real',
    'Float64', 'Enumeration', ...)."""
    version = 3 if isinstance(slave, FMU3Slave) else 2
    return getattr(slave, f"{verb}{called_type(version, fmi_type)}")


def order_components(
    names: list[str], connections: list[Any], feedthrough: Callable | None = None
) -> tuple:
    """Components in stepping order, and the connections that must lag one step.

    ``feedthrough(connection)`` tells whether the connection's source output depends
    directly on an input of its component (default: every connection does). Such
    connections fix the order: their source steps first. A connection from an output that
    depends on no input (a state) may lag: it is dropped from the ordering only when it
    closes a cycle, and its target then uses the value from the previous communication
    point (Gauss-Seidel with one delayed coupling). A cycle of feedthrough connections is
    an algebraic loop: SceneError names it.
    """
    feedthrough = feedthrough or (lambda connection: True)
    hard = [c for c in connections if feedthrough(c)]
    targets: dict[str, set[str]] = {name: set() for name in names}
    for connection in hard:
        targets[connection.source].add(connection.target)
    cycle = _find_cycle(names, targets)
    if cycle:
        raise SceneError(
            "algebraic loop: the direct-feedthrough connections form a cycle "
            + " -> ".join(cycle + cycle[:1])
        )
    lagged = []
    for connection in connections:
        if connection in hard or connection.target in targets[connection.source]:
            continue
        targets[connection.source].add(connection.target)
        if _find_cycle(names, targets):
            targets[connection.source].discard(connection.target)
            lagged.append(connection)
    return _topological(names, targets), lagged


def _topological(names: list[str], targets: dict[str, set[str] | set[Any]]) -> list[str]:
    indegree = {name: 0 for name in names}
    for name in names:
        for target in targets[name]:
            indegree[target] += 1
    ready = [name for name in names if indegree[name] == 0]
    ordered = []
    while ready:
        name = ready.pop(0)
        ordered.append(name)
        for target in sorted(targets[name], key=names.index):
            indegree[target] -= 1
            if indegree[target] == 0:
                ready.append(target)
    return ordered


def _find_cycle(names: list[str], targets: dict[str, set[str] | set[Any]]) -> list[str] | None:
    """A list of components forming a cycle, or None (iterative depth-first search)."""
    state = {name: 0 for name in names}  # 0 new, 1 on the current path, 2 done
    for root in names:
        if state[root]:
            continue
        path, stack = [], [(root, iter(sorted(targets[root], key=names.index)))]
        state[root] = 1
        path.append(root)
        while stack:
            node, children = stack[-1]
            child = next(children, None)
            if child is None:
                stack.pop()
                path.pop()
                state[node] = 2
            elif state[child] == 1:
                return path[path.index(child) :]
            elif state[child] == 0:
                state[child] = 1
                path.append(child)
                stack.append((child, iter(sorted(targets[child], key=names.index))))
    return None


class Simulation:
    """A scene bound to its FMUs, checked and ready to run."""

    def __init__(self, scene: Scene, fmu_dir: str | Path | None = None) -> None:
        self.scene = scene
        fmu_dir = scene_fmu_folder(scene, fmu_dir)  # the one rule (cosim/locate.py)
        self.components = {}
        for name, spec in scene.components.items():
            path = resolve_fmu(spec, scene, fmu_dir)
            try:
                description = model_description(path)
            except FmuError as error:
                raise FmuError(f"component {name!r}: FMU file {error}") from None
            self.components[name] = _Component(spec, path, description)
        self.scene = resolved_times(
            scene, {name: c.description for name, c in self.components.items()}
        )
        self._check()
        self.order, self.lagged = order_components(
            list(self.components), self.connections, self._feedthrough
        )

    def _feedthrough(self, connection: Connection) -> bool:
        """Whether the connection's source output depends directly on one of its inputs."""
        description = self.components[connection.source].description
        for unknown in description.outputs:
            if unknown.variable.name == connection.output:
                return bool(unknown.dependencies) or unknown.dependencies is None
        return True

    def _check(self) -> None:
        where = str(self.scene.path)
        fed: dict[tuple[str, str], str] = {}
        for connection in self.scene.connections:
            for name in (connection.source, connection.target):
                if name not in self.components:
                    raise SceneError(
                        f"{where}: connection {connection} names unknown component "
                        f"{name!r}; components: {', '.join(self.components)}"
                    )
            source = self.components[connection.source].variable(
                connection.output, f"{where}: connection {connection}", ("output",)
            )
            target = self.components[connection.target].variable(
                connection.input, f"{where}: connection {connection}", ("input",)
            )
            ends = [
                (self.components[name].version, variable.type)
                for name, variable in ((connection.source, source), (connection.target, target))
            ]
            if not all(movable(*end) for end in ends):
                raise SceneError(
                    f"{where}: connection {connection} joins {source.type} variables; the "
                    "master connects Real (Float32, Float64), integer, Boolean, String and "
                    "Enumeration variables"
                )
            if not connectable(*ends):
                raise SceneError(
                    f"{where}: connection {connection} joins a {source.type} output to a "
                    f"{target.type} input"
                    + (
                        " (of FMUs of FMI 2.0 and 3.0, whose values differ in size)"
                        if source.type == target.type
                        else ""
                    )
                )
            key = (connection.target, connection.input)
            if key in fed:
                raise SceneError(
                    f"{where}: input {connection.target}.{connection.input} is "
                    f"connected twice ({fed[key]} and {connection})"
                )
            fed[key] = str(connection)
        for component in self.components.values():
            for name, value in component.spec.parameters.items():
                variable = component.variable(name, f"{where}: parameters", ("parameter",))
                converted = scene_value(component.name, variable, value, f"{where}: parameters")
                component.settings.append((variable, converted))
            available = sorted(
                v.name
                for v in component.variables.values()
                if v.causality == "parameter"
                and v.type == "Boolean"
                and (v.description or "").startswith(EFFECT_PREFIX)
            )
            for name in component.spec.effects:
                if name not in available:
                    raise SceneError(
                        f"{where}: effects: {component.name!r} "
                        f"({component.description.modelName}) has no effect {name!r}; "
                        f"its effects: {', '.join(available) or 'none'}"
                    )
                if name in component.spec.parameters:
                    raise SceneError(
                        f"{where}: effect {component.name}.{name} is also given "
                        f"under parameters; list it in one place only"
                    )
            for name in component.spec.effects:
                component.settings.append((component.variables[name], True))
            for name, value in component.spec.inputs.items():
                variable = component.variable(name, f"{where}: inputs", ("input",))
                converted = scene_value(component.name, variable, value, f"{where}: inputs")
                component.settings.append((variable, converted))
                if (component.name, name) in fed:
                    raise SceneError(
                        f"{where}: input {component.name}.{name} is both "
                        f"connected ({fed[(component.name, name)]}) and given a value"
                    )
            unfed = [
                v.name
                for v in component.variables.values()
                if v.causality == "input"
                and (component.name, v.name) not in fed
                and v.name not in component.spec.inputs
                and _read(component, v)
            ]
            if unfed:
                raise SceneError(
                    f"{where}: input(s) {', '.join(unfed)} of {component.name!r} are "
                    f"neither connected nor given a value under "
                    f"[components.{component.name}.inputs]"
                )
        self.recorded = []
        names = self.scene.record or [
            f"{c.name}.{v.name}"
            for c in self.components.values()
            for v in c.variables.values()
            if v.causality == "output" and recordable(c.version, v.type)
        ]
        for full_name in names:
            component_name, variable_name = split_name(full_name, f"{where}: record")
            if component_name not in self.components:
                raise SceneError(f"{where}: record names unknown component {component_name!r}")
            component = self.components[component_name]
            variable = component.variable(variable_name, f"{where}: record")
            if not recordable(component.version, variable.type):
                raise SceneError(
                    f"{where}: record: {full_name} is a {variable.type}; result columns are "
                    "numbers: Real, integer, Boolean and Enumeration variables are recorded"
                )
            self.recorded.append((full_name, self.components[component_name], variable))
        self.pruned = self._prune()

    def _prune(self) -> dict[Any, Any]:
        """Drop components that feed none of the recorded outputs; return {name: why}."""
        needed = {component.name for _, component, _ in self.recorded}
        frontier = list(needed)
        while frontier:
            name = frontier.pop()
            for connection in self.scene.connections:
                if connection.target == name and connection.source not in needed:
                    needed.add(connection.source)
                    frontier.append(connection.source)
        pruned = {
            name: "feeds none of the recorded outputs, not instantiated"
            for name in self.components
            if name not in needed
        }
        for name in pruned:
            del self.components[name]
        self.connections = [c for c in self.scene.connections if c.target in needed]
        return pruned

    # --- running ----------------------------------------------------------------------
    def run(
        self,
        time_fmi_calls: bool = False,
        instances: Any = None,
        stop: Any = None,
        checkpoints: Checkpoints | None = None,
        resume: Checkpoint | None = None,
        sink: Any = None,
        keep: bool = True,
    ) -> Result:
        """Run the scene; return a Result or raise SimulationError with the partial Result.

        ``time_fmi_calls``: also measure the time spent inside the FMI calls of the stepping
        loop (``meta['fmi_call_time_s']``, next to ``meta['loop_time_s']``; by call,
        ``meta['fmi_call_times_s']``: "component.fmi2DoStep" -> s); the timers add
        a little to the loop, so benchmarks time it separately.
        ``instances``: an Instances pool to take the FMU instances from and give them back
        to, reset, for the next run (many short runs: a sweep worker); by default the FMUs
        are extracted and instantiated for this run and freed at its end.
        ``stop``: an InterruptGuard (mechfmu.cosim.interrupt) asked before each component's
        instantiation and between steps; when it has received a signal the run stops there
        with SimulationInterrupted (the rows so far, every instance freed).
        ``checkpoints``: where and how often to write a checkpoint (cosim/checkpoint.py;
        always when a signal stops the run); ``resume``: a checkpoint of this scene to continue
        from. A checkpoint holds the rows still in memory; the rows a run that does not keep
        them has let go are in its sink's file: the checkpoint holds the sink's position
        there (``sink.position()``), and a resumed run needs a sink that continues that file
        (``sink.continued``: results.StreamedResult(resume=...)).
        ``sink``: where the recorded rows go as the run makes them (a RowSink of
        mechfmu.cosim.results: ``begin(names)``, then ``rows(times, columns)`` per chunk
        of at most CHUNK_ROWS rows or FLUSH_SECONDS, also for the rows made before a
        failure); ``keep``: whether the Result holds every row too (False: memory bounded
        whatever the run's length; ``result.kept`` says which).
        The time points are computed as the run goes (scene.time), never listed.
        """
        scene = self.scene
        result = Result(
            scene=scene,
            columns={name: [] for name, _, _ in self.recorded},
            units={name: unit_of(variable) for name, _, variable in self.recorded},
        )
        result.meta["coupling"] = scene.coupling
        own = instances is None
        if own:
            instances = Instances()
        logbook = instances.logbook
        logbook.messages = result.log = []
        logbook.dropped = 0
        # a resumed run whose first rows went to a file has only the later ones in memory
        result.kept = (keep or sink is None) and not (resume is not None and resume.streamed)
        instantiated = []
        started = clock.perf_counter()
        current = (None, scene.start_time)
        plan = None
        stop = stop or _NEVER
        try:
            for name in self.order:
                if stop.requested:
                    raise _Stopped(scene.start_time)
                current = (name, scene.start_time)
                component = self.components[name]
                component.slave = instances.acquire(component)
                instantiated.append(component)
                component.initialise(scene.start_time, scene.stop_time)
                for variable, value in component.settings:
                    component.set(variable, value)
                self._feed(name, skip=self.lagged)
                component.slave.exitInitializationMode()
            for connection in self.lagged:  # their sources initialise after their targets
                self._set_from_source(connection)
            timer = CallTimer() if time_fmi_calls else None
            plan = _StepPlan(self, timer, sink, result.kept)
            if sink is not None:
                sink.begin([name for name, _, _ in self.recorded])
            current = (None, scene.start_time)
            if stop.requested:
                raise _Stopped(scene.start_time)
            first = 1
            if resume is not None:
                first = self._resume(resume, plan, result, sink) + 1
            plan.start(result, resume.time if resume else scene.start_time, resume is None)
            saving = self._checkpointer(checkpoints, plan, result)
            loop_started, loop_cpu_started = clock.perf_counter(), clock.process_time()
            try:
                plan.run(result, scene, stop, first, saving)
            finally:
                result.meta["loop_time_s"] = clock.perf_counter() - loop_started
                # the process's CPU time: the loop's work whatever else runs on the machine
                result.meta["loop_cpu_time_s"] = clock.process_time() - loop_cpu_started
                if timer is not None:
                    result.meta["fmi_call_time_s"] = timer.total
                    result.meta["fmi_call_times_s"] = dict(timer.by_call)
        except _Ended as ended:
            message = logbook.last_message(ended.component)
            result.meta["ended_by"] = {
                "component": ended.component,
                "time": ended.time,
                "message": message,
            }
        except _InstantiationFailed as failure:
            result.partial = True
            raise SimulationError(
                failure.component,
                scene.start_time,
                f"the FMU could not be instantiated; its log: "
                f"{logbook.last_problem(failure.component)} "
                f"[fmi2Instantiate failed]",
                result,
            ) from None
        except _Stopped as stopped:
            result.partial = True
            if checkpoints is not None and plan is not None and plan.recorded():
                # every component at the last row (the stop comes between steps)
                self._save_checkpoint(checkpoints, plan, plan.recorded() - 1, result)
            raise SimulationInterrupted(stop.take(), stopped.time, result) from None
        except _CallFailed as failure:
            result.partial = True
            message = logbook.last_problem(failure.component)
            raise SimulationError(
                failure.component,
                failure.time,
                f"{message} [{failure.function} returned "
                f"{STATUS_NAMES.get(failure.status, failure.status)}]",
                result,
            ) from None
        except FMICallException as error:
            name, at = current
            result.partial = True
            message = logbook.last_problem(name) if name else str(error)
            raise SimulationError(name, at, f"{message} [{error}]", result) from None
        finally:
            if plan is not None:
                plan.drain(result)  # the rows not yet handed over (also after a failure)
                if result.kept:
                    plan.collect(result)
            result.meta["wall_time_s"] = clock.perf_counter() - started
            result.meta["steps"] = max(result.rows - 1, 0)
            if logbook.dropped:
                result.meta["log_dropped"] = logbook.dropped
            for component in instantiated:
                instances.release(component)
                component.slave = None
            if own:
                instances.close()
        return result

    # --- checkpoints ------------------------------------------------------------------
    def _states(self) -> dict[str, bytes]:
        """Every component's FMU state, serialised by the FMU."""
        states = {}
        for name, component in self.components.items():
            slave = component.slave
            if component.version == 3:
                state = slave.getFMUState()
                states[name] = bytes(slave.serializeFMUState(state))
                slave.freeFMUState(state)
            else:
                state = slave.getFMUstate()
                states[name] = bytes(slave.serializeFMUstate(state))
                slave.freeFMUstate(state)
        return states

    def _guids(self) -> dict[str, str]:
        return {name: c.description.guid for name, c in self.components.items()}

    def _save_checkpoint(
        self, checkpoints: Checkpoints, plan: _StepPlan, index: int, result: Result
    ) -> None:
        """Write a checkpoint at point ``index`` (the last recorded): the FMU states, the
        rows still in memory and, when rows were let go, where the sink's file holds them
        (every row up to ``index`` is handed to the sink first)."""
        plan.drain(result)
        time = plan.times[-1] if plan.times else plan.last_time
        stream = None
        if plan.let_go:
            position = getattr(plan.sink, "position", None)
            if position is None:
                raise CheckpointError(
                    "the run lets its rows go to a sink that cannot say where they are: "
                    "no checkpoint"
                )
            stream = position()
        checkpoint = Checkpoint(
            scene=self.scene.name,
            digest=scene_digest(self.scene),
            index=index,
            time=time,
            guids=self._guids(),
            states=self._states(),
            rows=plan.recorded_rows(),
            times=list(plan.times),
            streamed=plan.let_go,
            stream=stream,
        )
        save_checkpoint(checkpoints.path, checkpoint)
        result.meta["checkpoint"] = {"file": str(checkpoints.path), "index": index}

    def _checkpointer(
        self, checkpoints: Checkpoints | None, plan: _StepPlan, result: Result
    ) -> Callable[[int], None] | None:
        """``on_point`` for the loop: a checkpoint every ``checkpoints.steps`` points and
        whenever ``checkpoints.seconds`` of wall time have passed since the last."""
        if checkpoints is None or (checkpoints.steps <= 0 and checkpoints.seconds <= 0):
            return None
        steps, seconds = checkpoints.steps, checkpoints.seconds
        due = [clock.monotonic() + seconds if seconds > 0 else math.inf]

        def on_point(index: int) -> None:
            if (steps > 0 and index % steps == 0) or clock.monotonic() >= due[0]:
                self._save_checkpoint(checkpoints, plan, index, result)
                if seconds > 0:
                    due[0] = clock.monotonic() + seconds

        return on_point

    def check_checkpoints(self) -> None:
        """SceneError unless every component can serialise its FMU state."""
        for name, component in self.components.items():
            capabilities = component.description.coSimulation
            if not (capabilities.canGetAndSetFMUstate and capabilities.canSerializeFMUstate):
                raise CheckpointError(
                    f"component {name!r} ({component.description.modelName}) cannot "
                    "serialise its FMU state (canSerializeFMUstate is false): no checkpoints"
                )

    def check_resume(self, checkpoint: Checkpoint) -> None:
        """CheckpointError unless ``checkpoint`` was taken by a run of this scene with these
        FMUs (before anything runs or is written)."""
        check_matches(checkpoint, self.scene, self._guids())

    def _resume(self, checkpoint: Checkpoint, plan: _StepPlan, result: Result, sink: Any) -> int:
        """Restore ``checkpoint`` (every FMU state, the rows); the index of its point. The
        rows it let go must be in ``sink``'s file already (``sink.continued``); the rows it
        holds go to the sink unless that file has them too."""
        self.check_resume(checkpoint)
        continued = getattr(sink, "continued", 0)
        if checkpoint.streamed != continued:
            raise CheckpointError(
                f"the checkpoint's first {checkpoint.streamed} rows were streamed to the "
                f"result file of its run, here {continued} rows are: resume into the output "
                "folder of the run that wrote the checkpoint (its .partial file continues)"
            )
        for name, component in self.components.items():
            slave, data = component.slave, checkpoint.states[name]
            if component.version == 3:
                slave.setFMUState(slave.deserializeFMUState(data))
            else:
                slave.setFMUstate(slave.deSerializeFMUstate(data))
        plan.restore_rows(checkpoint.rows, len(checkpoint.times))
        plan.times.extend(checkpoint.times)
        plan.let_go = checkpoint.streamed
        plan.last_time = checkpoint.time
        plan.handed = len(checkpoint.times) if checkpoint.streamed else 0
        result.rows = checkpoint.index + 1
        result.meta["resumed_from"] = {"index": checkpoint.index, "time": checkpoint.time}
        return checkpoint.index

    def _feeds(self, name: str, skip: Any = ()) -> list[Any]:
        """(get from source, set on ``name``) pairs for the connected inputs of ``name``."""
        feeds = []
        for connection in self.connections:
            if connection.target == name and connection not in skip:
                source = self.components[connection.source]
                target = self.components[name]
                feeds.append(
                    (
                        source.getter(source.variables[connection.output]),
                        target.setter(target.variables[connection.input]),
                    )
                )
        return feeds

    def _feed(self, name: str, skip: Any = ()) -> None:
        """Set the connected inputs of ``name`` from its sources' current outputs."""
        for get, put in self._feeds(name, skip):
            put(get())

    def _set_from_source(self, connection: Connection) -> None:
        source, target = self.components[connection.source], self.components[connection.target]
        target.set(
            target.variables[connection.input], source.getter(source.variables[connection.output])()
        )


# --- the stepping loop: FMI calls bound once, buffers allocated once -----------------------

_TERMINATE = 100  # what an FMI 3.0 step adapter returns when the FMU asks to end the run


def _bare(function: Any) -> Any:
    """The C function behind ctypes' ``function`` as a caller without argument types,
    returning a C int (the status): it passes ctypes objects built once as they are, where
    fmpy's declared argtypes convert every argument at every call (0.4 us of a 1.7 us
    fmi2GetReal, measured)."""
    address = ctypes.cast(function, ctypes.c_void_p).value
    if address is None:  # never for a function the FMU's library exports
        raise FmuError(f"{function.__name__} is at a null address")
    return ctypes.CFUNCTYPE(ctypes.c_int)(address)


class _Fmi3Step:
    """fmi3DoStep as the loop calls fmi2DoStep, ``(instance, t, h, flag) -> status``; a
    step that asks to end the simulation (terminateSimulation) returns _TERMINATE, and
    ``last`` holds the FMU's last successful time."""

    def __init__(self, function: Any) -> None:
        self.function = function
        self.event, self.terminate, self.early = fmi3Boolean(), fmi3Boolean(), fmi3Boolean()
        self.last = fmi3Float64()
        self.outputs = (byref(self.event), byref(self.terminate), byref(self.early))
        self.time = byref(self.last)

    def __call__(self, instance: Any, start: float, size: float, flag: int) -> int:
        status = self.function(instance, start, size, flag, *self.outputs, self.time)
        return _TERMINATE if status <= _WARNING and self.terminate.value else status


def _termination(component: _Component, do_step: Any) -> Callable:
    """``ended(status) -> time or None``: after a step that did not succeed, the time at
    which the FMU asked to end the simulation, or None when it did not ask (FMI 2.0:
    fmi2Discard and fmi2GetBooleanStatus(fmi2Terminated); FMI 3.0: terminateSimulation)."""
    if component.version == 3:
        return lambda status: do_step.last.value if status == _TERMINATE else None
    slave = component.slave

    def ended(status: int) -> float | None:
        if status != 2:  # fmi2Discard
            return None
        try:
            if slave.getBooleanStatus(fmi2Terminated):
                return float(slave.getRealStatus(fmi2LastSuccessfulTime))
        except FMICallException:
            pass  # an FMU that cannot tell: no request to end
        return None

    return ended


class _InstantiationFailed(Exception):
    """fmi2Instantiate of ``component`` returned NULL."""

    def __init__(self, component: Any) -> None:
        super().__init__(component)
        self.component = component


class _Stopped(Exception):
    """The run's InterruptGuard received a signal; the loop stopped before the step at
    ``time``."""

    def __init__(self, time: float) -> None:
        super().__init__(time)
        self.time = time


class _NoStop:
    """The ``stop`` of a run nobody can interrupt (a sweep worker's)."""

    requested = False


_NEVER = _NoStop()


class _Ended(Exception):
    """Component ``component`` asked to end the simulation at ``time`` (s)."""

    def __init__(self, component: str, time: float) -> None:
        super().__init__(component, time)
        self.component, self.time = component, time


class _CallFailed(Exception):
    """An FMI call of the stepping loop returned a status worse than fmi2Warning."""

    def __init__(self, component: str, time: float, function: str, status: int) -> None:
        super().__init__(component, time, function, status)
        self.component, self.time, self.function, self.status = component, time, function, status


class CallTimer:
    """Accumulates the wall time (s) spent inside the wrapped FMI C functions.

    Used by the master (``run(time_fmi_calls=True)``) and, around fmpy's own calls, by the
    benchmarks, so both sides are timed at the same layer.
    """

    def __init__(self) -> None:
        self.total = 0.0
        self.by_call: dict[str, float] = {}  # label ("component.fmi2DoStep") -> s

    def wrap(self, function: Any, label: str | None = None) -> Any:
        """``function`` timed into ``total`` and, with a ``label``, into ``by_call[label]``."""

        def timed(*arguments: Any, _function=function, _clock=clock.perf_counter):
            begin = _clock()
            status = _function(*arguments)
            spent = _clock() - begin
            self.total += spent
            if label is not None:
                self.by_call[label] = self.by_call.get(label, 0.0) + spent
            return status

        # A ctypes caller may read these from the function it looked up (fmpy's _call does).
        for name in ("restype", "argtypes", "argnames"):
            setattr(timed, name, getattr(function, name, None))
        return timed


class _Call:
    """One raw FMI get or set of a group of variables of one type on one instance.

    The value references and the value buffer are ctypes arrays built once per run; the
    call's whole argument list (``arguments``: instance, references, their count, buffer and,
    FMI 3.0, the count of values) is built once too and passed as it is (``_bare``).
    """

    __slots__ = (
        "function",
        "arguments",
        "count",
        "buffer",
        "component",
        "name",
        "raw",
        "sent",
    )

    def __init__(
        self, component: Any, verb: str, fmi_type: Any, references: Any, buffer: Any, timer: Any
    ) -> None:
        version = component.version
        name = f"fmi{version}{verb}{called_type(version, fmi_type)}"
        function = _bare(getattr(component.slave.dll, name))
        self.function = timer.wrap(function, f"{component.name}.{name}") if timer else function
        self.count = len(references)
        count = ctypes.c_size_t(self.count)
        self.arguments = (
            ctypes.c_void_p(component.slave.component),
            (fmi2ValueReference * len(references))(*references),
            count,
            buffer,
        ) + ((count,) if version == 3 else ())  # FMI 3.0: nValues = nValueReferences
        self.buffer = buffer
        self.component, self.name = component.name, name
        self.raw = memoryview(buffer).cast("B")  # the buffer's bytes
        self.sent: bytes | None = None  # a set's bytes when it was last made (None: never)


class _Outputs:
    """The outputs of one type that the loop reads from one component after it steps.

    One call reads them all into one buffer: first each connection group's outputs, in a
    contiguous block that the group's target sets its inputs from directly (a view into
    this buffer, no copy), then the recorded outputs not already read. A recorded row is
    the buffer's bytes appended as they are.
    """

    def __init__(
        self,
        component: _Component,
        fmi_type: str,
        groups: list[Any],
        recorded: list[Any],
        timer: CallTimer | None,
    ) -> None:
        variables = [variable for _, variables in groups for variable in variables]
        self.offsets, start = {}, 0
        for key, group in groups:
            self.offsets[key] = start
            start += len(group)
        self.positions = {}  # recorded name -> index in the buffer
        for full_name, variable in recorded:
            if variable not in variables:
                variables.append(variable)
            self.positions[full_name] = variables.index(variable)
        ctype, code = element(component.version, fmi_type)
        self.call = _Call(
            component,
            "Get",
            fmi_type,
            [v.valueReference for v in variables],
            (ctype * len(variables))(),
            timer,
        )
        self.rows = array(code or "B")  # row-major, one row per point (String: never recorded)
        self.raw = memoryview(self.call.buffer).cast("B")  # the buffer's bytes, viewed once

    def view(self, key: Any, size: Any) -> Any:
        """The part of the buffer that holds connection group ``key`` (shared memory)."""
        ctype = self.call.buffer._type_
        return (ctype * size).from_buffer(
            self.call.buffer, self.offsets[key] * ctypes.sizeof(ctype)
        )


class _StepPlan:
    """Everything the stepping loop calls, bound once.

    Each component's needed outputs are read once after it steps; its targets set their
    inputs straight from that buffer. Gauss-Seidel: set, step and read one component after
    the other, so a target sees its sources' values at the end of the step (a lagged
    source, stepped later, still holds the previous point's). Jacobi: every component's
    inputs are set from the buffers of the previous point before any component steps.
    """

    def __init__(
        self,
        simulation: Simulation,
        timer: CallTimer | None,
        sink: Any = None,
        keep: bool = True,
    ) -> None:
        self.sink, self.keep = sink, keep
        self.times = array("d")  # the recorded rows' times not yet let go (keep: all)
        self.handed = 0  # of them, rows already given to the sink
        self.let_go = 0  # rows given to the sink and dropped (keep False)
        self.last_time = math.nan  # s, the time of the last row let go
        self.last_drain = clock.perf_counter()
        components = simulation.components
        self.jacobi = simulation.scene.coupling == "jacobi"
        members: dict[
            tuple, tuple[list, list]
        ] = {}  # (target, source, type) -> ([source outputs], [target inputs])
        for connection in simulation.connections:
            output = components[connection.source].variables[connection.output]
            outputs, inputs = members.setdefault(
                (connection.target, connection.source, output.type), ([], [])
            )
            outputs.append(output)
            inputs.append(components[connection.target].variables[connection.input])
        groups: dict[tuple, list] = {}  # (source, type) -> [(member key, [source outputs])]
        for key, (outputs, _) in members.items():
            groups.setdefault(key[1:], []).append((key, outputs))
        recorded: dict[tuple, list] = {}
        for full_name, component, variable in simulation.recorded:
            recorded.setdefault((component.name, variable.type), []).append((full_name, variable))
        self.outputs = {
            key: _Outputs(
                components[key[0]], key[1], groups.get(key, []), recorded.get(key, []), timer
            )
            for key in list(groups) + [k for k in recorded if k not in groups]
        }
        self.recorders = [self.outputs[key] for key in recorded]
        self.recorder_keys = [f"{name}|{fmi_type}" for name, fmi_type in recorded]
        self.versions = {name: component.version for name, component in components.items()}
        # each recorded name's (recorder, position in its rows) in the recorded order
        self.layout = [
            (self.outputs[(component.name, variable.type)], full_name)
            for full_name, component, variable in simulation.recorded
        ]
        self.steps = []  # (name, doStep, instance, [input sets], [output reads], ended)
        for name in simulation.order:
            sets = [
                _Call(
                    components[name],
                    "Set",
                    inputs[0].type,  # the target's own type name (Real: Float64 in FMI 3.0)
                    [v.valueReference for v in inputs],
                    self.outputs[key[1:]].view(key, len(inputs)),
                    timer,
                )
                for key, (_, inputs) in members.items()
                if key[0] == name
            ]
            reads = [outputs.call for (owner, _), outputs in self.outputs.items() if owner == name]
            component = components[name]
            slave = component.slave
            do_step = (
                _Fmi3Step(slave.dll.fmi3DoStep) if component.version == 3 else slave.dll.fmi2DoStep
            )
            self.steps.append(
                (
                    name,
                    timer.wrap(do_step, f"{name}.fmi{component.version}DoStep")
                    if timer
                    else do_step,
                    slave.component,
                    sets,
                    reads,
                    _termination(component, do_step),
                )
            )

    @staticmethod
    def _call(call: _Call, time: float) -> None:
        status = call.function(*call.arguments)
        if status > _WARNING:
            raise _CallFailed(call.component, time, call.name, status)

    @classmethod
    def _set(cls, call: _Call, time: float) -> None:
        """A set of inputs, made only if their values changed since it was last made (an
        FMU keeps an input's value until it is set again)."""
        raw = call.raw
        if raw != call.sent:
            cls._call(call, time)
            call.sent = raw.tobytes()

    def start(self, result: Result, time: float, record: bool = True) -> None:
        """Read every needed output after initialisation (or a restored checkpoint) and
        record the first row (unless ``record`` is False: the checkpoint brought it)."""
        for _, _, _, _, reads, _ in self.steps:
            for read in reads:
                self._call(read, time)
        if record:
            self._record(result, time)

    def recorded_rows(self) -> dict[str, tuple[str, bytes]]:
        """Every recorder's rows so far: key -> (array typecode, bytes) (a checkpoint)."""
        return {
            key: (recorder.rows.typecode, recorder.rows.tobytes())
            for key, recorder in zip(self.recorder_keys, self.recorders)
        }

    def restore_rows(self, rows: dict[str, tuple[str, bytes]], count: int) -> None:
        """Put back the ``count`` rows of a checkpoint (CheckpointError when they are not
        this run's)."""
        if set(rows) != set(self.recorder_keys):
            raise CheckpointError("the checkpoint recorded other variables than this run does")
        for key, recorder in zip(self.recorder_keys, self.recorders):
            typecode, data = rows[key]
            size = count * recorder.call.count * recorder.rows.itemsize
            if typecode != recorder.rows.typecode or len(data) != size:
                raise CheckpointError(f"the checkpoint's rows of {key} are not {count} rows")
            recorder.rows.frombytes(data)

    def _record(self, result: Result, time: float) -> None:
        for recorder in self.recorders:
            recorder.rows.frombytes(recorder.raw)
        self.times.append(time)
        result.rows = self.let_go + len(self.times)

    def recorded(self) -> int:
        """The rows recorded so far, let go or not."""
        return self.let_go + len(self.times)

    def drain(self, result: Result) -> None:
        """Give the rows recorded since the last drain to the sink (each column as an
        array, in the recorded order) and, unless the run keeps its rows, let them go."""
        result.rows = self.let_go + len(self.times)
        self.last_drain = clock.perf_counter()
        if self.sink is None:
            return
        rows = min(
            [len(self.times)] + [len(r.rows) // r.call.count for r in self.recorders]
        )  # complete rows (a failed step records none)
        first = self.handed
        if rows > first:
            self.sink.rows(
                self.times[first:rows],
                [
                    recorder.rows[
                        first * recorder.call.count + recorder.positions[name] : rows
                        * recorder.call.count : recorder.call.count
                    ]
                    for recorder, name in self.layout
                ],
            )
        if self.keep:
            self.handed = rows
            return
        self.let_go += rows
        if rows:
            self.last_time = self.times[rows - 1]
        del self.times[:rows]
        for recorder in self.recorders:
            del recorder.rows[: rows * recorder.call.count]
        self.handed = 0

    def run(
        self,
        result: Result,
        scene: Scene,
        stop: InterruptGuard | _NoStop = _NEVER,
        first: int = 1,
        on_point: Callable[[int], None] | None = None,
    ) -> None:
        """Step from start_time to stop_time, recording after every communication step
        (each time point computed as it comes: scene.time, no list of them); before each
        step, stop with _Stopped if ``stop`` has been requested; with a sink, drain every
        CHUNK_ROWS rows or FLUSH_SECONDS. A component that asks to end the simulation ends
        the run after its outputs are read: the last row is at the time it reached
        (_Ended; the caller's final drain hands it to the sink). ``first``: the index of the
        first communication point to step to (a resumed run: the one after its checkpoint);
        ``on_point(index)``: called after each row is recorded (checkpoints)."""
        put_changed, jacobi = self._set, self.jacobi
        time_of, last_index = scene.time, scene.steps
        draining, now = self.sink is not None, clock.perf_counter
        # Everything a step calls, unpacked once: (name, doStep, instance, input sets as
        # (function, arguments, their bytes, call), output reads as (function, arguments,
        # call)).
        steps = [
            (
                name,
                do_step,
                ctypes.c_void_p(instance),
                [(s.function, s.arguments, s.raw, s) for s in sets],
                [(r.function, r.arguments, r) for r in reads],
                ended,
            )
            for name, do_step, instance, sets, reads, ended in self.steps
        ]
        rows = [(recorder.rows.frombytes, recorder.raw) for recorder in self.recorders]
        append_time, times = self.times.append, self.times
        end = time_of(first - 1)
        for index in range(first, last_index + 1):
            start = end
            if stop.requested:
                raise _Stopped(start)
            end = time_of(index)
            size = end - start
            if jacobi:  # every input from the previous point's outputs, then every step
                for _, _, _, sets, _, _ in steps:
                    for _, _, _, put in sets:
                        put_changed(put, start)
            for name, do_step, instance, sets, reads, ended in steps:
                if not jacobi:  # _set, inline: a set only when its values changed
                    for function, arguments, raw, put in sets:
                        if raw != put.sent:
                            status = function(*arguments)
                            if status > _WARNING:
                                raise _CallFailed(put.component, start, put.name, status)
                            put.sent = raw.tobytes()
                status = do_step(instance, start, size, fmi2True)
                if status > _WARNING:
                    self._end(name, start, status, ended(status), reads, result)
                for function, arguments, read in reads:
                    status = function(*arguments)
                    if status > _WARNING:
                        raise _CallFailed(read.component, end, read.name, status)
            for add, raw in rows:  # _record, inline
                add(raw)
            append_time(end)
            if draining and (
                len(times) - self.handed >= CHUNK_ROWS or now() - self.last_drain >= FLUSH_SECONDS
            ):
                self.drain(result)
            if on_point is not None:
                on_point(index)
        result.rows = self.let_go + len(times)

    def _end(
        self, name: str, start: float, status: int, time: float | None, reads: Any, result: Result
    ) -> None:
        """After component ``name``'s step from ``start`` returned ``status``: _CallFailed,
        or, when it asked to end the simulation at ``time``, its outputs read, the last row
        recorded at ``time`` and _Ended."""
        if time is None:
            raise _CallFailed(name, start, f"fmi{self.versions[name]}DoStep", status)
        for *_, read in reads:
            self._call(read, time)
        self._record(result, time)
        raise _Ended(name, time)

    def collect(self, result: Result) -> None:
        """Copy the recorded rows into result.times and result.columns (also after a
        failed run)."""
        recorders = self.recorders
        rows = min([len(self.times)] + [len(r.rows) // r.call.count for r in recorders])
        result.times = [float(time) for time in self.times[:rows]]
        result.rows = rows
        for recorder in recorders:
            width = recorder.call.count
            for name, position in recorder.positions.items():
                result.columns[name] = [
                    float(value) for value in recorder.rows[position : rows * width : width]
                ]


_WARNING = 1  # fmi2Warning: the worst status a step may return and still count as done
_DISCARD = 2  # fmi2Discard: from here on a status is a problem (LogBook keeps it)


def parameter_values(
    simulation: Simulation,
) -> dict[str, dict[str, str | dict[str, float]] | dict[str, str | dict[str, float] | list[str]]]:
    """Every parameter of every component as applied: scene values over FMU defaults."""
    values = {}
    for component in simulation.components.values():
        applied = {}
        for variable in component.variables.values():
            if variable.causality == "parameter":
                start = start_value(variable)
                applied[variable.name] = component.spec.parameters.get(
                    variable.name, True if variable.name in component.spec.effects else start
                )
        values[component.name] = {
            "fmu": str(component.path),
            "model": component.description.modelName,
            "guid": component.description.guid,
            "parameters": applied,
            "effects": list(component.spec.effects),
            "inputs": dict(component.spec.inputs),
        }
    return values
