"""Cam and pushrod valve-train reference kinematics (numpy, vectorised).

An independent implementation of src/mechfmu/runtime/physics/cam_laws.py and valve_train.py, written
without them, so the two check each other. Geometry (m, rad; camshaft centre at the origin):
the pushrod foot P = (0, y1), y1 = cam_base_radius + tappet_lift, is joined by the pushrod
(length L1) to the rocker's tappet end T = (a - lt cos phi, b - lt sin phi); the rocker turns
about (a, b); its valve end V = (a + lv cos phi, b + lv sin phi) is joined by the valve link
(length L3) to the foot Q = (c, y3) on the valve axis x = c. Valve lift = y3_closed - y3.

Where the standard-library version solves u cos(phi) + w sin(phi) = K, this one intersects
the two circles directly (the chord construction: distance along the centre line
(r1^2 - r2^2 + d^2) / (2 d), half chord sqrt(r1^2 - along^2)), picks the branch by the
orientation of the triangle, and gets the rates by implicit differentiation of the scalar
constraint F(phi, y) = 0 (F_phi phi' + F_y y' = 0 and its derivative) rather than of the
vector constraints. Arrays broadcast; outside the valid range the results are NaN.

Cam laws: rise s = lift f(x), return s = lift (1 - f(x)), written in expanded polynomial and
plain trigonometric form, angles reduced with np.mod.
"""

from collections.abc import Mapping
import numpy as np
from numpy import ndarray
from typing import Any

CAM_LAWS = ("harmonic", "cycloidal", "polynomial_345", "polynomial_4567")
MOTION_FIELDS = (
    "tappet_lift",
    "tappet_velocity",
    "tappet_acceleration",
    "rocker_angle",
    "rocker_angular_velocity",
    "rocker_angular_acceleration",
    "valve_lift",
    "valve_velocity",
    "valve_acceleration",
)

# Expanded polynomial coefficients of f, lowest power first.
_POLYNOMIALS = {
    "polynomial_345": [0.0, 0.0, 0.0, 10.0, -15.0, 6.0],
    "polynomial_4567": [0.0, 0.0, 0.0, 0.0, 35.0, -84.0, 70.0, -20.0],
}


def normalized(law: str, x: float | ndarray) -> tuple:
    """(f, f', f'') of the normalized rise at x in [0, 1] (arrays)."""
    x = np.asarray(x, dtype=float)
    if law == "harmonic":
        return (
            (1.0 - np.cos(np.pi * x)) / 2.0,
            np.pi / 2.0 * np.sin(np.pi * x),
            np.pi**2 / 2.0 * np.cos(np.pi * x),
        )
    if law == "cycloidal":
        angle = 2.0 * np.pi * x
        return (x - np.sin(angle) / (2.0 * np.pi), 1.0 - np.cos(angle), 2.0 * np.pi * np.sin(angle))
    if law not in _POLYNOMIALS:
        raise ValueError(f"law = {law!r} is not one of {', '.join(CAM_LAWS)}")
    poly = np.polynomial.Polynomial(_POLYNOMIALS[law])
    return poly(x), poly.deriv(1)(x), poly.deriv(2)(x)


def cam_lift(
    law: str,
    lift: float,
    rise_start: float,
    rise_angle: float,
    high_dwell_angle: float,
    return_angle: float,
    angle: float | list[float] | ndarray,
) -> tuple[ndarray, ndarray, ndarray]:
    """Follower lift s (m) and ds/dtheta, d2s/dtheta2 (m/rad, m/rad^2) at camshaft ``angle``.

    Segments closed on the left: rise [0, beta_r), high dwell, return, low dwell, measured
    from rise_start modulo 2 pi.
    """
    angle = np.asarray(angle, dtype=float)
    local = np.mod(angle - rise_start, 2.0 * np.pi)
    return_start = rise_angle + high_dwell_angle
    return_end = return_start + return_angle
    rising = local < rise_angle
    high = (local >= rise_angle) & (local < return_start)
    returning = (local >= return_start) & (local < return_end)
    f_r, f1_r, f2_r = normalized(law, np.clip(local / rise_angle, 0.0, 1.0))
    f_d, f1_d, f2_d = normalized(law, np.clip((local - return_start) / return_angle, 0.0, 1.0))
    s = np.where(
        rising, lift * f_r, np.where(high, lift, np.where(returning, lift * (1.0 - f_d), 0.0))
    )
    s1 = np.where(
        rising, lift * f1_r / rise_angle, np.where(returning, -lift * f1_d / return_angle, 0.0)
    )
    s2 = np.where(
        rising,
        lift * f2_r / rise_angle**2,
        np.where(returning, -lift * f2_d / return_angle**2, 0.0),
    )
    return s, s1, s2


CAM_FIELDS = ("cam_law", "lift", "rise_start", "rise_angle", "high_dwell_angle", "return_angle")


def tappet_motion(
    parameters: Mapping[str, Any],
    angle: float | ndarray,
    speed: float | ndarray,
    acceleration: float | ndarray,
) -> tuple[ndarray, ndarray, ndarray]:
    """Tappet lift s (m), velocity (m/s) and acceleration (m/s^2) of the cam law in a
    ValveTrain's ``parameters`` (CAM_FIELDS) at camshaft ``angle`` (rad), ``speed``
    (rad/s) and ``acceleration`` (rad/s^2)."""
    law, lift, rise_start, rise_angle, dwell_angle, return_angle = (
        parameters[key] for key in CAM_FIELDS
    )
    s, s1, s2 = cam_lift(law, lift, rise_start, rise_angle, dwell_angle, return_angle, angle)
    return s, s1 * speed, s2 * speed * speed + s1 * acceleration


GEOMETRY_FIELDS = (
    "cam_base_radius",
    "pushrod_length",
    "rocker_pivot_x",
    "rocker_pivot_y",
    "tappet_arm",
    "valve_arm",
    "valve_axis_x",
    "valve_link_length",
)


def _unpack(geometry: dict[str, float]) -> tuple[float, ...]:
    return tuple(float(geometry[key]) for key in GEOMETRY_FIELDS)


def _circle_point(
    centre_x: float,
    centre_y: ndarray | float,
    radius: float,
    other_x: float,
    other_y: float,
    other_radius: float,
    sign: float,
) -> tuple:
    """Intersection of circle (centre, radius) with circle (other, other_radius).

    sign = +1 takes the point to the left of the direction centre -> other, -1 to the right.
    """
    dx, dy = other_x - centre_x, other_y - centre_y
    distance = np.hypot(dx, dy)
    ex, ey = dx / distance, dy / distance
    along = (radius**2 - other_radius**2 + distance**2) / (2.0 * distance)
    with np.errstate(invalid="ignore"):
        chord = np.sqrt((radius - along) * (radius + along))
    return centre_x + along * ex - sign * chord * ey, centre_y + along * ey + sign * chord * ex


def _rocker_from_y1(geometry: dict[str, float], y1: ndarray | float) -> ndarray | float:
    r_b, l1, a, b, lt, lv, c, l3 = _unpack(geometry)
    # T lies on the circle L1 about P and lt about the pivot; seen from the pivot it is
    # clockwise of P, i.e. left of the direction P -> pivot.
    tx, ty = _circle_point(0.0, y1, l1, a, b, lt, +1.0)
    return np.arctan2(b - ty, a - tx)


def _y3_from_rocker(geometry: dict[str, float], phi: ndarray | float) -> ndarray | float:
    r_b, l1, a, b, lt, lv, c, l3 = _unpack(geometry)
    vx, vy = a + lv * np.cos(phi), b + lv * np.sin(phi)
    with np.errstate(invalid="ignore"):
        return vy - np.sqrt(l3**2 - (c - vx) ** 2)


def _rocker_from_y3(geometry: dict[str, float], y3: ndarray) -> ndarray:
    r_b, l1, a, b, lt, lv, c, l3 = _unpack(geometry)
    # V lies on the circle L3 about Q and lv about the pivot, counter-clockwise of Q seen
    # from the pivot: right of the direction Q -> pivot.
    vx, vy = _circle_point(c, y3, l3, a, b, lv, -1.0)
    return np.arctan2(vy - b, vx - a)


def _y1_from_rocker(geometry: dict[str, float], phi: ndarray) -> ndarray:
    r_b, l1, a, b, lt, lv, c, l3 = _unpack(geometry)
    tx, ty = a - lt * np.cos(phi), b - lt * np.sin(phi)
    with np.errstate(invalid="ignore"):
        return ty - np.sqrt(l1**2 - tx**2)


def closed_valve_position(geometry: dict[str, float]) -> float:
    """y3 (m) at zero tappet lift."""
    r_b = float(geometry["cam_base_radius"])
    return float(_y3_from_rocker(geometry, _rocker_from_y1(geometry, np.float64(r_b))))


def _tappet_partials(
    geometry: dict[str, float], phi: ndarray | float, y1: ndarray | float
) -> tuple:
    """Partials of F = a cos(phi) + (b - y1) sin(phi) - (a^2 + (b - y1)^2 + lt^2 - L1^2)/(2 lt)."""
    r_b, l1, a, b, lt, lv, c, l3 = _unpack(geometry)
    w = b - y1
    cos_phi, sin_phi = np.cos(phi), np.sin(phi)
    f_p = -a * sin_phi + w * cos_phi
    f_y = -sin_phi + w / lt
    f_pp = -a * cos_phi - w * sin_phi
    f_py = -cos_phi
    f_yy = -1.0 / lt
    return f_p, f_y, f_pp, f_py, f_yy


def _valve_partials(geometry: dict[str, float], phi: ndarray | float, y3: ndarray | float) -> tuple:
    """Partials of H = (c - a) cos(phi) + (y3 - b) sin(phi)
    - ((c - a)^2 + (y3 - b)^2 + lv^2 - L3^2) / (2 lv)."""
    r_b, l1, a, b, lt, lv, c, l3 = _unpack(geometry)
    u, w = c - a, y3 - b
    cos_phi, sin_phi = np.cos(phi), np.sin(phi)
    h_p = -u * sin_phi + w * cos_phi
    h_y = sin_phi - w / lv
    h_pp = -u * cos_phi - w * sin_phi
    h_py = cos_phi
    h_yy = -1.0 / lv
    return h_p, h_y, h_pp, h_py, h_yy


def _driven(
    partials: tuple, rate: float | ndarray, accel: float | ndarray, driver_is_phi: bool
) -> tuple:
    """Rates of the driven variable of F(phi, y) = 0 from those of the driver.

    F_phi phi' + F_y y' = 0;  F_pp phi'^2 + 2 F_py phi' y' + F_yy y'^2 + F_phi phi'' + F_y y'' = 0.
    """
    f_p, f_y, f_pp, f_py, f_yy = partials
    with np.errstate(invalid="ignore", divide="ignore"):
        if driver_is_phi:
            y_rate = -f_p * rate / f_y
            y_accel = (
                -(f_pp * rate**2 + 2.0 * f_py * rate * y_rate + f_yy * y_rate**2 + f_p * accel)
                / f_y
            )
            return y_rate, y_accel
        phi_rate = -f_y * rate / f_p
        phi_accel = (
            -(f_pp * phi_rate**2 + 2.0 * f_py * phi_rate * rate + f_yy * rate**2 + f_y * accel)
            / f_p
        )
        return phi_rate, phi_accel


def forward(
    geometry: dict[str, float],
    tappet_lift: float | ndarray,
    tappet_velocity: float | ndarray,
    tappet_acceleration: float | ndarray,
) -> dict[str, ndarray | float]:
    """Rocker and valve motion for a tappet motion: dict of arrays keyed by MOTION_FIELDS.

    ``geometry``: mapping with the ValveGeometry field names (m).
    """
    s, sd, sdd = (
        np.asarray(v, dtype=float) for v in (tappet_lift, tappet_velocity, tappet_acceleration)
    )
    s, sd, sdd = np.broadcast_arrays(s, sd, sdd)
    y1 = float(geometry["cam_base_radius"]) + s
    phi = _rocker_from_y1(geometry, y1)
    y3 = _y3_from_rocker(geometry, phi)
    omega, alpha = _driven(_tappet_partials(geometry, phi, y1), sd, sdd, driver_is_phi=False)
    y3_rate, y3_accel = _driven(
        _valve_partials(geometry, phi, y3), omega, alpha, driver_is_phi=True
    )
    values = (
        s,
        sd,
        sdd,
        phi,
        omega,
        alpha,
        closed_valve_position(geometry) - y3,
        -y3_rate,
        -y3_accel,
    )
    return dict(zip(MOTION_FIELDS, values))


def inverse(
    geometry: dict[str, float],
    valve_lift: ndarray,
    valve_velocity: ndarray,
    valve_acceleration: ndarray,
) -> dict[str, ndarray]:
    """Rocker and tappet motion for a valve motion: dict of arrays keyed by MOTION_FIELDS."""
    lift, ld, ldd = (
        np.asarray(v, dtype=float) for v in (valve_lift, valve_velocity, valve_acceleration)
    )
    lift, ld, ldd = np.broadcast_arrays(lift, ld, ldd)
    y3 = closed_valve_position(geometry) - lift
    phi = _rocker_from_y3(geometry, y3)
    y1 = _y1_from_rocker(geometry, phi)
    omega, alpha = _driven(_valve_partials(geometry, phi, y3), -ld, -ldd, driver_is_phi=False)
    y1_rate, y1_accel = _driven(
        _tappet_partials(geometry, phi, y1), omega, alpha, driver_is_phi=True
    )
    values = (
        y1 - float(geometry["cam_base_radius"]),
        y1_rate,
        y1_accel,
        phi,
        omega,
        alpha,
        lift,
        ld,
        ldd,
    )
    return dict(zip(MOTION_FIELDS, values))


def revolution(
    geometry: dict[str, float],
    law: str,
    lift: float,
    rise_start: float,
    rise_angle: float,
    high_dwell_angle: float,
    return_angle: float,
    angle: list[float],
    camshaft_speed: float,
) -> dict[str, Any]:
    """Valve-train motion at constant camshaft speed (rad/s) over camshaft ``angle`` (rad).

    The tappet follows the cam: lift s, velocity s1 w, acceleration s2 w^2.
    """
    s, s1, s2 = cam_lift(law, lift, rise_start, rise_angle, high_dwell_angle, return_angle, angle)
    w = float(camshaft_speed)
    return forward(geometry, s, s1 * w, s2 * w * w)
