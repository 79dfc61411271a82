"""What effects cost: the kinematic gear scene against the full-dynamics one.

Both scenes cover the same 3 s at the same 0.01 s communication step. Each runs --repeats
times (no plot); the medians of the wall times and their ratio are printed. A benchmark,
not a test: timings depend on the machine.
"""

import argparse
import statistics
import time
from pathlib import Path

from mechfmu.cosim.master import Simulation
from mechfmu.cosim.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent


def wall_time(scene_name, fmu_dir, repeats):
    scene = load_scene(ROOT / "sims" / "scenes" / f"{scene_name}.toml")
    times = []
    for _ in range(repeats):
        simulation = Simulation(scene, fmu_dir)
        started = time.perf_counter()
        simulation.run()
        times.append(time.perf_counter() - started)
    return statistics.median(times), scene


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu-dir", default=str(ROOT / "fmus"))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    kinematic, scene = wall_time("gear_retraction", args.fmu_dir, args.repeats)
    full, _ = wall_time("gear_retraction_dynamic", args.fmu_dir, args.repeats)
    print(f"gear_retraction (kinematic, 2 FMUs):            {kinematic * 1e3:8.1f} ms "
          f"for {scene.stop_time} s, {scene.steps} steps (median of {args.repeats})")
    print(f"gear_retraction_dynamic (all six effects, radau): {full * 1e3:8.1f} ms")
    print(f"kinematic / full = 1/{full / kinematic:.1f}")


if __name__ == "__main__":
    main()
