"""Generate the shipped scenes' reference CSVs (scenes/reference/) from the numpy closed forms.

Each reference belongs to a shipped scene (scenes/): it is sampled at the scene's
communication points, uses the scene's parameters over the models' defaults, and names
its columns like the scene's result ('component.variable'), so ``mechfmu check`` can
compare the two directly.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
from pathlib import Path

import numpy as np

from ..cosim.files import atomic_write_all
from ..cosim.results import csv_writer, json_text, write_csv
from ..io import read_profile_table
from ..cosim.scene import find_file, load_scene
from .docs import declared_units, model_class
from ..references import (
    cam_geometry,
    drives,
    engine,
    gear_dynamics,
    gear_forces,
    landing_gear,
    link_forces,
    linkages,
    suspension,
    suspension_dynamics,
    valve_spring,
    valve_train,
)

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from ..cosim.scene import Scene
    from numpy import ndarray


def start_values(model: str, causality: str | None = None) -> dict[str, Any]:
    """Start values declared by a model (its FMU's), of every variable or of one causality."""
    return {
        v.name: v.start
        for v in model_class(model).VARIABLES
        if causality is None or v.causality == causality
    }


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


def component(scene: Scene, model: str) -> tuple[str, dict[str, Any]]:
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
    _, stroke = component(scene, "PistonActuator")
    _, geometry = component(scene, "LandingGear")
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
    actuator, _ = component(scene, "PistonActuator")
    gear, _ = component(scene, "LandingGear")
    columns = landing_gear.retraction(*retraction_arguments(scene))
    owner = {
        "piston_extension": actuator,
        "piston_speed": actuator,
        "piston_acceleration": actuator,
    }
    return {f"{owner.get(key, gear)}.{key}": values for key, values in columns.items()}


def suspension_load_ramp(scene: Any) -> Any:
    """Load and equilibrium columns for a LoadProfile(ramp) -> Suspension scene."""
    source, ramp = component(scene, "LoadProfile")
    name, spring = component(scene, "Suspension")
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
    source, load = component(scene, "LoadProfile")
    name, parameters = component(scene, "Suspension")
    parameters.update({effect: True for effect in scene.components[name].effects})
    road_name, road = None, None
    if any(Path(spec.fmu).stem == "RoadProfile" for spec in scene.components.values()):
        road_name, road = component(scene, "RoadProfile")
    return suspension_dynamics.scene_columns(
        sample_times(scene), source, load, name, parameters, road_name, road, scene.record
    )


def gear_dynamics_scene(scene: Scene) -> Any:
    """Recorded columns of a dynamic LandingGear scene (no connections), by scipy."""
    name, _ = component(scene, "LandingGear")
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
    name, shaft = component(scene, model)
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
    name, p = component(scene, model)
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
    _, shaft = component(scene, "CamshaftDrive")
    _, train = component(scene, "ValveTrain")
    name, parameters = component(scene, "ValveSpring")
    if parameters["drive"] == "camshaft":  # the valve's own cam law and rocker geometry
        train = {**parameters, "mode": "forward"}
    columns = valve_train_scene(scene)
    dynamics, _ = valve_spring.scene_columns(sample_times(scene), shaft, train, parameters)
    if parameters["drive"] == "camshaft":
        angle = drives.shaft_rotation(sample_times(scene), shaft, 0.5)["angle"]
        dynamics["camshaft_torque"] = camshaft_torque(train, angle, dynamics["contact_force"])
    columns.update({f"{name}.{key}": value for key, value in dynamics.items()})
    return _recorded(scene, columns)


def link_layouts(p: dict, links: tuple[str, ...]) -> list[tuple[float, float, float, float]]:
    """(mass, com_along, com_across, inertia) of each link from a model's parameters."""
    return [
        (p[f"{link}_mass"], p[f"{link}_com_along"], p[f"{link}_com_across"], p[f"{link}_inertia"])
        for link in links
    ]


def linkage_gravity(p: dict, effects: Any) -> tuple[float, float]:
    """Gravity (m/s^2) of a linkage with the forces effect: none unless the scene lists it."""
    if "gravity" not in effects:
        return (0.0, 0.0)
    return (
        p["gravity_acceleration"] * np.cos(p["gravity_direction"]),
        p["gravity_acceleration"] * np.sin(p["gravity_direction"]),
    )


def constant_inputs(scene: Any, name: str, model: str) -> dict:
    """The model's input start values under the scene's constant inputs."""
    return {**start_values(model, "input"), **scene.components[name].inputs}


def four_bar_forces_scene(scene: Any) -> Any:
    """CrankDrive -> FourBar with the forces effect: the motion as four_bar_scene, the pin
    forces and crank torque by Norton's matrix, the energies and shaking from the links'
    motion (references/link_forces.py)."""
    columns = four_bar_scene(scene)
    crank_name, crank = _shaft_columns(scene)
    name, p = component(scene, "FourBar")
    lengths = [
        p[key] for key in ("ground_length", "crank_length", "coupler_length", "rocker_length")
    ]
    drive = (crank["crank_angle"], crank["crank_speed"], crank["crank_acceleration"])
    motion = linkages.four_bar(lengths[0], lengths[1], lengths[2], lengths[3], p["circuit"], *drive)
    links = link_forces.four_bar_links(lengths, drive, motion)
    layouts = link_layouts(p, ("crank", "coupler", "rocker"))
    gravity = linkage_gravity(p, scene.components[name].effects)
    loads = constant_inputs(scene, name, "FourBar")
    point = (p["coupler_point_along"], p["coupler_point_across"])
    force = (loads["coupler_force_x"], loads["coupler_force_y"])
    forces = link_forces.norton_four_bar(
        lengths, links, layouts, gravity, point, force, loads["rocker_torque"]
    )
    forces.update(link_forces.energies(links, layouts, gravity))
    with np.errstate(divide="ignore"):
        forces["mechanical_advantage"] = drive[1] / motion["rocker_angular_velocity"]
    columns.update({f"{name}.{key}": value for key, value in forces.items()})
    return _recorded(scene, columns)


def slider_crank_engine_scene(scene: Any) -> Any:
    """CrankDrive and LoadProfile(table) -> SliderCrank with the forces effect: the motion as
    slider_crank_scene, the gas force interpolated in the scene's table, the forces by the
    slider-crank's matrix (references/link_forces.py)."""
    columns = slider_crank_scene(scene)
    _, crank = _shaft_columns(scene)
    name, p = component(scene, "SliderCrank")
    gas_name, gas = component(scene, "LoadProfile")
    geometry = [p[key] for key in ("crank_length", "coupler_length", "offset")]
    drive = (crank["crank_angle"], crank["crank_speed"], crank["crank_acceleration"])
    motion = linkages.slider_crank(geometry[0], geometry[1], geometry[2], p["circuit"], *drive)
    links = link_forces.slider_crank_links(geometry, drive, motion)
    layouts = link_layouts(p, ("crank", "coupler")) + [(p["slider_mass"], 0.0, 0.0, 0.0)]
    gravity = linkage_gravity(p, scene.components[name].effects)
    loads = constant_inputs(scene, name, "SliderCrank")
    table = read_profile_table(gas["table_file"])
    load = np.interp(sample_times(scene), table.index.to_numpy(), table.iloc[:, 0].to_numpy())
    towards_crank = -1.0 if p["circuit"] == 0 else 1.0
    counterweight = (p["counterweight_mass"], p["counterweight_radius"])
    forces = link_forces.norton_slider_crank(
        links,
        layouts,
        gravity,
        (p["coupler_point_along"], p["coupler_point_across"]),
        geometry[0],
        geometry[1],
        (loads["coupler_force_x"], loads["coupler_force_y"]),
        towards_crank * load,
        counterweight,
    )
    forces.update(
        link_forces.energies(
            [*links, links[0]],  # the counterweight turns with the crank
            [*layouts, (counterweight[0], -counterweight[1], 0.0, 0.0)],
            gravity,
        )
    )
    forces["mechanical_advantage"] = towards_crank * motion["slider_speed"] / drive[1]
    columns[f"{gas_name}.load"] = load
    columns.update({f"{name}.{key}": value for key, value in forces.items()})
    return _recorded(scene, columns)


def gear_loads_scene(scene: Any) -> Any:
    """PistonActuator -> LandingGear (motion drive) with the forces effect: the retraction
    as gear_retraction, the required piston force and the pivot and anchor loads from
    references/gear_forces.py."""
    columns = gear_retraction(scene)
    actuator, _ = component(scene, "PistonActuator")
    name, p = component(scene, "LandingGear")
    effects = scene.components[name].effects
    values = {**p, **{effect: effect in effects for effect in gear_forces.EFFECTS}}
    values.update(constant_inputs(scene, name, "LandingGear"))
    x, v, a = (
        columns[f"{actuator}.piston_{key}"] for key in ("extension", "speed", "acceleration")
    )
    columns.update(
        {f"{name}.{key}": value for key, value in gear_forces.loads(values, x, v, a).items()}
    )
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
    "four_bar_forces": four_bar_forces_scene,
    "slider_crank_engine": slider_crank_engine_scene,
    "gear_retraction_loads": gear_loads_scene,
    "camshaft_inline_four": valve_train_scene,
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


def engine_gas_force() -> tuple[ndarray, dict[str, ndarray]]:
    """The slider_crank_engine scene's gas force table: one four-stroke cycle at its crank
    speed, 3000 rpm (references/engine.py)."""
    times, force = engine.gas_force_table(100.0 * np.pi)
    return times, {"load": force}


# Input tables of the shipped scenes (file names in the scenes' tables/ folder), generated
# from the documented models in references/ by the same command as the references.
TABLES = {"engine_gas_force.csv": engine_gas_force}


def generate_tables(out_dir: Any) -> list[Path]:
    """Write every table of TABLES into ``out_dir``; return their paths."""
    return [write_csv(Path(out_dir) / name, *build()) for name, build in TABLES.items()]


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
