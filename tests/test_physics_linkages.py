"""Four-bar and slider-crank kinematics against geometry, finite differences and the numpy
reference (an independent circle-intersection derivation with 2x2 linear solves).

Layers: constants and Grashof classes; loop closure and the circuit rule; agreement with the
reference along full crank revolutions; rates against central differences; range and
singularity errors; property tests over random crank-rocker geometries.
"""

import cmath
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mechfmu.runtime.physics import four_bar as fb
from mechfmu.runtime.physics import slider_crank as sc
from mechfmu.runtime.errors import MechanismError, RangeError, SingularConfiguration
from mechfmu.references import linkages as ref

INCH = 0.0254
PROPERTY = settings(derandomize=True, max_examples=200, deadline=None)

# (ground, crank, coupler, rocker)
COURSEWORK = (6.0 * INCH, 2.0 * INCH, 7.0 * INCH, 9.0 * INCH)
NORTON_4_1 = (100.0, 40.0, 120.0, 80.0)  # Norton example 4-1 numbers (mm)
DOUBLE_CRANK = (1.0, 3.0, 3.5, 2.5)  # ground shortest
TRIPLE_ROCKER = (8.0, 4.0, 5.0, 6.0)  # 4, 5, 6, 8: S + L = 12 > 11
TOGGLE = (4.0, 3.0, 2.0, 3.0)  # f = 5 = b + c at crank angle pi/2
FULL_TURN = [-math.pi + 2.0 * math.pi * (i + 0.5) / 720 for i in range(720)]

FOUR_BAR_CASES = [
    pytest.param(COURSEWORK, 0, id="coursework-open"),
    pytest.param(COURSEWORK, 1, id="coursework-crossed"),
    pytest.param(NORTON_4_1, 0, id="norton-open"),
    pytest.param(NORTON_4_1, 1, id="norton-crossed"),
    pytest.param(DOUBLE_CRANK, 0, id="double-crank-open"),
    pytest.param(DOUBLE_CRANK, 1, id="double-crank-crossed"),
]

SLIDER_CASES = (
    [
        pytest.param(tuple(sc.DEFAULT_SLIDER_CRANK), circuit, id=f"default-{circuit}")
        for circuit in (0, 1)
    ]
    + [
        pytest.param((0.05, 0.15, offset), circuit, id=f"offset{offset:+}-{circuit}")
        for offset in (0.02, -0.03)
        for circuit in (0, 1)
    ]
    + [
        pytest.param((2.0, 1.5, 0.3), circuit, id=f"partial-{circuit}")  # crank cannot turn fully
        for circuit in (0, 1)
    ]
)


def angle_difference(x, y):
    """|x - y| on the circle, in [0, pi]."""
    return abs(math.remainder(x - y, 2.0 * math.pi))


def closure(lengths, crank_angle, coupler_angle, rocker_angle):
    """|a e^(i t2) + b e^(i t3) - c e^(i t4) - d|."""
    d, a, b, c = lengths
    return abs(
        a * cmath.exp(1j * crank_angle)
        + b * cmath.exp(1j * coupler_angle)
        - c * cmath.exp(1j * rocker_angle)
        - d
    )


def joints(lengths, crank_angle, circuit):
    d, a, b, c = lengths
    t3, _ = fb.position(*lengths, crank_angle, circuit)
    o2, o4 = (0.0, 0.0), (d, 0.0)
    pin_a = (a * math.cos(crank_angle), a * math.sin(crank_angle))
    pin_b = (pin_a[0] + b * math.cos(t3), pin_a[1] + b * math.sin(t3))
    return o2, pin_a, pin_b, o4


def _cross(o, p, q):
    return (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])


def _segments_cross(p1, p2, q1, q2):
    return (
        _cross(p1, p2, q1) * _cross(p1, p2, q2) < 0.0
        and _cross(q1, q2, p1) * _cross(q1, q2, p2) < 0.0
    )


def loop_crosses_itself(lengths, crank_angle, circuit):
    o2, a, b, o4 = joints(lengths, crank_angle, circuit)
    return _segments_cross(o2, a, b, o4) or _segments_cross(a, b, o4, o2)


# --- constants and classes -----------------------------------------------------------------


def test_coursework_constants():
    assert fb.INCH == INCH
    assert fb.COURSEWORK_FOUR_BAR == COURSEWORK
    assert fb.COURSEWORK_FOUR_BAR.crank == 2.0 * INCH
    assert fb.COURSEWORK_CRANK_ANGLE == pytest.approx(math.pi / 6, rel=1e-16)
    assert sc.DEFAULT_SLIDER_CRANK == (0.05, 0.15, 0.0)
    assert sc.crank_angle_range(sc.DEFAULT_SLIDER_CRANK) is None


def test_grashof_class_table():
    assert [entry.code for entry in fb.GRASHOF_CLASSES] == [1, 2, 3, 4, 5, 6]
    assert [entry.name for entry in fb.GRASHOF_CLASSES] == [
        "crank-rocker",
        "double-crank",
        "double-rocker",
        "rocker-crank",
        "triple-rocker",
        "change-point",
    ]


@pytest.mark.parametrize(
    "lengths, code",
    [
        ((6, 2, 7, 9), 1),  # coursework: crank shortest
        (COURSEWORK, 1),  # same in metres (rounded products)
        (NORTON_4_1, 1),
        ((2, 7, 9, 6), 2),  # ground shortest
        (DOUBLE_CRANK, 2),
        ((6, 7, 2, 9), 3),  # coupler shortest
        ((6, 7, 9, 2), 4),  # rocker shortest
        ((8, 4, 5, 6), 5),  # 4 + 8 > 5 + 6
        ((4, 5, 6, 8), 5),
        ((5, 8, 4, 6), 5),
        ((5, 2, 5, 2), 6),  # parallelogram 2, 5, 2, 5
        ((2, 2, 5, 5), 6),  # deltoid
        ((5 * INCH, 2 * INCH, 5 * INCH, 2 * INCH), 6),  # inexact in binary, within 1e-12 L
        ((10.0, 4.0, 7.0, 7.0 + 1e-9), 1),  # just Grashof: 4 + 10 < 7 + 7.000000001
        ((10.0, 4.0, 7.0, 7.0 - 1e-9), 5),  # just not
    ],
)
def test_grashof_class(lengths, code):
    assert fb.grashof_class(*lengths) == code


@pytest.mark.parametrize(
    "lengths, name",
    [
        ((0.0, 2, 7, 9), "ground"),
        ((6, -2, 7, 9), "crank"),
        ((6, 2, math.nan, 9), "coupler"),
        ((6, 2, 7, math.inf), "rocker"),
        ((1, 1, 1, 3), "rocker"),  # longest = sum of the others: no loop
        ((20, 2, 7, 9), "ground"),
    ],
)
def test_check_four_bar_rejects(lengths, name):
    with pytest.raises(RangeError) as info:
        fb.check_four_bar(*lengths)
    assert info.value.name == name
    assert name in str(info.value)
    assert info.value.unit == "m"


def test_check_four_bar_returns_floats():
    assert fb.check_four_bar(6, 2, 7, 9) == (6.0, 2.0, 7.0, 9.0)
    with pytest.raises(RangeError) as info:
        fb.check_four_bar(1, 1, 1, 3)
    assert "cannot close a loop" in str(info.value)


def test_crank_angle_range():
    assert fb.crank_angle_range(COURSEWORK) is None
    assert fb.crank_angle_range(*COURSEWORK) is None
    assert fb.crank_angle_range(DOUBLE_CRANK) is None
    # (a^2 + d^2 - (b +- c)^2) / (2ad) = (16 + 64 - 121) / 64 and (16 + 64 - 1) / 64 -> clip
    assert fb.crank_angle_range(TRIPLE_ROCKER) == (-0.640625, 1.0)
    assert fb.crank_angle_range(TOGGLE) == (0.0, 1.0)
    # a double-rocker: the crank swings between two limits away from theta2 = 0
    low, high = fb.crank_angle_range(6, 7, 2, 9)
    assert -1.0 < low < high < 1.0


# --- coursework and Norton's example -------------------------------------------------------


def test_coursework_example_both_circuits():
    t2 = fb.COURSEWORK_CRANK_ANGLE
    open_ = fb.motion(*COURSEWORK, 0, t2, 1.0, 0.0)
    crossed = fb.motion(*COURSEWORK, 1, t2, 1.0, 0.0)
    assert round(math.degrees(open_.coupler_angle), 2) == 88.84
    assert round(math.degrees(open_.rocker_angle), 2) == 117.29
    assert round(math.degrees(crossed.coupler_angle), 2) == -115.21
    assert round(math.degrees(crossed.rocker_angle), 2) == -143.66
    # mirror images about the diagonal: the same transmission angle
    assert round(math.degrees(open_.transmission_angle), 2) == 28.45
    assert crossed.transmission_angle == pytest.approx(open_.transmission_angle, abs=4e-15)
    # transmission angle from the law of cosines in triangle A-B-O4 (inches)
    f2 = 2 * 2 + 6 * 6 - 2 * 2 * 6 * math.cos(t2)
    mu = math.acos((7 * 7 + 9 * 9 - f2) / (2 * 7 * 9))
    assert open_.transmission_angle == pytest.approx(min(mu, math.pi - mu), abs=1e-14)


def test_norton_example_4_1_numbers():
    t2 = math.radians(40.0)
    t3, t4 = fb.position(*NORTON_4_1, t2, 0)
    assert (round(math.degrees(t3), 1), round(math.degrees(t4), 1)) == (20.3, 57.3)
    t3, t4 = fb.position(*NORTON_4_1, t2, 1)
    assert (round(math.degrees(t3), 1), round(math.degrees(t4), 1)) == (-61.0, -98.0)


def norton_textbook(lengths, t2, circuit):
    """Norton eqs 4.8-4.13 exactly as printed (K1..K5, atan, minus sign = open)."""
    d, a, b, c = lengths
    k1, k2, k3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    k4, k5 = d / b, (c * c - d * d - a * a - b * b) / (2 * a * b)
    big_a = math.cos(t2) - k1 - k2 * math.cos(t2) + k3
    big_b = -2 * math.sin(t2)
    big_c = k1 - (k2 + 1) * math.cos(t2) + k3
    big_d = math.cos(t2) - k1 + k4 * math.cos(t2) + k5
    big_e = -2 * math.sin(t2)
    big_f = k1 + (k4 - 1) * math.cos(t2) + k5
    sign = -1 if circuit == 0 else 1
    t4 = 2 * math.atan((-big_b + sign * math.sqrt(big_b**2 - 4 * big_a * big_c)) / (2 * big_a))
    t3 = 2 * math.atan((-big_e + sign * math.sqrt(big_e**2 - 4 * big_d * big_f)) / (2 * big_d))
    return t3, t4


@pytest.mark.parametrize("lengths", [COURSEWORK, NORTON_4_1, DOUBLE_CRANK, TRIPLE_ROCKER])
def test_position_matches_nortons_printed_equations(lengths):
    for t2 in [-3.0 + 0.15 * i for i in range(41)]:
        for circuit in (0, 1):
            try:
                expected = norton_textbook(lengths, t2, circuit)
            except ValueError:  # sqrt of a negative: no assembly
                with pytest.raises(RangeError):
                    fb.position(*lengths, t2, circuit)
                continue
            got = fb.position(*lengths, t2, circuit)
            assert angle_difference(got.coupler_angle, expected[0]) < 1e-12
            assert angle_difference(got.rocker_angle, expected[1]) < 1e-12


def test_position_is_scale_invariant():
    inches = fb.position(6, 2, 7, 9, 0.7, 0)
    metres = fb.position(*COURSEWORK, 0.7, 0)
    assert angle_difference(inches.coupler_angle, metres.coupler_angle) < 1e-15
    assert angle_difference(inches.rocker_angle, metres.rocker_angle) < 1e-15


# --- loop closure and circuits -------------------------------------------------------------


@pytest.mark.parametrize("lengths, circuit", FOUR_BAR_CASES)
def test_loop_closes_and_circuit_is_consistent(lengths, circuit):
    scale = sum(lengths)
    previous = None
    for t2 in FULL_TURN:
        t3, t4 = fb.position(*lengths, t2, circuit)
        assert -math.pi < t3 <= math.pi and -math.pi < t4 <= math.pi
        assert closure(lengths, t2, t3, t4) <= 1e-15 * scale
        # the circuit rule: open <=> sin(theta4 - theta3) > 0 (B left of A -> O4)
        assert (math.sin(t4 - t3) > 0.0) == (circuit == 0)
        # and the branch is continuous: a 0.5 degree crank step moves nothing far
        if previous is not None:
            assert angle_difference(t3, previous[0]) < 0.1
            assert angle_difference(t4, previous[1]) < 0.1
        previous = t3, t4


def test_open_loop_does_not_cross_itself_above_the_ground_line():
    for lengths in (COURSEWORK, NORTON_4_1, DOUBLE_CRANK):
        for i in range(1, 360):
            t2 = math.pi * i / 360
            assert not loop_crosses_itself(lengths, t2, 0)
            # mirror symmetry: below the ground line the crossed loop is the simple one
            assert not loop_crosses_itself(lengths, -t2, 1)
    # the coursework's crossed loop does cross itself at 30 degrees (and its open loop at -30)
    assert loop_crosses_itself(COURSEWORK, fb.COURSEWORK_CRANK_ANGLE, 1)
    assert loop_crosses_itself(COURSEWORK, -fb.COURSEWORK_CRANK_ANGLE, 0)


def test_circuits_are_mirror_images_about_the_diagonal():
    for lengths in (COURSEWORK, NORTON_4_1, DOUBLE_CRANK):
        for t2 in FULL_TURN[::37]:
            _, a, b_open, o4 = joints(lengths, t2, 0)
            _, _, b_crossed, _ = joints(lengths, t2, 1)
            # reflect b_open across the line a-o4
            ux, uy = o4[0] - a[0], o4[1] - a[1]
            norm = math.hypot(ux, uy)
            ux, uy = ux / norm, uy / norm
            px, py = b_open[0] - a[0], b_open[1] - a[1]
            along = px * ux + py * uy
            mirrored = (a[0] + 2 * along * ux - px, a[1] + 2 * along * uy - py)
            assert math.dist(mirrored, b_crossed) <= 1e-14 * sum(lengths)


def test_angles_are_wrapped_to_half_open_interval():
    # parallelogram at theta2 = pi: the crossed rocker angle is exactly +-pi territory
    for t2 in (math.pi, -math.pi, 3 * math.pi, 0.0):
        for circuit in (0, 1):
            t3, t4 = fb.position(*DOUBLE_CRANK, t2, circuit)
            assert -math.pi < t3 <= math.pi and -math.pi < t4 <= math.pi
    assert fb.transmission_angle(0.0, math.pi) == 0.0
    assert fb.transmission_angle(-3.0, 3.0) == pytest.approx(2 * math.pi - 6.0, abs=1e-15)
    assert fb.transmission_angle(0.1, 0.1 + math.pi / 2) == pytest.approx(math.pi / 2)
    assert fb.transmission_angle(0.1, 0.1 + 2.0) == pytest.approx(math.pi - 2.0)


def test_half_angle_form_stays_accurate_when_the_rocker_angle_is_pi():
    # ground 4, crank 1 at pi/2 (A = (0, 1)), rocker 2, coupler sqrt(5): the crossed circuit
    # has B = (2, 0), theta4 = pi exactly, where Norton's A coefficient vanishes
    lengths = (4.0, 1.0, math.sqrt(5.0), 2.0)
    rocker_angles = []
    for t2 in (math.pi / 2 - 1e-9, math.pi / 2, math.pi / 2 + 1e-9):
        t3, t4 = fb.position(*lengths, t2, 1)
        assert closure(lengths, t2, t3, t4) <= 1e-15 * sum(lengths)
        assert angle_difference(t4, math.pi) < 1e-8
        assert angle_difference(t3, math.atan2(-1.0, 2.0)) < 1e-8
        rocker_angles.append(t4)
    # the rocker angle passes through pi: it wraps from one end of (-pi, pi] to the other
    assert rocker_angles[0] < -3.14 and rocker_angles[2] > 3.14
    # the rate through pi follows the angle smoothly
    m = fb.motion(*lengths, 1, math.pi / 2, 1.0, 0.0)
    ahead = fb.position(*lengths, math.pi / 2 + 1e-6, 1).rocker_angle
    behind = fb.position(*lengths, math.pi / 2 - 1e-6, 1).rocker_angle
    derivative = math.remainder(ahead - behind, 2 * math.pi) / 2e-6
    assert m.rocker_angular_velocity == pytest.approx(derivative, rel=1e-8)


def test_toggle_on_the_ground_line_returns_an_accurate_position():
    # crank at pi: A = (-1, 0), B = (2, 0), O4 = (4, 0): coupler 3 and rocker 2 collinear with
    # the ground (f = 5 = b + c). Norton's coefficients B, E and one of A, C (D, F) vanish.
    lengths = (4.0, 1.0, 3.0, 2.0)
    for t2 in (math.pi, -math.pi):
        for circuit in (0, 1):
            t3, t4 = fb.position(*lengths, t2, circuit)
            assert closure(lengths, t2, t3, t4) <= 1e-15 * sum(lengths)
            assert angle_difference(t3, 0.0) < 1e-15 and angle_difference(t4, math.pi) < 1e-15
            with pytest.raises(SingularConfiguration):
                fb.motion(*lengths, circuit, t2, 1.0, 0.0)


def test_slider_crank_closure_and_circuits():
    for geometry, circuit in [
        (g, c) for g in ((0.05, 0.15, 0.0), (0.05, 0.15, 0.02), (0.05, 0.15, -0.03)) for c in (0, 1)
    ]:
        a, b, e = geometry
        for t2 in FULL_TURN:
            t3, s = sc.position(*geometry, t2, circuit)
            assert -math.pi < t3 <= math.pi
            assert abs(a * math.sin(t2) + b * math.sin(t3) - e) <= 1e-16 * 4 * (a + b)
            assert abs(a * math.cos(t2) + b * math.cos(t3) - s) <= 1e-16 * 4 * (a + b)
            assert (math.cos(t3) > 0.0) == (circuit == 0)
            assert (s > a * math.cos(t2)) == (circuit == 0)


def test_in_line_slider_crank_dead_centres():
    a, b, e = sc.DEFAULT_SLIDER_CRANK
    assert sc.position(a, b, e, 0.0, 0) == (0.0, a + b)
    bottom = sc.position(a, b, e, math.pi, 0)  # sin(float pi) = 1.2e-16, not 0
    assert abs(bottom.coupler_angle) < 1e-16 and bottom.slider_position == pytest.approx(b - a)
    assert sc.position(a, b, e, 0.0, 1) == (math.pi, a - b)
    assert sc.position(a, b, e, -0.0, 1).coupler_angle == math.pi  # -0.0 sine, still +pi
    m = sc.motion(a, b, e, 0, 0.0, 100.0, 0.0)
    assert m.slider_speed == pytest.approx(0.0, abs=1e-18)
    # top dead centre: s'' = -a w^2 (1 + a/b)
    assert m.slider_acceleration == pytest.approx(-a * 1e4 * (1 + a / b), rel=1e-14)


# --- agreement with the numpy reference ----------------------------------------------------


def assert_four_bar_matches_reference(lengths, circuit, angles, speed, accel):
    expected = ref.four_bar(*lengths, circuit, np.array(angles), speed, accel)
    for i, t2 in enumerate(angles):
        got = fb.motion(*lengths, circuit, t2, speed, accel)
        for key in ("coupler_angle", "rocker_angle", "transmission_angle"):
            assert angle_difference(getattr(got, key), expected[key][i]) <= 1e-12, (key, t2)
        for key in ("coupler_angular_velocity", "rocker_angular_velocity"):
            value = expected[key][i]
            assert abs(getattr(got, key) - value) <= 1e-12 * (abs(value) + abs(speed)), key
        for key in ("coupler_angular_acceleration", "rocker_angular_acceleration"):
            value = expected[key][i]
            allowance = 1e-12 * (abs(value) + abs(accel) + speed * speed)
            assert abs(getattr(got, key) - value) <= allowance, key


@pytest.mark.parametrize("lengths, circuit", FOUR_BAR_CASES)
def test_four_bar_matches_reference_over_a_revolution(lengths, circuit):
    assert_four_bar_matches_reference(lengths, circuit, FULL_TURN, 2.5, -1.5)


@pytest.mark.parametrize("circuit", [0, 1])
def test_triple_rocker_matches_reference_inside_its_range(circuit):
    low, _ = fb.crank_angle_range(TRIPLE_ROCKER)
    limit = math.acos(low)
    angles = [limit * (-0.99 + 1.98 * i / 200) for i in range(201)]
    assert_four_bar_matches_reference(TRIPLE_ROCKER, circuit, angles, 1.0, 0.5)
    # outside: the reference reports NaN, the physics raises
    outside = ref.four_bar(*TRIPLE_ROCKER, circuit, np.array([math.pi, limit + 1e-6]), 1.0, 0.0)
    assert all(np.isnan(v).all() for v in outside.values())


@pytest.mark.parametrize("geometry, circuit", SLIDER_CASES)
def test_slider_crank_matches_reference(geometry, circuit):
    interval = sc.crank_angle_range(geometry)
    angles = FULL_TURN
    if interval is not None:
        # keep away from the singular positions, where the rates blow up
        low, high = interval
        angles = [t for t in FULL_TURN if low + 1e-3 < math.sin(t) < high - 1e-3]
        assert 100 < len(angles) < len(FULL_TURN)
    speed, accel = 30.0, -4.0
    a, b, _ = geometry
    expected = ref.slider_crank(*geometry, circuit, np.array(angles), speed, accel)
    for i, t2 in enumerate(angles):
        got = sc.motion(*geometry, circuit, t2, speed, accel)
        assert angle_difference(got.coupler_angle, expected["coupler_angle"][i]) <= 1e-12
        for key, scale in (
            ("slider_position", a + b),
            ("slider_speed", (a + b) * speed),
            ("slider_acceleration", (a + b) * (speed * speed + abs(accel))),
            ("coupler_angular_velocity", speed),
            ("coupler_angular_acceleration", speed * speed + abs(accel)),
        ):
            value = expected[key][i]
            assert abs(getattr(got, key) - value) <= 1e-12 * (abs(value) + scale), key


def test_reference_returns_the_namedtuple_fields():
    four = ref.four_bar(*COURSEWORK, 0, np.array([0.1, 0.2]), 1.0, 0.0)
    assert set(four) == set(fb.FourBarMotion._fields)
    slider = ref.slider_crank(0.05, 0.15, 0.0, 0, np.array([0.1]), 1.0, 0.0)
    assert set(slider) == set(sc.SliderCrankMotion._fields)
    partial = ref.slider_crank(2.0, 1.5, 0.3, 1, np.array([-math.pi / 2]), 1.0, 0.0)
    assert all(np.isnan(v).all() for v in partial.values())


# --- rates against central finite differences ----------------------------------------------


def _crank_path(t):
    """A non-uniform crank motion: angle, speed and acceleration at time t."""
    return 0.3 + 1.1 * t + 0.4 * math.sin(t), 1.1 + 0.4 * math.cos(t), -0.4 * math.sin(t)


def _along_crank_path(at):
    """The finite-difference step (s), the motion function, 120 sample times over 6 s of
    _crank_path and the motions there."""
    times = [0.05 * i for i in range(120)]
    return 1e-5, at, times, [at(t) for t in times]


@pytest.mark.parametrize("lengths, circuit", FOUR_BAR_CASES)
def test_four_bar_rates_are_derivatives(lengths, circuit):
    step, at, times, motions = _along_crank_path(
        lambda t: fb.motion(*lengths, circuit, *_crank_path(t))
    )
    w_scale = max(
        max(abs(m.coupler_angular_velocity), abs(m.rocker_angular_velocity)) for m in motions
    )
    al_scale = max(
        max(abs(m.coupler_angular_acceleration), abs(m.rocker_angular_acceleration))
        for m in motions
    )
    for t, m in zip(times, motions):
        ahead, behind = at(t + step), at(t - step)
        for angle, rate, accel in (
            ("coupler_angle", "coupler_angular_velocity", "coupler_angular_acceleration"),
            ("rocker_angle", "rocker_angular_velocity", "rocker_angular_acceleration"),
        ):
            d_angle = math.remainder(
                getattr(ahead, angle) - getattr(behind, angle), 2 * math.pi
            ) / (2 * step)
            d_rate = (getattr(ahead, rate) - getattr(behind, rate)) / (2 * step)
            assert abs(getattr(m, rate) - d_angle) <= 1e-8 * w_scale, (t, rate)
            assert abs(getattr(m, accel) - d_rate) <= 1e-8 * al_scale, (t, accel)


@pytest.mark.parametrize("geometry, circuit", SLIDER_CASES[:6])
def test_slider_crank_rates_are_derivatives(geometry, circuit):
    step, at, times, motions = _along_crank_path(
        lambda t: sc.motion(*geometry, circuit, *_crank_path(t))
    )
    scales = {
        key: max(abs(getattr(m, key)) for m in motions) for key in sc.SliderCrankMotion._fields
    }
    for t, m in zip(times, motions):
        ahead, behind = at(t + step), at(t - step)
        pairs = (
            ("slider_position", "slider_speed"),
            ("slider_speed", "slider_acceleration"),
            ("coupler_angular_velocity", "coupler_angular_acceleration"),
        )
        for value, rate in pairs:
            derivative = (getattr(ahead, value) - getattr(behind, value)) / (2 * step)
            assert abs(getattr(m, rate) - derivative) <= 1e-8 * scales[rate], (t, rate)
        d_angle = math.remainder(ahead.coupler_angle - behind.coupler_angle, 2 * math.pi)
        assert (
            abs(m.coupler_angular_velocity - d_angle / (2 * step))
            <= 1e-8 * scales["coupler_angular_velocity"]
        )


def test_velocity_formulas_agree_with_instant_centre_ratio():
    # angular velocity ratio w4/w2 = a sin(t2 - t3) / (c sin(t4 - t3)); zero rates at rest
    m = fb.motion(*COURSEWORK, 0, 0.4, 0.0, 0.0)
    assert m.coupler_angular_velocity == 0.0 and m.rocker_angular_velocity == 0.0
    assert m.coupler_angular_acceleration == 0.0 and m.rocker_angular_acceleration == 0.0
    # crank acceleration alone: alpha follows the velocity ratios exactly
    unit = fb.motion(*COURSEWORK, 0, 0.4, 1.0, 0.0)
    pure = fb.motion(*COURSEWORK, 0, 0.4, 0.0, 3.0)
    assert pure.rocker_angular_acceleration == pytest.approx(
        3.0 * unit.rocker_angular_velocity, rel=1e-14
    )
    assert pure.coupler_angular_acceleration == pytest.approx(
        3.0 * unit.coupler_angular_velocity, rel=1e-14
    )


# --- errors --------------------------------------------------------------------------------


@pytest.mark.parametrize("t2", [math.pi, -2.5, 2.3, 2.2661083, 4.0])
def test_triple_rocker_outside_its_range_raises(t2):
    with pytest.raises(RangeError) as info:
        fb.motion(*TRIPLE_ROCKER, 0, t2, 1.0, 0.0)
    error = info.value
    assert error.name == "crank_angle" and error.value == t2
    text = str(error)
    assert repr(t2) in text
    assert "[-0.640625, 1.0]" in text  # cos(crank_angle) interval
    assert repr(math.acos(-0.640625)) in text  # the angle limit
    assert "no assembly" in text
    assert "[1.0, 11.0]" in text  # [|b - c|, b + c]
    assert isinstance(error, MechanismError)
    with pytest.raises(RangeError):
        fb.position(*TRIPLE_ROCKER, t2, 1)


def test_triple_rocker_works_just_inside_its_range():
    limit = math.acos(-0.640625)
    for t2 in (limit - 1e-6, -limit + 1e-6, 0.0):
        for circuit in (0, 1):
            m = fb.motion(*TRIPLE_ROCKER, circuit, t2, 1.0, 0.0)
            assert closure(TRIPLE_ROCKER, t2, m.coupler_angle, m.rocker_angle) <= 1e-14


def test_toggle_position_is_singular_for_rates():
    t2 = math.pi / 2  # f = sqrt(3^2 + 4^2) = 5 = coupler + rocker
    open_ = fb.position(*TOGGLE, t2, 0)
    crossed = fb.position(*TOGGLE, t2, 1)
    assert angle_difference(open_.coupler_angle, crossed.coupler_angle) < 1e-14
    assert angle_difference(open_.rocker_angle, crossed.rocker_angle) < 1e-14
    # coupler and rocker collinear (antiparallel: B between A and O4)
    assert angle_difference(open_.rocker_angle - open_.coupler_angle, math.pi) < 1e-14
    assert closure(TOGGLE, t2, *open_) < 1e-14
    for circuit in (0, 1):
        with pytest.raises(SingularConfiguration) as info:
            fb.motion(*TOGGLE, circuit, t2, 1.0, 0.0)
        text = str(info.value)
        assert "toggle position" in text and "collinear" in text
        assert repr(t2) in text
        assert not isinstance(info.value, RangeError)
    # just inside the range the rates are finite (and large), just outside it raises
    near = fb.motion(*TOGGLE, 0, t2 - 1e-6, 1.0, 0.0)
    assert 1e2 < abs(near.rocker_angular_velocity) < 1e4
    with pytest.raises(RangeError):
        fb.motion(*TOGGLE, 0, t2 + 1e-6, 1.0, 0.0)


def test_deltoid_with_crank_pin_on_rocker_pivot_is_singular():
    with pytest.raises(SingularConfiguration):
        fb.position(2.0, 2.0, 5.0, 5.0, 0.0, 0)


@pytest.mark.parametrize("circuit", [2, -1, 0.5, "open", None, True, math.nan])
def test_circuit_must_be_0_or_1(circuit):
    with pytest.raises(RangeError) as info:
        fb.motion(*COURSEWORK, circuit, 0.1, 1.0, 0.0)
    assert info.value.name == "circuit"
    with pytest.raises(RangeError):
        sc.motion(0.05, 0.15, 0.0, circuit, 0.1, 1.0, 0.0)


@pytest.mark.parametrize(
    "index, name", [(5, "crank_angle"), (6, "crank_speed"), (7, "crank_acceleration")]
)
def test_non_finite_four_bar_inputs(index, name):
    args = [*COURSEWORK, 0, 0.1, 1.0, 0.0]
    args[index] = math.nan
    with pytest.raises(RangeError) as info:
        fb.motion(*args)
    assert info.value.name == name


def test_slider_crank_errors():
    geometry = (2.0, 1.5, 0.3)
    assert sc.crank_angle_range(geometry) == (-0.6, 0.9)
    with pytest.raises(RangeError) as info:
        sc.motion(*geometry, 0, -math.pi / 2, 1.0, 0.0)
    text = str(info.value)
    assert info.value.name == "crank_angle"
    assert "[-0.6, 0.9]" in text and "no assembly" in text and repr(-math.pi / 2) in text
    # coupler perpendicular to the slider axis: |0 - 2 sin(pi/6)| = 1 = b
    for circuit in (0, 1):
        assert sc.position(2.0, 1.0, 0.0, math.pi / 6, circuit).coupler_angle == pytest.approx(
            -math.pi / 2
        )
        with pytest.raises(SingularConfiguration) as info:
            sc.motion(2.0, 1.0, 0.0, circuit, math.pi / 6, 1.0, 0.0)
        assert repr(math.pi / 6) in str(info.value)
    for args, name in (
        ((0.0, 1.0, 0.0), "crank"),
        ((1.0, -1.0, 0.0), "coupler"),
        ((1.0, 1.0, math.inf), "offset"),
        ((1.0, 1.0, -2.0), "offset"),
    ):
        with pytest.raises(RangeError) as info:
            sc.check_slider_crank(*args)
        assert info.value.name == name


# --- property tests ------------------------------------------------------------------------


@st.composite
def crank_rockers(draw):
    """(ground, crank, coupler, rocker) with the crank shortest and S + L < P + Q by 2 %."""
    scale = draw(st.floats(0.01, 10.0))
    b, c, d = (draw(st.floats(1.1, 8.0)) for _ in range(3))
    longest = max(b, c, d)
    assume(1.0 + longest < (b + c + d - longest) - 0.02 * longest)
    return d * scale, scale, b * scale, c * scale


def _signed(low, high):
    """0, or a magnitude in [low, high] of either sign (no subnormal rates)."""
    magnitude = st.floats(low, high)
    return st.one_of(st.just(0.0), magnitude, magnitude.map(lambda v: -v))


@PROPERTY
@given(
    crank_rockers(),
    st.sampled_from([0, 1]),
    st.floats(-math.pi, math.pi),
    _signed(1e-3, 50.0),
    _signed(1e-3, 100.0),
)
def test_property_crank_rocker_closure_and_reference(lengths, circuit, start, speed, accel):
    assert fb.grashof_class(*lengths) == 1
    assert fb.crank_angle_range(lengths) is None
    angles = [math.remainder(start + 2 * math.pi * i / 12, 2 * math.pi) for i in range(12)]
    for t2 in angles:
        t3, t4 = fb.position(*lengths, t2, circuit)
        # the half-angle roots' rounding grows as 1/sin(mu) towards a toggle (the quadratic's
        # discriminant is 4 (2 b c sin mu)^2): a few 1e-16 of the loop size, more as mu -> 0
        mu = fb.transmission_angle(t3, t4)
        assert closure(lengths, t2, t3, t4) <= 2e-15 * sum(lengths) * (1 + 0.1 / math.sin(mu))
        assert (math.sin(t4 - t3) > 0.0) == (circuit == 0)
    assert_four_bar_matches_reference(lengths, circuit, angles, speed, accel)


@PROPERTY
@given(
    st.floats(0.01, 1.0),
    st.floats(1.05, 6.0),
    st.floats(-0.9, 0.9),
    st.sampled_from([0, 1]),
    st.floats(-math.pi, math.pi),
)
def test_property_full_turn_slider_crank_matches_reference(a, ratio, offset_ratio, circuit, t2):
    # b > a + |offset|: the crank turns fully
    b = a * ratio
    offset = offset_ratio * (b - a)
    assert sc.crank_angle_range(a, b, offset) is None
    got = sc.motion(a, b, offset, circuit, t2, 7.0, 3.0)
    expected = ref.slider_crank(a, b, offset, circuit, np.array([t2]), 7.0, 3.0)
    assert angle_difference(got.coupler_angle, expected["coupler_angle"][0]) <= 1e-12
    assert abs(got.slider_position - expected["slider_position"][0]) <= 1e-14 * (a + b)
    for key in (
        "slider_speed",
        "slider_acceleration",
        "coupler_angular_velocity",
        "coupler_angular_acceleration",
    ):
        value = expected[key][0]
        scale = 50.0 * (a + b) if key.startswith("slider") else 50.0
        assert abs(getattr(got, key) - value) <= 1e-12 * (abs(value) + scale), key
