"""Benchmark 1: what the project's master costs per step, against fmpy.simulate_fmu.

Ours: mechfmu.cosim.master.Simulation on gear_retraction (PistonActuator -> LandingGear,
3 connections, 6 recorded outputs). fmpy: simulate_fmu running LandingGear.fmu alone, the
piston motion given as an input table on the same grid, 3 recorded outputs, on an FMU2Slave
instance made here (``fmu_instance=``) so that its FMI calls can be timed.

Each master runs at two lengths; the per-step time is the slope between them, so extraction
and instantiation cancel. The time inside FMI calls comes from separate timed runs (the
timers cost time of their own); overhead = per-step wall time - per-step FMI time.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import contextlib
import cProfile
import dataclasses
import io
import pstats
import shutil
from pathlib import Path
from typing import NamedTuple
from collections.abc import Callable, Sequence

from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

from ...cosim.fmu_file import unpack

from ...cosim.master import CallTimer, Simulation
from . import model_cost, timing
from .gear import (
    GEAR_OUTPUTS,
    KINEMATIC_SCENE,
    load_named_scene,
    piston_table,
    with_stop_time,
)
from .report import Row, Target, ratio_row
from .timing import per_step, seconds_of, set_up, side_by_side_medians

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from fmpy.simulation import SimulationResult
    from ...cosim.scene import Scene

BENCHMARK = "master overhead"
TARGET = Target(0.5, "<= 0.5")  # the issue: ours at most half of fmpy's
MICRO, MILLI = 1e6, 1e3


class FmiCallTimer:
    """Wall time (s) spent inside an FMU2Slave's C get/set/doStep functions.

    fmpy calls every FMI function through FMU2Slave._call, which looks the ctypes function
    up in the instance's ``_functions`` at each call. Replacing those entries times the C
    calls themselves: the layer the master's time_fmi_calls times (its raw calls on the
    library's functions), so that fmpy's Python around them (_call and its status check,
    Input, Recorder) counts as fmpy's overhead just as the master's own Python counts as
    ours.
    """

    FUNCTIONS = (
        "fmi2DoStep",
        "fmi2SetReal",
        "fmi2GetReal",
        "fmi2SetInteger",
        "fmi2GetInteger",
        "fmi2SetBoolean",
        "fmi2GetBoolean",
    )

    def __init__(self) -> None:
        self.timer = CallTimer()

    @property
    def seconds(self) -> float:
        return self.timer.total

    def attach(self, instance: FMU2Slave) -> None:
        functions = getattr(instance, "_functions", None)
        if not isinstance(functions, dict):
            raise RuntimeError(
                "this fmpy keeps no FMU2Slave._functions table (fmpy 0.3.2x "
                "does); the FMI-call timer cannot be attached"
            )
        for name in self.FUNCTIONS:
            functions[name] = self.timer.wrap(functions[name])


class FmpyGearAlone:
    """LandingGear.fmu alone under fmpy.simulate_fmu, fed the gear scene's piston motion
    (or, with ``component`` and ``outputs``, that component of the scene alone, its scene
    parameters and inputs as start values, no input table)."""

    def __init__(
        self,
        fmu_path: str | Path,
        scene: Scene,
        component: str = "gear",
        outputs: Sequence[str] = GEAR_OUTPUTS,
    ) -> None:
        self.scene, self.outputs = scene, tuple(outputs)
        self.description = read_model_description(str(fmu_path))
        self.folder = unpack(fmu_path)
        spec = scene.components[component]
        self.table = piston_table(scene) if component == "gear" else None
        # the unconnected inputs (and the parameters) as start values
        self.start_values = {**spec.parameters, **spec.inputs}

    def run(self, timer: FmiCallTimer | None = None) -> SimulationResult:
        """One run: instantiate, simulate_fmu, free. Attaches ``timer`` if given."""
        scene = self.scene
        instance = FMU2Slave(
            guid=self.description.guid,
            unzipDirectory=self.folder,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName="gear",
        )
        if timer is not None:
            timer.attach(instance)
        instance.instantiate()
        try:
            # fmpy prints a warning per input missing from the table (the three given as
            # start values); keep them out of the benchmark's own output.
            with contextlib.redirect_stdout(io.StringIO()):
                result = simulate_fmu(
                    self.folder,
                    model_description=self.description,
                    fmu_instance=instance,
                    start_time=scene.start_time,
                    stop_time=scene.stop_time,
                    step_size=scene.step,
                    output_interval=scene.step,
                    input=self.table,
                    output=list(self.outputs),
                    start_values=dict(self.start_values),
                )
        finally:
            instance.freeInstance()
        if len(result) != scene.steps + 1:
            raise RuntimeError(
                f"fmpy recorded {len(result)} points, expected "
                f"{scene.steps + 1} ({scene.steps} steps)"
            )
        return result

    def close(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


def _ours(simulation: Simulation, timed: bool) -> dict[str, float]:
    if not timed:
        return {"wall": seconds_of(simulation.run)}
    started = timing.now()
    result = simulation.run(time_fmi_calls=True)
    wall = timing.now() - started
    return {"wall": wall, "fmi": result.meta["fmi_call_time_s"]}


def _fmpy(alone: FmpyGearAlone, timed: bool) -> dict[str, float]:
    if not timed:
        return {"wall": seconds_of(alone.run)}
    timer = FmiCallTimer()
    wall = seconds_of(alone.run, timer)
    return {"wall": wall, "fmi": timer.seconds}


def _runs(
    ours: list[Simulation], alone: list[FmpyGearAlone]
) -> dict[tuple[str, str, bool], Callable]:
    """The measured runs: each master at each length, untimed and with FMI-call timers."""
    measurements = {}
    for timed in (False, True):
        for length, simulation, run in zip(("short", "long"), ours, alone):
            measurements[("ours", length, timed)] = lambda simulation=simulation, timed=timed: (
                _ours(simulation, timed)
            )
            measurements[("fmpy", length, timed)] = lambda run=run, timed=timed: _fmpy(run, timed)
    return measurements


class MasterRows(NamedTuple):
    wall: Row
    set_up: Row
    fmi: Row
    overhead: Row


def _master_rows(
    master: str,
    medians: dict[Any, dict[str, float]],
    steps: Sequence[int],
    description: str,
    repeats: int,
    label: str | None = None,
) -> MasterRows:
    """Wall, set-up, FMI and overhead rows of one master from the medians of its runs;
    ``label`` names the rows (default: the master)."""
    label = label or master

    def median(length: str, key: str, timed: bool) -> float:
        return medians[(master, length, timed)][key]

    span = f"slope between {steps[0]} and {steps[1]} steps"
    wall = per_step(median("short", "wall", False), median("long", "wall", False), *steps)
    fmi = per_step(median("short", "fmi", True), median("long", "fmi", True), *steps)
    return MasterRows(
        Row(
            BENCHMARK,
            f"{label}: wall per step",
            wall * MICRO,
            "us",
            repeats,
            notes=f"{description}; {span}",
        ),
        Row(
            BENCHMARK,
            f"{label}: set-up",
            set_up(median("short", "wall", False), wall, steps[0]) * MILLI,
            "ms",
            repeats,
            notes="intercept of the same line: extraction (ours only), instantiation, "
            "initialisation",
        ),
        Row(
            BENCHMARK,
            f"{label}: FMI calls per step",
            fmi * MICRO,
            "us",
            repeats,
            notes=f"time inside the C get/set/doStep calls; timed runs; {span}",
        ),
        Row(
            BENCHMARK,
            f"{label}: overhead per step",
            (wall - fmi) * MICRO,
            "us",
            repeats,
            notes="wall per step (untimed runs) - FMI calls per step (timed runs)",
        ),
    )


def actuator_alone(scene: Scene) -> Scene:
    """The gear scene's actuator alone: one FMU (PistonActuator), its three outputs
    recorded, no connections."""
    assert scene.record is not None  # the gear scene lists what it records
    return dataclasses.replace(
        scene,
        name=f"{scene.name} (actuator alone)",
        components={"actuator": scene.components["actuator"]},
        connections=[],
        record=[name for name in scene.record if name.startswith("actuator.")],
    )


def measure_one_fmu(
    scene_dir: str, fmu_dir: str | Path, lengths_s: Sequence[float], repeats: int
) -> list[Row]:
    """Rows of benchmark 1 on one FMU: our master and simulate_fmu each stepping
    PistonActuator.fmu alone with the gear scene's parameters, recording its 3 outputs."""
    scene = actuator_alone(load_named_scene(scene_dir, KINEMATIC_SCENE))
    scenes = [with_stop_time(scene, stop) for stop in lengths_s]
    steps = [s.steps for s in scenes]
    assert scene.record is not None  # set by actuator_alone
    outputs = [name.split(".", 1)[1] for name in scene.record]
    ours = [Simulation(s, fmu_dir) for s in scenes]
    alone = [
        FmpyGearAlone(Path(fmu_dir) / "PistonActuator.fmu", s, "actuator", outputs) for s in scenes
    ]
    # The same FMU's calls and nothing else: model_cost's raw ctypes loop (fmi2DoStep and
    # one fmi2GetReal of its 3 outputs per step, on arrays built once), the long run's steps.
    bare = model_cost.ExtractedFmu(Path(fmu_dir) / "PistonActuator.fmu")
    case = model_cost.ModelCase(
        "PistonActuator (bare loop)",
        "PistonActuator",
        scenes[1].stop_time - scenes[1].start_time,
        dict(scene.components["actuator"].parameters),
    )
    loop = model_cost.PreparedLoop(case, bare.description, steps[1])

    def bare_run() -> dict[str, float]:
        with bare.initialised(case.parameters) as instance:
            return {"wall": loop.run(instance).seconds}

    try:
        medians = side_by_side_medians({**_runs(ours, alone), "bare": bare_run}, repeats)
    finally:
        for run in alone:
            run.close()
        bare.close()
    descriptions = {
        "one FMU, ours": f"PistonActuator alone, {len(outputs)} recorded, steps of {scene.step} s",
        "one FMU, fmpy": f"simulate_fmu: PistonActuator.fmu alone, {len(outputs)} recorded, "
        f"steps of {scene.step} s",
    }
    rows = {
        label: _master_rows(master, medians, steps, descriptions[label], repeats, label)
        for label, master in (("one FMU, ours", "ours"), ("one FMU, fmpy", "fmpy"))
    }
    ours_rows, fmpy_rows = rows["one FMU, ours"], rows["one FMU, fmpy"]
    bare_row = Row(
        BENCHMARK,
        "one FMU, its calls alone: wall per step",
        medians["bare"]["wall"] / steps[1] * MICRO,
        "us",
        repeats,
        notes="fmi2DoStep + one fmi2GetReal of the 3 outputs per step in a bare ctypes loop "
        "(model_cost's), no master: what any master pays for this FMU",
    )
    return [
        *ours_rows,
        *fmpy_rows,
        bare_row,
        ratio_row(
            "one FMU: its calls alone / fmpy",
            bare_row,
            fmpy_rows.wall,
            notes="the lowest total-per-step ratio a master can reach with this FMU",
        ),
        ratio_row(
            "one FMU: total per step, ours / fmpy",
            ours_rows.wall,
            fmpy_rows.wall,
            TARGET,
            "the same FMU",
        ),
        ratio_row(
            "one FMU: overhead per step, ours / fmpy",
            ours_rows.overhead,
            fmpy_rows.overhead,
            TARGET,
        ),
    ]


def measure(
    scene_dir: str, fmu_dir: str | Path, lengths_s: Sequence[float], repeats: int
) -> list[Row]:
    """Rows of benchmark 1; ``lengths_s`` = (short, long) stop times in s."""
    scene = load_named_scene(scene_dir, KINEMATIC_SCENE)
    scenes = [with_stop_time(scene, stop) for stop in lengths_s]
    steps = [s.steps for s in scenes]
    ours = [Simulation(s, fmu_dir) for s in scenes]
    alone = [FmpyGearAlone(Path(fmu_dir) / "LandingGear.fmu", s) for s in scenes]
    try:
        medians = side_by_side_medians(_runs(ours, alone), repeats)
    finally:
        for run in alone:
            run.close()
    descriptions = {
        "ours": f"{KINEMATIC_SCENE}: PistonActuator -> LandingGear, "
        f"{len(ours[0].connections)} connections, {len(ours[0].recorded)} recorded, "
        f"steps of {scene.step} s",
        "fmpy": f"simulate_fmu: LandingGear.fmu alone, piston motion as an input table, "
        f"{len(GEAR_OUTPUTS)} recorded, steps of {scene.step} s",
    }
    rows = {
        master: _master_rows(master, medians, steps, descriptions[master], repeats)
        for master in ("ours", "fmpy")
    }
    ours_rows, fmpy_rows = rows["ours"], rows["fmpy"]
    return [
        *ours_rows,
        *fmpy_rows,
        ratio_row(
            "total per step, ours / fmpy",
            ours_rows.wall,
            fmpy_rows.wall,
            TARGET,
            "two FMUs against one",
        ),
        ratio_row("overhead per step, ours / fmpy", ours_rows.overhead, fmpy_rows.overhead, TARGET),
        *measure_one_fmu(scene_dir, fmu_dir, lengths_s, repeats),
    ]


def profile(
    scene_dir: Any, fmu_dir: Any, stop_time: float, top: Any = 15, stream: Any = None
) -> None:
    """Print cProfile's ``top`` functions by own time for one run of each master."""
    scene = with_stop_time(load_named_scene(scene_dir, KINEMATIC_SCENE), stop_time)
    simulation = Simulation(scene, fmu_dir)
    alone = FmpyGearAlone(Path(fmu_dir) / "LandingGear.fmu", scene)
    try:
        for label, run in (
            ("ours (Simulation.run, 2 FMUs)", simulation.run),
            ("fmpy (simulate_fmu, LandingGear alone)", alone.run),
        ):
            run()  # warm
            profiler = cProfile.Profile()
            profiler.runcall(run)
            print(f"\ncProfile, {label}, {scene.steps} steps: top {top} by tottime", file=stream)
            stats = pstats.Stats(profiler, stream=stream)
            stats.strip_dirs().sort_stats("tottime").print_stats(top)
    finally:
        alone.close()
