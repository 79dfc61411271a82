"""Landing gear loads reference (numpy): the piston force a prescribed retraction needs and
the loads at the bar's pivot B and at the actuator's anchor C.

Written from vectors in airframe axes (origin B, x forward, y up; the runtime's convention,
runtime/physics/gear_forces.py), not from gear_dynamics' scalar moments: the bar's unit
vector u at beta = theta - down_angle from hanging, the attachment P = d u, the anchor
C = h (-sin down_angle, -cos down_angle). Bar and wheel as two parts, a uniform bar (centre
of mass at L/2, I = m L^2 / 12 about it) and the wheel a point mass at L, so I_B and the
first moment come from the parallel-axis sums. Every external force is a vector at its point
of application: the weights at the parts' centres along (-sin p, -cos p), the drag at the
wheel against the flight direction (cos p, -sin p), the friction a pure moment. Then

    piston force F:  (r_P x e) F = I_B alpha - sum over the loads of r x F_load - M_friction,
    pivot load:      R_B = sum m a_part - sum F_load - F e      (each part's a by the chain rule),

with e = (P - C)/|P - C| and the anchor holding the actuator with F e. Units: SI.
"""

from typing import Any

import numpy as np
from numpy import ndarray

from . import landing_gear

EFFECTS = ("inertia", "gravity", "aero_drag", "pivot_friction", "forces")


def _frame(values: dict, theta: Any) -> tuple[ndarray, ndarray, ndarray, Any]:
    """Bar direction u, its derivative du/dbeta, the piston direction e (2 x N) and the
    moment arm r_P x e (m) at gear angles ``theta``."""
    d, h, down = values["attachment_distance"], values["pivot_height"], values["down_angle"]
    beta = np.asarray(theta, dtype=float) - down
    u = np.stack([np.sin(beta), -np.cos(beta)])
    du = np.stack([np.cos(beta), np.sin(beta)])
    anchor = np.array([-h * np.sin(down), -h * np.cos(down)])[:, None]
    line = d * u - anchor
    e = line / np.hypot(line[0], line[1])
    return u, du, e, _cross(d * u, e)


def _cross(r: ndarray, f: ndarray) -> ndarray:
    return r[0] * f[1] - r[1] * f[0]


def _parts(values: dict) -> list[tuple[float, float, float]]:
    """(mass, distance from B, inertia about the part's centre) of bar and wheel."""
    length, m_bar = values["bar_length"], values["bar_mass"]
    return [(m_bar, 0.5 * length, m_bar * length**2 / 12.0), (values["wheel_mass"], length, 0.0)]


def _external(values: dict, theta: Any, omega: Any) -> tuple[ndarray, ndarray]:
    """(moment about B, resultant force) of the enabled weights, drag and friction."""
    u, _, _, _ = _frame(values, theta)
    pitch, length = values["airframe_pitch"], values["bar_length"]
    moment = np.zeros(u.shape[1])
    load = np.zeros_like(u)
    if values["gravity"]:
        down_dir = np.array([-np.sin(pitch), -np.cos(pitch)])[:, None]
        for m, r, _ in _parts(values):
            weight = m * values["gravity_acceleration"] * down_dir
            moment = moment + _cross(r * u, weight)
            load = load + weight
    if values["aero_drag"]:
        airspeed = values["airspeed"]
        drag = 0.5 * values["air_density"] * values["drag_area"] * airspeed * abs(airspeed)
        force = -drag * np.array([np.cos(pitch), -np.sin(pitch)])[:, None] * np.ones_like(u[0])
        moment = moment + _cross(length * u, force)
        load = load + force
    if values["pivot_friction"]:
        moment = moment - (
            values["viscous_friction"] * omega
            + values["coulomb_friction"] * np.tanh(np.asarray(omega) / values["friction_speed"])
        )
    return moment, load


def pivot_and_anchor(
    values: dict, theta: Any, omega: Any, alpha: Any, piston_force: Any
) -> dict[str, ndarray]:
    """pivot_force_* (airframe on bar at B) and anchor_force_* (airframe on the actuator),
    N, for the gear motion (rad, rad/s, rad/s^2) and the whole force along the piston (N)."""
    u, du, e, _ = _frame(values, theta)
    _, load = _external(values, theta, omega)
    momentum_rate = np.zeros_like(u)
    if values["inertia"]:
        for m, r, _ in _parts(values):  # a = r (u' alpha + u'' omega^2), u'' = -u
            momentum_rate = momentum_rate + m * r * (du * alpha - u * np.asarray(omega) ** 2)
    pivot = momentum_rate - load - piston_force * e
    anchor = piston_force * e
    return {
        "pivot_force_x": pivot[0],
        "pivot_force_y": pivot[1],
        "pivot_force_magnitude": np.hypot(pivot[0], pivot[1]),
        "anchor_force_x": anchor[0],
        "anchor_force_y": anchor[1],
        "anchor_force_magnitude": np.abs(piston_force),
    }


def loads(values: dict, extension: Any, speed: Any, acceleration: Any) -> dict[str, ndarray]:
    """piston_force_required, piston_power, pivot_force_* and anchor_force_* (N, W) of the
    motion drive for a piston motion (m, m/s, m/s^2) and the gear's variable values (its
    parameters, effects as booleans, and the input airspeed)."""
    d, h = values["attachment_distance"], values["pivot_height"]
    theta, omega, alpha = landing_gear.gear_from_piston(extension, speed, acceleration, d, h)
    _, _, _, arm = _frame(values, theta)
    moment, _ = _external(values, theta, omega)
    inertia = sum(i + m * r * r for m, r, i in _parts(values)) if values["inertia"] else 0.0
    required = (inertia * alpha - moment) / arm
    if not any(values[name] for name in EFFECTS[:-1]):
        required = np.zeros_like(theta)
    return {
        "piston_force_required": required,
        "piston_power": required * np.asarray(speed, dtype=float),
        **pivot_and_anchor(values, theta, omega, alpha, required),
    }
