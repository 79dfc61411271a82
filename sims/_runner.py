"""Shared command line for the sims/run_*.py scripts."""

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def arguments(description):
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", default=str(ROOT / "out"), help="output folder")
    parser.add_argument("--fmu-dir", default=str(ROOT / "fmus"), help="folder of built FMUs")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    return parser.parse_args()


def run(scene, args):
    """Run a Scene or sims/scenes/<scene>.toml; exit with a message on a scene or FMU failure."""
    from mechfmu.cosim.files import OutputError
    from mechfmu.cosim.interrupt import exit_code
    from mechfmu.cosim.master import SimulationError, SimulationInterrupted
    from mechfmu.cosim.run import run_scene
    from mechfmu.cosim.scene import Scene, SceneError
    if not isinstance(scene, Scene):
        scene = ROOT / "sims" / "scenes" / f"{scene}.toml"
    try:
        return run_scene(scene, args.out, args.fmu_dir, plot=not args.no_plot)
    except (SceneError, OutputError) as error:
        sys.exit(f"{'scene' if isinstance(error, SceneError) else 'output'} error: {error}")
    except SimulationError as error:
        print(f"{'' if isinstance(error, SimulationInterrupted) else 'simulation failed: '}"
              f"{error}\npartial results: " + ", ".join(str(p) for p in error.paths.values()),
              file=sys.stderr)
        sys.exit(exit_code(error.signum) if isinstance(error, SimulationInterrupted) else 1)


def report(scene_name, args, rtol, atol, label="reference"):
    """Run a scene and print, per recorded column shared with its reference CSV, the worst
    absolute deviation (and as a fraction of the column's peak), the FMUs' non-ok log
    messages, and the verdict of ``mechfmu check`` at (rtol, atol). Returns (result, ok)."""
    import numpy as np

    from mechfmu.check import compare
    from mechfmu.cosim.results import read_csv

    result, paths = run(scene_name, args)
    print(f"{scene_name}: {result.meta['steps']} steps of {result.scene.step} s in "
          f"{result.meta['wall_time_s']:.3f} s wall time")
    for entry in result.log:
        if entry["status"] != "ok":
            print(f"  [{entry['status']}] {entry['message']}")
    _, reference = read_csv(result.scene.reference)
    times = np.asarray(result.times)
    print(f"  worst deviation from the {label} (absolute; as a fraction of the column's "
          f"peak |value|):")
    for name, values in result.columns.items():
        if name not in reference:
            continue
        expected = np.asarray(reference[name])
        difference = np.abs(np.asarray(values) - expected)
        i = int(np.argmax(difference))
        peak = max(float(np.max(np.abs(expected))), 1e-300)
        unit = result.units.get(name) or ""
        print(f"    {name:34s} {difference[i]:.2e} {unit:6s} at t = {times[i]:.5g} s "
              f"({difference[i] / peak:.1e} of peak)")
    comparison = compare(paths["csv"], result.scene.reference, rtol=rtol, atol=atol)
    print(f"  against the {label} (rtol {rtol:g}, atol {atol:g}): {comparison}")
    for kind, path in paths.items():
        print(f"  {kind}: {path}")
    return result, comparison.ok
