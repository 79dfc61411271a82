"""Timing primitives: medians of side-by-side rounds after a warm-up, per-step slopes."""

from typing import Any
import os
import statistics
import time
from collections.abc import Callable

_clock = time.perf_counter


def use_cpu_time(cpu: bool) -> None:
    """Time the benchmarks' runs and loops by the process's CPU time (``time.process_time``)
    instead of the wall clock: on a machine shared with other work the wall clock also
    counts the time the process waits for a core. Every FMU here runs in this process's
    one thread, so its CPU time is all the work. (The timers around single FMI calls stay on
    the wall clock: reading the CPU clock costs about 0.4 us, more than a call's margin.)"""
    global _clock
    _clock = time.process_time if cpu else time.perf_counter


def cpu_time() -> bool:
    """Whether the benchmarks time by CPU time (use_cpu_time)."""
    return _clock is time.process_time


def now() -> float:
    """The benchmarks' clock in s: wall (default) or CPU time (use_cpu_time)."""
    return _clock()


def now_with_children() -> float:
    """now(), plus with CPU time the CPU time of the child processes that have ended (an
    encoder that runs as a subprocess, such as ffmpeg)."""
    if _clock is time.process_time:
        times = os.times()
        return _clock() + times.children_user + times.children_system
    return _clock()


def side_by_side_medians(
    measurements: dict[Any, Callable], repeats: int
) -> dict[Any, dict[str, float]]:
    """Median of every measurement over ``repeats`` rounds, after one warm-up round.

    ``measurements`` maps a name to a function that runs once and returns a dict of named
    durations in seconds. Each round runs every function once, in turn, so a slow drift of
    the machine (clock frequency, caches, other load) affects all of them alike, and a
    ratio of two of them compares runs made side by side. Returns
    ``{name: {key: median seconds}}``.
    """
    for run in measurements.values():
        run()  # warm-up: first loads of libraries and modules, caches, lazy imports
    samples: dict[str, list[dict[str, float]]] = {name: [] for name in measurements}
    for _ in range(repeats):
        for name, run in measurements.items():
            samples[name].append(run())
    return {
        name: {key: statistics.median(sample[key] for sample in runs) for key in runs[0]}
        for name, runs in samples.items()
    }


def per_step(short_run_s: float, long_run_s: float, short_steps: int, long_steps: int) -> float:
    """Cost of one step in s: the slope between two run lengths, so the set-up cancels."""
    return (long_run_s - short_run_s) / (long_steps - short_steps)


def set_up(short_run_s: float, per_step_s: float, short_steps: int) -> float:
    """Set-up cost in s (extraction, instantiation, ...): the intercept of the same line."""
    return short_run_s - per_step_s * short_steps


def seconds_of(function: Callable, *args: Any, **kwargs: Any) -> float:
    """Wall time in s of one call of ``function``."""
    started = now()
    function(*args, **kwargs)
    return now() - started
