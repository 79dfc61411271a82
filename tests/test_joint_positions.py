"""The geometry effect's points (runtime/physics/joint_positions.py) and what the animations
draw from them, on random geometries: every joint where the mechanism's constraints put it
(link lengths, sliders on their lines, the valve on its axis) to 1e-9 of the mechanism's
size; the cam profile touching the tappet's face; the frames' schedule against the times.
"""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mechfmu.runtime.errors import MechanismError
from mechfmu.runtime.physics import cam_laws, joint_positions
from mechfmu.runtime.physics import four_bar as fb
from mechfmu.runtime.physics import landing_gear as gear
from mechfmu.runtime.physics import slider_crank as sc
from mechfmu.runtime.physics import suspension as susp
from mechfmu.runtime.physics import valve_train as vt
from mechfmu.tools.animate import AnimationError
from mechfmu.tools.animate.cam import cam_of, turned_profile
from mechfmu.tools.animate.frames import schedule
from mechfmu.tools.animate.shapes import hatching, spring

PROPERTY = settings(derandomize=True, max_examples=150, deadline=None)
CAMS = settings(derandomize=True, max_examples=40, deadline=None)  # a cam: 360 profile points
TOLERANCE = 1e-9  # of the mechanism's size
lengths = st.floats(0.01, 2.0)
angles = st.floats(-10.0, 10.0)


def distance(p, q):
    return math.hypot(q[0] - p[0], q[1] - p[1])


def cross(o, p, q):
    """z of (p - o) x (q - o): 0 when o, p, q are collinear."""
    return (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])


@PROPERTY
@given(lengths, lengths, lengths, lengths, angles, st.sampled_from(fb.CIRCUITS))
def test_four_bar_points_close_the_loop(ground, crank, coupler, rocker, angle, circuit):
    try:
        position = fb.position(ground, crank, coupler, rocker, angle, circuit)
    except MechanismError:
        assume(False)
    p = joint_positions.four_bar_points(ground, crank, rocker, angle, position.rocker_angle)
    size = max(ground, crank, coupler, rocker)
    assert p.crank_pivot == (0.0, 0.0) and p.rocker_pivot == (ground, 0.0)
    assert abs(distance(p.crank_pivot, p.crank_pin) - crank) <= TOLERANCE * size
    assert abs(distance(p.crank_pin, p.rocker_pin) - coupler) <= TOLERANCE * size
    assert abs(distance(p.rocker_pivot, p.rocker_pin) - rocker) <= TOLERANCE * size
    # the coupler's direction is theta3
    direction = math.atan2(p.rocker_pin[1] - p.crank_pin[1], p.rocker_pin[0] - p.crank_pin[0])
    assert abs(math.remainder(direction - position.coupler_angle, 2 * math.pi)) <= 1e-6


@PROPERTY
@given(lengths, lengths, st.floats(-1.0, 1.0), angles, st.sampled_from(sc.CIRCUITS))
def test_slider_crank_points_keep_the_slider_on_its_line(crank, coupler, offset, angle, circuit):
    try:
        position = sc.position(crank, coupler, offset, angle, circuit)
    except MechanismError:
        assume(False)
    p = joint_positions.slider_crank_points(crank, offset, angle, position.slider_position)
    size = max(crank, coupler, abs(offset))
    assert p.slider_pin[1] == offset
    assert abs(distance(p.crank_pivot, p.crank_pin) - crank) <= TOLERANCE * size
    assert abs(distance(p.crank_pin, p.slider_pin) - coupler) <= TOLERANCE * size


@PROPERTY
@given(
    lengths,
    lengths,
    lengths,
    st.floats(0.01, math.pi - 0.01),
    st.floats(0.01, math.pi - 0.01),
    st.floats(-0.5, 0.5),
    st.floats(-1.0, 1.0),
)
def test_gear_points_follow_the_law_of_cosines(d, h, bar, theta, other, down, pitch):
    assume(abs(d - h) > 1e-3)
    p = joint_positions.gear_points(d, h, bar, theta, down, pitch)
    size = max(d, h, bar)
    assert abs(distance(p.bar_pivot, p.piston_attachment) - d) <= TOLERANCE * size
    assert abs(distance(p.bar_pivot, p.piston_pivot) - h) <= TOLERANCE * size
    assert abs(distance(p.bar_pivot, p.wheel_axle) - bar) <= TOLERANCE * size
    assert abs(cross(p.bar_pivot, p.piston_attachment, p.wheel_axle)) <= TOLERANCE * size**2
    piston = gear.piston_motion(theta, 0.0, 0.0, d, h).extension
    assert abs(distance(p.piston_pivot, p.piston_attachment) - piston) <= TOLERANCE * size
    # the piston's pivot is fixed on the airframe; the bar hangs at psi from the vertical
    moved = joint_positions.gear_points(d, h, bar, other, down, pitch)
    assert distance(moved.piston_pivot, p.piston_pivot) <= TOLERANCE * size
    psi = math.atan2(p.wheel_axle[0], -p.wheel_axle[1])
    assert abs(math.remainder(psi - (theta - down + pitch), 2 * math.pi)) <= 1e-9


@PROPERTY
@given(
    st.floats(0.1, 1.0),
    st.floats(0.05, 0.95),
    st.floats(1e3, 1e7),
    st.floats(-0.5, 1.5),
    st.floats(-0.2, 0.2),
)
def test_suspension_points_give_the_spring_force(free_length, ratio, stiffness, u_ratio, z):
    spring_ = susp.make_spring(free_length, stiffness, ratio * free_length)
    h = susp.rest_height(spring_)
    u = u_ratio * h
    p = joint_positions.suspension_points(spring_.base_offset, h, u, z)
    assert p.apex[0] == 0.0 and p.left_base[1] == p.right_base[1] == -z
    assert p.left_base[0] == -p.right_base[0] == -spring_.base_offset
    s = distance(p.left_base, p.apex)
    assert abs(s - distance(p.right_base, p.apex)) <= TOLERANCE * free_length
    assert abs(s - susp.spring_length(u, spring_)) <= TOLERANCE * free_length
    # the force of the drawn springs is the model's F(u) (force scale k L)
    drawn = 2 * stiffness * (free_length - s) * (p.apex[1] - p.left_base[1]) / s
    assert abs(drawn - susp.spring_force(u, spring_)) <= TOLERANCE * stiffness * free_length


def valve_geometries():
    """The default valve train scaled and perturbed (kept when check_geometry accepts it)."""
    default = vt.DEFAULT_VALVE_GEOMETRY
    return st.builds(
        lambda scale, *factors: vt.ValveGeometry(
            *(scale * value * factor for value, factor in zip(default, factors))
        ),
        st.floats(0.5, 3.0),
        *[st.floats(0.85, 1.15) for _ in default],
    )


@PROPERTY
@given(valve_geometries(), st.floats(0.01, 0.99), st.booleans())
def test_valve_train_points_keep_links_and_axes(geometry, fraction, inverse):
    try:
        g = vt.check_geometry(geometry)
    except MechanismError:
        assume(False)
    low, high = vt.working_range(g)[:2]
    lift = low + fraction * (high - low)
    try:
        motion = vt.forward(g, lift, 0.0, 0.0)
        if inverse:  # the same position reached from the valve side
            motion = vt.inverse(g, motion.valve_lift, 0.0, 0.0)
    except MechanismError:
        assume(False)
    closed = vt.rest_position(g)[1]
    p = joint_positions.valve_train_points(
        g, motion.tappet_lift, motion.rocker_angle, closed - motion.valve_lift
    )
    size = g.pushrod_length
    assert p.tappet_foot[0] == 0.0 and p.valve_foot[0] == g.valve_axis_x
    assert p.rocker_fulcrum == (g.rocker_pivot_x, g.rocker_pivot_y)
    assert abs(p.tappet_foot[1] - g.cam_base_radius - motion.tappet_lift) <= TOLERANCE * size
    assert abs(distance(p.tappet_foot, p.pushrod_end) - g.pushrod_length) <= TOLERANCE * size
    assert abs(distance(p.rocker_fulcrum, p.pushrod_end) - g.tappet_arm) <= TOLERANCE * size
    assert abs(distance(p.rocker_fulcrum, p.valve_end) - g.valve_arm) <= TOLERANCE * size
    assert abs(cross(p.rocker_fulcrum, p.pushrod_end, p.valve_end)) <= TOLERANCE * size**2
    assert abs(distance(p.valve_end, p.valve_foot) - g.valve_link_length) <= TOLERANCE * size
    axis = joint_positions.valve_axis_points(g.valve_axis_x, closed, 1e-4, 0.003, 0.002)
    assert axis.rocker_end[0] == axis.valve_tip[0] == g.valve_axis_x
    assert abs((axis.rocker_end[1] - axis.valve_tip[1]) - (1e-4 + 0.002 - 0.003)) <= 1e-15


def cam_parameters():
    return st.fixed_dictionaries(
        {
            "cam_law": st.sampled_from(cam_laws.CAM_LAWS),
            "lift": st.floats(0.001, 0.012),
            "rise_start": st.floats(-3.0, 3.0),
            "rise_angle": st.floats(0.8, 2.0),
            "high_dwell_angle": st.floats(0.0, 0.5),
            "return_angle": st.floats(0.8, 2.0),
            "cam_base_radius": st.floats(0.012, 0.04),
        }
    )


CAM_LAW = ("cam_law", "lift", "rise_start", "rise_angle", "high_dwell_angle", "return_angle")


def profile_of(parameters):
    return cam_laws.check_profile(*(parameters[k] for k in CAM_LAW))


def convex(parameters):
    """The flat-faced follower's cam has no cusp: r_b + s + s'' > 0 at every angle."""
    profile = profile_of(parameters)
    return all(
        parameters["cam_base_radius"] + lift.s + lift.s2 > 0.0
        for lift in (cam_laws.cam_lift(profile, a) for a in np.linspace(0, 2 * np.pi, 721))
    )


@CAMS
@given(cam_parameters(), st.floats(-20.0, 20.0))
def test_cam_touches_the_tappet_face_at_its_highest_point(parameters, angle):
    assume(
        parameters["rise_angle"] + parameters["high_dwell_angle"] + parameters["return_angle"]
        < 2 * math.pi
    )
    assume(convex(parameters))
    cam = cam_of(parameters)
    drawn = turned_profile(cam, angle)
    lift = cam_laws.cam_lift(profile_of(parameters), angle)
    face = parameters["cam_base_radius"] + lift.s
    top = int(np.argmax(drawn[:, 1]))
    assert abs(drawn[top, 1] - face) <= TOLERANCE * face
    assert abs(drawn[top, 0] - lift.s1) <= TOLERANCE * face  # contact s' right of the axis
    assert np.all(drawn[:, 1] <= face * (1 + TOLERANCE))
    assert np.array_equal(drawn[0], drawn[-1])  # closed


@CAMS
@given(
    cam_parameters(),
    st.floats(0.002, 0.02),
    st.floats(-0.6, 0.6),
    st.booleans(),
    st.floats(-20.0, 20.0),
)
def test_the_drawn_cam_touches_its_follower(parameters, roller, offset, rolling, angle):
    """Flat face or roller, with an offset: the turned profile holds the point where the
    cam touches the follower (cam_geometry's), on the face or at the roller's radius from its
    centre, the follower resting on the cam at the tappet foot (cam_centre)."""
    assume(sum(parameters[k] for k in CAM_LAW[3:]) < 2 * math.pi)
    parameters = dict(parameters, follower="roller" if rolling else "flat_faced")
    parameters["roller_radius"] = roller
    parameters["follower_offset"] = offset * parameters["cam_base_radius"]
    cam = cam_of(parameters)
    centre = np.array(joint_positions.cam_centre(cam.follower))
    drawn = centre + turned_profile(cam, angle)
    s, s1, _, _ = cam_laws.cam_lift(profile_of(parameters), angle)
    foot = np.array([0.0, parameters["cam_base_radius"] + s])  # the tappet foot: the trace point
    size = parameters["cam_base_radius"]
    if rolling:
        distances = np.hypot(*(drawn - foot).T)
        assert np.min(np.abs(distances - roller)) <= TOLERANCE * size
    else:
        on_face = np.abs(drawn[:, 1] - foot[1]) <= TOLERANCE * size
        contact = s1 - parameters["follower_offset"]  # on the face, from the tappet's axis
        assert np.any(on_face & (np.abs(drawn[:, 0] - contact) <= TOLERANCE * size))


@PROPERTY
@given(
    st.lists(st.floats(0.0001, 0.5), min_size=1, max_size=300),
    st.floats(-5.0, 5.0),
    st.floats(0.01, 5.0),
    st.sampled_from([5.0, 10.0, 25.0, 30.0, 50.0]),
)
def test_frames_show_the_last_row_at_or_before_their_time(steps, start, speed, fps):
    times = start + np.concatenate([[0.0], np.cumsum(steps)])
    frames = schedule(times, speed, fps)
    span = times[-1] - times[0]
    assert len(frames.rows) == math.floor(span * fps / speed * (1 + 1e-12) + 1e-9) + 1
    assert np.all(np.diff(frames.rows) >= 0) and frames.rows[0] == 0
    np.testing.assert_allclose(np.diff(frames.clock), speed / fps, rtol=1e-9)
    shown = times[frames.rows]
    slack = 1e-9 * max(abs(times[0]), abs(times[-1]), speed / fps)
    assert np.all(shown <= frames.clock + slack)
    following = np.minimum(frames.rows + 1, len(times) - 1)
    later = frames.rows + 1 < len(times)
    assert np.all(times[following][later] > frames.clock[later] + slack)


@pytest.mark.parametrize(
    "speed, fps", [(0.0, 25.0), (-1.0, 25.0), (1.0, 0.0), (math.nan, 25.0), (1.0, math.inf)]
)
def test_a_speed_or_frame_rate_that_is_not_positive_is_refused(speed, fps):
    with pytest.raises(AnimationError, match="must be a finite number > 0"):
        schedule(np.array([0.0, 1.0]), speed, fps)


def test_too_many_frames_are_refused_with_the_count():
    with pytest.raises(AnimationError, match="100001 frames"):
        schedule(np.array([0.0, 4000.0]), 1.0, 25.0)


@PROPERTY
@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.integers(1, 12))
def test_a_spring_joins_its_two_ends(x0, y0, x1, y1, coils):
    drawn = spring(np.array([x0, y0]), np.array([x1, y1]), coils=coils, width=0.05)
    assert tuple(drawn[0]) == (x0, y0) and tuple(drawn[-1]) == (x1, y1)
    assert len(drawn) == 2 * coils + 3


def test_hatching_lies_on_the_ground_side():
    drawn = hatching(np.array([1.0, 2.0]), 0.4)  # ground below
    finite = drawn[np.isfinite(drawn).all(axis=1)]
    assert finite[:, 1].max() == pytest.approx(2.0) and finite[:, 1].min() < 2.0
    assert np.isnan(drawn).any()  # pen lifts between strokes
