"""Run a scene end to end: check it, simulate it, write its result files."""

from .master import Simulation, SimulationError, parameter_values
from .results import write_result
from .scene import Scene, load_scene


def run_scene(scene, out_dir, fmu_dir=None, plot=True):
    """Run ``scene`` (a Scene or a path) and write its files into ``out_dir``.

    Returns (Result, {kind: path}). On a component failure the rows computed so far are
    written as '<scene>.partial.csv' (and .json, .png) and the SimulationError is re-raised
    with ``paths`` set.
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    simulation = Simulation(scene, fmu_dir)
    setup = {"components": parameter_values(simulation), "order": simulation.order,
             "connections": [str(c) for c in simulation.connections],
             "pruned": simulation.pruned,
             "lagged_connections": [str(c) for c in simulation.lagged]}
    try:
        result = simulation.run()
    except SimulationError as error:
        error.result.meta.update(setup, error=str(error), failed_component=error.component,
                                 failed_at=error.time)
        error.paths = write_result(error.result, out_dir, plot)
        raise
    result.meta.update(setup, error=None)
    return result, write_result(result, out_dir, plot)
