"""Benchmarks of the master, the models and the effects: ``mechfmu bench`` (``make bench``).

See the README section "Benchmarks". Timings are reported against the issue's targets, never
asserted: they depend on the machine. suite.py runs them; this module holds their settings
(light, for the command line's help).
"""

from dataclasses import dataclass

BENCHMARKS = (
    "master_overhead",
    "model_cost",
    "effects",
    "floor",
    "sweep",
    "dynamic_scenes",
    "growth",
    "animation",
    "long_runs",
)


@dataclass(frozen=True)
class Settings:
    """How long each benchmark runs. Lengths in s of simulated time; steps per loop."""

    repeats: int
    master_lengths_s: tuple  # (short, long) stop times of the gear scene
    model_steps: int
    effects_stop_time_s: float | None = None  # None: the scenes as written (3 s)
    sweep_scenes: int = 1000  # scenes of the sweep benchmark, run once on 1 and on 2 workers
    dynamic_stop_fraction: float | None = None  # None: the dynamic scenes as written
    growth_base_s: float = 3.0  # the growth benchmark's 1x stop time (gear_retraction's)
    animation_s: float = 10.0  # simulated time the animation benchmark plays
    animation_fps: float = 30.0  # its frames per second
    long_base_steps: int = 10_000  # the long-runs benchmark's 1x (then 10x, 100x)


FULL = Settings(repeats=5, master_lengths_s=(3.0, 60.0), model_steps=2000)
# The master's lengths stay: a shorter span makes the slope noisy, and the runs are cheap.
QUICK = Settings(
    repeats=2,
    master_lengths_s=FULL.master_lengths_s,
    model_steps=200,
    effects_stop_time_s=0.5,
    sweep_scenes=16,
    dynamic_stop_fraction=0.1,
    growth_base_s=0.25,
    animation_s=1.0,
    animation_fps=10.0,
    long_base_steps=500,
)
