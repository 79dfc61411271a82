"""Road profiles for base excitation of the suspension (standard library only).

A road profile maps time t (s) to the road height r (m, positive upward, 0 = level road),
its rate dr/dt (m/s) and its second rate (m/s^2), exactly at any time:

- step:  r = 0 before start_time, ``height`` from start_time on (a kerb); rates 0.
- bump:  one-cosine bump of ``height`` over ``duration`` from start_time:
         r = height (1 - cos(2 pi tau)) / 2, tau = (t - start_time) / duration in [0, 1],
         0 outside. r and dr/dt are continuous (dr/dt = 0 at both ends), d2r/dt2 jumps there.
- sine:  r = amplitude sin(2 pi frequency (t - start_time)) from start_time on, 0 before.
- table: piecewise-linear through a CSV of (time s, height m) (profiles.read_table), held
         at both ends; the rate is the slope of the current segment.

Heights are what the tyre (or, without a tyre, the spring base) rests on, so a bump pushes
the wheel up, i.e. the suspension's downward displacements decrease.
"""

from typing import Any
import math

from ..errors import require_positive
from .profiles import TIME_SNAP, Sample, check_shape, interpolate

ROAD_SHAPES = ("step", "bump", "sine", "table")


def check_road(
    shape: str,
    height: float,
    duration: float,
    start_time: float,
    amplitude: float,
    frequency: float,
) -> Any:
    """Validate road parameters (only the ones the shape uses must be usable)."""
    check_shape(
        shape,
        ROAD_SHAPES,
        (("start_time", start_time, "s"), ("height", height, "m"), ("amplitude", amplitude, "m")),
    )
    if shape == "bump":
        require_positive("duration", duration, "s")
    if shape == "sine":
        require_positive("frequency", frequency, "Hz")


def bump(time: float, height: float, duration: float, start_time: float = 0.0) -> Sample:
    """One-cosine bump: height (m), rate (m/s), second rate (m/s^2); 0 outside it."""
    tau = (time - start_time) / duration
    if abs(tau) <= TIME_SNAP or abs(tau - 1.0) <= TIME_SNAP or tau < 0.0 or tau > 1.0:
        return Sample(0.0, 0.0, 0.0)  # the ends are exact rests (cos(2 pi) is not 1 in floats)
    angle = 2.0 * math.pi * tau
    rate_scale = math.pi / duration
    return Sample(
        height * 0.5 * (1.0 - math.cos(angle)),
        height * rate_scale * math.sin(angle),
        height * 2.0 * rate_scale * rate_scale * math.cos(angle),
    )


def sine(time: float, amplitude: float, frequency: float, start_time: float = 0.0) -> Sample:
    """amplitude sin(2 pi f (t - start_time)) from start_time on, 0 before."""
    if time < start_time - TIME_SNAP:
        return Sample(0.0, 0.0, 0.0)
    omega = 2.0 * math.pi * frequency
    angle = omega * max(time - start_time, 0.0)
    return Sample(
        amplitude * math.sin(angle),
        amplitude * omega * math.cos(angle),
        -amplitude * omega * omega * math.sin(angle),
    )


def step(time: float, height: float, start_time: float = 0.0) -> Sample:
    """0 before start_time, ``height`` from it on (times within TIME_SNAP count as on it)."""
    return Sample(height if time >= start_time - TIME_SNAP else 0.0, 0.0, 0.0)


def road(
    time: float,
    shape: str,
    height: float = 0.0,
    duration: float = 1.0,
    start_time: float = 0.0,
    amplitude: float = 0.0,
    frequency: float = 1.0,
    table: tuple[list[float], list[float]] | None = None,
) -> Sample:
    """Road height (m), rate (m/s), second rate (m/s^2) at ``time`` for any shape."""
    if shape == "step":
        return step(time, height, start_time)
    if shape == "bump":
        return bump(time, height, duration, start_time)
    if shape == "sine":
        return sine(time, amplitude, frequency, start_time)
    assert table is not None  # shape 'table' is read with its table (check_road)
    return interpolate(table, time)
