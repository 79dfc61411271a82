"""Where a closed-form FMU's step goes, against the 1.3x-its-null target of issue 21.

For each closed-form case of model_cost (the same models, parameters and inputs) this times,
in-process (``timeit`` on the process's CPU time, median of 7), what the model adds to its null twin's step:

- ``do_step``: the whole MechSlave.do_step (guards, copy of the values for the
  all-or-nothing step, input and output finiteness checks, the model's update);
- ``shared``: the same do_step with the model's update replaced by an empty function,
  the part every model pays;
- ``update``: the model's update alone (its physics, reading inputs, writing outputs);
- ``physics``: the physics function the update calls, alone, with its arguments ready.

and, through the FMU (model_cost's loop, CPU time), the null twin's step and the model's.
The 1.3x target leaves a model 0.3x its null's step for everything in ``do_step``; where
``physics`` alone exceeds that budget no Python do_step can meet the target.

    python -m mechfmu.tools.bench.model_floor [--fmu-dir fmus] [--steps 2000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
import timeit
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...packaging.describe import model_class
from ...runtime.physics import landing_gear as gear
from ...runtime.physics import profiles, road
from . import model_cost, timing

MICRO = 1e6


@dataclass(frozen=True)
class Floor:
    """In-process times of one case (us per call) and its FMU times (us per step)."""

    label: str
    do_step: float
    shared: float
    update: float
    physics: float | None
    null_fmu: float | None = None
    model_fmu: float | None = None


def _per_call(function: Callable[[], Any], number: int) -> float:
    """Median over 7 runs of ``number`` calls of ``function``, in us per call."""
    runs = timeit.repeat(function, number=number, repeat=7, timer=time.process_time)
    return statistics.median(runs) / number * MICRO


def _physics(model: Any, label: str, at: float) -> Callable[[], Any] | None:
    """The physics call of ``model``'s update at time ``at`` (s) with its arguments bound,
    or None."""
    v = model.values
    name = type(model).__name__
    if name == "LoadProfile":
        args = (v["shape"], v["initial_value"], v["final_value"], v["start_time"], v["duration"])
        return lambda: profiles.load(at, *args, model.table)
    if name == "RoadProfile":
        bump = (v["shape"], v["height"], v["duration"], v["start_time"], v["amplitude"])
        return lambda: road.road(at, *bump, v["frequency"], model.table)
    if name in ("CrankDrive", "CamshaftDrive"):
        ratio = model.RATIO
        angle, speeds = v["initial_angle"], (ratio * v["initial_speed"], ratio * v["speed"])
        return lambda: profiles.rotation(at, angle, *speeds, v["ramp_time"], v["start_time"])
    if name == "PistonActuator":
        stroke = model._stroke_parameters()
        return lambda: profiles.stroke(at, *stroke)
    if name == "LandingGear":
        inputs = (v["piston_extension"], v["piston_speed"], v["piston_acceleration"])
        d, h = v["attachment_distance"], v["pivot_height"]
        return lambda: gear.gear_motion(*inputs, d, h)
    if hasattr(model, "closed_form"):  # the linkages' closed forms (a dict of outputs)
        return lambda: model.closed_form(at)
    return None  # Suspension: its update is the physics (a safeguarded Newton solve)


def measure_case(case: model_cost.ModelCase, number: int = 20000) -> Floor:
    """In-process times of ``case`` a third into its motion (us per call)."""
    cls = model_class(case.model)
    model = cls(instance_name="floor")
    model.values.update(case.parameters)
    model.enter_initialization_mode()
    model.exit_initialization_mode()
    if model.pending_error is not None:
        raise RuntimeError(f"{case.label}: {model.pending_error}")
    step = case.duration_s / 2000
    start = 0.3 * case.duration_s
    if case.inputs:
        for name, column in case.inputs(np.array([start + step])).items():
            model.values[name] = float(column[0])
    if not model.do_step(start, step):
        raise RuntimeError(f"{case.label}: the step was discarded")
    do_step = _per_call(lambda: model.do_step(start, step), number)
    update = _per_call(lambda: model.update(start + step, step), number)
    physics = _physics(model, case.label, start + step)
    physics_us = None if physics is None else _per_call(physics, number)
    model.update = lambda time, step_size: None  # type: ignore[method-assign]  # the shared path alone
    shared = _per_call(lambda: model.do_step(start, step), number)
    return Floor(case.label, do_step, shared, update, physics_us)


def closed_form_cases() -> tuple[model_cost.ModelCase, ...]:
    """model_cost's cases whose target is 1.3x (every one but the constraint solvers)."""
    return tuple(
        c for c in model_cost.CASES if "constraint_solver" not in c.label and c.effect_of is None
    )


def measure(fmu_dir: str | None, steps: int, repeats: int) -> list[Floor]:
    """Floors of every closed-form case; with ``fmu_dir`` also their FMU rows (CPU time)."""
    cases = closed_form_cases()
    floors = [measure_case(case) for case in cases]
    if fmu_dir is None:
        return floors
    timing.use_cpu_time(True)
    rows = {row.case: row.value for row in model_cost.measure(fmu_dir, steps, repeats, cases)}
    return [
        Floor(
            **{
                **floor.__dict__,
                "null_fmu": rows[f"{floor.label}: null"],
                "model_fmu": rows[f"{floor.label}: model"],
            }
        )
        for floor in floors
    ]


def table(floors: list[Floor]) -> str:
    """A Markdown table of ``floors`` (us; budget = 0.3 x the null's FMU step)."""

    def cell(value: float | None) -> str:
        return "" if value is None else f"{value:.3g}"

    lines = [
        "| case | null FMU step | model FMU step | model / null | budget 0.3 x null "
        "| do_step | shared path | update | physics alone |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for f in floors:
        ratio = budget = None
        if f.null_fmu and f.model_fmu:
            ratio, budget = f.model_fmu / f.null_fmu, 0.3 * f.null_fmu
        lines.append(
            f"| {f.label} | {cell(f.null_fmu)} | {cell(f.model_fmu)} | {cell(ratio)} | "
            f"{cell(budget)} | {cell(f.do_step)} | {cell(f.shared)} | {cell(f.update)} | "
            f"{cell(f.physics)} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the table (``--fmu-dir ''``: in-process columns only)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu-dir", default="fmus", help="built FMUs ('' for none)")
    parser.add_argument("--steps", type=int, default=2000, help="FMU loop steps (default 2000)")
    parser.add_argument("--repeats", type=int, default=3, help="FMU loop repeats (default 3)")
    args = parser.parse_args(argv)
    print(table(measure(args.fmu_dir or None, args.steps, args.repeats)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
