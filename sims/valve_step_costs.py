"""Where a step of the dynamic valve scenes goes: the time of each FMI call of the loop.

python sims/valve_step_costs.py [--repeats 20]: runs valve_train_dynamic and
valve_float_dynamic as shipped (Simulation.run with time_fmi_calls: wall clock inside each
FMI call, ``meta["fmi_call_times_s"]``) and prints a Markdown table per scene: each call's
time per communication step (us) in the run of the fastest loop, its share of that loop, and
the loop's median CPU time per simulated s (the figure of ``mechfmu bench --only dynamic_scenes --cpu-time``; issue 33 asks
for 0.25). The rest of the loop (the master's own Python) is the row "master". See
docs/dynamics.md, "Dynamic scenes against real time".

With --floor it also runs each scene with ValveSpring's null twin in its place (the same
variables, a doStep that returns at once; built into a temporary folder): the loop's CPU
time without the valve's own computation, the floor of the three FMUs' boundary and the
master, which no work inside the valve can lower.

With --profile it also runs the valve alone in-process (ValveSpring driven by the scene's
camshaft motion, no FMU) under cProfile and prints its top functions by cumulative time:
where the valve's own step goes (cProfile's overhead inflates the small functions). The first
line of each table also gives the valve alone's CPU time per simulated s, without the FMU.
"""

import argparse
import cProfile
import dataclasses
import io
import pstats
import shutil
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from mechfmu.cosim.locate import fmu_folder
from mechfmu.cosim.master import Simulation
from mechfmu.cosim.scene import SCENE_DIR, load_scene
from mechfmu.runtime.models.shaft_drives import CamshaftDrive
from mechfmu.runtime.models.valve_spring import ValveSpring
from mechfmu.packaging.build import null_name
from mechfmu.runtime.physics.profiles import rotation
from mechfmu.tools.bench.model_cost import build_null_models

SCENES = ("valve_train_dynamic", "valve_float_dynamic")


def call_costs(name: str, fmu_dir: str, repeats: int) -> str:
    """Markdown table of scene ``name``'s FMI calls: us per step and share of the loop's
    wall time in the fastest of ``repeats`` timed runs after one warm-up."""
    scene = load_scene(SCENE_DIR / f"{name}.toml")
    simulation = Simulation(scene, fmu_dir)
    simulation.run(time_fmi_calls=True)
    runs = [simulation.run(time_fmi_calls=True).meta for _ in range(repeats)]
    steps = scene.steps
    # the fastest run's own breakdown: the wall clock of a slower one holds the time the
    # process waited for a core on a busy machine (in no call: the "master" row)
    fastest = min(runs, key=lambda meta: meta["loop_time_s"])
    per_step = {label: seconds / steps for label, seconds in fastest["fmi_call_times_s"].items()}
    loop = fastest["loop_time_s"] / steps
    per_step["master"] = loop - sum(per_step.values())
    cpu = statistics.median(meta["loop_cpu_time_s"] for meta in runs)
    span = scene.stop_time - scene.start_time
    lines = [
        f"{name}: loop {cpu / span:.3f} CPU s per simulated s ({steps} steps of "
        f"{scene.step:g} s, median of {repeats}); the valve alone in-process "
        f"{valve_alone_cpu(name, repeats):.3f}",
        "",
        "| call | us per step | share of the loop |",
        "|---|---:|---:|",
    ]
    for label, seconds in sorted(per_step.items(), key=lambda item: -item[1]):
        lines.append(f"| {label} | {seconds * 1e6:.1f} | {seconds / loop:.1%} |")
    return "\n".join(lines)


def valve_alone(name: str) -> tuple[ValveSpring, Callable[[], None]]:
    """Scene ``name``'s ValveSpring in-process (its parameters, initialised), and what steps
    it over the scene's span at its step with the camshaft's motion as CamshaftDrive makes
    it."""
    scene = load_scene(SCENE_DIR / f"{name}.toml")
    shaft = next(spec for spec in scene.components.values() if spec.fmu == "CamshaftDrive")
    valve = next(spec for spec in scene.components.values() if spec.fmu == "ValveSpring")
    drive = CamshaftDrive(instance_name="camshaft")
    drive.values.update(shaft.parameters)
    drive.check_parameters()
    model = ValveSpring(instance_name="valve")
    model.values.update(valve.parameters)

    def set_camshaft(time: float) -> None:
        angle, speed, acceleration = rotation(time, *drive.rotation)
        model.values.update(
            camshaft_angle=angle, camshaft_speed=speed, camshaft_acceleration=acceleration
        )

    def step_all() -> None:
        for index in range(scene.steps):
            start = scene.time(index)
            set_camshaft(scene.time(index + 1))
            if not model.do_step(start, scene.time(index + 1) - start):
                raise RuntimeError(f"{name}: the valve refused a step: {model.pending_error}")

    set_camshaft(scene.start_time)
    model.setup_experiment(scene.start_time)
    model.exit_initialization_mode()
    return model, step_all


def valve_alone_cpu(name: str, repeats: int) -> float:
    """Median CPU time (s) per simulated s of valve_alone's steps over ``repeats`` runs."""
    scene = load_scene(SCENE_DIR / f"{name}.toml")
    times = []
    for _ in range(repeats):
        step_all = valve_alone(name)[1]
        started = time.process_time()
        step_all()
        times.append(time.process_time() - started)
    return statistics.median(times) / (scene.stop_time - scene.start_time)


def loop_cpu(scene, fmu_dir: str, repeats: int) -> tuple[float, float]:
    """(first, median) CPU time per simulated s of ``scene``'s stepping loop over ``repeats``
    runs of one Simulation (the first pays for the FMUs' caches that later runs reuse)."""
    simulation = Simulation(scene, fmu_dir)
    times = [simulation.run().meta["loop_cpu_time_s"] for _ in range(repeats)]
    span = scene.stop_time - scene.start_time
    return times[0] / span, statistics.median(times) / span


def floor_table(fmu_dir: str, repeats: int) -> str:
    """Markdown table: each scene's loop CPU s per simulated s as shipped and with
    ValveSpring's null twin in its place (first run and median of ``repeats``)."""
    lines = [
        "| scene | as shipped: first, median | null valve: first, median |",
        "|---|---:|---:|",
    ]
    with tempfile.TemporaryDirectory() as folder:
        for fmu in Path(fmu_dir).glob("*.fmu"):
            shutil.copy(fmu, folder)
        build_null_models(["ValveSpring"], Path(folder))
        for name in SCENES:
            scene = load_scene(SCENE_DIR / f"{name}.toml")
            components = {
                key: dataclasses.replace(spec, fmu=null_name(spec.fmu))
                if spec.fmu == "ValveSpring"
                else spec
                for key, spec in scene.components.items()
            }
            floor = dataclasses.replace(scene, components=components)
            shipped = loop_cpu(scene, folder, repeats)
            null = loop_cpu(floor, folder, repeats)
            lines.append(
                f"| {name} | {shipped[0]:.3f}, {shipped[1]:.3f} | {null[0]:.3f}, {null[1]:.3f} |"
            )
    return "\n".join(lines)


def valve_profile(repeats: int, lines: int = 30) -> str:
    """cProfile's top ``lines`` functions (cumulative) of valve_alone's steps over both
    scenes, ``repeats`` times each (the set-up not profiled)."""
    profiler = cProfile.Profile()
    for _ in range(repeats):
        for name in SCENES:
            profiler.runcall(valve_alone(name)[1])
    stream = io.StringIO()
    pstats.Stats(profiler, stream=stream).sort_stats("cumulative").print_stats(lines)
    return stream.getvalue()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--repeats", type=int, default=20, help="timed runs per scene (default: 20)"
    )
    parser.add_argument(
        "--profile",
        action="store_true",
        help="also profile the valve alone in-process (default: off)",
    )
    parser.add_argument(
        "--floor",
        action="store_true",
        help="also run each scene with ValveSpring's null twin in its place (default: off)",
    )
    parser.add_argument(
        "--fmu-dir", help="folder of the built FMUs (default: found as by every command)"
    )
    args = parser.parse_args()
    folder = fmu_folder(["ValveSpring", "ValveTrain", "CamshaftDrive"], args.fmu_dir)
    print("\n\n".join(call_costs(name, folder, args.repeats) for name in SCENES))
    if args.floor:
        print("\n" + floor_table(folder, args.repeats))
    if args.profile:
        print(valve_profile(args.repeats))
