"""Suspension dynamics: road bump and sudden load, checked against the solve_ivp references.

Runs scenes/suspension_road_bump.toml (LoadProfile + RoadProfile -> Suspension with
dynamics, damping, tyre and road input) and scenes/suspension_sudden_load.toml (a step
load below the static limit load that snaps the suspension through), and prints for each the
worst deviation of every recorded column from its reference, the scene's declared tolerance
and, for the sudden load, the snap-through time from the FMU's log.
"""

import re

from _runner import arguments, report

from mechfmu.cosim.scene import find_file
from mechfmu.runtime.physics import suspension as statics

SCENES = ("suspension_road_bump", "suspension_sudden_load")


def declared_tolerance(scene_name):
    text = find_file(scene_name).read_text()
    match = re.search(r"^# tolerance: rtol=([0-9.e+-]+), atol=([0-9.e+-]+)$", text, re.M)
    return float(match.group(1)), float(match.group(2))


def main():
    args = arguments(__doc__.splitlines()[0])
    ok = True
    for scene_name in SCENES:
        result, passed = report(scene_name, args, *declared_tolerance(scene_name),
                                label="solve_ivp reference")
        ok &= passed
        if scene_name == "suspension_sudden_load":
            limit = statics.limit_point(statics.make_spring(0.5, 1e4, 0.2)).load
            load = max(result.columns["load.load"])
            snaps = [m["message"] for m in result.log if "snap-through" in m["message"]]
            times = [float(re.search(r"at t = ([0-9.e+-]+) s", m).group(1)) for m in snaps]
            print(f"  load {load:.1f} N = {load / limit:.3f} of the static limit load "
                  f"{limit:.2f} N; snap-throughs at t = "
                  + ", ".join(f"{t:.6f} s" for t in times))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
