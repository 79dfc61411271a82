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


def run(scene_name, args):
    """Run sims/scenes/<scene_name>.toml; exit with a message on a scene or FMU failure."""
    from mechfmu.cosim.master import SimulationError
    from mechfmu.cosim.run import run_scene
    from mechfmu.cosim.scene import SceneError
    try:
        return run_scene(ROOT / "sims" / "scenes" / f"{scene_name}.toml", args.out,
                         args.fmu_dir, plot=not args.no_plot)
    except SceneError as error:
        sys.exit(f"scene error: {error}")
    except SimulationError as error:
        sys.exit(f"simulation failed: {error}\npartial results: "
                 + ", ".join(str(p) for p in error.paths.values()))
