"""``mechfmu bench`` (``make bench``): run the benchmarks, write bench.csv, bench.md and
machine.json, print the Markdown table; ``--only NAME`` runs one and only prints it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import sys
import time
from pathlib import Path

from . import BENCHMARKS, FULL, QUICK, Settings
from . import animation, dynamic_scenes, effects, floor, growth, master_overhead, model_cost
from . import long_runs, sweep, timing
from .report import machine, machine_line, markdown_table, write_outputs
from argparse import Namespace
from typing import Any

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .report import Row


def settings_for(args: Namespace) -> Settings:
    chosen = QUICK if args.quick else FULL
    repeats = args.repeats if args.repeats is not None else chosen.repeats
    scenes = args.sweep_scenes if args.sweep_scenes is not None else chosen.sweep_scenes
    return Settings(
        repeats,
        chosen.master_lengths_s,
        chosen.model_steps,
        chosen.effects_stop_time_s,
        scenes,
        chosen.dynamic_stop_fraction,
        chosen.growth_base_s,
        chosen.animation_s,
        chosen.animation_fps,
        chosen.long_base_steps,
    )


# the models the benchmarks load (mechfmu bench finds them by the one rule: cosim/locate.py)
MODELS_NEEDED = sorted(
    {
        "LandingGear",
        "PistonActuator",
        "LoadProfile",
        "Suspension",
        "RoadProfile",
        "ValveSpring",
        "ValveTrain",
        "CamshaftDrive",
        "HydraulicActuator",
        *(case.model for case in model_cost.CASES),
    }
)


def missing_fmus(fmu_dir: str) -> list[Any]:
    """The models of MODELS_NEEDED that ``fmu_dir`` lacks."""
    return [name for name in MODELS_NEEDED if not (Path(fmu_dir) / f"{name}.fmu").is_file()]


def run_benchmarks(
    args: Namespace, settings: Settings, names: tuple[str, ...] | list[str] = BENCHMARKS
) -> list[Row]:
    """Rows of the named benchmarks (default: all, in the order of the README)."""
    measures = {
        "master_overhead": lambda: master_overhead.measure(
            args.scenes, args.fmu_dir, settings.master_lengths_s, settings.repeats
        ),
        "model_cost": lambda: model_cost.measure(
            args.fmu_dir, settings.model_steps, settings.repeats
        ),
        "effects": lambda: effects.measure(
            args.scenes, args.fmu_dir, settings.repeats, settings.effects_stop_time_s
        ),
        "floor": lambda: floor.measure(args.scenes, args.fmu_dir, settings.repeats),
        "sweep": lambda: sweep.measure(args.sweeps, args.fmu_dir, settings.sweep_scenes),
        "dynamic_scenes": lambda: dynamic_scenes.measure(
            args.scenes, args.fmu_dir, settings.repeats, settings.dynamic_stop_fraction
        ),
        "growth": lambda: growth.measure(
            args.scenes, args.fmu_dir, settings.repeats, settings.growth_base_s
        ),
        "animation": lambda: animation.measure(
            args.scenes,
            args.fmu_dir,
            settings.repeats,
            settings.animation_s,
            settings.animation_fps,
        ),
        "long_runs": lambda: long_runs.measure(
            args.scenes, args.fmu_dir, settings.repeats, settings.long_base_steps
        ),
    }
    return [row for name in names for row in measures[name]()]


def command(args: Namespace) -> int:
    """``mechfmu bench`` with the parsed command line ``args`` (options in mechfmu/cli.py);
    the exit status."""
    missing = missing_fmus(args.fmu_dir)
    if missing:
        print(
            f"bench: FMU(s) {', '.join(missing)} not found in {args.fmu_dir}; build them "
            f"with 'mechfmu build' (or 'make fmus')",
            file=sys.stderr,
        )
        return 2
    settings = settings_for(args)
    timing.use_cpu_time(getattr(args, "cpu_time", False))
    if args.only:  # one benchmark alone: printed, data/bench left as it is
        print(markdown_table(run_benchmarks(args, settings, [args.only])))
        return 0
    started = time.perf_counter()
    rows = run_benchmarks(args, settings)
    info = machine()
    paths = write_outputs(args.out, rows, info)
    print(markdown_table(rows))
    print()
    print(machine_line(info))
    print(
        f"\n{len(rows)} measurements in {time.perf_counter() - started:.0f} s "
        f"({'quick' if args.quick else 'full'}, median of {settings.repeats} after one "
        f"warm-up; {'CPU' if getattr(args, 'cpu_time', False) else 'wall'} time); wrote {', '.join(str(path) for path in paths.values())}"
    )
    if args.profile:
        master_overhead.profile(args.scenes, args.fmu_dir, settings.master_lengths_s[1])
    return 0
