"""Which result row each frame of an animation shows.

Played at ``speed`` (1: real time; 0.01: a hundred times slower) and ``fps`` frames per
second, frame k stands for the simulated time t0 + k speed / fps, from the result's first
time up to its last. It shows the result's last row at or before that time: every frame is
a row of the result as computed (positions are never interpolated, which would shorten the
links between two rows), so a result coarser than the frames repeats its rows.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .columns import AnimationError

MAX_FRAMES = 100_000  # a bound on the frames one animation may have


class Schedule(NamedTuple):
    """The frames of an animation: ``rows[k]``, the result row frame k shows; ``clock[k]``,
    the simulated time it stands for (s); at ``fps`` frames per second and ``speed``."""

    rows: np.ndarray
    clock: np.ndarray
    fps: float
    speed: float


def schedule(times: np.ndarray, speed: float = 1.0, fps: float = 25.0) -> Schedule:
    """The frames that play the result with time points ``times`` (s, increasing) at
    ``speed`` times real time and ``fps`` frames per second. AnimationError for a speed or
    frame rate that is not a finite positive number, or more than MAX_FRAMES frames."""
    for name, value in (("speed", speed), ("fps", fps)):
        if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
            raise AnimationError(f"{name} = {value!r} must be a finite number > 0")
    times = np.asarray(times, dtype=float)
    span = float(times[-1] - times[0])
    count = int(np.floor(span * fps / speed * (1.0 + 1e-12) + 1e-9)) + 1
    if count > MAX_FRAMES:
        raise AnimationError(
            f"{count} frames ({span:g} s of results at speed {speed:g} and {fps:g} frames/s) "
            f"is more than {MAX_FRAMES}: raise speed or lower fps"
        )
    clock = times[0] + np.arange(count) * (speed / fps)
    # the last row at or before each clock time (a clock a rounding above a row shows it)
    tolerance = 1e-9 * max(abs(times[0]), abs(times[-1]), speed / fps)
    rows = np.searchsorted(times, clock + tolerance, side="right") - 1
    return Schedule(np.clip(rows, 0, len(times) - 1), clock, float(fps), float(speed))
