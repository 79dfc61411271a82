"""Suspension dynamics: road bump and sudden load, checked against the solve_ivp references.

Runs sims/scenes/suspension_road_bump.toml (LoadProfile + RoadProfile -> Suspension with
dynamics, damping, tyre and road input) and sims/scenes/suspension_sudden_load.toml (a step
load below the static limit load that snaps the suspension through), and prints for each the
worst deviation of every recorded column from its reference, the scene's declared tolerance
and, for the sudden load, the snap-through time from the FMU's log.
"""

import re

import numpy as np

from _runner import ROOT, arguments, run

from mechfmu.check import compare
from mechfmu.cosim.results import read_csv
from mechfmu.physics import suspension as statics

SCENES = ("suspension_road_bump", "suspension_sudden_load")


def declared_tolerance(scene_name):
    text = (ROOT / "sims" / "scenes" / f"{scene_name}.toml").read_text()
    match = re.search(r"^# tolerance: rtol=([0-9.e+-]+), atol=([0-9.e+-]+)$", text, re.M)
    return float(match.group(1)), float(match.group(2))


def report(scene_name, args):
    result, paths = run(scene_name, args)
    rtol, atol = declared_tolerance(scene_name)
    print(f"{scene_name}: {result.meta['steps']} steps of {result.scene.step} s in "
          f"{result.meta['wall_time_s']:.3f} s wall time")
    for entry in result.log:
        if entry["status"] != "ok":
            print(f"  [{entry['status']}] {entry['message']}")
    _, reference = read_csv(result.scene.reference)
    times = np.asarray(result.times)
    print("  worst deviation from the solve_ivp reference (absolute; as a fraction of the "
          "column's peak |value|):")
    for name, values in result.columns.items():
        if name not in reference:
            continue
        expected = np.asarray(reference[name])
        difference = np.abs(np.asarray(values) - expected)
        i = int(np.argmax(difference))
        peak = max(float(np.max(np.abs(expected))), 1e-300)
        unit = result.units.get(name) or ""
        print(f"    {name:34s} {difference[i]:.2e} {unit:5s} at t = {times[i]:.3f} s "
              f"({difference[i] / peak:.1e} of peak)")
    comparison = compare(paths["csv"], result.scene.reference, rtol=rtol, atol=atol)
    print(f"  against the reference (declared rtol {rtol:g}, atol {atol:g}): {comparison}")
    return result, comparison.ok


def main():
    args = arguments(__doc__.splitlines()[0])
    ok = True
    for scene_name in SCENES:
        result, passed = report(scene_name, args)
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
