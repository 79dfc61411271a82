"""Run the shipped sweeps (src/mechfmu/sweeps/*.toml), check them against their references and write
out/sweeps/: each sweep's folder (sweep.csv, sweep.json, plots), summary.md and
suspension_mass.png (static and sudden snap-through on one plot). `make sweeps` runs it.

    python sims/run_sweeps.py [--quick] [--jobs J] [--scheduler tcp://HOST:PORT] [--out DIR]

--quick runs a few points of each sweep around its threshold (what the tests run).
Exit status 1 if a sweep disagrees with its reference.
"""

import argparse
import sys
from pathlib import Path

from mechfmu.cosim.scene import SWEEP_DIR
from mechfmu.tools.report import sweeps

ROOT = Path(__file__).resolve().parent.parent
TOLERANCES = {"gear_max_error_s": 1e-6, "valve_max_relative_error": 1e-9,
              "static_deflection_m": 1e-9}  # the scenes' declared tolerances or tighter


def failures(findings):
    """What disagrees with the references, as sentences (empty: all agree)."""
    found = []
    for name, suspension in findings["suspension"].items():
        if not suspension["inside"]:
            found.append(f"{name}: reference mass {suspension['reference_kg']:.4f} kg outside "
                         f"the sweep's bracket {suspension['bracket_kg']}")
    static = findings["suspension"][sweeps.STATIC]["deflection_max_error_m"]
    if not static <= TOLERANCES["static_deflection_m"]:
        found.append(f"static deflections differ from the closed form by {static:.3g} m")
    gear = findings["gear"]
    if gear["disagree"] or not gear["max_error_s"] <= TOLERANCES["gear_max_error_s"]:
        found.append(f"gear: retraction times differ by {gear['max_error_s']:.3g} s; "
                     f"disagreements {gear['disagree']}")
    valve = findings["valve"]["max_relative_error"]
    if not valve <= TOLERANCES["valve_max_relative_error"]:
        found.append(f"valve: float speeds differ by {valve:.3g} (relative)")
    return found


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a few points of each sweep")
    parser.add_argument("--jobs", type=int, default=None, help="local worker processes")
    parser.add_argument("--scheduler", help="a Dask scheduler, tcp://HOST:PORT")
    parser.add_argument("--out", default=str(ROOT / "out" / "sweeps"), help="output folder")
    parser.add_argument("--fmu-dir", default=str(ROOT / "fmus"), help="built FMUs")
    args = parser.parse_args(argv)
    summaries = sweeps.run_shipped(SWEEP_DIR, args.out, args.fmu_dir, args.jobs, args.quick,
                                   args.scheduler)
    findings, text = sweeps.report(SWEEP_DIR, args.out, summaries)
    print(text)
    print(f"wrote {Path(args.out) / 'summary.md'} and {Path(args.out) / 'suspension_mass.png'}")
    problems = failures(findings)
    for problem in problems:
        print(f"DISAGREES: {problem}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
