"""Run a scene end to end: check it, simulate it, write its result files."""

from .files import OutputError, output_folder
from .master import Simulation, SimulationError, parameter_values
from .results import move_aside_complete, write_result
from .scene import Scene, load_scene


def run_scene(scene, out_dir, fmu_dir=None, plot=True):
    """Run ``scene`` (a Scene or a path) and write its files into ``out_dir``.

    The scene and the output folder (created if missing, OutputError if it cannot be
    written) are checked before anything runs. Returns (Result, {kind: path}). On a
    component failure an older complete result of the same name is moved aside
    (<scene>.previous.*), the rows computed so far are written as '<scene>.partial.csv'
    (and .json, .png) and the SimulationError is re-raised with ``paths`` and
    ``moved_aside`` set (and ``output_error`` if the partial files could not be written).
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    simulation = Simulation(scene, fmu_dir)
    out_dir = output_folder(out_dir)
    setup = {"components": parameter_values(simulation), "order": simulation.order,
             "connections": [str(c) for c in simulation.connections],
             "pruned": simulation.pruned,
             "lagged_connections": [str(c) for c in simulation.lagged]}
    try:
        result = simulation.run()
    except SimulationError as error:
        error.moved_aside = move_aside_complete(scene.name, out_dir)
        error.result.meta.update(setup, error=str(error), failed_component=error.component,
                                 failed_at=error.time,
                                 moved_aside=[str(path) for path in error.moved_aside])
        try:
            error.paths = write_result(error.result, out_dir, plot)
        except OutputError as problem:  # the failure is the news; the writer's error joins it
            error.output_error = problem
        raise
    result.meta.update(setup, error=None)
    return result, write_result(result, out_dir, plot)
