"""ValveTrain's cam_geometry effect and the camshaft torque (ValveTrain, ValveSpring) through
the built FMUs: the outputs are the runtime's cam at each step, forward and inverse; a cusp,
an undercut and an offset beyond the base circle are refused at initialisation naming the
parameter and its limit, a pressure angle over its limit is warned; the torque balances the
power of the force on the valve and averages out over a revolution."""

import math

import numpy as np
import pytest

import mechfmu
from mechfmu.cli import main as cli
from mechfmu.cosim.master import SimulationError
from mechfmu.cosim.scene import find_file, load_scene
from mechfmu.runtime.physics import cam_geometry as cg
from mechfmu.runtime.physics import cam_laws as cl
from mechfmu.runtime.physics import valve_train as vt

CAM_OUTPUTS = (
    "pressure_angle",
    "radius_of_curvature",
    "pitch_radius_of_curvature",
    "cam_contact_x",
    "cam_contact_y",
    "face_contact_position",
)
DESIGN_OUTPUTS = ("min_radius_of_curvature", "max_pressure_angle", "face_width")


def scene_recording(name, *variables):
    """The shipped scene ``name`` recording also ``variables`` of its component valve."""
    scene = load_scene(find_file(name))
    scene.record = list(scene.record) + [f"valve.{v}" for v in variables]
    return scene


def follower_of(parameters):
    return cg.check_follower(
        parameters["follower"],
        parameters["cam_base_radius"],
        parameters["roller_radius"],
        parameters["follower_offset"],
    )


def test_effect_off_costs_no_output(fmu_dir):
    scene = scene_recording(
        "valve_train", *DESIGN_OUTPUTS, "pressure_angle", "pitch_radius_of_curvature"
    )
    table = mechfmu.simulate(scene, parameters={"valve.cam_geometry": False}, stop_time=0.002)
    for name in DESIGN_OUTPUTS:
        assert (table[f"valve.{name}"] == -1.0).all()
    for name in CAM_OUTPUTS:
        assert (table[f"valve.{name}"] == 0.0).all()
    assert table["valve.camshaft_torque"].abs().max() > 1.0  # valve_spring is still on


@pytest.mark.parametrize("scene_name", ["valve_train", "valve_train_inverse"])
def test_cam_outputs_are_the_runtime_cam_at_each_step(fmu_dir, scene_name):
    table = mechfmu.simulate(scene_recording(scene_name, *DESIGN_OUTPUTS), stop_time=0.02)
    parameters = table.attrs["components"]["valve"]["parameters"]
    follower = follower_of(parameters)
    geometry = vt.check_geometry(
        vt.ValveGeometry(*(parameters[name] for name in vt.ValveGeometry._fields))
    )
    profile = cl.check_profile(
        *(parameters[k] for k in ("cam_law", "lift", "rise_start", "rise_angle")),
        parameters["high_dwell_angle"],
        parameters["return_angle"],
    )
    pieces = vt.tappet_pieces(geometry, profile, parameters["mode"])
    found = cg.design(follower, pieces, parameters["pressure_angle_limit"])
    assert table["valve.min_radius_of_curvature"].iloc[-1] == found.least_radius
    assert table["valve.max_pressure_angle"].iloc[-1] == abs(found.largest_pressure_angle)
    assert table["valve.face_width"].iloc[-1] == found.face_width
    for angle, row in zip(table["camshaft.camshaft_angle"], table.itertuples(index=False)):
        s, s1, s2, _ = cl.cam_lift(profile, angle)
        if parameters["mode"] == "inverse":
            motion = vt.inverse(geometry, s, s1, s2)
            s, s1, s2 = motion.tappet_lift, motion.tappet_velocity, motion.tappet_acceleration
        point = cg.cam_point(follower, angle, s, s1, s2)
        recorded = dict(zip(table.columns, row))
        for name, value in zip(
            CAM_OUTPUTS,
            (
                point.pressure_angle,
                point.radius_of_curvature,
                point.pitch_radius_of_curvature,
                point.x,
                point.y,
                point.face_contact,
            ),
        ):
            if f"valve.{name}" in recorded:
                assert recorded[f"valve.{name}"] == value, name


def test_inverse_mode_cam_has_the_roller_on_the_desired_valve_motion(fmu_dir):
    # every recorded contact point lies Rf inside the roller centre's path, and the roller
    # centre is where the tappet's lift (an output of the inverse) puts it
    table = mechfmu.simulate("valve_train_inverse")
    parameters = table.attrs["components"]["valve"]["parameters"]
    follower = follower_of(parameters)
    angle = table["camshaft.camshaft_angle"].to_numpy()
    height = cg.trace_height(follower) + table["valve.tappet_lift"].to_numpy()
    centre_x = np.cos(angle) * follower.offset + np.sin(angle) * height
    centre_y = np.cos(angle) * height - np.sin(angle) * follower.offset
    gap = np.hypot(table["valve.cam_contact_x"] - centre_x, table["valve.cam_contact_y"] - centre_y)
    np.testing.assert_allclose(gap, follower.roller_radius, rtol=1e-12)


@pytest.mark.parametrize(
    "changes, name, limit",
    [
        (
            {"valve.cam_base_radius": 0.015, "valve.pushrod_length": 0.2},
            "cam_base_radius = 0.015 m",
            "(0.0215522191130",
        ),
        (
            {
                "valve.follower": "roller",
                "valve.roller_radius": 0.03,
                "valve.cam_base_radius": 0.005,
                "valve.pushrod_length": 0.21,
            },
            "roller_radius = 0.03 m",
            "(0, 0.0248695941",
        ),
        ({"valve.follower_offset": 0.026}, "follower_offset = 0.026 m", "(-0.025, 0.025)"),
    ],
)
def test_a_cam_that_cannot_be_made_is_refused_naming_the_limit(fmu_dir, changes, name, limit):
    with pytest.raises(SimulationError) as info:
        mechfmu.simulate("valve_train", parameters=changes, stop_time=0.001)
    message = str(info.value)
    assert f"{name} is outside the valid range {limit}" in message
    if "follower_offset" not in name:
        assert "at camshaft angle" in message


def test_a_pressure_angle_over_its_limit_is_warned(fmu_dir):
    table = mechfmu.simulate(
        "valve_train_inverse", parameters={"valve.pressure_angle_limit": 0.4}, stop_time=0.001
    )
    warnings = [entry["message"] for entry in table.attrs["log"] if entry["status"] == "warning"]
    assert len(warnings) == 1
    assert "pressure angle 25.87 deg at camshaft angle" in warnings[0]
    assert "exceeds pressure_angle_limit 22.92 deg" in warnings[0]


def test_camshaft_torque_balances_the_valves_power_and_averages_out(fmu_dir):
    table = mechfmu.simulate("valve_train")
    torque = table["valve.camshaft_torque"].to_numpy()
    speed = 0.5 * 100.0 * math.pi  # rad/s: 3000 engine rpm
    power = (table["valve.contact_force"] * table["valve.valve_velocity"]).to_numpy()
    peak = np.max(np.abs(torque))
    np.testing.assert_allclose(torque * speed, power, rtol=1e-9, atol=1e-9 * peak * speed)
    # one revolution at constant speed: the spring and the valve's inertia give back what
    # they took (trapezoid over 400 samples; the exact integral is 0, tests/test_cam_geometry)
    angle = table["camshaft.camshaft_angle"].to_numpy()
    assert angle[-1] - angle[0] == pytest.approx(2.0 * math.pi, rel=1e-12)
    mean = np.trapezoid(torque, angle) / (2.0 * math.pi)
    assert abs(mean) < 1e-3 * peak
    assert 8.0 < peak < 12.0  # N.m


def test_valve_spring_torque_balances_the_contact_power(fmu_dir):
    table = mechfmu.simulate("valve_train_dynamic")
    torque = table["valve.camshaft_torque"].to_numpy()
    power = (table["valve.contact_force"] * table["valve_train.valve_velocity"]).to_numpy()
    speed = table["camshaft.camshaft_speed"].to_numpy()
    peak = np.max(np.abs(torque))
    assert peak > 1.0
    np.testing.assert_allclose(torque * speed, power, rtol=1e-9, atol=1e-9 * peak * speed[0])


def test_camshaft_example_compares_the_sequences(fmu_dir, tmp_path, capsys):
    status = cli(
        ["example", "camshaft", "--out", str(tmp_path), "--fmu-dir", str(fmu_dir), "--no-plot"]
    )
    out = capsys.readouterr().out
    assert status == 0
    assert "| firing order 1-3-4-2 | 18.627 | 6.801 |" in out
    assert "| firing order 1-2-3-4 | 18.627 | 6.801 |" in out
    assert "| crank-throw angles 0-180-180-0 (not halved) | 37.60" in out
    assert (tmp_path / "camshaft_torque.png").read_bytes()[:4] == b"\x89PNG"
