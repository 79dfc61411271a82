"""Nose landing gear dynamics: moments about the bar pivot B (standard library only).

The bar and wheel rotate about B; theta is the same angle as in the kinematics (at B, between
the bar and the line to the piston's fixed pivot), growing as the gear retracts. A piston force
F (along the piston, positive extending) acts with moment arm d h sin(theta) / x, the
virtual-work ratio dx/dtheta. The equation of motion is

    I_B theta'' = F arm(theta) + sum of the enabled effect moments,

with I_B = m_bar L^2 / 3 + m_wheel L^2 (uniform bar of length L, wheel at its tip A).

Effects (each a separate moment function, composed once from the enabled effects, so a
disabled effect costs nothing):
- gravity: -m g l_cg sin(psi), psi the bar's angle from the downward vertical,
  psi = theta - theta_down + airframe_pitch (theta_down: the gear angle with the bar vertical);
  gravity resists retraction and drives a free-fall extension.
- aero_drag: -(1/2) rho CdA V^2 L cos(psi): drag on the wheel, horizontal aft, resists a
  forward retraction and helps extension.
- pivot_friction: -(c omega + M_c tanh(omega / omega_s)), viscous plus smoothed Coulomb.
- end_stops: stiff contacts at the piston's stroke limits; a spring-damper on the piston
  length, compressive only, damping from the restitution coefficient e:
  zeta = -ln(e) / sqrt(pi^2 + ln(e)^2), c = 2 zeta sqrt(k m_eff), m_eff = I_B / arm^2.

Units: m, kg, s, rad, N, N m.
"""

import math
from collections import namedtuple

from . import landing_gear as kinematics
from ..errors import require_between, require_positive

STANDARD_GRAVITY = 9.80665

# Plausible single-engine nose gear (documented in the README): 12 kg strut and bar,
# 6 kg wheel and tyre, 5x5 in wheel.
DEFAULT_BAR_MASS = 12.0
DEFAULT_WHEEL_MASS = 6.0
DEFAULT_DRAG_AREA = 0.03  # Cd * frontal area of the wheel, m^2
DEFAULT_AIR_DENSITY = 1.225
DEFAULT_VISCOUS_FRICTION = 2.0  # N m s/rad
DEFAULT_COULOMB_FRICTION = 3.0  # N m
DEFAULT_FRICTION_SPEED = 0.01  # rad/s
DEFAULT_STOP_STIFFNESS = 2.0e6  # N/m on the piston length
DEFAULT_RESTITUTION = 0.3

Body = namedtuple("Body", "bar_length bar_mass wheel_mass")
Geometry = namedtuple("Geometry", "attachment_distance pivot_height down_angle airframe_pitch")
Drag = namedtuple("Drag", "air_density drag_area")
Friction = namedtuple("Friction", "viscous coulomb smoothing_speed")
Stops = namedtuple("Stops", "min_length max_length stiffness damping_ratio")


def inertia(body):
    """I_B (kg m^2): uniform bar about its end plus the wheel as a point mass at the tip."""
    L = body.bar_length
    return body.bar_mass * L * L / 3.0 + body.wheel_mass * L * L


def gravity_lever(body):
    """First moment m l_cg (kg m) of bar and wheel about B."""
    return body.bar_mass * body.bar_length / 2.0 + body.wheel_mass * body.bar_length


def bar_from_vertical(angle, geometry):
    """psi (rad): the bar's angle from the downward vertical, growing with the gear angle."""
    return angle - geometry.down_angle + geometry.airframe_pitch


def moment_arm(angle, geometry):
    """Piston moment arm d h sin(theta) / x (m) at a gear angle."""
    x = kinematics.piston_motion(angle, 0.0, 0.0, geometry.attachment_distance,
                                 geometry.pivot_height).extension
    return geometry.attachment_distance * geometry.pivot_height * math.sin(angle) / x


def gravity_moment(angle, body, geometry, gravity=STANDARD_GRAVITY):
    """Moment of gravity about B (N m), positive towards retraction."""
    return -gravity_lever(body) * gravity * math.sin(bar_from_vertical(angle, geometry))


def gravity_potential(angle, body, geometry, gravity=STANDARD_GRAVITY):
    """Potential energy (J) relative to the bar hanging vertically: m g l_cg (1 - cos psi)."""
    return gravity_lever(body) * gravity * (1.0 - math.cos(bar_from_vertical(angle, geometry)))


def drag_moment(angle, airspeed, body, geometry, drag):
    """Moment about B (N m) of the aerodynamic drag on the wheel at airspeed V (m/s)."""
    force = 0.5 * drag.air_density * drag.drag_area * airspeed * abs(airspeed)
    return -force * body.bar_length * math.cos(bar_from_vertical(angle, geometry))


def friction_moment(angular_velocity, friction):
    """Pivot friction moment (N m): viscous plus Coulomb smoothed by tanh."""
    return -(friction.viscous * angular_velocity
             + friction.coulomb * math.tanh(angular_velocity / friction.smoothing_speed))


def damping_ratio(restitution):
    """Damping ratio of a linear contact whose coefficient of restitution is ``restitution``."""
    e = require_between("restitution", restitution, 0.0, 1.0, low_open=True)
    if e == 1.0:
        return 0.0
    log_e = math.log(e)
    return -log_e / math.sqrt(math.pi * math.pi + log_e * log_e)


def stop_force(length, speed, effective_mass, stops):
    """Contact force along the piston (N) from the stroke-limit stops; 0 inside the stroke."""
    if stops.min_length < length < stops.max_length:
        return 0.0
    damping = 2.0 * stops.damping_ratio * math.sqrt(stops.stiffness * effective_mass)
    if length >= stops.max_length:
        return min(0.0, -stops.stiffness * (length - stops.max_length) - damping * speed)
    return max(0.0, stops.stiffness * (stops.min_length - length) - damping * speed)


def make_body(bar_length, bar_mass, wheel_mass):
    """Validated Body: positive bar length and mass, non-negative wheel mass."""
    return Body(require_positive("bar_length", bar_length, "m"),
                require_positive("bar_mass", bar_mass, "kg"),
                require_between("wheel_mass", wheel_mass, 0.0, math.inf, "kg"))
