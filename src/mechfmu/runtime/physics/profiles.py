"""Time profiles for source components (standard library only).

A profile maps time t (s) to (value, rate, second rate): the piston actuator's stroke
(m, m/s, m/s^2), the load sources (N, N/s, N/s^2) and the shaft drives (rad, rad/s,
rad/s^2). Each is exact at any time.
"""

import bisect
import csv
import math
from collections import namedtuple

from ..errors import MechanismError, RangeError, require_finite, require_positive
from typing import Any

Sample = namedtuple("Sample", "value rate rate2")

MAX_STROKE_TIME = 4.0  # s, the landing-gear requirement: full retraction in under 4 s
STROKE_PROFILES = ("constant_speed", "cycloidal")
LOAD_SHAPES = ("constant", "ramp", "step", "table")

# Times this close to a breakpoint count as the breakpoint, so that a master's
# t + dt landing one rounding error past the end of a stroke still sees the end of it.
TIME_SNAP = 1e-9


def _phase(time: float, start_time: float, duration: float) -> float:
    """Normalised time tau in [0, 1] through a segment, snapped at both ends."""
    tau = (time - start_time) / duration
    if abs(tau) <= TIME_SNAP:
        return 0.0
    if abs(tau - 1.0) <= TIME_SNAP:
        return 1.0
    return tau


def check_stroke(
    start_extension: float,
    end_extension: float,
    stroke_time: float,
    profile: str | None,
    start_time: float = 0.0,
) -> None:
    """Validate stroke parameters; stroke_time must lie in (0, 4] s."""
    require_finite("start_extension", start_extension, "m")
    require_finite("end_extension", end_extension, "m")
    require_positive("stroke_time", stroke_time, "s")
    require_finite("start_time", start_time, "s")
    if stroke_time > MAX_STROKE_TIME:
        raise RangeError(
            "stroke_time",
            stroke_time,
            f"(0, {MAX_STROKE_TIME}]",
            "s",
            "the gear must retract in under 4 s",
        )
    if profile not in STROKE_PROFILES:
        raise MechanismError(f"profile = {profile!r} is not one of {', '.join(STROKE_PROFILES)}")


def stroke(
    time: float,
    start_extension: float,
    end_extension: float,
    stroke_time: float,
    profile: str,
    start_time: float = 0.0,
) -> "Sample":
    """Piston extension (m), speed (m/s) and acceleration (m/s^2) at ``time`` (s).

    constant_speed: x moves linearly from start to end over stroke_time, then holds
    (the acceleration impulses at both ends are not represented: it reports 0).
    cycloidal: x = x0 + (x1 - x0)(tau - sin(2 pi tau) / (2 pi)), zero speed and zero
    acceleration at both ends.
    """
    tau = _phase(time, start_time, stroke_time)
    travel = end_extension - start_extension
    if tau < 0.0:
        return Sample(start_extension, 0.0, 0.0)
    if tau > 1.0:
        return Sample(end_extension, 0.0, 0.0)
    if profile == "constant_speed":
        # x0 + (x1 - x0) is not always x1 in floating point: the end is returned exactly.
        position = end_extension if tau == 1.0 else start_extension + travel * tau
        return Sample(position, travel / stroke_time, 0.0)
    if tau in (0.0, 1.0):  # sin(2 pi) is not 0 in floating point; the ends are exact rests
        return Sample(start_extension if tau == 0.0 else end_extension, 0.0, 0.0)
    angle = 2.0 * math.pi * tau
    return Sample(
        start_extension + travel * (tau - math.sin(angle) / (2.0 * math.pi)),
        travel * (1.0 - math.cos(angle)) / stroke_time,
        travel * 2.0 * math.pi * math.sin(angle) / stroke_time**2,
    )


def check_shape(shape: Any, shapes: Any, finite: Any) -> Any:
    """Raise MechanismError unless ``shape`` is one of ``shapes`` and each (name, value,
    unit) of ``finite`` is a finite number (checked in that order)."""
    if shape not in shapes:
        raise MechanismError(f"shape = {shape!r} is not one of {', '.join(shapes)}")
    for name, value, unit in finite:
        require_finite(name, value, unit)


def check_load(
    shape: str, initial_value: float, final_value: float, start_time: float, duration: float
) -> None:
    """Validate load-shape parameters."""
    check_shape(
        shape,
        LOAD_SHAPES,
        (
            ("initial_value", initial_value, "N"),
            ("final_value", final_value, "N"),
            ("start_time", start_time, "s"),
        ),
    )
    if shape == "ramp":
        require_positive("duration", duration, "s")


def load(
    time: float,
    shape: str,
    initial_value: float,
    final_value: float,
    start_time: float,
    duration: float,
    table: tuple[list[float], list[float]] | None = None,
) -> "Sample":
    """Load value (N), rate (N/s) and second rate (N/s^2) at ``time`` (s).

    constant: initial_value. step: initial_value before start_time, final_value from it on.
    ramp: linear from initial_value at start_time to final_value at start_time + duration.
    table: piecewise-linear through ``table`` (from read_table), held at both ends.
    """
    if shape == "constant":
        return Sample(initial_value, 0.0, 0.0)
    if shape == "step":
        return Sample(final_value if time >= start_time - TIME_SNAP else initial_value, 0.0, 0.0)
    if shape == "ramp":
        tau = _phase(time, start_time, duration)
        if tau < 0.0:
            return Sample(initial_value, 0.0, 0.0)
        if tau > 1.0:
            return Sample(final_value, 0.0, 0.0)
        change = final_value - initial_value
        value = final_value if tau == 1.0 else initial_value + change * tau
        return Sample(value, change / duration, 0.0)
    assert table is not None  # shape 'table' is read with its table (check_load)
    return interpolate(table, time)


def read_table(path: Any) -> tuple[list[float], list[float]]:
    """Read a two-column CSV (time in s, value; a header row is allowed) into sorted lists.

    Times must be finite and strictly increasing; at least one row is needed.
    """
    times: list[float] = []
    values: list[float] = []
    header_seen = False
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            for number, row in enumerate(csv.reader(handle), start=1):
                if not row or row[0].lstrip().startswith("#"):
                    continue
                try:
                    time, value = float(row[0]), float(row[1])
                except (ValueError, IndexError):
                    if not times and not header_seen:
                        header_seen = True  # the first row that is not a comment
                        continue
                    raise MechanismError(
                        f"{path}, line {number}: expected 'time,value', got {','.join(row)!r}"
                    ) from None
                if not (math.isfinite(time) and math.isfinite(value)):
                    raise MechanismError(f"{path}, line {number}: non-finite number")
                if times and time <= times[-1]:
                    raise MechanismError(
                        f"{path}, line {number}: time {time!r} s is not "
                        f"after {times[-1]!r} s (times must increase)"
                    )
                times.append(time)
                values.append(value)
    except OSError as error:
        raise MechanismError(f"table_file {path!r} cannot be read: {error.strerror}") from None
    if not times:
        raise MechanismError(f"table_file {path!r} has no data rows")
    return times, values


def interpolate(table: tuple[list[float], list[float]], time: float) -> "Sample":
    """Piecewise-linear value and slope of ``table`` at ``time``, held outside its range."""
    times, values = table
    if time <= times[0]:
        return Sample(values[0], 0.0, 0.0)
    if time >= times[-1]:
        return Sample(values[-1], 0.0, 0.0)
    i = bisect.bisect_right(times, time) - 1
    slope = (values[i + 1] - values[i]) / (times[i + 1] - times[i])
    return Sample(values[i] + slope * (time - times[i]), slope, 0.0)


def check_rotation(initial_angle: Any, initial_speed: Any, final_speed: Any, ramp_time: Any) -> Any:
    """Validate a shaft rotation: finite angle and speeds (rad, rad/s), ramp_time >= 0 s."""
    require_finite("initial_angle", initial_angle, "rad")
    require_finite("initial_speed", initial_speed, "rad/s")
    require_finite("speed", final_speed, "rad/s")
    ramp = require_finite("ramp_time", ramp_time, "s")
    if ramp < 0.0:
        raise RangeError("ramp_time", ramp, "[0, inf)", "s")


def rotation(
    time: float,
    initial_angle: Any,
    initial_speed: Any,
    final_speed: Any,
    ramp_time: Any,
    start_time: float = 0.0,
) -> Any:
    """Shaft angle (rad), speed (rad/s) and angular acceleration (rad/s^2) at ``time`` (s).

    The speed ramps linearly from initial_speed to final_speed over ramp_time from
    start_time (constant speed for ramp_time = 0), so the angle is exact: a parabola during
    the ramp, a line after it. The acceleration is the ramp's on [start, start + ramp).
    """
    elapsed = time - start_time
    # Within TIME_SNAP * ramp_time of either end of the ramp a time counts as that end (the
    # acceleration jumps there): a sample a rounding error early still sees the ramp start.
    ramping = ramp_time > 0.0 and -TIME_SNAP * ramp_time <= elapsed < ramp_time * (1.0 - TIME_SNAP)
    if elapsed < 0.0 and not ramping:  # before the start the shaft turns at initial_speed
        return Sample(initial_angle + initial_speed * elapsed, initial_speed, 0.0)
    if ramping:
        rate = (final_speed - initial_speed) / ramp_time
        return Sample(
            initial_angle + elapsed * (initial_speed + 0.5 * rate * elapsed),
            initial_speed + rate * elapsed,
            rate,
        )
    ramped = 0.5 * (initial_speed + final_speed) * ramp_time
    return Sample(initial_angle + ramped + final_speed * (elapsed - ramp_time), final_speed, 0.0)
