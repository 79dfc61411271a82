"""Offset slider-crank: slider position, speed and acceleration (standard library only).

Geometry: the crank pivots at the origin; crank length a (origin -> crank pin A), coupler
(connecting rod) length b (A -> slider pin B). The slider moves along a line parallel to +x at
height y = offset (any sign, zero for an in-line slider-crank). Angles are measured
counter-clockwise from +x:

    theta2 = crank_angle (angle of O -> A), theta3 = coupler_angle (angle of A -> B),
    slider_position s = x coordinate of B, measured along the slider axis from the foot of the
    perpendicular from the crank pivot.

Loop: a e^(i theta2) + b e^(i theta3) = s + i offset, so

    a sin(theta2) + b sin(theta3) = offset,    s = a cos(theta2) + b cos(theta3).

Circuits: 0 puts the slider on the +x side of the crank pin (cos(theta3) >= 0,
theta3 = asin((offset - a sin theta2)/b)); 1 is the mirror branch on the -x side
(theta3 = pi - asin(...)). They meet where |offset - a sin(theta2)| = b, the coupler
perpendicular to the slider axis: there the rates are infinite (SingularConfiguration).

All lengths in m, angles in rad, time in s.
"""

from typing import Any
import math
import sys
from collections import namedtuple

from ..errors import RangeError, SingularConfiguration, require_finite, require_positive
from .crank import check_circuit, crank_drive

SliderCrank = namedtuple("SliderCrank", "crank coupler offset")
# An engine-like in-line slider-crank: 50 mm crank (100 mm stroke), 150 mm connecting rod
# (rod/crank ratio 3, within the usual 3-4 of piston engines), no offset. The crank turns
# fully on either circuit (b > a + |offset|).
DEFAULT_SLIDER_CRANK = SliderCrank(0.05, 0.15, 0.0)

CIRCUITS = (0, 1)

# |offset - a sin(theta2)| this close to b (in units of eps * (a + b + |offset|)) is the
# singular position: the input cannot tell which side of it it is on.
SINGULAR_ULPS = 8

SliderCrankPosition = namedtuple("SliderCrankPosition", "coupler_angle slider_position")
SliderCrankMotion = namedtuple(
    "SliderCrankMotion",
    "slider_position slider_speed slider_acceleration coupler_angle coupler_angular_velocity "
    "coupler_angular_acceleration",
)


def check_slider_crank(crank: float, coupler: float, offset: float) -> "SliderCrank":
    """Validate crank, coupler (finite, > 0, m) and offset (finite, m); return SliderCrank.

    |offset| must be below crank + coupler, else the coupler can never reach the slider axis
    (at equality it reaches it at a single, singular crank angle).
    """
    a = require_positive("crank", crank, "m")
    b = require_positive("coupler", coupler, "m")
    e = require_finite("offset", offset, "m")
    if abs(e) >= a + b:
        raise RangeError(
            "offset",
            e,
            f"({-(a + b)!r}, {a + b!r})",
            "m",
            "the coupler cannot reach the slider axis: |offset| must be below crank + coupler",
        )
    return SliderCrank(a, b, e)


def _as_lengths(values: tuple) -> tuple[float, float, float]:
    if len(values) == 1:
        values = tuple(values[0])
    if len(values) != 3:
        raise TypeError(
            f"expected crank, coupler, offset or one sequence of them, got {len(values)} arguments"
        )
    return values


def crank_angle_range(*slider_crank: Any) -> tuple[float, float] | None:
    """Interval (low, high) of sin(crank_angle) in which the slider-crank assembles, or None.

    Call as crank_angle_range(crank, coupler, offset) or crank_angle_range(slider_crank).
    Assembly needs |offset - a sin(theta2)| <= b, i.e. (offset - b)/a <= sin(theta2) <=
    (offset + b)/a, clipped to [-1, 1]; None when every crank angle assembles. The crank
    angles are [asin(low), asin(high)] and [pi - asin(high), pi - asin(low)] (mod 2 pi).
    """
    a, b, e = check_slider_crank(*_as_lengths(slider_crank))
    low, high = (e - b) / a, (e + b) / a
    if low <= -1.0 and high >= 1.0:
        return None
    return max(low, -1.0), min(high, 1.0)


def _wrap(angle: float) -> float:
    """Angle in (-pi, pi]: atan2 returns [-pi, pi]."""
    return math.pi if angle <= -math.pi else angle


def _solve(
    geometry: "SliderCrank", crank_angle: float, circuit: int
) -> tuple[float, float, float, float, bool]:
    """(theta3, b sin(theta3), b cos(theta3), s, singular) for validated geometry."""
    a, b, e = geometry
    t2 = crank_angle
    cos2, sin2 = math.cos(t2), math.sin(t2)
    rise = e - a * sin2  # b sin(theta3)
    tolerance = SINGULAR_ULPS * sys.float_info.epsilon * (a + b + abs(e))
    margin = b - abs(rise)
    if margin < -tolerance:
        low, high = crank_angle_range(a, b, e) or (math.nan, math.nan)
        raise RangeError(
            "crank_angle",
            t2,
            f"sin(crank_angle) in [{low!r}, {high!r}], i.e. crank_angle (mod 2 pi) in "
            f"[{math.asin(low)!r}, {math.asin(high)!r}] or "
            f"[{math.pi - math.asin(high)!r}, {math.pi - math.asin(low)!r}]",
            "rad",
            f"no assembly: offset - crank sin(crank_angle) = {rise!r} m, but the coupler "
            f"reaches only {b!r} m from the slider axis",
        )
    singular = margin <= tolerance
    # b cos(theta3) = +-sqrt((b - rise)(b + rise)): no cancellation next to the singularity
    run = 0.0 if singular else math.sqrt((b - rise) * (b + rise))
    if circuit == 1:
        run = -run
    coupler_angle = _wrap(math.atan2(rise, run))
    return coupler_angle, rise, run, a * cos2 + run, singular


def _check_circuit(circuit: float | None) -> int:
    return check_circuit(circuit, "0 = slider on the +x side of the crank pin, 1 = mirror branch")


def position(
    crank: float, coupler: float, offset: float, crank_angle: float, circuit: int
) -> "SliderCrankPosition":
    """Coupler angle (rad, in (-pi, pi]) and slider position (m) at a crank angle (rad).

    Returns SliderCrankPosition(coupler_angle, slider_position). Raises RangeError where the
    coupler cannot reach the slider axis. At the singular position (coupler perpendicular to
    the slider axis) both circuits coincide and the position is returned; ``motion`` raises.
    """
    geometry = check_slider_crank(crank, coupler, offset)
    t2 = require_finite("crank_angle", crank_angle, "rad")
    t3, _, _, s, _ = _solve(geometry, t2, _check_circuit(circuit))
    return SliderCrankPosition(t3, s)


def motion(
    crank: float,
    coupler: float,
    offset: float,
    circuit: float | None,
    crank_angle: float,
    crank_speed: float,
    crank_acceleration: float,
) -> "SliderCrankMotion":
    """Slider and coupler motion for a prescribed crank motion.

    Differentiating a sin(t2) + b sin(t3) = offset and s = a cos(t2) + b cos(t3):

        w3 = -a w2 cos(t2) / (b cos t3),
        ds/dt = -a w2 sin(t2) - b w3 sin(t3),
        al3 = (a w2^2 sin(t2) + b w3^2 sin(t3) - a al2 cos(t2)) / (b cos t3),
        d2s/dt2 = -a al2 sin(t2) - a w2^2 cos(t2) - b al3 sin(t3) - b w3^2 cos(t3).

    Inputs: lengths in m, circuit 0 or 1, crank angle (rad), speed (rad/s), acceleration
    (rad/s^2). Returns SliderCrankMotion (m, m/s, m/s^2, rad in (-pi, pi], rad/s, rad/s^2).
    Raises RangeError for invalid inputs or no assembly, SingularConfiguration where the
    coupler is perpendicular to the slider axis (cos(theta3) = 0: rates infinite).
    """
    geometry = check_slider_crank(crank, coupler, offset)
    circuit = _check_circuit(circuit)
    t2, w2, al2 = crank_drive(crank_angle, crank_speed, crank_acceleration)
    return checked_motion(geometry, circuit, t2, w2, al2)


def checked_motion(
    geometry: "SliderCrank", circuit: int, t2: float, w2: float, al2: float
) -> "SliderCrankMotion":
    """``motion`` for a geometry from check_slider_crank (m), a circuit from CIRCUITS and
    finite crank angle (rad), speed (rad/s) and acceleration (rad/s^2): what an FMU that
    validated them once calls at every step."""
    t3, b_sin3, b_cos3, s, singular = _solve(geometry, t2, circuit)
    if singular:
        raise SingularConfiguration(
            f"coupler perpendicular to the slider axis at crank angle {t2!r} rad "
            f"(coupler angle {t3!r} rad): slider speed and coupler angular velocity infinite"
        )
    a = geometry.crank
    cos2, sin2 = math.cos(t2), math.sin(t2)
    w3 = -a * w2 * cos2 / b_cos3
    speed = -a * w2 * sin2 - w3 * b_sin3
    al3 = (a * w2 * w2 * sin2 + w3 * w3 * b_sin3 - a * al2 * cos2) / b_cos3
    accel = -a * al2 * sin2 - a * w2 * w2 * cos2 - al3 * b_sin3 - w3 * w3 * b_cos3
    return SliderCrankMotion(s, speed, accel, t3, w3, al3)
