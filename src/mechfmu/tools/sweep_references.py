"""Scalar references for parameter sweeps (numpy + scipy): what a sweep's metric should be.

Three sweeps reduce each FMU run to one number; the functions here compute that number
without the FMUs' standard-library physics for the quantity checked:

- Suspension: the sprung mass at which a load m g snaps the spring pair through, statically
  (m g > F*) and suddenly applied (dynamics effect, optional damper), with the numpy statics
  of references/suspension.py and the equations of references/suspension_dynamics.py.
- LandingGear (scene gear_retraction_dynamic): the retraction time against the supply
  pressure, by the dynamic gear reference's machinery (references/gear_dynamics.py, which
  reuses the FMU's right-hand side by design), and a static moment balance for the lowest
  supply pressure that can hold the gear anywhere on its way up (numpy closed forms).
- ValveTrain (forward drive, valve_spring effect): the camshaft speed at which the valve
  starts to float, from the numpy valve-train reference (references/valve_train.py).

Units SI: m, kg, s, rad, N, Pa. Bad input raises ValueError naming the value.
"""

from typing import Any
import math
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from ..cosim.scene import SCENE_DIR
from ..runtime.errors import require_between, require_finite, require_positive
from ..references import gear_dynamics as gear_reference
from ..references import suspension as statics
from ..references import suspension_dynamics as dynamics
from ..references import valve_train as valve_reference
from ..references.events import ivp_event
from .scene_references import model_defaults, start_values

STANDARD_GRAVITY = 9.80665  # m/s^2
# solve_ivp tolerances of the suspension integrations (as the scene references).
SUSPENSION_TOLERANCE = 1e-12
# Longest simulated time (s) before a sudden-load run counts as undecided (an error): every
# run ends long before by one of its events (snap, turn, or energy below the saddle's).
SUSPENSION_MAX_TIME = 1e3

GEAR_SCENE = SCENE_DIR / "gear_retraction_dynamic.toml"
# Off the stroke surface after a crossing, as references/gear_dynamics.simulate does.
GEAR_EVENT_OFFSET = 1e-9

# Per-segment phase samples of the float-speed grid (the FMU's own search uses ~720 per
# revolution; this grid is independent and much finer).
FLOAT_GRID = 20001


# --- validation -----------------------------------------------------------------------------


def _non_negative(name: str, value: float, unit: str = "") -> float:
    return require_between(name, value, 0.0, math.inf, unit)


def _spring(
    spring_free_length: float, spring_stiffness: float, spring_base_offset: float
) -> tuple[float, float, float]:
    L = require_positive("spring_free_length", spring_free_length, "m")
    k = require_positive("spring_stiffness", spring_stiffness, "N/m")
    d = require_positive("spring_base_offset", spring_base_offset, "m")
    if not d < L:
        raise ValueError(
            f"spring_base_offset = {spring_base_offset!r} m must be below "
            f"spring_free_length = {spring_free_length!r} m"
        )
    return L, k, d


# --- suspension: static and sudden snap-through -----------------------------------------------


def static_snap_through_mass(
    spring_free_length: float = 0.5,
    spring_stiffness: float = 1e4,
    spring_base_offset: float = 0.2,
    gravity: float = STANDARD_GRAVITY,
) -> float:
    """Sprung mass (kg) whose weight equals the static limit load F* of the near branch.

    A quasi-static load m g snaps through for every m above F*/g (the near equilibrium
    ceases to exist) and never below, so F*/g is the sweep's threshold. F* from the numpy
    statics (s*^3 = L d^2). Lengths in m, stiffness in N/m, gravity in m/s^2.
    """
    L, k, d = _spring(spring_free_length, spring_stiffness, spring_base_offset)
    g = require_positive("gravity", gravity, "m/s^2")
    return statics.limit_point(L, k, d)[1] / g


def _spring_energy(u: float, L: float, k: float, d: float) -> float:
    """Strain energy (J) of both springs at deflection u: 2 * k (s - L)^2 / 2, with
    s - L = -u (2h - u) / (L + s) so small deflections keep their relative accuracy."""
    h = float(statics.rest_height(L, d))
    s = math.sqrt(d * d + (h - u) ** 2)
    stretch = -u * (2.0 * h - u) / (L + s)
    return k * stretch * stretch


def _saddle(W: float, L: float, k: float, d: float) -> float:
    """Unstable equilibrium u2 in (u*, h) of F(u) = W for 0 < W <= F* (F falls from F* to 0
    there, so the root is bracketed and unique)."""
    u_star, F_star = statics.limit_point(L, k, d)
    h = float(statics.rest_height(L, d))
    if W >= F_star:
        return u_star
    return brentq(
        lambda u: float(statics.spring_force(u, L, k, d)) - W,
        u_star,
        h,
        xtol=1e-15,
        rtol=4.0 * np.finfo(float).eps,
    )


def sudden_snap_through_load_undamped(
    spring_free_length: float = 0.5, spring_stiffness: float = 1e4, spring_base_offset: float = 0.2
) -> float:
    """Smallest suddenly applied constant load W (N) that snaps the undamped spring pair
    through, starting at rest unstressed: the energy closed form.

    The kinetic energy is W u - V(u) (V the springs' strain energy). Past the first
    equilibrium it falls until the saddle u2 (F(u2) = W) and grows again beyond, so the
    mass crosses the saddle, and then the far region, exactly when W u2 >= V(u2). The
    threshold solves F(u2) u2 = V(u2) for u2 in (u*, h): positive at u* (V(u*) < F* u*,
    F rising before), negative at h (F = 0), found by brentq; W = F(u2).
    """
    L, k, d = _spring(spring_free_length, spring_stiffness, spring_base_offset)
    u_star, _ = statics.limit_point(L, k, d)
    h = float(statics.rest_height(L, d))

    def surplus(u: Any):
        return float(statics.spring_force(u, L, k, d)) * u - _spring_energy(u, L, k, d)

    u2 = brentq(surplus, u_star, h, xtol=1e-15, rtol=4.0 * np.finfo(float).eps)
    return float(statics.spring_force(u2, L, k, d))


def sudden_load_snaps(
    mass: float,
    damping_coefficient: float,
    spring_free_length: float = 0.5,
    spring_stiffness: float = 1e4,
    spring_base_offset: float = 0.2,
    gravity: float = STANDARD_GRAVITY,
) -> bool:
    """True if the load W = m g, applied at t = 0 to the mass m at rest (u = 0, u' = 0) and
    held, snaps the suspension through as the Suspension FMU's dynamics mode defines it:
    the deflection rises through the start of the far stable region, 2h - u*.

    m u'' + c u' + F(u) = W by solve_ivp (DOP853, rtol = atol = 1e-12) on the dynamic
    reference's right-hand side (references/suspension_dynamics.System). Each run stops at
    the first of three terminal events:
      - u rises through 2h - u*: a snap-through (the FMU's event);
      - u' falls through 0 before the saddle u2: the mass turns (it cannot have passed it,
        past u2 it only accelerates until 2h - u*); its energy is then below the saddle's
        (the potential W u - V rises from u1 to u2) and can never climb back: no snap;
      - the energy E = m u'^2/2 + V(u) - W u falls through V(u2) - W u2 before the saddle
        (E never rises, the damper dissipates): no snap. This ends overdamped runs, which
        never turn.
    """
    L, k, d = _spring(spring_free_length, spring_stiffness, spring_base_offset)
    m = require_positive("mass", mass, "kg")
    c = _non_negative("damping_coefficient", damping_coefficient, "N s/m")
    W = m * require_positive("gravity", gravity, "m/s^2")
    u_star, F_star = statics.limit_point(L, k, d)
    if W > F_star:
        return True  # only the far equilibrium exists; every motion ends there
    h = float(statics.rest_height(L, d))
    far_start = 2.0 * h - u_star
    u2 = _saddle(W, L, k, d)
    saddle_level = _spring_energy(u2, L, k, d) - W * u2

    system = dynamics.System((L, k, d), m, c, None, lambda t: W, None)

    def snap(t: float, x: Any):
        return x[0] - far_start

    ivp_event(snap, terminal=True, direction=1.0)

    # Both "no snap" events count only before the saddle: max(., u - u2) stays positive past
    # it and is still continuous, so solve_ivp's root finding applies.
    def turn(t: float, x: Any):
        return max(x[1], x[0] - u2)

    ivp_event(turn, terminal=True, direction=-1.0)

    def below_saddle(t: float, x: Any):
        energy = 0.5 * m * x[1] * x[1] + _spring_energy(x[0], L, k, d) - W * x[0]
        return max(energy - saddle_level, x[0] - u2)

    ivp_event(below_saddle, terminal=True, direction=-1.0)

    solution = solve_ivp(
        system,
        (0.0, SUSPENSION_MAX_TIME),
        system.initial(0.0, 0.0, 0.0),
        method="DOP853",
        rtol=SUSPENSION_TOLERANCE,
        atol=SUSPENSION_TOLERANCE,
        events=(snap, turn, below_saddle),
    )
    if solution.status == 1:
        return len(solution.t_events[0]) > 0
    raise RuntimeError(
        f"sudden load {W!r} N on {m!r} kg, c = {c!r} N s/m: undecided after "
        f"{SUSPENSION_MAX_TIME} s ({solution.message})"
    )


def sudden_snap_through_mass(
    damping_coefficient: float,
    spring_free_length: float = 0.5,
    spring_stiffness: float = 1e4,
    spring_base_offset: float = 0.2,
    gravity: float = STANDARD_GRAVITY,
    tolerance: float = 1e-6,
) -> float:
    """Threshold sprung mass (kg) for a suddenly applied weight m g (Suspension FMU with the
    dynamics effect, damping c in N s/m): m above it snaps through, below it does not.

    Bisection on m (relative width ``tolerance``) with sudden_load_snaps. Bracket: the
    undamped energy threshold (a damper only removes energy, so nothing lighter snaps) and
    F*/g (anything heavier has no near equilibrium). With c > 0 the damping ratio
    c / (2 sqrt(k_t m)) falls with m, so the threshold depends on c alone through the run.
    """
    L, k, d = _spring(spring_free_length, spring_stiffness, spring_base_offset)
    c = _non_negative("damping_coefficient", damping_coefficient, "N s/m")
    g = require_positive("gravity", gravity, "m/s^2")
    tol = require_positive("tolerance", tolerance)
    if not tol < 0.1:
        raise ValueError(f"tolerance = {tolerance!r} must be below 0.1 (relative)")
    low = sudden_snap_through_load_undamped(L, k, d) / g
    high = statics.limit_point(L, k, d)[1] / g
    while high - low > tol * high:
        middle = 0.5 * (low + high)
        if sudden_load_snaps(middle, c, L, k, d, g):
            high = middle
        else:
            low = middle
    return 0.5 * (low + high)


# --- landing gear: retraction time against supply pressure --------------------------------------


def gear_scene_values(
    scene_file: Path = GEAR_SCENE, **overrides: Any
) -> tuple[dict[str, float], float]:
    """(LandingGear values, stop time in s) of a dynamic gear scene: the FMU's defaults, the
    scene's parameters, effects and inputs (as generate.gear_dynamics_scene applies them),
    then ``overrides`` (any gear parameter or input, e.g. supply_pressure, airspeed)."""
    from ..cosim.scene import load_scene

    scene = load_scene(scene_file)
    specs = [spec for spec in scene.components.values() if Path(spec.fmu).stem == "LandingGear"]
    if len(specs) != 1:
        raise ValueError(f"scene {scene_file} has {len(specs)} LandingGear components, not 1")
    spec = specs[0]
    values = gear_reference.gear_values(
        start_values("LandingGear"), spec.parameters, spec.effects, spec.inputs
    )
    unknown = sorted(set(overrides) - set(values))
    if unknown:
        raise ValueError(f"unknown LandingGear variable(s) {', '.join(unknown)}")
    values.update(overrides)
    return values, float(scene.stop_time)


def retraction_time(
    supply_pressure: float,
    scene_file: Path = GEAR_SCENE,
    method: str = "LSODA",
    tolerance: float = 1e-12,
    stop_time: float | None = None,
    **overrides: Any,
) -> float:
    """Retraction time (s) of the gear_retraction_dynamic scene at ``supply_pressure`` (Pa):
    the first time the piston rises through stroke_max, as the FMU's retraction_time output
    reports it; math.nan if that does not happen by the scene's stop time.

    The equations are the dynamic gear reference's (the FMU's Dynamics right-hand side and
    stroke events, restarted at every stroke crossing 1e-9 s off the surface), integrated
    only until the retraction instead of over the whole scene. method/tolerance: solve_ivp's;
    the default LSODA at 1e-12 gives the stored Radau reference's 2.259698139413 s to 1.1e-11 s
    at the scene's pressure in 0.4 s instead of 29 s. stop_time (s): the scene's unless
    given. ``overrides``: other gear values.
    """
    p = require_positive("supply_pressure", supply_pressure, "Pa")
    values, scene_stop = gear_scene_values(scene_file, supply_pressure=p, **overrides)
    stop_time = scene_stop if stop_time is None else require_positive("stop_time", stop_time, "s")
    if not values["drive"] == "dynamics" or not values["hydraulics"]:
        raise ValueError("retraction_time needs drive = 'dynamics' and the hydraulics effect")
    tol = require_positive("tolerance", tolerance)
    # Validation of the gear values is the FMU's (require_* raise MechanismError/RangeError,
    # both ValueErrors), exactly as for the scene reference.
    from ..references.gear_dynamics import SURFACE_RTOL, dynamics_model, stroke_crossings

    model = dynamics_model(values)

    def rhs(t: float, y: Any):
        return model.derivatives(list(y), values)[0]

    t, y = 0.0, np.array(model.initial_state(), dtype=float)
    high = model.stroke[1]
    surface = SURFACE_RTOL * (high - model.stroke[0])
    for _ in range(10_000):
        solution = solve_ivp(
            rhs,
            (t, stop_time),
            y,
            method=method,
            rtol=tol,
            atol=tol,
            events=stroke_crossings(model),
        )
        if solution.status == -1:
            raise RuntimeError(f"solve_ivp failed at t = {t} s: {solution.message}")
        start_length = model.piston_length(list(y))
        t, y = float(solution.t[-1]), solution.y[:, -1]
        if solution.status != 1 or t >= stop_time:
            return math.nan
        # rising through stroke_max (the FMU's retraction event): the piece started below
        # it, as references/gear_dynamics decides (not by the rate's sign at the event)
        if len(solution.t_events[0]) and start_length < high - surface:
            return t
        t_next = min(t + GEAR_EVENT_OFFSET, stop_time)
        step = solve_ivp(rhs, (t, t_next), y, method="DOP853", rtol=tol, atol=tol)
        if step.status == -1:
            raise RuntimeError(
                f"solve_ivp failed stepping off the stroke surface at t = {t} s: {step.message}"
            )
        t, y = t_next, step.y[:, -1]
    raise RuntimeError("more than 10000 stroke crossings")


def minimum_retraction_pressure(
    scene_file: Path = GEAR_SCENE, include_coulomb: bool = False, **overrides: Any
) -> float:
    """Lowest supply pressure (Pa) at which the stalled actuator holds the gear at every angle
    from its start to stroke_max (static moment balance, numpy closed forms).

    At rest the valve flows vanish, so the cap side sits at supply and the rod side at
    return pressure: F = p_s A1 - p_r A2. The enabled loads resist retraction with
    M(theta) = m l_cg g sin(psi) + (1/2) rho CdA V |V| L cos(psi), psi = theta - theta_down
    + pitch; the piston's arm is d h sin(theta) / x, x^2 = d^2 + h^2 - 2 d h cos(theta).
    p_min = max over theta of (M / arm + p_r A2) / A1: the lowest pressure that holds the
    gear at every angle up to stroke_max, i.e. that retracts it quasi-statically. The smoothed
    Coulomb friction (tanh(omega / omega_s)) vanishes at a creeping speed, so it is left out
    by default; include_coulomb adds the full Coulomb moment (a gear moving much faster than
    omega_s). Not an exact bound on the dynamic runs: on the scene's gear the balance is
    hardest at stroke_max itself (shortest arm), and a gear arriving with momentum still
    reaches it a little below p_min (measured: 0.98 p_min retracts in 3.5 s, 0.9 p_min
    stalls); within a finite stop time more is needed (lowest_retracting_pressure).
    """
    v, _ = gear_scene_values(scene_file, **overrides)
    d = require_positive("attachment_distance", v["attachment_distance"], "m")
    h = require_positive("pivot_height", v["pivot_height"], "m")
    L = require_positive("bar_length", v["bar_length"], "m")
    lever = v["bar_mass"] * L / 2.0 + v["wheel_mass"] * L
    x_high = require_positive("stroke_max", v["stroke_max"], "m")
    bore, rod = (
        require_positive("bore", v["bore"], "m"),
        _non_negative("rod_diameter", v["rod_diameter"], "m"),
    )
    cap_area = np.pi * bore**2 / 4.0
    rod_area = cap_area - np.pi * rod**2 / 4.0
    cos_end = (d * d + h * h - x_high * x_high) / (2.0 * d * h)
    if not -1.0 < cos_end < 1.0:
        raise ValueError(f"stroke_max = {x_high!r} m is not reachable by the linkage")
    start, end = float(v["initial_angle"]), float(np.arccos(cos_end))
    if not start < end:
        raise ValueError(
            f"initial_angle = {start!r} rad is not below the retracted angle {end!r} rad"
        )
    airspeed = float(v["airspeed"])
    drag = (
        0.5 * v["air_density"] * v["drag_area"] * airspeed * abs(airspeed) * L
        if v["aero_drag"]
        else 0.0
    )
    weight = lever * v["gravity_acceleration"] if v["gravity"] else 0.0
    friction = v["coulomb_friction"] if (include_coulomb and v["pivot_friction"]) else 0.0

    def required(theta: Any):
        theta = np.asarray(theta, dtype=float)
        psi = theta - v["down_angle"] + v["airframe_pitch"]
        x = np.sqrt(d * d + h * h - 2.0 * d * h * np.cos(theta))
        arm = d * h * np.sin(theta) / x
        moment = weight * np.sin(psi) + drag * np.cos(psi) + friction
        return (moment / arm + v["return_pressure"] * rod_area) / cap_area

    grid = np.linspace(start, end, 4001)
    values = required(grid)
    i = int(np.argmax(values))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    # The maximum can sit at an end of the stroke; refine inside the bracketing cells.
    refined = minimize_scalar(
        lambda th: -float(required(th)), bounds=(lo, hi), method="bounded", options={"xatol": 1e-13}
    )
    return float(max(values[i], -refined.fun))


def lowest_retracting_pressure(
    low: Any,
    high: Any,
    scene_file: Any = GEAR_SCENE,
    relative_width: float = 1e-4,
    **overrides: Any,
) -> Any:
    """Lowest supply pressure (Pa) in [low, high] whose scene run retracts by the stop time,
    by bisection on retraction_time being finite (one gear run per halving, ~0.5 s each)."""
    low = require_positive("low", low, "Pa")
    high = require_positive("high", high, "Pa")
    if not math.isfinite(retraction_time(high, scene_file, **overrides)):
        raise ValueError(f"high = {high!r} Pa does not retract the gear by the stop time")
    if math.isfinite(retraction_time(low, scene_file, **overrides)):
        raise ValueError(f"low = {low!r} Pa already retracts the gear")
    while high - low > relative_width * high:
        middle = 0.5 * (low + high)
        if math.isfinite(retraction_time(middle, scene_file, **overrides)):
            high = middle
        else:
            low = middle
    return high


# --- valve train: float speed ---------------------------------------------------------------

_CAM_FIELDS = ("cam_law", "lift", "rise_start", "rise_angle", "high_dwell_angle", "return_angle")


def valve_float_point(
    spring_preload: float, valve_mass: float = 0.1, spring_stiffness: float = 5e4, **cam: Any
) -> tuple[float, float]:
    """(camshaft speed in rad/s, camshaft angle in rad) where the valve first floats at
    constant camshaft speed; (inf, nan) if the valve never decelerates.

    At constant speed w the valve's acceleration is L''(theta) w^2, so the contact force
    m L'' w^2 + k L + F0 first vanishes at w^2 = min over L'' < 0 of (k L + F0)/(m (-L'')).
    L and L'' from the numpy reference (cam law on the tappet at unit speed, rocker closed
    forms) on a fine grid of the phase x in [0, 1] of the rise and of the return, both ends
    included as the segments' one-sided limits (the harmonic law decelerates hardest at a
    segment end); every grid local minimum is refined by a bounded scalar minimisation.
    ``cam``: ValveTrain parameters (cam_law, lift, rise_start, rise_angle, high_dwell_angle,
    return_angle and the geometry fields), defaults the FMU's.
    """
    F0 = _non_negative("spring_preload", spring_preload, "N")
    m = require_positive("valve_mass", valve_mass, "kg")
    k = _non_negative("spring_stiffness", spring_stiffness, "N/m")
    defaults = model_defaults("ValveTrain")
    allowed = set(_CAM_FIELDS) | set(valve_reference.GEOMETRY_FIELDS)
    unknown = sorted(set(cam) - allowed)
    if unknown:
        raise ValueError(f"unknown cam or geometry parameter(s) {', '.join(unknown)}")
    p = {key: cam.get(key, defaults[key]) for key in allowed}
    law = p["cam_law"]
    if law not in valve_reference.CAM_LAWS:
        raise ValueError(f"cam_law = {law!r} is not one of {', '.join(valve_reference.CAM_LAWS)}")
    lift = require_positive("lift", p["lift"], "m")
    rise, ret = (
        require_positive("rise_angle", p["rise_angle"], "rad"),
        require_positive("return_angle", p["return_angle"], "rad"),
    )
    dwell = _non_negative("high_dwell_angle", p["high_dwell_angle"], "rad")
    if rise + dwell + ret > 2.0 * np.pi:
        raise ValueError(
            f"rise_angle + high_dwell_angle + return_angle = {rise + dwell + ret!r} "
            f"rad exceeds one revolution"
        )
    geometry = {key: require_finite(key, p[key], "m") for key in valve_reference.GEOMETRY_FIELDS}
    segments = (("rise", rise, 0.0), ("return", ret, rise + dwell))

    def ratio(segment: Any, x: Any):
        """w^2 (rad^2/s^2) at which the contact force vanishes at phase x; inf where L'' >= 0."""
        f, f1, f2 = valve_reference.normalized(law, x)
        if segment == "rise":
            beta = rise
            s, s1, s2 = lift * f, lift * f1 / beta, lift * f2 / beta**2
        else:
            beta = ret
            s, s1, s2 = lift * (1.0 - f), -lift * f1 / beta, -lift * f2 / beta**2
        motion = valve_reference.forward(geometry, s, s1, s2)  # unit camshaft speed
        L, accel = motion["valve_lift"], motion["valve_acceleration"]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(accel < 0.0, np.maximum(k * L + F0, 0.0) / (m * -accel), np.inf)

    best = (math.inf, math.nan)
    x = np.linspace(0.0, 1.0, FLOAT_GRID)
    for segment, beta, offset in segments:
        values = ratio(segment, x)
        if np.any(np.isnan(values)):
            raise ValueError("the valve-train geometry does not assemble along the cam law")
        padded = np.concatenate(([np.inf], values, [np.inf]))
        minima = np.flatnonzero(
            np.isfinite(values) & (values <= padded[:-2]) & (values <= padded[2:])
        )
        for i in minima.tolist():
            lo, hi = x[max(i - 1, 0)], x[min(i + 1, x.size - 1)]
            found = minimize_scalar(
                lambda z: float(ratio(segment, z)),
                bounds=(lo, hi),
                method="bounded",
                options={"xatol": 1e-14},
            )
            candidates = [(float(values[i]), float(x[i]))]
            if found.success and math.isfinite(found.fun):
                candidates.append((float(found.fun), float(found.x)))
            value, phase = min(candidates)
            if value < best[0]:
                best = (value, float(p["rise_start"]) + offset + phase * beta)
    if best[0] == math.inf:
        return math.inf, math.nan
    return math.sqrt(best[0]), best[1]


def valve_float_speed(
    spring_preload: float, valve_mass: float = 0.1, spring_stiffness: float = 5e4, **cam: Any
) -> float:
    """Constant camshaft speed (rad/s) at which the ValveTrain FMU's valve (forward drive,
    valve_spring effect) starts to float: see valve_float_point. math.inf if it never does."""
    return valve_float_point(spring_preload, valve_mass, spring_stiffness, **cam)[0]
