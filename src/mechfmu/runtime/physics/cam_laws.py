"""Cam follower motion laws over one camshaft revolution (standard library only).

One revolution of the camshaft angle theta (rad), measured from ``rise_start``, is split into

    rise        [0, beta_r)                    s = lift f(x),       x = theta' / beta_r
    high dwell  [beta_r, theta_r)              s = lift             theta_r = beta_r + beta_d
    return      [theta_r, theta_r + beta_ret)  s = lift (1 - f(x)), x = (theta' - theta_r)/beta_ret
    low dwell   [theta_r + beta_ret, 2 pi)     s = 0

with theta' = (theta - rise_start) reduced into [0, 2 pi). Every segment is closed on the
left and open on the right: at a boundary the values (and, where they jump, the derivatives)
are those of the segment that starts there. The profile is periodic with period 2 pi.

The normalized rise f(x), x in [0, 1], rises from f(0) = 0 to f(1) = 1 (CAM_LAWS):

    harmonic          f = (1 - cos(pi x)) / 2
    cycloidal         f = x - sin(2 pi x) / (2 pi)
    polynomial_345    f = 10 x^3 - 15 x^4 + 6 x^5
    polynomial_4567   f = 35 x^4 - 84 x^5 + 70 x^6 - 20 x^7

All four are point-symmetric about (1/2, 1/2): f(x) + f(1 - x) = 1. The evaluation uses it:
for x > 1/2 the law is evaluated at 1 - x (exact in floating point for x in [1/2, 1]), so
f(1) = 1, the end derivatives are exact zeros where they should be, and the return lift
lift * (1 - f(x)) = lift * f(1 - x) keeps full relative accuracy as it closes.

Lift in m, angles in rad, camshaft speed in rad/s; derivatives of the lift with respect to
the camshaft angle in m/rad, m/rad^2, m/rad^3.
"""

import math
from collections import namedtuple
from collections.abc import Callable

from ..errors import MechanismError, RangeError, require_between, require_finite, require_positive

CAM_LAWS = ("harmonic", "cycloidal", "polynomial_345", "polynomial_4567")
SEGMENTS = ("rise", "return")
TAU = 2.0 * math.pi  # the float nearest 2 pi; it differs from 2 pi by 2.4e-16 rad

NormalizedRise = namedtuple("NormalizedRise", "f f1 f2 f3")
PeakCoefficients = namedtuple("PeakCoefficients", "velocity acceleration jerk")
Continuity = namedtuple("Continuity", "velocity acceleration jerk")
CamProfile = namedtuple(
    "CamProfile", "law lift rise_start rise_angle high_dwell_angle return_angle"
)
CamLift = namedtuple("CamLift", "s s1 s2 s3")
FollowerMotion = namedtuple("FollowerMotion", "lift velocity acceleration")

# Maxima of |f1|, |f2|, |f3| on [0, 1], in closed form (derivation in peak_coefficients).
_PEAKS = {
    "harmonic": PeakCoefficients(math.pi / 2.0, math.pi**2 / 2.0, math.pi**3 / 2.0),
    "cycloidal": PeakCoefficients(2.0, 2.0 * math.pi, 4.0 * math.pi**2),
    "polynomial_345": PeakCoefficients(15.0 / 8.0, 10.0 / math.sqrt(3.0), 60.0),
    "polynomial_4567": PeakCoefficients(35.0 / 16.0, 84.0 / (5.0 * math.sqrt(5.0)), 52.5),
}

# Whether velocity, acceleration and jerk of the lift are continuous where a rise or a return
# meets a dwell (the dwell has zero derivatives, so a derivative is continuous there exactly
# when the law's derivative is 0 at x = 0 and x = 1, and every lower derivative is too):
#   harmonic          f1(0) = f1(1) = 0; f2(0) = pi^2/2, f2(1) = -pi^2/2: the acceleration
#                     jumps, so the jerk has an impulse (though f3(0) = f3(1) = 0).
#   cycloidal         f1, f2 vanish at both ends; f3(0) = f3(1) = 4 pi^2: the jerk jumps.
#   polynomial_345    f1, f2 vanish at both ends; f3(0) = f3(1) = 60: the jerk jumps.
#   polynomial_4567   f1, f2, f3 all vanish at both ends: the jerk is continuous.
CONTINUITY = {
    "harmonic": Continuity(True, False, False),
    "cycloidal": Continuity(True, True, False),
    "polynomial_345": Continuity(True, True, False),
    "polynomial_4567": Continuity(True, True, True),
}

# u - sin(u) by its Taylor series below this u (rad): the direct difference would lose
# about log10(6 / u^2) digits to cancellation near the start of a cycloidal rise.
_SERIES_LIMIT = 1.0


def _check_law(law: str) -> None:
    if law not in CAM_LAWS:
        raise MechanismError(f"law = {law!r} is not one of {', '.join(CAM_LAWS)}")


def _u_minus_sin(u: float) -> float:
    """u - sin(u) for u >= 0, without cancellation for small u."""
    if u >= _SERIES_LIMIT:
        return u - math.sin(u)
    # sum_{k>=1} (-1)^(k+1) u^(2k+1) / (2k+1)!; at u < 1 ten terms reach 1e-20 relative.
    term = u * u * u / 6.0
    total = 0.0
    k = 1
    while term != 0.0 and k < 20:
        total += term
        term *= -u * u / ((2 * k + 2) * (2 * k + 3))
        k += 1
        if abs(term) <= 1e-18 * abs(total):
            break
    return total


def _half(law: str, y: float) -> tuple[float, float, float, float]:
    """(f, f1, f2, f3) of ``law`` at y in [0, 1/2], each with full relative accuracy."""
    if law == "harmonic":
        half_angle = 0.5 * math.pi * y
        s = math.sin(math.pi * y)
        return (
            math.sin(half_angle) ** 2,  # (1 - cos(pi y))/2 without cancellation
            0.5 * math.pi * s,
            0.5 * math.pi**2 * math.cos(math.pi * y),
            -0.5 * math.pi**3 * s,
        )
    if law == "cycloidal":
        u = TAU * y
        return (
            _u_minus_sin(u) / TAU,
            2.0 * math.sin(0.5 * u) ** 2,  # 1 - cos(u)
            TAU * math.sin(u),
            TAU * TAU * math.cos(u),
        )
    z = 1.0 - y  # exact for y in [0, 1/2]
    if law == "polynomial_345":
        # factored forms: the roots at 0 and 1 are exact, the cubic terms carry the sign
        return (
            y**3 * (10.0 + y * (-15.0 + 6.0 * y)),
            30.0 * (y * z) ** 2,
            60.0 * y * z * (1.0 - 2.0 * y),
            60.0 * (1.0 + 6.0 * y * (y - 1.0)),
        )
    return (
        y**4 * (35.0 + y * (-84.0 + y * (70.0 - 20.0 * y))),
        140.0 * (y * z) ** 3,
        420.0 * (y * z) ** 2 * (1.0 - 2.0 * y),
        840.0 * y * z * (1.0 + 5.0 * y * (y - 1.0)),
    )


def _rise(law: str, x: float) -> tuple[float, float, float, float, float]:
    """(f, 1 - f, f1, f2, f3) at x in [0, 1]; 1 - f keeps full relative accuracy near x = 1."""
    if x <= 0.5:
        f, f1, f2, f3 = _half(law, x)
        return f, 1.0 - f, f1, f2, f3
    # point symmetry: f(x) = 1 - f(1 - x), f1 even, f2 odd, f3 even about x = 1/2
    g, g1, g2, g3 = _half(law, 1.0 - x)
    return 1.0 - g, g, g1, -g2, g3


def normalized(law: str, x: float) -> "NormalizedRise":
    """Normalized rise f(x) and its derivatives f1, f2, f3 with respect to x, x in [0, 1].

    f(0) = 0, f(1) = 1 (dimensionless). Raises MechanismError for an unknown law and
    RangeError for x outside [0, 1].
    """
    _check_law(law)
    x = require_between("x", x, 0.0, 1.0)
    f, _, f1, f2, f3 = _rise(law, x)
    return NormalizedRise(f, f1, f2, f3)


def peak_coefficients(law: str) -> "PeakCoefficients":
    """Maxima of |f1|, |f2|, |f3| on [0, 1] in closed form: (velocity, acceleration, jerk).

    The peak follower velocity, acceleration and jerk of a rise of ``lift`` over ``beta``
    at constant camshaft speed w are lift * (velocity w / beta, acceleration w^2 / beta^2,
    jerk w^3 / beta^3). Where each maximum lies (t = x - 1/2):

    harmonic: f1 = (pi/2) sin(pi x), max pi/2 at x = 1/2; f2 = (pi^2/2) cos(pi x), max
    pi^2/2 at x = 0 and 1; f3 = -(pi^3/2) sin(pi x), max pi^3/2 at x = 1/2.

    cycloidal: f1 = 1 - cos(2 pi x), max 2 at x = 1/2; f2 = 2 pi sin(2 pi x), max 2 pi at
    x = 1/4 and 3/4; f3 = 4 pi^2 cos(2 pi x), max 4 pi^2 at x = 0, 1/2 and 1.

    polynomial_345: f1 = 30 x^2 (1 - x)^2, max 30/16 = 15/8 at x = 1/2;
    f2 = 60 x (1 - x)(1 - 2x) = -120 t (1/4 - t^2), stationary at t^2 = 1/12, i.e.
    x = 1/2 -+ sqrt(3)/6, where |f2| = 120 (1/(2 sqrt 3)) (1/6) = 10/sqrt(3);
    f3 = 60 (1 - 6x + 6x^2) = 60 (6 t^2 - 1/2): 60 at x = 0 and 1, -30 at x = 1/2; max 60.

    polynomial_4567: f1 = 140 x^3 (1 - x)^3, max 140/64 = 35/16 at x = 1/2;
    f2 = 420 x^2 (1 - x)^2 (1 - 2x) = -840 t (1/4 - t^2)^2, whose t-derivative
    (1/4 - t^2)(1/4 - 5 t^2) vanishes at t^2 = 1/20, i.e. x = (5 -+ sqrt(5))/10, where
    |f2| = 840 (1/(2 sqrt 5)) (1/5)^2 = 84/(5 sqrt 5) = 84 sqrt(5)/25 = 7.5132...;
    f3 = -840 (1/4 - t^2)(1/4 - 5 t^2): -52.5 at x = 1/2, +42 at t^2 = 3/20, 0 at the ends;
    max 52.5 at x = 1/2.
    """
    _check_law(law)
    return _PEAKS[law]


def check_profile(
    law: str,
    lift: float,
    rise_start: float,
    rise_angle: float,
    high_dwell_angle: float,
    return_angle: float,
) -> "CamProfile":
    """Validate a cam profile and return it as a CamProfile of floats (law, m, rad).

    law in CAM_LAWS; lift > 0 (m); rise_start any finite angle (the profile is periodic);
    rise_angle > 0, return_angle > 0, high_dwell_angle >= 0, and the three together at
    most one revolution, 2 pi (the low dwell takes the rest and may be empty).
    """
    _check_law(law)
    lift = require_positive("lift", lift, "m")
    rise_start = require_finite("rise_start", rise_start, "rad")
    rise_angle = require_positive("rise_angle", rise_angle, "rad")
    high_dwell_angle = require_between("high_dwell_angle", high_dwell_angle, 0.0, TAU, "rad")
    return_angle = require_positive("return_angle", return_angle, "rad")
    total = rise_angle + high_dwell_angle + return_angle
    if total > TAU:
        raise RangeError(
            "rise_angle + high_dwell_angle + return_angle",
            total,
            f"(0, {TAU!r}]",
            "rad",
            "rise, high dwell and return must fit in one camshaft revolution",
        )
    return CamProfile(law, lift, rise_start, rise_angle, high_dwell_angle, return_angle)


DEFAULT_CAM_PROFILE = check_profile("polynomial_345", 0.007, 0.0, 1.2, 0.1, 1.2)


def reduce_angle(angle: float) -> float:
    """``angle`` reduced into [0, 2 pi) (rad).

    math.fmod is exact, so the only errors are the float period (2.4e-16 rad per revolution,
    i.e. 4e-17 * |angle|) and none from the reduction itself: after n revolutions the result
    is still within about 1e-16 * |angle| of the true one, where angle - 2 pi floor(angle/2 pi)
    would lose the digits of the rounded quotient.
    """
    reduced = math.fmod(angle, TAU)
    if reduced < 0.0:
        reduced += TAU
        if reduced >= TAU:  # a tiny negative remainder rounds to 2 pi: it is the start
            reduced = 0.0
    return reduced


def segment_lift(profile: "CamProfile", segment: str, x: float) -> "CamLift":
    """Lift and its angle derivatives at phase x in [0, 1] of the rise or the return.

    Both ends are included (they are the one-sided limits of the segment, whichever segment
    cam_lift assigns the boundary to). Returns CamLift(s m, s1 m/rad, s2 m/rad^2, s3 m/rad^3).
    """
    if segment not in SEGMENTS:
        raise MechanismError(f"segment = {segment!r} is not one of {', '.join(SEGMENTS)}")
    f, complement, f1, f2, f3 = _rise(profile.law, min(max(x, 0.0), 1.0))
    lift = profile.lift
    if segment == "rise":
        beta = profile.rise_angle
        return CamLift(lift * f, lift * f1 / beta, lift * f2 / beta**2, lift * f3 / beta**3)
    beta = profile.return_angle
    return CamLift(lift * complement, -lift * f1 / beta, -lift * f2 / beta**2, -lift * f3 / beta**3)


def cam_lift(profile: "CamProfile", camshaft_angle: float) -> "CamLift":
    """Follower lift and its derivatives with respect to the camshaft angle.

    ``profile`` is a CamProfile from check_profile; ``camshaft_angle`` in rad, any finite
    value (period 2 pi). Segments are closed on the left: at the start of the rise the rise
    applies, at its end the high dwell, and so on. Returns CamLift(s m, s1 m/rad,
    s2 m/rad^2, s3 m/rad^3).
    """
    angle = require_finite("camshaft_angle", camshaft_angle, "rad")
    local = reduce_angle(angle - profile.rise_start)
    rise_end = profile.rise_angle
    return_start = rise_end + profile.high_dwell_angle
    return_end = return_start + profile.return_angle
    if local < rise_end:
        return segment_lift(profile, "rise", local / rise_end)
    if local < return_start:
        return CamLift(profile.lift, 0.0, 0.0, 0.0)
    if local < return_end:
        return segment_lift(profile, "return", (local - return_start) / profile.return_angle)
    return CamLift(0.0, 0.0, 0.0, 0.0)


def follower_motion(
    profile: "CamProfile",
    camshaft_angle: float,
    camshaft_speed: float,
    camshaft_acceleration: float,
) -> "FollowerMotion":
    """Follower lift (m), velocity (m/s) and acceleration (m/s^2) by the chain rule.

    With the camshaft at angle theta (rad), speed w (rad/s) and acceleration alpha (rad/s^2):
    v = s1 w, a = s2 w^2 + s1 alpha.
    """
    speed = require_finite("camshaft_speed", camshaft_speed, "rad/s")
    accel = require_finite("camshaft_acceleration", camshaft_acceleration, "rad/s^2")
    s, s1, s2, _ = cam_lift(profile, camshaft_angle)
    return FollowerMotion(s, s1 * speed, s2 * speed * speed + s1 * accel)


def _half_law(law: str) -> Callable[[float], tuple[float, float, float]]:
    """(f, f1, f2) of ``law`` at y in [0, 1/2]: _half's expressions without f3."""
    pi = math.pi
    if law == "harmonic":
        c1, c2 = 0.5 * pi, 0.5 * pi**2

        def harmonic(y: float) -> tuple[float, float, float]:
            return math.sin(0.5 * pi * y) ** 2, c1 * math.sin(pi * y), c2 * math.cos(pi * y)

        return harmonic
    if law == "cycloidal":

        def cycloidal(y: float) -> tuple[float, float, float]:
            u = TAU * y
            return _u_minus_sin(u) / TAU, 2.0 * math.sin(0.5 * u) ** 2, TAU * math.sin(u)

        return cycloidal
    if law == "polynomial_345":

        def polynomial_345(y: float) -> tuple[float, float, float]:
            z = 1.0 - y
            return (
                y**3 * (10.0 + y * (-15.0 + 6.0 * y)),
                30.0 * (y * z) ** 2,
                60.0 * y * z * (1.0 - 2.0 * y),
            )

        return polynomial_345

    def polynomial_4567(y: float) -> tuple[float, float, float]:
        z = 1.0 - y
        return (
            y**4 * (35.0 + y * (-84.0 + y * (70.0 - 20.0 * y))),
            140.0 * (y * z) ** 3,
            420.0 * (y * z) ** 2 * (1.0 - 2.0 * y),
        )

    return polynomial_4567


def motion_function(
    profile: "CamProfile",
) -> Callable[[float, float, float], tuple[float, float, float]]:
    """follower_motion of ``profile`` as one function of (camshaft angle rad, speed rad/s,
    acceleration rad/s^2) -> (lift m, velocity m/s, acceleration m/s^2), for a model's
    step: the profile's constants worked out once, the same arithmetic as follower_motion
    (the same numbers, bit for bit), no checks: the arguments must be finite (a slave's
    step has checked its inputs; a NaN or infinity goes to follower_motion, which names
    it)."""
    _check_law(profile.law)
    half = _half_law(profile.law)
    lift, rise_start = profile.lift, profile.rise_start
    rise_end = profile.rise_angle
    return_start = rise_end + profile.high_dwell_angle
    return_angle = profile.return_angle
    return_end = return_start + return_angle
    rise_squared, return_squared = rise_end**2, return_angle**2
    fmod, isfinite = math.fmod, math.isfinite

    def motion(angle: float, speed: float, accel: float) -> tuple[float, float, float]:
        if not isfinite(angle + speed + accel):
            return tuple(follower_motion(profile, angle, speed, accel))
        local = fmod(angle - rise_start, TAU)  # reduce_angle, inline
        if local < 0.0:
            local += TAU
            if local >= TAU:
                local = 0.0
        if local < rise_end:
            x = min(max(local / rise_end, 0.0), 1.0)
            if x <= 0.5:
                f, f1, f2 = half(x)
                s = lift * f
            else:
                g, f1, f2 = half(1.0 - x)
                f2 = -f2
                s = lift * (1.0 - g)
            s1, s2 = lift * f1 / rise_end, lift * f2 / rise_squared
        elif local < return_start:
            return lift, 0.0 * speed, 0.0 * speed * speed + 0.0 * accel
        elif local < return_end:
            x = min(max((local - return_start) / return_angle, 0.0), 1.0)
            if x <= 0.5:
                f, f1, f2 = half(x)
                s = lift * (1.0 - f)
            else:
                s, f1, f2 = half(1.0 - x)
                f2 = -f2
                s = lift * s
            s1, s2 = -lift * f1 / return_angle, -lift * f2 / return_squared
        else:
            return 0.0, 0.0 * speed, 0.0 * speed * speed + 0.0 * accel
        return s, s1 * speed, s2 * speed * speed + s1 * accel

    return motion
