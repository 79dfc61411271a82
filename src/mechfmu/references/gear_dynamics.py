"""High-accuracy references for the dynamic gear scenes (scipy).

The same equations as LandingGear.fmu's dynamics drive (its right-hand side is reused, so
the reference checks the FMU's integration, events and co-simulation plumbing, not a second
derivation), integrated by scipy's Radau at rtol = atol = 1e-12, restarted at every
stroke-limit crossing (where the end-stop force has a kink), and evaluated by its dense
output at the scene's sample times.

The pieces are contiguous and each sample is assigned to one by its start time
(references/breakpoints.py), so no sample falls between pieces whatever the event times round
to. The 1e-9 s step off the stroke surface after a crossing is taken with an explicit method
(DOP853): Radau's Newton iteration, started exactly on the kink, can fail there on some CPUs'
BLAS kernels ("required step size is less than spacing between numbers"); over 1e-9 s the
problem is not stiff. A failed integration raises, naming the time, never leaves a gap.
"""

import numpy as np
from scipy.integrate import solve_ivp
from typing import Any

from ..runtime.physics import gear_dynamics as gd
from ..runtime.physics import landing_gear as gear
from .breakpoints import piece_of_samples
from .events import ivp_event

TOLERANCE = 1e-12
# Off the stroke surface after a crossing (s), so the restarted integration does not refire.
STEP_OFF = 1e-9
# A piece that starts within SURFACE_RTOL * (stroke_max - stroke_min) of a stroke limit
# starts on it: its end there is no crossing (the FMU's rule: an event needs a nonzero
# event function at the step start), whatever the sign of the rounding-level distance.
SURFACE_RTOL = 1e-12


def gear_values(defaults: Any, parameters: Any, effects: Any, inputs: Any) -> Any:
    """The FMU's variable values as a scene sets them: defaults, parameters, effects, inputs."""
    values = dict(defaults)
    values.update(parameters)
    values.update({name: True for name in effects})
    values.update(inputs)
    return values


def dynamics_model(values: Any) -> Any:
    """The FMU's own right-hand side (runtime.physics.gear_dynamics.Dynamics) for the gear
    ``values``."""
    body = gd.make_body(values["bar_length"], values["bar_mass"], values["wheel_mass"])
    d, h = gear.check_geometry(values["attachment_distance"], values["pivot_height"])
    geometry = gd.Geometry(d, h, values["down_angle"], values["airframe_pitch"])
    return gd.Dynamics(values, body, geometry)


def stroke_crossings(dynamics: Any) -> Any:
    """Terminal solve_ivp events: the piston length through stroke_max, through stroke_min
    (the integration restarts at each, as the FMU's does at the kink)."""

    def crossing(limit: Any):
        def event(t: float, y: Any):
            return dynamics.piston_length(y) - limit

        return ivp_event(event, terminal=True)

    low, high = dynamics.stroke
    return [crossing(high), crossing(low)]


def simulate(values: Any, times: Any) -> Any:
    """Columns of the dynamics drive at ``times`` (s), and the stroke event times."""
    dynamics = dynamics_model(values)
    rhs = lambda t, y: dynamics.derivatives(list(y), values)[0]  # noqa: E731
    t, y = times[0], np.array(dynamics.initial_state(), dtype=float)
    pieces: list = []
    events: dict[str, list[float]] = {"stroke_max": [], "stroke_min": []}
    for _ in range(10_000):
        solution = solve_ivp(
            rhs,
            (t, times[-1]),
            y,
            method="Radau",
            rtol=TOLERANCE,
            atol=TOLERANCE,
            dense_output=True,
            events=stroke_crossings(dynamics),
        )
        if solution.status == -1:
            raise RuntimeError(f"gear reference: Radau failed at t = {t!r} s: {solution.message}")
        pieces.append((t, float(solution.t[-1]), solution.sol))
        start_length = dynamics.piston_length(list(y))
        t, y = float(solution.t[-1]), solution.y[:, -1]
        if solution.status != 1 or t >= times[-1]:
            break
        # like the FMU: retraction = rising through stroke_max, extension = falling through
        # stroke_min, decided by the side the piece started on (not by the sign of the
        # piston rate at the event, which is rounding noise where the piston rests on a
        # stop); every crossing restarts the integration at the kink
        low, high = dynamics.stroke
        surface = SURFACE_RTOL * (high - low)
        if len(solution.t_events[0]) and start_length < high - surface:
            events["stroke_max"].append(t)
        if len(solution.t_events[1]) and start_length > low + surface:
            events["stroke_min"].append(t)
        t_next = min(t + STEP_OFF, times[-1])  # step off the surface so it does not refire
        step = solve_ivp(
            rhs, (t, t_next), y, method="DOP853", rtol=TOLERANCE, atol=TOLERANCE, dense_output=True
        )
        if step.status == -1:
            raise RuntimeError(
                f"gear reference: the step off the stroke surface at "
                f"t = {t!r} s failed: {step.message}"
            )
        pieces.append((t, t_next, step.sol))
        t, y = t_next, step.y[:, -1]
    else:
        raise RuntimeError(f"gear reference: more than 10000 stroke crossings by t = {t!r} s")
    owner = piece_of_samples([p[0] for p in pieces], [p[1] for p in pieces], times)
    columns: dict[str, Any] = {}
    for time, index in zip(times, owner):
        state = list(pieces[index][2](time))
        sample = dict(values, retraction_time=-1.0, extension_time=-1.0)
        dynamics.publish(sample, time, state)
        # the FMU records a stroke event once it has happened (rising/falling crossings)
        rises = [e for e in events["stroke_max"] if e <= time]
        falls = [e for e in events["stroke_min"] if e <= time]
        sample["retraction_time"] = rises[0] if rises else -1.0
        sample["extension_time"] = falls[0] if falls else -1.0
        for key, value in sample.items():
            if isinstance(value, float):
                columns.setdefault(key, []).append(value)
    return columns
