"""Run a scene end to end: check it, simulate it, write its result files."""

from __future__ import annotations

from typing import TYPE_CHECKING
from contextlib import nullcontext

from .checkpoint import Checkpoints
from .checkpoint import load as load_checkpoint
from .files import OutputError, output_folder
from .interrupt import InterruptGuard, signal_name
from .master import Simulation, SimulationError, SimulationInterrupted, parameter_values
from .results import move_aside_complete, write_result
from .scene import Scene, check_tables, load_scene
from pathlib import Path

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .master import Result


def run_scene(
    scene: Path | Scene,
    out_dir: Path | str,
    fmu_dir: Path | str | None = None,
    plot: bool = True,
    guard: InterruptGuard | None = None,
    checkpoints: Checkpoints | None = None,
    resume: Path | None = None,
) -> tuple[Result, dict[str, Path]]:
    """Run ``scene`` (a Scene or a path) and write its files into ``out_dir``.

    The scene, its table files (check_tables) and the output folder (created if missing,
    OutputError if it cannot be written) are checked before anything runs. Returns (Result, {kind: path}).

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
        check_tables(scene)
        simulation = Simulation(scene, fmu_dir)
        if checkpoints is not None:
            simulation.check_checkpoints()
        checkpoint = load_checkpoint(resume) if resume is not None else None
        out_dir = output_folder(out_dir)
        setup = {
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
