"""What the accuracy study sweeps: its scenes, and the points (settings) run for each.

A point is one run of a shipped dynamic scene with the integrating component's method,
tolerance and sub-step and the master's communication step and coupling replaced. The
sweep is the full grid of communication step x integrator setting (Gauss-Seidel), plus
the communication step x coupling grid at the tightest setting of the scene's own method
(the coupling error alone) and the Jacobi runs of the whole grid where the scene couples
several FMUs. Every communication step is a whole multiple of the scene's finest, so all
runs share the reference's sample times.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import copy
import dataclasses
from dataclasses import dataclass

from ...cosim.scene import find_file, load_scene
from pathlib import Path

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from ...cosim.scene import Scene

ADAPTIVE = ("dopri5", "radau")
FIXED = ("euler", "rk4")
TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)  # rtol = atol
TIGHTEST = TOLERANCES[-1]
JACOBI_TOLERANCES = (1e-6, TIGHTEST)


# Communication steps: 2 decades (a third, down to 1e-4 s, multiplies the study's time past
# its 15-minute budget on 2 cores), each a whole multiple of the finest and a divisor of the
# coarsest, so every run is compared at the coarsest step's points (all runs have them).
_STEPS = (1e-3, 2e-3, 5e-3, 1e-2, 5e-2, 0.1)


@dataclass(frozen=True)
class StudyScene:
    """A shipped dynamic scene and how the study varies it.

    component   the scene's integrating component (its integrator parameters are varied)
    headline    the recorded output whose error the Pareto front and the README table use
    steps       communication steps (s), the finest first; each divides the coarsest
                (which divides the scene's span) and is a whole multiple of the finest
    substeps    fixed sub-steps (s) tried for euler and rk4 (capped by the step)
    """

    name: str
    component: str
    headline: str
    steps: tuple
    substeps: tuple


SCENES = (
    StudyScene("gear_retraction_dynamic", "gear", "gear.gear_angle", _STEPS, (1e-3, 1e-4)),
    StudyScene("gear_extension_gravity", "gear", "gear.gear_angle", _STEPS, (1e-3, 1e-4)),
    StudyScene(
        "suspension_road_bump", "suspension", "suspension.sprung_displacement", _STEPS, (1e-3, 1e-4)
    ),
    StudyScene(
        "suspension_sudden_load", "suspension", "suspension.deflection", _STEPS, (1e-3, 1e-4)
    ),
    StudyScene(
        "valve_train_dynamic",
        "valve",
        "valve.valve_lift",
        tuple(step * 1e-2 for step in _STEPS),
        (1e-5, 1e-6),
    ),
)


@dataclass(frozen=True)
class Point:
    """One run of the study: a scene with these settings."""

    scene: str
    integrator: str
    tolerance: float  # rtol = atol of the adaptive methods; 0 for euler and rk4
    max_substep: float  # s; the fixed sub-step of euler and rk4, the cap of the others
    step: float  # s, communication step
    coupling: str  # gauss_seidel or jacobi

    def label(self) -> str:
        knob = (
            f"tol {self.tolerance:g}"
            if self.integrator in ADAPTIVE
            else f"h {self.max_substep:g} s"
        )
        return f"{self.integrator} {knob}, step {self.step:g} s, {self.coupling}"


def integrator_settings(study_scene: StudyScene, step: float) -> list[tuple[str, float, float]]:
    """(integrator, tolerance, max_substep) tried at communication step ``step``."""
    settings = [(method, tolerance, step) for method in ADAPTIVE for tolerance in TOLERANCES]
    fixed = sorted({min(substep, step) for substep in study_scene.substeps}, reverse=True)
    settings += [(method, 0.0, substep) for method in FIXED for substep in fixed]
    return settings


def points(study_scene: StudyScene, couplings: tuple, quick: bool = False) -> list[Point]:
    """Every point of the sweep for ``study_scene``; ``quick`` keeps a small, cheap corner
    of it (the two coarsest steps, six settings).

    Gauss-Seidel runs the full grid. Jacobi, which costs the same calls and only moves
    the inputs' time, runs each adaptive method at 1e-6 and at the tightest tolerance:
    enough to show the coupling error against the step. ``couplings``: both when the
    scene connects several FMUs (with one FMU the two couplings are the same run).
    """
    steps = study_scene.steps[-2:] if quick else study_scene.steps
    chosen = []
    for step in steps:
        settings = integrator_settings(study_scene, step)
        if quick:
            settings = [s for s in settings if s[0] in FIXED or s[1] in (1e-4, 1e-8)][:6]
        for coupling in couplings:
            for integrator, tolerance, max_substep in settings:
                if coupling == "jacobi" and not quick and tolerance not in JACOBI_TOLERANCES:
                    continue
                chosen.append(
                    Point(study_scene.name, integrator, tolerance, max_substep, step, coupling)
                )
    return chosen


def couplings_of(scene: Scene) -> tuple:
    """Both couplings for a scene with connections; Gauss-Seidel alone otherwise."""
    return ("gauss_seidel", "jacobi") if scene.connections else ("gauss_seidel",)


def counters(study_scene: Any) -> Any:
    """The integrating component's work counters (recorded in every run of the study)."""
    return (f"{study_scene.component}.rhs_evaluations", f"{study_scene.component}.substeps")


def configure(scene: Any, study_scene: Any, point: Any) -> Any:
    """The shipped ``scene`` with the point's settings and the work counters recorded."""
    components = copy.deepcopy(scene.components)
    parameters = components[study_scene.component].parameters
    parameters.update(integrator=point.integrator, max_substep=point.max_substep)
    if point.integrator in ADAPTIVE:
        parameters.update(rtol=point.tolerance, atol=point.tolerance)
    record = list(scene.record) + [
        name for name in counters(study_scene) if name not in scene.record
    ]
    return dataclasses.replace(
        scene, components=components, step=point.step, coupling=point.coupling, record=record
    )


def load(scene_dir: Path | str, study_scene: StudyScene) -> Scene:
    """The shipped scene, checked against the study's assumptions. A valve scene is studied
    on the rocker inputs (ValveTrain -> ValveSpring, drive = rocker), as before issue 21
    moved the shipped scenes to the camshaft drive: the study compares the general-purpose
    integrators and communication steps on the valve's equations, which the camshaft drive
    would make a closed-form evaluation of ValveTrain per right-hand side."""
    scene = load_scene(find_file(study_scene.name, (scene_dir,)))
    if any(spec.fmu == "ValveSpring" for spec in scene.components.values()):
        from ..bench.dynamic_scenes import configured

        scene = configured(scene, {"drive": "rocker"}, "rocker")
    span = scene.stop_time - scene.start_time
    finest, coarsest = study_scene.steps[0], study_scene.steps[-1]
    for whole in (
        [span / coarsest]
        + [coarsest / step for step in study_scene.steps]
        + [step / finest for step in study_scene.steps]
    ):
        if abs(whole - round(whole)) > 1e-9 * max(1.0, whole):
            raise ValueError(
                f"study of {scene.name}: the steps {study_scene.steps} must be "
                f"multiples of the finest, divide the coarsest, and the coarsest "
                f"must divide the span {span} s"
            )
    if study_scene.component not in scene.components:
        raise ValueError(f"study of {scene.name}: no component {study_scene.component!r}")
    return scene
