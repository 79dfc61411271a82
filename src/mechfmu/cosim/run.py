"""Run a scene end to end: the one entry the command line and the Python API call.

``prepare`` binds a scene to its FMUs (found by the one rule of cosim/locate.py), applies
parameter overrides (checked against the FMUs' declarations), reads its table files and
checks it; ``simulate`` runs it; ``run_scene`` runs it and writes its result files.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any
import copy
import os
from contextlib import nullcontext

from . import limits
from .checkpoint import Checkpoints
from .checkpoint import load as load_checkpoint
from .files import OutputError, output_folder
from .interrupt import InterruptGuard, signal_name
from .locate import scene_fmu_folder
from .master import (
    Simulation,
    SimulationError,
    SimulationInterrupted,
    model_description,
    parameter_values,
    resolve_fmu,
)
from .results import move_aside_complete, write_result
from .scene import (
    SCENE_DIR,
    ComponentSpec,
    Scene,
    SceneError,
    apply_parameters,
    check_tables,
    check_times,
    find_file,
    load_scene,
)
from pathlib import Path

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .master import Result


def choose_scene(
    scene: Scene | str | os.PathLike,
    start_time: float | None = None,
    stop_time: float | None = None,
    step: float | None = None,
) -> Scene:
    """The Scene ``scene`` names (a Scene, copied; a scene file; or a shipped scene's name,
    found from any folder), with the given times (s) replacing its own, checked as in the
    scene file (a whole number of steps). SceneError naming the shipped scenes for a name
    that is neither one of them nor a file."""
    overrides = {
        key: value
        for key, value in (("start_time", start_time), ("stop_time", stop_time), ("step", step))
        if value is not None
    }
    if isinstance(scene, Scene):
        chosen = copy.deepcopy(scene)
        for key, value in overrides.items():
            number = limits.finite_float(value)
            if number is None:
                raise SceneError(f"{key} = {limits.shortened(value)} must be a finite number")
            setattr(chosen, key, number)
        check_times(str(chosen.path), chosen.start_time, chosen.stop_time, chosen.step)
        return chosen
    if not isinstance(scene, (str, os.PathLike)):
        raise TypeError(
            f"scene must be a shipped scene's name, a scene file or a Scene, got "
            f"{type(scene).__name__}"
        )
    path = find_file(str(scene))
    if not path.exists() and Path(str(scene)).suffix != ".toml" and "/" not in str(scene):
        shipped = sorted(p.stem for p in SCENE_DIR.glob("*.toml"))
        raise SceneError(
            f"no shipped scene named {str(scene)!r} and no such file; shipped "
            f"scenes: {', '.join(shipped)}"
        )
    return load_scene(path, overrides)


def prepare(
    scene: Scene, fmu_dir: str | os.PathLike | None = None, parameters: dict[str, Any] | None = None
) -> Simulation:
    """``scene`` bound to its FMUs, checked and ready to run.

    The FMUs are those of ``fmu_dir`` or of the first folder the search finds
    (locate.scene_fmu_folder); ``parameters`` ({"component.parameter": value}, SI units;
    a constant input or an effect too) are set on ``scene`` in place after checking each
    name against its FMU's declared parameters (scene.apply_parameters); the table files
    are read (check_tables). SceneError naming the problem otherwise."""
    folder = scene_fmu_folder(scene, fmu_dir)

    def declared(spec: ComponentSpec) -> tuple[str, list[str]]:
        description = model_description(resolve_fmu(spec, scene, folder))
        names = [v.name for v in description.modelVariables if v.causality == "parameter"]
        return description.modelName, names

    apply_parameters(scene, parameters, declared)
    check_tables(scene)
    return Simulation(scene, folder)


def simulate(
    scene: Scene | str | os.PathLike,
    fmu_dir: str | os.PathLike | None = None,
    parameters: dict[str, Any] | None = None,
    guard: InterruptGuard | None = None,
    **times: float | None,
) -> tuple[Simulation, Result]:
    """Load ``scene`` (choose_scene: a Scene, a file or a shipped scene's name; ``times``:
    start_time, stop_time, step replacing its own), prepare it (its FMUs, ``parameters``,
    its table files), then run it: (the Simulation, whose ``scene`` is the one run, and its
    Result). ``guard``: the caller's InterruptGuard (SIGINT, SIGTERM taken between steps),
    or None for one installed here. SceneError for a scene that cannot run;
    SimulationError (SimulationInterrupted) when a component fails (a signal stops it)."""
    simulation = prepare(choose_scene(scene, **times), fmu_dir, parameters)
    with nullcontext(guard) if guard is not None else InterruptGuard() as guard:
        return simulation, simulation.run(stop=guard)


def run_scene(
    scene: Path | Scene,
    out_dir: Path | str,
    fmu_dir: str | os.PathLike | None = None,
    plot: bool = True,
    guard: InterruptGuard | None = None,
    parameters: dict[str, Any] | None = None,
    checkpoints: Checkpoints | None = None,
    resume: Path | None = None,
) -> tuple[Result, dict[str, Path]]:
    """Run ``scene`` (a Scene or a path) and write its files into ``out_dir``.

    The scene (prepare: its FMUs, ``parameters``, its table files) and the output folder
    (created if missing, OutputError if it cannot be written) are checked before anything
    runs. Returns (Result, {kind: path}).

    SIGINT and SIGTERM are taken between steps: ``guard`` is an InterruptGuard the caller
    has installed (the command line, for its whole duration), or None for one installed
    here for the run. On a component failure or such a signal an older complete result of
    the same name is moved aside (<scene>.previous.*), the rows computed so far are written
    as '<scene>.partial.csv' (and .json, .png; the JSON says ``interrupted`` and the
    signal) and the SimulationError (SimulationInterrupted) is re-raised with ``paths`` and
    ``moved_aside`` set (and ``output_error`` if the partial files could not be written).

    ``checkpoints``: write checkpoints of the run (cosim/checkpoint.py); ``resume``: the path
    of a checkpoint of this scene to continue from (checked before anything runs: a
    CheckpointError, a SceneError, names what does not match).
    """
    with nullcontext(guard) if guard is not None else InterruptGuard() as guard:
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        simulation = prepare(scene, fmu_dir, parameters)
        if checkpoints is not None:
            simulation.check_checkpoints()
        checkpoint = load_checkpoint(resume) if resume is not None else None
        out_dir = output_folder(out_dir)
        setup = {
            "parameters": dict(parameters or {}),
            "components": parameter_values(simulation),
            "order": simulation.order,
            "connections": [str(c) for c in simulation.connections],
            "pruned": simulation.pruned,
            "lagged_connections": [str(c) for c in simulation.lagged],
        }
        try:
            result = simulation.run(stop=guard, checkpoints=checkpoints, resume=checkpoint)
        except SimulationError as error:
            interrupted = isinstance(error, SimulationInterrupted)
            error.moved_aside = move_aside_complete(scene.name, out_dir)
            error.result.meta.update(
                setup,
                error=str(error),
                failed_component=error.component,
                failed_at=error.time,
                interrupted=interrupted,
                signal=(
                    signal_name(error.signum) if isinstance(error, SimulationInterrupted) else None
                ),
                moved_aside=[str(path) for path in error.moved_aside],
            )
            try:
                error.paths = write_result(error.result, out_dir, plot)
            except OutputError as problem:  # the failure is the news; the writer's joins it
                error.output_error = problem
            raise
        result.meta.update(setup, error=None, interrupted=False, signal=None)
        return result, write_result(result, out_dir, plot)
