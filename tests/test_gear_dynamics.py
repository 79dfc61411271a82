"""Landing gear dynamics: the issue's physical checks, effects that cost nothing when off."""

import math

import numpy as np
import pytest

from conftest import SCENES
from fmu_driver import Driven
from mechfmu.check import compare
from mechfmu.cosim.run import run_scene
from mechfmu.runtime.models.landing_gear import LandingGear
from mechfmu.runtime.physics import gear_dynamics as gd
from mechfmu.runtime.physics import hydraulics, profiles
from mechfmu.runtime.physics import landing_gear as kinematics
from mechfmu.runtime.numerics.integrators import make_integrator
from mechfmu.runtime.physics.landing_gear import DEFAULT_GEOMETRY as G

D, H = G.attachment_distance, G.pivot_height
BODY = gd.Body(0.762, gd.DEFAULT_BAR_MASS, gd.DEFAULT_WHEEL_MASS)
GEOMETRY = gd.Geometry(D, H, G.start_angle, 0.0)


def test_static_holding_force_is_gravity_moment_over_moment_arm(fmu_dir):
    gear = Driven(fmu_dir / "LandingGear.fmu", parameters={"gravity": True})
    try:
        for x in np.linspace(0.39, 0.60, 15):
            assert gear.step(0.01, piston_extension=float(x)) is True
            angle = kinematics.gear_motion(x, 0.0, 0.0, D, H).angle
            weight_moment = (
                (BODY.bar_mass * BODY.bar_length / 2 + BODY.wheel_mass * BODY.bar_length)
                * gd.STANDARD_GRAVITY
                * math.sin(angle - G.start_angle)
            )
            arm = D * H * math.sin(angle) / x
            assert gear.get("piston_force_required") == pytest.approx(
                weight_moment / arm, rel=1e-12
            )
    finally:
        gear.close()


def test_piston_work_equals_kinetic_plus_potential_energy_change(fmu_dir):
    gear = Driven(
        fmu_dir / "LandingGear.fmu",
        parameters={
            "drive": "dynamics",
            "inertia": True,
            "gravity": True,
            "integrator": "dopri5",
            "rtol": 1e-11,
            "atol": 1e-11,
        },
        inputs={"piston_force": 800.0},
    )
    try:
        start = gear.get("kinetic_energy") + gear.get("potential_energy")
        for _ in range(100):
            assert gear.step(0.01) is True
        work = gear.get("piston_work")
        change = gear.get("kinetic_energy") + gear.get("potential_energy") - start
        assert work > 50.0  # the gear really moved
        assert change == pytest.approx(work, rel=1e-8)
    finally:
        gear.close()


def test_vanishing_inertia_with_a_stiff_servo_reproduces_the_kinematic_solution():
    """I_B -> 0 and a stiff PD position servo on the piston: theta(t) -> theta(x_ref(t))."""
    body = gd.Body(0.762, 1e-6, 0.0)
    inertia = gd.inertia(body)
    stiffness, damping = 1e7, 2e5

    def reference(t):
        return profiles.stroke(t, 0.381, 0.6096, 3.0, "cycloidal")

    def rhs(t, y):
        piston = kinematics.piston_motion(y[0], y[1], 0.0, D, H)
        target = reference(t)
        force = stiffness * (target.value - piston.extension) + damping * (
            target.rate - piston.speed
        )
        arm = D * H * math.sin(y[0]) / piston.extension
        return [y[1], force * arm / inertia]

    integrator = make_integrator("radau", rtol=1e-10, atol=1e-12, max_substep=0.01)
    y, worst = [G.start_angle, 0.0], 0.0
    for k in range(1, 31):
        t0, t1 = (k - 1) * 0.1, k * 0.1
        y = integrator.advance(rhs, t0, y, t1).y
        exact = kinematics.gear_motion(*reference(t1), D, H).angle
        worst = max(worst, abs(y[0] - exact))
    assert worst < 1e-7


def test_retraction_under_four_seconds_and_matches_its_reference(fmu_dir, tmp_path):
    result, paths = run_scene(
        SCENES / "gear_retraction_dynamic.toml", tmp_path, fmu_dir, plot=False
    )
    retraction = result.columns["gear.retraction_time"][-1]
    assert 1.0 < retraction < 4.0
    comparison = compare(paths["csv"], result.scene.reference)  # its declared [check]
    assert comparison.ok, str(comparison)
    assert any("reached stroke_max" in entry["message"] for entry in result.log)


def test_gravity_extension_matches_its_reference_and_reports_the_time(fmu_dir, tmp_path):
    result, paths = run_scene(SCENES / "gear_extension_gravity.toml", tmp_path, fmu_dir, plot=False)
    assert 0.2 < result.columns["gear.extension_time"][-1] < 2.0
    assert abs(result.columns["gear.gear_angular_velocity"][-1]) < 1e-6  # at rest on the stop
    comparison = compare(paths["csv"], result.scene.reference)  # its declared [check]
    assert comparison.ok, str(comparison)


def test_external_hydraulics_agree_with_built_in_up_to_the_coupling_error(fmu_dir, tmp_path):
    built_in, _ = run_scene(SCENES / "gear_retraction_dynamic.toml", tmp_path, fmu_dir, plot=False)
    external, paths = run_scene(
        SCENES / "gear_retraction_external_hydraulics.toml", tmp_path, fmu_dir, plot=False
    )
    assert external.meta["lagged_connections"] == ["hydraulics.piston_force -> gear.piston_force"]
    difference = abs(
        external.columns["gear.retraction_time"][-1] - built_in.columns["gear.retraction_time"][-1]
    )
    assert 0.0 < difference < 2e-3  # one lagged coupling at a 1 ms communication step


def _counting(monkeypatch, module, names, counts):
    """Wrap module functions so each call increments counts[name]."""
    for name in names:
        counts[name] = 0
        original = getattr(module, name)

        def wrapper(*args, _name=name, _original=original, **kwargs):
            counts[_name] += 1
            return _original(*args, **kwargs)

        monkeypatch.setattr(module, name, wrapper)


def _run_model(parameters, inputs, steps=20):
    model = LandingGear(instance_name="counted")
    model.values.update(parameters)
    model.values.update(inputs)
    model.exit_initialization_mode()
    for k in range(steps):
        assert model.do_step(k * 0.01, 0.01), model.pending_error
    return model


@pytest.mark.parametrize(
    "enabled",
    [
        (),
        ("gravity",),
        ("aero_drag", "pivot_friction"),
        ("gravity", "aero_drag", "pivot_friction", "end_stops", "hydraulics"),
    ],
)
def test_a_disabled_effect_is_never_evaluated(monkeypatch, enabled):
    names = {
        "gravity": "gravity_moment",
        "aero_drag": "drag_moment",
        "pivot_friction": "friction_moment",
        "end_stops": "stop_force",
    }
    counts = {}
    _counting(monkeypatch, gd, list(names.values()), counts)
    _counting(monkeypatch, hydraulics, ["pressure_rates"], counts)
    parameters = {"drive": "dynamics", "inertia": True, **{name: True for name in enabled}}
    _run_model(parameters, {"piston_force": 300.0, "valve_command": 1.0, "airspeed": 30.0})
    for effect, function in list(names.items()) + [("hydraulics", "pressure_rates")]:
        if effect in enabled:
            assert counts[function] > 0, effect
        else:
            assert counts[function] == 0, effect


def test_dynamics_drive_needs_inertia_and_says_so():
    model = LandingGear(instance_name="no_inertia")
    model.values["drive"] = "dynamics"
    model.exit_initialization_mode()
    assert not model.do_step(0.0, 0.01)
    assert "needs the inertia effect" in model.pending_error


def test_fmu_state_round_trip_in_the_dynamics_drive(fmu_dir):
    gear = Driven(
        fmu_dir / "LandingGear.fmu",
        parameters={
            "drive": "dynamics",
            "inertia": True,
            "gravity": True,
            "hydraulics": True,
            "end_stops": True,
        },
        inputs={"valve_command": 1.0},
    )
    try:
        for _ in range(50):
            assert gear.step(0.01) is True

        def steps():
            rows = []
            for _ in range(30):
                assert gear.step(0.01) is True
                rows.append(
                    (gear.get("gear_angle"), gear.get("cap_pressure"), gear.get("rhs_evaluations"))
                )
            return rows

        first, second = gear.replayed(steps)
        assert first == second
    finally:
        gear.close()
