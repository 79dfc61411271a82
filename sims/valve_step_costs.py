"""Where a step of the dynamic valve scenes goes: the time of each FMI call of the loop.

python sims/valve_step_costs.py [--repeats 20]: runs valve_train_dynamic and
valve_float_dynamic as shipped (Simulation.run with time_fmi_calls: wall clock inside each
FMI call, ``meta["fmi_call_times_s"]``) and prints a Markdown table per scene: each call's
median time per communication step (us), its share of the loop, and the loop's CPU time per
simulated s (the figure of ``mechfmu bench --only dynamic_scenes --cpu-time``; issue 33 asks
for 0.25). The rest of the loop (the master's own Python) is the row "master". See
docs/dynamics.md, "Dynamic scenes against real time".
"""

import argparse
import statistics

from mechfmu.cosim.locate import fmu_folder
from mechfmu.cosim.master import Simulation
from mechfmu.cosim.scene import SCENE_DIR, load_scene

SCENES = ("valve_train_dynamic", "valve_float_dynamic")


def call_costs(name: str, fmu_dir: str, repeats: int) -> str:
    """Markdown table of scene ``name``'s FMI calls: median us per step and share of the
    loop's wall time, over ``repeats`` timed runs after one warm-up."""
    scene = load_scene(SCENE_DIR / f"{name}.toml")
    simulation = Simulation(scene, fmu_dir)
    simulation.run(time_fmi_calls=True)
    runs = [simulation.run(time_fmi_calls=True).meta for _ in range(repeats)]
    steps = scene.steps
    per_step = {
        label: statistics.median(meta["fmi_call_times_s"][label] for meta in runs) / steps
        for label in runs[0]["fmi_call_times_s"]
    }
    loop = statistics.median(meta["loop_time_s"] for meta in runs) / steps
    per_step["master"] = loop - sum(per_step.values())
    cpu = statistics.median(meta["loop_cpu_time_s"] for meta in runs)
    span = scene.stop_time - scene.start_time
    lines = [
        f"{name}: loop {cpu / span:.3f} CPU s per simulated s ({steps} steps of "
        f"{scene.step:g} s, median of {repeats})",
        "",
        "| call | us per step | share of the loop |",
        "|---|---:|---:|",
    ]
    for label, seconds in sorted(per_step.items(), key=lambda item: -item[1]):
        lines.append(f"| {label} | {seconds * 1e6:.1f} | {seconds / loop:.1%} |")
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--repeats", type=int, default=20, help="timed runs per scene, median (default: 20)"
    )
    parser.add_argument(
        "--fmu-dir", help="folder of the built FMUs (default: found as by every command)"
    )
    args = parser.parse_args()
    folder = fmu_folder(["ValveSpring", "ValveTrain", "CamshaftDrive"], args.fmu_dir)
    print("\n\n".join(call_costs(name, folder, args.repeats) for name in SCENES))
