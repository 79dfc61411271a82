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

The two drives of LandingGear.fmu compose these: InverseDynamics (motion drive: the piston
force that produces a prescribed motion) and Dynamics (dynamics drive: the state equations,
the stroke-limit events and the published outputs). Both read the FMU's variable values
(a dict keyed by variable name), so the references integrate exactly the FMU's equations.

Units: m, kg, s, rad, N, N m, Pa.
"""

import math
from collections import namedtuple

from . import hydraulics
from . import landing_gear as kinematics
from ..errors import MechanismError, require_between, require_finite, require_positive
from ..numerics.integrators import Event
from ..numerics.stepping import advance_through_events
from ..numerics.integrators import DormandPrince45
from typing import Any

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


def inertia(body: "Body") -> float:
    """I_B (kg m^2): uniform bar about its end plus the wheel as a point mass at the tip."""
    L = body.bar_length
    return body.bar_mass * L * L / 3.0 + body.wheel_mass * L * L


def gravity_lever(body: "Body") -> float:
    """First moment m l_cg (kg m) of bar and wheel about B."""
    return body.bar_mass * body.bar_length / 2.0 + body.wheel_mass * body.bar_length


def bar_from_vertical(angle: float, geometry: "Geometry") -> float:
    """psi (rad): the bar's angle from the downward vertical, growing with the gear angle."""
    return angle - geometry.down_angle + geometry.airframe_pitch


def gravity_moment(angle: Any, body: Any, geometry: Any, gravity: float = STANDARD_GRAVITY) -> Any:
    """Moment of gravity about B (N m), positive towards retraction."""
    return -gravity_lever(body) * gravity * math.sin(bar_from_vertical(angle, geometry))


def gravity_potential(
    angle: float, body: "Body", geometry: "Geometry", gravity: float = STANDARD_GRAVITY
) -> float:
    """Potential energy (J) relative to the bar hanging vertically: m g l_cg (1 - cos psi)."""
    return gravity_lever(body) * gravity * (1.0 - math.cos(bar_from_vertical(angle, geometry)))


def drag_moment(angle: Any, airspeed: Any, body: Any, geometry: Any, drag: Any) -> Any:
    """Moment about B (N m) of the aerodynamic drag on the wheel at airspeed V (m/s)."""
    force = 0.5 * drag.air_density * drag.drag_area * airspeed * abs(airspeed)
    return -force * body.bar_length * math.cos(bar_from_vertical(angle, geometry))


def friction_moment(angular_velocity: Any, friction: Any) -> Any:
    """Pivot friction moment (N m): viscous plus Coulomb smoothed by tanh."""
    return -(
        friction.viscous * angular_velocity
        + friction.coulomb * math.tanh(angular_velocity / friction.smoothing_speed)
    )


def damping_ratio(restitution: float) -> float:
    """Damping ratio of a linear contact whose coefficient of restitution is ``restitution``."""
    e = require_between("restitution", restitution, 0.0, 1.0, low_open=True)
    if e == 1.0:
        return 0.0
    log_e = math.log(e)
    return -log_e / math.sqrt(math.pi * math.pi + log_e * log_e)


def stop_force(length: Any, speed: float, effective_mass: Any, stops: Any) -> Any:
    """Contact force along the piston (N) from the stroke-limit stops; 0 inside the stroke."""
    if stops.min_length < length < stops.max_length:
        return 0.0
    damping = 2.0 * stops.damping_ratio * math.sqrt(stops.stiffness * effective_mass)
    if length >= stops.max_length:
        return min(0.0, -stops.stiffness * (length - stops.max_length) - damping * speed)
    return max(0.0, stops.stiffness * (stops.min_length - length) - damping * speed)


def make_body(bar_length: float, bar_mass: float, wheel_mass: float) -> "Body":
    """Validated Body: positive bar length and mass, non-negative wheel mass."""
    return Body(
        require_positive("bar_length", bar_length, "m"),
        require_positive("bar_mass", bar_mass, "kg"),
        require_between("wheel_mass", wheel_mass, 0.0, math.inf, "kg"),
    )


def moment_terms(values: dict[str, float], body: "Body", geometry: "Geometry") -> list[Any]:
    """Moment functions (angle, omega, airspeed) -> N m of the enabled effects only."""
    terms = []
    if values["gravity"]:
        g = require_finite("gravity_acceleration", values["gravity_acceleration"], "m/s^2")
        terms.append(lambda angle, omega, airspeed: gravity_moment(angle, body, geometry, g))
    if values["aero_drag"]:
        drag = Drag(values["air_density"], values["drag_area"])
        terms.append(
            lambda angle, omega, airspeed: drag_moment(angle, airspeed, body, geometry, drag)
        )
    if values["pivot_friction"]:
        friction = Friction(
            values["viscous_friction"],
            values["coulomb_friction"],
            require_positive("friction_speed", values["friction_speed"], "rad/s"),
        )
        terms.append(lambda angle, omega, airspeed: friction_moment(omega, friction))
    return terms


class InverseDynamics:
    """Motion drive: the piston force that produces the prescribed motion."""

    def __init__(self, values: Any, body: Any, geometry: Any) -> None:
        self.body, self.geometry = body, geometry
        self.inertia = inertia(body) if values["inertia"] else 0.0
        self.terms = moment_terms(values, body, geometry)
        self.gravity = values["gravity_acceleration"] if values["gravity"] else None

    def publish(self, v: Any, motion: Any) -> None:
        """Required piston force (N) and energies (J) into the values ``v`` for ``motion``
        (angle rad, rate rad/s, acceleration rad/s^2); v["piston_moment_arm"] is set."""
        angle, omega, alpha = motion
        arm = v["piston_moment_arm"]
        external = sum(term(angle, omega, v["airspeed"]) for term in self.terms)
        v["piston_force_required"] = (
            (self.inertia * alpha - external) / arm if (self.inertia or self.terms) else 0.0
        )
        v["kinetic_energy"] = 0.5 * self.inertia * omega * omega
        v["potential_energy"] = (
            gravity_potential(angle, self.body, self.geometry, self.gravity)
            if self.gravity is not None
            else 0.0
        )


class Dynamics:
    """Dynamics drive: the state equations, their events and the published outputs.

    The state y is [theta (rad), omega (rad/s), piston work (J)], plus the cap and rod
    pressures (Pa) with the hydraulics effect.
    """

    def __init__(self, values: dict[str, float], body: "Body", geometry: "Geometry") -> None:
        self.body, self.geometry = body, geometry
        self.inertia = inertia(body)
        self.terms = moment_terms(values, body, geometry)
        self.gravity = values["gravity_acceleration"] if values["gravity"] else None
        low = require_positive("stroke_min", values["stroke_min"], "m")
        high = require_positive("stroke_max", values["stroke_max"], "m")
        if not low < high:
            raise MechanismError(f"stroke_min = {low!r} m must be below stroke_max = {high!r} m")
        self.stroke = (low, high)
        self.stops = (
            Stops(
                low,
                high,
                require_positive("stop_stiffness", values["stop_stiffness"], "N/m"),
                damping_ratio(values["restitution"]),
            )
            if values["end_stops"]
            else None
        )
        self.actuator = (
            hydraulics.make_actuator(
                values["supply_pressure"],
                values["return_pressure"],
                values["bore"],
                values["rod_diameter"],
                values["bulk_modulus"],
                values["dead_volume"],
                values["valve_rated_flow"],
                values["valve_rated_pressure_drop"],
                values["max_flow"],
                low,
                high,
            )
            if values["hydraulics"]
            else None
        )
        self.initial = (
            require_finite("initial_angle", values["initial_angle"], "rad"),
            require_finite("initial_angular_velocity", values["initial_angular_velocity"], "rad/s"),
            require_finite("initial_pressure", values["initial_pressure"], "Pa"),
        )
        self.events = [
            Event("stroke_max", lambda t, y: self.piston_length(y) - high, +1),
            Event("stroke_min", lambda t, y: self.piston_length(y) - low, -1),
        ]

    def initial_state(self) -> list[float]:
        angle, omega, pressure = self.initial
        state = [angle, omega, 0.0]
        if self.actuator:
            state += [pressure, pressure]
        return state

    def piston_length(self, y: list[float]) -> float:
        """Piston length (m) at state y."""
        return kinematics.piston_motion(
            y[0], 0.0, 0.0, self.geometry.attachment_distance, self.geometry.pivot_height
        ).extension

    def piston_kinematics(self, y: list[float]) -> tuple[float, float, float]:
        """Piston length (m), rate (m/s) and moment arm (m) at state y."""
        d, h = self.geometry.attachment_distance, self.geometry.pivot_height
        piston = kinematics.piston_motion(y[0], y[1], 0.0, d, h)
        return piston.extension, piston.speed, d * h * math.sin(y[0]) / piston.extension

    def _drive_force(self, y: list[float], v: dict[str, float]) -> float:
        if self.actuator:
            return hydraulics.piston_force(y[3], y[4], self.actuator)
        return v["piston_force"]

    def _piston_forces(
        self, y: list[float], v: dict[str, float], length: float, rate: float, arm: float
    ) -> tuple[float, float]:
        """(drive force, drive plus end-stop force) along the piston (N) at state y, the
        piston's length (m), rate (m/s) and moment arm (m) given."""
        force = self._drive_force(y, v)
        on_piston = force
        if self.stops:
            on_piston += stop_force(length, rate, self.inertia / (arm * arm), self.stops)
        return force, on_piston

    def piston_force_on_bar(self, y: list[float], v: dict[str, float]) -> float:
        """The whole force along the piston on the bar at state y (N): drive and end stops."""
        length, rate, arm = self.piston_kinematics(y)
        return self._piston_forces(y, v, length, rate, arm)[1]

    def derivatives(self, y: list[float], v: dict[str, float]) -> tuple[list[float], float, float]:
        """(dy/dt, acceleration, drive force) at state y with inputs held over the step."""
        length, rate, arm = self.piston_kinematics(y)
        force, on_piston = self._piston_forces(y, v, length, rate, arm)
        moment = on_piston * arm + sum(term(y[0], y[1], v["airspeed"]) for term in self.terms)
        alpha = moment / self.inertia
        rates = [y[1], alpha, force * rate]
        if self.actuator:
            rates += hydraulics.pressure_rates(
                v["valve_command"], y[3], y[4], length, rate, self.actuator
            )
        return rates, alpha, force

    def advance(
        self,
        integrator: DormandPrince45,
        t: float,
        y: list[float],
        t_end: float,
        v: dict[str, float],
    ) -> tuple[list[float], list[Any]]:
        """Integrate from t to t_end (s) with the inputs in ``v`` held; return the state at
        t_end and the stroke limits crossed on the way, as (event name, t, piston length)."""
        for name in ("piston_force", "valve_command", "airspeed"):
            require_finite(name, v[name])
        crossings = []

        def record(event: Any, time: float, state: Any):
            crossings.append((event.name, time, self.piston_length(state)))
            return state

        y = advance_through_events(
            integrator,
            lambda time, state: self.derivatives(state, v)[0],
            t,
            y,
            t_end,
            self.events,
            record,
        )
        return y, crossings

    def publish(self, v: dict[str, float], time: float, y: list[float]) -> None:
        """The drive's outputs at state y into the values ``v``."""
        length, rate, arm = self.piston_kinematics(y)
        rates, alpha, force = self.derivatives(y, v)
        v["gear_angle"], v["gear_angular_velocity"], v["gear_angular_acceleration"] = (
            y[0],
            y[1],
            alpha,
        )
        v["piston_moment_arm"], v["piston_length"], v["piston_rate"] = arm, length, rate
        v["wheel_speed"] = v["bar_length"] * y[1]
        v["piston_force_applied"] = force
        v["piston_work"] = y[2]
        v["kinetic_energy"] = 0.5 * self.inertia * y[1] * y[1]
        v["potential_energy"] = (
            gravity_potential(y[0], self.body, self.geometry, self.gravity)
            if self.gravity is not None
            else 0.0
        )
        if self.actuator:
            v["cap_pressure"], v["rod_pressure"] = y[3], y[4]
