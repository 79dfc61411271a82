"""Retractable nose landing gear: piston length <-> gear angle (standard library only).

Geometry (mechanisms.md section 1): the bar pivots on the airframe at B; a piston joins a
fixed pivot at distance ``h`` (pivot_height) from B to a point on the bar at distance ``d``
(attachment_distance) from B. With ``theta`` the angle at B between the two,

    x^2 = h^2 + d^2 - 2 d h cos(theta)                       (law of cosines)

All lengths in m, angles in rad, time in s.
"""

import math
import sys
from collections import namedtuple

from ..errors import (
    RangeError,
    SingularConfiguration,
    require_above,
    require_finite,
    require_positive,
)

FOOT = 0.3048  # m, exact by definition

# Coursework design: piston 1.25 ft retracted, 2.0 ft extended, bar 2.5 ft, stroke in 3 s.
COURSEWORK_RETRACTED_LENGTH = 1.25 * FOOT
COURSEWORK_EXTENDED_LENGTH = 2.0 * FOOT
COURSEWORK_BAR_LENGTH = 2.5 * FOOT
COURSEWORK_STROKE_TIME = 3.0

DEAD_CENTRE_ULPS = 4  # piston lengths this close (in units of eps * (h + d)) are dead centres

Geometry = namedtuple("Geometry", "attachment_distance pivot_height start_angle")
GearMotion = namedtuple("GearMotion", "angle angular_velocity angular_acceleration")
PistonMotion = namedtuple("PistonMotion", "extension speed acceleration")


def design_geometry(retracted_length: float, extended_length: float) -> "Geometry":
    """Attachment distance d and pivot height h from the coursework's design conditions.

    Conditions: the piston is perpendicular to d at the retracted length x_r (so
    h^2 = d^2 + x_r^2), and the bar has turned by pi/2 at the extended length x_e. Together
    they give d^2 + x_r d + (x_r^2 - x_e^2)/2 = 0; d is its positive root.

    Returns Geometry(d [m], h [m], start_angle theta_1 = atan(x_r/d) [rad]).
    """
    x_r = require_positive("retracted_length", retracted_length, "m")
    x_e = require_above(
        "extended_length", extended_length, x_r, "m", "must exceed the retracted length"
    )
    # Positive root written without cancellation: -b/2 + sqrt(b^2/4 - c) = -c / (b/2 + sqrt(.))
    half_b = 0.5 * x_r
    c = 0.5 * (x_r * x_r - x_e * x_e)
    d = -c / (half_b + math.sqrt(half_b * half_b - c))
    return Geometry(d, math.hypot(d, x_r), math.atan2(x_r, d))


DEFAULT_GEOMETRY = design_geometry(COURSEWORK_RETRACTED_LENGTH, COURSEWORK_EXTENDED_LENGTH)


def check_geometry(attachment_distance: float, pivot_height: float) -> tuple[float, float]:
    """Validate d and h (finite, positive, not equal: d == h lets the piston shrink to 0)."""
    d = require_positive("attachment_distance", attachment_distance, "m")
    h = require_positive("pivot_height", pivot_height, "m")
    if d == h:
        raise RangeError(
            "attachment_distance",
            d,
            f"(0, inf) except {h!r}",
            "m",
            "equal to pivot_height makes |h - d| = 0, a degenerate linkage",
        )
    return d, h


def assembly_range(attachment_distance: float, pivot_height: float) -> tuple[float, float]:
    """Piston lengths [|h - d|, h + d] (m) for which the linkage assembles."""
    d, h = attachment_distance, pivot_height
    return abs(h - d), h + d


def _sine_and_cosine_terms(piston_extension: float, d: float, h: float) -> tuple[float, float]:
    """Return (2 d h sin(theta), 2 d h cos(theta)) for piston length x.

    The sine term is written as the square root of a product of four factors, so it keeps
    full relative accuracy next to the singular lengths x = h + d and x = |h - d|, where
    arccos of the cosine form would lose half the digits.
    """
    x = piston_extension
    low, high = assembly_range(d, h)
    if not (low <= x <= high):
        raise RangeError(
            "piston_extension",
            x,
            f"[{low!r}, {high!r}]",
            "m",
            "outside the assembly range [|h - d|, h + d]",
        )
    # h + d and |h - d| are rounded; their rounding errors (exact, by TwoSum) are added
    # back so the distances to the dead centres keep full relative accuracy.
    high_error = _two_sum_error(h, d, high)
    low_error = _two_sum_error(max(h, d), -min(h, d), low)
    to_high = (high - x) + high_error
    to_low = (x - low) - low_error
    # Within a few rounding units of a dead centre the input cannot tell which side it is on.
    if min(to_high, to_low) <= DEAD_CENTRE_ULPS * sys.float_info.epsilon * high:
        return 0.0, h * h + d * d - x * x
    product = to_high * (high + x) * to_low * (x + low)
    return math.sqrt(product), h * h + d * d - x * x


def _two_sum_error(a: float, b: float, rounded: float) -> float:
    """Exact rounding error of ``rounded = a + b`` (Knuth's TwoSum): a + b = rounded + error."""
    b_virtual = rounded - a
    a_virtual = rounded - b_virtual
    return (a - a_virtual) + (b - b_virtual)


def gear_motion(
    piston_extension: float,
    piston_speed: float,
    piston_acceleration: float,
    attachment_distance: float,
    pivot_height: float,
) -> "GearMotion":
    """Gear angle, angular velocity and acceleration for a prescribed piston motion.

    theta = angle at B with cos(theta) = (h^2 + d^2 - x^2) / (2 d h),
    omega = x xdot / (d h sin theta),
    alpha = (xdot^2 + x xddot - d h cos(theta) omega^2) / (d h sin theta).

    Inputs in m, m/s, m/s^2; returns GearMotion in rad, rad/s, rad/s^2.
    Raises RangeError outside [|h-d|, h+d] and SingularConfiguration where sin(theta) = 0
    (velocity and acceleration undefined there).
    """
    d, h = attachment_distance, pivot_height
    x = require_finite("piston_extension", piston_extension, "m")
    speed = require_finite("piston_speed", piston_speed, "m/s")
    accel = require_finite("piston_acceleration", piston_acceleration, "m/s^2")
    two_dh_sin, two_dh_cos = _sine_and_cosine_terms(x, d, h)
    angle = math.atan2(two_dh_sin, two_dh_cos)
    if two_dh_sin == 0.0:
        raise SingularConfiguration(
            f"piston_extension = {x!r} m is at a dead centre (sin(gear_angle) = 0, "
            f"x = {'h + d' if x > abs(h - d) else '|h - d|'}): angular velocity undefined"
        )
    dh_sin = 0.5 * two_dh_sin
    dh_cos = 0.5 * two_dh_cos
    omega = x * speed / dh_sin
    alpha = (speed * speed + x * accel - dh_cos * omega * omega) / dh_sin
    return GearMotion(angle, omega, alpha)


def piston_motion(
    gear_angle: float,
    gear_angular_velocity: float,
    gear_angular_acceleration: float,
    attachment_distance: float,
    pivot_height: float,
) -> "PistonMotion":
    """Piston length, speed and acceleration for a prescribed gear angle motion.

    x = sqrt(h^2 + d^2 - 2 d h cos theta), xdot = d h sin(theta) omega / x,
    xddot = (d h (cos(theta) omega^2 + sin(theta) alpha) - xdot^2) / x.

    Inputs in rad, rad/s, rad/s^2; returns PistonMotion in m, m/s, m/s^2.
    """
    d, h = attachment_distance, pivot_height
    theta = require_finite("gear_angle", gear_angle, "rad")
    omega = require_finite("gear_angular_velocity", gear_angular_velocity, "rad/s")
    alpha = require_finite("gear_angular_acceleration", gear_angular_acceleration, "rad/s^2")
    # (h - d)^2 + 4 d h sin^2(theta/2) avoids cancellation near theta = 0.
    half = math.sin(0.5 * theta)
    x = math.sqrt((h - d) ** 2 + 4.0 * d * h * half * half)
    if x == 0.0:
        raise SingularConfiguration("gear_angle = 0 with d = h: piston length is zero")
    dh = d * h
    speed = dh * math.sin(theta) * omega / x
    accel = (dh * (math.cos(theta) * omega * omega + math.sin(theta) * alpha) - speed * speed) / x
    return PistonMotion(x, speed, accel)


def piston_moment_arm(
    piston_extension: float, attachment_distance: float, pivot_height: float
) -> float:
    """Moment arm of the piston force about B: d h sin(theta) / x (m)."""
    two_dh_sin, _ = _sine_and_cosine_terms(piston_extension, attachment_distance, pivot_height)
    if piston_extension == 0.0:
        raise SingularConfiguration("piston_extension = 0: moment arm undefined")
    return 0.5 * two_dh_sin / piston_extension
