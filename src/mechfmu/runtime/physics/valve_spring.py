"""Valve spring dynamics: the valve as a mass on its spring, pushed open by the rocker
through a compliant contact and stopped by a compliant seat (standard library only: runs
inside ValveSpring.fmu).

Coordinates (SI units throughout):

- x: valve lift (m), opening positive, 0 = closed on the (undeformed) seat; v = dx/dt (m/s);
- L(t): position of the rocker's valve end (m), the kinematic valve lift of ValveTrain (a
  prescribed motion), with L'(t) (m/s) and L''(t) (m/s^2).

Forces on the valve along its axis (N, positive opening):

    spring   F_s = F0 + k x                                    (closes the valve)
    contact  d = L - x - lash                                  (penetration, m)
             F_c = max(0, k_c d + c_c d')   where d > 0, else 0
    seat     F_seat = max(0, -k_s x - c_s v) where x < 0, else 0

    m x'' = F_c + F_seat - F_s

Both contacts are Kelvin-Voigt (a spring and a dashpot in parallel) clipped at zero: a
contact can push, never pull. Without the clip the dashpot would pull the valve back just
before it leaves the rocker (for d -> 0+ with d' < 0 the force tends to c_c d' < 0), so it
would hold on to the valve and delay the very separation (float) this model is built to
show, and it would glue a rebounding valve to its seat. The clip releases the valve where
the force reaches zero, slightly before the surfaces part (d or x reaches 0 later).

The force law is piecewise smooth. Its kinks and jumps are where a contact force switches on
or off: the switch functions contact_switch = min(k_c d, k_c d + c_c d') and
seat_switch = min(-k_s x, -k_s x - c_s v) are positive exactly where the force is; they
cross zero at an impact (d or x passing 0 towards contact, where the dashpot makes the force
jump to c_c d' or -c_s v) and at a release. The integration is split into segments at these
crossings: within a segment each contact is engaged (its unclipped Kelvin-Voigt force acts)
or idle (Engaged, Modes), so the right-hand side is smooth and tight tolerances (1e-10) are
reachable, also for the implicit Radau method, whose Newton iteration cannot converge
across a jump of the force. Each segment ends at the terminal event of a switch function
crossing towards the other mode; the contact flips there and the integration restarts. A
third event, d falling through 0, locates the separation of valve and rocker (float).

Energy (J): kinetic T = m v^2 / 2; elastic V = F0 x + k x^2 / 2 (the valve spring, relative
to the closed valve) + k_c d^2 / 2 (d > 0) + k_s x^2 / 2 (x < 0). The rocker's power on the
valve system is F_c L', so the contact work W (the third state, W' = F_c L') satisfies
W(t) - W(0) = T + V - (T + V)(0) + (energy the dashpots dissipated): with both dashpots off
the balance is exact, and with them on T + V can never gain more than W (the FMU refuses a
step that does: an unstable integration).

Drive and exact integration: L(t) comes from the rocker inputs interpolated across the step
(StepDrive) or, with the drive from the camshaft (CamshaftStepDrive), from ValveTrain's closed
forms at the camshaft's angle, the cam law's segment boundaries located in time. Between
switches the valve is then a linear oscillator m x'' + c x' + K x = f(t) with f a polynomial
on each drive piece, which valve_exact.integrate_exact solves in closed form
(numerics/linear_ode.py), locating the switches on the closed form (the integrator value
"exact").

Travel limit: the valve can open only so far before its spring retainer meets the valve guide
(or the spring reaches coil bind), max_valve_lift, 12.5 mm by default (2 mm beyond the 10.5
mm of the default cam through the rocker). That is a collision that damages a valve train,
not an operating regime, so the model has no contact law there: the FMU refuses the step in
which the valve would reach it (the terminal event travel_limit, x rising through the limit),
naming the limit, the time and whether the valve had floated.

Neglected: gravity on the valve (about 1 N against hundreds of N of spring force), friction
in the valve guide, the spring's own surge modes (its moving mass is lumped into m), the
rocker's reaction (the rocker end is a prescribed motion), and the drive's compliance other
than the lumped contact stiffness.
"""

import math
from collections import namedtuple

from ..errors import (
    MechanismError,
    RangeError,
    require_finite,
    require_positive,
)
from ..numerics import polynomials, roots
from ..numerics.integrators import EVENT_TOLERANCE, Event
from ..numerics.polynomials import polynomial_motion
from ..numerics.stepping import hermite, hermite_nodes
from . import cam_laws
from . import valve_train as vt
from typing import Any
from collections.abc import Callable

Triple = tuple[float, float, float]  # a coordinate (m or rad) and its two rates at one instant

# Defaults (N, m, kg, s), documented in the README and the FMU:
DEFAULT_MASS = 0.1  # kg: valve, retainer and a third of the spring, as ValveTrain's
DEFAULT_SPRING_STIFFNESS = 50e3  # N/m, as ValveTrain's valve spring
DEFAULT_SPRING_PRELOAD = 300.0  # N at the closed valve, as ValveTrain's
# Pushrod valve trains are 1e6 .. 1e7 N/m stiff referred to the valve (pushrod, rocker and
# its shaft in series): 1e7 N/m puts the valve on the rocker at sqrt(k_c/m)/(2 pi) = 1.6 kHz.
DEFAULT_CONTACT_STIFFNESS = 1e7
# c_c = 2 zeta sqrt(k_c m) with zeta = 0.05, a lightly damped steel contact: 100 N s/m.
DEFAULT_CONTACT_DAMPING = 100.0
# The valve head on its seat insert is a short, wide steel contact, an order of magnitude
# stiffer than the pushrod chain: 1e8 N/m (5 kHz with the valve mass).
DEFAULT_SEAT_STIFFNESS = 1e8
# c_s = 2 zeta sqrt(k_s m): 300 N s/m is zeta = 0.047, a restitution of about 0.86.
DEFAULT_SEAT_DAMPING = 300.0
DEFAULT_LASH = 0.0  # m: a hydraulic lash adjuster keeps the rocker on the valve
# m: retainer-to-guide clearance at the closed valve: the default cam's 10.5 mm of valve lift
# plus 2 mm, a usual margin to coil bind
DEFAULT_MAX_LIFT = 0.0125

INPUT_MODES = ("interpolate", "hold")
DRIVES = ("rocker", "camshaft")  # what moves the rocker's valve end (the drive parameter)

Parameters = namedtuple(
    "Parameters",
    "mass spring_stiffness spring_preload contact_stiffness contact_damping "
    "seat_stiffness seat_damping lash",
)
Forces = namedtuple("Forces", "acceleration contact seat spring penetration")
Phase = namedtuple("Phase", "touching open landed")
Engaged = namedtuple("Engaged", "contact seat")
CONTACT, SEAT = 0, 1
SWITCH_EVENTS = ("contact_switch", "seat_switch")  # event names, indexed by CONTACT, SEAT
TRAVEL_LIMIT = "travel_limit"  # event name: the valve lift rising through max_valve_lift
OPENING = "opening"  # event name: the valve lift rising through 0 (leaving the seat)
Happening = namedtuple("Happening", "kind time lift velocity drive")
FLOAT, REBOUND, SEAT_IMPACT, BOUNCE = "float", "rebound", "seat impact", "bounce"


def _non_negative(name: str, value: float, unit: str) -> float:
    number = require_finite(name, value, unit)
    if number < 0.0:
        raise RangeError(name, number, "[0, inf)", unit, "must not be negative")
    return number


def make_parameters(
    mass: float = DEFAULT_MASS,
    spring_stiffness: float = DEFAULT_SPRING_STIFFNESS,
    spring_preload: float = DEFAULT_SPRING_PRELOAD,
    contact_stiffness: float = DEFAULT_CONTACT_STIFFNESS,
    contact_damping: float = DEFAULT_CONTACT_DAMPING,
    seat_stiffness: float = DEFAULT_SEAT_STIFFNESS,
    seat_damping: float = DEFAULT_SEAT_DAMPING,
    lash: float = DEFAULT_LASH,
) -> "Parameters":
    """Validated Parameters; RangeError names the parameter, its value and its range.

    The mass and the three stiffnesses must be positive (without them there is no equation
    of motion, no drive and no seat); preload, dampings and lash must not be negative.
    """
    return Parameters(
        require_positive("valve_mass", mass, "kg"),
        require_positive("spring_stiffness", spring_stiffness, "N/m"),
        _non_negative("spring_preload", spring_preload, "N"),
        require_positive("contact_stiffness", contact_stiffness, "N/m"),
        _non_negative("contact_damping", contact_damping, "N.s/m"),
        require_positive("seat_stiffness", seat_stiffness, "N/m"),
        _non_negative("seat_damping", seat_damping, "N.s/m"),
        _non_negative("lash", lash, "m"),
    )


# --- the force laws: one small function each ---------------------------------------------


def spring_force(p: "Parameters", lift: float) -> float:
    """Valve spring force F0 + k x (N), closing the valve."""
    return p.spring_preload + p.spring_stiffness * lift


def penetration(p: "Parameters", rocker_lift: float, lift: float) -> float:
    """d = L - x - lash (m): how far the rocker end presses into the valve tip."""
    return rocker_lift - lift - p.lash


def contact_force(p: "Parameters", depth: float, depth_rate: float) -> float:
    """Rocker-on-valve force max(0, k_c d + c_c d') for d > 0, else 0 (N)."""
    if depth <= 0.0:
        return 0.0
    force = p.contact_stiffness * depth + p.contact_damping * depth_rate
    return force if force > 0.0 else 0.0


def seat_force(p: "Parameters", lift: float, velocity: float) -> float:
    """Seat-on-valve force max(0, -k_s x - c_s v) for x < 0, else 0 (N)."""
    if lift >= 0.0:
        return 0.0
    force = -p.seat_stiffness * lift - p.seat_damping * velocity
    return force if force > 0.0 else 0.0


def contact_switch(p: "Parameters", depth: float, depth_rate: float) -> float:
    """Positive exactly where the contact force is (N); zero where it switches."""
    spring = p.contact_stiffness * depth
    damped = spring + p.contact_damping * depth_rate
    return damped if damped < spring else spring  # min() without a call: the same on a tie


def seat_switch(p: "Parameters", lift: float, velocity: float) -> float:
    """Positive exactly where the seat force is (N); zero where it switches."""
    spring = -p.seat_stiffness * lift
    damped = spring - p.seat_damping * velocity
    return damped if damped < spring else spring


def forces(
    p: "Parameters", rocker_lift: float, rocker_velocity: float, lift: float, velocity: float
) -> "Forces":
    """Forces (acceleration m/s^2, contact N, seat N, spring N, penetration m) at a state."""
    depth = penetration(p, rocker_lift, lift)
    contact = contact_force(p, depth, rocker_velocity - velocity)
    seat = seat_force(p, lift, velocity)
    spring = spring_force(p, lift)
    return Forces((contact + seat - spring) / p.mass, contact, seat, spring, depth)


def kinetic_energy(p: "Parameters", velocity: float) -> float:
    """m v^2 / 2 (J)."""
    return 0.5 * p.mass * velocity * velocity


def elastic_energy(p: "Parameters", rocker_lift: float, lift: float) -> float:
    """Energy stored in the valve spring (relative to the closed valve), the contact and
    the seat (J)."""
    spring, contact, seat = _elastic_parts(p, rocker_lift, lift)
    return spring + contact + seat


def _elastic_parts(p: "Parameters", rocker_lift: float, lift: float) -> tuple[float, float, float]:
    """(spring, contact, seat) stored energies (J) at a state: the valve spring's relative to
    the closed valve (negative below it), and the contact's and the seat's (0 where not
    engaged)."""
    depth = penetration(p, rocker_lift, lift)
    spring = lift * (p.spring_preload + 0.5 * p.spring_stiffness * lift)
    contact = 0.5 * p.contact_stiffness * depth * depth if depth > 0.0 else 0.0
    seat = 0.5 * p.seat_stiffness * lift * lift if lift < 0.0 else 0.0
    return spring, contact, seat


def energy_terms(
    p: "Parameters", rocker_lift: float, lift: float, velocity: float
) -> tuple[float, float]:
    """(T + V, scale) in J at a state: kinetic_energy + elastic_energy, and the sum of the
    magnitudes of those energy terms, the energy in play against which a change of T + V is
    judged (the step's energy check asks for both at each end of a step)."""
    kinetic = kinetic_energy(p, velocity)
    spring, contact, seat = _elastic_parts(p, rocker_lift, lift)
    return kinetic + (spring + contact + seat), kinetic + abs(spring) + contact + seat


def energy_gain(
    p: "Parameters", rocker0: float, y0: list[float], rocker1: float, y1: list[float]
) -> tuple[float, float]:
    """(gain, scale) in J over a step from state y0 = (x, v, W) with the rocker end at
    ``rocker0`` (m) to y1 with it at ``rocker1``: the growth of T + V beyond the contact
    work, (T + V)(t1) - (T + V)(t0) - (W(t1) - W(t0)), which the exact solution keeps <= 0
    (the dashpots only dissipate), and the energy in play it is judged against (the larger
    energy_terms scale at either end, or the work if larger)."""
    start, start_scale = energy_terms(p, rocker0, y0[0], y0[1])
    end, end_scale = energy_terms(p, rocker1, y1[0], y1[1])
    work = y1[2] - y0[2]
    return end - start - work, max(start_scale, end_scale, abs(work))


# --- static equilibrium ------------------------------------------------------------------


def static_equilibrium(p: "Parameters", rocker_lift: float, rocker_velocity: float) -> float:
    """Valve lift x (m) where the forces balance with the valve moving with the rocker.

    With v = L' the contact dashpot is idle, and every force is linear in x on each side of
    its switch, so the balance F_c + F_seat = F_s is solved for each of the four
    combinations of contact and seat on or off:

        x = (k_c (L - lash) [contact] - c_s L' [seat] - F0) / (k + k_c [contact] + k_s [seat])

    and the combination whose solution agrees with it (each force on exactly where its
    switch function is positive) is taken. The net force decreases strictly with x, so
    exactly one does, except when a rocker moving down (L' < 0) makes the seat dashpot's
    force jump at x = 0; then the equilibrium is the seat surface, x = 0.
    """
    L = require_finite("rocker_lift", rocker_lift, "m")
    rate = require_finite("rocker_velocity", rocker_velocity, "m/s")
    for contact in (True, False):
        for seat in (True, False):
            numerator = -p.spring_preload
            stiffness = p.spring_stiffness
            if contact:
                numerator += p.contact_stiffness * (L - p.lash)
                stiffness += p.contact_stiffness
            if seat:
                numerator -= p.seat_damping * rate
                stiffness += p.seat_stiffness
            x = numerator / stiffness
            if (contact_switch(p, penetration(p, L, x), 0.0) > 0.0) == contact and (
                seat_switch(p, x, rate) > 0.0
            ) == seat:
                return x
    return 0.0


# --- the drive inside one communication step ---------------------------------------------


class StepDrive:
    """The rocker-end motion L(t), L'(t), L''(t) over one communication step [t0, t1].

    The FMU receives (L, L', L'') at the end of each step (the master's Gauss-Seidel order:
    the sources have already advanced). ``interpolate``: the quintic Hermite polynomial
    through (L, L', L'') at both ends (exact for quintic motions; O(step^6) for smooth ones,
    O(step^3) across a jump of the jerk, as where a 3-4-5 cam law meets a dwell).
    ``hold``: the values at t0 held, i.e. the acceleration L''(t0) held and L, L' its
    consistent Taylor expansion from t0 (exact for motions with constant acceleration over
    the step; the next step starts from the values given at its own start).
    The right-hand side keeps one instance and reads it through its ``at``.
    """

    __slots__ = ("mode", "t0", "coefficients", "current")

    def __init__(self, mode: str = "interpolate") -> None:
        if mode not in INPUT_MODES:
            raise MechanismError(
                f"input_interpolation = {mode!r} is not one of {', '.join(INPUT_MODES)}"
            )
        self.mode = mode
        self.set_constant(0.0, (0.0, 0.0, 0.0))

    def set_constant(self, t: float, start: tuple[float, float, float]) -> None:
        """The motion from (L, L', L'') at t with constant acceleration."""
        lift, rate, acceleration = start
        self.t0 = t
        self.coefficients: tuple[float, ...] = (lift, rate, 0.5 * acceleration)
        self.current: tuple | None = None

    def set_step(self, t0: float, t1: float, start: Triple, end: Triple) -> None:
        """The motion over [t0, t1] from (L, L', L'') at t0 and at t1."""
        if self.mode == "hold" or not t1 > t0:
            self.set_constant(t0, start)
            return
        self.t0, self.coefficients = t0, hermite(t1 - t0, start, end)
        self.current = None

    def at(self, t: float) -> tuple[float, float, float]:
        """(L m, L' m/s, L'' m/s^2) at time t (s) inside the current step (inside the piece
        the exact integrator is on: that piece's polynomial, what it integrates)."""
        if self.current is not None and self.current[0] <= t <= self.current[1]:
            return polynomial_motion(self.current[2], t - self.current[0])
        return polynomial_motion(self.coefficients, t - self.t0)

    def breakpoints(self, t0: float, t1: float) -> list[float]:
        """Times in (t0, t1) where a derivative of L jumps: none inside a step."""
        return []

    def constant(self, a: float, b: float) -> bool:
        """Whether L stands still over [a, b] (s): not known of the inputs' interpolant."""
        return False

    def piece(self, a: float, b: float) -> tuple[float, ...]:
        """Coefficients of L(a + tau) (m, tau in s) over [a, b] inside the current step
        (remembered for ``at`` until the next step)."""
        coefficients = polynomials.shift(self.coefficients, a - self.t0)
        self.current = (a, b, coefficients)
        return coefficients


# --- the drive from the camshaft: ValveTrain's closed forms inside ValveSpring -------------

_SEGMENT_NAMES = ("rise", "high dwell", "return", "low dwell")


def _segment_starts(profile: "cam_laws.CamProfile") -> tuple[float, float, float, float]:
    """Local camshaft angles (rad from rise_start) where rise, high dwell, return and low
    dwell start."""
    rise_end = profile.rise_angle
    return_start = rise_end + profile.high_dwell_angle
    return (0.0, rise_end, return_start, return_start + profile.return_angle)


class CamshaftStepDrive:
    """The rocker-end motion from the camshaft's motion over one communication step.

    The FMU receives the camshaft's (angle, speed, acceleration) at the end of each step.
    The angle over the step is a polynomial: ``interpolate`` the quintic Hermite through
    both ends (exact at constant acceleration), ``hold`` the start's values at constant
    acceleration. The rocker's valve end follows from the angle by ValveTrain's closed forms
    (cam_laws.follower_motion, valve_train.forward): L, L', L'' at any time of the step.
    ``breakpoints`` are the times where the cam law changes segment (the jerk jumps);
    ``piece`` the quintic Hermite of L through its exact values at both ends of a piece that
    lies inside one segment.
    """

    __slots__ = (
        "mode",
        "profile",
        "geometry",
        "closed_height",
        "boundaries",
        "t0",
        "angle",
        "known",
        "held",
        "current",
        "end",
        "span",
        "starts",
        "moving",
    )

    def __init__(
        self,
        profile: "cam_laws.CamProfile",
        geometry: "vt.ValveGeometry",
        mode: str = "interpolate",
    ) -> None:
        if mode not in INPUT_MODES:
            raise MechanismError(
                f"input_interpolation = {mode!r} is not one of {', '.join(INPUT_MODES)}"
            )
        self.mode, self.profile, self.geometry = mode, profile, geometry
        self.closed_height = vt.rest_position(geometry)[1]
        # rad from rise_start: where rise, high dwell, return and low dwell start; and per
        # moving segment (0 rise, 2 return) its start, its length, the offset from its start
        # beyond which an angle lies just before it, and its name in cam_laws (worked out
        # once: the closed forms run at every point of the drive's fit)
        self.starts = _segment_starts(profile)
        self.moving = {
            index: (
                self.starts[index],
                length,
                length + 0.5 * (cam_laws.TAU - length),
                cam_laws.SEGMENTS[index // 2],
            )
            for index, length in ((0, profile.rise_angle), (2, profile.return_angle))
        }
        # rad in [0, 2 pi): the camshaft angles where the cam law changes segment
        self.boundaries = sorted(
            {cam_laws.reduce_angle(profile.rise_start + a) for a in self.starts}
        )
        self.known: dict[tuple, tuple[float, float, float]] = {}
        # (camshaft motion, its segment, (L, L', L'')) last asked for without a segment: the
        # held inputs, asked for several times a step (resume, publish, valve_lift_rate)
        self.held: tuple = (None, 0, None)
        self.set_step(0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def set_step(self, t0: float, t1: float, start: Triple, end: Triple) -> None:
        """The camshaft over [t0, t1] from its (angle rad, speed rad/s, acceleration
        rad/s^2) at t0 and at t1."""
        self.t0 = t0
        self.current: tuple | None = None
        self.span: tuple | None = None  # segment's (a, b, index)
        if self.mode == "hold" or not t1 > t0:
            self.angle: tuple[float, ...] = (start[0], start[1], 0.5 * start[2])
            self.end: tuple = (None, None)
        else:
            self.angle = hermite(t1 - t0, start, end)
            self.end = (t1, tuple(end))

    def camshaft(self, t: float) -> tuple[float, float, float]:
        """(angle rad, speed rad/s, acceleration rad/s^2) at time t (s): at the end of an
        interpolated step the inputs given for it, as they are (the polynomial meets them
        up to rounding; so the drive there is the one the outputs are published with)."""
        if t == self.end[0]:
            return self.end[1]
        return polynomial_motion(self.angle, t - self.t0)

    def motion(self, shaft: tuple[float, float, float], index: int | None = None) -> tuple:
        """(L m, L' m/s, L'' m/s^2) for the camshaft motion ``shaft``, on segment ``index``
        (None: the segment the angle lies in, as ValveTrain). Remembered for the last few
        calls (a piece's end is the next piece's start; on the dwells L is constant), and
        for the same tuple ``shaft`` asked for again without a segment."""
        if index is None:
            if shaft is self.held[0]:
                return self.held[2]
            index = self.segment_index(shaft[0])
            motion = self.motion(shaft, index)
            self.held = (shaft, index, motion)
            return motion
        key = (index,) if index in (1, 3) else (index, *shaft)
        known = self.known.get(key)
        if known is not None:
            return known
        if len(self.known) > 16:  # the dwells' and the newest half kept
            kept = list(self.known.items())
            self.known = {k: v for k, v in kept[:8] if len(k) == 1} | dict(kept[8:])
        motion = self.known[key] = self.closed_form(shaft, index)
        return motion

    def segment_index(self, camshaft_angle: float) -> int:
        """0 rise, 1 high dwell, 2 return, 3 low dwell at ``camshaft_angle`` (rad), closed on
        the left as cam_laws.cam_lift."""
        local = cam_laws.reduce_angle(camshaft_angle - self.profile.rise_start)
        starts = self.starts
        for index in (3, 2, 1):
            if local >= starts[index]:
                return index
        return 0

    def cam_lift(self, index: int, camshaft_angle: float) -> tuple[float, float, float]:
        """(s m, s1 m/rad, s2 m/rad^2) of segment ``index`` at ``camshaft_angle`` (rad),
        clamped to the segment: at a boundary, the one-sided limit from inside the
        segment."""
        if index == 1:
            return self.profile.lift, 0.0, 0.0
        if index == 3:
            return 0.0, 0.0, 0.0
        start, length, before, segment = self.moving[index]
        offset = cam_laws.reduce_angle(camshaft_angle - self.profile.rise_start - start)
        if offset > before:  # just before the segment's start
            offset -= cam_laws.TAU
        lift = cam_laws.segment_lift(self.profile, segment, offset / length)
        return lift.s, lift.s1, lift.s2

    def closed_form(self, shaft: tuple[float, float, float], index: int) -> Triple:
        """(L m, L' m/s, L'' m/s^2) by ValveTrain's closed forms for the camshaft motion
        ``shaft`` (rad, rad/s, rad/s^2) on segment ``index`` (not remembered: ``motion``
        remembers)."""
        angle, speed, acceleration = shaft
        s, s1, s2 = self.cam_lift(index, angle)
        train = vt.motion_from_tappet(
            self.geometry,
            self.closed_height,
            s,
            s1 * speed,
            s2 * speed * speed + s1 * acceleration,
        )
        return train.valve_lift, train.valve_velocity, train.valve_acceleration

    def valve_lift_rate(self, shaft: tuple[float, float, float]) -> float:
        """dL/dtheta (m/rad) of the rocker's valve end at the camshaft motion ``shaft``
        (angle rad, speed rad/s, acceleration rad/s^2), on the segment ValveTrain's closed
        form uses there: what turns the contact force into the camshaft torque. L' / speed
        where the camshaft turns (its motion is known: the outputs were just published
        with it), 0 on a dwell."""
        index = self.held[1] if shaft is self.held[0] else self.segment_index(shaft[0])
        if index in (1, 3):
            return 0.0
        if shaft[1] != 0.0:
            return self.motion(shaft, index)[1] / shaft[1]
        s, s1, _ = self.cam_lift(index, shaft[0])
        return vt.valve_lift_rate(self.geometry, self.closed_height, s, s1)

    def at(self, t: float) -> tuple[float, float, float]:
        """(L m, L' m/s, L'' m/s^2) at time t (s) inside the current step: inside the piece
        the exact integrator is on, that piece's quintic (what it integrates, so that events
        and the happenings judged there agree), else the closed forms."""
        if self.current is not None and self.current[0] <= t <= self.current[1]:
            return polynomial_motion(self.current[2], t - self.current[0])
        return self.motion(self.camshaft(t))

    def breakpoints(self, t0: float, t1: float) -> list[float]:
        """Sorted times in (t0, t1) (s) where the camshaft angle crosses a boundary of the
        cam law's segments (located to EVENT_TOLERANCE), found between BREAKPOINT_SAMPLES
        samples of the angle (monotone between them at any plausible speed)."""
        tau0, span = t0 - self.t0, t1 - t0
        boundaries = self.boundaries
        if tau0 >= 0.0 and span > 0.0:  # the angles' range bounded first (most steps: none)
            start_angle = polynomials.polynomial(self.angle, tau0)
            down, up = polynomials.change_bounds(self.angle, tau0, tau0 + span)
            if up - down < MAX_REVOLUTIONS * cam_laws.TAU:
                # the boundaries that may lie in the range, sought between the samples below
                boundaries = [
                    boundary
                    for boundary in boundaries
                    if math.ceil((start_angle + down - boundary) / cam_laws.TAU)
                    <= math.floor((start_angle + up - boundary) / cam_laws.TAU)
                ]
                if not boundaries:
                    return []
        taus = [tau0 + span * i / BREAKPOINT_SAMPLES for i in range(BREAKPOINT_SAMPLES + 1)]
        angles = [polynomials.polynomial(self.angle, tau) for tau in taus]
        turned = (max(angles) - min(angles)) / cam_laws.TAU
        if not turned <= MAX_REVOLUTIONS:  # also NaN and inf
            raise RangeError(
                "camshaft_angle",
                max(angles, key=lambda angle: abs(angle - angles[0])),
                f"{angles[0]!r} +- {MAX_REVOLUTIONS} revolutions",
                "rad",
                f"the camshaft would turn {turned:.3g} revolutions between t = {t0!r} s and "
                f"{t1!r} s; the camshaft drive follows at most {MAX_REVOLUTIONS} per step: "
                f"reduce the step",
            )
        found: list[float] = []
        tolerance = EVENT_TOLERANCE * max(1.0, abs(t1))
        for i in range(BREAKPOINT_SAMPLES):
            low, high = sorted((angles[i], angles[i + 1]))
            for boundary in boundaries:
                first = math.ceil((low - boundary) / cam_laws.TAU)
                last = math.floor((high - boundary) / cam_laws.TAU)
                for n in range(first, last + 1):
                    target = boundary + n * cam_laws.TAU
                    g_a = angles[i] - target
                    if g_a == 0.0:
                        found.append(self.t0 + taus[i])
                        continue

                    def misfit(tau: float, target: float = target) -> float:
                        return polynomials.polynomial(self.angle, tau) - target

                    root = roots.find_root(
                        misfit,
                        taus[i],
                        g_a,
                        taus[i + 1],
                        angles[i + 1] - target,
                        tolerance,
                    )
                    found.append(self.t0 + root)
        # a boundary within the location tolerance of a communication point is that point
        return sorted(t for t in set(found) if t0 + tolerance < t < t1 - tolerance)

    def segment(self, a: float, b: float) -> int:
        """The cam law's segment (0 rise, 1 high dwell, 2 return, 3 low dwell) of [a, b] (s),
        a span inside one segment: the one at its middle (remembered for the pieces of the
        last span asked for)."""
        if self.span is not None and self.span[0] <= a and b <= self.span[1]:
            return self.span[2]
        index = self.segment_index(self.camshaft(0.5 * (a + b))[0])
        self.span = (a, b, index)
        return index

    def constant(self, a: float, b: float) -> bool:
        """Whether L stands still over [a, b] (s), a span inside one segment of the cam law:
        on a dwell."""
        return self.segment(a, b) in (1, 3)

    def piece(self, a: float, b: float) -> tuple[float, ...]:
        """Coefficients of L(a + tau) (m, tau in s) over [a, b], a piece inside one segment of
        the cam law: on a dwell the constant (L,), else the polynomial of degree 3 n - 1
        through L, L', L'' at n equally spaced points of the piece from that segment's law
        (stepping.hermite_nodes), n = piece_nodes(b - a)."""
        index = self.segment(a, b)
        if index in (1, 3):
            coefficients: tuple[float, ...] = (self.motion((0.0, 0.0, 0.0), index)[0],)
        else:
            last = piece_nodes(b - a) - 1
            # the ends remembered (a piece's end is the next one's start), the interior
            # points, asked for once, not
            motions = [self.motion(self.camshaft(a), index)]
            for i in range(1, last):
                motions.append(self.closed_form(self.camshaft(a + (b - a) * i / last), index))
            motions.append(self.motion(self.camshaft(b), index))
            coefficients = hermite_nodes(b - a, motions)
        self.current = (a, b, coefficients)
        return coefficients


# Points of the camshaft drive's fit per piece, by the piece's length (s): (longest, points).
# L's error against the closed forms, measured on the default cam at 300 and 475 rad/s
# (rise and return): 2 points (the quintic) 1.3e-14 and 1.4e-13 m at 0.1 ms; 3 points
# 1.1e-16 and 1.4e-15 m at 0.25 ms; 4 points 8e-17 and 2e-16 m at 0.5 ms; 5 points 1.9e-15 and
# 6e-15 m at 1 ms (2.4e-13 m at 2 ms; 6 or more points fare worse: the monomial basis).
# Each is at least as accurate as the quintic on 0.1 ms pieces.
PIECE_NODES = ((1e-4, 2), (2.5e-4, 3), (5e-4, 4), (math.inf, 5))


def piece_nodes(length: float) -> int:
    """Points of the drive's fit on a piece of ``length`` s (PIECE_NODES)."""
    for longest, nodes in PIECE_NODES:
        if length <= longest * (1.0 + 1e-9):
            return nodes
    return PIECE_NODES[-1][1]


MAX_REVOLUTIONS = 100  # camshaft revolutions per communication step the drive follows
BREAKPOINT_SAMPLES = 4  # samples of the camshaft angle per step between which boundaries are sought


# --- the system for the integrator: contacts engaged or not -------------------------------


def switches(
    p: "Parameters", rocker_lift: float, rocker_velocity: float, lift: float, velocity: float
) -> tuple[float, float]:
    """(contact, seat) switch functions (N) at a state: positive where the force pushes."""
    return (
        contact_switch(p, penetration(p, rocker_lift, lift), rocker_velocity - velocity),
        seat_switch(p, lift, velocity),
    )


def engagement(
    p: "Parameters", rocker_lift: float, rocker_velocity: float, lift: float, velocity: float
) -> "Engaged":
    """Engaged(contact, seat) at a state: each contact engaged where its force pushes."""
    contact, seat = switches(p, rocker_lift, rocker_velocity, lift, velocity)
    return Engaged(contact > 0.0, seat > 0.0)


def resume(
    p: "Parameters",
    engaged: "Engaged",
    rocker_lift: float,
    rocker_velocity: float,
    lift: float,
    velocity: float,
) -> "Engaged":
    """Engaged at the start of a step: each contact as its switch function's sign says, or as
    ``engaged`` (the end of the last step) where the function is exactly 0. They agree
    unless the drive jumps at the communication point (input_interpolation = hold: the
    step starts from the inputs given for its start, not from the last step's
    extrapolation), which may engage or release a contact without a crossing to see."""
    values = switches(p, rocker_lift, rocker_velocity, lift, velocity)
    return Engaged(*[value > 0.0 if value != 0.0 else mode for value, mode in zip(values, engaged)])


def engaged_forces(
    p: "Parameters",
    rocker_lift: float,
    rocker_velocity: float,
    lift: float,
    velocity: float,
    engaged: "Engaged",
) -> "Forces":
    """Forces with the contacts ``engaged`` (Engaged) acting by their unclipped Kelvin-Voigt
    law and the others idle: the smooth right-hand side of one integration segment."""
    depth = penetration(p, rocker_lift, lift)
    contact = (
        p.contact_stiffness * depth + p.contact_damping * (rocker_velocity - velocity)
        if engaged.contact
        else 0.0
    )
    seat = -p.seat_stiffness * lift - p.seat_damping * velocity if engaged.seat else 0.0
    spring = spring_force(p, lift)
    return Forces((contact + seat - spring) / p.mass, contact, seat, spring, depth)


def after_switch(
    p: "Parameters",
    engaged: "Engaged",
    fired: int,
    rocker_lift: float,
    rocker_velocity: float,
    lift: float,
    velocity: float,
) -> "Engaged":
    """Engaged after the switch function ``fired`` (CONTACT or SEAT) crossed zero at a state.

    The fired contact flips. The other one keeps following its own sign, which is far from
    zero unless both switch at the same instant (no lash and the rocker on its base circle:
    then d = -x and the valve meets, or leaves, seat and rocker together); there the
    integrator's event point lies on the far side of the fired surface only, and the other
    function may be exactly 0: then the other contact engages if it is closing (d' > 0 for
    the rocker, v < 0 for the seat).
    """
    values = switches(p, rocker_lift, rocker_velocity, lift, velocity)
    closing = (rocker_velocity - velocity > 0.0, velocity < 0.0)
    other = 1 - fired
    modes = list(engaged)
    modes[fired] = not engaged[fired]
    modes[other] = values[other] > 0.0 if values[other] != 0.0 else closing[other]
    return Engaged(*modes)


class Modes:
    """The contacts engaged over the current integration segment; the right-hand side reads
    it, the event handler changes it at each switch."""

    __slots__ = ("engaged",)

    def __init__(self, engaged: "Engaged | None" = None) -> None:
        self.engaged: Any = engaged  # an Engaged once the integration starts


def build_rhs(p: "Parameters", drive: "StepDrive | CamshaftStepDrive", modes: Modes) -> Callable:
    """y' = rhs(t, y) for y = (x, v, W): the valve's motion and the contact work, with the
    contacts engaged as ``modes`` says (smooth between switches).

    The integrators call it tens of thousands of times per simulated 0.01 s, so it is
    engaged_forces and drive.at written out with the parameters bound once: the same
    operations in the same order (the same floats), without their calls, the unused
    L'' and the Forces tuple (about half the time per call)."""
    m, k, preload, lash = p.mass, p.spring_stiffness, p.spring_preload, p.lash
    kc, cc, ks, cs = p.contact_stiffness, p.contact_damping, p.seat_stiffness, p.seat_damping

    if not isinstance(drive, StepDrive):  # the camshaft drive: its closed forms at each t

        def rhs_closed_form(t: float, y: Any):
            L, rate, _ = drive.at(t)
            x, v = y[0], y[1]
            contact_on, seat_on = modes.engaged
            contact = kc * (L - x - lash) + cc * (rate - v) if contact_on else 0.0
            seat = -ks * x - cs * v if seat_on else 0.0
            return [v, (contact + seat - (preload + k * x)) / m, contact * rate]

        return rhs_closed_form

    def rhs(t: float, y: Any):
        tau = t - drive.t0
        L = rate = 0.0
        for a in reversed(drive.coefficients):  # polynomial_motion without p''
            rate = rate * tau + L
            L = L * tau + a
        x, v = y[0], y[1]
        contact_on, seat_on = modes.engaged
        contact = kc * (L - x - lash) + cc * (rate - v) if contact_on else 0.0
        seat = -ks * x - cs * v if seat_on else 0.0
        return [v, (contact + seat - (preload + k * x)) / m, contact * rate]

    return rhs


def build_events(
    p: "Parameters", drive: "StepDrive | CamshaftStepDrive", max_lift: float | None = None
) -> dict[Engaged, tuple[Event, ...]]:
    """{Engaged: events to watch in that mode}: each contact's switch function crossing
    towards the other mode (falling while engaged, rising while idle) ends the segment, and
    d falling through 0 (the valve leaving the rocker) is located for the float report;
    with ``max_lift`` (m), the valve lift rising through it (TRAVEL_LIMIT) as well."""

    def contact(t: float, y: Any):
        L, rate, _ = drive.at(t)
        return contact_switch(p, penetration(p, L, y[0]), rate - y[1])

    def seat(t: float, y: Any):
        return seat_switch(p, y[0], y[1])

    def separation(t: float, y: Any):
        return penetration(p, drive.at(t)[0], y[0])

    # the valve leaving its seat (x rising through 0): judged for the next impact's count
    # however many bounces one step holds
    always = [Event("separation", separation, -1), Event(OPENING, lambda t, y: y[0], 1)]
    if max_lift is not None:
        always.append(Event(TRAVEL_LIMIT, lambda t, y: y[0] - max_lift, 1))
    return {
        Engaged(c, s): (
            Event(SWITCH_EVENTS[CONTACT], contact, -1 if c else 1),
            Event(SWITCH_EVENTS[SEAT], seat, -1 if s else 1),
            *always,
        )
        for c in (False, True)
        for s in (False, True)
    }


def initial_state(p: "Parameters", rocker_lift: float, rocker_velocity: float) -> list[float]:
    """(x, v, W) at the start: static equilibrium, moving with the rocker, no work done."""
    return [static_equilibrium(p, rocker_lift, rocker_velocity), float(rocker_velocity), 0.0]


# --- what happened inside a step -----------------------------------------------------------


def contact_phase(
    p: "Parameters",
    rocker_lift: float,
    lift: float,
    landed: bool = False,
    velocity: float = 0.0,
    rocker_velocity: float = 0.0,
) -> "Phase":
    """Phase(touching: d > 0, or d = 0 closing (L' - v > 0), open: x > 0, or x = 0 moving up
    (velocity > 0 m/s), landed) at a state; ``landed``: the valve has come down on its seat
    since the rocker last sat on its base circle (L <= lash). (A surface reached exactly,
    d = 0 or x = 0, is where an event's located point can land: moving into contact or off
    the seat there counts as being there.)"""
    depth = rocker_lift - lift - p.lash  # penetration (judged at every event)
    return Phase(
        depth > 0.0 or (depth == 0.0 and rocker_velocity - velocity > 0.0),
        lift > 0.0 or (lift == 0.0 and velocity > 0.0),
        landed and rocker_lift - p.lash > 0.0,
    )


def next_phase(
    p: "Parameters",
    before: "Phase",
    t: float,
    lift: float,
    velocity: float,
    drive: tuple[float, float, float],
) -> tuple:
    """(Phase at time t, [Happening]) for a state reached from the Phase ``before``.

    Happenings, each Happening(kind, t, x, v, (L, L', L'')):
    - SEAT_IMPACT: the valve reached its seat moving down (x fell through 0 with v < 0), a
      closing; BOUNCE as well when the valve was not on the rocker just before (it came
      down in free flight);
    - FLOAT: the valve left the rocker (d fell through 0) while the rocker holds it open
      (L > lash; where d = 0 that is x > 0) and before it closed: the spring could not keep
      the valve on the rocker;
    - REBOUND: the same separation after the valve landed: it bounced off its seat and
      left the rocker that was still closing (a cam without a closing ramp seats the valve
      at the rocker speed where L = F_c / k_c, a few tenths of a m/s).
    Judging the states rather than which event fired keeps crossings that coincide (with no
    lash and the rocker on its base circle d = -x: leaving the seat is leaving the rocker)
    counted once each.
    """
    found = []
    now = contact_phase(p, drive[0], lift, before.landed, velocity, drive[1])
    if before.open and not now.open and velocity < 0.0:
        found.append(Happening(SEAT_IMPACT, t, lift, velocity, drive))
        if not before.touching:
            found.append(Happening(BOUNCE, t, lift, velocity, drive))
        now = now._replace(landed=drive[0] - p.lash > 0.0)
    if before.touching and not now.touching and drive[0] - p.lash > 0.0:
        found.append(Happening(REBOUND if now.landed else FLOAT, t, lift, velocity, drive))
    return now, found
