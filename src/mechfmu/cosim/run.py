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
from .results import (
    CSV_VALUE_BYTES,
    PARQUET_VALUE_BYTES,
    StreamedResult,
    move_aside_complete,
    result_meta,
)
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
    if not limits.exists(path) and Path(str(scene)).suffix != ".toml" and "/" not in str(scene):
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


IN_MEMORY_ROWS = 100_000  # rows run_scene keeps in its Result besides the file (keep=None)


def output_estimate(scene: Scene, columns: int, fmt: str = "csv") -> tuple[int, int]:
    """(rows, bytes) a run of ``scene`` recording ``columns`` variables writes: its
    communication points and, per row, the time and each column at the most a value takes
    in ``fmt`` (CSV_VALUE_BYTES, PARQUET_VALUE_BYTES)."""
    rows = scene.steps + 1
    per_value = CSV_VALUE_BYTES if fmt == "csv" else PARQUET_VALUE_BYTES
    return rows, rows * (columns + 1) * per_value


def _size_text(size: float) -> str:
    """A byte count for people: '2.1 GB'."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if size >= scale:
            return f"{size / scale:.3g} {unit}"
    return f"{size:.0f} bytes"


def check_output_size(
    scene: Scene, columns: int, fmt: str = "csv", max_output: int | None = None
) -> None:
    """SceneError, one line naming the steps, the estimated size and the option that lifts
    the limit, when a run of ``scene`` would write more than ``max_output`` bytes (None:
    limits.MAX_RUN_OUTPUT_BYTES). Called before anything runs."""
    limit = limits.MAX_RUN_OUTPUT_BYTES if max_output is None else max_output
    rows, size = output_estimate(scene, columns, fmt)
    if size > limit:
        raise SceneError(
            f"{scene.path}: {rows - 1} steps of {scene.step!r} s (start_time "
            f"{scene.start_time!r} s to stop_time {scene.stop_time!r} s) would write up to "
            f"{_size_text(size)} of {fmt.upper()} ({columns + 1} columns), over the limit of "
            f"{_size_text(limit)}: pass --max-output {_size_text(size * 1.1).replace(' ', '')} "
            f"(max_output= in Python) to run it anyway, or record less, coarsen the step or "
            f"shorten the run"
        )


def run_scene(
    scene: Path | Scene,
    out_dir: Path | str,
    fmu_dir: str | os.PathLike | None = None,
    plot: bool = True,
    guard: InterruptGuard | None = None,
    parameters: dict[str, Any] | None = None,
    checkpoints: Checkpoints | None = None,
    resume: Path | None = None,
    fmt: str = "csv",
    max_output: int | None = None,
    keep: bool | None = None,
) -> tuple[Result, dict[str, Path]]:
    """Run ``scene`` (a Scene or a path) and write its files into ``out_dir``.

    The scene (prepare: its FMUs, ``parameters``, its table files) and the output folder
    (created if missing, OutputError if it cannot be written) are checked before anything
    runs, and so is the output's size (check_output_size: ``max_output`` bytes, None for
    limits.MAX_RUN_OUTPUT_BYTES). Returns (Result, {kind: path}).

    The rows are streamed to ``<scene>.partial.csv`` (``fmt = "parquet"``: .parquet) as
    they are made (StreamedResult), renamed to ``<scene>.csv`` with its JSON at the end:
    memory stays bounded whatever the run's length. ``keep``: whether the Result holds
    every row too (None: when the run has at most IN_MEMORY_ROWS rows; ``result.kept``).

    SIGINT and SIGTERM are taken between steps: ``guard`` is an InterruptGuard the caller
    has installed (the command line, for its whole duration), or None for one installed
    here for the run. On a component failure or such a signal an older complete result of
    the same name is moved aside (<scene>.previous.*), the rows computed so far are written
    as '<scene>.partial.csv' (and .json, .png; the JSON says ``interrupted`` and the
    signal) and the SimulationError (SimulationInterrupted) is re-raised with ``paths`` and
    ``moved_aside`` set (and ``output_error`` if the partial files could not be written).

    ``checkpoints``: write checkpoints of the run (cosim/checkpoint.py); ``resume``: the path
    of a checkpoint of this scene to continue from (checked before anything runs: a
    CheckpointError, a SceneError, names what does not match). A checkpoint of a run that
    let its rows go to its file continues that file: ``out_dir`` must be that run's, and
    ``fmt`` its format; the resumed run's files equal an uninterrupted run's.
    """
    with nullcontext(guard) if guard is not None else InterruptGuard() as guard:
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        simulation = prepare(scene, fmu_dir, parameters)
        check_output_size(simulation.scene, len(simulation.recorded), fmt, max_output)
        if checkpoints is not None:
            simulation.check_checkpoints()
        checkpoint = load_checkpoint(resume) if resume is not None else None
        if checkpoint is not None:
            simulation.check_resume(checkpoint)
        out_dir = output_folder(out_dir)
        if keep is None:
            keep = simulation.scene.steps + 1 <= IN_MEMORY_ROWS
        setup = {
            "parameters": dict(parameters or {}),
            "components": parameter_values(simulation),
            "order": simulation.order,
            "connections": [str(c) for c in simulation.connections],
            "pruned": simulation.pruned,
            "lagged_connections": [str(c) for c in simulation.lagged],
        }
        # a checkpoint that let rows go continues their file (the others start a new one)
        stream = StreamedResult(
            out_dir, scene.name, fmt, resume=checkpoint.stream if checkpoint else None
        )
        try:
            result = simulation.run(
                stop=guard,
                checkpoints=checkpoints,
                resume=checkpoint,
                sink=stream,
                keep=keep,
            )
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
                error.paths = stream.finish(error.result, result_meta(error.result), plot)
            except OutputError as problem:  # the failure is the news; the writer's joins it
                error.output_error = problem
            raise
        finally:
            stream.abandon()  # any other exception: the rows so far stay readable
        result.meta.update(setup, error=None, interrupted=False, signal=None)
        return result, stream.finish(result, result_meta(result), plot)
