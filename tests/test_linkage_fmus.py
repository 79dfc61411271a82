"""FourBar, SliderCrank, ValveTrain and the shaft drives as FMUs, driven through fmpy.

Closed form against the constraint solver inside the same FMU along full revolutions (both
circuits), the drives against their numpy reference, singular positions and assembly limits
reported with the configuration, valve float detected with its camshaft speed, and the
solver's branch state rolled back and re-stepped identically through get/set FMU state.
"""

import math

import numpy as np
import pytest

from fmu_driver import Driven

from mechfmu.runtime.physics import cam_laws, constraint_models, planar
from mechfmu.runtime.physics import four_bar as fb
from mechfmu.runtime.physics import valve_train as vt
from mechfmu.references import drives, linkages
from mechfmu.references import valve_train as vt_reference


def wrapped_difference(a, b):
    return abs(math.remainder(a - b, 2.0 * math.pi))


def crank_run(
    path, parameters, outputs, steps=360, speed=2.0 * math.pi, start=0.3, acceleration=0.0
):
    """One crank revolution (plus) with exact crank inputs; returns {output: array}."""
    fmu = Driven(
        path,
        parameters,
        {"crank_angle": start, "crank_speed": speed, "crank_acceleration": acceleration},
    )
    dt = 1.0 / steps
    rows = {name: [fmu.get(name)] for name in outputs}
    try:
        for k in range(1, steps + 1):
            t = k * dt
            result = fmu.step(
                dt,
                crank_angle=start + speed * t + 0.5 * acceleration * t * t,
                crank_speed=speed + acceleration * t,
                crank_acceleration=acceleration,
            )
            assert result is True, result
            for name in outputs:
                rows[name].append(fmu.get(name))
        rows["newton_iterations"] = fmu.get("newton_iterations")
    finally:
        fmu.close()
    return {name: np.asarray(values) for name, values in rows.items()}


FOUR_BAR_OUTPUTS = (
    "coupler_angle",
    "rocker_angle",
    "coupler_angular_velocity",
    "rocker_angular_velocity",
    "coupler_angular_acceleration",
    "rocker_angular_acceleration",
    "transmission_angle",
)


@pytest.mark.parametrize(
    "lengths",
    [
        {},  # the coursework's 2, 7, 9, 6 in crank-rocker
        {
            "ground_length": 0.02,
            "crank_length": 0.06,
            "coupler_length": 0.07,
            "rocker_length": 0.05,
        },  # ground shortest: double-crank, coupler and rocker turn fully
    ],
)
@pytest.mark.parametrize("circuit", [0, 1])
def test_four_bar_solver_agrees_with_freudenstein_over_a_revolution(fmu_dir, lengths, circuit):
    closed = crank_run(
        fmu_dir / "FourBar.fmu", {**lengths, "circuit": circuit}, FOUR_BAR_OUTPUTS, acceleration=3.0
    )
    solved = crank_run(
        fmu_dir / "FourBar.fmu",
        {**lengths, "circuit": circuit, "solver": "constraint_solver"},
        FOUR_BAR_OUTPUTS,
        acceleration=3.0,
    )
    for name in FOUR_BAR_OUTPUTS:
        if name.endswith("angle"):
            worst = max(wrapped_difference(a, b) for a, b in zip(closed[name], solved[name]))
            assert worst <= 1e-10, name
        else:
            np.testing.assert_allclose(
                solved[name], closed[name], rtol=1e-10, atol=1e-10, err_msg=name
            )
    assert closed["newton_iterations"] == 0 and 1 <= solved["newton_iterations"] <= 3


def test_four_bar_fmu_matches_the_numpy_reference_and_reports_its_grashof_class(fmu_dir):
    ground, crank, coupler, rocker = fb.COURSEWORK_FOUR_BAR
    for circuit in (0, 1):
        fmu = Driven(
            fmu_dir / "FourBar.fmu",
            {"circuit": circuit},
            {
                "crank_angle": fb.COURSEWORK_CRANK_ANGLE,
                "crank_speed": 1.0,
                "crank_acceleration": 0.0,
            },
        )
        try:
            expected = linkages.four_bar(
                ground, crank, coupler, rocker, circuit, fb.COURSEWORK_CRANK_ANGLE, 1.0, 0.0
            )
            for name in FOUR_BAR_OUTPUTS:
                assert fmu.get(name) == pytest.approx(
                    float(expected[name]), rel=1e-12, abs=1e-14
                ), name
            assert fmu.get("grashof_class") == 1  # crank-rocker
        finally:
            fmu.close()
    assert math.degrees(
        float(
            linkages.four_bar(ground, crank, coupler, rocker, 0, fb.COURSEWORK_CRANK_ANGLE, 1, 0)[
                "rocker_angle"
            ]
        )
    ) == pytest.approx(117.2861, abs=1e-4)


SLIDER_OUTPUTS = (
    "slider_position",
    "slider_speed",
    "slider_acceleration",
    "coupler_angle",
    "coupler_angular_velocity",
    "coupler_angular_acceleration",
)


@pytest.mark.parametrize("offset", [0.0, 0.02, -0.03])
@pytest.mark.parametrize("circuit", [0, 1])
def test_slider_crank_solver_and_closed_form_agree_with_the_reference(fmu_dir, offset, circuit):
    parameters = {"offset": offset, "circuit": circuit}
    closed = crank_run(
        fmu_dir / "SliderCrank.fmu", parameters, SLIDER_OUTPUTS, speed=100.0, steps=200
    )
    solved = crank_run(
        fmu_dir / "SliderCrank.fmu",
        {**parameters, "solver": "constraint_solver"},
        SLIDER_OUTPUTS,
        speed=100.0,
        steps=200,
    )
    angle = 0.3 + 100.0 * np.arange(201) / 200
    expected = linkages.slider_crank(0.05, 0.15, offset, circuit, angle, 100.0, 0.0)
    for name in SLIDER_OUTPUTS:
        scale = np.max(np.abs(expected[name]))
        for values in (closed[name], solved[name]):
            difference = np.abs(values - expected[name])
            if name == "coupler_angle":
                difference = np.abs(np.remainder(difference + np.pi, 2 * np.pi) - np.pi)
            assert np.max(difference) <= 1e-12 * scale + 1e-13, name


def test_crank_and_camshaft_drives_match_their_reference(fmu_dir):
    for model, prefix, ratio in (("CrankDrive", "crank", 1.0), ("CamshaftDrive", "camshaft", 0.5)):
        parameters = {
            "initial_angle": 0.4,
            "initial_speed": 10.0,
            "speed": 50.0,
            "ramp_time": 0.3,
            "start_time": 0.1,
        }
        fmu = Driven(fmu_dir / f"{model}.fmu", parameters)
        times = np.arange(1, 61) * 0.01
        try:
            rows = []
            for _ in times:
                assert fmu.step(0.01) is True
                rows.append(
                    [fmu.get(f"{prefix}_{key}") for key in ("angle", "speed", "acceleration")]
                )
        finally:
            fmu.close()
        expected = drives.rotation(times, 0.4, 10.0, 50.0, 0.3, 0.1, ratio)
        rows = np.asarray(rows)
        np.testing.assert_allclose(rows[:, 0], expected["angle"], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(rows[:, 1], expected["speed"], rtol=1e-14, atol=1e-13)
        # At the ramp's start and end points the acceleration belongs to the ramp or not by
        # the rounding of the accumulated time
        inside = (np.abs(times - 0.4) > 1e-9) & (np.abs(times - 0.1) > 1e-9)
        np.testing.assert_allclose(rows[inside, 2], expected["acceleration"][inside], rtol=1e-14)


@pytest.mark.parametrize("solver", ["closed_form", "constraint_solver"])
def test_non_grashof_four_bar_stops_at_its_toggle_with_the_configuration(fmu_dir, solver):
    """(a, b, c, d) = (3, 2, 2.5, 4) cm: a triple-rocker whose crank cannot pass the angle
    where coupler and rocker line up, acos((a^2 + d^2 - (b + c)^2) / (2 a d))."""
    lengths = {
        "crank_length": 0.03,
        "coupler_length": 0.02,
        "rocker_length": 0.025,
        "ground_length": 0.04,
        "solver": solver,
    }
    limit = math.acos((9 + 16 - 4.5**2) / 24)
    fmu = Driven(fmu_dir / "FourBar.fmu", lengths, {"crank_angle": 0.5, "crank_speed": 1.0})
    try:
        assert fmu.get("grashof_class") == 5
        angle, result = 0.5, True
        while result is True and angle < limit + 0.2:
            angle += 0.01
            result = fmu.step(0.01, crank_angle=angle)
        assert result is not True
        assert limit - 0.01 < angle <= limit + 0.01
        if solver == "closed_form":
            assert "crank_angle" in result and "no assembly" in result
        else:
            assert "toggle position: coupler and rocker collinear" in result, result
            assert "condition number" in result or "did not converge" in result
        # The last good outputs are kept, and the instance can go back inside its range.
        assert fmu.step(0.01, crank_angle=0.6) is True
        assert 0.0 < fmu.get("transmission_angle") <= math.pi / 2
    finally:
        fmu.close()


def test_four_bar_solver_state_rolls_back_and_re_steps_identically(fmu_dir):
    fmu = Driven(
        fmu_dir / "FourBar.fmu",
        {"solver": "constraint_solver", "circuit": 1},
        {"crank_angle": 0.0, "crank_speed": 5.0},
    )
    try:
        for k in range(1, 11):
            assert fmu.step(0.01, crank_angle=0.05 * k) is True

        def steps():
            rows = []
            for k in range(11, 31):
                assert fmu.step(0.01, crank_angle=0.05 * k) is True
                rows.append((fmu.get("rocker_angle"), fmu.get("newton_iterations")))
            return rows

        first, again = fmu.replayed(steps)
        assert again == first  # bit for bit, iteration counts included
    finally:
        fmu.close()


VALVE_OUTPUTS = vt_reference.MOTION_FIELDS  # the same names and order as the FMU's outputs


def cam_run(path, parameters, speed=150.0, steps=400, revolutions=1.0):
    fmu = Driven(path, parameters, {"camshaft_angle": 0.0, "camshaft_speed": speed})
    dt = revolutions * 2.0 * math.pi / speed / steps
    rows = {name: [] for name in VALVE_OUTPUTS + ("contact_force", "newton_iterations")}
    try:
        for k in range(1, steps + 1):
            assert fmu.step(dt, camshaft_angle=speed * k * dt) is True
            for name in rows:
                rows[name].append(fmu.get(name))
        warnings = fmu.messages("warning")
        float_speed = fmu.get("float_camshaft_speed")
    finally:
        fmu.close()
    return {name: np.asarray(values) for name, values in rows.items()}, warnings, float_speed


@pytest.mark.parametrize(
    "mode, law, lift",
    [
        ("forward", "polynomial_345", 0.007),
        ("inverse", "cycloidal", 0.01),
        ("forward", "harmonic", 0.008),
    ],
)
def test_valve_train_solver_matches_the_closed_form_and_the_reference(fmu_dir, mode, law, lift):
    parameters = {"mode": mode, "cam_law": law, "lift": lift}
    solved, _, _ = cam_run(fmu_dir / "ValveTrain.fmu", parameters)
    closed, _, _ = cam_run(fmu_dir / "ValveTrain.fmu", {**parameters, "solver": "closed_form"})
    angle = 150.0 * np.arange(1, 401) * (2 * math.pi / 150.0 / 400)
    s, s1, s2 = vt_reference.cam_lift(law, lift, 0.0, 1.2, 0.1, 1.2, angle)
    geometry = vt.DEFAULT_VALVE_GEOMETRY._asdict()
    solve = vt_reference.inverse if mode == "inverse" else vt_reference.forward
    expected = solve(geometry, s, s1 * 150.0, s2 * 150.0**2)
    for name in VALVE_OUTPUTS:
        scale = np.max(np.abs(expected[name]))
        for values in (solved[name], closed[name]):
            assert np.max(np.abs(values - expected[name])) <= 1e-12 * scale + 1e-15, name
    assert np.max(solved["newton_iterations"]) <= 3 and np.max(closed["newton_iterations"]) == 0


def test_valve_float_is_reported_with_the_camshaft_speed(fmu_dir):
    parameters = {"valve_spring": True, "solver": "closed_form"}
    predicted = vt.float_speed(
        vt.DEFAULT_VALVE_GEOMETRY, cam_laws.DEFAULT_CAM_PROFILE, 0.1, 50e3, 300.0
    ).camshaft_speed
    below, warnings, reported = cam_run(
        fmu_dir / "ValveTrain.fmu", parameters, speed=0.99 * predicted, steps=2000
    )
    assert reported == predicted
    assert warnings == [] and below["contact_force"].min() > 0
    above, warnings, _ = cam_run(
        fmu_dir / "ValveTrain.fmu", parameters, speed=1.01 * predicted, steps=2000
    )
    assert above["contact_force"].min() < 0
    assert any("valve float" in w and f"{predicted:.6g} rad/s" in w for w in warnings), warnings
    # The required force is m a + k lift + F0 at every sample.
    np.testing.assert_allclose(
        above["contact_force"],
        0.1 * above["valve_acceleration"] + 50e3 * above["valve_lift"] + 300.0,
        rtol=1e-12,
        atol=1e-9,
    )
    fmu = Driven(
        fmu_dir / "ValveTrain.fmu",
        {**parameters, "stop_on_float": True},
        {"camshaft_angle": 0.0, "camshaft_speed": 1.01 * predicted},
    )
    try:
        dt, result, k = 2 * math.pi / predicted / 2000, True, 0
        while result is True and k < 2000:
            k += 1
            result = fmu.step(dt, camshaft_angle=1.01 * predicted * k * dt)
        assert result is not True and "valve float" in result
        # The refused step changed nothing: the outputs are those of the last step taken.
        assert fmu.get("contact_lost") in (False, 0) and fmu.get("contact_force") > 0
    finally:
        fmu.close()


def test_inverse_then_forward_returns_the_original_valve_motion(fmu_dir):
    """The inverse FMU's tappet motion (the cam diagram for a desired cycloidal valve motion)
    drives the forward constraint solver, which must give the valve motion back."""
    parameters = {"mode": "inverse", "cam_law": "cycloidal", "lift": 0.01}
    rows, _, _ = cam_run(fmu_dir / "ValveTrain.fmu", parameters)
    g = vt.DEFAULT_VALVE_GEOMETRY
    profile = cam_laws.check_profile("cycloidal", 0.01, 0.0, 1.2, 0.1, 1.2)
    follower = planar.BranchFollower(constraint_models.valve_train(g))
    closed = vt.rest_position(g)[1]
    dt = 2 * math.pi / 150.0 / 400
    for k in range(400):
        drive = [
            (
                g.cam_base_radius + rows["tappet_lift"][k],
                rows["tappet_velocity"][k],
                rows["tappet_acceleration"][k],
            )
        ]
        if k == 0:
            solution = follower.assemble(constraint_models.valve_train_guess(g), drive)
        else:
            solution = follower.follow(drive, dt)
        wanted = cam_laws.follower_motion(profile, 150.0 * (k + 1) * dt, 150.0, 0.0)
        valve = 3 * constraint_models.VALVE + 1
        assert closed - solution.q[valve] == pytest.approx(wanted.lift, abs=1e-15)
        assert -solution.qdot[valve] == pytest.approx(wanted.velocity, abs=1e-12)
        assert -solution.qddot[valve] == pytest.approx(wanted.acceleration, rel=1e-10, abs=1e-8)


@pytest.mark.parametrize("effect", ["valve_spring", "cam_geometry"])
def test_valve_train_effect_outputs_hold_their_start_values_only_while_the_effect_is_off(effect):
    """The per-step output check leaves out what EFFECT_OUTPUTS lists for an effect that is
    off: over a revolution those outputs keep their start values; on, they move."""
    from mechfmu.runtime.models.valve_train import ValveTrain

    starts = {v.name: v.start for v in ValveTrain.VARIABLES}
    watched = ValveTrain.EFFECT_OUTPUTS[effect]
    seen = {}
    for on in (False, True):
        model = ValveTrain(instance_name="vt")
        model.values[effect] = on
        if effect == "cam_geometry":  # a base circle without a cusp for the default cam
            model.values["cam_base_radius"] = 0.03
        model.setup_experiment(0.0)
        model.enter_initialization_mode()
        model.exit_initialization_mode()
        assert model.pending_error is None
        seen[on] = set()
        for index in range(1, 73):
            model.values.update(camshaft_angle=index * math.tau / 72, camshaft_speed=300.0)
            assert model.do_step((index - 1) * 1e-3, 1e-3)
            seen[on] |= {name for name in watched if model.values[name] != starts[name]}
    assert seen[False] == set()
    assert seen[True]
