"""Cam geometry and camshaft torque by other routes than runtime/physics/cam_geometry.py
(numpy): numerical envelopes, a contact search on a computed profile, the statics of the
rocker.

- flat_face_envelope: the cam of a flat-faced follower as the envelope of the face's lines,
  each line at camshaft angle theta being x sin(theta) + y cos(theta) = Rb + s(theta) in the
  cam's frame; the envelope point at theta is where the lines at theta - delta and
  theta + delta cross (the graphical construction, its error of order rho delta^2 / 2),
  extrapolated to zero spacing from two deltas.
- roller_envelope: the pitch curve (the roller centre (e, d + s) turned into the cam's
  frame) offset inwards by the roller radius along its normal, the normal from central
  differences of the pitch points; the pressure angle from that normal.
- circumradius: the radius of curvature of a sampled curve as the radius of the circle
  through three neighbouring points.
- contact_lift: rotate a computed profile (points given by a function of a parameter) to
  camshaft angle theta and find where the follower rests on it by a dense search: the face's
  highest point of contact (flat), or the highest roller centre that touches no profile
  point (roller); the search is refined on ever finer sub-grids around the best point.
- cam_columns: ValveTrain's cam_geometry outputs in the seed's complex-number form (the
  scene references).
- follower_force_by_statics, camshaft_torque_by_statics: the tappet's force from the
  valve's by the moments about the rocker pivot (the pushrod and the valve link are
  two-force members), and the camshaft torque as the moment of the contact force about the
  camshaft centre, at the contact point of the flat face (x = ds/dtheta in the fixed frame).

Conventions as the runtime's: fixed frame with the camshaft centre at the origin, y along
the follower's lift, the follower's axis at x = e; the camshaft turns counter-clockwise by
theta and a fixed point q is at R(-theta) q in the cam frame. Lengths in m, angles in rad.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from numpy import ndarray

from . import valve_train as vt

Profile = Callable[[ndarray], tuple[ndarray, ndarray]]  # parameter (rad) -> cam-frame x, y (m)


def to_cam_frame(x: Any, y: Any, angle: Any) -> tuple[Any, Any]:
    """Fixed-frame points (x, y) (m, floats or arrays) at camshaft ``angle`` (rad) in the
    cam's frame: R(-angle) (x, y)."""
    cos_t, sin_t = np.cos(angle), np.sin(angle)
    return x * cos_t + y * sin_t, y * cos_t - x * sin_t


def to_fixed_frame(x: Any, y: Any, angle: Any) -> tuple[Any, Any]:
    """Cam-frame points (x, y) (m) at camshaft ``angle`` (rad) in the fixed frame."""
    cos_t, sin_t = np.cos(angle), np.sin(angle)
    return x * cos_t - y * sin_t, x * sin_t + y * cos_t


def _crossing(
    face_height: Callable[[ndarray], ndarray], angle: ndarray, delta: float
) -> tuple[ndarray, ndarray]:
    """Cam-frame point (m) where the face's lines at angle -+ delta cross."""
    a, b = angle - delta, angle + delta
    h_a, h_b = face_height(a), face_height(b)
    determinant = np.sin(a - b)
    return (
        (h_a * np.cos(b) - h_b * np.cos(a)) / determinant,
        (h_b * np.sin(a) - h_a * np.sin(b)) / determinant,
    )


def flat_face_envelope(
    face_height: Callable[[ndarray], ndarray], angle: ndarray, delta: float = 2.5e-4
) -> tuple[ndarray, ndarray]:
    """Cam-frame points (m) of the envelope of a flat face at the camshaft angles ``angle``
    (rad): where the face's lines at angle -+ delta cross, for delta = ``delta`` and
    2 delta, extrapolated to zero spacing (Richardson: the crossing's error is even in delta,
    (4 P(delta) - P(2 delta)) / 3 leaves O(delta^4)). ``face_height``(theta) = Rb + s(theta)
    (m), the face's distance from the camshaft centre. Valid where the lift is smooth over
    [angle - 2 delta, angle + 2 delta] (not across a join of the cam law's segments)."""
    angle = np.asarray(angle, dtype=float)
    near_x, near_y = _crossing(face_height, angle, delta)
    far_x, far_y = _crossing(face_height, angle, 2.0 * delta)
    return (4.0 * near_x - far_x) / 3.0, (4.0 * near_y - far_y) / 3.0


def pitch_curve(
    lift: Callable[[ndarray], ndarray], trace_height: float, offset: float, angle: ndarray
) -> tuple[ndarray, ndarray]:
    """Cam-frame points (m) of the trace point (e, d + s(theta)) at ``angle`` (rad)."""
    angle = np.asarray(angle, dtype=float)
    return to_cam_frame(np.full_like(angle, offset), trace_height + lift(angle), angle)


def roller_envelope(
    lift: Callable[[ndarray], ndarray],
    trace_height: float,
    offset: float,
    roller_radius: float,
    angle: ndarray,
    delta: float = 2.5e-4,
) -> tuple[ndarray, ndarray, ndarray]:
    """(x, y, pressure angle) of a roller follower's cam at ``angle`` (rad): the pitch curve
    offset by ``roller_radius`` (m) towards the cam along its normal; the tangent from the
    central differences of the pitch points at angle -+ delta and -+ 2 delta, extrapolated
    (Richardson, O(delta^4)); the pressure angle (rad) between the normal, turned into the
    fixed frame, and the follower's axis. Valid where the lift is smooth over
    [angle - 2 delta, angle + 2 delta]."""
    angle = np.asarray(angle, dtype=float)
    x, y = pitch_curve(lift, trace_height, offset, angle)

    def difference(step: float) -> tuple[ndarray, ndarray]:
        x_a, y_a = pitch_curve(lift, trace_height, offset, angle - step)
        x_b, y_b = pitch_curve(lift, trace_height, offset, angle + step)
        return (x_b - x_a) / (2.0 * step), (y_b - y_a) / (2.0 * step)

    (near_x, near_y), (far_x, far_y) = difference(delta), difference(2.0 * delta)
    tangent_x, tangent_y = (4.0 * near_x - far_x) / 3.0, (4.0 * near_y - far_y) / 3.0
    length = np.hypot(tangent_x, tangent_y)
    # the curve runs clockwise round the cam: the cam lies to the right of its tangent
    normal_x, normal_y = tangent_y / length, -tangent_x / length
    fixed_x, fixed_y = to_fixed_frame(normal_x, normal_y, angle)
    return x + roller_radius * normal_x, y + roller_radius * normal_y, np.arctan2(fixed_x, -fixed_y)


def circumradius(x: ndarray, y: ndarray) -> ndarray:
    """Signed radius (m) of the circle through each three neighbouring points of a sampled
    curve, at the middle ones (positive where the curve turns clockwise, as a cam profile
    traced with the camshaft angle does where convex)."""
    ax, ay, bx, by, cx, cy = x[:-2], y[:-2], x[1:-1], y[1:-1], x[2:], y[2:]
    cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    sides = np.hypot(bx - ax, by - ay) * np.hypot(cx - bx, cy - by) * np.hypot(cx - ax, cy - ay)
    return -sides / (2.0 * cross)


def _support(points_x: ndarray, points_y: ndarray, follower: Mapping[str, Any], angle: float):
    """Height of the follower (face, or roller centre, m) resting on the cam-frame points at
    camshaft ``angle``, point by point (-inf where a point cannot touch the roller)."""
    x, y = to_fixed_frame(points_x, points_y, angle)
    if follower["kind"] == "flat_faced":
        return y
    dx = x - follower["offset"]
    radius = follower["roller_radius"]
    with np.errstate(invalid="ignore"):
        reach = np.sqrt((radius - dx) * (radius + dx))
    return np.where(np.abs(dx) <= radius, y + reach, -np.inf)


def contact_lift(
    profile: Profile,
    follower: Mapping[str, Any],
    trace_height: float,
    angle: ndarray,
    coarse: int = 4096,
    levels: int = 6,
    points: int = 33,
) -> ndarray:
    """The follower's lift (m) on the cam whose surface is ``profile`` (a function of a
    parameter over [0, 2 pi) giving cam-frame points), at each camshaft ``angle`` (rad), by
    a contact search: the follower (``follower``: kind, offset, roller_radius) rests on the
    highest of ``coarse`` profile points turned to that angle; the search is repeated
    ``levels`` times on ``points`` points spanning the two coarse intervals either side of
    the best one, each level 8 times finer (down to 2 pi / coarse / 8^levels). Lift =
    height - ``trace_height`` (the trace point's height at zero lift, m)."""
    step = 2.0 * np.pi / coarse
    grid = np.arange(coarse) * step
    grid_x, grid_y = profile(grid)
    lifts = []
    for theta in np.atleast_1d(angle):
        heights = _support(grid_x, grid_y, follower, theta)
        best = grid[int(np.argmax(heights))]
        height = float(np.max(heights))
        span = 2.0 * step
        for _ in range(levels):
            local = best + np.linspace(-span, span, points)
            heights = _support(*profile(local), follower, theta)
            index = int(np.argmax(heights))
            if heights[index] > height:
                height = float(heights[index])
            best = local[index]
            span = 2.0 * (2.0 * span / (points - 1))
        lifts.append(height - trace_height)
    return np.array(lifts)


def _unit(x: ndarray, y: ndarray) -> tuple[ndarray, ndarray]:
    length = np.hypot(x, y)
    return x / length, y / length


def follower_force_by_statics(
    geometry: Mapping[str, float], tappet_lift: ndarray, valve_force: ndarray
) -> ndarray:
    """Force (N) along the tappet's axis that holds the rocker in equilibrium against
    ``valve_force`` (N, pushing the valve open, down its axis) with the tappet at
    ``tappet_lift`` (m): the valve link and the pushrod carry forces along themselves
    (massless, pinned at both ends), the link's vertical component is the valve force, and
    the moments about the rocker pivot balance."""
    r_b, l1, a, b, lt, lv, c, l3 = (float(geometry[key]) for key in vt.GEOMETRY_FIELDS)
    lift = np.asarray(tappet_lift, dtype=float)
    motion = vt.forward(dict(geometry), lift, np.zeros_like(lift), np.zeros_like(lift))
    phi = motion["rocker_angle"]
    y1 = r_b + lift
    y3 = vt.closed_valve_position(dict(geometry)) - motion["valve_lift"]
    t_x, t_y = a - lt * np.cos(phi), b - lt * np.sin(phi)
    v_x, v_y = a + lv * np.cos(phi), b + lv * np.sin(phi)
    link_x, link_y = _unit(v_x - c, v_y - y3)  # from the valve foot Q up to V
    rod_x, rod_y = _unit(t_x, t_y - y1)  # from the tappet foot P up to T
    link_force = np.asarray(valve_force) / link_y  # compression; pushes the rocker along +link
    moment_link = (v_x - a) * link_y - (v_y - b) * link_x
    moment_rod = (t_x - a) * rod_y - (t_y - b) * rod_x
    rod_force = -moment_link * link_force / moment_rod
    return rod_force * rod_y


def camshaft_torque_by_statics(
    geometry: Mapping[str, float],
    tappet_lift: ndarray,
    tappet_lift_rate: ndarray,
    valve_force: ndarray,
) -> ndarray:
    """Torque (N.m) the camshaft supplies to a flat-faced tappet at ``tappet_lift`` (m),
    whose lift rises ``tappet_lift_rate`` = ds/dtheta (m/rad) per camshaft radian, with
    ``valve_force`` (N) on the valve: the tappet force by the rocker's statics, acting down
    on the cam at the contact (ds/dtheta, Rb + s) of the fixed frame; the torque balances
    its moment about the camshaft centre."""
    force = follower_force_by_statics(geometry, tappet_lift, valve_force)
    contact_x = np.asarray(tappet_lift_rate, dtype=float)
    moment = contact_x * -force  # of the tappet's push (0, -force) at (contact_x, Rb + s)
    return -moment


def cam_columns(
    follower: Mapping[str, Any],
    lift: ndarray,
    lift_rate: ndarray,
    lift_curvature: ndarray,
    angle: ndarray,
) -> dict[str, ndarray]:
    """The cam_geometry outputs of ValveTrain at camshaft ``angle`` (rad) for the tappet's
    s, ds/dtheta, d2s/dtheta2 (``lift`` m, ``lift_rate`` m/rad, ``lift_curvature``
    m/rad^2), in complex form (the seed's complex-number kinematics): the trace point
    z = exp(-i theta) (e + i h) and its derivatives by the product rule; the curvature
    -Im(conj(z') z'') / |z'|^3; the roller's contact z - i Rf z' / |z'|; the flat face's
    contact on the face line through z, s1 - e along the face's direction exp(-i theta),
    and its surface radius h + s2 (the support function's radius). ``follower``: kind,
    base_circle_radius, roller_radius, offset (m)."""
    theta = np.asarray(angle, dtype=float)
    s, s1, s2 = (np.asarray(v, dtype=float) for v in (lift, lift_rate, lift_curvature))
    e, base, roller = (
        float(follower[k]) for k in ("offset", "base_circle_radius", "roller_radius")
    )
    flat = follower["kind"] == "flat_faced"
    rest = base if flat else float(np.sqrt((base + roller) ** 2 - e**2))
    turn = np.exp(-1j * theta)
    h = rest + s
    z = turn * (e + 1j * h)
    dz = -1j * z + turn * (1j * s1)
    ddz = -1j * dz + turn * (s1 + 1j * s2)
    speed = np.abs(dz)
    curvature = -np.imag(np.conj(dz) * ddz) / speed**3
    if flat:
        contact = z + turn * (s1 - e)  # along the face (the fixed x axis turned by -theta)
        surface = h + s2
        pressure = np.zeros_like(theta)
        face = s1 - e
    else:
        contact = z - 1j * roller * dz / speed
        surface = 1.0 / curvature - roller
        normal = (contact - z) / turn  # in the fixed frame, pointing into the cam
        pressure = np.arctan2(normal.real, -normal.imag)
        face = np.zeros_like(theta)
    return {
        "pressure_angle": pressure,
        "radius_of_curvature": surface,
        "pitch_radius_of_curvature": 1.0 / curvature,
        "cam_contact_x": contact.real,
        "cam_contact_y": contact.imag,
        "face_contact_position": face,
    }
