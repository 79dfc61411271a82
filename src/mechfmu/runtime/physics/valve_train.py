"""Pushrod (OHV) valve train: tappet lift <-> rocker angle <-> valve lift (standard library only).

The coursework's closed-form rocker geometry, generalised to unequal rocker arms. All lengths
in m, angles in rad (counter-clockwise positive), time in s; the camshaft centre is the origin,
x to the right, y up.

    body 1  tappet and pushrod: the bottom point P = (0, y1) slides on the vertical x = 0,
            y1 = cam_base_radius + tappet_lift; the pushrod of length L1 joins P to the
            rocker's tappet end T:  |T - P| = L1.
    body 2  rocker, pivoted on the block at (a, b) = (rocker_pivot_x, rocker_pivot_y), angle
            phi from +x; tappet arm lt, valve arm lv on opposite sides of the pivot:
                T = (a - lt cos phi, b - lt sin phi),   V = (a + lv cos phi, b + lv sin phi).
    body 3  valve link of length L3 from V down to Q = (c, y3), which slides on the vertical
            x = c = valve_axis_x:  |V - Q| = L3.

    valve lift = y3_closed - y3 (positive when the valve opens, i.e. moves down), where
    y3_closed is y3 at tappet_lift = 0.

Closed forms. Tappet side: |T - P|^2 = L1^2 is u cos(phi) + w sin(phi) = K with u = a,
w = b - y1, K = (u^2 + w^2 + lt^2 - L1^2) / (2 lt), so with R = hypot(u, w),
psi = atan2(w, u): phi = psi - acos(K/R). The acos is evaluated as atan2(sqrt(R^2 - K^2), K)
with R^2 - K^2 written as a product of the four triangle factors (L1 + lt - R)(R + lt - L1)
(R + L1 - lt)(R + L1 + lt) / (2 lt)^2, which keeps full accuracy next to the dead centres.
Valve side: y3 = V_y - sqrt(L3^2 - (c - V_x)^2); inverted by the same circle intersection
about Q: phi = psi' + acos(K'/R') with u' = c - a, w' = y3 - b, K' = (u'^2 + w'^2 + lv^2 -
L3^2) / (2 lv). Tappet from rocker: y1 = T_y - sqrt(L1^2 - T_x^2).

Branch: the one near phi = 0 of the coursework layout: the tappet arm points left of the
pivot (cos(phi) > 0 at rest), the pushrod below T (y1 < T_y), the valve link below V
(y3 < V_y); in the tappet triangle T is clockwise of P seen from the pivot, in the valve
triangle V is counter-clockwise of Q. Each function is valid on the interval around the rest
position bounded by its own singular configurations; there it raises SingularConfiguration
(the rate of its output is infinite), beyond it RangeError naming the input and the interval:

    rocker_from_tappet   pushrod and tappet arm collinear (stretched or folded)
    valve_from_rocker    valve link perpendicular to the valve axis (horizontal)
    rocker_from_valve    valve link and valve arm collinear
    tappet_from_rocker   pushrod perpendicular to the tappet axis (horizontal)

Between the nearest dead centres of the whole chain (working_range: for the defaults tappet
lift -22.5 .. 29.2 mm, the top end where the valve link comes in line with the valve arm) the
maps are monotone and forward and inverse are exact inverses; a cam lift of 5-12 mm lies far
inside.

Rates: differentiating |T - P| = L1 and |V - Q| = L3 with e = T - P, g = V - Q gives
e.(Tdot - Pdot) = 0 and e.(Tddot - Pddot) + |Tdot - Pdot|^2 = 0, and the same for g: each is
linear in the unknown rate, solved directly in forward and inverse.
"""

import math
import sys
from functools import lru_cache
from collections import namedtuple
from typing import Any

from . import cam_geometry, cam_laws
from ..errors import (
    RangeError,
    require_above,
    SingularConfiguration,
    require_between,
    require_finite,
    require_positive,
)
from .cam_laws import CamProfile
from ..numerics.roots import refined_minimum
from collections.abc import Callable

ValveGeometry = namedtuple(
    "ValveGeometry",
    "cam_base_radius pushrod_length rocker_pivot_x rocker_pivot_y tappet_arm valve_arm "
    "valve_axis_x valve_link_length",
)
Vector = tuple[float, float]  # (x, y) in m, or its rate of change per rad of rocker angle
ValveTrainMotion = namedtuple(
    "ValveTrainMotion",
    "tappet_lift tappet_velocity tappet_acceleration rocker_angle rocker_angular_velocity "
    "rocker_angular_acceleration valve_lift valve_velocity valve_acceleration",
)
FloatSpeed = namedtuple("FloatSpeed", "camshaft_speed camshaft_angle")
WorkingRange = namedtuple("WorkingRange", "tappet_low tappet_high valve_low valve_high")

# Plausible automotive OHV values (m): 15 mm cam base circle, 200 mm pushrod, rocker pivot
# 30 mm right of the tappet axis and 218.5 mm above the camshaft centre, arms 28 mm (tappet
# side) and 42 mm (valve side): rocker ratio 42/28 = 1.5; valve axis 72 mm right of the tappet
# axis (a + lv: the valve tip sits under the valve arm's end), 50 mm valve link. At rest the
# rocker is at 7.2 deg, the pushrod within 0.7 deg of vertical; 7 mm of cam lift gives
# 10.50 mm of valve lift (instantaneous ratio d(valve lift)/d(tappet lift) 1.503 at rest,
# 1.497 at 7 mm).
DEFAULT_VALVE_GEOMETRY = ValveGeometry(
    cam_base_radius=0.015,
    pushrod_length=0.200,
    rocker_pivot_x=0.030,
    rocker_pivot_y=0.2185,
    tappet_arm=0.028,
    valve_arm=0.042,
    valve_axis_x=0.072,
    valve_link_length=0.050,
)

SINGULAR_ULPS = 4  # triangle factors this small (in units of eps * perimeter) are dead centres
_EPS = sys.float_info.epsilon


# --- geometry checks and ranges ----------------------------------------------------------


def check_geometry(g: "ValveGeometry") -> "ValveGeometry":
    """Validate a ValveGeometry and return it with float fields.

    Layout: every length > 0; the rocker pivot right of the tappet axis (rocker_pivot_x > 0)
    and above the tappet at rest (rocker_pivot_y > cam_base_radius); the valve axis right of
    the pivot (valve_axis_x > rocker_pivot_x). At zero tappet lift the rocker must assemble
    off the dead centres with its tappet arm left of the pivot (pushrod_length in an open
    interval), and the valve link must reach below the valve arm without being horizontal or
    in line with the arm (valve_link_length above a bound). RangeError names the parameter.
    """
    r_b = require_positive("cam_base_radius", g.cam_base_radius, "m")
    length_1 = require_positive("pushrod_length", g.pushrod_length, "m")
    a = require_positive("rocker_pivot_x", g.rocker_pivot_x, "m")
    b = require_above(
        "rocker_pivot_y",
        g.rocker_pivot_y,
        r_b,
        "m",
        "the rocker pivot must lie above the tappet (cam_base_radius)",
    )
    arm_t = require_positive("tappet_arm", g.tappet_arm, "m")
    arm_v = require_positive("valve_arm", g.valve_arm, "m")
    c = require_above(
        "valve_axis_x",
        g.valve_axis_x,
        a,
        "m",
        "the valve axis must lie beyond the rocker pivot, under the valve arm",
    )
    length_3 = require_positive("valve_link_length", g.valve_link_length, "m")
    checked = ValveGeometry(r_b, length_1, a, b, arm_t, arm_v, c, length_3)

    # Tappet side at rest: w0 > 0 and a > 0 put psi0 in (0, pi/2), so phi0 in (psi0 - pi,
    # psi0) falls from psi0 (stretched, L1 = |R0 - lt|) as L1 grows; cos(phi0) > 0 holds
    # until phi0 = -pi/2, where T = (a, b + lt). The folded dead centre (L1 = R0 + lt) lies
    # beyond that, so the open interval below excludes both dead centres.
    w0 = b - r_b
    low = abs(math.hypot(a, w0) - arm_t)
    high = math.hypot(a, w0 + arm_t)
    if not low < length_1 < high:
        raise RangeError(
            "pushrod_length",
            length_1,
            f"({low!r}, {high!r})",
            "m",
            "at zero tappet lift the rocker must assemble off the dead centres "
            "with its tappet arm left of the pivot",
        )

    # Valve side at rest: with dx = c - V_x and h = sqrt(L3^2 - dx^2), the valve triangle's
    # orientation is lv (dx sin(phi0) + h cos(phi0)); it must be > 0 (V counter-clockwise
    # of Q) and h > 0, i.e. L3 > |dx|, and L3 > |dx| / cos(phi0) when dx sin(phi0) < 0.
    phi0 = _phi_from_y1(checked, r_b)
    dx = c - (a + arm_v * math.cos(phi0))
    bound = abs(dx) if dx * math.sin(phi0) >= 0.0 else abs(dx) / math.cos(phi0)
    require_above(
        "valve_link_length",
        length_3,
        bound,
        "m",
        "at zero tappet lift the valve link must reach below the valve "
        "arm's end, neither horizontal nor in line with the arm",
    )
    return checked


def _triangle_factors(
    side: float, arm: float, distance: float
) -> tuple[float, float, float, float]:
    """(L + l - R, R + l - L, R + L - l, perimeter) of the triangle link L, arm l, distance R."""
    return (
        side + arm - distance,
        distance + arm - side,
        distance + side - arm,
        distance + side + arm,
    )


def _phi_from_y1(g: "ValveGeometry", y1: float) -> float:
    """Rocker angle for a pushrod foot at height y1 (m), no checks: psi - acos(K/R)."""
    u = g.rocker_pivot_x
    w = g.rocker_pivot_y - y1
    distance = math.hypot(u, w)
    arm, side = g.tappet_arm, g.pushrod_length
    f1, f2, f3, perimeter = _triangle_factors(side, arm, distance)
    k = ((distance - side) * (distance + side) + arm * arm) / (2.0 * arm)
    s = math.sqrt(max(f1 * f2 * f3 * perimeter, 0.0)) / (2.0 * arm)
    return math.atan2(w, u) - math.atan2(s, k)


def _y3_from_phi(g: "ValveGeometry", phi: float) -> float:
    """Valve-link foot height y3 (m) for rocker angle phi, no checks."""
    dx = g.valve_axis_x - (g.rocker_pivot_x + g.valve_arm * math.cos(phi))
    length = g.valve_link_length
    return (
        g.rocker_pivot_y
        + g.valve_arm * math.sin(phi)
        - math.sqrt(max((length - dx) * (length + dx), 0.0))
    )


@lru_cache(maxsize=16)  # a function of the geometry alone (a tuple of floats)
def rest_position(g: "ValveGeometry") -> tuple[float, float]:
    """(rocker angle phi0 in rad, valve foot height y3_closed in m) at zero tappet lift."""
    phi0 = _phi_from_y1(g, g.cam_base_radius)
    return phi0, _y3_from_phi(g, phi0)


def _component(low: float, high: float, reference: float) -> tuple[float, float]:
    """The one of [low, high] and [-high, -low] that holds ``reference`` (low > 0), or
    [-high, high] when low == 0."""
    if low == 0.0:
        return -high, high
    return (low, high) if reference > 0.0 else (-high, -low)


@lru_cache(maxsize=16)  # a function of the geometry alone (a tuple of floats)
def tappet_lift_range(g: "ValveGeometry") -> tuple[float, float]:
    """Tappet lifts (m) for which the rocker assembles on the branch: [low, high].

    The pushrod foot's distance to the pivot, hypot(a, b - y1), must lie between
    |L1 - lt| (folded) and L1 + lt (stretched); the ends are dead centres.
    """
    a = g.rocker_pivot_x
    arm, side = g.tappet_arm, g.pushrod_length
    reach = side + arm
    w_high = math.sqrt((reach - a) * (reach + a))
    short = abs(side - arm)
    w_low = math.sqrt((short - a) * (short + a)) if short > a else 0.0
    w_min, w_max = _component(w_low, w_high, g.rocker_pivot_y - g.cam_base_radius)
    base = g.rocker_pivot_y - g.cam_base_radius
    return base - w_max, base - w_min


def _angle_interval(cos_low: float, cos_high: float, reference: float) -> tuple[float, float]:
    """Angles around ``reference`` (|reference| < pi/2) with cos_low <= cos <= cos_high."""
    if cos_low <= -1.0 and cos_high >= 1.0:
        return -math.inf, math.inf
    if cos_high >= 1.0:
        half = math.acos(cos_low)
        return -half, half
    near = math.acos(max(cos_high, -1.0))
    far = math.acos(cos_low) if cos_low > -1.0 else 2.0 * math.pi - near
    return (near, far) if reference >= 0.0 else (-far, -near)


@lru_cache(maxsize=16)  # a function of the geometry alone (a tuple of floats)
def rocker_angle_range(g: "ValveGeometry") -> tuple[float, float]:
    """Rocker angles (rad) that valve_from_rocker accepts: |c - V_x| <= L3, around rest."""
    u = g.valve_axis_x - g.rocker_pivot_x
    length, arm = g.valve_link_length, g.valve_arm
    return _angle_interval((u - length) / arm, (u + length) / arm, rest_position(g)[0])


@lru_cache(maxsize=16)  # a function of the geometry alone (a tuple of floats)
def tappet_rocker_angle_range(g: "ValveGeometry") -> tuple[float, float]:
    """Rocker angles (rad) that tappet_from_rocker accepts: |T_x| <= L1, around rest."""
    a, arm, length = g.rocker_pivot_x, g.tappet_arm, g.pushrod_length
    return _angle_interval((a - length) / arm, (a + length) / arm, rest_position(g)[0])


@lru_cache(maxsize=16)  # a function of the geometry alone (a tuple of floats)
def valve_position_range(g: "ValveGeometry") -> tuple[float, float]:
    """Valve foot heights y3 (m) that rocker_from_valve accepts: [low, high].

    The foot's distance to the pivot, hypot(c - a, y3 - b), must lie between |L3 - lv| and
    L3 + lv; the ends are the configurations with the valve link in line with the valve arm.
    """
    u = g.valve_axis_x - g.rocker_pivot_x
    arm, length = g.valve_arm, g.valve_link_length
    reach = length + arm
    w_high = math.sqrt((reach - u) * (reach + u))
    short = abs(length - arm)
    w_low = math.sqrt((short - u) * (short + u)) if short > u else 0.0
    w_min, w_max = _component(w_low, w_high, rest_position(g)[1] - g.rocker_pivot_y)
    return g.rocker_pivot_y + w_min, g.rocker_pivot_y + w_max


@lru_cache(maxsize=16)  # a function of the geometry alone (a tuple of floats)
def valve_lift_range(g: "ValveGeometry") -> tuple[float, float]:
    """Valve lifts (m) that inverse accepts on the valve side: y3_closed - valve_position_range."""
    low, high = valve_position_range(g)
    closed = rest_position(g)[1]
    return closed - high, closed - low


def working_range(g: "ValveGeometry") -> "WorkingRange":
    """Tappet and valve lifts (m) between the nearest dead centres of the whole chain.

    forward maps [tappet_low, tappet_high] monotonically onto [valve_low, valve_high] and
    inverse maps it back; past the ends one of the four maps has a dead centre (e.g. the
    valve link comes in line with the valve arm, where the valve lift peaks and the inverse
    switches branch). The ends are where a triangle is degenerate or a link is horizontal:

        tappet side   tappet_lift_range (pushrod in line with the tappet arm), and
                      cos(phi) = (a -+ L1) / lt (pushrod horizontal);
        valve side    cos(phi) = u / (lv + L3) with sin(phi) < 0, cos(phi) = u / (lv - L3)
                      with sin(phi) > 0 (valve link in line with the arm, link below V),
                      and cos(phi) = (u -+ L3) / lv (valve link horizontal), u = c - a.

    Returns WorkingRange (tappet_low, tappet_high, valve_low, valve_high); for the defaults
    about (-22.5 mm, 29.2 mm) of tappet lift.
    """
    low, high = tappet_lift_range(g)
    a, arm_t, length_1 = g.rocker_pivot_x, g.tappet_arm, g.pushrod_length
    u, arm_v, length_3 = g.valve_axis_x - g.rocker_pivot_x, g.valve_arm, g.valve_link_length
    candidates = [(-1.0, u / (arm_v + length_3))]
    if arm_v != length_3:
        candidates.append((1.0, u / (arm_v - length_3)))
    for cosine in (
        (a - length_1) / arm_t,
        (a + length_1) / arm_t,
        (u - length_3) / arm_v,
        (u + length_3) / arm_v,
    ):
        candidates += [(-1.0, cosine), (1.0, cosine)]
    for sign, cosine in candidates:
        if not -1.0 < cosine < 1.0:
            continue
        phi = sign * math.acos(cosine)
        tx = a - arm_t * math.cos(phi)
        if abs(tx) > length_1:
            continue
        lift = (
            g.rocker_pivot_y
            - arm_t * math.sin(phi)
            - math.sqrt((length_1 - tx) * (length_1 + tx))
            - g.cam_base_radius
        )
        # only a point the tappet side reaches on its own branch bounds the range
        if not low < lift < high or abs(_phi_from_y1(g, g.cam_base_radius + lift) - phi) > 1e-9:
            continue
        if lift > 0.0:
            high = min(high, lift)
        elif lift < 0.0:
            low = max(low, lift)
    y3_closed = rest_position(g)[1]
    return WorkingRange(
        low,
        high,
        y3_closed - _y3_from_phi(g, _phi_from_y1(g, g.cam_base_radius + low)),
        y3_closed - _y3_from_phi(g, _phi_from_y1(g, g.cam_base_radius + high)),
    )


# --- positions ------------------------------------------------------------------------------


def _singular_tolerance(perimeter: float) -> float:
    return SINGULAR_ULPS * _EPS * perimeter


def _require_inside(
    name: str, value: float, interval: tuple[float, float], unit: str, scale: float, why: str
) -> float:
    """``value`` as float; RangeError unless it is finite and inside ``interval`` (low, high),
    give or take a few rounding units of ``scale``.

    A value that misses an end only by rounding (e.g. y3_closed - valve_lift at the end of
    valve_lift_range) is at that end: the dead-centre test that follows reports it as such.
    """
    value = require_finite(name, value, unit)
    low, high = interval
    slack = 2 * SINGULAR_ULPS * _EPS * scale
    if not low - slack <= value <= high + slack:
        raise RangeError(name, value, f"[{low!r}, {high!r}]", unit, why)
    return value


def rocker_from_tappet(g: "ValveGeometry", tappet_lift: float) -> float:
    """Rocker angle phi (rad) for a tappet lift (m): phi = psi - acos(K/R).

    RangeError outside tappet_lift_range(g); SingularConfiguration where the pushrod and the
    tappet arm are collinear (its ends).
    """
    lift = _require_inside(
        "tappet_lift",
        tappet_lift,
        tappet_lift_range(g),
        "m",
        g.rocker_pivot_y + g.pushrod_length + g.tappet_arm,
        "the pushrod cannot reach the rocker's tappet arm",
    )
    y1 = g.cam_base_radius + lift
    distance = math.hypot(g.rocker_pivot_x, g.rocker_pivot_y - y1)
    stretched, folded_a, folded_b, perimeter = _triangle_factors(
        g.pushrod_length, g.tappet_arm, distance
    )
    tolerance = _singular_tolerance(perimeter)
    if min(stretched, folded_a, folded_b) <= tolerance:
        kind = (
            "stretched out: pivot distance = pushrod_length + tappet_arm"
            if stretched <= tolerance
            else "folded: pivot distance = |pushrod_length - tappet_arm|"
        )
        raise SingularConfiguration(
            f"tappet_lift = {lift!r} m puts the pushrod and the tappet arm in line ({kind}): "
            "dead centre, the rocker's angular rate is undefined"
        )
    return _phi_from_y1(g, y1)


def _rocker_angle(rocker_angle: float, interval: tuple[float, float], why: str) -> float:
    """``rocker_angle`` (rad) as float; RangeError (with ``why``) outside ``interval``."""
    return require_between("rocker_angle", rocker_angle, *interval, "rad", why=why)


def valve_from_rocker(g: "ValveGeometry", rocker_angle: float) -> float:
    """Valve-link foot height y3 (m) for a rocker angle (rad): V_y - sqrt(L3^2 - (c - V_x)^2).

    RangeError outside rocker_angle_range(g); SingularConfiguration where the valve link is
    perpendicular to the valve axis.
    """
    phi = _rocker_angle(
        rocker_angle, rocker_angle_range(g), "the valve link cannot reach the valve axis"
    )
    dx = g.valve_axis_x - (g.rocker_pivot_x + g.valve_arm * math.cos(phi))
    length = g.valve_link_length
    if min(length - dx, length + dx) <= _singular_tolerance(length):
        raise SingularConfiguration(
            f"rocker_angle = {phi!r} rad turns the valve link perpendicular to the valve axis "
            "(horizontal): the valve's rate is undefined"
        )
    return _y3_from_phi(g, phi)


def rocker_from_valve(g: "ValveGeometry", valve_position: float) -> float:
    """Rocker angle phi (rad) for a valve-link foot height y3 (m): phi = psi' + acos(K'/R').

    RangeError outside valve_position_range(g); SingularConfiguration where the valve link
    and the valve arm are collinear (its ends).
    """
    y3 = _require_inside(
        "valve_position",
        valve_position,
        valve_position_range(g),
        "m",
        abs(g.rocker_pivot_y) + g.valve_link_length + g.valve_arm,
        "the valve link cannot reach the rocker's valve arm",
    )
    u = g.valve_axis_x - g.rocker_pivot_x
    w = y3 - g.rocker_pivot_y
    distance = math.hypot(u, w)
    arm, side = g.valve_arm, g.valve_link_length
    f1, f2, f3, perimeter = _triangle_factors(side, arm, distance)
    tolerance = _singular_tolerance(perimeter)
    if min(f1, f2, f3) <= tolerance:
        kind = "stretched out" if f1 <= tolerance else "folded"
        raise SingularConfiguration(
            f"valve_position = {y3!r} m puts the valve link and the valve arm in line "
            f"({kind}): dead centre, the rocker's angular rate is undefined"
        )
    k = ((distance - side) * (distance + side) + arm * arm) / (2.0 * arm)
    s = math.sqrt(f1 * f2 * f3 * perimeter) / (2.0 * arm)
    return math.atan2(w, u) + math.atan2(s, k)


def tappet_from_rocker(g: "ValveGeometry", rocker_angle: float) -> float:
    """Pushrod foot height y1 (m; tappet lift = y1 - cam_base_radius) for a rocker angle (rad).

    y1 = T_y - sqrt(L1^2 - T_x^2). RangeError outside tappet_rocker_angle_range(g);
    SingularConfiguration where the pushrod is perpendicular to the tappet axis.
    """
    phi = _rocker_angle(
        rocker_angle, tappet_rocker_angle_range(g), "the pushrod cannot reach the tappet axis"
    )
    tx = g.rocker_pivot_x - g.tappet_arm * math.cos(phi)
    length = g.pushrod_length
    if min(length - tx, length + tx) <= _singular_tolerance(length):
        raise SingularConfiguration(
            f"rocker_angle = {phi!r} rad turns the pushrod perpendicular to the tappet axis "
            "(horizontal): the tappet's rate is undefined"
        )
    return (
        g.rocker_pivot_y - g.tappet_arm * math.sin(phi) - math.sqrt((length - tx) * (length + tx))
    )


# --- rates ------------------------------------------------------------------------------------


def _tappet_vectors(g: "ValveGeometry", phi: float, y1: float) -> tuple[Vector, Vector, Vector]:
    """e = T - P, t1 = dT/dphi, t2 = d2T/dphi2 (m)."""
    cos_phi, sin_phi = math.cos(phi), math.sin(phi)
    arm = g.tappet_arm
    e = (g.rocker_pivot_x - arm * cos_phi, g.rocker_pivot_y - arm * sin_phi - y1)
    return e, (arm * sin_phi, -arm * cos_phi), (arm * cos_phi, arm * sin_phi)


def _valve_vectors(g: "ValveGeometry", phi: float, y3: float) -> tuple[Vector, Vector, Vector]:
    """g = V - Q, v1 = dV/dphi, v2 = d2V/dphi2 (m)."""
    cos_phi, sin_phi = math.cos(phi), math.sin(phi)
    arm = g.valve_arm
    link = (
        g.rocker_pivot_x + arm * cos_phi - g.valve_axis_x,
        g.rocker_pivot_y + arm * sin_phi - y3,
    )
    return link, (-arm * sin_phi, arm * cos_phi), (-arm * cos_phi, -arm * sin_phi)


def _dot(p: Vector, q: Vector) -> float:
    return p[0] * q[0] + p[1] * q[1]


def _rocker_rates(
    link: Vector,
    t1: Vector,
    t2: Vector,
    slider_rate: float,
    slider_accel: float,
    singular: Callable[[], str],
) -> Vector:
    """Rocker rates (rad/s, rad/s^2) from the rates of a link end sliding vertically.

    The link vector e = (rocker end) - (slider end) has constant length, with the rocker end
    moving as phi' t1 and phi'' t1 + phi'^2 t2. Differentiating |e|^2 once and twice:
    phi' (e.t1) = e_y y',  phi'' (e.t1) = e_y y'' - phi'^2 (e.t2) - |phi' t1 - (0, y')|^2.
    ``singular``: makes the message when e.t1 = 0 (link and rocker arm in line).
    """
    e_t1 = _dot(link, t1)
    if e_t1 == 0.0:
        raise SingularConfiguration(singular())
    omega = link[1] * slider_rate / e_t1
    rel = (omega * t1[0], omega * t1[1] - slider_rate)
    return omega, (link[1] * slider_accel - omega * omega * _dot(link, t2) - _dot(rel, rel)) / e_t1


def _slider_rates(
    link: Vector,
    t1: Vector,
    t2: Vector,
    omega: float,
    alpha: float,
    singular: Callable[[], str],
) -> Vector:
    """Rates (m/s, m/s^2) of a vertically sliding link end driven by the rocker: the same
    two equations solved for y' and y''. ``singular``: makes the message when e_y = 0."""
    if link[1] == 0.0:
        raise SingularConfiguration(singular())
    rate = omega * _dot(link, t1) / link[1]
    rel = (omega * t1[0], omega * t1[1] - rate)
    return rate, (alpha * _dot(link, t1) + omega * omega * _dot(link, t2) + _dot(rel, rel)) / link[
        1
    ]


def _chain_rates(
    driving: tuple[Any, Any, Any],
    driven: tuple[Any, Any, Any],
    rate: float,
    acceleration: float,
    driving_singular: Callable[[], str],
    driven_singular: Callable[[], str],
) -> tuple[float, float, float, float]:
    """Through the rocker: its (omega, alpha) from the driving slider's ``rate`` and
    ``acceleration`` (vectors ``driving``), then the driven slider's (rate, acceleration)
    (vectors ``driven``); the messages, made only when needed, name each singular
    position."""
    omega, alpha = _rocker_rates(*driving, rate, acceleration, driving_singular)
    driven_rate, driven_acceleration = _slider_rates(*driven, omega, alpha, driven_singular)
    return omega, alpha, driven_rate, driven_acceleration


@lru_cache(maxsize=16)  # a function of the geometry alone (a tuple of floats)
def _forward_bounds(g: "ValveGeometry") -> tuple[float, float, float, float, float]:
    """What motion_from_tappet checks its input against, worked out once per geometry:
    (lowest, highest tappet lift in m as rocker_from_tappet accepts it, with its rounding
    slack; lowest, highest rocker angle in rad as valve_from_rocker accepts it; the
    valve link's dead-centre tolerance in m)."""
    low, high = tappet_lift_range(g)
    slack = 2 * SINGULAR_ULPS * _EPS * (g.rocker_pivot_y + g.pushrod_length + g.tappet_arm)
    angle_low, angle_high = rocker_angle_range(g)
    return (
        low - slack,
        high + slack,
        angle_low,
        angle_high,
        _singular_tolerance(g.valve_link_length),
    )


def motion_from_tappet(
    g: "ValveGeometry", y3_closed: float, lift: float, velocity: float, acceleration: float
) -> "ValveTrainMotion":
    """``forward`` without the input checks, for callers that checked the drive and hold
    ``y3_closed`` (m, rest_position(g)[1]): float_speed, ValveTrain and ValveSpring's
    camshaft drive call it many times (several times per step).

    The same arithmetic as rocker_from_tappet, valve_from_rocker, _tappet_vectors,
    _valve_vectors and _chain_rates (the results agree to the bit), written out in one
    function with cos(phi) and sin(phi) evaluated once: the range and dead-centre tests are
    comparisons against _forward_bounds, and a tappet lift that fails one goes to
    _refuse_forward, which raises the error those functions raise."""
    a, b, arm_t, side_1 = g.rocker_pivot_x, g.rocker_pivot_y, g.tappet_arm, g.pushrod_length
    arm_v, c, side_3 = g.valve_arm, g.valve_axis_x, g.valve_link_length
    lift_low, lift_high, angle_low, angle_high, link_tolerance = _forward_bounds(g)
    if not lift_low <= lift <= lift_high:  # also NaN
        _refuse_forward(g, lift)
    # tappet side: phi from the pushrod foot at y1 (rocker_from_tappet, _phi_from_y1)
    y1 = g.cam_base_radius + lift
    w = b - y1
    distance = math.hypot(a, w)
    f1, f2, f3, perimeter = _triangle_factors(side_1, arm_t, distance)
    tolerance = _singular_tolerance(perimeter)
    if f1 <= tolerance or f2 <= tolerance or f3 <= tolerance:  # min() <= without a call
        _refuse_forward(g, lift)
    k = ((distance - side_1) * (distance + side_1) + arm_t * arm_t) / (2.0 * arm_t)
    square = f1 * f2 * f3 * perimeter
    if square < 0.0:  # max(square, 0.0)
        square = 0.0
    phi = math.atan2(w, a) - math.atan2(math.sqrt(square) / (2.0 * arm_t), k)
    if not angle_low <= phi <= angle_high:
        _refuse_forward(g, lift)
    cos_phi, sin_phi = math.cos(phi), math.sin(phi)
    # valve side: the link foot y3 (valve_from_rocker, _y3_from_phi)
    dx = c - (a + arm_v * cos_phi)
    if side_3 - dx <= link_tolerance or side_3 + dx <= link_tolerance:
        _refuse_forward(g, lift)
    square = (side_3 - dx) * (side_3 + dx)
    if square < 0.0:
        square = 0.0
    y3 = b + arm_v * sin_phi - math.sqrt(square)
    # rates (_chain_rates): the rocker's from the pushrod foot's, the link foot's from the
    # rocker's; e = T - P with T' = phi' t1, g = V - Q with V' = phi' v1
    e_x, e_y = a - arm_t * cos_phi, b - arm_t * sin_phi - y1
    t1_x, t1_y = arm_t * sin_phi, -arm_t * cos_phi
    e_t1 = e_x * t1_x + e_y * t1_y
    if e_t1 == 0.0:
        raise SingularConfiguration(
            f"tappet_lift = {lift!r} m: pushrod and tappet arm in line, rates undefined"
        )
    omega = e_y * velocity / e_t1
    rel_x, rel_y = omega * t1_x, omega * t1_y - velocity
    e_t2 = e_x * (arm_t * cos_phi) + e_y * (arm_t * sin_phi)
    alpha = (e_y * acceleration - omega * omega * e_t2 - (rel_x * rel_x + rel_y * rel_y)) / e_t1
    g_x, g_y = a + arm_v * cos_phi - c, b + arm_v * sin_phi - y3
    if g_y == 0.0:
        raise SingularConfiguration(
            f"tappet_lift = {lift!r} m: valve link horizontal, valve rates undefined"
        )
    v1_x, v1_y = -arm_v * sin_phi, arm_v * cos_phi
    g_v1 = g_x * v1_x + g_y * v1_y
    y3_rate = omega * g_v1 / g_y
    rel_x, rel_y = omega * v1_x, omega * v1_y - y3_rate
    g_v2 = g_x * (-arm_v * cos_phi) + g_y * (-arm_v * sin_phi)
    y3_accel = (alpha * g_v1 + omega * omega * g_v2 + (rel_x * rel_x + rel_y * rel_y)) / g_y
    return ValveTrainMotion(
        lift, velocity, acceleration, phi, omega, alpha, y3_closed - y3, -y3_rate, -y3_accel
    )


def _refuse_forward(g: "ValveGeometry", lift: float) -> None:
    """Raise the error of rocker_from_tappet or valve_from_rocker for a tappet lift (m)
    that motion_from_tappet's comparisons refused (RangeError or SingularConfiguration)."""
    valve_from_rocker(g, rocker_from_tappet(g, lift))
    raise AssertionError(f"tappet_lift = {lift!r} m: motion_from_tappet refused what both accept")


def forward(
    g: "ValveGeometry", tappet_lift: float, tappet_velocity: float, tappet_acceleration: float
) -> "ValveTrainMotion":
    """Rocker and valve motion for a prescribed tappet motion (m, m/s, m/s^2).

    Returns ValveTrainMotion (m, m/s, m/s^2; rad, rad/s, rad/s^2; m, m/s, m/s^2). Raises the
    errors of rocker_from_tappet, then of valve_from_rocker (naming the rocker angle reached).
    """
    lift = require_finite("tappet_lift", tappet_lift, "m")
    velocity = require_finite("tappet_velocity", tappet_velocity, "m/s")
    acceleration = require_finite("tappet_acceleration", tappet_acceleration, "m/s^2")
    return motion_from_tappet(g, rest_position(g)[1], lift, velocity, acceleration)


def inverse(
    g: "ValveGeometry", valve_lift: float, valve_velocity: float, valve_acceleration: float
) -> "ValveTrainMotion":
    """Rocker and tappet motion for a prescribed valve motion (m, m/s, m/s^2).

    Returns ValveTrainMotion. Raises the errors of rocker_from_valve (naming valve_position
    = y3_closed - valve_lift), then of tappet_from_rocker.
    """
    lift = require_finite("valve_lift", valve_lift, "m")
    velocity = require_finite("valve_velocity", valve_velocity, "m/s")
    acceleration = require_finite("valve_acceleration", valve_acceleration, "m/s^2")
    y3 = rest_position(g)[1] - lift
    phi = rocker_from_valve(g, y3)
    y1 = tappet_from_rocker(g, phi)
    omega, alpha, y1_rate, y1_accel = _chain_rates(
        _valve_vectors(g, phi, y3),
        _tappet_vectors(g, phi, y1),
        -velocity,
        -acceleration,
        lambda: f"valve_lift = {lift!r} m: valve link and valve arm in line, rates undefined",
        lambda: f"valve_lift = {lift!r} m: pushrod horizontal, tappet rates undefined",
    )
    return ValveTrainMotion(
        y1 - g.cam_base_radius, y1_rate, y1_accel, phi, omega, alpha, lift, velocity, acceleration
    )


def tappet_pieces(
    g: "ValveGeometry", profile: CamProfile, mode: str = "forward"
) -> tuple["cam_geometry.Piece", ...]:
    """The tappet's displacement diagram over a camshaft revolution as cam_geometry Pieces
    (start rad, span rad, motion: phase x -> (s m, s1 m/rad, s2 m/rad^2)): the cam the
    valve train needs. forward: the cam law is the tappet lift. inverse: the cam law is the
    valve lift L(theta); the tappet's s, s1, s2 are inverse's lift, velocity and acceleration
    for the valve motion (L, L1, L2) at unit camshaft speed (time derivatives equal angle
    derivatives there)."""
    pieces = cam_geometry.law_pieces(profile)
    if mode == "forward":
        return pieces

    def through_rocker(valve: Callable) -> Callable:
        def tappet(x: float) -> tuple[float, float, float]:
            motion = inverse(g, *valve(x))
            return motion.tappet_lift, motion.tappet_velocity, motion.tappet_acceleration

        return tappet

    return tuple(
        cam_geometry.Piece(piece.start, piece.span, through_rocker(piece.motion))
        for piece in pieces
    )


def valve_lift_rate(g: "ValveGeometry", y3_closed: float, lift: float, lift_rate: float) -> float:
    """dL/dtheta (m/rad): the valve lift's rate per camshaft radian where the tappet is at
    ``lift`` (m) rising ``lift_rate`` = ds/dtheta (m/rad): the valve velocity at unit
    camshaft speed (``y3_closed``: rest_position(g)[1], m)."""
    return motion_from_tappet(g, y3_closed, lift, lift_rate, 0.0).valve_velocity


def rocker_ratio(g: "ValveGeometry", tappet_lift: float = 0.0) -> float:
    """Instantaneous ratio d(valve lift) / d(tappet lift) at ``tappet_lift`` (m)."""
    return forward(g, tappet_lift, 1.0, 0.0).valve_velocity


# --- valve spring and float -------------------------------------------------------------------


def contact_force(
    valve_mass: float,
    spring_stiffness: float,
    spring_preload: float,
    valve_lift: float,
    valve_acceleration: float,
) -> float:
    """Force (N) the rocker must push on the valve along its axis: m a + k lift + F0.

    valve_mass m (kg) lumps valve, retainer and the moving part of the spring; the spring
    (stiffness k in N/m, preload F0 in N at zero lift) closes the valve. Gravity (about
    1 N on a 0.1 kg valve, against kN of spring force) and friction are neglected. Positive:
    the rocker pushes; it cannot pull, so a negative value means the valve leaves the rocker.
    """
    m = require_positive("valve_mass", valve_mass, "kg")
    k = require_between("spring_stiffness", spring_stiffness, 0.0, math.inf, "N/m")
    preload = require_between("spring_preload", spring_preload, 0.0, math.inf, "N")
    lift = require_finite("valve_lift", valve_lift, "m")
    accel = require_finite("valve_acceleration", valve_acceleration, "m/s^2")
    return m * accel + k * lift + preload


# The contact force m a + k lift + F0 is a sum of terms of kN that cancel where the valve is
# about to float; rounding leaves ~1e-16 of their magnitudes. A force below
# -FLOAT_RTOL * (|m a| + |k lift| + F0) is lost contact; one within the band is a touching
# contact (zero force), not a float, so the classification does not hinge on the last bit.
FLOAT_RTOL = 1e-9


def contact_lost(
    valve_mass: float,
    spring_stiffness: float,
    spring_preload: float,
    valve_lift: float,
    valve_acceleration: float,
) -> bool:
    """True if the rocker would have to pull the valve (contact force below
    -FLOAT_RTOL times the terms' magnitude, N): the valve floats. Arguments as
    contact_force (kg, N/m, N, m, m/s^2)."""
    force = contact_force(
        valve_mass, spring_stiffness, spring_preload, valve_lift, valve_acceleration
    )
    scale = (
        abs(valve_mass * valve_acceleration)
        + abs(spring_stiffness * valve_lift)
        + abs(spring_preload)
    )
    return force < -FLOAT_RTOL * scale


def float_speed(
    g: "ValveGeometry",
    profile: CamProfile,
    valve_mass: float,
    spring_stiffness: float,
    spring_preload: float,
    samples: int = 720,
    valve_law: bool = False,
) -> "FloatSpeed":
    """Lowest constant camshaft speed (rad/s) at which the valve floats, and where.

    At constant speed w the valve acceleration is L'' w^2 (L'' = d2(valve lift)/dtheta2 in
    m/rad^2, from forward with the tappet motion (s, s1, s2) of cam_lift at unit speed), so
    the contact force m L'' w^2 + k L + F0 first reaches zero at

        w_float = min over angles with L'' < 0 of sqrt((k L + F0) / (m (-L''))).

    The rise and the return are sampled on closed grids of their phase (about ``samples``
    points per revolution; the ends are the segments' one-sided limits, so a maximum
    deceleration at a segment end, as the harmonic law's, is found), and every sampled local
    minimum is refined by golden section. Returns FloatSpeed(w in rad/s, camshaft angle in
    rad within [rise_start, rise_start + 2 pi]); (inf, nan) if L'' is never negative.

    valve_law=True: the cam law prescribes the valve lift itself (the inverse drive), so
    L = s and L'' = s2 and the rocker geometry plays no part.
    """
    g = check_geometry(g)
    profile = cam_laws.check_profile(*profile)
    m = require_positive("valve_mass", valve_mass, "kg")
    k = require_between("spring_stiffness", spring_stiffness, 0.0, math.inf, "N/m")
    preload = require_between("spring_preload", spring_preload, 0.0, math.inf, "N")
    if not isinstance(samples, int) or samples < 8:
        raise RangeError("samples", samples, "[8, inf)", "", "an integer")
    y3_closed = rest_position(g)[1]

    def ratio(segment: Any, x: Any):
        """w^2 at which the contact force vanishes at phase x, inf where L'' >= 0."""
        s, s1, s2, _ = cam_laws.segment_lift(profile, segment, x)
        if valve_law:
            lift, accel = s, s2
        else:
            motion = motion_from_tappet(g, y3_closed, s, s1, s2)
            lift, accel = motion.valve_lift, motion.valve_acceleration
        if accel >= 0.0:
            return math.inf
        return max(k * lift + preload, 0.0) / (m * -accel)

    best = (math.inf, math.nan)
    starts = {"rise": 0.0, "return": profile.rise_angle + profile.high_dwell_angle}
    for segment, beta in (("rise", profile.rise_angle), ("return", profile.return_angle)):
        count = max(8, math.ceil(samples * beta / cam_laws.TAU))
        grid = [i / count for i in range(count + 1)]
        value, x = refined_minimum(
            lambda x: ratio(segment, x), grid, [ratio(segment, x) for x in grid]
        )
        if value < best[0]:
            best = (value, profile.rise_start + starts[segment] + x * beta)
    if best[0] == math.inf:
        return FloatSpeed(math.inf, math.nan)
    return FloatSpeed(math.sqrt(best[0]), best[1])
