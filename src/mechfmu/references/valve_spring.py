"""Valve spring dynamics reference (numpy + scipy) for the ValveSpring scenes.

The model of physics/valve_spring.py written again, without its code, in numpy/scipy.

Drive: the rocker's valve end follows the kinematic valve lift L(t) of the scene's
CamshaftDrive -> ValveTrain chain, evaluated exactly at any time from the numpy shaft
rotation (references/drives.py), the numpy cam law and the closed-form rocker geometry
(references/valve_train.py): L = forward(s, s1 w, s2 w^2 + s1 alpha)["valve_lift"], with
its velocity and acceleration. Where the cam law meets a dwell (or the shaft's speed ramp
starts or ends) a derivative of L jumps: the integration restarts at those times. Between
them the numpy closed forms cost half a millisecond per call, too slow for the hundreds of
thousands of right-hand sides of a tight integration, so each smooth piece is tabulated
exactly (L, L', L'' at nodes TABLE_SPACING apart, computed in one vectorised call) and
interpolated by the quintic through both nodes' values. Its truncation error,
h^6 max|L^(6)| / 46080, vanishes next to the rounding of the closed form itself (1e-16 m,
a few ulps of the valve foot's position); the interpolated rates carry that rounding divided
by h and h^2 (measured on the shipped drive: 1.3e-16 m, 2.4e-11 m/s, 7.5e-6 m/s^2, a test
checks it). A finer table would amplify the rounding more: 1e-6 s gives 9e-4 m/s^2.

Valve (x lift, v velocity, m, m/s): m x'' = F_c + F_seat - F0 - k x with the penetration
d = L - x - lash, and two Kelvin-Voigt contacts that only push:

    F_c    = k_c d + c_c (L' - v)   while the contact is engaged, else 0
    F_seat = -k_s x - c_s v         while the seat is engaged, else 0

The contacts are hybrid modes: within one integration segment each contact is engaged or
not and the right-hand side is a smooth linear ODE in (x, v) driven by L(t). A contact
engages when its switch function rises through zero and disengages when it falls through
zero (solve_ivp terminal events; the segment ends there and the mode flips):

    contact: min(k_c d, k_c d + c_c d')      seat: min(-k_s x, -k_s x - c_s v)

(positive exactly where the force would push). A third, non-terminal, event records d
falling through 0 (the valve leaving the rocker). The contact work W' = F_c L' is
integrated as a third state. scipy's solve_ivp (DOP853) integrates every segment at
rtol = 1e-12, atol = (1e-14 m, 1e-12 m/s, 1e-12 J), with dense output sampled at the
scene's communication points.

Counts: a seat impact is the seat engaging with v < 0 (x reaching 0 from above); a float is
a separation (d falling through 0) while the rocker is open (L > lash), unless the valve has
landed on its seat since the rocker last sat on its base circle (then it is the valve
rebounding from its seat).
"""

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from typing import Any

from . import drives, valve_train
from numpy import ndarray
from collections.abc import Callable

TOLERANCE = 1e-12
TABLE_SPACING = 1e-5  # s, between the nodes of the tabulated drive
# s: events are seen as sign changes between steps, so no step may be long enough to hold a
# whole contact; the shortest, of the valve on its seat, lasts half a period of
# sqrt((k_s + k) / m), 0.1 ms with the defaults, ten such steps
MAX_STEP = 1e-5
# N: a switch function (a force) this close to zero at another contact's event switches at
# the same instant (rounding puts it at ~1e-11 N: 1e8 N/m times 1e-19 m)
NEAR_ZERO = 1e-9
ATOL = (1e-14, 1e-12, 1e-12)  # m, m/s, J
COLUMNS = (
    "valve_lift",
    "valve_velocity",
    "valve_acceleration",
    "contact_force",
    "seat_force",
    "spring_force",
    "penetration",
    "contact_lost",
    "float_events",
    "seat_impacts",
    "kinetic_energy",
    "elastic_energy",
    "contact_work",
)


# --- the drive --------------------------------------------------------------------------------


class RockerDrive:
    """L(t), L'(t), L''(t) of the rocker's valve end, and the times where they lose
    smoothness. ``shaft``: CamshaftDrive parameters; ``train``: ValveTrain parameters."""

    def __init__(self, shaft: dict[str, float], train: dict[str, Any]) -> None:
        self.shaft = shaft
        self.train = train
        self.geometry = {key: train[key] for key in valve_train.GEOMETRY_FIELDS}
        self.solve = valve_train.inverse if train["mode"] == "inverse" else valve_train.forward

    def rotation(self, t: float | ndarray) -> dict[str, Any]:
        return drives.shaft_rotation(t, self.shaft, ratio=0.5)

    def __call__(self, t: float | ndarray) -> tuple:
        shaft = self.rotation(t)
        tappet = valve_train.tappet_motion(
            self.train, shaft["angle"], shaft["speed"], shaft["acceleration"]
        )
        motion = self.solve(self.geometry, *tappet)
        return motion["valve_lift"], motion["valve_velocity"], motion["valve_acceleration"]

    def breakpoints(self, times: Any) -> Any:
        """Times in (times[0], times[-1]) where the cam law changes segment or the shaft's
        speed ramp starts or ends (the camshaft angle rises monotonically)."""
        p, s = self.train, self.shaft
        t0, t1 = times[0], times[-1]
        found = [t for t in (s["start_time"], s["start_time"] + s["ramp_time"]) if t0 < t < t1]
        angles = self.rotation(times)["angle"]
        edges = np.cumsum([0.0, p["rise_angle"], p["high_dwell_angle"], p["return_angle"]])
        turns = np.arange(
            np.floor((angles[0] - p["rise_start"]) / (2 * np.pi)) - 1,
            np.ceil((angles[-1] - p["rise_start"]) / (2 * np.pi)) + 1,
        )
        for target in (p["rise_start"] + 2 * np.pi * turns[:, None] + edges).ravel():
            i = np.searchsorted(angles, target)
            if 0 < i < len(times):
                found.append(
                    brentq(
                        lambda t: float(self.rotation(t)["angle"]) - target,
                        times[i - 1],
                        times[i],
                        xtol=1e-15,
                        rtol=1e-15,
                    )
                )
        return sorted(set(found))

    def piece(self, a: float, b: float) -> Callable:
        """Fast scalar L(t), L'(t), L''(t) on [a, b], a smooth piece of the drive: the
        quintic interpolation of exact values at nodes about TABLE_SPACING apart. The end
        nodes take the values just inside [a, b] (the piece's one-sided limits)."""
        count = max(1, int(np.ceil((b - a) / TABLE_SPACING)))
        nodes = np.linspace(a, b, count + 1)
        inside = nodes.copy()
        inside[0] += 1e-13 * (b - a)
        inside[-1] -= 1e-13 * (b - a)
        values = np.array(self(inside))  # (3, count + 1)
        h = (b - a) / count
        # conditions on the unit interval: p, p', p'' at s = 0 and s = 1, scaled by h^k
        scaled = (
            np.vstack([values[:, :-1], values[:, 1:]])
            * np.array([1.0, h, h * h, 1.0, h, h * h])[:, None]
        )
        coefficients = (_UNIT_QUINTIC @ scaled).T  # (count, 6), powers of s
        rows = [tuple(row) for row in coefficients]
        first = [tuple(row[1:] * np.arange(1, 6)) for row in coefficients]
        second = [tuple(row[2:] * np.arange(2, 6) * np.arange(1, 5)) for row in coefficients]
        last = count - 1

        def drive(t: float):
            position = (t - a) / h
            i = min(max(int(position), 0), last)
            u = position - i
            return (_horner(rows[i], u), _horner(first[i], u) / h, _horner(second[i], u) / (h * h))

        return drive


def _horner(coefficients: tuple[float, ...], u: float) -> float:
    total = 0.0
    for c in reversed(coefficients):
        total = total * u + c
    return total


def _unit_quintic() -> ndarray:
    """Inverse of the map from the coefficients of a quintic on [0, 1] to its values and
    first two derivatives at 0 and 1."""
    powers = np.arange(6)
    rows = []
    for s in (0.0, 1.0):
        rows.append(s**powers)
        rows.append(np.where(powers >= 1, powers * s ** np.maximum(powers - 1, 0), 0.0))
        rows.append(
            np.where(powers >= 2, powers * (powers - 1) * s ** np.maximum(powers - 2, 0), 0.0)
        )
    return np.linalg.inv(np.array(rows))


_UNIT_QUINTIC = _unit_quintic()


# --- the valve, by contact modes ---------------------------------------------------------------


class Valve:
    """The equations for ValveSpring parameters ``p`` (a mapping); ``drive`` arguments are
    functions t -> (L, L', L'')."""

    def __init__(self, p: Any) -> None:
        self.m, self.k, self.f0 = p["valve_mass"], p["spring_stiffness"], p["spring_preload"]
        self.kc, self.cc = p["contact_stiffness"], p["contact_damping"]
        self.ks, self.cs = p["seat_stiffness"], p["seat_damping"]
        self.lash = p["lash"]

    def engaged_forces(self, L: Any, rate: Any, x: Any, v: Any) -> Any:
        """(contact, seat) forces if both contacts were engaged (may be negative)."""
        return self.kc * (L - x - self.lash) + self.cc * (rate - v), -self.ks * x - self.cs * v

    def rhs(self, t: float, state: Any, drive: Any, contact_on: Any, seat_on: Any) -> Any:
        x, v = state[0], state[1]
        L, rate, _ = drive(t)
        contact, seat = self.engaged_forces(L, rate, x, v)
        contact = contact if contact_on else 0.0
        seat = seat if seat_on else 0.0
        return np.array([v, (contact + seat - self.f0 - self.k * x) / self.m, contact * rate])

    def switches(self, t: float, state: Any, drive: Any) -> Any:
        """(contact, seat) switch functions: positive exactly where the force pushes."""
        x, v = state[0], state[1]
        L, rate, _ = drive(t)
        d = L - x - self.lash
        return (
            min(self.kc * d, self.kc * d + self.cc * (rate - v)),
            min(-self.ks * x, -self.ks * x - self.cs * v),
        )

    def other_mode(self, which: Any, t: float, state: Any, drive: Any, engaged: Any) -> Any:
        """Mode of contact ``which`` (0 rocker, 1 seat) at an event of the other one.

        Its switch function is far from zero unless both switch at the same instant (no
        lash and the rocker on its base circle: the valve meets seat and rocker together,
        d = -x). Then the event that fired left the other a rounding error from zero, of
        either sign, and its sign cannot tell: the contact engages if it is closing
        (d' > 0 for the rocker, v < 0 for the seat)."""
        value = self.switches(t, state, drive)[which]
        if abs(value) > NEAR_ZERO:
            return value > 0.0
        if which == 0:
            return drive(t)[1] - state[1] > 0.0
        return state[1] < 0.0

    def columns(self, t: float, states: Any, drive: Any) -> Any:
        """Output columns at sample times ``t`` from states (3, n); forces by the clipped
        law, which the modes follow."""
        x, v, work = states
        L, rate, _ = drive(t)
        d = L - x - self.lash
        contact, seat = self.engaged_forces(L, rate, x, v)
        contact = np.where(d > 0.0, np.maximum(contact, 0.0), 0.0)
        seat = np.where(x < 0.0, np.maximum(seat, 0.0), 0.0)
        spring = self.f0 + self.k * x
        elastic = (
            self.f0 * x
            + 0.5 * self.k * x * x
            + 0.5 * self.kc * np.where(d > 0.0, d, 0.0) ** 2
            + 0.5 * self.ks * np.where(x < 0.0, x, 0.0) ** 2
        )
        lost = (d <= 0.0) & (L - self.lash > 0.0)
        return {
            "valve_lift": x,
            "valve_velocity": v,
            "valve_acceleration": (contact + seat - spring) / self.m,
            "contact_force": contact,
            "seat_force": seat,
            "spring_force": spring,
            "penetration": d,
            "contact_lost": lost.astype(float),
            "kinetic_energy": 0.5 * self.m * v * v,
            "elastic_energy": elastic,
            "contact_work": work,
        }

    def equilibrium(self, t: float, drive: Any) -> Any:
        """(x, v, W) at rest on the drive: the force balance with v = L', by trying the four
        mode combinations (the net force falls strictly with x: one of them is consistent)."""
        L, rate, _ = (float(value) for value in drive(t))
        for contact_on in (True, False):
            for seat_on in (True, False):
                stiffness = self.k + self.kc * contact_on + self.ks * seat_on
                force = -self.f0 + self.kc * (L - self.lash) * contact_on - self.cs * rate * seat_on
                state = np.array([force / stiffness, rate, 0.0])
                engaged = tuple(value > 0.0 for value in self.switches(t, state, drive))
                if engaged == (contact_on, seat_on):
                    return state
        raise ValueError(f"no static equilibrium at t = {t} s")


def _event(function: Any, direction: Any, terminal: Any):
    function.direction, function.terminal = direction, terminal
    return function


def simulate(valve: Any, drive: Any, times: Any) -> Any:
    """Integrate from rest at times[0] over the sorted sample ``times`` (a RockerDrive).

    Returns (states (3, n) at the samples, separation times, seat impact times, work
    counters {"rhs": right-hand sides, "steps": accepted steps}).
    """
    times = np.asarray(times, dtype=float)
    edges = [times[0], *drive.breakpoints(times), times[-1]]
    state = valve.equilibrium(times[0], drive)
    modes = [value > 0.0 for value in valve.switches(times[0], state, drive)]
    states = np.empty((3, times.size))
    states[:, 0] = state
    separations, impacts = [], []
    work = {"rhs": 0, "steps": 0}
    for a, b in zip(edges[:-1], edges[1:]):
        piece = drive.piece(a, b)
        t = a
        while t < b:
            switch = [
                _event(
                    lambda s, y, i=i: valve.switches(s, y, piece)[i],
                    -1.0 if modes[i] else 1.0,
                    True,
                )
                for i in range(2)
            ]
            separation = _event(lambda s, y: piece(s)[0] - y[0] - valve.lash, -1.0, False)
            engaged = tuple(modes)
            solution = solve_ivp(
                lambda s, y: valve.rhs(s, y, piece, *engaged),
                (t, b),
                state,
                method="DOP853",
                rtol=TOLERANCE,
                atol=ATOL,
                max_step=MAX_STEP,
                dense_output=True,
                events=(*switch, separation),
            )
            if solution.status < 0:
                raise RuntimeError(f"solve_ivp failed on [{t}, {b}]: {solution.message}")
            work["rhs"] += solution.nfev
            work["steps"] += solution.t.size - 1
            end = solution.t[-1]
            inside = (times > t) & (times <= end)
            if inside.any():
                states[:, inside] = solution.sol(times[inside])
            separations += [(s, piece(s)[0]) for s in solution.t_events[2]]
            state = solution.y[:, -1]
            if solution.status == 1:  # a contact switched: flip it; a coincident one too
                fired = next(i for i in range(2) if len(solution.t_events[i]))
                before = list(modes)
                modes[fired] = not modes[fired]
                modes[1 - fired] = valve.other_mode(1 - fired, end, state, piece, modes[1 - fired])
                if modes[1] and not before[1] and state[1] < 0.0:
                    impacts.append(end)
            t = end
    return states, separations, impacts, work


def _floats(valve: Any, drive: Any, separations: Any, impacts: Any):
    """Times of the separations (t, L) with the rocker open (L > lash) at which the valve had
    not landed on its seat since the rocker left its base circle (no impact with the rocker
    open all the way from the impact to the separation)."""
    floats = []
    for t, rocker_lift in separations:
        if rocker_lift - valve.lash <= 0.0:
            continue
        landed = any(
            np.min(drive(np.linspace(t_i, t, 1001))[0]) - valve.lash > 0.0
            for t_i in impacts
            if t_i <= t
        )
        if not landed:
            floats.append(t)
    return floats


def scene_columns(times: Any, shaft: Any, train: Any, parameters: Any) -> Any:
    """Columns of the ValveSpring component at the sample ``times`` ('variable' -> array,
    COLUMNS) and the reference's work counters, for a CamshaftDrive -> ValveTrain ->
    ValveSpring chain with the given parameters (the models' defaults included)."""
    times = np.asarray(times, dtype=float)
    valve, drive = Valve(parameters), RockerDrive(shaft, train)
    states, separations, impacts, work = simulate(valve, drive, times)
    columns = valve.columns(times, states, drive)
    columns["float_events"] = _cumulative_count(times, _floats(valve, drive, separations, impacts))
    columns["seat_impacts"] = _cumulative_count(times, impacts)
    return {name: columns[name] for name in COLUMNS}, work


def _cumulative_count(times: Any, events: Any):
    """Events so far at each sample; sample i ends the step (t_{i-1}, t_i]."""
    index = np.searchsorted(times, events, side="left")
    return np.cumsum(np.bincount(index, minlength=times.size)[: times.size]).astype(float)
