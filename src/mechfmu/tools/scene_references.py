"""Generate the shipped scenes' reference CSVs (scenes/reference/) from the numpy closed forms.

Each reference belongs to a shipped scene (scenes/): it is sampled at the scene's
communication points, uses the scene's parameters over the models' defaults, and names
its columns like the scene's result ('component.variable'), so ``mechfmu check`` can
compare the two directly.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import importlib
from pathlib import Path

import numpy as np

from ..cosim.files import atomic_write_all
from ..cosim.results import csv_writer, json_text
from ..cosim.scene import find_file, load_scene
from ..runtime.models import MODELS
from .docs import declared_units
from ..references import (
    cam_geometry,
    drives,
    gear_dynamics,
    landing_gear,
    linkages,
    suspension,
    suspension_dynamics,
    valve_spring,
    valve_train,
)

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from ..cosim.scene import Scene
    from numpy import ndarray


def start_values(model: str, causality: str | None = None) -> dict[str, float]:
    """Start values declared by a model (its FMU's), of every variable or of one causality."""
    cls = getattr(importlib.import_module(MODELS[model]), model)
    return {v.name: v.start for v in cls.VARIABLES if causality is None or v.causality == causality}


def model_defaults(model: str) -> dict[str, float]:
    """Parameter defaults declared by a model (its FMU start values)."""
    return start_values(model, "parameter")


def _components(scene: Scene, model: str) -> list[tuple[str, dict[str, Any]]]:
    """(name, parameters over defaults) of every component of the scene using ``model``."""
    return [
        (name, {**model_defaults(model), **spec.parameters})
        for name, spec in scene.components.items()
        if Path(spec.fmu).stem == model
    ]


def _component(scene: Scene, model: str):
    """(name, parameters over defaults) of the scene's (first) component using ``model``."""
    found = _components(scene, model)
    if not found:
        raise ValueError(f"scene {scene.name} has no {model} component")
    return found[0]


def sample_times(scene: Scene) -> ndarray:
    return np.array([scene.time(i) for i in range(scene.steps + 1)])


def retraction_arguments(scene: Scene) -> tuple[Any, ...]:
    """Positional arguments of references.landing_gear.retraction for a PistonActuator ->
    LandingGear scene: its sample times (s) and the actuator's and gear's parameters over the
    defaults (m, s, the profile's name)."""
    _, stroke = _component(scene, "PistonActuator")
    _, geometry = _component(scene, "LandingGear")
    return (
        sample_times(scene),
        geometry["attachment_distance"],
        geometry["pivot_height"],
        stroke["start_extension"],
        stroke["end_extension"],
        stroke["stroke_time"],
        stroke["profile"],
    )


def gear_retraction(scene: Any) -> Any:
    """Piston stroke and gear motion columns for a PistonActuator -> LandingGear scene."""
    actuator, _ = _component(scene, "PistonActuator")
    gear, _ = _component(scene, "LandingGear")
    columns = landing_gear.retraction(*retraction_arguments(scene))
    owner = {
        "piston_extension": actuator,
        "piston_speed": actuator,
        "piston_acceleration": actuator,
    }
    return {f"{owner.get(key, gear)}.{key}": values for key, values in columns.items()}


def suspension_load_ramp(scene: Any) -> Any:
    """Load and equilibrium columns for a LoadProfile(ramp) -> Suspension scene."""
    source, ramp = _component(scene, "LoadProfile")
    name, spring = _component(scene, "Suspension")
    if ramp["shape"] != "ramp":
        raise ValueError(f"scene {scene.name}: the reference covers ramp loads only")
    times = sample_times(scene)
    tau = np.clip((times - ramp["start_time"]) / ramp["duration"], 0.0, 1.0)
    loads = ramp["initial_value"] + (ramp["final_value"] - ramp["initial_value"]) * tau
    columns = suspension.follow_load(
        loads,
        spring["spring_free_length"],
        spring["spring_stiffness"],
        spring["spring_base_offset"],
    )
    return {f"{source}.load": loads, **{f"{name}.{key}": v for key, v in columns.items()}}


def suspension_dynamics_scene(scene: Any) -> Any:
    """LoadProfile [-> RoadProfile] -> Suspension with the dynamics effect: solve_ivp columns."""
    source, load = _component(scene, "LoadProfile")
    name, parameters = _component(scene, "Suspension")
    parameters.update({effect: True for effect in scene.components[name].effects})
    road_name, road = None, None
    if any(Path(spec.fmu).stem == "RoadProfile" for spec in scene.components.values()):
        road_name, road = _component(scene, "RoadProfile")
    return suspension_dynamics.scene_columns(
        sample_times(scene), source, load, name, parameters, road_name, road, scene.record
    )


def gear_dynamics_scene(scene: Scene) -> Any:
    """Recorded columns of a dynamic LandingGear scene (no connections), by scipy."""
    name, _ = _component(scene, "LandingGear")
    spec = scene.components[name]
    values = gear_dynamics.gear_values(
        start_values("LandingGear"), spec.parameters, spec.effects, spec.inputs
    )
    columns = gear_dynamics.simulate(values, sample_times(scene))
    return {
        f"{name}.{key}": np.asarray(values_)
        for key, values_ in columns.items()
        if scene.record is None or f"{name}.{key}" in scene.record
    }


def _shaft_columns(
    scene: Any, model: str = "CrankDrive", prefix: str = "crank", ratio: float = 1.0
):
    """(component name, {angle, speed, acceleration}) of the scene's shaft drive."""
    name, shaft = _component(scene, model)
    columns = drives.shaft_rotation(sample_times(scene), shaft, ratio)
    return name, {f"{prefix}_{key}": value for key, value in columns.items()}


def _recorded(scene: Any, columns: Any):
    return {
        key: value for key, value in columns.items() if scene.record is None or key in scene.record
    }


def _linkage_scene(scene: Any, model: str, solve: Any, dimensions: tuple[str, ...]) -> Any:
    """CrankDrive -> ``model``: the crank motion and ``solve``'s closed-form motion, called
    with the linkage's ``dimensions`` (m), its circuit and the crank's angle, speed and
    acceleration."""
    crank_name, crank = _shaft_columns(scene)
    name, p = _component(scene, model)
    motion = solve(
        *(p[key] for key in dimensions),
        p["circuit"],
        crank["crank_angle"],
        crank["crank_speed"],
        crank["crank_acceleration"],
    )
    columns = {f"{crank_name}.{key}": value for key, value in crank.items()}
    columns.update({f"{name}.{key}": value for key, value in motion.items()})
    return _recorded(scene, columns)


def four_bar_scene(scene: Any) -> Any:
    """CrankDrive -> FourBar: the crank motion and the closed-form linkage motion."""
    return _linkage_scene(
        scene,
        "FourBar",
        linkages.four_bar,
        ("ground_length", "crank_length", "coupler_length", "rocker_length"),
    )


def slider_crank_scene(scene: Any) -> Any:
    """CrankDrive -> SliderCrank: the crank motion and the closed-form slider motion."""
    return _linkage_scene(
        scene, "SliderCrank", linkages.slider_crank, ("crank_length", "coupler_length", "offset")
    )


def tappet_diagram(parameters: Any, angle: Any) -> tuple[Any, Any, Any]:
    """(s m, ds/dtheta m/rad, d2s/dtheta2 m/rad^2) of the tappet of a ValveTrain with
    ``parameters`` at camshaft ``angle`` (rad): the cam law (forward), or the numpy inverse
    of the valve law at unit camshaft speed (inverse)."""
    law = valve_train.cam_lift(
        parameters["cam_law"],
        parameters["lift"],
        parameters["rise_start"],
        parameters["rise_angle"],
        parameters["high_dwell_angle"],
        parameters["return_angle"],
        angle,
    )
    if parameters["mode"] != "inverse":
        return law
    geometry = {key: parameters[key] for key in valve_train.GEOMETRY_FIELDS}
    motion = valve_train.inverse(geometry, *law)
    return motion["tappet_lift"], motion["tappet_velocity"], motion["tappet_acceleration"]


def camshaft_torque(parameters: Any, angle: Any, valve_force: Any) -> Any:
    """Torque (N.m) the camshaft supplies to the tappet of a ValveTrain with ``parameters``
    at camshaft ``angle`` (rad) against ``valve_force`` (N) on the valve: the rocker's
    statics and the moment of the tappet's push (references/cam_geometry.py)."""
    s, s1, _ = tappet_diagram(parameters, angle)
    geometry = {key: parameters[key] for key in valve_train.GEOMETRY_FIELDS}
    return cam_geometry.camshaft_torque_by_statics(geometry, s, s1, valve_force)


def valve_train_scene(scene: Any) -> Any:
    """CamshaftDrive -> ValveTrain(s): the cam law composed with the closed-form rocker
    geometry (forward or inverse), the valve spring's contact force and the camshaft torque
    where that effect is on, the cam's geometry where cam_geometry is; every ValveTrain of
    the scene (a whole camshaft has one per lobe)."""
    cam_name, cam = _shaft_columns(scene, "CamshaftDrive", "camshaft", ratio=0.5)
    angle, speed, acceleration = (
        cam[f"camshaft_{key}"] for key in ("angle", "speed", "acceleration")
    )
    columns = {f"{cam_name}.{key}": value for key, value in cam.items()}
    for name, p in _components(scene, "ValveTrain"):
        effects = scene.components[name].effects
        law = valve_train.tappet_motion(p, angle, speed, acceleration)
        solve = valve_train.inverse if p["mode"] == "inverse" else valve_train.forward
        geometry = {key: p[key] for key in valve_train.GEOMETRY_FIELDS}
        motion = solve(geometry, *law)
        if "valve_spring" in effects:
            motion["contact_force"] = (
                p["valve_mass"] * motion["valve_acceleration"]
                + p["spring_stiffness"] * motion["valve_lift"]
                + p["spring_preload"]
            )
            motion["camshaft_torque"] = camshaft_torque(p, angle, motion["contact_force"])
        if "cam_geometry" in effects:
            follower = {
                "kind": p["follower"],
                "base_circle_radius": p["cam_base_radius"],
                "roller_radius": p["roller_radius"] if p["follower"] == "roller" else 0.0,
                "offset": p["follower_offset"],
            }
            motion.update(cam_geometry.cam_columns(follower, *tappet_diagram(p, angle), angle))
        columns.update({f"{name}.{key}": value for key, value in motion.items()})
    return _recorded(scene, columns)


def valve_spring_scene(scene: Any) -> Any:
    """CamshaftDrive -> ValveTrain -> ValveSpring: the kinematic columns as valve_train_scene,
    the valve's dynamics on that drive by scipy (references/valve_spring.py); with the
    valve's drive = camshaft, the drive from the valve's own cam and geometry parameters."""
    _, shaft = _component(scene, "CamshaftDrive")
    _, train = _component(scene, "ValveTrain")
    name, parameters = _component(scene, "ValveSpring")
    if parameters["drive"] == "camshaft":  # the valve's own cam law and rocker geometry
        train = {**parameters, "mode": "forward"}
    columns = valve_train_scene(scene)
    dynamics, _ = valve_spring.scene_columns(sample_times(scene), shaft, train, parameters)
    if parameters["drive"] == "camshaft":
        angle = drives.shaft_rotation(sample_times(scene), shaft, 0.5)["angle"]
        dynamics["camshaft_torque"] = camshaft_torque(train, angle, dynamics["contact_force"])
    columns.update({f"{name}.{key}": value for key, value in dynamics.items()})
    return _recorded(scene, columns)


REFERENCES = {
    "gear_retraction": gear_retraction,
    "gear_retraction_cycloidal": gear_retraction,
    "suspension_load_ramp": suspension_load_ramp,
    "gear_retraction_dynamic": gear_dynamics_scene,
    "gear_extension_gravity": gear_dynamics_scene,
    "suspension_road_bump": suspension_dynamics_scene,
    "suspension_sudden_load": suspension_dynamics_scene,
    "four_bar_crank_rocker": four_bar_scene,
    "four_bar_solver_crossed": four_bar_scene,
    "slider_crank_offset": slider_crank_scene,
    "valve_train": valve_train_scene,
    "valve_train_inverse": valve_train_scene,
    "valve_float": valve_train_scene,
    "valve_train_dynamic": valve_spring_scene,
    "valve_float_dynamic": valve_spring_scene,
}


# References integrated by scipy (rtol = atol = 1e-12) rather than evaluated in closed form:
# a different scipy may change their last digits, so regeneration is compared more loosely.
INTEGRATED = {
    "gear_retraction_dynamic",
    "gear_extension_gravity",
    "suspension_road_bump",
    "suspension_sudden_load",
    "valve_train_dynamic",
    "valve_float_dynamic",
}


def reference_metadata(scene: Scene, columns: list[str]) -> dict[str, Any]:
    """The JSON beside a reference CSV: the scene, the columns' declared units, and the
    scene's check tolerances (its [check] table, which ``mechfmu check`` and
    ``mechfmu.compare`` apply when comparing a result with this reference)."""
    units = declared_units(scene)
    return {
        "scene": scene.name,
        "kind": "reference",
        "description": scene.description,
        "recorded": columns,
        "units": {name: units[name] for name in columns if name in units},
        "check": scene.check.as_dict() if scene.check else None,
        "generated_by": "mechfmu references",
    }


def generate(scene_dir: Any, out_dir: Any) -> Any:
    """Write one reference CSV per entry of REFERENCES, each with its JSON
    (reference_metadata) beside it, both or neither; return the CSV paths."""
    paths = []
    for scene_name, build in REFERENCES.items():
        scene = load_scene(find_file(scene_name, (scene_dir,)))
        columns = build(scene)
        path = Path(out_dir) / f"{scene_name}.csv"
        atomic_write_all(
            {
                path: csv_writer(list(sample_times(scene)), columns),
                path.with_suffix(".json"): json_text(reference_metadata(scene, list(columns))),
            }
        )
        paths.append(path)
    return paths
