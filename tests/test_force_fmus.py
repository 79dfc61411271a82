"""The forces effect through the FMUs and mechfmu.simulate: the power balance on random
geometries and mass layouts, bad parameters, unbounded forces reported through the FMI
status, the effect off leaving the kinematics untouched, and a replayed FMU state."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mechfmu
from fmu_driver import Driven
from mechfmu.cosim.master import SimulationError
from mechfmu.references import gear_forces as gear_reference
from mechfmu.references import link_forces as ref
from mechfmu.runtime.physics import four_bar as fb
from mechfmu.tools.scene_references import start_values

LINKS = ("crank", "coupler", "rocker")


def power_balance(table, lengths, layouts, gravity, point, loads):
    """Input power from the recorded kinematics alone (references/link_forces.py)."""
    crank = [table[f"crank.crank_{k}"].to_numpy() for k in ("angle", "speed", "acceleration")]
    motion = {key: table[f"linkage.{key}"].to_numpy() for key in fb.FourBarMotion._fields[:6]}
    links = ref.four_bar_links(lengths, crank, motion)
    power = ref.load_power(links, point, loads[1:], loads[0])
    return ref.power_balance_torque(links, layouts, gravity, power)["input_power"]


@settings(
    max_examples=4, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    scale=st.floats(0.5, 3.0),
    shape=st.sampled_from(
        [(6.0, 2.0, 7.0, 9.0), (10.0, 3.0, 8.0, 7.0), (5.0, 1.5, 5.5, 4.0), (8.0, 2.5, 9.0, 8.5)]
    ),
    masses=st.lists(st.floats(0.05, 4.0), min_size=3, max_size=3),
    offsets=st.lists(st.floats(-0.1, 0.1), min_size=6, max_size=6),
    inertias=st.lists(st.floats(0.0, 0.02), min_size=3, max_size=3),
    gravity_direction=st.floats(-math.pi, math.pi),
)
def test_power_balance_through_simulate_on_random_geometries_and_mass_layouts(
    fmu_dir, scale, shape, masses, offsets, inertias, gravity_direction
):
    lengths = [0.0254 * scale * v for v in shape]  # ground, crank, coupler, rocker: Grashof
    parameters = {
        f"linkage.{name}_length": value
        for name, value in zip(("ground", "crank", "coupler", "rocker"), lengths)
    }
    parameters["linkage.gravity_direction"] = gravity_direction
    layouts = []
    for k, link in enumerate(LINKS):
        layout = (masses[k], offsets[2 * k], offsets[2 * k + 1], inertias[k])
        layouts.append(layout)
        for field, value in zip(("mass", "com_along", "com_across", "inertia"), layout):
            parameters[f"linkage.{link}_{field}"] = value
    table = mechfmu.simulate("four_bar_forces", parameters=parameters, fmu_dir=fmu_dir)
    defaults = start_values("FourBar")
    g = defaults["gravity_acceleration"]
    gravity = (g * math.cos(gravity_direction), g * math.sin(gravity_direction))
    point = (defaults["coupler_point_along"], defaults["coupler_point_across"])
    expected = power_balance(table, lengths, layouts, gravity, point, (-0.5, 0.0, -20.0))
    power = table["linkage.input_power"].to_numpy()
    assert np.max(np.abs(power - expected)) <= 1e-9 * np.max(np.abs(expected))
    torque = table["linkage.crank_torque"].to_numpy() * table["crank.crank_speed"].to_numpy()
    np.testing.assert_array_equal(torque, power)


def test_negative_mass_is_one_clear_error_through_simulate(fmu_dir):
    with pytest.raises(SimulationError) as caught:
        mechfmu.simulate(
            "four_bar_forces", parameters={"linkage.coupler_mass": -0.2}, fmu_dir=fmu_dir
        )
    message = str(caught.value)
    assert "coupler_mass = -0.2 kg is outside the valid range [0, inf) kg" in message
    assert message.count("coupler_mass") == 1


def test_unbounded_forces_reach_the_host_as_a_discarded_step_with_time_and_configuration(
    fmu_dir,
):
    # a triple rocker driven to 1e-12 rad of its toggle: the kinematics answer, the joints
    # cannot carry the load (condition number above singularity_threshold)
    lengths = {"ground_length": 0.1, "crank_length": 0.08, "coupler_length": 0.06}
    lengths["rocker_length"] = 0.05
    toggle = math.acos((0.08**2 + 0.1**2 - 0.11**2) / (2 * 0.08 * 0.1))
    fmu = Driven(
        fmu_dir / "FourBar.fmu",
        {**lengths, "forces": True},
        {"crank_angle": toggle - 0.1, "rocker_torque": 1.0},
    )
    try:
        assert fmu.step(0.01, crank_angle=toggle - 1e-8) is True
        torque = fmu.get("crank_torque")
        assert math.isfinite(torque) and abs(torque) > 1e3
        result = fmu.step(0.01, crank_angle=toggle - 1e-12)
        assert result is not True and "discard" in result
        assert "at t = 0.02 s" in result and "joint forces unbounded" in result
        assert "toggle position" in result and "crank angle 1.2987" in result
        assert fmu.get("crank_torque") == torque  # the last answer is kept
    finally:
        fmu.close()


def test_forces_off_leave_the_kinematics_alone_and_publish_nothing(fmu_dir):
    runs = {}
    for forces in (False, True):
        fmu = Driven(fmu_dir / "SliderCrank.fmu", {"forces": forces}, {"crank_angle": 0.2})
        try:
            rows = []
            for k in range(1, 30):
                assert fmu.step(1e-3, crank_angle=0.2 + 300.0 * k * 1e-3, crank_speed=300.0)
                rows.append(
                    [
                        fmu.get(n)
                        for n in (
                            "slider_position",
                            "coupler_angular_acceleration",
                            "crank_torque",
                            "guide_force_y",
                        )
                    ]
                )
            runs[forces] = np.array(rows)
        finally:
            fmu.close()
    np.testing.assert_array_equal(runs[False][:, :2], runs[True][:, :2])
    assert not runs[False][:, 2:].any() and runs[True][:, 2:].all()


@pytest.mark.parametrize("solver", ["closed_form", "constraint_solver"])
def test_replayed_state_gives_the_same_forces_bit_for_bit(fmu_dir, solver):
    fmu = Driven(
        fmu_dir / "FourBar.fmu",
        {"forces": True, "gravity": True, "solver": solver},
        {"crank_angle": 0.5, "crank_speed": 20.0, "rocker_torque": -1.0},
    )
    names = ("crank_torque", "rocker_pin_force_x", "shaking_moment")

    def steps():
        values = []
        for k in range(1, 40):
            assert fmu.step(0.005, crank_angle=0.5 + 20.0 * (fmu.time + 0.005)) is True
            values.append([fmu.get(n) for n in names])
        return values

    try:
        first, again = fmu.replayed(steps)
        assert first == again
    finally:
        fmu.close()


def test_gear_dynamic_drive_loads_follow_newton(fmu_dir):
    # the dynamics drive pushed by a constant piston force: the loads from the integrated
    # motion and the applied force (no end stops)
    values = {**start_values("LandingGear")}
    gear = Driven(
        fmu_dir / "LandingGear.fmu",
        {
            "drive": "dynamics",
            "forces": True,
            "inertia": True,
            "gravity": True,
            "aero_drag": True,
            "pivot_friction": True,
        },
        {"piston_force": 4000.0, "airspeed": 30.0},
    )
    try:
        rows = []
        for _ in range(60):
            assert gear.step(0.01) is True
            rows.append(
                {
                    name: gear.get(name)
                    for name in (
                        "gear_angle",
                        "gear_angular_velocity",
                        "gear_angular_acceleration",
                        "pivot_force_x",
                        "pivot_force_y",
                        "anchor_force_x",
                        "anchor_force_y",
                        "piston_power",
                        "piston_rate",
                    )
                }
            )
    finally:
        gear.close()
    values.update(inertia=True, gravity=True, aero_drag=True, pivot_friction=True, airspeed=30.0)
    theta, omega, alpha = (
        np.array([row[k] for row in rows])
        for k in ("gear_angle", "gear_angular_velocity", "gear_angular_acceleration")
    )
    expected = gear_reference.pivot_and_anchor(values, theta, omega, alpha, 4000.0)
    for key in ("pivot_force_x", "pivot_force_y", "anchor_force_x", "anchor_force_y"):
        np.testing.assert_allclose(
            [row[key] for row in rows], expected[key], rtol=1e-9, atol=1e-9 * 4000.0, err_msg=key
        )
    np.testing.assert_allclose(
        [row["piston_power"] for row in rows], [4000.0 * row["piston_rate"] for row in rows]
    )


@pytest.mark.parametrize("solver", ["closed_form", "constraint_solver"])
def test_valve_train_cam_torque_ties_to_the_camshaft_torque(fmu_dir, solver):
    # massless pushrod and rocker: the Newton-Euler cam torque is the valve spring effect's
    # camshaft torque; with their masses it differs, but a revolution at constant speed still
    # costs no work (a conservative train)
    speed, steps = 80.0, 720
    runs = {}
    for masses in ("massless", "default"):
        parameters = {"forces": True, "valve_spring": True, "solver": solver}
        if masses == "massless":
            parameters.update(pushrod_mass=0.0, pushrod_inertia=0.0, rocker_mass=0.0)
            parameters.update(rocker_inertia=0.0)
        fmu = Driven(fmu_dir / "ValveTrain.fmu", parameters, {"camshaft_speed": speed})
        try:
            rows = []
            for k in range(1, steps + 1):
                angle = 2.0 * math.pi * k / steps
                assert fmu.step(angle / speed - fmu.time, camshaft_angle=angle) is True
                rows.append([fmu.get(n) for n in ("cam_torque", "camshaft_torque", "cam_force")])
            runs[masses] = np.array(rows)
        finally:
            fmu.close()
    light, heavy = runs["massless"], runs["default"]
    scale = np.max(np.abs(light[:, 1]))
    assert np.max(np.abs(light[:, 0] - light[:, 1])) < 1e-9 * scale
    assert np.max(np.abs(heavy[:, 0] - heavy[:, 1])) > 1e-3 * scale  # the links' inertia
    assert abs(np.mean(heavy[:, 0])) < 1e-6 * scale  # zero work over a revolution
    assert np.all(heavy[:, 2] > 0.0)  # the cam always pushes (no float at 80 rad/s)


@pytest.mark.parametrize(
    "scene, parameter, value, words",
    [
        ("four_bar_crank_rocker", "linkage.crank_mass", -1.0, "crank_mass = -1.0 kg"),
        ("four_bar_crank_rocker", "linkage.rocker_inertia", math.nan, "rocker_inertia = nan"),
        ("four_bar_crank_rocker", "linkage.gravity_acceleration", -9.81, "[0, inf) m/s2"),
        ("four_bar_crank_rocker", "linkage.coupler_point_along", math.inf, "coupler_point_along"),
        ("slider_crank_offset", "slider.counterweight_radius", -0.01, "counterweight_radius"),
        ("slider_crank_offset", "slider.slider_mass", -0.5, "slider_mass = -0.5 kg"),
        ("valve_train", "valve.rocker_mass", -1.0, "rocker_mass = -1.0 kg"),
    ],
)
def test_a_bad_parameter_of_the_forces_effect_is_refused_with_the_effect_off(
    fmu_dir, scene, parameter, value, words
):
    # these scenes run the kinematics only: a negative mass was accepted, unused, until a
    # scene switched the forces on
    with pytest.raises(SimulationError) as caught:
        mechfmu.simulate(scene, parameters={parameter: value}, fmu_dir=fmu_dir)
    assert words in str(caught.value) and "fmi2ExitInitializationMode" in str(caught.value)
