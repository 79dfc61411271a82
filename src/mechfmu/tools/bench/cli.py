"""``python -m mechfmu.tools.bench`` (also ``mechfmu bench``, ``make bench``): run the benchmarks,
write bench.csv, bench.md and machine.json, print the Markdown table.
"""

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from ...cosim.scene import SCENE_DIR, SWEEP_DIR
from . import effects, floor, master_overhead, model_cost, sweep
from .report import machine, machine_line, markdown_table, write_outputs


@dataclass(frozen=True)
class Settings:
    """How long each benchmark runs. Lengths in s of simulated time; steps per loop."""

    repeats: int
    master_lengths_s: tuple  # (short, long) stop times of the gear scene
    model_steps: int
    effects_stop_time_s: float = None  # None: the scenes as written (3 s)
    sweep_scenes: int = 1000  # scenes of the sweep benchmark, run once on 1 and on 2 workers


FULL = Settings(repeats=5, master_lengths_s=(3.0, 60.0), model_steps=2000)
# The master's lengths stay: a shorter span makes the slope noisy, and the runs are cheap.
QUICK = Settings(repeats=2, master_lengths_s=FULL.master_lengths_s, model_steps=200,
                 effects_stop_time_s=0.5, sweep_scenes=16)


def parse_arguments(argv):
    parser = argparse.ArgumentParser(
        prog="mechfmu bench", description="Benchmarks: master overhead against fmpy, model "
        "cost against null FMUs, effects, the closed-form floor, a sweep on 1 and 2 "
        "workers (README: Benchmarks).")
    parser.add_argument("--repeats", type=int, default=None,
                        help=f"measured repeats per case after one warm-up (default "
                             f"{FULL.repeats}, --quick {QUICK.repeats})")
    parser.add_argument("--quick", action="store_true",
                        help="fewer steps and repeats (for the test; timings are rough)")
    parser.add_argument("--out", default="data/bench", help="output folder (default data/bench)")
    parser.add_argument("--fmu-dir", default="fmus", help="folder of the built FMUs")
    parser.add_argument("--scenes", default=str(SCENE_DIR),
                        help="folder of the scene files (default: the shipped scenes)")
    parser.add_argument("--sweeps", default=str(SWEEP_DIR),
                        help="folder of the sweep files (default: the shipped sweeps)")
    parser.add_argument("--sweep-scenes", type=int, default=None,
                        help=f"scenes of the sweep benchmark (default {FULL.sweep_scenes}, "
                             f"--quick {QUICK.sweep_scenes})")
    parser.add_argument("--profile", action="store_true",
                        help="also print cProfile's top 15 functions of each master")
    args = parser.parse_args(argv)
    if args.repeats is not None and args.repeats < 1:
        parser.error("--repeats must be at least 1")
    if args.sweep_scenes is not None and args.sweep_scenes < 1:
        parser.error("--sweep-scenes must be at least 1")
    return args


def settings_for(args):
    chosen = QUICK if args.quick else FULL
    repeats = args.repeats if args.repeats is not None else chosen.repeats
    scenes = args.sweep_scenes if args.sweep_scenes is not None else chosen.sweep_scenes
    return Settings(repeats, chosen.master_lengths_s, chosen.model_steps,
                    chosen.effects_stop_time_s, scenes)


def missing_fmus(fmu_dir):
    needed = {"LandingGear", "PistonActuator", "LoadProfile", "Suspension",
              *(case.model for case in model_cost.CASES)}
    return sorted(name for name in needed if not (Path(fmu_dir) / f"{name}.fmu").is_file())


def run_benchmarks(args, settings):
    """Rows of the four benchmarks, in the order of the README."""
    rows = master_overhead.measure(args.scenes, args.fmu_dir, settings.master_lengths_s,
                                   settings.repeats)
    rows += model_cost.measure(args.fmu_dir, settings.model_steps, settings.repeats)
    rows += effects.measure(args.scenes, args.fmu_dir, settings.repeats,
                            settings.effects_stop_time_s)
    rows += floor.measure(args.scenes, args.fmu_dir, settings.repeats)
    rows += sweep.measure(args.sweeps, args.fmu_dir, settings.sweep_scenes)
    return rows


def main(argv=None) -> int:
    args = parse_arguments(argv)
    missing = missing_fmus(args.fmu_dir)
    if missing:
        print(f"bench: FMU(s) {', '.join(missing)} not found in {args.fmu_dir}; build them "
              f"with 'mechfmu build' (or 'make fmus')", file=sys.stderr)
        return 2
    settings = settings_for(args)
    started = time.perf_counter()
    rows = run_benchmarks(args, settings)
    info = machine()
    paths = write_outputs(args.out, rows, info)
    print(markdown_table(rows))
    print()
    print(machine_line(info))
    print(f"\n{len(rows)} measurements in {time.perf_counter() - started:.0f} s "
          f"({'quick' if args.quick else 'full'}, median of {settings.repeats} after one "
          f"warm-up); wrote {', '.join(str(path) for path in paths.values())}")
    if args.profile:
        master_overhead.profile(args.scenes, args.fmu_dir, settings.master_lengths_s[1])
    return 0
