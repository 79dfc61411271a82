"""Suspension dynamics reference (numpy + scipy), mechanisms.md section 2, "Dynamics".

An independent formulation of the same equations as physics/suspension_dynamics.py, written
without the standard-library physics; the spring force is the numpy reference statics'.

Coordinates, all positive downward and zero in the unstressed configuration (road at 0):
sprung mass (apex) y, spring base z, spring deflection u = y - z. The road height r is
positive upward, so a road rise pushes the base up: without a tyre z = -r; with a tyre of
stiffness k_t its compression is z + r. Newton's law for each mass:

    sprung:    m y''   = W(t) - F(u) - c u'
    unsprung:  m_u z'' = F(u) + c u' + m_u g - k_t (z + r(t))          (tyre only)

(c = 0 without the damping effect). Energies: T = m y'^2/2 + m_u z'^2/2,
V = 2 * k (s - L)^2 / 2 - W y + k_t (z + r)^2 / 2 - m_u g z.

The load and the road are the exact signals of the scene's sources (a step load jumps at its
start time, a bump is the one-cosine bump), not sampled ones. scipy's solve_ivp integrates
piecewise between the signals' breakpoints (DOP853 by default, Radau for stiff springs) at
rtol = atol = 1e-12 with dense output evaluated at the sample times. Snap-throughs are
located as solve_ivp events on u crossing the boundaries of the stable regions, u* and
2h - u*: leaving the region last visited for the other one.
"""

from typing import Any
import numpy as np
from scipy.integrate import solve_ivp

from . import suspension as statics
from .events import ivp_event

GRAVITY = 9.81
NEAR, FAR, BETWEEN = 0, 1, 2
TOLERANCE = 1e-12


# --- exact source signals -------------------------------------------------------------------


# The LoadProfile and RoadProfile parameters load_signal and road_signal take, in order.
LOAD_FIELDS = ("shape", "initial_value", "final_value", "start_time", "duration")
ROAD_FIELDS = ("shape", "height", "duration", "start_time", "amplitude", "frequency")


def load_signal(
    shape: Any, initial_value: Any, final_value: Any, start_time: float, duration: float
) -> Any:
    """(W(t) vectorised, breakpoints) for a LoadProfile constant, step or ramp."""
    if shape == "constant":
        return (lambda t: np.full(np.shape(t), float(initial_value))), []
    if shape == "step":
        return (
            lambda t: np.where(np.asarray(t) >= start_time, final_value, initial_value).astype(
                float
            )
        ), [start_time]
    if shape == "ramp":

        def ramp(t: float):
            tau = np.clip((np.asarray(t, dtype=float) - start_time) / duration, 0.0, 1.0)
            return initial_value + (final_value - initial_value) * tau

        return ramp, [start_time, start_time + duration]
    raise ValueError(f"load shape {shape!r} is not covered by the dynamic reference")


def road_signal(
    shape: Any, height: Any, duration: float, start_time: float, amplitude: Any, frequency: Any
) -> Any:
    """(r(t) -> (r, r', r'') vectorised, breakpoints) for a RoadProfile step, bump or sine."""
    if shape == "bump":

        def bump(t: Any):
            t = np.asarray(t, dtype=float)
            phase = (t - start_time) / duration
            inside = (phase > 0.0) & (phase < 1.0)
            angle = 2.0 * np.pi * phase
            w = np.pi / duration
            return (
                np.where(inside, 0.5 * height * (1.0 - np.cos(angle)), 0.0),
                np.where(inside, height * w * np.sin(angle), 0.0),
                np.where(inside, 2.0 * height * w * w * np.cos(angle), 0.0),
            )

        return bump, [start_time, start_time + duration]
    if shape == "sine":

        def sine(t: Any):
            t = np.asarray(t, dtype=float)
            on = t >= start_time
            w = 2.0 * np.pi * frequency
            angle = w * (t - start_time)
            return (
                np.where(on, amplitude * np.sin(angle), 0.0),
                np.where(on, amplitude * w * np.cos(angle), 0.0),
                np.where(on, -amplitude * w * w * np.sin(angle), 0.0),
            )

        return sine, [start_time]
    if shape == "step":

        def kerb(t: Any):
            t = np.asarray(t, dtype=float)
            zero = np.zeros_like(t)
            return np.where(t >= start_time, height, 0.0), zero, zero

        return kerb, [start_time]
    raise ValueError(f"road shape {shape!r} is not covered by the dynamic reference")


def no_road(t: float) -> Any:
    zero = np.zeros_like(np.asarray(t, dtype=float))
    return zero, zero, zero


# --- the equations ----------------------------------------------------------------------------


class System:
    """The suspension's state equations for given parameters and signals.

    spring: (L, k, d); damping: c or 0; tyre: (k_t, m_u) or None; road: None (rigid level
    base), or r(t) as above.
    """

    def __init__(
        self, spring: Any, mass: Any, damping: Any, tyre: Any, load: Any, road: Any
    ) -> None:
        self.L, self.k, self.d = spring
        self.m, self.c, self.tyre = mass, damping, tyre
        self.load, self.road = load, road
        self.rigid_road = road if road is not None else no_road

    def base(self, t: float, x: Any) -> Any:
        """(z, z') of the spring base: the unsprung states, or the road's mirror image."""
        if self.tyre is not None:
            return x[2], x[3]
        r, rate, _ = self.rigid_road(t)
        return -r, -rate

    def suspension_force(self, u: Any, du: Any) -> Any:
        return statics.spring_force(u, self.L, self.k, self.d) + self.c * du

    def __call__(self, t: float, x: Any) -> Any:
        z, dz = self.base(t, x)
        f = self.suspension_force(x[0] - z, x[1] - dz)
        ddy = (self.load(t) - f) / self.m
        if self.tyre is None:
            return np.array([x[1], ddy])
        kt, mu = self.tyre
        r = self.rigid_road(t)[0]
        return np.array([x[1], ddy, x[3], (f + mu * GRAVITY - kt * (z + r)) / mu])

    def initial(self, u0: Any, du0: Any, t0: float) -> Any:
        """State for spring deflection u0, rate du0; with the tyre the unsprung mass is at
        rest on a tyre that carries F(u0) + m_u g."""
        r, rate, _ = self.rigid_road(t0)
        if self.tyre is not None:
            kt, mu = self.tyre
            z = (float(statics.spring_force(u0, self.L, self.k, self.d)) + mu * GRAVITY) / kt - r
            return np.array([u0 + z, du0, z, 0.0])
        return np.array([u0 - r, du0 - rate], dtype=float)

    def columns(self, t: float, x: Any) -> Any:
        """Outputs at sample times t (arrays) from states x (shape (n_states, n))."""
        y, dy = x[0], x[1]
        r, rate, rate2 = self.rigid_road(t)
        W = self.load(t)
        if self.tyre is not None:
            z, dz = x[2], x[3]
            kt, mu = self.tyre
            f = self.suspension_force(y - z, dy - dz)
            ddz = (f + mu * GRAVITY - kt * (z + r)) / mu
            tyre_force = kt * (z + r)
            kinetic_extra = 0.5 * mu * dz * dz
            potential_extra = 0.5 * kt * (z + r) ** 2 - mu * GRAVITY * z
        else:
            z, dz, ddz = -r, -rate, -rate2
            f = self.suspension_force(y - z, dy - dz)
            tyre_force = kinetic_extra = potential_extra = np.zeros_like(y)
        u = y - z
        ddy = (W - f) / self.m
        L, k, d = self.L, self.k, self.d
        h = float(statics.rest_height(L, d))
        s = np.sqrt(d * d + (h - u) ** 2)
        stretch = -u * (2.0 * h - u) / (L + s)  # s - L without cancellation
        tangent = statics.tangent_stiffness(u, L, k, d)
        stable, marginal = statics.stability(tangent, k)
        return {
            "deflection": u,
            "velocity": dy - dz,
            "acceleration": ddy - ddz,
            "sprung_displacement": y,
            "unsprung_displacement": z,
            "tyre_force": tyre_force,
            "spring_force": statics.spring_force(u, L, k, d),
            "secant_stiffness": statics.secant_stiffness(u, L, k, d),
            "tangent_stiffness": tangent,
            "stable": stable,
            "marginal": marginal,
            "kinetic_energy": 0.5 * self.m * dy * dy + kinetic_extra,
            "potential_energy": k * stretch * stretch - W * y + potential_extra,
        }


def simulate(
    system: Any,
    times: Any,
    u0: Any,
    du0: Any,
    breakpoints: Any = (),
    method: str = "DOP853",
    max_step: Any = np.inf,
) -> Any:
    """Integrate ``system`` over ``times`` (sorted samples, the first the start time).

    Returns (columns at the samples, snap-through times). Integration restarts at each
    breakpoint inside the interval (the signals' kinks and jumps), so solve_ivp never steps
    over a discontinuity. Columns also include branch, snap_through (1 on the sample that
    ends the step containing a snap) and snap_through_count.
    """
    times = np.asarray(times, dtype=float)
    t0, t1 = times[0], times[-1]
    near_end, _ = statics.limit_point(system.L, system.k, system.d)
    h = float(statics.rest_height(system.L, system.d))
    far_start = 2.0 * h - near_end

    def deflection(t: float, x: Any):
        return x[0] - system.base(t, x)[0]

    up = lambda t, x: deflection(t, x) - far_start  # noqa: E731
    ivp_event(up, direction=1.0)
    down = lambda t, x: deflection(t, x) - near_end  # noqa: E731
    ivp_event(down, direction=-1.0)
    edges = [t0] + sorted(b for b in breakpoints if t0 < b < t1) + [t1]
    state = system.initial(u0, du0, t0)
    states = np.empty((state.size, times.size))
    crossings = []
    for a, b in zip(edges[:-1], edges[1:]):
        solution = solve_ivp(
            system,
            (a, b),
            state,
            method=method,
            rtol=TOLERANCE,
            atol=TOLERANCE,
            dense_output=True,
            events=(up, down),
            max_step=max_step,
        )
        if solution.status != 0:
            raise RuntimeError(f"solve_ivp failed on [{a}, {b}]: {solution.message}")
        inside = (times >= a) & (times <= b)
        states[:, inside] = solution.sol(times[inside])
        crossings += [(t, FAR) for t in solution.t_events[0]]
        crossings += [(t, NEAR) for t in solution.t_events[1]]
        state = solution.y[:, -1]
    columns = system.columns(times, states)
    u = columns["deflection"]
    columns["branch"] = np.where(u < near_end, NEAR, np.where(u > far_start, FAR, BETWEEN)).astype(
        float
    )
    side = NEAR if u0 <= h else FAR
    snaps = []
    for t, target in sorted(crossings):
        if target != side:
            snaps.append(t)
            side = target
    index = np.searchsorted(times, snaps, side="left")  # sample i ends the step (t_{i-1}, t_i]
    flags = np.zeros(times.size)
    flags[index] = 1.0
    columns["snap_through"] = flags
    columns["snap_through_count"] = np.cumsum(np.bincount(index, minlength=times.size)).astype(
        float
    )
    return columns, snaps


# --- a scene's reference -------------------------------------------------------------------------


def scene_columns(
    times: Any,
    load_name: Any,
    load: Any,
    suspension_name: Any,
    parameters: Any,
    road_name: Any = None,
    road: Any = None,
    record: Any = None,
) -> Any:
    """Reference columns ('component.variable') of a LoadProfile [-> RoadProfile] ->
    Suspension scene with the dynamics effect, from the components' parameters (scene values
    over the models' defaults). Only the recorded columns are returned when ``record`` is
    given, in its order.
    """
    p = parameters
    if not p["dynamics"]:
        raise ValueError("the dynamic reference needs the dynamics effect")
    W, breaks = load_signal(*(load[key] for key in LOAD_FIELDS))
    r = None
    if p["road_input"]:
        if road is None:
            raise ValueError("road_input needs a RoadProfile component")
        r, road_breaks = road_signal(*(road[key] for key in ROAD_FIELDS))
        breaks = breaks + road_breaks
    system = System(
        (p["spring_free_length"], p["spring_stiffness"], p["spring_base_offset"]),
        p["mass"],
        p["damping_coefficient"] if p["damping"] else 0.0,
        (p["tyre_stiffness"], p["unsprung_mass"]) if p["tyre"] else None,
        W,
        r,
    )
    times = np.asarray(times, dtype=float)
    columns, _ = simulate(system, times, p["initial_deflection"], p["initial_velocity"], breaks)
    named = {f"{suspension_name}.{key}": value for key, value in columns.items()}
    named[f"{load_name}.load"] = W(times)
    if r is not None:
        height, rate, _ = r(times)
        named[f"{road_name}.road_height"], named[f"{road_name}.road_rate"] = height, rate
    if record is None:
        return named
    missing = [name for name in record if name not in named]
    if missing:
        raise ValueError(f"the dynamic reference has no column(s) {', '.join(missing)}")
    return {name: named[name] for name in record}
