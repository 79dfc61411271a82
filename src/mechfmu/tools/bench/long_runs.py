"""Benchmark 9 (issue 33): long runs in bounded memory, and the valve scenes' CPU time.

Memory: ``mechfmu run`` of gear_retraction (two FMUs, 7 columns) at 1x, 10x and 100x a base
number of steps, each in a fresh Python process (``peak_rss_of_run``: its peak resident set,
VmHWM, big_files.peak_mb), written as CSV; the master streams the rows to the file as they
come, so the peak should not grow with the run (target: 100x within 1.25 times 1x). The
valve scenes: the stepping loop's CPU time of the process (``meta['loop_cpu_time_s']``,
whatever else runs on the machine) per simulated second, as shipped (target: 0.25).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from .gear import load_named_scene
from .report import Row, Target, ratio_row
from .timing import side_by_side_medians

BENCHMARK = "long runs"
MEMORY_SCENE = "gear_retraction"  # two closed-form FMUs: the master's cost shows
MEMORY_TARGET = Target(1.25, "<= 1.25")
VALVE_SCENES = ("valve_train_dynamic", "valve_float_dynamic")
VALVE_TARGET = Target(0.25, "<= 0.25")

# peak_mb: the child's own peak (VmHWM). ru_maxrss would start from the parent's resident set
# at the fork (a bench process grown to 739 MiB by the benchmarks before this one made every
# run read 739, and a test in a large pytest worker could not see the run grow).
_PEAK = """
import json, sys
from mechfmu.cosim.run import run_scene
from mechfmu.tools.bench.big_files import peak_mb
result, paths = run_scene(sys.argv[1], sys.argv[2], sys.argv[3] or None, plot=True, fmt=sys.argv[4])
data = paths[sys.argv[4]]
print(json.dumps({"peak_kib": peak_mb() * 1024.0,
                  "rows": result.rows, "bytes": data.stat().st_size, "kept": result.kept}))
"""


def scene_file_with_steps(scene_dir: str, name: str, steps: int, folder: Path) -> Path:
    """A copy of shipped scene ``name`` (from ``scene_dir``) running ``steps`` steps of its
    own step, without its reference (a longer run has none), written into ``folder``."""
    scene = load_named_scene(scene_dir, name)
    text = scene.path.read_text()
    lines = []
    for line in text.splitlines():
        if line.startswith("stop_time ="):
            line = f"stop_time = {scene.start_time + steps * scene.step!r}"
        elif line.startswith("reference ="):
            continue
        lines.append(line)
    path = folder / f"{name}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def peak_rss_of_run(scene_file: Path, out: Path, fmu_dir: str | None, fmt: str = "csv") -> dict:
    """Run ``scene_file`` by run_scene (as ``mechfmu run``) in a fresh Python process:
    {"peak_kib": its peak resident set in KiB, "rows", "bytes" of the data file, "kept"}."""
    completed = subprocess.run(
        [sys.executable, "-c", _PEAK, str(scene_file), str(out), fmu_dir or "", fmt],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    if completed.returncode != 0:
        raise RuntimeError(f"run of {scene_file} failed: {completed.stderr.strip()[-2000:]}")
    return json.loads(completed.stdout.strip().splitlines()[-1])


def measure_memory(scene_dir: str, fmu_dir: str | None, base_steps: int) -> list[Row]:
    """Rows: peak resident memory (MiB) of a run at 1x, 10x, 100x ``base_steps``, and the
    100x / 1x ratio."""
    peaks = {}
    with tempfile.TemporaryDirectory(prefix="mechfmu_bench_long_") as folder:
        for factor in (1, 10, 100):
            steps = base_steps * factor
            scene = scene_file_with_steps(scene_dir, MEMORY_SCENE, steps, Path(folder))
            peaks[factor] = peak_rss_of_run(scene, Path(folder) / "out", fmu_dir)
    rows = [
        Row(
            BENCHMARK,
            f"run peak memory, {factor}x ({base_steps * factor} steps)",
            found["peak_kib"] / 1024.0,
            "MiB",
            1,
            None,
            notes=f"{MEMORY_SCENE}, CSV of {found['bytes'] / 1e6:.3g} MB streamed; rows kept "
            f"in memory too: {'yes' if found['kept'] else 'no'}",
        )
        for factor, found in peaks.items()
    ]
    rows.append(
        ratio_row(
            "run peak memory, 100x / 1x",
            rows[2],
            rows[0],
            MEMORY_TARGET,
            "flat in the run's length: the rows go to the file as they come",
        )
    )
    return rows


def measure_valves(scene_dir: str, fmu_dir: str | None, repeats: int) -> list[Row]:
    """Rows: each valve scene's stepping-loop CPU time per simulated second (median of
    ``repeats`` after one warm-up run)."""
    from ...cosim.master import Simulation

    simulations = {}
    for name in VALVE_SCENES:
        scene = load_named_scene(scene_dir, name)
        simulations[name] = (Simulation(scene, fmu_dir), scene.stop_time - scene.start_time)
    medians = side_by_side_medians(
        {
            name: (lambda simulation=simulation: {"loop": simulation.run().meta["loop_cpu_time_s"]})
            for name, (simulation, _) in simulations.items()
        },
        repeats,
    )
    return [
        Row(
            BENCHMARK,
            f"{name}: loop CPU / simulated",
            medians[name]["loop"] / span,
            "s/s",
            repeats,
            VALVE_TARGET,
            notes=f"as shipped (step {simulations[name][0].scene.step:g} s); CPU time of "
            f"the process, so the figure holds on a busy machine",
        )
        for name, (_, span) in simulations.items()
    ]


def measure(scene_dir: str, fmu_dir: str | None, repeats: int, base_steps: int) -> list[Row]:
    """Rows of benchmark 9: memory of long runs, then the valve scenes' CPU time."""
    return measure_memory(scene_dir, fmu_dir, base_steps) + measure_valves(
        scene_dir, fmu_dir, repeats
    )
