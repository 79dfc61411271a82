"""Where each joint and body of a mechanism is: the points a drawing needs (standard library).

The ``geometry`` effect of every mechanism model publishes these points as outputs
(``<point>_x``, ``<point>_y``, m), so any tool can draw the mechanism from a result alone.
Each function takes the model's lengths and its computed coordinates (angles, lifts) and
returns a namedtuple of (x, y) points, in the frame its docstring names. The points follow
from the coordinates by rigid-body placement only, so they satisfy the joints' constraints
(link lengths, sliders on their lines) as well as the coordinates satisfy them.

All lengths in m, angles in rad (counter-clockwise positive).
"""

import math
from collections import namedtuple

from . import cam_geometry

Point = tuple[float, float]  # (x, y) in m

FourBarPoints = namedtuple("FourBarPoints", "crank_pivot rocker_pivot crank_pin rocker_pin")
SliderCrankPoints = namedtuple("SliderCrankPoints", "crank_pivot crank_pin slider_pin")
GearPoints = namedtuple("GearPoints", "bar_pivot piston_pivot piston_attachment wheel_axle")
SuspensionPoints = namedtuple("SuspensionPoints", "left_base right_base apex")
ValveTrainPoints = namedtuple(
    "ValveTrainPoints", "cam_centre tappet_foot rocker_fulcrum pushrod_end valve_end valve_foot"
)
ValveAxisPoints = namedtuple("ValveAxisPoints", "rocker_end valve_tip")


def _polar(origin: Point, length: float, angle: float) -> Point:
    """The point ``length`` (m) from ``origin`` in the direction ``angle`` (rad from +x)."""
    return (origin[0] + length * math.cos(angle), origin[1] + length * math.sin(angle))


def four_bar_points(
    ground: float, crank: float, rocker: float, crank_angle: float, rocker_angle: float
) -> FourBarPoints:
    """The four-bar's joints in Norton's frame: origin at the crank pivot O2, +x along the
    ground link towards the rocker pivot O4 = (d, 0). crank_pin A = O2 + a e^(i theta2),
    rocker_pin B = O4 + c e^(i theta4); the coupler A -> B has length b when theta3 and
    theta4 close the loop."""
    crank_pivot, rocker_pivot = (0.0, 0.0), (ground, 0.0)
    return FourBarPoints(
        crank_pivot,
        rocker_pivot,
        _polar(crank_pivot, crank, crank_angle),
        _polar(rocker_pivot, rocker, rocker_angle),
    )


def slider_crank_points(
    crank: float, offset: float, crank_angle: float, slider_position: float
) -> SliderCrankPoints:
    """The slider-crank's joints: origin at the crank pivot, +x along the slider's line,
    which runs at y = ``offset``; slider_pin B = (slider_position, offset)."""
    crank_pivot = (0.0, 0.0)
    return SliderCrankPoints(
        crank_pivot, _polar(crank_pivot, crank, crank_angle), (slider_position, offset)
    )


def gear_points(
    attachment_distance: float,
    pivot_height: float,
    bar_length: float,
    gear_angle: float,
    down_angle: float,
    airframe_pitch: float,
) -> GearPoints:
    """The nose gear's joints in the earth frame: origin at the bar pivot B, +x forward
    (horizontal), +y up. The bar hangs at psi = theta - theta_down + pitch from the downward
    vertical (gear_dynamics.bar_from_vertical), turning forward and up as the gear angle
    theta grows: its direction is psi - pi/2 from +x. The piston's fixed pivot lies at h from
    B, theta clockwise of the bar (the direction psi - pi/2 - theta, fixed on the airframe),
    the piston's attachment at d along the bar, the wheel axle A at bar_length."""
    bar_pivot = (0.0, 0.0)
    bar_direction = gear_angle - down_angle + airframe_pitch - 0.5 * math.pi
    return GearPoints(
        bar_pivot,
        _polar(bar_pivot, pivot_height, bar_direction - gear_angle),
        _polar(bar_pivot, attachment_distance, bar_direction),
        _polar(bar_pivot, bar_length, bar_direction),
    )


def suspension_points(
    base_offset: float, rest_height: float, deflection: float, base_displacement: float
) -> SuspensionPoints:
    """The two springs' ends: origin on the centre line at the spring bases' height with the
    base at z = 0, +x right, +y up. The bases sit at (-d, -z) and (d, -z) (z: the base's
    downward displacement), the apex where the springs meet at (0, -z + h - u), u the
    deflection, h the unstressed height sqrt(L^2 - d^2)."""
    base = -base_displacement
    return SuspensionPoints(
        (-base_offset, base), (base_offset, base), (0.0, base + rest_height - deflection)
    )


def cam_centre(follower: "cam_geometry.Follower") -> Point:
    """The cam's centre in the valve train's frame for a cam_geometry.Follower: the
    follower's axis is the tappet axis x = 0, and at zero lift the follower's trace point
    (a flat face on the axis, a roller's centre) is the tappet foot (0, r_b) with the
    follower on the base circle, so the centre lies at (-e, r_b - d), d = trace_height (e
    the follower's offset). The origin for a flat face without offset."""
    base = follower.base_circle_radius
    return (-follower.offset, base - cam_geometry.trace_height(follower))


def valve_train_points(
    geometry: tuple[float, ...],
    tappet_lift: float,
    rocker_angle: float,
    valve_foot_height: float,
    centre: Point = (0.0, 0.0),
) -> ValveTrainPoints:
    """The pushrod valve train's joints (valve_train.py's frame): origin at the camshaft
    centre of a flat-faced tappet without offset, +x right, +y up; ``centre``: where the cam's
    centre is (cam_centre). ``geometry``: a valve_train.ValveGeometry. The tappet foot P =
    (0, r_b + tappet lift) on the tappet axis, the rocker pivot (a, b), its tappet end T =
    (a - lt cos phi, b - lt sin phi) and valve end V = (a + lv cos phi, b + lv sin phi), the
    valve foot Q = (c, y3) on the valve axis (``valve_foot_height``: y3)."""
    (base_radius, _, pivot_x, pivot_y, tappet_arm, valve_arm, axis_x, _) = geometry
    cos_phi, sin_phi = math.cos(rocker_angle), math.sin(rocker_angle)
    return ValveTrainPoints(
        centre,
        (0.0, base_radius + tappet_lift),
        (pivot_x, pivot_y),
        (pivot_x - tappet_arm * cos_phi, pivot_y - tappet_arm * sin_phi),
        (pivot_x + valve_arm * cos_phi, pivot_y + valve_arm * sin_phi),
        (axis_x, valve_foot_height),
    )


def valve_axis_points(
    axis_x: float, closed_height: float, lash: float, rocker_lift: float, valve_lift: float
) -> ValveAxisPoints:
    """The rocker's valve end and the valve's tip on the valve axis x = ``axis_x``, in the
    valve train's frame: the rocker end at the valve train's valve foot, closed_height -
    rocker_lift; the valve tip ``lash`` below it when both are closed, at closed_height -
    lash - valve_lift. The gap between them is lash + valve_lift - rocker_lift, minus the
    contact's penetration."""
    return ValveAxisPoints(
        (axis_x, closed_height - rocker_lift), (axis_x, closed_height - lash - valve_lift)
    )


def output_names(kind: type) -> tuple[str, ...]:
    """The geometry outputs of a namedtuple type of points: <point>_x, <point>_y of each."""
    return tuple(f"{name}_{axis}" for name in kind._fields for axis in ("x", "y"))  # type: ignore[attr-defined]


_NAMES: dict[type, tuple[str, ...]] = {}  # output_names of each points type, once


def flattened(points: tuple[Point, ...]) -> dict[str, float]:
    """{<point>_x: x, <point>_y: y} of a namedtuple of points: the geometry outputs."""
    kind = type(points)
    names = _NAMES.get(kind) or _NAMES.setdefault(kind, output_names(kind))
    return dict(zip(names, [coordinate for point in points for coordinate in point]))
