"""The valve scenes at larger communication steps: speed against their reference check.

python sims/dynamic_step_accuracy.py [--repeats 3]: runs valve_train_dynamic and
valve_float_dynamic at steps 1e-5 .. 2e-3 s in four configurations of the valve (the
rocker inputs with dopri5, as shipped before issue 21's goal 4; the rocker inputs with the
exact integrator; the camshaft drive with the exact integrator on drive pieces of 0.1 ms,
as shipped before issue 33, and of 1 ms, as shipped now), prints a Markdown table (loop
CPU time per simulated s, right-hand sides or closed-form
evaluations, worst deviation from the scipy reference sampled every 1e-5 s as a fraction of
the check's allowance; > 1 fails). See docs/dynamics.md, "Dynamic scenes against real time".
"""

import argparse

import pandas as pd

from mechfmu.cosim.locate import fmu_folder
from mechfmu.cosim.scene import SCENE_DIR
from mechfmu.tools.bench.dynamic_scenes import step_accuracy

STEPS = {
    "valve_train_dynamic": (1e-5, 1e-4, 5e-4, 1e-3, 2e-3),
    "valve_float_dynamic": (1e-5, 1e-4, 5e-4, 1e-3, 2e-3),
}

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--repeats", type=int, default=3, help="timed runs per point, median (default: 3)"
    )
    parser.add_argument(
        "--fmu-dir", help="folder of the built FMUs (default: found as by every command)"
    )
    args = parser.parse_args()
    args.fmu_dir = fmu_folder(["ValveSpring", "ValveTrain", "CamshaftDrive"], args.fmu_dir)
    frame = pd.concat(
        [
            step_accuracy(SCENE_DIR, args.fmu_dir, name, steps, args.repeats)
            for name, steps in STEPS.items()
        ],
        ignore_index=True,
    )
    print("| " + " | ".join(frame.columns) + " |")
    print("|" + "---|" * len(frame.columns))
    for row in frame.itertuples(index=False):
        print("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in row) + " |")
