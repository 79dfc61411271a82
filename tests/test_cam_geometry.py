"""Cam geometry (runtime/physics/cam_geometry.py) against exact shapes and other routes.

Exact shapes: the eccentric disc is the cam of simple harmonic motion for a flat face (its
profile is a circle of the disc's radius), and of a known lift for an offset roller (pitch
curve and surface circles about the disc's centre, the normal through that centre); dwells
are circular arcs about the camshaft centre. Other routes (mechfmu.references.cam_geometry,
numpy): the flat face's profile as the envelope of its lines, the roller's as the inner
offset of the pitch curve; a round trip, the computed profile turned and searched for the
follower's resting place, which must give back the cam law's lift; radii of curvature from
circles through three profile points; the camshaft torque from the statics of the rocker
and from the moment of the contact force. Then the design checks, sizing and bad input.
Property tests draw cam laws and geometries at random.
"""

import math
import sys

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy import integrate

from mechfmu.references import cam_geometry as ref
from mechfmu.references import valve_train as vt_ref
from mechfmu.runtime.errors import CamDesignError, MechanismError, RangeError
from mechfmu.runtime.physics import cam_geometry as cg
from mechfmu.runtime.physics import cam_laws as cl
from mechfmu.runtime.physics import valve_train as vt

PROPERTY = settings(derandomize=True, max_examples=25, deadline=None)
TAU = 2.0 * math.pi
G = vt.DEFAULT_VALVE_GEOMETRY
DEFAULT = cl.DEFAULT_CAM_PROFILE  # 3-4-5, 7 mm, rise and return over 1.2 rad, 0.1 rad dwell


def numpy_lift(profile):
    """s(theta) of the cam law by the numpy reference (vectorised)."""
    return lambda angle: vt_ref.cam_lift(*profile, angle)[0]


def runtime_profile(follower, profile):
    """The runtime's profile as a function of the camshaft angle (arrays in, arrays out)."""

    def points(angles):
        found = [cg.profile_point(follower, profile, float(a)) for a in np.atleast_1d(angles)]
        return np.array([p.x for p in found]), np.array([p.y for p in found])

    return points


def joins(profile):
    """Camshaft angles (rad, in [0, 2 pi)) where the cam law changes segment."""
    rise, dwell, ret = profile.rise_angle, profile.high_dwell_angle, profile.return_angle
    return np.mod(profile.rise_start + np.array([0.0, rise, rise + dwell, rise + dwell + ret]), TAU)


def away_from_joins(profile, angles, margin=1e-3):
    """The angles farther than ``margin`` (rad) from every join (numerical routes need the
    lift smooth around them)."""
    distance = np.abs((angles[:, None] - joins(profile)[None, :] + np.pi) % TAU - np.pi)
    return angles[np.min(distance, axis=1) > margin]


# --- exact shapes ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "radius, eccentricity, rise_start, offset",
    [(0.02, 0.004, 0.0, 0.0), (0.03, 0.0125, 1.3, 0.01), (0.015, 0.001, -2.0, -0.005)],
)
def test_eccentric_disc_is_the_cam_of_harmonic_motion_for_a_flat_face(
    radius, eccentricity, rise_start, offset
):
    # s = e (1 - cos(theta - theta0)): the harmonic law rising 2 e over pi, returning over pi
    profile = cl.check_profile("harmonic", 2.0 * eccentricity, rise_start, math.pi, 0.0, math.pi)
    follower = cg.check_follower("flat_faced", radius - eccentricity, offset=offset)
    centre = (-eccentricity * math.sin(rise_start), -eccentricity * math.cos(rise_start))
    for angle in np.linspace(-3.0, 10.0, 301):
        point = cg.profile_point(follower, profile, float(angle))
        assert math.hypot(point.x - centre[0], point.y - centre[1]) == pytest.approx(
            radius, rel=1e-14
        )
        assert point.radius_of_curvature == pytest.approx(radius, rel=1e-14)
        assert point.pressure_angle == 0.0
        contact = eccentricity * math.sin(angle - rise_start) - offset
        assert point.face_contact == pytest.approx(contact, abs=1e-15)
    found = cg.design(follower, cg.law_pieces(profile))
    assert found.least_radius == pytest.approx(radius, rel=1e-13)
    assert found.face_width == pytest.approx(2.0 * eccentricity, rel=1e-13)
    assert found.problems == ()
    # rho = Rb + s + s'' = Rb + e everywhere: a radius of 10 mm needs Rb = 10 mm - e
    sizing = cg.smallest_base_circle(
        "flat_faced", cg.law_pieces(profile), min_radius_of_curvature=0.04
    )
    assert sizing.base_circle_radius == pytest.approx(0.04 - eccentricity, rel=1e-13)


def eccentric_roller_lift(radius, eccentricity, roller, offset, trace_height):
    """Lift (s, s1, s2) of a roller on an axis at x = offset resting on a disc of ``radius``
    whose centre is at distance ``eccentricity`` below the camshaft centre at theta = 0: the
    roller centre's height y = -e cos(t) + sqrt(A^2 - q^2), A = radius + roller,
    q = offset - e sin(t), differentiated by hand."""

    def lift(theta):
        q, q1, q2 = (
            offset - eccentricity * math.sin(theta),
            -eccentricity * math.cos(theta),
            eccentricity * math.sin(theta),
        )
        reach = radius + roller
        w = math.sqrt(reach * reach - q * q)
        w1 = -q * q1 / w
        w2 = -(q1 * q1 + q * q2) / w - (q * q1) ** 2 / w**3
        return (
            -eccentricity * math.cos(theta) + w - trace_height,
            eccentricity * math.sin(theta) + w1,
            eccentricity * math.cos(theta) + w2,
        )

    return lift


@pytest.mark.parametrize(
    "radius, eccentricity, roller, offset",
    [(0.02, 0.004, 0.008, 0.0), (0.025, 0.006, 0.01, 0.007), (0.02, 0.003, 0.005, -0.012)],
)
def test_eccentric_disc_with_an_offset_roller(radius, eccentricity, roller, offset):
    follower = cg.check_follower("roller", radius - eccentricity, roller, offset)
    lift = eccentric_roller_lift(radius, eccentricity, roller, offset, cg.trace_height(follower))
    for angle in np.linspace(0.0, TAU, 181):
        s, s1, s2 = lift(float(angle))
        assert s >= -1e-15  # the roller never goes below the prime circle
        point = cg.cam_point(follower, float(angle), s, s1, s2)
        # in the cam frame the disc's centre stays at (0, -e)
        assert math.hypot(point.pitch_x, point.pitch_y + eccentricity) == pytest.approx(
            radius + roller, rel=1e-13
        )
        assert math.hypot(point.x, point.y + eccentricity) == pytest.approx(radius, rel=1e-13)
        assert point.pitch_radius_of_curvature == pytest.approx(radius + roller, rel=1e-9)
        assert point.radius_of_curvature == pytest.approx(radius, rel=1e-9)
        # the common normal runs through the disc's centre
        height = cg.trace_height(follower) + s
        toward_centre = (
            eccentricity * math.sin(angle) - offset,
            -eccentricity * math.cos(angle) - height,
        )
        expected = math.atan2(toward_centre[0], -toward_centre[1])
        assert point.pressure_angle == pytest.approx(expected, abs=1e-13)


@pytest.mark.parametrize(
    "kind, roller, offset", [("flat_faced", 0.0, 0.003), ("roller", 0.007, -0.004)]
)
def test_dwells_are_arcs_about_the_camshaft_centre(kind, roller, offset):
    follower = cg.check_follower(kind, 0.03, roller, offset)
    low_start = DEFAULT.rise_angle + DEFAULT.high_dwell_angle + DEFAULT.return_angle
    height = cg.trace_height(follower)
    for phase, lift in ((0.3, DEFAULT.lift), (0.5, 0.0)):
        start = DEFAULT.rise_angle if lift else low_start
        span = DEFAULT.high_dwell_angle if lift else TAU - low_start
        point = cg.profile_point(follower, DEFAULT, start + phase * span)
        pitch = math.hypot(offset, height + lift)
        assert math.hypot(point.pitch_x, point.pitch_y) == pytest.approx(pitch, rel=1e-15)
        assert point.pitch_radius_of_curvature == pytest.approx(pitch, rel=1e-14)
        surface = 0.03 + lift if kind == "flat_faced" else pitch - roller
        assert math.hypot(point.x, point.y) == pytest.approx(surface, rel=1e-14)
        assert point.radius_of_curvature == pytest.approx(surface, rel=1e-14)


# --- other routes: envelope, round trip, curvature ------------------------------------------


@st.composite
def cams(draw):
    """A cam law and a follower whose cam has no cusp or undercut."""
    rise, ret = draw(st.floats(0.5, 2.4)), draw(st.floats(0.5, 2.4))
    dwell = draw(st.floats(0.0, min(1.0, TAU - rise - ret)))
    profile = cl.check_profile(
        draw(st.sampled_from(cl.CAM_LAWS)),
        draw(st.floats(0.002, 0.012)),
        draw(st.floats(-4.0, 4.0)),
        rise,
        dwell,
        ret,
    )
    kind = draw(st.sampled_from(cg.FOLLOWERS))
    pieces = cg.law_pieces(profile)
    least = cg.smallest_base_circle("flat_faced", pieces, min_radius_of_curvature=0.002)
    base = max(least.base_circle_radius, 0.004) * draw(st.floats(1.05, 2.5))
    roller = draw(st.floats(0.002, 0.6)) * base if kind == "roller" else 0.0
    offset = draw(st.floats(-0.4, 0.4)) * base
    follower = cg.check_follower(kind, base, roller, offset)
    if kind == "roller":  # the flat face's bound does not cover a roller's undercut
        problems = cg.design(follower, pieces).problems
        assume(all(problem.kind != cg.UNDERCUT for problem in problems))
    return profile, follower


@PROPERTY
@given(cams(), st.integers(0, 2**31))
def test_profile_is_the_envelope_of_the_follower(cam, seed):
    profile, follower = cam
    angles = away_from_joins(profile, np.random.default_rng(seed).uniform(0.0, TAU, 60))
    points = [cg.profile_point(follower, profile, float(a)) for a in angles]
    x, y = np.array([p.x for p in points]), np.array([p.y for p in points])
    lift = numpy_lift(profile)
    if follower.kind == "flat_faced":
        ex, ey = ref.flat_face_envelope(lambda a: follower.base_circle_radius + lift(a), angles)
    else:
        ex, ey, pressure = ref.roller_envelope(
            lift, cg.trace_height(follower), follower.offset, follower.roller_radius, angles
        )
        expected = np.array([p.pressure_angle for p in points])
        np.testing.assert_allclose(pressure, expected, rtol=0.0, atol=1e-9)
    assert np.max(np.hypot(ex - x, ey - y)) <= 1e-9 * profile.lift


@PROPERTY
@given(cams(), st.integers(0, 2**31))
def test_round_trip_the_follower_rests_at_the_cam_laws_lift(cam, seed):
    profile, follower = cam
    angles = np.random.default_rng(seed).uniform(0.0, TAU, 12)
    found = ref.contact_lift(
        runtime_profile(follower, profile),
        follower._asdict(),
        cg.trace_height(follower),
        angles,
    )
    expected = numpy_lift(profile)(angles)
    assert np.max(np.abs(found - expected)) <= 1e-9 * profile.lift


def test_round_trip_finds_a_cusp():
    # the default cam on a 15 mm base circle has a cusp under a flat face: the follower,
    # resting on the profile the formulas draw, no longer moves as the law says
    follower = cg.check_follower("flat_faced", 0.015)
    angles = np.linspace(0.8, 1.1, 7)
    found = ref.contact_lift(runtime_profile(follower, DEFAULT), follower._asdict(), 0.015, angles)
    assert np.max(np.abs(found - numpy_lift(DEFAULT)(angles))) > 1e-5


@pytest.mark.parametrize("law", cl.CAM_LAWS)
@pytest.mark.parametrize(
    "kind, roller, offset", [("flat_faced", 0.0, 0.0), ("roller", 0.008, 0.004)]
)
def test_radius_of_curvature_is_the_circle_through_neighbouring_points(law, kind, roller, offset):
    profile = cl.check_profile(law, 0.007, 0.2, 1.3, 0.1, 1.4)
    follower = cg.check_follower(kind, 0.05, roller, offset)
    spacing = 2e-4
    for centre in away_from_joins(profile, np.linspace(0.0, TAU, 40, endpoint=False), 1e-3):
        angles = centre + spacing * np.array([-1.0, 0.0, 1.0])
        x, y = runtime_profile(follower, profile)(angles)
        px, py = np.array(
            [
                (p.pitch_x, p.pitch_y)
                for p in (cg.profile_point(follower, profile, float(a)) for a in angles)
            ]
        ).T
        point = cg.profile_point(follower, profile, float(centre))
        assert ref.circumradius(x, y)[0] == pytest.approx(point.radius_of_curvature, rel=1e-5)
        assert ref.circumradius(px, py)[0] == pytest.approx(
            point.pitch_radius_of_curvature, rel=1e-5
        )


def test_inverse_chain_closes():
    """Desired valve motion -> tappet diagram -> cam profile -> follower on that profile ->
    forward solver -> the desired valve motion."""
    desired = cl.check_profile("polynomial_4567", 0.0105, 0.4, 1.2, 0.1, 1.2)
    pieces = vt.tappet_pieces(G, desired, "inverse")
    follower = cg.check_follower("roller", G.cam_base_radius, 0.008, 0.002)
    assert not cg.design(follower, pieces).problems

    def profile(angles):
        points = []
        for angle in np.atleast_1d(angles):
            index = next(
                i for i, p in enumerate(pieces) if cl.reduce_angle(float(angle) - p.start) <= p.span
            )
            piece = pieces[index]
            motion = piece.motion(cl.reduce_angle(float(angle) - piece.start) / piece.span)
            points.append(cg.cam_point(follower, float(angle), *motion))
        return np.array([p.x for p in points]), np.array([p.y for p in points])

    angles = np.linspace(0.0, TAU, 24, endpoint=False) + 0.05
    tappet = ref.contact_lift(profile, follower._asdict(), cg.trace_height(follower), angles)
    valve = np.array([vt.forward(G, float(s), 0.0, 0.0).valve_lift for s in tappet])
    desired_valve = numpy_lift(desired)(angles)
    assert np.max(np.abs(valve - desired_valve)) <= 1e-9 * desired.lift
    assert np.max(tappet) == pytest.approx(0.0105 / 1.5, rel=2e-3)  # the rocker ratio, 1.5


# --- design checks, sizing, bad input -------------------------------------------------------


def test_default_cam_has_a_cusp_under_a_flat_face_and_the_error_names_the_limit():
    follower = cg.check_follower("flat_faced", G.cam_base_radius)
    found = cg.design(follower, cg.law_pieces(DEFAULT))
    (problem,) = found.problems
    # dense numpy minimum of Rb + s + s'' over a revolution
    angles = np.linspace(0.0, TAU, 400_001)
    s, _, s2 = vt_ref.cam_lift(*DEFAULT, angles)
    dense = np.min(G.cam_base_radius + s + s2)
    assert problem.kind == cg.CUSP and found.least_radius == pytest.approx(dense, rel=1e-9)
    at = vt_ref.cam_lift(*DEFAULT, problem.angle)  # a minimum of the rise or the return
    assert G.cam_base_radius + at[0] + at[2] == pytest.approx(dense, rel=1e-9)
    with pytest.raises(CamDesignError) as info:
        cg.require_design(follower, found)
    error = info.value
    assert (
        error.kind == cg.CUSP and error.name == "cam_base_radius" and error.angle == problem.angle
    )
    limit = G.cam_base_radius - found.least_radius
    assert f"({limit!r}, inf) m" in str(error) and "cusp" in str(error)
    sizing = cg.smallest_base_circle("flat_faced", cg.law_pieces(DEFAULT))
    assert sizing.base_circle_radius == pytest.approx(limit, rel=1e-12)
    assert sizing.limit == "curvature" and sizing.angle == pytest.approx(problem.angle, abs=1e-6)
    wider = cg.check_follower("flat_faced", limit * (1.0 + 1e-6))
    assert cg.require_design(wider, cg.design(wider, cg.law_pieces(DEFAULT))).problems == ()


def test_a_roller_larger_than_the_curvature_allows_is_refused():
    pieces = cg.law_pieces(DEFAULT)
    small = cg.check_follower("roller", 0.015, 0.002)
    least_pitch = cg.design(small, pieces).least_pitch_radius
    big = cg.check_follower("roller", 0.002, 0.015)  # same prime circle, larger roller
    found = cg.design(big, pieces)
    assert found.least_pitch_radius == pytest.approx(least_pitch, rel=1e-12)
    assert [p.kind for p in found.problems][0] == cg.UNDERCUT
    with pytest.raises(CamDesignError) as info:
        cg.require_design(big, found)
    assert info.value.name == "roller_radius" and info.value.value == 0.015
    assert f"(0, {found.least_pitch_radius!r}) m" in str(info.value)


def test_pressure_angle_over_the_limit_is_flagged_with_its_angle():
    follower = cg.check_follower("roller", 0.012, 0.008)
    found = cg.design(follower, cg.law_pieces(DEFAULT), math.radians(20.0))
    kinds = [p.kind for p in found.problems]
    assert kinds == [cg.PRESSURE_ANGLE]
    (problem,) = found.problems
    angles = np.linspace(0.0, TAU, 200_001)
    s, s1, _ = vt_ref.cam_lift(*DEFAULT, angles)
    dense = np.arctan2(s1, cg.trace_height(follower) + s)
    largest = np.max(np.abs(dense))
    assert abs(found.largest_pressure_angle) == pytest.approx(largest, rel=1e-9)
    at = vt_ref.cam_lift(*DEFAULT, problem.angle)  # where it is, rise or return
    at_angle = np.arctan2(at[1], cg.trace_height(follower) + at[0])
    assert at_angle == pytest.approx(found.largest_pressure_angle, rel=1e-9)
    assert cg.require_design(follower, found) is found  # a flag, not an error


@pytest.mark.parametrize("offset", [0.0, 0.004, -0.006])
@pytest.mark.parametrize("limit", [math.radians(25.0), math.radians(35.0)])
def test_smallest_roller_base_circle_meets_its_limit_with_equality(offset, limit):
    pieces = cg.law_pieces(DEFAULT)
    sizing = cg.smallest_base_circle("roller", pieces, 0.006, offset, limit, 0.001)
    at = cg.design(
        cg.check_follower("roller", sizing.base_circle_radius, 0.006, offset), pieces, limit
    )
    if sizing.limit == "pressure_angle":
        assert abs(at.largest_pressure_angle) == pytest.approx(limit, rel=1e-9)
    else:
        assert sizing.limit == "curvature"
        assert at.least_radius == pytest.approx(0.001, rel=1e-9)
        assert abs(at.largest_pressure_angle) <= limit * (1 + 1e-12)
    smaller = cg.check_follower("roller", sizing.base_circle_radius * (1 - 1e-6), 0.006, offset)
    below = cg.design(smaller, pieces, limit)
    assert abs(below.largest_pressure_angle) > limit or below.least_radius < 0.001


@pytest.mark.parametrize(
    "arguments, name, valid",
    [
        (("flat_faced", 0.0), "cam_base_radius", "(0, inf)"),
        (("flat_faced", -0.01), "cam_base_radius", "(0, inf)"),
        (("roller", 0.015, 0.0), "roller_radius", "(0, inf)"),
        (("flat_faced", 0.015, 0.0, 0.015), "follower_offset", "(-0.015, 0.015)"),
        (("roller", 0.015, 0.005, -0.021), "follower_offset", "(-0.02, 0.02)"),
        (("flat_faced", math.nan), "cam_base_radius", "(0, inf)"),
    ],
)
def test_bad_follower_names_the_value_and_the_limit(arguments, name, valid):
    with pytest.raises(RangeError) as info:
        cg.check_follower(*arguments)
    assert info.value.name == name and f"valid range {valid}" in str(info.value)


def test_unknown_follower_and_zero_rise_angle():
    with pytest.raises(MechanismError, match="follower = 'knife' is not one of flat_faced, roller"):
        cg.check_follower("knife", 0.015)
    with pytest.raises(
        RangeError, match=r"rise_angle = 0.0 rad is outside the valid range \(0, inf\)"
    ):
        cl.check_profile("harmonic", 0.007, 0.0, 0.0, 0.1, 1.2)


# --- camshaft torque ------------------------------------------------------------------------


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_torque_by_power_equals_the_moment_of_the_contact_force_by_statics(law):
    """F_valve dL/dtheta (runtime: power) against the tappet force from the rocker's
    moments and its moment about the camshaft centre (numpy: statics)."""
    profile = cl.check_profile(law, 0.007, 0.0, 1.2, 0.1, 1.2)
    angles = np.linspace(0.0, TAU, 181)
    speed, mass, stiffness, preload = 300.0, 0.1, 50e3, 300.0
    closed = vt.rest_position(G)[1]
    torques, forces, lifts, rates = [], [], [], []
    for angle in angles:
        s, s1, s2, _ = cl.cam_lift(profile, float(angle))
        motion = vt.forward(G, s, s1 * speed, s2 * speed**2)
        force = vt.contact_force(
            mass, stiffness, preload, motion.valve_lift, motion.valve_acceleration
        )
        torques.append(cg.camshaft_torque(force, vt.valve_lift_rate(G, closed, s, s1)))
        forces.append(force)
        lifts.append(s)
        rates.append(s1)
    statics = ref.camshaft_torque_by_statics(
        G._asdict(), np.array(lifts), np.array(rates), np.array(forces)
    )
    np.testing.assert_allclose(torques, statics, rtol=1e-9, atol=1e-9 * np.max(np.abs(statics)))


@pytest.mark.parametrize(
    "kind, roller, offset", [("flat_faced", 0.0, 0.005), ("roller", 0.008, -0.004)]
)
def test_torque_is_the_moment_of_the_normal_force_at_the_contact(kind, roller, offset):
    # F s1 against the moment of N = F / cos(phi) along the normal at the runtime's contact
    follower = cg.check_follower(kind, 0.03, roller, offset)
    for angle in np.linspace(0.0, TAU, 97):
        point = cg.profile_point(follower, DEFAULT, float(angle))
        s1 = cl.cam_lift(DEFAULT, float(angle)).s1
        x, y = ref.to_fixed_frame(point.x, point.y, angle)
        normal = (math.sin(point.pressure_angle), -math.cos(point.pressure_angle))
        force = 500.0
        push = force / math.cos(point.pressure_angle)
        moment = x * push * normal[1] - y * push * normal[0]
        assert -moment == pytest.approx(cg.camshaft_torque(force, s1), abs=1e-12)


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_mean_torque_over_a_revolution_is_zero(law):
    # conservative: spring and valve inertia give back over the return what the rise took
    profile = cl.check_profile(law, 0.007, 0.5, 1.1, 0.2, 1.3)
    speed, mass, stiffness, preload = 250.0, 0.1, 50e3, 300.0
    closed = vt.rest_position(G)[1]

    def torque(angle):
        s, s1, s2, _ = cl.cam_lift(profile, angle)
        motion = vt.forward(G, s, s1 * speed, s2 * speed**2)
        force = vt.contact_force(
            mass, stiffness, preload, motion.valve_lift, motion.valve_acceleration
        )
        return cg.camshaft_torque(force, vt.valve_lift_rate(G, closed, s, s1))

    edges = np.sort(np.concatenate([joins(profile), [0.0, TAU]]))
    work = sum(
        integrate.quad(torque, a, b, epsabs=1e-13, epsrel=1e-13, limit=200)[0]
        for a, b in zip(edges[:-1], edges[1:])
        if b > a
    )
    peak = max(abs(torque(a)) for a in np.linspace(0.0, TAU, 2001))
    assert abs(work) <= 1e-10 * peak * TAU
    assert peak > 1.0  # N.m: a real load, not a zero


@pytest.mark.parametrize("roller", [1e-300, 1e-30, 1e-9])
def test_a_vanishing_roller_sizes_the_cam_as_a_knife_edge_would(roller):
    # roller_radius 1e-300 m raised ZeroDivisionError (a trial prime circle of 1e-300 m, whose
    # curvature's r^3 underflowed) and, once finite, "no base circle up to 1e40 m" (the search
    # grew from 1e-300 m by 1.25 a step): the sizing must not depend on how small the roller is
    pieces = cg.law_pieces(DEFAULT)
    sizing = cg.smallest_base_circle("roller", pieces, roller)
    knife = cg.smallest_base_circle("roller", pieces, 1e-6)
    assert sizing.limit == knife.limit == "pressure_angle"
    assert sizing.base_circle_radius + roller == pytest.approx(
        knife.base_circle_radius + 1e-6, rel=1e-9
    )


@pytest.mark.parametrize("scale", [1e-300, 1.0, 1e300])
def test_pitch_curvature_of_a_nan_lift_is_nan_not_a_cusp(scale):
    # at any scale (the scaled branch included): a NaN cam law is not an unbounded curvature
    follower = cg.check_follower("roller", scale, scale)
    assert math.isnan(cg.pitch_curvature(follower, math.nan, 0.1 * scale, 0.0))
    assert math.isnan(cg.pitch_curvature(follower, 0.1 * scale, math.nan, 0.0))


@given(
    scale=st.sampled_from([1e-300, 1e-150, 1e-9, 1.0, 1e150, 1e300]),
    lift=st.floats(-0.5, 0.5),
    rate=st.floats(-1.0, 1.0),
    rate2=st.floats(-1.0, 1.0),
)
def test_pitch_curvature_is_finite_and_scales_as_one_over_length(scale, lift, rate, rate2):
    # every length (Rb, Rf, s, ds/dtheta, d2s/dtheta2) times scale: the curvature (1/m) over
    # scale, at any scale where that is a float (r^3 leaves the floats at 1e-300 and 1e300 m)
    unit = cg.pitch_curvature(cg.check_follower("roller", 1.0, 1.0), lift, rate, rate2)
    follower = cg.check_follower("roller", scale, scale)
    curvature = cg.pitch_curvature(follower, lift * scale, rate * scale, rate2 * scale)
    assert math.isfinite(curvature)
    if abs(unit) / scale < sys.float_info.max / 2:
        assert curvature == pytest.approx(unit / scale, rel=1e-9, abs=1e-300 / scale)
    else:
        assert curvature == math.copysign(sys.float_info.max, unit)
