"""Suspension dynamics: the two-spring suspension with a sprung mass (standard library only).

Sign conventions (all displacements positive DOWNWARD, zero in the unstressed configuration
with the road at height 0; the road height r is positive UPWARD):

- y: sprung-mass (apex) displacement; z: spring-base (unsprung point) displacement;
- u = y - z: spring deflection, the u of the static model (physics/suspension.py), so the
  spring force F(u), the stiffnesses, the limit point and the branches are the static ones;
- W(t): downward load on the apex (the input ``load``; W = m g for the car's weight).

Equations, each bracketed term present only when its effect is on:

    m y''   = W(t) - F(u) [- c u']                                        (sprung mass)
    m_u z'' = F(u) [+ c u'] + m_u g - k_t (z + r)        [tyre: unsprung mass on the tyre]
    z = -r(t), z' = -r'(t)                               [road_input without tyre: the base
                                                          rides on the road]
    z = 0                                                [neither]

so with only ``dynamics`` on it is m u'' + F(u) = W(t); ``damping`` adds c u'; ``tyre``
adds a linear tyre spring k_t between the road and an unsprung mass m_u that carries its own
weight (g = 9.81 m/s^2); ``road_input`` feeds the road height r(t) and rate r'(t) into the
tyre (or directly into the spring base). The tyre force k_t (z + r) is the compression force
of the tyre; a negative value means the linear tyre would pull on the road (loss of contact is
not modelled). States: (y, y') or, with the tyre, (y, y', z, z').

Energy (J, zero in the unstressed configuration):
- kinetic  T = m y'^2 / 2 [+ m_u z'^2 / 2];
- potential V = k (s - L)^2 (both springs; s - L = -u (2h - u)/(L + s), no cancellation)
  - W(t) y (the load's potential at its current value: for a constant load, e.g. gravity on
  the sprung mass, V + T is conserved without damping and road input)
  [+ k_t (z + r)^2 / 2 - m_u g z].

Inputs inside one communication step [t0, t1] are reconstructed from their values at both
ends (the master feeds each component values at the end of the step, its sources having
already advanced): mode ``interpolate``: load linear, road height the cubic Hermite through
heights and rates at t0 and t1 (exact for cubic roads, fourth order for smooth ones);
mode ``hold``: the values at t0 held over the step (exact for loads or kerbs that jump at a
communication point, as a ``step`` LoadProfile does).

Every effect is a separate small function (spring_force_term, damping_force, tyre_force,
road_at, load_at), looked up once when the right-hand side is built from the enabled
effects; a disabled effect's function is never called.

Units: m, s, kg, N, J.
"""

from typing import Any
from collections import namedtuple

from . import suspension as statics
from ..errors import MechanismError, RangeError, require_finite, require_positive
from ..numerics.polynomials import polynomial_motion
from ..numerics.stepping import hermite
from .suspension import Spring
from collections.abc import Callable

GRAVITY = statics.GRAVITY

# Defaults (documented in the README):
DEFAULT_MASS = statics.COURSEWORK_MASS  # 211 kg: the coursework's 180 + 31 kg
# c = 2 zeta sqrt(K_t m) with zeta = 0.3 at the coursework's stable equilibrium under m g
# (u1 = 0.13746 m, tangent stiffness K_t = 12596 N/m): 0.6 sqrt(12596.3 * 211) = 978 N s/m.
DEFAULT_DAMPING = 980.0
DEFAULT_TYRE_STIFFNESS = 2.0e5  # N/m, a passenger-car tyre
DEFAULT_UNSPRUNG_MASS = 35.0  # kg, wheel, tyre, hub and brake of one corner

INPUT_MODES = ("interpolate", "hold")
# (load N, road height m, road rate m/s) at one instant
Inputs = tuple[float, float, float]
NEAR, FAR, BETWEEN = statics.NEAR, statics.FAR, 2

Effects = namedtuple("Effects", "damping tyre road_input")
Model = namedtuple("Model", "spring mass damping tyre_stiffness unsprung_mass effects")
Motion = namedtuple(
    "Motion",
    "deflection velocity acceleration sprung_displacement unsprung_displacement "
    "tyre_force kinetic_energy potential_energy",
)


def make_model(
    spring: Spring,
    mass: float,
    damping: float = 0.0,
    tyre_stiffness: float = DEFAULT_TYRE_STIFFNESS,
    unsprung_mass: float = DEFAULT_UNSPRUNG_MASS,
    effects: "Effects" = Effects(False, False, False),
) -> "Model":
    """Validated Model; only the parameters of enabled effects are checked."""
    mass = require_positive("mass", mass, "kg")
    if effects.damping:
        damping = require_finite("damping_coefficient", damping, "N.s/m")
        if damping < 0.0:
            raise RangeError(
                "damping_coefficient", damping, "[0, inf)", "N.s/m", "must not be negative"
            )
    if effects.tyre:
        tyre_stiffness = require_positive("tyre_stiffness", tyre_stiffness, "N/m")
        unsprung_mass = require_positive("unsprung_mass", unsprung_mass, "kg")
    return Model(
        spring,
        mass,
        float(damping),
        float(tyre_stiffness),
        float(unsprung_mass),
        Effects(*(bool(e) for e in effects)),
    )


# --- the terms: one small function each ----------------------------------------------------


def spring_force_term(deflection: float, spring: Spring) -> float:
    """F(u) (N), the static model's spring force."""
    return statics.spring_force(deflection, spring)


def damping_force(damping: float, relative_velocity: float) -> float:
    """Damper force c u' (N), opposing the spring's compression rate."""
    return damping * relative_velocity


def tyre_force(tyre_stiffness: float, unsprung_displacement: float, road_height: float) -> float:
    """Tyre compression force k_t (z + r) (N), upward on the unsprung mass."""
    return tyre_stiffness * (unsprung_displacement + road_height)


def spring_energy(deflection: float, spring: Spring) -> float:
    """Elastic energy of both springs k (s - L)^2 (J), accurate at small deflection."""
    L, k, _ = spring
    h = statics.rest_height(spring)
    s = statics.spring_length(deflection, spring)
    stretch = -deflection * (2.0 * h - deflection) / (L + s)  # s - L
    return k * stretch * stretch


# --- inputs inside one communication step -------------------------------------------------


class StepInputs:
    """Load W(t) and road r(t), r'(t), r''(t) over one communication step [t0, t1].

    ``set_step`` loads the values at both ends; the right-hand side keeps one instance and
    reads it through load_at and road_at, so it is built once, not per step.
    """

    __slots__ = ("mode", "t0", "load0", "load_slope", "road")

    def __init__(self, mode: str = "interpolate") -> None:
        if mode not in INPUT_MODES:
            raise MechanismError(
                f"input_interpolation = {mode!r} is not one of {', '.join(INPUT_MODES)}"
            )
        self.mode = mode
        self.set_constant(0.0, 0.0, 0.0, 0.0)

    def set_constant(self, t: float, load: float, road_height: float, road_rate: float) -> None:
        """Inputs frozen at their values at ``t`` (initialisation, outputs at an instant)."""
        self.t0, self.load0, self.load_slope = t, load, 0.0
        self.road: tuple[float, ...] = (road_height, road_rate, 0.0, 0.0)

    def set_step(self, t0: float, t1: float, start: Inputs, end: Inputs) -> None:
        """Inputs over [t0, t1] from (load, road_height, road_rate) at t0 and at t1."""
        load0, r0, rate0 = start
        load1, r1, rate1 = end
        if self.mode == "hold" or not t1 > t0:
            self.set_constant(t0, load0, r0, rate0)
            return
        step = t1 - t0
        self.t0, self.load0, self.load_slope = t0, load0, (load1 - load0) / step
        # Cubic Hermite r(t0 + tau) = a0 + a1 tau + a2 tau^2 + a3 tau^3 through the heights
        # and rates at both ends.
        self.road = hermite(step, (r0, rate0), (r1, rate1))


def load_at(inputs: StepInputs, t: float) -> float:
    """Load W (N) at time t inside the current step."""
    return inputs.load0 + inputs.load_slope * (t - inputs.t0)


def road_at(inputs: Any, t: float) -> Any:
    """Road height (m), rate (m/s), second rate (m/s^2) at time t inside the current step."""
    return polynomial_motion(inputs.road, t - inputs.t0)


# --- the system built from the enabled effects --------------------------------------------


def build_rhs(model: "Model", inputs: StepInputs) -> Callable:
    """y' = rhs(t, y) for the enabled effects, composed once (module functions looked up now)."""
    spring, m = model.spring, model.mass
    force, load, effects = spring_force_term, load_at, model.effects
    if effects.damping:
        damp, c = damping_force, model.damping

        def suspension(u: Any, v: Any):
            return force(u, spring) + damp(c, v)
    else:

        def suspension(u: Any, v: Any):
            return force(u, spring)

    if effects.tyre:
        tyre, kt, mu = tyre_force, model.tyre_stiffness, model.unsprung_mass
        weight = mu * GRAVITY
        if effects.road_input:
            road = road_at

            def rhs(t: float, y: Any):
                f = suspension(y[0] - y[2], y[1] - y[3])
                return [
                    y[1],
                    (load(inputs, t) - f) / m,
                    y[3],
                    (f + weight - tyre(kt, y[2], road(inputs, t)[0])) / mu,
                ]
        else:

            def rhs(t: float, y: Any):
                f = suspension(y[0] - y[2], y[1] - y[3])
                return [
                    y[1],
                    (load(inputs, t) - f) / m,
                    y[3],
                    (f + weight - tyre(kt, y[2], 0.0)) / mu,
                ]
    elif effects.road_input:
        road = road_at

        def rhs(t: float, y: Any):
            r, rate, _ = road(inputs, t)
            return [y[1], (load(inputs, t) - suspension(y[0] + r, y[1] + rate)) / m]
    else:

        def rhs(t: float, y: Any):
            return [y[1], (load(inputs, t) - suspension(y[0], y[1])) / m]

    return rhs


def build_deflection(model: "Model", inputs: StepInputs) -> Callable:
    """u(t, y): the spring deflection, for event functions."""
    if model.effects.tyre:
        return lambda t, y: y[0] - y[2]
    if model.effects.road_input:
        road = road_at
        return lambda t, y: y[0] + road(inputs, t)[0]
    return lambda t, y: y[0]


def base_motion(model: "Model", inputs: StepInputs, t: float, y: list[float]) -> tuple:
    """(z, z', z'') of the spring base for the state y at time t (z'' needs the rhs)."""
    if model.effects.tyre:
        return y[2], y[3], None
    if model.effects.road_input:
        r, rate, rate2 = road_at(inputs, t)
        return -r, -rate, -rate2
    return 0.0, 0.0, 0.0


def initial_state(
    model: "Model", deflection: float, velocity: float, inputs: StepInputs, t: float
) -> list[float]:
    """State for a spring deflection u and rate u' at time t.

    Without the tyre the base is where the road puts it. With the tyre the unsprung mass
    starts at rest, the tyre carrying the spring force plus the unsprung weight:
    z = (F(u) + m_u g) / k_t - r. So u = u1 with F(u1) = W, u' = 0 starts at rest in
    equilibrium.
    """
    u = require_finite("initial_deflection", deflection, "m")
    v = require_finite("initial_velocity", velocity, "m/s")
    r = road_at(inputs, t)[:2] if model.effects.road_input else (0.0, 0.0)
    if model.effects.tyre:
        z = (
            statics.spring_force(u, model.spring) + model.unsprung_mass * GRAVITY
        ) / model.tyre_stiffness - r[0]
        return [u + z, v, z, 0.0]
    if model.effects.road_input:
        return [u - r[0], v - r[1]]
    return [u, v]


def energy(
    model: "Model", inputs: StepInputs, t: float, y: list[float]
) -> tuple[float, float, float]:
    """(kinetic T, potential V, scale) in J at state y and time t.

    scale is the sum of the magnitudes of the terms of T + V, a measure of the energy in
    play against which a change of T + V can be judged.
    """
    z = (
        y[2]
        if model.effects.tyre
        else (-road_at(inputs, t)[0] if model.effects.road_input else 0.0)
    )
    kinetic = 0.5 * model.mass * y[1] * y[1]
    elastic = spring_energy(y[0] - z, model.spring)
    load = load_at(inputs, t) * y[0]
    potential = elastic - load
    scale = kinetic + elastic + abs(load)
    if model.effects.tyre:
        r = road_at(inputs, t)[0] if model.effects.road_input else 0.0
        tyre = 0.5 * model.tyre_stiffness * (z + r) * (z + r)
        weight = model.unsprung_mass * GRAVITY * z
        unsprung = 0.5 * model.unsprung_mass * y[3] * y[3]
        kinetic += unsprung
        potential += tyre - weight
        scale += unsprung + tyre + abs(weight)
    return kinetic, potential, scale


def motion(model: "Model", inputs: StepInputs, rhs: Callable, t: float, y: list[float]) -> "Motion":
    """Every output of the dynamic model for state y at time t (a Motion)."""
    derivative = rhs(t, y)
    z, z_rate, z_rate2 = base_motion(model, inputs, t, y)
    if z_rate2 is None:
        z_rate2 = derivative[3]
    tyre = 0.0
    if model.effects.tyre:
        r = road_at(inputs, t)[0] if model.effects.road_input else 0.0
        tyre = tyre_force(model.tyre_stiffness, z, r)
    kinetic, potential, _ = energy(model, inputs, t, y)
    return Motion(
        y[0] - z, y[1] - z_rate, derivative[1] - z_rate2, y[0], z, tyre, kinetic, potential
    )


def passive(model: "Model", inputs: StepInputs) -> bool:
    """True when T + V cannot grow over the current step: no road input, constant load."""
    return not model.effects.road_input and inputs.load_slope == 0.0


def region(deflection: float, spring: Spring) -> int:
    """Position region: NEAR (u < u*), FAR (u > 2h - u*) or BETWEEN (the unstable band)."""
    u_star = statics.limit_point(spring).deflection
    if deflection < u_star:
        return NEAR
    if deflection > 2.0 * statics.rest_height(spring) - u_star:
        return FAR
    return BETWEEN


def snap_boundaries(spring: Spring) -> tuple[float, float]:
    """(u*, 2h - u*): the end of the near stable region and the start of the far one."""
    u_star = statics.limit_point(spring).deflection
    return u_star, 2.0 * statics.rest_height(spring) - u_star


def snap_function(model: "Model", inputs: StepInputs, side: int) -> Callable:
    """Event function for leaving the stable region last visited (``side`` NEAR or FAR).

    From NEAR it crosses zero upward when u reaches the far region (2h - u*); from FAR it
    crosses zero downward when u comes back below u*.
    """
    deflection = build_deflection(model, inputs)
    near_end, far_start = snap_boundaries(model.spring)
    if side == NEAR:
        return lambda t, y: deflection(t, y) - far_start
    return lambda t, y: deflection(t, y) - near_end
