"""Benchmark 2: what each kinematic model costs per step, against its null twin.

The null twin (mechfmu.packaging.build, null=True) has the same variables, parameters and
initialisation but a do_step that returns at once, so the difference is the model's own
computation; the rest (pythonfmu's C++ layer, the Python call, getters and setters) is the
same for both. Each is driven by a tight loop of raw ctypes calls on prepared arrays:
fmi2SetReal of all its Real inputs (values that advance with time), fmi2DoStep,
fmi2GetReal of all its Real outputs.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import contextlib
import math
import shutil
import sys
import tempfile
from ctypes import c_double, c_uint
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

from ...cosim.fmu_file import unpack
from ...packaging.build import build_all
from ...references import landing_gear
from ...runtime.physics import landing_gear as gear
from . import timing
from .report import Row, Target, ratio_row
from .timing import side_by_side_medians
from collections.abc import Callable, Iterator

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from fmpy.model_description import ModelDescription
    from numpy import ndarray

BENCHMARK = "model cost"
# Issue 21: a closed form (every model but the constraint solvers) at most 1.3x its null
# twin, a constraint solver at most 6x (issue 5 asked 1.2x of every model).
TARGET = Target(1.3, "<= 1.3")
SOLVER_TARGET = Target(6.0, "<= 6")
MICRO = 1e6
CAMSHAFT_SPEED = 50.0 * math.pi  # rad/s: 3000 engine rpm, as in the valve_train scene


def shaft_turning(prefix: str, speed: float, initial_angle: float = 0.0) -> Callable:
    """Inputs ``<prefix>_angle`` (rad), ``_speed`` (rad/s), ``_acceleration`` (rad/s^2) of a
    shaft turning at constant ``speed`` from ``initial_angle``, as functions of time (s)."""

    def inputs(times: Any):
        return {
            f"{prefix}_angle": initial_angle + speed * times,
            f"{prefix}_speed": np.full_like(times, speed),
            f"{prefix}_acceleration": np.zeros_like(times),
        }

    return inputs


def piston_stroke(times: ndarray) -> dict[str, ndarray]:
    """The coursework's stroke, 0.381 m to 0.6096 m at constant speed in 3 s (inside the
    gear's assembly range at every time)."""
    extension, speed, acceleration = landing_gear.stroke(
        times,
        gear.COURSEWORK_RETRACTED_LENGTH,
        gear.COURSEWORK_EXTENDED_LENGTH,
        gear.COURSEWORK_STROKE_TIME,
        "constant_speed",
    )
    return {
        "piston_extension": extension,
        "piston_speed": speed,
        "piston_acceleration": acceleration,
    }


def load_ramp(
    times: ndarray, peak_n: float = 2500.0, duration_s: float = 4.0
) -> dict[str, ndarray]:
    """Suspension load from 0 to 2500 N over 4 s: below the 3090.6 N limit load, no
    snap-through."""
    return {"load": peak_n * np.clip(times / duration_s, 0.0, 1.0)}


@dataclass(frozen=True)
class ModelCase:
    """A model in one configuration, stepped over ``duration_s`` (its motion) in N steps.

    ``inputs(times)`` gives the driven inputs at the given times (s); every other Real input
    keeps its start value (still set at every step, as a master would).
    """

    label: str
    model: str
    duration_s: float
    parameters: dict = field(default_factory=dict)
    inputs: Any = None
    effect_of: str | None = None  # the label of the same case with this case's effect off


def with_forces(case: ModelCase, extra: dict | None = None) -> ModelCase:
    """``case`` with the forces effect on (and ``extra`` parameters): its cost against
    ``case`` is the effect's."""
    return ModelCase(
        case.label.replace(")", ", forces)"),
        case.model,
        case.duration_s,
        {**case.parameters, "forces": True, **(extra or {})},
        case.inputs,
        effect_of=case.label,
    )


CASES = (
    ModelCase("LandingGear (motion drive)", "LandingGear", 3.0, {"drive": "motion"}, piston_stroke),
    ModelCase("PistonActuator", "PistonActuator", 3.0),
    ModelCase("Suspension (static)", "Suspension", 4.0, {}, load_ramp),
    ModelCase("LoadProfile (ramp)", "LoadProfile", 1.0),
    ModelCase("RoadProfile (bump)", "RoadProfile", 0.08),  # ends inside the 0.1 s bump
    ModelCase("CrankDrive", "CrankDrive", 1.0),
    ModelCase("CamshaftDrive", "CamshaftDrive", 1.0),
    *(
        ModelCase(
            f"FourBar ({solver})",
            "FourBar",
            1.0,
            {"solver": solver},
            shaft_turning("crank", 2.0 * math.pi, math.radians(30.0)),
        )
        for solver in ("closed_form", "constraint_solver")
    ),
    *(
        ModelCase(
            f"SliderCrank ({solver})",
            "SliderCrank",
            0.02,
            {"solver": solver},
            shaft_turning("crank", 100.0 * math.pi),
        )
        for solver in ("closed_form", "constraint_solver")
    ),
    # 1.25 camshaft revolutions: every phase of the cam law, ending inside the return (a
    # whole revolution would end where it started, outputs and all).
    *(
        ModelCase(
            f"ValveTrain ({solver})",
            "ValveTrain",
            0.05,
            {"solver": solver},
            shaft_turning("camshaft", CAMSHAFT_SPEED),
        )
        for solver in ("closed_form", "constraint_solver")
    ),
)
# The forces effect on, against the same cases with it off (issue 29): every model that
# has it, the linkages with gravity too.
CASES += tuple(
    with_forces(case, extra)
    for case in CASES
    for label, extra in (
        ("LandingGear (motion drive)", {"inertia": True, "gravity": True}),
        ("FourBar (closed_form)", {"gravity": True}),
        ("FourBar (constraint_solver)", {"gravity": True}),
        ("SliderCrank (closed_form)", {}),
        ("ValveTrain (constraint_solver)", {"valve_spring": True}),
    )
    if case.label == label
)


@dataclass
class LoopRun:
    """One timed loop: its wall time (s) and the Real outputs before and after it."""

    seconds: float
    initial_outputs: list
    final_outputs: list


class PreparedLoop:
    """A case's calls, prepared once: value references, per-step input arrays, times."""

    def __init__(self, case: ModelCase, description: ModelDescription, steps: int) -> None:
        self.case, self.description = case, description
        self.step = case.duration_s / steps
        self.times = [index * self.step for index in range(steps)]  # start of each step
        reals = [v for v in description.modelVariables if v.type == "Real"]
        inputs = [v for v in reals if v.causality == "input"]
        outputs = [v for v in reals if v.causality == "output"]
        driven = case.inputs(np.array(self.times) + self.step) if case.inputs else {}
        unknown = set(driven) - {v.name for v in inputs}
        if unknown:
            raise ValueError(f"{case.label}: {case.model} has no Real input(s) {sorted(unknown)}")
        # The values a Gauss-Seidel master would set before each step: those at its end.
        columns = [
            np.broadcast_to(np.asarray(driven.get(v.name, float(v.start)), float), (steps,))
            for v in inputs
        ]
        self.input_count = len(inputs)
        self.input_refs = (c_uint * len(inputs))(*(v.valueReference for v in inputs))
        self.input_rows = [(c_double * len(inputs))(*row) for row in zip(*columns)]
        self.output_count = len(outputs)
        self.output_refs = (c_uint * len(outputs))(*(v.valueReference for v in outputs))
        self.output_names = [v.name for v in outputs]

    def run(self, instance: FMU2Slave) -> LoopRun:
        """Step ``instance`` through the prepared loop; a LoopRun."""
        set_real, do_step, get_real = (
            getattr(instance.dll, name) for name in ("fmi2SetReal", "fmi2DoStep", "fmi2GetReal")
        )
        component, step = instance.component, self.step
        input_refs, input_count = self.input_refs, self.input_count
        output_refs, output_count = self.output_refs, self.output_count
        outputs = (c_double * output_count)()
        get_real(component, output_refs, output_count, outputs)
        initial = list(outputs)
        status = 0  # fmi2OK; any other status sets bits
        started = timing.now()
        if input_count:
            for values, current in zip(self.input_rows, self.times):
                status |= set_real(component, input_refs, input_count, values)
                status |= do_step(component, current, step, 1)
                status |= get_real(component, output_refs, output_count, outputs)
        else:
            for current in self.times:
                status |= do_step(component, current, step, 1)
                status |= get_real(component, output_refs, output_count, outputs)
        seconds = timing.now() - started
        if status:
            raise RuntimeError(
                f"{self.case.label}: an FMI call returned a non-OK status "
                f"(bits {status:#x}) during the loop"
            )
        return LoopRun(seconds, initial, list(outputs))


class ExtractedFmu:
    """An FMU extracted once, instantiated afresh for every loop."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.description = read_model_description(str(path))
        self.folder = unpack(path)

    @contextlib.contextmanager
    def initialised(self, parameters: dict[str, str]) -> Iterator[FMU2Slave]:
        """A fresh instance with ``parameters`` applied, out of initialisation mode."""
        instance = FMU2Slave(
            guid=self.description.guid,
            unzipDirectory=self.folder,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName=self.description.modelName,
        )
        instance.instantiate()
        try:
            instance.setupExperiment(startTime=0.0)
            instance.enterInitializationMode()
            variables = {v.name: v for v in self.description.modelVariables}
            for name, value in parameters.items():
                setter = getattr(instance, f"set{variables[name].type}")
                setter([variables[name].valueReference], [value])
            instance.exitInitializationMode()
            yield instance
        finally:
            instance.terminate()
            instance.freeInstance()

    def close(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


def run_case(case: ModelCase, fmu_path: Path, steps: int) -> LoopRun:
    """One fresh instance of ``fmu_path`` configured as ``case``, stepped ``steps`` times."""
    fmu = ExtractedFmu(fmu_path)
    try:
        with fmu.initialised(case.parameters) as instance:
            return PreparedLoop(case, fmu.description, steps).run(instance)
    finally:
        fmu.close()


def build_null_models(models: list[str], folder: Path) -> dict[str, Path]:
    """Build the null twins of ``models`` into ``folder``; {model: path of its null FMU}."""
    # The build reports its binary patch on stdout; keep stdout for the results table.
    with contextlib.redirect_stdout(sys.stderr):
        return dict(zip(models, build_all(folder, models, null=True)))


def check_null_held(case: ModelCase, null_run: LoopRun, model_run: LoopRun) -> None:
    """The null twin's outputs must not move while the model's do (its do_step does nothing)."""
    if null_run.final_outputs != null_run.initial_outputs:
        raise RuntimeError(f"{case.label}: the null FMU's outputs changed during the loop")
    if model_run.final_outputs == model_run.initial_outputs:
        raise RuntimeError(f"{case.label}: the model's outputs did not change during the loop")


def _measure_case(
    case: ModelCase, model_fmu: ExtractedFmu, null_fmu: ExtractedFmu, steps: int, repeats: int
) -> list[Row]:
    loops = {fmu: PreparedLoop(case, fmu.description, steps) for fmu in (model_fmu, null_fmu)}
    last = {}

    def timed(fmu: Any):
        with fmu.initialised(case.parameters) as instance:
            last[fmu] = loops[fmu].run(instance)
        return {"loop": last[fmu].seconds}

    medians = side_by_side_medians(
        {"model": lambda: timed(model_fmu), "null": lambda: timed(null_fmu)}, repeats
    )
    check_null_held(case, last[null_fmu], last[model_fmu])
    span = f"{steps} steps of {loops[model_fmu].step:.3g} s"
    notes = {
        "model": "per step (set inputs, doStep, get outputs)",
        "null": "per step; do_step returns at once; outputs held their initial values",
    }
    model_row, null_row = (
        Row(
            BENCHMARK,
            f"{case.label}: {kind}",
            medians[kind]["loop"] / steps * MICRO,
            "us",
            repeats,
            notes=f"{notes[kind]}; {span}",
        )
        for kind in ("model", "null")
    )
    target: Target | None = SOLVER_TARGET if "constraint_solver" in case.label else TARGET
    if case.effect_of is not None:  # an effect's cost: no target, reported against its base
        target = None
    return [
        model_row,
        null_row,
        ratio_row(f"{case.label}: model / null", model_row, null_row, target),
    ]


def measure(
    fmu_dir: str, steps: int, repeats: int, cases: tuple[ModelCase, ...] = CASES
) -> list[Row]:
    """Rows of benchmark 2: per case the model's and the null twin's time per step (us)."""
    models = list(dict.fromkeys(case.model for case in cases))
    with tempfile.TemporaryDirectory(prefix="mechfmu_bench_null_") as temp:
        nulls = build_null_models(models, Path(temp))
        fmus = {
            model: (ExtractedFmu(Path(fmu_dir) / f"{model}.fmu"), ExtractedFmu(nulls[model]))
            for model in models
        }
        try:
            rows = [
                row
                for case in cases
                for row in _measure_case(case, *fmus[case.model], steps, repeats)
            ]
        finally:
            for pair in fmus.values():
                for fmu in pair:
                    fmu.close()
    return rows + effect_rows(cases, rows)


def effect_rows(cases: tuple[ModelCase, ...], rows: list[Row]) -> list[Row]:
    """Per case with an effect on whose base case was measured too: the effect's cost, the
    model's time per step with it on over with it off."""
    by_case = {row.case: row for row in rows}
    found = []
    for case in cases:
        base = by_case.get(f"{case.effect_of}: model")
        if base is not None:
            found.append(
                ratio_row(f"{case.label}: effect on / off", by_case[f"{case.label}: model"], base)
            )
    return found
