"""Disc cam geometry for a translating follower (standard library only).

From the follower's displacement diagram s(theta) and its derivatives with respect to the
camshaft angle, s1 = ds/dtheta, s2 = d2s/dtheta2 (m, m/rad, m/rad^2), this module gives the
cam that produces it: the profile point in the cam's frame, the pressure angle, the radii of
curvature of the pitch curve and of the cam surface, where the contact lies on a flat face;
the design checks (cusp, undercut, pressure angle) over a revolution; and the smallest base
circle that meets them. References: R. L. Norton, *Design of Machinery*, chapter "Cam
Design", sections "Sizing the cam: pressure angle and radius of curvature" and "Cam
manufacturing considerations" (the formulas below are written out in full, derived here).

Supported followers (FOLLOWERS), both translating along a line parallel to y:

    flat_faced  a flat face perpendicular to the follower's axis (the pushrod tappet of the
                valve train); its axis may be offset, which moves the contact on the face
                but not the cam.
    roller      a roller of radius Rf whose centre moves on the axis; the axis may be offset
                from the camshaft centre by e (Norton's eccentricity epsilon).

Oscillating (rocker-arm) followers are not supported: their follower motion is an angle about
a pivot, not a translation, and needs its own inversion.

Frames (m, rad). Fixed frame: origin at the camshaft centre, y along the follower's
direction of lift, x to the right; the follower's axis is the line x = e (follower_offset).
The camshaft turns counter-clockwise by theta; the cam frame is fixed to the cam and
coincides with the fixed frame at theta = 0, so a fixed point q is at R(-theta) q in the cam
frame (the inversion: the follower walks clockwise round a standing cam).

Trace point (complex notation, z = x + i y in the cam frame): the roller's centre
T = (e, h), h = d + s, d = sqrt(Rp^2 - e^2), Rp = Rb + Rf the prime circle; for the flat face
the point of the face on the axis, h = Rb + s. Its path is the pitch curve

    z = e^(-i theta) (e + i h),   z' = e^(-i theta) (h + i c),   c = s1 - e,
    z'' = e^(-i theta) ((2 s1 - e) + i (s2 - h)).

The curve runs clockwise, so its radius of curvature, positive where it is convex, is

    rho_pitch = |z'|^3 / -Im(conj(z') z'') = (h^2 + c^2)^(3/2) / (h^2 - h s2 + c (2 s1 - e))

(Norton's pitch-curve radius; with e = 0 the denominator is (Rp + s)^2 + 2 v^2 - a (Rp + s),
v = s1, a = s2). Pressure angle: the angle between the follower's axis and the common normal,
the normal of the pitch curve at T, n = (c, -h) / |z'| in the fixed frame pointing into the
cam: tan(phi) = c / h = (s1 - e) / (s + sqrt(Rp^2 - e^2)) (Norton's pressure angle with
eccentricity). A positive offset lowers the pressure angle of the rise (s1 > 0).

    roller      contact point T + Rf n (fixed frame): the inner offset of the pitch curve by
                Rf; surface radius rho = rho_pitch - Rf (Norton: rho_cam = rho_pitch - Rf).
                Undercut where the convex pitch curve is sharper than the roller,
                0 < rho_pitch <= Rf; a concave part (rho_pitch < 0) is no limit, the surface
                there is concave with radius |rho_pitch| + Rf > Rf.
    flat_faced  the face is the line q . u = H, u = (sin theta, cos theta) the follower's
                direction in the cam frame, H = Rb + s; the cam is the envelope of these
                lines: with u' = (cos theta, -sin theta), q = H u + s1 u', i.e. the contact
                lies on the face at x = s1 in the fixed frame (s1 - e from the axis) and the
                face must cover the range of s1 (Norton's face width). q' = (H + s2) u', so the
                surface radius of curvature is rho = Rb + s + s2 (Norton's flat-faced
                radius); rho <= 0 is a cusp: the face cannot follow the law (the cam would
                need a concave part, which a flat face bridges). The pressure angle is 0.

Torque: a frictionless follower pressed on the cam with force F along its axis needs the
camshaft torque F s1 in the direction of rotation, whatever the follower type or offset:
the normal force F / cos(phi) along n at the contact has the moment F s1 about the camshaft
centre (flat face: F at x = s1; roller: the line of n passes through T = (e, h), and
(e, h) x (c, -h) = -h s1). See camshaft_torque.
"""

import functools
import math
import sys
from collections import namedtuple
from collections.abc import Callable

from ..errors import CamDesignError, MechanismError, RangeError, require_finite, require_positive
from ..numerics.roots import refined_minimum
from . import cam_laws
from .cam_laws import TAU, CamProfile

FOLLOWERS = ("flat_faced", "roller")
# Norton's rule for translating followers: keep the pressure angle below about 30 degrees.
DEFAULT_PRESSURE_ANGLE_LIMIT = math.pi / 6.0
DEFAULT_SAMPLES = 720  # grid points per revolution of the design scan (then golden section)
# Golden section stops at a bracket of 1e-9 of a piece's phase: the extreme value is then
# found to about 1e-18 of its scale (the error is quadratic), its angle to about 1e-9 rad.
PHASE_TOLERANCE = 1e-9
# FMU parameter names the messages use (the ValveTrain parameters a user sets)
BASE, ROLLER, OFFSET, KIND = "cam_base_radius", "roller_radius", "follower_offset", "follower"
# DesignProblem kinds: require_design refuses a cusp and an undercut; the others are flags
CUSP, UNDERCUT, PRESSURE_ANGLE = "cusp", "undercut", "pressure_angle"
BOUND = "offset"  # Sizing.limit where only |e| < Rb (flat) or |e| < Rp, Rb > 0 (roller) binds

Follower = namedtuple("Follower", "kind base_circle_radius roller_radius offset")
CamPoint = namedtuple(
    "CamPoint",
    "x y pitch_x pitch_y pressure_angle radius_of_curvature pitch_radius_of_curvature face_contact",
)
Piece = namedtuple("Piece", "start span motion")
DesignProblem = namedtuple("DesignProblem", "kind angle value limit message")
CamDesign = namedtuple(
    "CamDesign",
    "least_radius least_radius_angle least_pitch_radius least_pitch_radius_angle "
    "largest_pressure_angle largest_pressure_angle_angle contact_low contact_high "
    "face_width problems",
)
Sizing = namedtuple("Sizing", "base_circle_radius limit angle")
Motion = tuple[float, float, float]  # (s m, s1 m/rad, s2 m/rad^2) at one camshaft angle


def check_follower(
    kind: str, base_circle_radius: float, roller_radius: float = 0.0, offset: float = 0.0
) -> "Follower":
    """A validated Follower (kind, base circle radius Rb m, roller radius Rf m, offset e m).

    kind in FOLLOWERS; Rb > 0; a roller needs Rf > 0 (a flat face ignores it and keeps 0);
    the axis must cross the cam's circle the follower rests on at zero lift: |e| < Rb for the
    flat face, |e| < Rb + Rf (the prime circle) for the roller. RangeError names the
    ValveTrain parameter, its value and the limit.
    """
    if kind not in FOLLOWERS:
        raise MechanismError(f"{KIND} = {kind!r} is not one of {', '.join(FOLLOWERS)}")
    base = require_positive(BASE, base_circle_radius, "m")
    roller = require_positive(ROLLER, roller_radius, "m") if kind == "roller" else 0.0
    offset = require_finite(OFFSET, offset, "m")
    reach = base + roller
    if not abs(offset) < reach:
        circle = "the prime circle Rb + Rf" if kind == "roller" else "the base circle"
        raise RangeError(
            OFFSET,
            offset,
            f"({-reach!r}, {reach!r})",
            "m",
            f"the follower's axis must cross {circle} (the offset lies beyond it)",
        )
    return Follower(kind, base, roller, offset)


def trace_height(follower: "Follower") -> float:
    """Height d (m) of the trace point above the camshaft centre at zero lift: Rb for the
    flat face, sqrt(Rp^2 - e^2) for the roller (Rp = Rb + Rf)."""
    if follower.kind == "flat_faced":
        return follower.base_circle_radius
    prime = follower.base_circle_radius + follower.roller_radius
    e = follower.offset
    product = (prime - e) * (prime + e)
    if 1e-290 < product < 1e290:
        return math.sqrt(product)
    return math.sqrt(prime - e) * math.sqrt(prime + e)  # the product would under/overflow


SEARCH_START = 1e-3  # m: smallest_base_circle's search grows the prime circle from here at least


def pitch_curvature(follower: "Follower", s: float, s1: float, s2: float) -> float:
    """Curvature (1/m) of the trace point's path at lift s, s1, s2: positive where convex,
    finite everywhere (the radius of curvature is its inverse)."""
    h = trace_height(follower) + s
    c = s1 - follower.offset
    squared = h * h + c * c
    if 1e-200 < squared < 1e200:  # r^3 a float (a power that overflows raises)
        return (h * (h - s2) + c * (2.0 * s1 - follower.offset)) / squared**1.5
    # the trace point's distance r = |(h, c)| is so small (or large) that r^3 leaves the
    # floats (a trial prime circle of 1e-300 m in smallest_base_circle): the same curvature
    # scaled by r, at most the largest float
    r = math.hypot(h, c)
    if r == 0.0:
        return sys.float_info.max  # the trace point on the camshaft's axis: unbounded
    curvature = ((h / r) * ((h - s2) / r) + (c / r) * ((2.0 * s1 - follower.offset) / r)) / r
    if math.isnan(curvature):  # inf / inf on the way from finite inputs; a NaN input stays
        return curvature if math.isnan(r) else sys.float_info.max
    return max(-sys.float_info.max, min(sys.float_info.max, curvature))


def _radius(curvature: float) -> float:
    """1 / curvature (m); for a straight piece (a curvature whose inverse overflows) the
    largest float with the curvature's sign, never inf (an FMU output must be finite)."""
    if abs(curvature) * sys.float_info.max <= 1.0:
        return math.copysign(sys.float_info.max, curvature)
    return 1.0 / curvature


def cam_point(follower: "Follower", angle: float, s: float, s1: float, s2: float) -> "CamPoint":
    """The cam at camshaft angle ``angle`` (rad) where the follower's lift is s (m) with
    s1 = ds/dtheta (m/rad) and s2 = d2s/dtheta2 (m/rad^2). Returns CamPoint:

    x, y                       contact point on the cam surface, cam frame (m)
    pitch_x, pitch_y           trace point (roller centre; flat face: the face on the axis),
                               cam frame (m): a point of the pitch curve
    pressure_angle             (rad) between the follower's axis and the common normal,
                               atan((s1 - e) / h); 0 for the flat face
    radius_of_curvature        of the cam surface at the contact (m): Rb + s + s2 (flat),
                               rho_pitch - Rf (roller); negative where concave (the
                               largest float where straight)
    pitch_radius_of_curvature  of the pitch curve (m), positive where convex
    face_contact               where the contact lies on a flat face, from the follower's
                               axis along +x (m): s1 - e; 0 for the roller
    """
    e = follower.offset
    h = trace_height(follower) + s
    c = s1 - e
    if follower.kind == "flat_faced":
        contact_x, contact_y = s1, h
        pressure = 0.0
        surface = h + s2
        face = c
        pitch = _radius(pitch_curvature(follower, s, s1, s2))
    else:
        length = math.hypot(h, c)
        roller = follower.roller_radius
        contact_x, contact_y = e + roller * c / length, h - roller * h / length
        pressure = math.atan2(c, h)
        pitch = _radius(pitch_curvature(follower, s, s1, s2))
        surface = pitch - roller
        face = 0.0
    cos_t, sin_t = math.cos(angle), math.sin(angle)
    return CamPoint(
        contact_x * cos_t + contact_y * sin_t,
        contact_y * cos_t - contact_x * sin_t,
        e * cos_t + h * sin_t,
        h * cos_t - e * sin_t,
        pressure,
        surface,
        pitch,
        face,
    )


def profile_point(follower: "Follower", profile: CamProfile, angle: float) -> "CamPoint":
    """cam_point of a cam whose displacement diagram is the cam law ``profile`` (a
    cam_laws.CamProfile) at camshaft angle ``angle`` (rad)."""
    s, s1, s2, _ = cam_laws.cam_lift(profile, angle)
    return cam_point(follower, angle, s, s1, s2)


def camshaft_torque(force: float, lift_rate: float) -> float:
    """Torque (N.m) the camshaft must supply, in its direction of rotation, to move a load
    ``force`` (N, opposing the lift) whose point rises lift_rate = dL/dtheta (m/rad) per
    camshaft radian, through frictionless joints: F dL/dtheta, from the power balance
    T w = F (dL/dtheta) w. For the follower itself (F along its axis, lift_rate = s1) it is
    also the moment of the contact's normal force about the camshaft centre, whatever the
    follower type and offset; through a massless rocker the valve's force and rate give the
    same torque (virtual work)."""
    return force * lift_rate


# --- the displacement diagram in pieces ------------------------------------------------------


def law_pieces(profile: CamProfile) -> tuple["Piece", ...]:
    """The cam law ``profile`` as Pieces (start rad, span rad, motion: phase x in [0, 1] ->
    (s, s1, s2)): rise, high dwell, return, low dwell (dwells of zero span left out). Each
    motion includes both ends of its piece (the one-sided limits where a derivative jumps),
    so a design scan sees the values on both sides of every join."""
    lift = profile.lift
    rise_end = profile.rise_angle
    return_start = rise_end + profile.high_dwell_angle
    return_end = return_start + profile.return_angle

    def segment(name: str) -> Callable[[float], Motion]:
        def motion(x: float) -> Motion:
            s, s1, s2, _ = cam_laws.segment_lift(profile, name, x)
            return s, s1, s2

        return motion

    def dwell(height: float) -> Callable[[float], Motion]:
        return lambda x: (height, 0.0, 0.0)

    pieces = [
        Piece(profile.rise_start, rise_end, segment("rise")),
        Piece(profile.rise_start + rise_end, profile.high_dwell_angle, dwell(lift)),
        Piece(profile.rise_start + return_start, profile.return_angle, segment("return")),
        Piece(profile.rise_start + return_end, TAU - return_end, dwell(0.0)),
    ]
    return tuple(piece for piece in pieces if piece.span > 0.0)


def _grid_count(piece: "Piece", samples: int) -> int:
    return max(8, math.ceil(samples * piece.span / TAU))


def piece_minimum(
    piece: "Piece", quantity: Callable[[Motion], float], samples: int = DEFAULT_SAMPLES
) -> tuple[float, float]:
    """(least value, camshaft angle rad) of quantity(motion) over ``piece``: a closed grid
    of its phase (about ``samples`` points per revolution), each sampled local minimum
    refined by golden section."""
    count = _grid_count(piece, samples)
    grid = [i / count for i in range(count + 1)]

    def function(x: float) -> float:
        return quantity(piece.motion(x))

    value, x = refined_minimum(function, grid, [function(x) for x in grid], PHASE_TOLERANCE)
    return value, piece.start + x * piece.span


def remembered(pieces: tuple["Piece", ...]) -> tuple["Piece", ...]:
    """``pieces`` whose motions remember their values: a design scans the same grid for
    several quantities (and sizing at every trial radius), each motion evaluated once."""
    return tuple(
        Piece(p.start, p.span, functools.lru_cache(maxsize=None)(p.motion)) for p in pieces
    )


def revolution_minimum(
    pieces: tuple["Piece", ...], quantity: Callable[[Motion], float], samples: int
) -> tuple[float, float]:
    """(least value, camshaft angle rad) of quantity(motion) over every piece."""
    return min((piece_minimum(p, quantity, samples) for p in pieces), key=lambda found: found[0])


# --- design checks and sizing ----------------------------------------------------------------


def design(
    follower: "Follower",
    pieces: tuple["Piece", ...],
    pressure_angle_limit: float = DEFAULT_PRESSURE_ANGLE_LIMIT,
    samples: int = DEFAULT_SAMPLES,
) -> "CamDesign":
    """The design figures of the cam that produces the displacement diagram ``pieces``
    (law_pieces, or ValveTrain's tappet diagram) with ``follower``, over a revolution:

    least_radius, _angle              least radius of curvature of the cam surface where it
                                      is convex (m; flat face: min of Rb + s + s2, negative
                                      at a cusp), and the camshaft angle (rad)
    least_pitch_radius, _angle        least positive radius of the pitch curve (m)
    largest_pressure_angle, _angle    the pressure angle of largest magnitude (rad, signed)
    contact_low, contact_high         flat face: the range of the contact on the face from
                                      the axis, s1 - e (m); 0, 0 for the roller
    face_width                        contact_high - contact_low (m)
    problems                          DesignProblems (kind CUSP, UNDERCUT or PRESSURE_ANGLE,
                                      camshaft angle, value, limit, message), in that order

    pressure_angle_limit in (0, pi/2) rad.
    """
    limit = require_positive("pressure_angle_limit", pressure_angle_limit, "rad")
    if limit >= math.pi / 2.0:
        raise RangeError("pressure_angle_limit", limit, f"(0, {math.pi / 2.0!r})", "rad")
    e = follower.offset
    problems = []
    pieces = remembered(pieces)
    negative, pitch_at = revolution_minimum(
        pieces, lambda m: -pitch_curvature(follower, *m), samples
    )
    curvature = -negative  # the pitch curve's largest curvature, 1/m
    pitch_least = _radius(curvature)  # the base circle is convex: curvature > 0
    if follower.kind == "flat_faced":
        base = follower.base_circle_radius
        least, least_at = revolution_minimum(pieces, lambda m: base + m[0] + m[2], samples)
        pressure, pressure_at = 0.0, pieces[0].start
        low = revolution_minimum(pieces, lambda m: m[1] - e, samples)[0]
        high = -revolution_minimum(pieces, lambda m: e - m[1], samples)[0]
        if least <= 0.0:
            problems.append(
                DesignProblem(
                    CUSP,
                    least_at,
                    least,
                    0.0,
                    f"cusp: the flat-faced follower's cam surface radius of curvature "
                    f"Rb + s + s'' falls to {least:.6g} m at camshaft angle {least_at:.6g} "
                    f"rad; it must stay positive: {BASE} above {base - least:.6g} m",
                ),
            )
    else:
        roller = follower.roller_radius
        height = trace_height(follower)

        def pressure_angle(m: Motion) -> float:
            return math.atan2(m[1] - e, height + m[0])

        largest, largest_at = revolution_minimum(pieces, lambda m: -pressure_angle(m), samples)
        smallest, smallest_at = revolution_minimum(pieces, pressure_angle, samples)
        pressure, pressure_at = (
            (-largest, largest_at) if -largest >= -smallest else (smallest, smallest_at)
        )
        low = high = 0.0
        least, least_at = pitch_least - roller, pitch_at
        if curvature * roller >= 1.0:
            problems.append(
                DesignProblem(
                    UNDERCUT,
                    pitch_at,
                    pitch_least,
                    roller,
                    f"undercut: the pitch curve's radius of curvature falls to "
                    f"{pitch_least:.6g} m at camshaft angle {pitch_at:.6g} rad, not above "
                    f"the roller's {roller:.6g} m: a smaller roller or a larger {BASE}",
                )
            )
        if abs(pressure) > limit:
            problems.append(
                DesignProblem(
                    PRESSURE_ANGLE,
                    pressure_at,
                    pressure,
                    limit,
                    f"pressure angle {math.degrees(pressure):.4g} deg at camshaft angle "
                    f"{pressure_at:.6g} rad exceeds pressure_angle_limit "
                    f"{math.degrees(limit):.4g} deg: a larger {BASE} (an offset helps the rise "
                    f"only at the return's expense)",
                )
            )
    return CamDesign(
        least,
        least_at,
        pitch_least,
        pitch_at,
        pressure,
        pressure_at,
        low,
        high,
        high - low,
        tuple(problems),
    )


def require_design(follower: "Follower", found: "CamDesign") -> "CamDesign":
    """``found`` when no cam can be made is refused: CamDesignError (a RangeError naming the
    parameter to change and its limit) for a cusp (flat face: cam_base_radius) or an
    undercut (roller: roller_radius), at the camshaft angle where it happens."""
    for problem in found.problems:
        if problem.kind == CUSP:
            raise CamDesignError(
                CUSP,
                problem.angle,
                BASE,
                follower.base_circle_radius,
                f"({follower.base_circle_radius - problem.value!r}, inf)",
                "m",
                problem.message,
            )
        if problem.kind == UNDERCUT:
            raise CamDesignError(
                UNDERCUT,
                problem.angle,
                ROLLER,
                follower.roller_radius,
                f"(0, {problem.value!r})",
                "m",
                problem.message,
            )
    return found


def smallest_base_circle(
    kind: str,
    pieces: tuple["Piece", ...],
    roller_radius: float = 0.0,
    offset: float = 0.0,
    pressure_angle_limit: float = DEFAULT_PRESSURE_ANGLE_LIMIT,
    min_radius_of_curvature: float = 0.0,
    samples: int = DEFAULT_SAMPLES,
) -> "Sizing":
    """The smallest base circle radius Rb (m) with which the diagram ``pieces`` makes a cam
    meeting the limits: surface radius of curvature at least ``min_radius_of_curvature`` (m)
    where convex (flat face: everywhere), pressure angle at most ``pressure_angle_limit``
    (rad; roller), and the axis inside the cam's circle (|e| < Rb, flat; |e| < Rb + Rf,
    roller). Returns Sizing(Rb m, the limit that sets it: "curvature", "pressure_angle" or
    BOUND ("offset": the offset, or for a roller Rb > 0, the infimum then), camshaft angle rad
    where it binds; nan for BOUND).

    Flat face: Rb + s + s2 >= rho_min gives Rb = rho_min - min(s + s2) in closed form.
    Roller: the pressure angle gives sqrt(Rp^2 - e^2) >= max(|s1 - e| / tan(limit) - s), in
    closed form; the curvature condition, rho_pitch >= Rf + rho_min where convex (the pitch
    curvature at most 1 / (Rf + rho_min)), is found by bisection on Rp from the first
    feasible point of a geometric scan upward from the offset and roller bounds. At the
    returned radius the limit is met with equality (to about 1e-12 relative): take a margin.
    """
    if kind not in FOLLOWERS:
        raise MechanismError(f"{KIND} = {kind!r} is not one of {', '.join(FOLLOWERS)}")
    e = require_finite(OFFSET, offset, "m")
    required = require_finite("min_radius_of_curvature", min_radius_of_curvature, "m", "[0, inf)")
    if required < 0.0:
        raise RangeError("min_radius_of_curvature", required, "[0, inf)", "m")
    if kind == "flat_faced":
        least, at = revolution_minimum(pieces, lambda m: m[0] + m[2], samples)
        base = required - least
        if base <= abs(e):
            return Sizing(abs(e), BOUND, math.nan)
        return Sizing(base, "curvature", at)
    roller = require_positive(ROLLER, roller_radius, "m")
    limit = require_positive("pressure_angle_limit", pressure_angle_limit, "rad")
    tangent = math.tan(limit)
    # the grid's motions are the same at every trial radius: each evaluated once
    pieces = tuple(
        Piece(p.start, p.span, functools.lru_cache(maxsize=None)(p.motion)) for p in pieces
    )
    need, need_at = revolution_minimum(pieces, lambda m: m[0] - abs(m[1] - e) / tangent, samples)
    prime_pressure = math.hypot(-need, e) if -need > 0.0 else 0.0
    allowed = 1.0 / (roller + required)

    def excess(prime: float) -> tuple[float, float]:
        """(largest pitch curvature times (Rf + rho_min) minus 1, its angle) at prime
        radius Rp: feasible where <= 0."""
        follower = Follower(kind, prime - roller, roller, e)
        worst, at = revolution_minimum(pieces, lambda m: -pitch_curvature(follower, *m), samples)
        return -worst / allowed - 1.0, at

    bound = max(abs(e), roller) * (1.0 + 1e-12)  # Rp > |e| and Rb = Rp - Rf > 0
    low = high = bound
    if excess(bound)[0] > 0.0:
        # grown from a millimetre at least: a bound of 1e-300 m (a roller that small) would
        # take thousands of steps of 1.25 to reach a real cam's size
        high = max(bound * 1.25, SEARCH_START)
        for _ in range(400):
            if excess(high)[0] <= 0.0:
                break
            low, high = high, high * 1.25
        else:
            raise MechanismError(
                f"smallest_base_circle: no prime circle up to {low:.3g} m is feasible "
                f"(roller_radius {roller!r} m, follower_offset {e!r} m)"
            )
    while high - low > 1e-13 * high:
        middle = 0.5 * (low + high)
        if excess(middle)[0] <= 0.0:
            high = middle
        else:
            low = middle
    candidates = [
        (high, "curvature", excess(high)[1]) if high > bound else (bound, BOUND, math.nan),
        (prime_pressure, "pressure_angle", need_at),
    ]
    prime, limit_name, at = max(candidates, key=lambda c: c[0])
    return Sizing(prime - roller, limit_name, at)
