"""The coursework's mechanisms as bodies and joints for the planar solver (stdlib only).

Each builder returns a planar.Mechanism whose constraints are assembled from the joints
(nothing is written out per mechanism), a starting guess on a chosen assembly branch, and a
``diagnose`` that names the configuration, and the singular condition if it recognises one,
in the solver's error messages. Coordinates per body: (x, y, phi) in m, m, rad.
"""

from collections.abc import Sequence
from typing import Any
import math

from .four_bar import singular_crossings, singular_position_kind
from .planar import GROUND, PHI, Y, Driver, Mechanism, PointOnLine, Revolute, translational


def _angle(q: Any, body: Any):
    return q[3 * body + PHI]


def wrap_angle(angle: Any) -> Any:
    """Angle (rad) in (-pi, pi], for any number of revolutions."""
    wrapped = math.remainder(angle, 2.0 * math.pi)
    return math.pi if wrapped <= -math.pi else wrapped


# --- four-bar -------------------------------------------------------------------------------------
# Bodies: crank (0) with its frame at O2, coupler (1) with its frame at the crank pin A,
# rocker (2) with its frame at O4; each link lies along its frame's x axis, so phi is the
# link angle of Norton's convention.


def four_bar(ground: Any, crank: Any, coupler: Any, rocker: Any) -> Any:
    a, b, c, d = crank, coupler, rocker, ground

    def diagnose(q: Any) -> str:
        t2, t3, t4 = _angle(q, 0), _angle(q, 1), _angle(q, 2)
        return (
            f"crank angle {wrap_angle(t2):.9g} rad, coupler angle {wrap_angle(t3):.9g} "
            f"rad, rocker angle {wrap_angle(t4):.9g} rad"
        )

    def singularity(q: Any):
        # With the crank driven, Phi_q loses rank only when coupler and rocker line up;
        # if the crank lines up with the ground too, all four links are collinear. Which
        # of the two is nearest follows from the crank angles of the toggles (comparing
        # sin(theta2) with sin(theta4 - theta3) at q cannot tell them apart: both vanish
        # linearly at a change point, at ratios that depend on the lengths).
        return singular_position_kind(d, a, b, c, _angle(q, 0))

    crossings = singular_crossings(d, a, b, c)

    def crossing(
        start: Sequence[tuple[float, ...]], end: Sequence[tuple[float, ...]]
    ) -> tuple[str, str] | None:
        # a change point reached or passed, or a range where the linkage does not assemble
        # jumped, between the two crank angles: the closed form asks the same
        return crossings(start[0][0], end[0][0])

    joints = [
        Revolute("crank pivot O2", 0, (0.0, 0.0), GROUND, (0.0, 0.0)),
        Revolute("crank pin A", 0, (a, 0.0), 1, (0.0, 0.0)),
        Revolute("rocker pin B", 1, (b, 0.0), 2, (c, 0.0)),
        Revolute("rocker pivot O4", 2, (0.0, 0.0), GROUND, (d, 0.0)),
        Driver("crank angle", ((0, PHI, 1.0),)),
    ]
    # A linkage without change points or gaps (a Grashof crank-rocker, a double crank)
    # refuses no drive change: no check at every step.
    return Mechanism(
        "four-bar",
        ("crank", "coupler", "rocker"),
        joints,
        (a + b + c + d) / 4.0,
        diagnose,
        singularity,
        None if getattr(crossings, "never", False) else crossing,
    )


def four_bar_guess(
    ground: Any, crank: Any, crank_angle: Any, coupler_angle: Any, rocker_angle: Any
) -> Any:
    """Coordinates for given link angles (rad); the crank pin placed exactly."""
    ax, ay = crank * math.cos(crank_angle), crank * math.sin(crank_angle)
    return [0.0, 0.0, crank_angle, ax, ay, coupler_angle, ground, 0.0, rocker_angle]


# --- slider-crank ---------------------------------------------------------------------------------
# Bodies: crank (0) at the origin, coupler (1) with its frame at the crank pin A, slider (2)
# with its frame at the slider pin B, translating along the line y = offset.


def slider_crank(crank: Any, coupler: Any, offset: Any) -> Any:
    a, b = crank, coupler

    def diagnose(q: Any) -> str:
        t2, t3 = _angle(q, 0), _angle(q, 1)
        return (
            f"crank angle {wrap_angle(t2):.9g} rad, coupler angle {wrap_angle(t3):.9g} "
            f"rad, slider position {q[6]:.9g} m"
        )

    def singularity(q: Any) -> str:
        # With the crank driven, the only rank loss: the rod perpendicular to the slider axis.
        return "limit position: coupler perpendicular to the slider axis"

    joints = [
        Revolute("crank pivot", 0, (0.0, 0.0), GROUND, (0.0, 0.0)),
        Revolute("crank pin A", 0, (a, 0.0), 1, (0.0, 0.0)),
        Revolute("slider pin B", 1, (b, 0.0), 2, (0.0, 0.0)),
        *translational("slider guide", 2, (0.0, 0.0), GROUND, (0.0, offset), (1.0, 0.0)),
        Driver("crank angle", ((0, PHI, 1.0),)),
    ]
    return Mechanism(
        "slider-crank", ("crank", "coupler", "slider"), joints, a + b, diagnose, singularity
    )


def slider_crank_guess(
    crank: Any, offset: Any, crank_angle: Any, coupler_angle: Any, slider_position: Any
) -> Any:
    ax, ay = crank * math.cos(crank_angle), crank * math.sin(crank_angle)
    return [0.0, 0.0, crank_angle, ax, ay, coupler_angle, slider_position, offset, 0.0]


# --- valve train --------------------------------------------------------------------------------
# The coursework's rocker-arm mechanism (mechanisms.md section 4, seed 002), with unequal
# rocker arms. Bodies: tappet/pushrod (0) with its frame at its foot P on the cam (x = 0),
# the pushrod along its local y axis to the top T; rocker (1) with its frame at the pivot
# (a, b), the tappet arm towards local -x and the valve arm towards +x; valve link (2) with
# its frame at the stem's foot Q (x = c), the link along local y up to V.
TAPPET, ROCKER, VALVE = 0, 1, 2


def valve_train(geometry: Any, inverse: bool = False) -> Any:
    """Driver: the tappet foot height y_P (forward) or the valve foot height y_Q (inverse)."""
    g = geometry
    lt, lv = g.tappet_arm, g.valve_arm

    def diagnose(q: Any) -> str:
        phi1, phi2, phi3 = _angle(q, TAPPET), _angle(q, ROCKER), _angle(q, VALVE)
        return (
            f"tappet height {q[1]:.9g} m, pushrod angle {phi1:.9g} rad, rocker angle "
            f"{phi2:.9g} rad, valve height {q[7]:.9g} m, valve link angle {phi3:.9g} rad"
        )

    def singularity(q: Any) -> str:
        phi1, phi2, phi3 = _angle(q, TAPPET), _angle(q, ROCKER), _angle(q, VALVE)
        # The links point along (-sin phi, cos phi), the rocker along (cos phi2, sin phi2):
        # each pair is collinear where the sine of the angle between them, cos(phi - phi2),
        # vanishes. With the tappet driven only the pushrod pair matters, and vice versa,
        # but either can be the nearer one; name the nearer.
        if abs(math.cos(phi1 - phi2)) <= abs(math.cos(phi3 - phi2)):
            return "pushrod and rocker tappet arm collinear"
        return "valve link and rocker valve arm collinear"

    joints = [
        PointOnLine("tappet guide x = 0", TAPPET, (0.0, 0.0), GROUND, (0.0, 0.0), (0.0, 1.0)),
        Revolute("rocker pivot", ROCKER, (0.0, 0.0), GROUND, (g.rocker_pivot_x, g.rocker_pivot_y)),
        Revolute("pushrod top", TAPPET, (0.0, g.pushrod_length), ROCKER, (-lt, 0.0)),
        Revolute("valve link top", VALVE, (0.0, g.valve_link_length), ROCKER, (lv, 0.0)),
        PointOnLine(
            "valve guide x = c", VALVE, (0.0, 0.0), GROUND, (g.valve_axis_x, 0.0), (0.0, 1.0)
        ),
        Driver(
            "valve height" if inverse else "tappet height",
            (((VALVE if inverse else TAPPET), Y, 1.0),),
            kind="length",
        ),
    ]
    return Mechanism(
        "valve train",
        ("tappet", "rocker", "valve"),
        joints,
        g.pushrod_length,
        diagnose,
        singularity,
    )


def valve_train_guess(geometry: Any, rocker_angle: float = 0.0) -> Any:
    """Coordinates with the rocker at ``rocker_angle`` and both links hanging from it."""
    g = geometry
    a, b = g.rocker_pivot_x, g.rocker_pivot_y
    c, s = math.cos(rocker_angle), math.sin(rocker_angle)
    top_t = (a - g.tappet_arm * c, b - g.tappet_arm * s)
    top_v = (a + g.valve_arm * c, b + g.valve_arm * s)
    rise_t = math.sqrt(max(g.pushrod_length**2 - top_t[0] ** 2, 0.0))
    rise_v = math.sqrt(max(g.valve_link_length**2 - (top_v[0] - g.valve_axis_x) ** 2, 0.0))
    # A body-frame vector (0, L) turned by phi is (-L sin phi, L cos phi).
    phi1 = math.atan2(-top_t[0], rise_t)
    phi3 = math.atan2(-(top_v[0] - g.valve_axis_x), rise_v)
    return [
        0.0,
        top_t[1] - rise_t,
        phi1,
        a,
        b,
        rocker_angle,
        g.valve_axis_x,
        top_v[1] - rise_v,
        phi3,
    ]
