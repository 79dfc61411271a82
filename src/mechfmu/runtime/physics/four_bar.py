"""Four-bar linkage: position, velocity and acceleration (standard library only).

Geometry and names (Norton, Design of Machinery, ch. 4 and 7): the ground link runs from the
crank pivot O2 = (0, 0) to the rocker pivot O4 = (d, 0). The crank O2 -> A has length a, the
coupler A -> B length b, the rocker O4 -> B length c, the ground length d. Angles are measured
counter-clockwise from +x (the ground link direction O2 -> O4):

    theta2 = angle of O2 -> A (crank_angle), theta3 = angle of A -> B (coupler_angle),
    theta4 = angle of O4 -> B (rocker_angle),

and the loop closes: a e^(i theta2) + b e^(i theta3) - c e^(i theta4) - d = 0.

Circuits (Norton's open and crossed, the minus and plus signs of his eqs 4.10 and 4.13): for a
crank angle the rocker pin B sits at one of two points mirrored about the diagonal A -> O4.

    circuit 0, open:    sin(theta4 - theta3) > 0, i.e. B lies to the LEFT of the directed
                        diagonal A -> O4 (cross(B - A, B - O4) = b c sin(theta4 - theta3) > 0);
    circuit 1, crossed: sin(theta4 - theta3) < 0, B to the right of A -> O4.

Why these agree with the signs: the half-angle quadratic P(x) = A x^2 + B x + C in
x = tan(theta4/2) equals (1 + x^2) G(theta4) with G = (|B - A|^2 - b^2)/(2ac); at a root
P'(x) = 2 G'(theta4) = 2 (b/a) sin(theta3 - theta4), and P' = -sqrt(B^2 - 4AC) < 0 at
Norton's minus root. The coupler equation gives the same sign rule.

Relation to "the loop does not cross itself": while the crank pin is above the ground line
(sin theta2 > 0) the open loop O2-A-B-O4 never crosses itself, for any link lengths: O2 lies
strictly right of the line A -> O4 (cross(O4 - A, O2 - A) = -d a sin(theta2) < 0), so the
ground link lies on the right and B strictly on the left, and neither AB meets O2 O4 nor
O2 A meets B O4. The crossed loop may or may not cross itself there (the coursework example's
does for 0 < theta2 < ~70 deg), and below the ground line the roles swap by mirror symmetry.
So the sign rule, not self-crossing, is the definition that holds for every crank angle. The
two circuits meet only at the toggle positions, where coupler and rocker are collinear
(sin(theta4 - theta3) = 0).

All lengths in m, angles in rad, time in s.
"""

import math
import sys
from collections import namedtuple

from ..errors import RangeError, SingularConfiguration, require_finite, require_positive
from .crank import check_circuit, crank_drive
from collections.abc import Callable
from typing import Any

INCH = 0.0254  # m, exact by definition

# Coursework example: a, b, c, d = 2, 7, 9, 6 in, crank at 30 deg (a Grashof crank-rocker).
FourBar = namedtuple("FourBar", "ground crank coupler rocker")
COURSEWORK_FOUR_BAR = FourBar(6.0 * INCH, 2.0 * INCH, 7.0 * INCH, 9.0 * INCH)
COURSEWORK_CRANK_ANGLE = math.radians(30.0)

OPEN, CROSSED = 0, 1
CIRCUITS = (OPEN, CROSSED)

# Distances from the crank pin to the rocker pivot this close (in units of eps * (b + c)) to
# b + c or |b - c| are toggle positions: the input cannot tell which side it is on.
TOGGLE_ULPS = 8

# S + L and P + Q this close (relative to L, the longest link) make a change-point linkage:
# the one tolerance of every decision "on the Grashof boundary" (grashof_class,
# change_point_angles, singular_crossing), scaled to the link lengths; never an exact
# comparison, so lengths like 5 and 2 inches, inexact in binary, still count.
CHANGE_POINT_TOLERANCE = 1e-12

# Names of the singular positions of a crank-driven four-bar (error messages).
TOGGLE = "toggle position: coupler and rocker collinear"
CHANGE_POINT = "change point: all four links collinear"

GrashofClass = namedtuple("GrashofClass", "code name description")
GRASHOF_CLASSES = (
    GrashofClass(
        1,
        "crank-rocker",
        "Grashof (S + L < P + Q), shortest link is the crank: the crank turns fully, "
        "the rocker oscillates",
    ),
    GrashofClass(
        2,
        "double-crank",
        "Grashof, shortest link is the ground (drag link): crank and rocker both turn fully",
    ),
    GrashofClass(
        3,
        "double-rocker",
        "Grashof, shortest link is the coupler: crank and rocker both oscillate, "
        "the coupler turns fully",
    ),
    GrashofClass(
        4,
        "rocker-crank",
        "Grashof, shortest link is the rocker (output): the rocker turns fully, the "
        "crank oscillates",
    ),
    GrashofClass(
        5, "triple-rocker", "non-Grashof (S + L > P + Q): no link turns fully relative to another"
    ),
    GrashofClass(
        6,
        "change-point",
        "S + L = P + Q (parallelogram, antiparallelogram, deltoid): the linkage can "
        "pass through a flat position and switch circuits",
    ),
)

Position = namedtuple("Position", "coupler_angle rocker_angle")
FourBarMotion = namedtuple(
    "FourBarMotion",
    "coupler_angle rocker_angle coupler_angular_velocity rocker_angular_velocity "
    "coupler_angular_acceleration rocker_angular_acceleration transmission_angle",
)

_LINK_NAMES = ("ground", "crank", "coupler", "rocker")


def check_four_bar(ground: float, crank: float, coupler: float, rocker: float) -> "FourBar":
    """Validate the link lengths (m) and return them as a FourBar of floats.

    Each must be finite and > 0, and the longest must be shorter than the sum of the other
    three, or the links cannot close a loop (RangeError naming the offending link).
    """
    lengths = [
        require_positive(name, value, "m")
        for name, value in zip(_LINK_NAMES, (ground, crank, coupler, rocker))
    ]
    longest = max(range(4), key=lambda i: lengths[i])
    others = sum(lengths) - lengths[longest]
    if lengths[longest] >= others:
        raise RangeError(
            _LINK_NAMES[longest],
            lengths[longest],
            f"(0, {others!r})",
            "m",
            "the links cannot close a loop: the longest link must be shorter "
            "than the sum of the other three",
        )
    return FourBar(*lengths)


def grashof_class(ground: float, crank: float, coupler: float, rocker: float) -> int:
    """Grashof class code (see GRASHOF_CLASSES) of a four-bar with the given lengths (m).

    With S, L the shortest and longest lengths and P, Q the other two: S + L = P + Q within
    CHANGE_POINT_TOLERANCE * L is a change point (6; decided by change_point_angles, so the
    class and the solvers' change points always agree), S + L > P + Q a triple-rocker (5), and
    otherwise (Grashof) the shortest link names the class: crank 1, ground 2, coupler 3,
    rocker 4.

    Ties for the shortest link need no rule: if the two shortest differ by delta, then
    (P + Q) - (S + L) <= delta - (L - Q) <= delta, so a Grashof linkage beyond the change-point
    tolerance has a shortest link shorter than every other by more than 1e-12 L. Ties only
    happen in classes 5 and 6, which do not depend on which link is shortest. (Were a tie to
    slip through rounding, the first of ground, crank, coupler, rocker would be taken.)
    """
    lengths = check_four_bar(ground, crank, coupler, rocker)
    ordered = sorted(lengths)
    shortest, longest = ordered[0], ordered[3]
    excess = (shortest + longest) - (ordered[1] + ordered[2])
    if change_point_angles(*lengths):  # |excess| <= CHANGE_POINT_TOLERANCE * longest
        return 6
    if excess > 0.0:
        return 5
    index = lengths.index(shortest)  # order of FourBar: ground, crank, coupler, rocker
    return (2, 1, 3, 4)[index]


def _as_lengths(linkage: tuple, count: int) -> tuple[float, float, float, float]:
    """Accept either ``count`` lengths or one sequence of them (e.g. COURSEWORK_FOUR_BAR)."""
    if len(linkage) == 1:
        linkage = tuple(linkage[0])
    if len(linkage) != count:
        raise TypeError(
            f"expected {count} lengths or one sequence of {count}, got {len(linkage)} arguments"
        )
    return linkage


def crank_angle_range(*linkage: Any) -> tuple[float, float] | None:
    """Interval (low, high) of cos(crank_angle) in which the linkage assembles, or None.

    Call as crank_angle_range(ground, crank, coupler, rocker) or crank_angle_range(linkage)
    with a (ground, crank, coupler, rocker) sequence such as COURSEWORK_FOUR_BAR.

    The crank pin A is at distance f from the rocker pivot O4, f^2 = a^2 + d^2 - 2 a d
    cos(theta2); the triangle A-B-O4 closes when |b - c| <= f <= b + c, so

        (a^2 + d^2 - (b + c)^2) / (2ad) <= cos(theta2) <= (a^2 + d^2 - (b - c)^2) / (2ad),

    clipped to [-1, 1]. None means every crank angle assembles (the crank turns fully).
    The crank angles are theta2 in +-[acos(high), acos(low)] (mod 2 pi).
    """
    d, a, b, c = check_four_bar(*_as_lengths(linkage, 4))
    two_ad = 2.0 * a * d
    low = (a * a + d * d - (b + c) ** 2) / two_ad
    high = (a * a + d * d - (b - c) ** 2) / two_ad
    if low <= -1.0 and high >= 1.0:
        return None
    return max(low, -1.0), min(high, 1.0)


def _toggles(d: float, a: float, b: float, c: float) -> list[Any]:
    """(crank angle in [0, pi], kind) of the singular positions with the crank pin above the
    ground line (their mirror images -angle are singular too).

    The toggles (coupler and rocker collinear) put the crank pin at f = |A - O4| = b + c or
    |b - c| from the rocker pivot, i.e. cos(theta2) = (a^2 + d^2 - f^2) / (2ad). One of them
    at theta2 = 0 (f = |d - a|) or pi (f = d + a) has the crank on the ground line as well:
    all four links collinear, a change point. That happens exactly when |d - a| = |b - c| or
    d + a = b + c, decided within CHANGE_POINT_TOLERANCE times the longest link (and then
    S + L = P + Q: the smallest of the three pairings' differences is the Grashof excess).
    """
    tolerance = CHANGE_POINT_TOLERANCE * max(d, a, b, c)
    found = []
    for reach, flat, centre in ((abs(b - c), abs(d - a), 0.0), (b + c, d + a, math.pi)):
        if abs(flat - reach) <= tolerance:
            found.append((centre, CHANGE_POINT))
            continue
        cosine = (a * a + d * d - reach * reach) / (2.0 * a * d)
        if -1.0 <= cosine <= 1.0:
            found.append((math.acos(cosine), TOGGLE))
    return found


def singular_position_kind(
    ground: float, crank: float, coupler: float, rocker: float, crank_angle: float
) -> str:
    """TOGGLE or CHANGE_POINT: the kind of singular position nearest to ``crank_angle`` (rad);
    TOGGLE if the crank has no singular position at all (see _toggles)."""
    nearest = None
    for angle, kind in _toggles(ground, crank, coupler, rocker):
        distance = min(
            abs(math.remainder(crank_angle - angle, 2.0 * math.pi)),
            abs(math.remainder(crank_angle + angle, 2.0 * math.pi)),
        )
        if nearest is None or distance < nearest[0]:
            nearest = (distance, kind)
    return CHANGE_POINT if nearest is not None and nearest[1] == CHANGE_POINT else TOGGLE


def change_point_angles(ground: float, crank: float, coupler: float, rocker: float) -> list[Any]:
    """Crank angles (rad, 0 and/or pi) of the change points: toggle positions with the crank
    on the ground line, all four links collinear, where two assembly branches cross. Empty
    unless S + L = P + Q (within CHANGE_POINT_TOLERANCE times the longest link)."""
    return sorted(
        angle for angle, kind in _toggles(ground, crank, coupler, rocker) if kind == CHANGE_POINT
    )


BRANCHES_CROSS = "there two assembly branches cross and the motion may continue on either"


def singular_crossing(
    ground: Any, crank: Any, coupler: Any, rocker: Any, start_angle: Any, end_angle: Any
) -> Any:
    """The first singular position the crank passes on its way from ``start_angle`` to
    ``end_angle`` (rad, not wrapped: the drive turns through every angle in between), as
    (position, consequence) texts, or None.

    Passed are: a change point reached or passed (0 or pi plus whole turns in the closed
    interval), where two assembly branches cross so that two samples either side cannot
    tell on which the linkage went on; and a toggle gap crossed, a range of crank angles
    around 0 or pi where the linkage does not assemble, lying between two angles that both
    assemble (a drive ending inside the gap is not a crossing: the end itself does not
    assemble, which the closed form and the solver each report). Both solvers of the
    four-bar ask this before they solve (planar.crossing_error), so they refuse the same
    drive changes with the same message.
    """
    return singular_crossings(ground, crank, coupler, rocker)(start_angle, end_angle)


def singular_crossings(
    ground: float, crank: float, coupler: float, rocker: float
) -> "Callable[[float, float], tuple[str, str] | None]":
    """singular_crossing for one linkage (lengths in m, validated here once): a function of
    (start_angle, end_angle) in rad, with what depends on the lengths alone worked out once
    (it runs at every communication step)."""
    d, a, b, c = lengths = check_four_bar(ground, crank, coupler, rocker)
    points = change_point_angles(d, a, b, c)
    interval = crank_angle_range(d, a, b, c)
    gaps = []  # (centre, half width): cos(theta2) > cos_high around 0, < cos_low around pi
    if interval is not None:
        cos_low, cos_high = interval
        gaps = [
            (centre, half)
            for centre, half, exists in (
                (0.0, math.acos(cos_high), cos_high < 1.0),
                (math.pi, math.pi - math.acos(cos_low), cos_low > -1.0),
            )
            if exists and centre not in points
        ]
    if not points and not gaps:

        def never(start_angle: float, end_angle: float) -> None:
            return None

        # nothing to pass: callers may skip the check (a marker attribute mypy cannot see)
        never.never = True  # type: ignore[attr-defined]
        return never
    turn = 2.0 * math.pi

    def crossing(start_angle: float, end_angle: float) -> tuple[str, str] | None:
        rising = end_angle >= start_angle
        low, high = (start_angle, end_angle) if rising else (end_angle, start_angle)
        passed = []  # (distance from the start along the drive, position, consequence)
        for centre in points:
            first = centre + turn * math.ceil((low - centre) / turn)
            last = centre + turn * math.floor((high - centre) / turn)
            if first <= high:
                angle = first if rising else last
                passed.append(
                    (
                        abs(angle - start_angle),
                        f"{CHANGE_POINT} at crank angle {angle!r} rad",
                        BRANCHES_CROSS,
                    )
                )
        if gaps and _assembles(lengths, end_angle):
            for centre, half in gaps:
                first = centre + turn * math.ceil((low - centre) / turn)
                last = centre + turn * math.floor((high - centre) / turn)
                if first <= high:
                    middle = first if rising else last
                    edge = middle - half if rising else middle + half
                    passed.append(
                        (
                            abs(edge - start_angle),
                            f"{TOGGLE} at crank angle {edge!r} rad",
                            f"the linkage does not assemble between crank angles "
                            f"{middle - half!r} and {middle + half!r} rad, so no "
                            f"motion joins the two drive values",
                        )
                    )
        if not passed:
            return None
        return min(passed)[1:]

    return crossing


def _assembles(lengths: Any, crank_angle: Any):
    """Whether the linkage assembles at ``crank_angle`` (rad), with _solve's tolerance."""
    to_high, to_low, tolerance = _reach_margins(lengths, crank_angle)
    return to_high >= -tolerance and to_low >= -tolerance


def _wrap(angle: float) -> float:
    """Angle in (-pi, pi]: atan2 results here lie in [-2 pi, 2 pi]."""
    if angle > math.pi:
        angle -= 2.0 * math.pi
    elif angle <= -math.pi:
        angle += 2.0 * math.pi
    return angle


def _half_angle_root(qa: float, qb: float, qc: float, root: float, sign: float) -> float:
    """Angle 2 atan(x) of the root x = (-qb + sign root)/(2 qa) of qa x^2 + qb x + qc = 0.

    The same root is 2 qc / (-qb - sign root); the form used is the one whose numerator adds
    two numbers of the same sign, so nothing cancels. atan2 keeps qa -> 0 (the angle -> pi)
    accurate and finite.

    At a toggle (root = 0, double root -qb/(2 qa) = -2 qc/qb) qb may be as small as its
    rounding error, together with qa or qc (qb^2 = 4 qa qc); the form divides by whichever of
    2 qa and qb pairs with the larger of qa and qc, so the angle rests on that coefficient.
    """
    if root == 0.0:
        if abs(qa) >= abs(qc):
            return _wrap(2.0 * math.atan2(-qb, 2.0 * qa))  # |x| <= 1
        return _wrap(2.0 * math.atan2(2.0 * qc, -qb))  # |x| > 1
    if sign * qb <= 0.0:
        numerator, denominator = -qb + sign * root, 2.0 * qa
    else:
        numerator, denominator = 2.0 * qc, -qb - sign * root
    return _wrap(2.0 * math.atan2(numerator, denominator))


def _difference_of_squares(x: float, y: float) -> float:
    """x^2 - y^2 as (x - y)(x + y): exact to a few ulps of the result when x is close to y."""
    return (x - y) * (x + y)


def _crank_pin_distance(a: float, d: float, crank_angle: float) -> float:
    """f = |A - O4| (m), from f^2 = (a - d)^2 + 4 a d sin^2(theta2/2): no cancellation at 0."""
    half = math.sin(0.5 * crank_angle)
    return math.sqrt((a - d) ** 2 + 4.0 * a * d * half * half)


def _reach_margins(lengths: "FourBar", crank_angle: float) -> tuple[float, float, float]:
    """(b + c - f, f - |b - c|, tolerance) in m: how far the crank pin's distance f from the
    rocker pivot lies inside the reach of coupler and rocker; within the tolerance of either
    end (TOGGLE_ULPS eps (b + c)) the linkage is at a toggle."""
    d, a, b, c = lengths
    f = _crank_pin_distance(a, d, crank_angle)
    return (b + c) - f, f - abs(b - c), TOGGLE_ULPS * sys.float_info.epsilon * (b + c)


def _solve(lengths: "FourBar", crank_angle: float, circuit: int) -> tuple[float, float, bool]:
    """(coupler_angle, rocker_angle, toggle) for validated lengths; see ``position``."""
    d, a, b, c = lengths
    t2 = crank_angle
    f = _crank_pin_distance(a, d, t2)
    high, low = b + c, abs(b - c)
    # _reach_margins, on the f worked out above
    to_high, to_low = high - f, f - low
    tolerance = TOGGLE_ULPS * sys.float_info.epsilon * high
    if to_high < -tolerance or to_low < -tolerance:
        lo, hi = crank_angle_range(d, a, b, c) or (math.nan, math.nan)
        raise RangeError(
            "crank_angle",
            t2,
            f"cos(crank_angle) in [{lo!r}, {hi!r}], i.e. crank_angle (mod 2 pi) in "
            f"+-[{math.acos(hi)!r}, {math.acos(lo)!r}]",
            "rad",
            f"no assembly: the crank pin is {f!r} m from the rocker pivot, which must lie "
            f"in [|coupler - rocker|, coupler + rocker] = [{low!r}, {high!r}] m",
        )
    if f <= tolerance:
        # only possible with coupler == rocker and crank == ground (deltoid): A sits on O4
        raise SingularConfiguration(
            f"crank pin on the rocker pivot at crank angle {t2!r} rad: coupler and rocker "
            f"angles undefined"
        )
    toggle = min(to_high, to_low) <= tolerance
    # Norton's half-angle quadratics, multiplied through by 2ac (rocker, eqs 4.8-4.10) and
    # 2ab (coupler, eqs 4.11-4.13), which moves neither root. With u = d - a cos(t2) and
    # v = -a sin(t2) (the diagonal A -> O4) they regroup as
    #   2ac A = (u - c)^2 + v^2 - b^2      = |A - (d - c, 0)|^2 - b^2   (G at theta4 = pi)
    #   2ac B = -4 a c sin(t2)
    #   2ac C = (u + c)^2 + v^2 - b^2      = |A - (d + c, 0)|^2 - b^2   (G at theta4 = 0)
    #   2ab D = c^2 - (u + b)^2 - v^2,  2ab E = -4 a b sin(t2),  2ab F = c^2 - (u - b)^2 - v^2
    # (expand K1 = d/a, ..., K5 to check), so rounding errors scale with these distances
    # rather than with the K terms (up to (c^2 + d^2)/(2ac)) that cancel in the textbook form.
    # Both discriminants become 4 H, H = (f^2 - (b - c)^2)((b + c)^2 - f^2) = 16 area(A B O4)^2,
    # taken in factored form: exact zero at the toggles, where B^2 - 4AC would cancel.
    root = 0.0 if toggle else 2.0 * math.sqrt(to_high * (high + f) * to_low * (f + low))
    sign = -1.0 if circuit == OPEN else 1.0  # Norton's minus sign is the open circuit
    a_cos, a_sin = a * math.cos(t2), a * math.sin(t2)
    v2 = a_sin * a_sin
    qa = _difference_of_squares((d - c) - a_cos, b) + v2
    qb = -4.0 * c * a_sin
    qc = _difference_of_squares((d + c) - a_cos, b) + v2
    rocker_angle = _half_angle_root(qa, qb, qc, root, sign)
    qd = -_difference_of_squares((d + b) - a_cos, c) - v2
    qe = -4.0 * b * a_sin
    qf = -_difference_of_squares((d - b) - a_cos, c) - v2
    coupler_angle = _half_angle_root(qd, qe, qf, root, sign)
    return coupler_angle, rocker_angle, toggle


def _check_circuit(circuit: float | None) -> int:
    return check_circuit(circuit, "0 = open, 1 = crossed")


def position(
    ground: float, crank: float, coupler: float, rocker: float, crank_angle: float, circuit: int
) -> "Position":
    """Coupler and rocker angles (rad, in (-pi, pi]) at a crank angle (rad).

    Freudenstein's half-angle closed form (Norton eqs 4.8-4.13, coefficients multiplied by
    2ac and 2ab and regrouped against cancellation), each root taken with atan2 in the form
    whose numerator does not cancel. Circuit 0 = open (Norton's minus sign,
    sin(theta4 - theta3) > 0), 1 = crossed. Returns Position(coupler_angle, rocker_angle).

    Raises RangeError (name crank_angle) where the linkage does not assemble. At a toggle
    position (coupler and rocker collinear, within TOGGLE_ULPS) both circuits give the same
    angles and they are returned; ``motion`` raises SingularConfiguration there. Raises
    SingularConfiguration if the crank pin lands on the rocker pivot (deltoid only).
    """
    lengths = check_four_bar(ground, crank, coupler, rocker)
    t2 = require_finite("crank_angle", crank_angle, "rad")
    coupler_angle, rocker_angle, _ = _solve(lengths, t2, _check_circuit(circuit))
    return Position(coupler_angle, rocker_angle)


def transmission_angle(coupler_angle: float, rocker_angle: float) -> float:
    """Acute angle (rad, in [0, pi/2]) between the coupler and rocker lines."""
    between = abs(_wrap(rocker_angle - coupler_angle))  # [0, pi]
    return min(between, math.pi - between)


def _rates(
    lengths: "FourBar", t2: float, t3: float, t4: float, w2: float, al2: float
) -> tuple[float, float, float, float]:
    """(omega3, omega4, alpha3, alpha4) from the differentiated loop equation.

    Velocity (Norton 6.18): omega3 = a w2 sin(t4 - t2) / (b sin(t3 - t4)),
    omega4 = a w2 sin(t2 - t3) / (c sin(t4 - t3)). Acceleration (Norton 7.12).
    """
    d, a, b, c = lengths
    w3 = a * w2 * math.sin(t4 - t2) / (b * math.sin(t3 - t4))
    w4 = a * w2 * math.sin(t2 - t3) / (c * math.sin(t4 - t3))
    cos2, sin2 = math.cos(t2), math.sin(t2)
    cos3, sin3 = math.cos(t3), math.sin(t3)
    cos4, sin4 = math.cos(t4), math.sin(t4)
    qa = c * sin4
    qb = b * sin3
    qc = a * al2 * sin2 + a * w2 * w2 * cos2 + b * w3 * w3 * cos3 - c * w4 * w4 * cos4
    qd = c * cos4
    qe = b * cos3
    qf = a * al2 * cos2 - a * w2 * w2 * sin2 - b * w3 * w3 * sin3 + c * w4 * w4 * sin4
    # A E - B D = b c sin(t3 - t4): zero only at the toggles, which the caller excluded
    det = qa * qe - qb * qd
    al3 = (qc * qd - qa * qf) / det
    al4 = (qc * qe - qb * qf) / det
    return w3, w4, al3, al4


def motion(
    ground: float,
    crank: float,
    coupler: float,
    rocker: float,
    circuit: float | None,
    crank_angle: float,
    crank_speed: float,
    crank_acceleration: float,
) -> "FourBarMotion":
    """Coupler and rocker motion for a prescribed crank motion.

    Inputs: lengths in m, circuit 0 (open) or 1 (crossed), crank angle (rad), speed (rad/s)
    and acceleration (rad/s^2). Returns FourBarMotion: angles in (-pi, pi] rad, angular
    velocities in rad/s, accelerations in rad/s^2, transmission angle in [0, pi/2] rad.

    Raises RangeError for invalid lengths, circuit, non-finite inputs or a crank angle where
    the linkage does not assemble, and SingularConfiguration at a toggle position (coupler
    and rocker collinear: the rates divide by sin(theta4 - theta3) = 0), named a change
    point when the crank lies on the ground line as well (all four links collinear).
    """
    lengths = check_four_bar(ground, crank, coupler, rocker)
    circuit = _check_circuit(circuit)
    t2, w2, al2 = crank_drive(crank_angle, crank_speed, crank_acceleration)
    return checked_motion(lengths, circuit, t2, w2, al2)


def checked_motion(
    lengths: "FourBar", circuit: int, t2: float, w2: float, al2: float
) -> "FourBarMotion":
    """``motion`` for lengths from check_four_bar (m), a circuit from CIRCUITS and finite
    crank angle (rad), speed (rad/s) and acceleration (rad/s^2): what an FMU that validated
    them once calls at every step."""
    t3, t4, toggle = _solve(lengths, t2, circuit)
    if toggle:
        raise SingularConfiguration(
            f"{singular_position_kind(*lengths, t2)} at crank angle {t2!r} rad (coupler "
            f"angle {t3!r} rad, rocker angle {t4!r} rad): angular velocities undefined"
        )
    w3, w4, al3, al4 = _rates(lengths, t2, t3, t4, w2, al2)
    return FourBarMotion(t3, t4, w3, w4, al3, al4, transmission_angle(t3, t4))
