"""Benchmark 8: what an animation costs: 10 s of a scene at 30 frames per second.

four_bar_crank_rocker run over ``seconds`` with the geometry effect (the run is not timed),
then animated in real time at ``fps`` and written: as a GIF (drawn and encoded in this
process) and, with imageio-ffmpeg, as an MP4 (ffmpeg encodes in a child process, whose CPU
time counts too with --cpu-time). Target (issue 30): under 30 s on one core.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from ...api import simulate
from ..animate import DEFAULT_WIDTH, animate, with_geometry
from .gear import load_named_scene, with_stop_time
from .report import Row, Target
from .timing import now_with_children, side_by_side_medians

BENCHMARK = "animation"
SCENE = "four_bar_crank_rocker"
TARGET = Target(30.0, "<= 30 s")


def _has_ffmpeg() -> bool:
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        return False
    return True


def measure(scene_dir: str, fmu_dir: str, repeats: int, seconds: float, fps: float) -> list[Row]:
    """Rows of benchmark 8: seconds to animate and write ``seconds`` s of SCENE at ``fps``."""
    scene = with_geometry(with_stop_time(load_named_scene(scene_dir, SCENE), seconds))
    table = simulate(scene, fmu_dir=fmu_dir)
    formats = ["gif"] + (["mp4"] if _has_ffmpeg() else [])
    with tempfile.TemporaryDirectory(prefix="mechfmu_bench_animation_") as folder:
        frames = {}

        def timed(suffix: str) -> dict[str, float]:
            started = now_with_children()
            animation = animate(table, fps=fps)
            animation.save(Path(folder) / f"{SCENE}.{suffix}")
            frames[suffix] = len(animation)
            return {"total": now_with_children() - started}

        medians = side_by_side_medians(
            {suffix: (lambda suffix=suffix: timed(suffix)) for suffix in formats}, repeats
        )
    return [
        Row(
            BENCHMARK,
            f"{SCENE}, {seconds:g} s at {fps:g} frames/s: {suffix.upper()}",
            medians[suffix]["total"],
            "s",
            repeats,
            TARGET,
            notes=f"{frames[suffix]} frames, {DEFAULT_WIDTH} px wide, drawn and written "
            "(the run not timed)",
        )
        for suffix in formats
    ]
