"""Work-precision: our integrators against scipy.integrate.solve_ivp on the same equations.

``mechfmu study --work-precision`` (``make work-precision``). Three right-hand sides, each
the FMU's own (runtime/physics), smooth over the span (no contact switch or stroke limit
inside it, so every method meets the same problem):

gear       LandingGear's dynamics drive with the six effects of gear_retraction_dynamic
           (inertia, gravity, drag at 40 m/s, pivot friction, end stops, built-in
           hydraulics: 4 states), over the first 1.5 s of the retraction (the scene uses
           radau; the table shows dopri5 needs fewer evaluations: not stiff at these
           tolerances).
suspension Suspension's dynamics with damping and tyre (4 states), from rest under the
           2500 N step load of suspension_sudden_load, over 1 s.
valve      ValveSpring's valve on its spring pushed by the rocker through the 1e7 N/m
           contact (3 states: lift, velocity, contact work), the rocker rising on a 3-4-5
           law of 10.5 mm over 10 ms; from 2 to 5 ms (contact engaged, off the seat).

Methods: ours (runtime/numerics/integrators.py) dopri5 and radau at rtol = atol = tol, and
rk4 at fixed sub-steps; scipy's RK45, DOP853, Radau and LSODA at the same rtol = atol.
Every run counts the calls of the right-hand side itself (a wrapper; scipy's finite-
difference Jacobians call it too, as ours do). The error is the largest over the state's
components of |y_i(T) - y_ref,i(T)| / peak_i, peak_i the largest |y_ref,i| on the span:
a relative error at the end time. The reference: scipy's DOP853 at rtol = atol = 1e-13
with the state scaled so that atol means the same for all (on the gear it agrees with
Radau at 1e-13 to 2e-14 of the peaks).

Writes work_precision.csv (one row per run, a pandas DataFrame) and work_precision.md
(the evaluations each method needs at a few target errors, interpolated log-log).
"""

from typing import Any
import itertools
import math
import statistics
import time

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from ...cosim.scene import find_file, load_scene
from ...references.gear_dynamics import dynamics_model, gear_values
from ...runtime.numerics.integrators import make_integrator
from ...runtime.physics import suspension as susp_statics
from ...runtime.physics import suspension_dynamics as sd
from ...runtime.physics import valve_spring as vs
from ..scene_references import model_defaults, start_values

OURS_ADAPTIVE = ("dopri5", "radau")
SCIPY = ("RK45", "DOP853", "Radau", "LSODA")
TOLERANCES = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
QUICK_TOLERANCES = (1e-5, 1e-8)
REFERENCE_TOLERANCE = 1e-13
TARGET_ERRORS = (1e-4, 1e-6, 1e-8)
COLUMNS = (
    "problem",
    "library",
    "method",
    "tolerance",
    "substep",
    "error",
    "rhs_evaluations",
    "steps",
    "wall_time_s",
)


class Problem:
    """y' = rhs(t, y) from y0 over [t0, t1] s; ``substeps`` the fixed sub-steps (s) of
    rk4."""

    def __init__(self, name: str, rhs: Any, y0: Any, t0: float, t1: float, substeps: Any) -> None:
        self.name, self.rhs, self.y0, self.t0, self.t1 = name, rhs, list(y0), t0, t1
        self.substeps = substeps


def gear_problem() -> Problem:
    """The gear: gear_retraction_dynamic's LandingGear, 0 .. 1.5 s (stroke end at ~2.1 s)."""
    scene = load_scene(find_file("gear_retraction_dynamic"))
    spec = scene.components["gear"]
    values = gear_values(start_values("LandingGear"), spec.parameters, spec.effects, spec.inputs)
    dynamics = dynamics_model(values)
    return Problem(
        "gear",
        lambda t, y: dynamics.derivatives(y, values)[0],
        dynamics.initial_state(),
        0.0,
        1.5,
        (3e-3, 1e-3, 3e-4),
    )


def suspension_problem() -> Problem:
    """The suspension with damping and tyre from rest under 2500 N, 0 .. 1 s."""
    v = model_defaults("Suspension")
    spring = susp_statics.make_spring(
        v["spring_free_length"], v["spring_stiffness"], v["spring_base_offset"]
    )
    model = sd.make_model(
        spring,
        v["mass"],
        200.0,
        v["tyre_stiffness"],
        v["unsprung_mass"],
        sd.Effects(True, True, False),
    )
    inputs = sd.StepInputs()
    inputs.set_constant(0.0, 2500.0, 0.0, 0.0)
    rhs = sd.build_rhs(model, inputs)
    y0 = sd.initial_state(model, 0.0, 0.0, inputs, 0.0)
    return Problem("suspension", rhs, y0, 0.0, 1.0, (1e-2, 3e-3, 1e-3))


def valve_problem() -> Problem:
    """The valve on the rising rocker, contact engaged, 2 .. 5 ms of a 10 ms rise."""
    p = vs.make_parameters()
    drive = vs.StepDrive("interpolate")
    drive.set_step(0.0, 0.01, (0.0, 0.0, 0.0), (0.0105, 0.0, 0.0))  # the 3-4-5 rise
    modes = vs.Modes(vs.Engaged(True, False))
    rhs = vs.build_rhs(p, drive, modes)
    L, rate, _ = drive.at(0.002)
    return Problem("valve", rhs, vs.initial_state(p, L, rate), 0.002, 0.005, (1e-5, 3e-6, 1e-6))


PROBLEMS = {"gear": gear_problem, "suspension": suspension_problem, "valve": valve_problem}


class Counted:
    """The right-hand side with a call counter (lists in, lists out, as our integrators
    call it; scipy's arrays are accepted and an array returned)."""

    def __init__(self, rhs: Any) -> None:
        self.rhs, self.calls = rhs, 0

    def ours(self, t: float, y: Any) -> Any:
        self.calls += 1
        return self.rhs(t, y)

    def scipy(self, t: float, y: Any) -> Any:
        self.calls += 1
        return np.asarray(self.rhs(t, y.tolist()), dtype=float)


def reference(problem: Problem) -> Any:
    """(state at t1, per-component peak |y| on the span) from scipy at 1e-13."""
    y0 = np.asarray(problem.y0, dtype=float)
    scale = np.maximum(np.abs(y0), 1.0)
    # solve in scaled variables so that one atol suits states of any unit (Pa and rad)
    counted = Counted(problem.rhs)
    solution = solve_ivp(
        lambda t, z: counted.scipy(t, z * scale) / scale,
        (problem.t0, problem.t1),
        y0 / scale,
        method="DOP853",
        rtol=REFERENCE_TOLERANCE,
        atol=REFERENCE_TOLERANCE,
        dense_output=True,
    )
    if not solution.success:
        raise RuntimeError(f"reference of {problem.name}: {solution.message}")
    samples = solution.sol(np.linspace(problem.t0, problem.t1, 401)) * scale[:, None]
    peak = np.maximum(np.abs(samples).max(axis=1), 1e-300)
    return solution.y[:, -1] * scale, peak


def _ours(problem: Any, method: Any, tolerance: float, substep: Any):
    counted = Counted(problem.rhs)
    integrator = make_integrator(method, tolerance, tolerance, substep if substep else math.inf)
    started = time.perf_counter()
    y = integrator.advance(counted.ours, problem.t0, list(problem.y0), problem.t1).y
    return y, counted.calls, integrator.stats.substeps, time.perf_counter() - started


def _scipy(problem: Any, method: Any, tolerance: float):
    counted = Counted(problem.rhs)
    started = time.perf_counter()
    solution = solve_ivp(
        counted.scipy,
        (problem.t0, problem.t1),
        np.asarray(problem.y0, dtype=float),
        method=method,
        rtol=tolerance,
        atol=tolerance,
    )
    wall = time.perf_counter() - started
    if not solution.success:
        raise RuntimeError(f"{method} on {problem.name}: {solution.message}")
    return solution.y[:, -1], counted.calls, len(solution.t) - 1, wall


def runs(problem: Problem, tolerances: Any, repeats: int) -> list:
    """Rows (dicts of COLUMNS) of every method on ``problem``; wall time the median of
    ``repeats`` runs."""
    y_ref, peak = reference(problem)
    cases = [("mechfmu", m, tol, None) for m in OURS_ADAPTIVE for tol in tolerances]
    cases += [("mechfmu", "rk4", None, h) for h in problem.substeps]
    cases += [("scipy", m, tol, None) for m in SCIPY for tol in tolerances]
    rows = []
    for library, method, tolerance, substep in cases:
        walls = []
        for _ in range(repeats):
            if library == "mechfmu":
                y, calls, steps, wall = _ours(problem, method, tolerance or 1.0, substep)
            else:
                y, calls, steps, wall = _scipy(problem, method, tolerance)
            walls.append(wall)
        error = float(np.max(np.abs(np.asarray(y, dtype=float) - y_ref) / peak))
        rows.append(
            {
                "problem": problem.name,
                "library": library,
                "method": method,
                "tolerance": tolerance if tolerance is not None else math.nan,
                "substep": substep if substep is not None else math.nan,
                "error": error,
                "rhs_evaluations": calls,
                "steps": steps,
                "wall_time_s": statistics.median(walls),
            }
        )
    return rows


def table(
    problems: Any = tuple(PROBLEMS), tolerances: Any = TOLERANCES, repeats: int = 3
) -> pd.DataFrame:
    """The work-precision DataFrame (COLUMNS) of the named problems."""
    rows = [row for name in problems for row in runs(PROBLEMS[name](), tolerances, repeats)]
    return pd.DataFrame(rows, columns=list(COLUMNS))


def evaluations_at(
    frame: pd.DataFrame, targets: Any = TARGET_ERRORS, column: str = "rhs_evaluations"
) -> pd.DataFrame:
    """What each (problem, library, method) spends in ``column`` (right-hand-side
    evaluations, or wall_time_s) for each target error: log-log interpolation between its
    two runs that bracket it (NaN if none do); and its observed order, the least-squares
    slope of -log(error) against log(evaluations) over its runs (a method of order p
    gives about p: error ~ evaluations^-p)."""
    out = []
    for (problem, library, method), group in frame.groupby(
        ["problem", "library", "method"], sort=False
    ):
        errors = np.log10(np.maximum(group["error"].to_numpy(), 1e-300))
        points = sorted(zip(errors, np.log10(group[column].to_numpy())))
        row = {"problem": problem, "library": library, "method": method}
        for target in targets:
            x, found = math.log10(target), math.nan
            for (e0, n0), (e1, n1) in itertools.pairwise(points):
                if e0 <= x <= e1 and e1 > e0:
                    found = 10.0 ** (n0 + (n1 - n0) * (x - e0) / (e1 - e0))
                    break
            row[f"at {target:g}"] = found
        work = np.log10(group["rhs_evaluations"].to_numpy())
        row["observed order"] = (
            -float(np.polyfit(work, errors, 1)[0])
            if len(group) > 1 and np.ptp(work) > 0
            else math.nan
        )
        out.append(row)
    return pd.DataFrame(out)


def markdown(frame: pd.DataFrame) -> str:
    """work_precision.md: per problem, the evaluations and the wall time (median) each
    method needs at the target errors, and its observed order."""
    calls = evaluations_at(frame)
    walls = evaluations_at(frame, column="wall_time_s")
    heads = [f"at {target:g}" for target in TARGET_ERRORS]
    lines = []
    for problem in calls["problem"].unique():
        lines += [
            f"#### {problem}",
            "",
            "| library | method | "
            + " | ".join(f"RHS calls, error {h[3:]}" for h in heads)
            + " | "
            + " | ".join(f"ms, error {h[3:]}" for h in heads)
            + " | observed order |",
            "|---|---|" + "---:|" * (2 * len(heads) + 1),
        ]
        for (_, row), (_, wall) in zip(
            calls[calls["problem"] == problem].iterrows(),
            walls[walls["problem"] == problem].iterrows(),
        ):
            cells = ["" if math.isnan(row[h]) else f"{row[h]:.0f}" for h in heads]
            cells += ["" if math.isnan(wall[h]) else f"{wall[h] * 1e3:.3g}" for h in heads]
            order = "" if math.isnan(row["observed order"]) else f"{row['observed order']:.1f}"
            lines.append(
                f"| {row['library']} | {row['method']} | " + " | ".join(cells) + f" | {order} |"
            )
        lines.append("")
    return "\n".join(lines)
