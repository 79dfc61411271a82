"""Running the study's points and measuring their error against the reference solution.

Each point runs through the project's master like any scene. Its cost is the stepping
loop's wall time (``meta['loop_time_s']``: what grows with simulated time; extraction and
instantiation, about 40 ms for two FMUs, are left out) as the median of ``repeats`` runs; its
error is taken against the scene's reference, computed once by the reference generator
(scipy Radau at rtol = atol = 1e-12) on the finest step's grid: at the points every run
shares (the coarsest step's), so a coarse step is not flattered by being looked at less
often (``max_error``, ``rms_error``), and at every point of the run (``max_error_all``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import dataclasses
import math
import statistics
from typing import Any

import numpy as np

from ...cosim.master import Simulation, SimulationError
from ..parallel import LocalPool
from ..scene_references import REFERENCES, sample_times
from .design import configure, counters

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from ...cosim.scene import Scene
    from .design import StudyScene

SLOW_RUN = 1.0  # s: a run this long is timed once (its spread is small against its length)

# One row of accuracy_cost.csv per (point, recorded output): each column and its type (str:
# text, float: SI number or time in s, int: a counter), in the file's order.
COLUMN_TYPES: dict[str, type] = {
    "scene": str,
    "integrator": str,
    "tolerance": float,
    "max_substep": float,
    "step": float,
    "coupling": str,
    "output": str,
    "max_error": float,
    "rms_error": float,
    "relative_error": float,
    "max_error_all": float,
    "reference_peak": float,
    "loop_time_s": float,
    "wall_time_s": float,
    "ms_per_simulated_s": float,
    "repeats": int,
    "communication_steps": int,
    "substeps": int,
    "rhs_evaluations": int,
    "status": str,
}
COLUMNS = tuple(COLUMN_TYPES)
TEXT_COLUMNS = tuple(name for name, kind in COLUMN_TYPES.items() if kind is str)
NUMBER_COLUMNS = tuple(name for name, kind in COLUMN_TYPES.items() if kind is float)
INTEGER_COLUMNS = tuple(name for name, kind in COLUMN_TYPES.items() if kind is int)


def reference(scene: Scene, study_scene: StudyScene) -> Any:
    """(times, {column: values}) of the scene's reference on the finest step's grid."""
    fine = dataclasses.replace(scene, step=study_scene.steps[0])
    columns = REFERENCES[scene.name](fine)
    return sample_times(fine), {
        name: np.asarray(values, dtype=float) for name, values in columns.items()
    }


def errors(
    times: Any, columns: Any, reference_times: Any, reference_columns: Any, common_step: Any
) -> Any:
    """{output: (max |error|, RMS error, max |error| at all points, peak |reference|)}.

    The first two are taken at the run's points that fall on the ``common_step`` grid,
    the third at all of its points. The run's times must lie on the reference's grid (the
    study's steps are multiples of the finest); a time off it is a design error.
    """
    times = np.asarray(times)
    spacing = reference_times[1] - reference_times[0]
    index = np.rint((times - reference_times[0]) / spacing).astype(int)
    if np.any(np.abs(reference_times[index] - times) > 1e-9 * spacing):
        raise ValueError("the run's sample times are not on the reference's grid")
    ratio = (times - reference_times[0]) / common_step
    common = np.abs(ratio - np.rint(ratio)) < 1e-6
    measured = {}
    for name, values in columns.items():
        if name not in reference_columns:
            continue
        expected = reference_columns[name][index]
        difference = np.abs(np.asarray(values) - expected)
        peak = float(np.max(np.abs(expected)))
        if not np.all(np.isfinite(difference)):
            measured[name] = (math.inf, math.inf, math.inf, peak)
            continue
        shared = difference[common]
        measured[name] = (
            float(shared.max()),
            float(np.sqrt(np.mean(shared**2))),
            float(difference.max()),
            peak,
        )
    return measured


def run_point(
    point: Any,
    scene: Any,
    study_scene: Any,
    reference_data: tuple[Any, Any],
    fmu_dir: Any,
    repeats: int,
) -> Any:
    """The rows of one point: its errors per output, cost and work counters."""
    configured = configure(scene, study_scene, point)
    simulation = Simulation(configured, fmu_dir)  # checked and its FMUs described once
    loop_times: list[float] = []
    wall_times: list[float] = []
    result: Any = None  # the last run's Result (repeats >= 1)
    failure = ""
    for _ in range(repeats):
        try:
            result = simulation.run()
        except SimulationError as error:
            result, failure = error.result, f"failed: {error}"
            break
        loop_times.append(result.meta["loop_time_s"])
        wall_times.append(result.meta["wall_time_s"])
        if result.meta["loop_time_s"] > SLOW_RUN:
            break
    rhs_name, substeps_name = counters(study_scene)
    span = scene.stop_time - scene.start_time
    loop = statistics.median(loop_times) if loop_times else math.nan
    common = {
        "scene": point.scene,
        "integrator": point.integrator,
        "tolerance": point.tolerance,
        "max_substep": point.max_substep,
        "step": point.step,
        "coupling": point.coupling,
        "loop_time_s": loop,
        "wall_time_s": statistics.median(wall_times) if wall_times else math.nan,
        "ms_per_simulated_s": loop / span * 1e3,
        "repeats": len(loop_times),
        "communication_steps": max(len(result.times) - 1, 0),
        "substeps": int(result.columns[substeps_name][-1]) if result.times else 0,
        "rhs_evaluations": int(result.columns[rhs_name][-1]) if result.times else 0,
        "status": failure or "ok",
    }
    counted = set(counters(study_scene))
    measured = (
        {}
        if failure
        else errors(result.times, result.columns, *reference_data, study_scene.steps[-1])
    )
    rows = []
    for name in configured.record:
        if name in counted or (not failure and name not in measured):
            continue
        largest, rms, everywhere, peak = measured.get(name, (math.nan,) * 4)
        rows.append(
            {
                **common,
                "output": name,
                "max_error": largest,
                "rms_error": rms,
                "relative_error": largest / peak if peak > 0 else math.nan,
                "max_error_all": everywhere,
                "reference_peak": peak,
            }
        )
    return rows


# --- parallel execution -----------------------------------------------------------------

_WORKER: dict[str, Any] = {}  # per worker process: the scenes and references, sent once at start


def _start_worker(payload: Any) -> None:
    _WORKER.update(payload)


def _run_in_worker(point: Any):
    scene, study_scene, reference_data = _WORKER["scenes"][point.scene]
    return run_point(
        point, scene, study_scene, reference_data, _WORKER["fmu_dir"], _WORKER["repeats"]
    )


def run_points(
    points: Any, scenes: Any, fmu_dir: Any, repeats: int, workers: int, progress: Any = None
) -> Any:
    """Rows of every point, run on ``workers`` processes (1: in this process).

    ``scenes`` maps a scene name to (scene, study scene, reference). Points are started
    finest step first so the long runs do not end up last on one worker.
    """
    payload = {"scenes": scenes, "fmu_dir": str(fmu_dir), "repeats": repeats}
    ordered = sorted(points, key=lambda p: (p.step, p.scene))
    rows = []
    if workers <= 1:
        _start_worker(payload)
        for done, point in enumerate(ordered, 1):
            rows.extend(_run_in_worker(point))
            if progress:
                progress(done, len(ordered), point)
        return rows
    # spawn: a fresh interpreter per worker, with no FMU loaded before it starts
    pool = LocalPool(workers, _run_in_worker, _start_worker, (payload,), context="spawn")
    try:
        for done, (point, point_rows) in enumerate(zip(ordered, pool.map(ordered)), 1):
            rows.extend(point_rows)
            if progress:
                progress(done, len(ordered), point)
    finally:
        pool.close()
    return rows
