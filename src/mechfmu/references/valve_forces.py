"""Valve train force reference (numpy): the cam's push and the camshaft torque by the power
balance, from the kinematics alone.

The bodies' poses come from references/valve_train.py's kinematics (tappet foot height,
rocker angle, valve foot height and their rates); the pushrod's and the valve link's angles,
rates and accelerations from the rocker's ends by differentiating phi = atan2(u, w) twice,
(u, w) the link's vector turned to its frame. Then, with no force computed anywhere,

    cam power  P = d(KE)/dt + d(PE)/dt + (k L + F0) dL/dt       (the spring closes the valve),
    cam force  F = P / (tappet velocity),      camshaft torque T = P / (camshaft speed),

the kinetic and potential energy of the pushrod, rocker and valve from their motion
(references/link_forces.energies). Units: SI.
"""

from typing import Any

import numpy as np
from numpy import ndarray

from . import valve_train
from .link_forces import Link, energies


def _angle_of(
    u: tuple[ndarray, ndarray, ndarray], w: tuple[ndarray, ndarray, ndarray]
) -> tuple[ndarray, ndarray, ndarray]:
    """phi = atan2(u, w) and its first two time derivatives from those of u and w."""
    (u0, u1, u2), (w0, w1, w2) = u, w
    r2 = u0 * u0 + w0 * w0
    numerator = w0 * u1 - u0 * w1
    rate = numerator / r2
    numerator_rate = w0 * u2 - u0 * w2
    acceleration = numerator_rate / r2 - numerator * 2.0 * (u0 * u1 + w0 * w1) / r2**2
    return np.arctan2(u0, w0), rate, acceleration


def valve_train_links(geometry: dict[str, float], motion: dict[str, Any]) -> list[Link]:
    """Pushrod (frame at the foot P, along its y axis), rocker (at the pivot) and valve link
    (frame at the foot Q, along its y axis) from the valve train's motion columns."""
    a, b = geometry["rocker_pivot_x"], geometry["rocker_pivot_y"]
    lt, lv, c = geometry["tappet_arm"], geometry["valve_arm"], geometry["valve_axis_x"]
    closed = valve_train.closed_valve_position(geometry)
    phi = np.asarray(motion["rocker_angle"], dtype=float)
    w1, a1 = motion["rocker_angular_velocity"], motion["rocker_angular_acceleration"]
    cos, sin = np.cos(phi), np.sin(phi)
    # rocker ends T = pivot - lt (cos, sin), V = pivot + lv (cos, sin), and their rates
    top = (a - lt * cos, b - lt * sin)
    top_rate = (lt * sin * w1, -lt * cos * w1)
    top_acc = (lt * (cos * w1**2 + sin * a1), lt * (sin * w1**2 - cos * a1))
    end = (a + lv * cos, b + lv * sin)
    end_rate = (-lv * sin * w1, lv * cos * w1)
    end_acc = (-lv * (cos * w1**2 + sin * a1), -lv * (sin * w1**2 - cos * a1))
    y1 = geometry["cam_base_radius"] + np.asarray(motion["tappet_lift"], dtype=float)
    v1, acc1 = motion["tappet_velocity"], motion["tappet_acceleration"]
    y3 = closed - np.asarray(motion["valve_lift"], dtype=float)
    v3, acc3 = -np.asarray(motion["valve_velocity"]), -np.asarray(motion["valve_acceleration"])
    # a body-frame (0, L) turned by phi is (-L sin phi, L cos phi): phi = atan2(-dx, dy)
    pushrod = _angle_of(
        (-top[0], -top_rate[0], -top_acc[0]), (top[1] - y1, top_rate[1] - v1, top_acc[1] - acc1)
    )
    link = _angle_of(
        (-(end[0] - c), -end_rate[0], -end_acc[0]),
        (end[1] - y3, end_rate[1] - v3, end_acc[1] - acc3),
    )
    zero = np.zeros_like(phi)
    return [
        Link((zero, y1), (zero, zero + v1), (zero, zero + acc1), *pushrod),
        Link((zero + a, zero + b), (zero, zero), (zero, zero), phi, zero + w1, zero + a1),
        Link((zero + c, y3), (zero, zero + v3), (zero, zero + acc3), *link),
    ]


def cam_power(
    geometry: dict[str, float],
    motion: dict[str, Any],
    layouts: list[tuple[float, float, float, float]],
    gravity: tuple[float, float],
    spring: tuple[float, float] = (0.0, 0.0),
) -> ndarray:
    """The power the cam delivers (W) by the power balance; ``layouts`` in the bodies' frames
    (pushrod, rocker, valve), ``spring``: (stiffness N/m, preload N) on the valve."""
    links = valve_train_links(geometry, motion)
    rates = energies(links, layouts, gravity)
    stiffness, preload = spring
    spring_power = (stiffness * np.asarray(motion["valve_lift"]) + preload) * np.asarray(
        motion["valve_velocity"]
    )
    return rates["kinetic_energy_rate"] + rates["potential_energy_rate"] + spring_power
