"""The forces effect's physics (runtime, stdlib) against references that take other routes.

Four-bar and slider-crank: the runtime's Newton-Euler on the constraint Jacobian against
Norton's matrix written link by link (numpy), the power balance from the kinematics alone,
each link's force sum and moment, virtual work at rest, the shaking force against the frame's
pin reactions and against the classic primary/secondary approximation, the counterweight, a
published example (Marghitu 2009), bad parameters and unbounded forces. Landing gear: the
pivot and anchor loads against references/gear_forces.py, statics and the power balance.
"""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mechfmu.runtime.errors import RangeError, SingularConfiguration
from mechfmu.references import engine, gear_forces as gear_reference
from mechfmu.references import landing_gear as gear_kinematics
from mechfmu.references import link_forces as ref
from mechfmu.references import linkages
from mechfmu.references import valve_forces as valve_reference
from mechfmu.runtime.physics import cam_geometry, cam_laws
from mechfmu.runtime.physics import four_bar as fb
from mechfmu.runtime.physics import valve_forces
from mechfmu.runtime.physics import valve_train as vt
from mechfmu.runtime.physics import gear_dynamics as gd
from mechfmu.runtime.physics import gear_forces
from mechfmu.runtime.physics import landing_gear as gear
from mechfmu.runtime.physics import link_forces
from mechfmu.runtime.physics import linkage_forces as lf
from mechfmu.runtime.physics import slider_crank as sc
from mechfmu.runtime.physics.link_forces import MassLayout

lengths_st = st.floats(0.02, 0.5)
layout_st = st.builds(
    MassLayout,
    st.floats(0.0, 5.0),
    st.floats(-0.3, 0.3),
    st.floats(-0.2, 0.2),
    st.floats(0.0, 0.05),
)
gravity_st = st.tuples(st.floats(-12.0, 12.0), st.floats(-12.0, 12.0))
rates_st = st.tuples(st.floats(-60.0, 60.0), st.floats(-500.0, 500.0))
load_st = st.floats(-50.0, 50.0)


def assert_close(actual, expected, scale, rtol=1e-9, what=""):
    assert abs(actual - expected) <= rtol * scale, f"{what}: {actual!r} vs {expected!r}"


def column(columns, key, k):
    return float(np.asarray(columns[key])[k]) if np.ndim(columns[key]) else float(columns[key])


def four_bar_case(lengths, circuit, angle, speed, acceleration):
    """(checked lengths, runtime motion dict, reference links) or None where the position
    does not assemble or lies near a toggle (where forces grow without bound)."""
    try:
        checked = fb.check_four_bar(*lengths)
        motion = fb.checked_motion(checked, circuit, angle, speed, acceleration)._asdict()
    except (RangeError, SingularConfiguration):
        return None
    if abs(math.sin(motion["rocker_angle"] - motion["coupler_angle"])) < 0.1:
        return None
    drive = (np.array([angle]), np.array([speed]), np.array([acceleration]))
    reference = linkages.four_bar(*lengths, circuit, *drive)
    links = ref.four_bar_links(lengths, drive, reference)
    return checked, motion, links


@settings(max_examples=80, deadline=None)
@given(
    lengths=st.tuples(lengths_st, lengths_st, lengths_st, lengths_st),
    circuit=st.sampled_from((0, 1)),
    angle=st.floats(-math.pi, math.pi),
    rates=rates_st,
    layouts=st.tuples(layout_st, layout_st, layout_st),
    gravity=gravity_st,
    point=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)),
    loads=st.tuples(load_st, load_st, load_st),
)
def test_four_bar_forces_match_norton_power_balance_and_each_link(
    lengths, circuit, angle, rates, layouts, gravity, point, loads
):
    case = four_bar_case(lengths, circuit, angle, *rates)
    assume(case is not None)
    checked, motion, links = case
    forces = lf.FourBarForces(checked, layouts, gravity, point)
    out = forces.analyse((angle, *rates), motion, lf.FourBarLoads(*loads))
    torque, force_x, force_y = loads

    norton = ref.norton_four_bar(
        lengths, links, layouts, gravity, point, (force_x, force_y), torque
    )
    scale = max(abs(column(norton, key, 0)) for key in norton) + 1.0
    for key in norton:
        assert_close(out[key], column(norton, key, 0), scale, what=key)

    # power balance from the kinematics alone: T12 omega2 = dKE/dt + dPE/dt - P_loads
    energy = ref.energies(links, layouts, gravity)
    loads_power = ref.load_power(links, point, (force_x, force_y), torque)
    balance = ref.power_balance_torque(links, layouts, gravity, loads_power)
    terms = (
        column(energy, "kinetic_energy_rate", 0),
        column(energy, "potential_energy_rate", 0),
        float(np.asarray(loads_power).ravel()[0]),
    )
    assert_close(
        out["input_power"],
        column(balance, "input_power", 0),
        max(map(abs, terms)) + abs(out["input_power"]) + 1e-9,
        what="power balance",
    )
    for key in ("kinetic_energy", "potential_energy", "shaking_force_x", "shaking_moment"):
        assert_close(out[key], column(energy, key, 0), abs(column(energy, key, 0)) + scale)

    # each link: sum of forces = m a_G, moments about G = I_G alpha
    def force(name):
        return np.array([out[f"{name}_force_x"], out[f"{name}_force_y"]])

    f12, f32, f43, f14 = (
        force(n) for n in ("crank_pivot", "crank_pin", "rocker_pin", "rocker_pivot")
    )
    on_link = [
        [(f12, (0.0, 0.0)), (f32, (lengths[1], 0.0))],
        [(-f32, (0.0, 0.0)), (f43, (lengths[2], 0.0)), (np.array([force_x, force_y]), point)],
        [(-f43, (lengths[3], 0.0)), (f14, (0.0, 0.0))],
    ]
    moments = [out["crank_torque"], 0.0, torque]
    for link, layout, acting, moment in zip(links, layouts, on_link, moments):
        m, cx, cy, inertia = layout
        gx, gy = (float(v[0]) for v in link.point(cx, cy))
        ax, ay = (float(v[0]) for v in link.point_acceleration(cx, cy))
        total = sum(f for f, _ in acting) + m * np.asarray(gravity)
        assert_close(total[0], m * ax, scale, what="sum Fx")
        assert_close(total[1], m * ay, scale, what="sum Fy")
        about_g = moment
        for f, local in acting:
            px, py = (float(v[0]) for v in link.point(*local))
            about_g += (px - gx) * f[1] - (py - gy) * f[0]
        assert_close(about_g, inertia * float(link.alpha[0]), scale * 1.0, what="sum M_G")


@settings(max_examples=60, deadline=None)
@given(
    geometry=st.tuples(st.floats(0.02, 0.2), st.floats(0.05, 0.6), st.floats(-0.1, 0.1)),
    circuit=st.sampled_from((0, 1)),
    angle=st.floats(-math.pi, math.pi),
    rates=st.tuples(st.floats(-400.0, 400.0), st.floats(-3e4, 3e4)),
    layouts=st.tuples(layout_st, layout_st, layout_st),
    counterweight=st.tuples(st.floats(0.0, 3.0), st.floats(0.0, 0.1)),
    gravity=gravity_st,
    loads=st.tuples(st.floats(-2e4, 2e4), load_st, load_st),
)
def test_slider_crank_forces_match_the_matrix_and_the_power_balance(
    geometry, circuit, angle, rates, layouts, counterweight, gravity, loads
):
    try:
        checked = sc.check_slider_crank(*geometry)
        motion = sc.checked_motion(checked, circuit, angle, *rates)._asdict()
    except (RangeError, SingularConfiguration):
        assume(False)
    assume(abs(math.cos(motion["coupler_angle"])) > 0.1)
    slider = MassLayout(layouts[2].mass, 0.0, 0.0, 0.0)
    crank = link_forces.with_point_mass(layouts[0], counterweight[0], -counterweight[1], 0.0)
    point = (0.5 * geometry[1], 0.01)
    forces = lf.SliderCrankForces(checked, circuit, [crank, layouts[1], slider], gravity, point)
    out = forces.analyse((angle, *rates), motion, lf.SliderCrankLoads(*loads))

    drive = (np.array([angle]), np.array([rates[0]]), np.array([rates[1]]))
    links = ref.slider_crank_links(
        geometry, drive, linkages.slider_crank(*geometry, circuit, *drive)
    )
    along = (-1.0 if circuit == 0 else 1.0) * loads[0]
    reference_layouts = [layouts[0], layouts[1], slider]
    norton = ref.norton_slider_crank(
        links,
        reference_layouts,
        gravity,
        point,
        geometry[0],
        geometry[1],
        loads[1:],
        along,
        counterweight,
    )
    scale = max(abs(column(norton, key, 0)) for key in norton) + 1.0
    for key in norton:
        assert_close(out[key], column(norton, key, 0), scale, what=key)
    weighted = (
        [*links, links[0]],
        [*reference_layouts, (counterweight[0], -counterweight[1], 0.0, 0.0)],
    )
    power = ref.load_power(links, point, loads[1:], 0.0, along)
    balance = ref.power_balance_torque(*weighted, gravity, power)
    energy = ref.energies(*weighted, gravity)
    terms = [abs(column(energy, k, 0)) for k in ("kinetic_energy_rate", "potential_energy_rate")]
    assert_close(
        out["input_power"],
        column(balance, "input_power", 0),
        max(terms) + abs(float(np.ravel(power)[0])) + abs(out["input_power"]) + 1e-9,
        what="power balance",
    )
    for key in ("shaking_force_x", "shaking_force_y", "shaking_moment", "kinetic_energy"):
        assert_close(out[key], column(energy, key, 0), abs(column(energy, key, 0)) + scale)


@settings(max_examples=60, deadline=None)
@given(
    lengths=st.tuples(lengths_st, lengths_st, lengths_st, lengths_st),
    circuit=st.sampled_from((0, 1)),
    angle=st.floats(-math.pi, math.pi),
    layouts=st.tuples(layout_st, layout_st, layout_st),
    gravity=gravity_st,
    loads=st.tuples(load_st, load_st, load_st),
)
def test_four_bar_at_rest_needs_the_virtual_work_torque(
    lengths, circuit, angle, layouts, gravity, loads
):
    case = four_bar_case(lengths, circuit, angle, 0.0, 0.0)
    assume(case is not None)
    checked, motion, _ = case
    point = (0.3 * lengths[2], 0.05)
    out = lf.FourBarForces(checked, layouts, gravity, point).analyse(
        (angle, 0.0, 0.0), motion, lf.FourBarLoads(*loads)
    )
    positions = ref.four_bar_positions(lengths, circuit)
    expected = ref.virtual_work_torque(
        positions, angle, layouts, gravity, point, loads[1:], loads[0]
    )
    # the loads' own size sets the scale (a four-point central difference: ~1e-10 relative)
    scale = sum(m for m, *_ in layouts) * math.hypot(*gravity) * sum(lengths) + sum(
        map(abs, loads)
    ) * (1.0 + sum(lengths))
    assert_close(out["crank_torque"], float(expected), scale + 1e-12, rtol=1e-7)


@settings(max_examples=40, deadline=None)
@given(
    geometry=st.tuples(st.floats(0.02, 0.2), st.floats(0.05, 0.6), st.floats(-0.1, 0.1)),
    angle=st.floats(-math.pi, math.pi),
    layouts=st.tuples(layout_st, layout_st, layout_st),
    gravity=gravity_st,
    force=st.floats(-2e3, 2e3),
)
def test_slider_crank_at_rest_needs_the_virtual_work_torque(
    geometry, angle, layouts, gravity, force
):
    try:
        checked = sc.check_slider_crank(*geometry)
        motion = sc.checked_motion(checked, 0, angle, 0.0, 0.0)._asdict()
    except (RangeError, SingularConfiguration):
        assume(False)
    assume(abs(math.cos(motion["coupler_angle"])) > 0.1)
    slider = MassLayout(layouts[2].mass, 0.0, 0.0, 0.0)
    point = (0.5 * geometry[1], 0.0)
    out = lf.SliderCrankForces(
        checked, 0, [layouts[0], layouts[1], slider], gravity, point
    ).analyse((angle, 0.0, 0.0), motion, lf.SliderCrankLoads(force, 0.0, 0.0))
    expected = ref.virtual_work_torque(
        ref.slider_crank_positions(geometry, 0),
        angle,
        [layouts[0], layouts[1], slider],
        gravity,
        point,
        slider_force_x=-force,
    )
    scale = (
        sum(m for m, *_ in layouts) * math.hypot(*gravity) * sum(map(abs, geometry))
        + abs(force) * geometry[0]
    )
    assert_close(out["crank_torque"], float(expected), scale + 1e-12, rtol=1e-7)
    # the piston drives: its force's torque on the crank is the mechanical advantage times it
    if not any(m for m, *_ in layouts) or gravity == (0.0, 0.0):
        assert_close(-out["crank_torque"], out["mechanical_advantage"] * force, scale + 1e-12)


@settings(max_examples=40, deadline=None)
@given(
    lengths=st.tuples(lengths_st, lengths_st, lengths_st, lengths_st),
    angle=st.floats(-math.pi, math.pi),
    rates=rates_st,
    layouts=st.tuples(layout_st, layout_st, layout_st),
)
def test_shaking_is_what_the_pins_and_the_motor_put_on_the_frame(lengths, angle, rates, layouts):
    # Norton eqs 11.15-11.16: with neither gravity nor loads, F_s = F21 + F41 and
    # M_s = T21 + r_O4 x F41 (about O2)
    case = four_bar_case(lengths, 0, angle, *rates)
    assume(case is not None)
    checked, motion, _ = case
    out = lf.FourBarForces(checked, layouts).analyse((angle, *rates), motion)
    f21 = -np.array([out["crank_pivot_force_x"], out["crank_pivot_force_y"]])
    f41 = -np.array([out["rocker_pivot_force_x"], out["rocker_pivot_force_y"]])
    scale = (
        np.abs(np.concatenate([f21, f41])).max() * (1.0 + lengths[0])
        + abs(out["crank_torque"])
        + 1e-9
    )
    assert_close(out["shaking_force_x"], f21[0] + f41[0], scale)
    assert_close(out["shaking_force_y"], f21[1] + f41[1], scale)
    assert_close(out["shaking_moment"], -out["crank_torque"] + lengths[0] * f41[1], scale)


def test_marghitu_slider_crank_example_reproduced():
    # Marghitu, "Mechanisms and Robots Analysis with MATLAB", Springer 2009, sect. 4.5
    # (R-RRT mechanism, eqs 4.51-4.52): AB = BC = 1 m, phi = pi/4, n = 30/pi rpm
    # (omega = 1 rad/s), links of 1 kg (bars h = 0.01 m high, slider 0.01 x 0.01 m),
    # g = 10 m/s^2, 100 N on the slider against its motion. Printed: the force of the crank
    # on the connecting rod F12 = (-(400 + 7 sqrt 2)/4, 5 (84 + sqrt 2)/4) N.
    h = 0.01
    layouts = [
        MassLayout(1.0, 0.5, 0.0, (1.0 + h * h) / 12.0),
        MassLayout(1.0, 0.5, 0.0, (1.0 + h * h) / 12.0),
        MassLayout(1.0, 0.0, 0.0, 2.0 * h * h / 12.0),
    ]
    geometry = sc.check_slider_crank(1.0, 1.0, 0.0)
    motion = sc.checked_motion(geometry, 0, math.pi / 4, 1.0, 0.0)._asdict()
    assert motion["slider_speed"] == pytest.approx(-math.sqrt(2.0))  # the 100 N points to +x
    forces = lf.SliderCrankForces(geometry, 0, layouts, (0.0, -10.0))
    out = forces.analyse((math.pi / 4, 1.0, 0.0), motion, lf.SliderCrankLoads(-100.0, 0.0, 0.0))
    root2 = math.sqrt(2.0)
    # crank_pin_force is F32, the rod on the crank: minus Marghitu's F12
    assert out["crank_pin_force_x"] == pytest.approx((400.0 + 7.0 * root2) / 4.0, rel=1e-13)
    assert out["crank_pin_force_y"] == pytest.approx(-5.0 * (84.0 + root2) / 4.0, rel=1e-13)


@pytest.mark.parametrize(
    "mass, inertia, name",
    [(-1.0, 1e-3, "crank_mass"), (1.0, -0.5, "crank_inertia"), (math.nan, 1e-3, "crank_mass")],
)
def test_negative_or_nan_mass_and_inertia_are_one_clear_error(mass, inertia, name):
    with pytest.raises(RangeError) as caught:
        link_forces.mass_layout("crank", mass, 0.01, 0.0, inertia)
    assert caught.value.name == name
    assert "valid range [0, inf)" in str(caught.value)


def test_forces_near_a_toggle_are_reported_as_unbounded_with_the_configuration():
    # a triple rocker 1e-12 rad from its toggle: the kinematics still answer, but the
    # joints' condition number is above the threshold (1e8, the solver's)
    lengths = fb.check_four_bar(0.1, 0.08, 0.06, 0.05)
    low, _ = fb.crank_angle_range(*lengths)
    angle = math.acos(low) - 1e-12
    motion = fb.checked_motion(lengths, 0, angle, 0.0, 0.0)._asdict()
    forces = lf.FourBarForces(lengths, lf.DEFAULT_FOUR_BAR_MASSES)
    with pytest.raises(SingularConfiguration) as caught:
        forces.analyse((angle, 0.0, 0.0), motion, lf.FourBarLoads(1.0, 0.0, 0.0))
    message = str(caught.value)
    assert "joint forces unbounded" in message and "toggle position" in message
    assert "crank angle 1.2987" in message and "condition number" in message
    # 1e-8 rad away the forces are large but finite, and answered
    angle = math.acos(low) - 1e-8
    motion = fb.checked_motion(lengths, 0, angle, 0.0, 0.0)._asdict()
    torque = forces.analyse((angle, 0.0, 0.0), motion, lf.FourBarLoads(1.0, 0.0, 0.0))
    assert 1e3 < abs(torque["crank_torque"]) < 1e5


def test_engine_shaking_force_against_primary_and_secondary():
    geometry = sc.check_slider_crank(0.05, 0.15, 0.0)
    layouts = lf.DEFAULT_SLIDER_CRANK_MASSES
    omega = 100.0 * math.pi
    angles = np.linspace(0.0, 2.0 * math.pi, 73)
    exact_x, exact_y = [], []
    forces = lf.SliderCrankForces(geometry, 0, layouts)
    for angle in angles:
        motion = sc.checked_motion(geometry, 0, angle, omega, 0.0)._asdict()
        out = forces.analyse((angle, omega, 0.0), motion)
        exact_x.append(out["shaking_force_x"])
        exact_y.append(out["shaking_force_y"])
    approx = ref.lumped_shaking_force(0.05, 0.15, layouts, (0.0, 0.0), angles, omega)
    # The lumped masses are exact for forces (the rod's centre of mass is their weighted
    # mean), so the vertical part agrees to rounding. The horizontal one misses what the
    # series drops from the piston acceleration, -r w^2 (lambda^3/4)(cos 2wt - cos 4wt) and
    # smaller: at most lambda^3/2 of m_B r w^2 (lambda = r/l = 1/3), at wt = 90 deg.
    m_b = layouts[2].mass + layouts[1].mass * layouts[1].com_x / 0.15
    amplitude = m_b * 0.05 * omega**2
    assert np.max(np.abs(np.array(exact_y) - approx["shaking_force_y"])) < 1e-9 * amplitude
    missing = np.abs(np.array(exact_x) - approx["shaking_force_x"])
    cubic = amplitude * (1 / 3) ** 3 / 2
    assert 0.9 * cubic < missing.max() < 1.2 * cubic
    assert angles[np.argmax(missing)] == pytest.approx(math.pi / 2, abs=0.1) or angles[
        np.argmax(missing)
    ] == pytest.approx(3 * math.pi / 2, abs=0.1)


def test_counterweight_balances_the_rotating_mass_and_half_the_reciprocating():
    geometry = sc.check_slider_crank(0.05, 0.15, 0.0)
    layouts = lf.DEFAULT_SLIDER_CRANK_MASSES
    crank, rod, slider = layouts
    radius, r, length = 0.05, 0.05, 0.15
    m_a = (crank.mass * crank.com_x + rod.mass * (length - rod.com_x) * r / length) / r
    m_b = slider.mass + rod.mass * rod.com_x / length
    omega, angles = 100.0 * math.pi, np.linspace(0.0, 2.0 * math.pi, 37)

    def peaks(counterweight_mass):
        heavy = link_forces.with_point_mass(crank, counterweight_mass, -radius, 0.0)
        forces = lf.SliderCrankForces(geometry, 0, [heavy, rod, slider])
        xs, ys = [], []
        for angle in angles:
            motion = sc.checked_motion(geometry, 0, angle, omega, 0.0)._asdict()
            out = forces.analyse((angle, omega, 0.0), motion)
            xs.append(out["shaking_force_x"])
            ys.append(out["shaking_force_y"])
        return np.max(np.abs(xs)), np.max(np.abs(ys))

    bare_x, bare_y = peaks(0.0)
    rotating_x, rotating_y = peaks(m_a * r / radius)
    half_x, half_y = peaks((m_a + 0.5 * m_b) * r / radius)
    unit = omega**2 * r
    assert rotating_y < 1e-9 * bare_y  # the rotating mass balanced: no vertical shaking
    assert rotating_x < bare_x and rotating_x == pytest.approx(
        m_b * unit * (1 + r / length), rel=0.05
    )
    assert half_y == pytest.approx(0.5 * m_b * unit, rel=1e-6)  # half moved to vertical
    assert half_x == pytest.approx(m_b * unit * (0.5 + r / length), rel=0.05)


def test_gas_force_table_is_generated_and_shipped(tmp_path):
    from conftest import SCENES
    from mechfmu.io import read_profile_table
    from mechfmu.tools.scene_references import TABLES, generate_tables

    (written,) = generate_tables(tmp_path)
    fresh = read_profile_table(written)
    shipped = read_profile_table(SCENES / "tables" / next(iter(TABLES)))
    np.testing.assert_allclose(fresh.to_numpy(), shipped.to_numpy(), rtol=1e-12, atol=1e-9)
    assert len(shipped) == 1441 and shipped.index[-1] == pytest.approx(0.04)
    # intake and exhaust at ambient pressure; the peak after the firing top dead centre
    angles = np.radians(np.arange(1441) * 0.5)
    peak = angles[np.argmax(shipped.to_numpy()[:, 0])]
    assert np.degrees(peak) == pytest.approx(381.0, abs=5.0)
    assert engine.gas_force(np.radians([90.0, 650.0])).tolist() == [0.0, 0.0]


GEAR_EFFECTS = {"inertia": True, "gravity": True, "aero_drag": True, "pivot_friction": True}


def gear_values(**changes):
    from mechfmu.tools.scene_references import start_values

    values = {**start_values("LandingGear"), **GEAR_EFFECTS, "forces": True, "airspeed": 40.0}
    values.update(changes)
    return values


def gear_setup(values):
    body = gd.make_body(values["bar_length"], values["bar_mass"], values["wheel_mass"])
    d, h = gear.check_geometry(values["attachment_distance"], values["pivot_height"])
    geometry = gd.Geometry(d, h, values["down_angle"], values["airframe_pitch"])
    return body, geometry


@settings(max_examples=60, deadline=None)
@given(
    extension=st.floats(0.4, 0.6),
    speed=st.floats(-0.2, 0.2),
    acceleration=st.floats(-0.5, 0.5),
    pitch=st.floats(-0.3, 0.3),
    airspeed=st.floats(-60.0, 60.0),
    effects=st.fixed_dictionaries({name: st.booleans() for name in GEAR_EFFECTS}),
)
def test_gear_loads_match_the_vector_reference(
    extension, speed, acceleration, pitch, airspeed, effects
):
    values = gear_values(airframe_pitch=pitch, airspeed=airspeed, **effects)
    body, geometry = gear_setup(values)
    d, h = geometry.attachment_distance, geometry.pivot_height
    motion, arm = gear.gear_motion_and_moment_arm(extension, speed, acceleration, d, h)
    published = dict(values, piston_moment_arm=arm)
    gd.InverseDynamics(values, body, geometry).publish(published, motion)
    out = gear_forces.GearForces(values, body, geometry).reactions(
        *motion, published["piston_force_required"], airspeed
    )
    expected = gear_reference.loads(
        values, np.array([extension]), np.array([speed]), np.array([acceleration])
    )
    assert_close(
        published["piston_force_required"],
        float(expected["piston_force_required"][0]),
        abs(float(expected["piston_force_required"][0])) + 1.0,
    )
    for key, value in out.items():
        assert_close(value, float(expected[key][0]), abs(float(expected[key][0])) + 1.0, what=key)


def test_gear_held_at_rest_balances_weight_piston_and_pivot():
    values = gear_values(inertia=False, aero_drag=False, pivot_friction=False)
    body, geometry = gear_setup(values)
    d, h = geometry.attachment_distance, geometry.pivot_height
    for extension in (0.40, 0.50, 0.58):
        motion, arm = gear.gear_motion_and_moment_arm(extension, 0.0, 0.0, d, h)
        published = dict(values, piston_moment_arm=arm)
        gd.InverseDynamics(values, body, geometry).publish(published, motion)
        force = published["piston_force_required"]
        out = gear_forces.GearForces(values, body, geometry).reactions(*motion, force, 0.0)
        weight = (body.bar_mass + body.wheel_mass) * values["gravity_acceleration"]
        # airframe on bar + airframe through the actuator = the weight, upwards
        assert out["pivot_force_x"] + out["anchor_force_x"] == pytest.approx(0.0, abs=1e-9 * weight)
        assert out["pivot_force_y"] + out["anchor_force_y"] == pytest.approx(weight, rel=1e-12)
        # the static holding force: gravity moment / moment arm (mechanisms.md sect. 1)
        gravity = gd.gravity_moment(motion.angle, body, geometry, values["gravity_acceleration"])
        assert force == pytest.approx(-gravity / arm, rel=1e-12)


def test_gear_retraction_power_balance_from_the_kinematics():
    # piston power = d/dt (1/2 I_B omega^2) + dPE/dt - drag and friction power
    values = gear_values()
    body, geometry = gear_setup(values)
    t = np.linspace(0.05, 2.95, 59)
    x, xdot, xddot = gear_kinematics.stroke(t, 0.381, 0.6096, 3.0, "cycloidal")
    loads = gear_reference.loads(values, x, xdot, xddot)
    theta, omega, alpha = gear_kinematics.gear_from_piston(
        x, xdot, xddot, geometry.attachment_distance, geometry.pivot_height
    )
    inertia = gd.inertia(body)
    lever = gd.gravity_lever(body) * values["gravity_acceleration"]
    psi = theta - geometry.down_angle + geometry.airframe_pitch
    drag = 0.5 * values["air_density"] * values["drag_area"] * 40.0**2 * body.bar_length
    friction = values["viscous_friction"] * omega + values["coulomb_friction"] * np.tanh(
        omega / values["friction_speed"]
    )
    expected = (
        inertia * omega * alpha
        + lever * np.sin(psi) * omega
        + drag * np.cos(psi) * omega
        + friction * omega
    )
    np.testing.assert_allclose(
        loads["piston_power"], expected, rtol=1e-10, atol=1e-9 * np.max(np.abs(expected))
    )


def test_gear_dead_centre_reports_the_unbounded_piston_force():
    values = gear_values()
    body, geometry = gear_setup(values)
    with pytest.raises(
        SingularConfiguration, match=r"piston force unbounded.*dead centre.*gear angle"
    ):
        gear_forces.check_moment_arm(1e-12, geometry, 3.14, 0.7)
    gear_forces.check_moment_arm(1e-6, geometry, 3.0, 0.7)  # small but finite: answered


VALVE = vt.DEFAULT_VALVE_GEOMETRY


@settings(max_examples=60, deadline=None)
@given(
    angle=st.floats(0.0, 2.0 * math.pi),
    speed=st.floats(-150.0, 150.0),
    acceleration=st.floats(-2e3, 2e3),
    pushrod=layout_st.map(
        lambda m: MassLayout(m.mass * 0.1, m.com_x, m.com_y * 0.1, m.inertia * 0.01)
    ),
    rocker=layout_st.map(
        lambda m: MassLayout(m.mass * 0.1, m.com_x * 0.1, m.com_y * 0.1, m.inertia * 1e-3)
    ),
    spring=st.tuples(st.floats(0.0, 0.3), st.floats(0.0, 1e5), st.floats(0.0, 600.0)),
    gravity=gravity_st,
    inverse=st.booleans(),
)
def test_valve_train_cam_power_from_the_kinematics_alone(
    angle, speed, acceleration, pushrod, rocker, spring, gravity, inverse
):
    law = cam_laws.motion_function(cam_laws.DEFAULT_CAM_PROFILE)(angle, speed, acceleration)
    motion = (vt.inverse if inverse else vt.forward)(VALVE, *law)._asdict()
    closed = vt.rest_position(VALVE)[1]
    forces = valve_forces.ValveTrainForces(
        VALVE,
        valve_forces.pushrod_frame(pushrod),
        rocker,
        valve_forces.ValveSpringLoad(*spring),
        gravity,
    )
    out = forces.analyse(motion, closed, 0.0)
    columns = {key: np.array([value]) for key, value in motion.items()}
    layouts = [
        tuple(valve_forces.pushrod_frame(pushrod)),
        tuple(rocker),
        (spring[0], 0.0, 0.0, 0.0),
    ]
    power = valve_reference.cam_power(VALVE._asdict(), columns, layouts, gravity, spring[1:])[0]
    scale = (abs(out["cam_force"]) + spring[2] + 1.0) * (abs(motion["tappet_velocity"]) + 1e-3)
    assert_close(out["input_power"], power, scale, what="cam power")


def test_massless_valve_train_gives_the_valve_springs_contact_force_and_camshaft_torque():
    # pushrod and rocker without mass: the rocker's push on the valve is the valve_spring
    # effect's contact force, and the cam torque its camshaft_torque (virtual work)
    closed = vt.rest_position(VALVE)[1]
    profile = cam_laws.DEFAULT_CAM_PROFILE
    law = cam_laws.motion_function(profile)
    forces = valve_forces.ValveTrainForces(
        VALVE,
        link_forces.NO_MASS,
        link_forces.NO_MASS,
        valve_forces.ValveSpringLoad(0.1, 5e4, 300.0),
    )
    for angle in np.linspace(0.0, 2.0 * math.pi, 25):
        s, s1, _, _ = cam_laws.cam_lift(profile, angle)
        motion = vt.forward(VALVE, *law(angle, 157.0, 0.0))._asdict()
        out = forces.analyse(motion, closed, s1)
        contact = vt.contact_force(
            0.1, 5e4, 300.0, motion["valve_lift"], motion["valve_acceleration"]
        )
        torque = cam_geometry.camshaft_torque(contact, vt.valve_lift_rate(VALVE, closed, s, s1))
        assert out["valve_link_force_y"] == pytest.approx(-contact, rel=1e-12)
        assert out["cam_torque"] == pytest.approx(torque, rel=1e-9, abs=1e-12 * 300.0)
        # the pushrod is a two-force member: its end forces lie along it
        assert out["tappet_guide_force_x"] == pytest.approx(
            -out["pushrod_force_x"], rel=1e-9, abs=1e-9
        )
