"""The forces pages' validation figures, drawn at every docs build (docs/gen_pages.py).

Each figure puts the runtime's force analysis (runtime/physics, the code the FMUs run, here
called in-process) beside the references that take other routes (references/link_forces.py,
references/gear_forces.py), on the shipped scenes' inputs, and states the largest deviation.
"""

import io
import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ...cosim.scene import find_file, load_scene
from ...references import link_forces as ref
from ...references import linkages
from ...references import valve_forces as valve_reference
from ...runtime.physics import cam_geometry, cam_laws
from ...runtime.physics import four_bar as fb
from ...runtime.physics import gear_dynamics as gd
from ...runtime.physics import gear_forces
from ...runtime.physics import landing_gear as gear
from ...runtime.physics import link_forces
from ...runtime.physics import linkage_forces as lf
from ...runtime.physics import slider_crank as sc
from ...runtime.physics import valve_forces
from ...runtime.physics import valve_train as vt
from .. import scene_references as sr


def _png(figure: Figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    return buffer.getvalue()


def _scene(name: str) -> Any:
    return load_scene(find_file(name))


def _layouts(p: dict, links: tuple[str, ...]) -> list[link_forces.MassLayout]:
    return [link_forces.MassLayout(*layout) for layout in sr.link_layouts(p, links)]


def four_bar_validation() -> bytes:
    """four_bar_forces: crank torque by the runtime, by Norton's matrix and by the power
    balance, their deviations, the pin loads and the coupler point's path."""
    scene = _scene("four_bar_forces")
    reference = sr.four_bar_forces_scene(scene)
    name, p = sr.component(scene, "FourBar")
    loads = sr.constant_inputs(scene, name, "FourBar")
    lengths = fb.check_four_bar(
        p["ground_length"], p["crank_length"], p["coupler_length"], p["rocker_length"]
    )
    layouts = _layouts(p, ("crank", "coupler", "rocker"))
    gravity = sr.linkage_gravity(p, scene.components[name].effects)
    point = (p["coupler_point_along"], p["coupler_point_across"])
    forces = lf.FourBarForces(lengths, layouts, gravity, point)
    angle, speed, acceleration = (
        reference[f"crank.crank_{k}"] for k in ("angle", "speed", "acceleration")
    )
    runtime = []
    for k in range(len(angle)):
        motion = fb.checked_motion(lengths, p["circuit"], angle[k], speed[k], acceleration[k])
        runtime.append(
            forces.analyse(
                (angle[k], speed[k], acceleration[k]),
                motion._asdict(),
                lf.FourBarLoads(*(loads[key] for key in lf.FourBarLoads._fields)),
            )
        )
    drive = (angle, speed, acceleration)
    motion_columns: dict[str, Any] = linkages.four_bar(*lengths, p["circuit"], *drive)
    links = ref.four_bar_links(lengths, drive, motion_columns)
    power = ref.load_power(
        links, point, (loads["coupler_force_x"], loads["coupler_force_y"]), loads["rocker_torque"]
    )
    balance = ref.power_balance_torque(links, layouts, gravity, power)["crank_torque"]
    torque = np.array([row["crank_torque"] for row in runtime])
    norton = reference[f"{name}.crank_torque"]
    degrees = np.degrees(angle)
    figure = Figure(figsize=(10, 7), layout="constrained")
    (a, b), (c, d) = figure.subplots(2, 2)
    a.plot(degrees, torque, label="runtime (Newton-Euler on the joints)")
    a.plot(degrees[::8], norton[::8], "o", mfc="none", label="Norton's matrix (numpy)")
    a.plot(degrees[::8], balance[::8], "x", label="power balance (kinematics only)")
    a.set(xlabel="crank angle [deg]", ylabel="crank torque T12 [N m]")
    a.legend(fontsize=8)
    scale = np.max(np.abs(torque))
    b.semilogy(degrees, np.abs(torque - norton) / scale + 1e-18, label="vs Norton's matrix")
    b.semilogy(degrees, np.abs(torque - balance) / scale + 1e-18, label="vs power balance")
    b.set(xlabel="crank angle [deg]", ylabel="|difference| / max |T12|")
    b.set_title(
        f"largest: {np.max(np.abs(torque - norton)) / scale:.1e}, "
        f"{np.max(np.abs(torque - balance)) / scale:.1e}",
        fontsize=9,
    )
    b.legend(fontsize=8)
    for joint, label in (
        ("crank_pivot", "F12 at O2"),
        ("crank_pin", "F32 at A"),
        ("rocker_pin", "F43 at B"),
        ("rocker_pivot", "F14 at O4"),
    ):
        c.plot(degrees, [row[f"{joint}_force_magnitude"] for row in runtime], label=label)
    c.plot(degrees, [row["shaking_force_magnitude"] for row in runtime], "k--", label="shaking")
    c.set(xlabel="crank angle [deg]", ylabel="force [N]")
    c.legend(fontsize=8)
    x = np.array([row["coupler_point_x"] for row in runtime])
    y = np.array([row["coupler_point_y"] for row in runtime])
    d.plot(x, y, label="coupler point P")
    first = 0
    ax, ay = lengths.crank * math.cos(angle[first]), lengths.crank * math.sin(angle[first])
    bx = ax + lengths.coupler * math.cos(motion_columns["coupler_angle"][first])
    by = ay + lengths.coupler * math.sin(motion_columns["coupler_angle"][first])
    d.plot([0.0, ax, bx, lengths.ground], [0.0, ay, by, 0.0], "k-o", lw=1, ms=3)
    d.plot([ax, x[first], bx], [ay, y[first], by], "k:", lw=1)
    d.set(xlabel="x [m]", ylabel="y [m]", aspect="equal")
    d.legend(fontsize=8)
    return _png(figure)


def engine_figure() -> bytes:
    """slider_crank_engine: gas force and crank torque over a cycle, the shaking force
    against the primary/secondary approximation, and counterweights."""
    scene = _scene("slider_crank_engine")
    reference = sr.slider_crank_engine_scene(scene)
    name, p = sr.component(scene, "SliderCrank")
    geometry = sc.check_slider_crank(p["crank_length"], p["coupler_length"], p["offset"])
    layouts = _layouts(p, ("crank", "coupler")) + [
        link_forces.MassLayout(p["slider_mass"], 0.0, 0.0, 0.0)
    ]
    angle, speed = reference["crank.crank_angle"], reference["crank.crank_speed"]
    gas = reference["gas.load"]
    degrees = np.degrees(angle)

    def run(counterweight: float, loads: Any = None) -> list[dict]:
        crank = link_forces.with_point_mass(
            layouts[0], counterweight, -p["counterweight_radius"], 0.0
        )
        forces = lf.SliderCrankForces(geometry, 0, [crank, *layouts[1:]])
        rows = []
        for k in range(len(angle)):
            motion = sc.checked_motion(geometry, 0, angle[k], speed[k], 0.0)._asdict()
            load = lf.SliderCrankLoads(gas[k] if loads is None else 0.0, 0.0, 0.0)
            rows.append(forces.analyse((angle[k], speed[k], 0.0), motion, load))
        return rows

    engine = run(0.0)
    torque = -np.array([row["crank_torque"] for row in engine])  # what the engine delivers
    figure = Figure(figsize=(10, 7), layout="constrained")
    (a, b), (c, d) = figure.subplots(2, 2)
    a.plot(degrees, gas / 1e3, label="gas force [kN]")
    a.plot(degrees, torque / 1e2, label="engine torque -T12 [100 N m]")
    inertia_only = -np.array([row["crank_torque"] for row in run(0.0, loads=False)])
    a.plot(degrees, inertia_only / 1e2, ":", label="inertia alone [100 N m]")
    a.set(xlabel="crank angle [deg]")
    a.set_title(f"mean torque {np.mean(torque[:-1]):.2f} N m over the cycle", fontsize=9)
    a.legend(fontsize=8)
    omega = float(speed[0])
    approx = ref.lumped_shaking_force(
        geometry.crank,
        geometry.coupler,
        sr.link_layouts(p, ("crank", "coupler")) + [(p["slider_mass"], 0, 0, 0)],
        (0.0, 0.0),
        angle,
        omega,
    )
    exact_x = np.array([row["shaking_force_x"] for row in engine])
    b.plot(degrees, exact_x, label="exact (runtime)")
    b.plot(degrees, approx["shaking_force_x"], "--", label="primary + secondary")
    b.plot(degrees, approx["primary_x"], ":", label="primary only")
    b.set(xlabel="crank angle [deg]", ylabel="shaking force x [N]")
    b.set_title(
        f"series truncation: {np.max(np.abs(exact_x - approx['shaking_force_x'])):.0f} N "
        f"of {np.max(np.abs(exact_x)):.0f} N",
        fontsize=9,
    )
    b.legend(fontsize=8)
    crank_l, rod = layouts[0], layouts[1]
    r, length = geometry.crank, geometry.coupler
    rotating = (crank_l.mass * crank_l.com_x + rod.mass * (length - rod.com_x) * r / length) / r
    reciprocating = layouts[2].mass + rod.mass * rod.com_x / length
    radius = p["counterweight_radius"]
    for mass, label in (
        (0.0, "no counterweight"),
        (rotating * r / radius, "rotating mass balanced"),
        ((rotating + 0.5 * reciprocating) * r / radius, "+ half the reciprocating"),
    ):
        rows = run(mass)
        c.plot(
            [row["shaking_force_x"] for row in rows],
            [row["shaking_force_y"] for row in rows],
            label=f"{label} ({mass:.2f} kg)",
        )
    c.set(xlabel="shaking force x [N]", ylabel="shaking force y [N]", aspect="equal")
    c.legend(fontsize=8)
    for joint, label in (
        ("crank_pin", "crank pin A"),
        ("slider_pin", "piston pin B"),
        ("crank_pivot", "main bearing"),
    ):
        d.plot(degrees, [row[f"{joint}_force_magnitude"] / 1e3 for row in engine], label=label)
    d.plot(degrees, [abs(row["guide_force_y"]) / 1e3 for row in engine], label="cylinder wall")
    d.set(xlabel="crank angle [deg]", ylabel="load [kN]")
    d.legend(fontsize=8)
    return _png(figure)


def gear_figure() -> bytes:
    """gear_retraction_loads (motion drive) and a dynamics-drive retraction: the piston force,
    the pivot and anchor loads."""
    scene = _scene("gear_retraction_loads")
    reference = sr.gear_loads_scene(scene)
    figure = Figure(figsize=(10, 3.8), layout="constrained")
    a, b = figure.subplots(1, 2)
    angle = np.degrees(reference["gear.gear_angle"])
    a.plot(angle, reference["gear.piston_force_required"], label="piston force")
    a.plot(angle, reference["gear.pivot_force_magnitude"], label="pivot B load")
    a.plot(angle, reference["gear.anchor_force_magnitude"], "--", label="anchor load")
    a.set(xlabel="gear angle [deg]", ylabel="force [N]")
    a.set_title("kinematic drive, 3 s retraction, 40 m/s", fontsize=9)
    a.legend(fontsize=8)
    values: dict[str, Any] = {**sr.start_values("LandingGear"), "inertia": True, "gravity": True}
    values.update(aero_drag=True, pivot_friction=True, forces=True, airspeed=30.0)
    values.update(drive="dynamics", piston_force=2000.0)
    body = gd.make_body(values["bar_length"], values["bar_mass"], values["wheel_mass"])
    d, h = gear.check_geometry(values["attachment_distance"], values["pivot_height"])
    geometry = gd.Geometry(d, h, values["down_angle"], values["airframe_pitch"])
    dynamics = gd.Dynamics(values, body, geometry)
    loads = gear_forces.GearForces(values, body, geometry)
    state = dynamics.initial_state()
    times, rows = [], []
    dt = 2e-3
    for k in range(1500):
        rates, alpha, _ = dynamics.derivatives(state, values)
        out = loads.reactions(
            state[0], state[1], alpha, dynamics.piston_force_on_bar(state, values), 30.0
        )
        times.append(k * dt)
        rows.append(out)
        if dynamics.piston_length(state) >= values["stroke_max"]:
            break
        half = [s + 0.5 * dt * r for s, r in zip(state, rates)]
        rates2, _, _ = dynamics.derivatives(half, values)
        state = [s + dt * r for s, r in zip(state, rates2)]
    b.plot(times, [row["pivot_force_magnitude"] for row in rows], label="pivot B load")
    b.plot(times, [row["anchor_force_magnitude"] for row in rows], "--", label="anchor load")
    b.set(xlabel="time [s]", ylabel="force [N]")
    b.set_title("dynamics drive: 2 kN on the piston, 30 m/s (midpoint rule, 2 ms)", fontsize=9)
    b.legend(fontsize=8)
    return _png(figure)


def valve_figure() -> bytes:
    """The valve train over a camshaft revolution at 3000 engine rpm, defaults with the valve
    spring: the cam's push and the joint loads, the cam torque with and without the links'
    inertia against the valve spring effect's camshaft torque, and the power balance."""
    geometry = vt.DEFAULT_VALVE_GEOMETRY
    profile = cam_laws.DEFAULT_CAM_PROFILE
    law = cam_laws.motion_function(profile)
    closed = vt.rest_position(geometry)[1]
    spring = valve_forces.ValveSpringLoad(0.1, 50e3, 300.0)
    speed = 50.0 * math.pi
    pushrod = valve_forces.pushrod_frame(valve_forces.DEFAULT_PUSHROD)
    heavy = valve_forces.ValveTrainForces(geometry, pushrod, valve_forces.DEFAULT_ROCKER, spring)
    light = valve_forces.ValveTrainForces(
        geometry, link_forces.NO_MASS, link_forces.NO_MASS, spring
    )
    angles = np.linspace(0.0, 2.0 * math.pi, 721)
    rows, light_rows, spring_torque, motions = [], [], [], []
    for angle in angles:
        s, s1, _, _ = cam_laws.cam_lift(profile, angle)
        motion = vt.forward(geometry, *law(angle, speed, 0.0))._asdict()
        motions.append(motion)
        rows.append(heavy.analyse(motion, closed, s1))
        light_rows.append(light.analyse(motion, closed, s1))
        contact = vt.contact_force(
            0.1, 50e3, 300.0, motion["valve_lift"], motion["valve_acceleration"]
        )
        spring_torque.append(
            cam_geometry.camshaft_torque(contact, vt.valve_lift_rate(geometry, closed, s, s1))
        )
    columns = {key: np.array([m[key] for m in motions]) for key in motions[0]}
    layouts = [tuple(pushrod), tuple(valve_forces.DEFAULT_ROCKER), (spring.mass, 0.0, 0.0, 0.0)]
    balance = valve_reference.cam_power(
        geometry._asdict(), columns, layouts, (0.0, 0.0), spring[1:]
    )
    power = np.array([row["input_power"] for row in rows])
    degrees = np.degrees(angles)
    figure = Figure(figsize=(10, 7), layout="constrained")
    (a, b), (c, d) = figure.subplots(2, 2)
    for key, label in (
        ("cam_force", "cam on tappet"),
        ("pushrod_force_magnitude", "pushrod (at T)"),
        ("rocker_pivot_force_magnitude", "rocker pivot"),
        ("valve_link_force_magnitude", "rocker on valve"),
    ):
        a.plot(degrees, [row[key] for row in rows], label=label)
    a.set(xlabel="camshaft angle [deg]", ylabel="force [N]")
    a.legend(fontsize=8)
    b.plot(degrees, [row["cam_torque"] for row in rows], label="cam_torque (forces)")
    b.plot(degrees, [row["cam_torque"] for row in light_rows], "--", label="massless links")
    b.plot(degrees[::12], spring_torque[::12], "x", label="camshaft_torque (valve_spring)")
    b.set(xlabel="camshaft angle [deg]", ylabel="torque [N m]")
    b.set_title(
        f"mean over the revolution {np.mean(np.array([r['cam_torque'] for r in rows])[:-1]):.1e} N m",
        fontsize=9,
    )
    b.legend(fontsize=8)
    c.plot(degrees, power, label="cam_force x tappet velocity (runtime)")
    c.plot(degrees[::12], balance[::12], "o", mfc="none", label="power balance (kinematics only)")
    c.set(xlabel="camshaft angle [deg]", ylabel="power [W]")
    c.legend(fontsize=8)
    scale = np.max(np.abs(power))
    d.semilogy(degrees, np.abs(power - balance) / scale + 1e-18)
    d.set(xlabel="camshaft angle [deg]", ylabel="|difference| / max |power|")
    d.set_title(f"largest {np.max(np.abs(power - balance)) / scale:.1e}", fontsize=9)
    return _png(figure)


FIGURES = {
    "four_bar_forces.png": four_bar_validation,
    "slider_crank_engine.png": engine_figure,
    "gear_loads.png": gear_figure,
    "valve_train_forces.png": valve_figure,
}
