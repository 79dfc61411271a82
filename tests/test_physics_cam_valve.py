"""Cam laws and the pushrod valve train against closed forms, finite differences and numpy.

Layers: each law's end values, derivatives and peak coefficients (against a dense, then
golden-section, numerical maximisation); the continuity table against the actual jumps at the
segment ends; profile checks, periodicity and angle reduction after a million revolutions;
the valve-train geometry (defaults, checks, range and singularity errors); its rates against
finite differences; stdlib against the independent numpy reference over full revolutions;
the float speed (0.99x keeps contact, 1.01x loses it); property tests over random profiles.
"""

import math
import re
from decimal import Decimal
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechfmu.runtime.physics import cam_laws as cl
from mechfmu.runtime.physics import valve_train as vt
from mechfmu.runtime.errors import MechanismError, RangeError, SingularConfiguration
from mechfmu.references import valve_train as ref

PROPERTY = settings(derandomize=True, max_examples=200, deadline=None)
TAU = 2.0 * math.pi
G = vt.DEFAULT_VALVE_GEOMETRY
GD = G._asdict()
R_B, L1, A, B, LT, LV, C, L3 = G

# Ends of f, f1, f2, f3 at x = 0 and x = 1 (from the formulas by hand).
END_VALUES = {
    "harmonic": ((0.0, 0.0, math.pi**2 / 2, 0.0), (1.0, 0.0, -(math.pi**2) / 2, 0.0)),
    "cycloidal": ((0.0, 0.0, 0.0, 4 * math.pi**2), (1.0, 0.0, 0.0, 4 * math.pi**2)),
    "polynomial_345": ((0.0, 0.0, 0.0, 60.0), (1.0, 0.0, 0.0, 60.0)),
    "polynomial_4567": ((0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)),
}


def textbook(law, x):
    """The laws exactly as written in the brief (expanded), with hand derivatives."""
    if law == "harmonic":
        return (
            (1 - math.cos(math.pi * x)) / 2,
            math.pi / 2 * math.sin(math.pi * x),
            math.pi**2 / 2 * math.cos(math.pi * x),
            -(math.pi**3) / 2 * math.sin(math.pi * x),
        )
    if law == "cycloidal":
        return (
            x - math.sin(TAU * x) / TAU,
            1 - math.cos(TAU * x),
            TAU * math.sin(TAU * x),
            TAU**2 * math.cos(TAU * x),
        )
    if law == "polynomial_345":
        return (
            10 * x**3 - 15 * x**4 + 6 * x**5,
            30 * x**2 - 60 * x**3 + 30 * x**4,
            60 * x - 180 * x**2 + 120 * x**3,
            60 - 360 * x + 360 * x**2,
        )
    return (
        35 * x**4 - 84 * x**5 + 70 * x**6 - 20 * x**7,
        140 * x**3 - 420 * x**4 + 420 * x**5 - 140 * x**6,
        420 * x**2 - 1680 * x**3 + 2100 * x**4 - 840 * x**5,
        840 * x - 5040 * x**2 + 8400 * x**3 - 4200 * x**4,
    )


def golden_max(function, low, high):
    """Maximum of a unimodal function on [low, high] by golden section (the test's own)."""
    ratio = (math.sqrt(5) - 1) / 2
    a, b = low, high
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = function(c), function(d)
    for _ in range(120):
        if fc >= fd:
            b, d, fd = d, c, fc
            c = b - ratio * (b - a)
            fc = function(c)
        else:
            a, c, fc = c, d, fd
            d = a + ratio * (b - a)
            fd = function(d)
    return max(fc, fd, function(low), function(high))


def scaled_close(got, expected, rtol, scale):
    return abs(got - expected) <= rtol * max(abs(expected), scale)


# --- normalized laws --------------------------------------------------------------------------


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_end_values_are_exact(law):
    at_0, at_1 = END_VALUES[law]
    assert tuple(cl.normalized(law, 0.0)) == pytest.approx(at_0, abs=1e-13)
    assert tuple(cl.normalized(law, 1.0)) == pytest.approx(at_1, abs=1e-13)
    # f, f1 and (except harmonic) f2 are exactly 0 or 1 at the ends, not merely close
    assert cl.normalized(law, 0.0).f == 0.0 and cl.normalized(law, 1.0).f == 1.0
    assert cl.normalized(law, 0.0).f1 == 0.0 and cl.normalized(law, 1.0).f1 == 0.0
    if law != "harmonic":
        assert cl.normalized(law, 0.0).f2 == 0.0 and cl.normalized(law, 1.0).f2 == 0.0


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_laws_match_the_textbook_formulas(law):
    peaks = cl.peak_coefficients(law)
    for i in range(0, 1001):
        x = i / 1000
        got = cl.normalized(law, x)
        want = textbook(law, x)
        assert abs(got.f - want[0]) <= 3e-14, x  # the expanded form cancels: ~100 eps
        for k, peak in zip((1, 2, 3), peaks):
            assert abs(got[k] - want[k]) <= 1e-13 * peak, (x, k)


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_laws_are_point_symmetric(law):
    for i in range(0, 201):
        x = i / 200
        f = cl.normalized(law, x)
        g = cl.normalized(law, 1.0 - x)
        assert abs(f.f + g.f - 1.0) <= 4.5e-16  # two roundings
        assert f.f1 == pytest.approx(g.f1, abs=1e-13)
        assert f.f2 == pytest.approx(-g.f2, abs=1e-12)


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_derivatives_match_finite_differences(law):
    step = 1e-5
    peaks = cl.peak_coefficients(law)
    for i in range(1, 200):
        x = i / 200
        lo, hi = cl.normalized(law, x - step), cl.normalized(law, x + step)
        here = cl.normalized(law, x)
        for k in (1, 2, 3):
            derivative = (hi[k - 1] - lo[k - 1]) / (2 * step)
            assert abs(here[k] - derivative) <= 1e-8 * peaks[k - 1], (x, k)


def test_cycloidal_start_keeps_relative_accuracy():
    # x - sin(2 pi x)/(2 pi) ~ (2 pi)^2 x^3 / 6 for small x: exact to full relative accuracy
    for x in (1e-3, 1e-5, 1e-8, 0.1, 0.15):
        u = Fraction(TAU) * Fraction(x)
        series = sum((-1) ** k * u ** (2 * k + 3) / math.factorial(2 * k + 3) for k in range(12))
        exact = float(series / Fraction(TAU))
        assert cl.normalized("cycloidal", x).f == pytest.approx(exact, rel=4e-15), x


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_peak_coefficients_equal_numerical_maxima(law):
    n = 20000
    grid = [i / n for i in range(n + 1)]
    for k, closed in zip((1, 2, 3), cl.peak_coefficients(law)):
        values = [abs(cl.normalized(law, x)[k]) for x in grid]
        i = max(range(n + 1), key=values.__getitem__)
        dense = values[i]
        assert dense <= closed * (1 + 1e-14)
        assert dense == pytest.approx(closed, rel=1e-7)
        refined = golden_max(
            lambda x: abs(cl.normalized(law, x)[k]), grid[max(i - 1, 0)], grid[min(i + 1, n)]
        )
        assert abs(refined - closed) <= 1e-12 * closed, (law, k, refined, closed)


def test_peak_coefficients_closed_forms():
    assert cl.peak_coefficients("harmonic") == (math.pi / 2, math.pi**2 / 2, math.pi**3 / 2)
    assert cl.peak_coefficients("cycloidal") == (2.0, TAU, 4 * math.pi**2)
    p345 = cl.peak_coefficients("polynomial_345")
    assert p345.velocity == 1.875 and p345.jerk == 60.0
    assert p345.acceleration == pytest.approx(10 / math.sqrt(3), rel=1e-15)
    assert cl.normalized("polynomial_345", (3 - math.sqrt(3)) / 6).f2 == pytest.approx(
        p345.acceleration, rel=1e-14
    )
    p4567 = cl.peak_coefficients("polynomial_4567")
    assert p4567.velocity == 35 / 16 and p4567.jerk == 52.5
    x_star = (5 - math.sqrt(5)) / 10
    assert p4567.acceleration == pytest.approx(
        cl.normalized("polynomial_4567", x_star).f2, rel=1e-14
    )
    assert p4567.acceleration == pytest.approx(84 * math.sqrt(5) / 25, rel=1e-15)
    assert round(p4567.acceleration, 4) == 7.5132


def test_unknown_law_and_phase_out_of_range():
    with pytest.raises(MechanismError, match="law = 'trapezoidal' is not one of harmonic"):
        cl.normalized("trapezoidal", 0.5)
    with pytest.raises(MechanismError):
        cl.peak_coefficients("sine")
    for x in (-1e-9, 1.0 + 1e-12, math.nan):
        with pytest.raises(RangeError) as info:
            cl.normalized("cycloidal", x)
        assert info.value.name == "x"


# --- continuity at the segment ends -----------------------------------------------------------

BOUNDARY_PROFILE = dict(
    lift=0.008, rise_start=0.0, rise_angle=1.0, high_dwell_angle=0.5, return_angle=1.0
)  # boundaries at 0, 1, 1.5 and 2.5 rad, all exact


def _jumps(profile):
    """Largest |right - left| of (s, s1, s2, s3) over the four segment boundaries."""
    dwell_high = (profile.lift, 0.0, 0.0, 0.0)
    dwell_low = (0.0, 0.0, 0.0, 0.0)
    pairs = [
        (dwell_low, cl.segment_lift(profile, "rise", 0.0)),
        (cl.segment_lift(profile, "rise", 1.0), dwell_high),
        (dwell_high, cl.segment_lift(profile, "return", 0.0)),
        (cl.segment_lift(profile, "return", 1.0), dwell_low),
    ]
    return [max(abs(right[k] - left[k]) for left, right in pairs) for k in range(4)]


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_continuity_table_matches_the_jumps(law):
    profile = cl.check_profile(law, **BOUNDARY_PROFILE)
    jumps = _jumps(profile)
    scale = [profile.lift * cl.peak_coefficients(law)[k - 1] for k in (1, 2, 3)]
    continuous = [jumps[k] <= 1e-12 * scale[k - 1] for k in (1, 2, 3)]
    assert jumps[0] == 0.0  # the lift itself is always continuous
    # a derivative is continuous only if every lower one is (a jump makes an impulse above it)
    expected = cl.Continuity(continuous[0], continuous[0] and continuous[1], all(continuous))
    assert cl.CONTINUITY[law] == expected
    assert cl.CONTINUITY[law].velocity


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_cam_lift_shows_the_jumps_and_is_left_closed(law):
    profile = cl.check_profile(law, **BOUNDARY_PROFILE)
    lift = profile.lift
    for boundary, right in [
        (0.0, cl.segment_lift(profile, "rise", 0.0)),
        (1.0, (lift, 0.0, 0.0, 0.0)),
        (1.5, cl.segment_lift(profile, "return", 0.0)),
        (2.5, (0.0, 0.0, 0.0, 0.0)),
    ]:
        at = cl.cam_lift(profile, boundary)
        assert tuple(at) == pytest.approx(tuple(right), abs=1e-15)  # closed on the left
        before = cl.cam_lift(profile, boundary - 1e-9)
        after = cl.cam_lift(profile, boundary + 1e-9)
        for k, smooth in ((2, cl.CONTINUITY[law].acceleration), (3, cl.CONTINUITY[law].jerk)):
            if smooth:
                assert abs(after[k] - before[k]) <= 1e-6 * lift, (boundary, k)
    if law == "harmonic":  # acceleration jumps by lift pi^2 / (2 beta^2) at the rise start
        assert cl.cam_lift(profile, 0.0).s2 == pytest.approx(0.008 * math.pi**2 / 2, rel=1e-15)
        assert cl.cam_lift(profile, -1e-12).s2 == 0.0
        assert cl.cam_lift(profile, 1.0).s2 == 0.0
        assert cl.cam_lift(profile, 1.0 - 1e-12).s2 == pytest.approx(
            -0.008 * math.pi**2 / 2, rel=1e-9
        )


# --- profiles ---------------------------------------------------------------------------------


def test_check_profile_returns_floats():
    profile = cl.check_profile("cycloidal", 7e-3, -1, 1, 0, 2)
    assert profile == cl.CamProfile("cycloidal", 0.007, -1.0, 1.0, 0.0, 2.0)
    assert all(isinstance(v, float) for v in profile[1:])
    assert cl.DEFAULT_CAM_PROFILE == ("polynomial_345", 0.007, 0.0, 1.2, 0.1, 1.2)
    full = cl.check_profile("harmonic", 0.01, 0.0, 3.0, TAU - 6.0, 3.0)  # no low dwell
    assert full.rise_angle + full.high_dwell_angle + full.return_angle <= TAU


@pytest.mark.parametrize(
    "changes, name",
    [
        (dict(lift=0.0), "lift"),
        (dict(lift=-0.001), "lift"),
        (dict(lift=math.nan), "lift"),
        (dict(rise_start=math.inf), "rise_start"),
        (dict(rise_angle=0.0), "rise_angle"),
        (dict(return_angle=-0.2), "return_angle"),
        (dict(high_dwell_angle=-0.1), "high_dwell_angle"),
        (dict(rise_angle="steep"), "rise_angle"),
    ],
)
def test_check_profile_rejects_bad_values(changes, name):
    values = dict(
        law="harmonic",
        lift=0.007,
        rise_start=0.0,
        rise_angle=1.2,
        high_dwell_angle=0.1,
        return_angle=1.2,
    )
    values.update(changes)
    with pytest.raises(RangeError) as info:
        cl.check_profile(**values)
    assert info.value.name == name
    assert name in str(info.value)


def test_check_profile_rejects_more_than_one_revolution():
    with pytest.raises(RangeError) as info:
        cl.check_profile("cycloidal", 0.007, 0.0, 3.0, 0.5, 3.0)
    text = str(info.value)
    assert info.value.value == 6.5
    assert "rise_angle + high_dwell_angle + return_angle = 6.5 rad" in text
    assert repr(TAU) in text and "one camshaft revolution" in text
    with pytest.raises(MechanismError, match="law = 'flat'"):
        cl.check_profile("flat", 0.007, 0.0, 1.0, 0.0, 1.0)


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_dwells_and_ranges_over_a_revolution(law):
    profile = cl.check_profile(law, 0.009, 0.4, 1.1, 0.3, 1.4)
    for i in range(720):
        angle = 0.4 + TAU * (i + 0.5) / 720
        local = angle - 0.4
        s = cl.cam_lift(profile, angle)
        assert 0.0 <= s.s <= 0.009
        if 1.1 <= local < 1.4:
            assert s == (0.009, 0.0, 0.0, 0.0)
        elif local >= 2.8:
            assert s == (0.0, 0.0, 0.0, 0.0)
        elif local < 1.1:
            assert s.s1 >= 0.0
        else:
            assert s.s1 <= 0.0


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_lift_derivatives_match_finite_differences(law):
    profile = cl.check_profile(law, 0.007, -0.3, 1.2, 0.1, 1.5)
    peaks = cl.peak_coefficients(law)
    step = 1e-6
    for i in range(300):
        angle = -0.3 + 2.8 * (i + 0.5) / 300
        if min(abs(angle + 0.3 - edge) for edge in (0.0, 1.2, 1.3, 2.8)) < 1e-4:
            continue
        lo, hi = cl.cam_lift(profile, angle - step), cl.cam_lift(profile, angle + step)
        here = cl.cam_lift(profile, angle)
        for k in (1, 2, 3):
            scale = 0.007 * peaks[k - 1] / 1.2**k
            assert abs(here[k] - (hi[k - 1] - lo[k - 1]) / (2 * step)) <= 1e-6 * scale, (angle, k)


def test_return_end_keeps_relative_accuracy():
    profile = cl.check_profile("polynomial_345", 0.007, 0.0, 1.0, 0.0, 1.0)
    # 1 - f(x) = f(1 - x) near the closing: lift * f(1e-6) with f(y) ~ 10 y^3
    y = 2.0**-20
    s = cl.segment_lift(profile, "return", 1.0 - y).s
    assert s == pytest.approx(0.007 * (10 * y**3 - 15 * y**4 + 6 * y**5), rel=1e-14)


def test_periodicity_over_revolutions():
    profile = cl.check_profile("polynomial_4567", 0.006, 1.0, 1.3, 0.2, 1.3)
    s1_max = 0.006 * cl.peak_coefficients("polynomial_4567").velocity / 1.3
    for i in range(50):
        angle = 1.0 + TAU * i / 50 + 0.01
        base = cl.cam_lift(profile, angle)
        for k in (-7, -1, 1, 3, 1000):
            shifted = cl.cam_lift(profile, angle + k * TAU)
            assert abs(shifted.s - base.s) <= s1_max * 4e-16 * abs(angle + k * TAU) + 1e-18


def test_angle_reduction_after_a_million_revolutions():
    profile = cl.check_profile("cycloidal", 0.007, 0.37, 1.2, 0.1, 1.2)
    origin = profile._replace(rise_start=0.0)
    pi = Fraction(Decimal("3.14159265358979323846264338327950288419716939937510582097494"))
    s1_max = 0.007 * 2.0 / 1.2
    s2_max = 0.007 * TAU / 1.2**2
    for revolutions in (10, 1000, 10**6, 10**8):
        for offset in (0.1, 0.5, 0.9, 1.27, 2.0):
            angle = offset + revolutions * TAU  # a float: its exact value is the input
            exact = (Fraction(angle) - Fraction(0.37)) % (2 * pi)
            want = cl.cam_lift(origin, float(exact))
            got = cl.cam_lift(profile, angle)
            assert abs(got.s - want.s) <= 1e-15 * angle * s1_max, (revolutions, offset)
            assert abs(got.s1 - want.s1) <= 1e-15 * angle * s2_max
    assert cl.reduce_angle(-1e-300) == 0.0
    assert cl.reduce_angle(-TAU) == 0.0
    assert 0.0 <= cl.reduce_angle(-3.0) < TAU


def test_follower_motion_is_the_time_derivative():
    profile = cl.check_profile("polynomial_345", 0.007, 0.0, 1.2, 0.1, 1.2)
    w0, alpha = 150.0, 400.0

    def at(t):
        return cl.follower_motion(profile, 0.2 + w0 * t + alpha * t * t / 2, w0 + alpha * t, alpha)

    step = 1e-7
    for i in range(1, 60):
        t = 0.00025 * i
        if abs((0.2 + w0 * t + alpha * t * t / 2) - 1.2) < 1e-3:
            continue
        here, lo, hi = at(t), at(t - step), at(t + step)
        assert abs(here.velocity - (hi.lift - lo.lift) / (2 * step)) <= 1e-6 * 2.0
        assert abs(here.acceleration - (hi.velocity - lo.velocity) / (2 * step)) <= 1e-6 * 1e3
    with pytest.raises(RangeError) as info:
        cl.follower_motion(profile, 0.1, math.nan, 0.0)
    assert info.value.name == "camshaft_speed"


# --- valve-train geometry ---------------------------------------------------------------------


def test_default_geometry_figures():
    assert vt.check_geometry(G) == G
    phi0, y3_closed = vt.rest_position(G)
    assert math.degrees(phi0) == pytest.approx(7.206, abs=1e-3)
    assert LV / LT == pytest.approx(1.5, rel=1e-15)
    assert vt.rocker_ratio(G) == pytest.approx(1.5, rel=0.01)
    lift = vt.forward(G, 0.007, 0.0, 0.0).valve_lift
    assert 0.0104 < lift < 0.0106
    assert vt.forward(G, 0.0, 0.0, 0.0).valve_lift == 0.0
    # the pushrod is nearly vertical at rest: T_x small against L1
    assert abs(A - LT * math.cos(phi0)) < 0.003


def test_rocker_angle_is_the_closed_form():
    for i in range(50):
        lift = -0.02 + 0.05 * i / 50
        y1 = R_B + lift
        u, w = A, B - y1
        k = (u * u + w * w + LT * LT - L1 * L1) / (2 * LT)
        big_r = math.hypot(u, w)
        phi = vt.rocker_from_tappet(G, lift)
        assert phi == pytest.approx(math.atan2(w, u) - math.acos(k / big_r), abs=1e-13)
        tx, ty = A - LT * math.cos(phi), B - LT * math.sin(phi)
        assert math.hypot(tx, ty - y1) == pytest.approx(L1, rel=1e-15)
        assert ty > y1  # pushrod below T


def test_working_range_of_the_defaults():
    work = vt.working_range(G)
    low, high = vt.tappet_lift_range(G)
    assert work.tappet_low == low  # the pushrod stretched in line with the tappet arm
    # the top end: valve link in line with the valve arm, cos(phi) = (c - a) / (lv + L3)
    phi = -math.acos((C - A) / (LV + L3))
    assert vt.rocker_from_tappet(G, work.tappet_high) == pytest.approx(phi, abs=1e-12)
    assert 0.029 < work.tappet_high < 0.0292 < high
    assert work.valve_high == pytest.approx(vt.valve_lift_range(G)[1], rel=1e-12)
    # the valve lift peaks there: its rate with respect to the tappet lift vanishes
    assert abs(vt.forward(G, work.tappet_high * (1 - 1e-7), 1.0, 0.0).valve_velocity) < 1e-3
    with pytest.raises(SingularConfiguration):
        vt.inverse(G, work.valve_high, 0.1, 0.0)


def test_position_round_trips():
    work = vt.working_range(G)
    for i in range(1, 80):
        lift = work.tappet_low + (work.tappet_high - work.tappet_low) * i / 80
        phi = vt.rocker_from_tappet(G, lift)
        assert vt.tappet_from_rocker(G, phi) - R_B == pytest.approx(lift, abs=1e-15)
        y3 = vt.valve_from_rocker(G, phi)
        vx, vy = A + LV * math.cos(phi), B + LV * math.sin(phi)
        assert math.hypot(vx - C, vy - y3) == pytest.approx(L3, rel=1e-15)
        assert y3 < vy
        assert vt.rocker_from_valve(G, y3) == pytest.approx(phi, abs=1e-13)


@pytest.mark.parametrize(
    "field, value, name",
    [
        ("cam_base_radius", 0.0, "cam_base_radius"),
        ("pushrod_length", 0.1, "pushrod_length"),
        ("pushrod_length", 0.3, "pushrod_length"),
        ("pushrod_length", -1.0, "pushrod_length"),
        ("rocker_pivot_x", -0.01, "rocker_pivot_x"),
        ("rocker_pivot_y", 0.01, "rocker_pivot_y"),
        ("tappet_arm", 0.0, "tappet_arm"),
        ("valve_arm", math.nan, "valve_arm"),
        ("valve_axis_x", 0.02, "valve_axis_x"),
        ("valve_link_length", 1e-4, "valve_link_length"),
        ("valve_link_length", math.inf, "valve_link_length"),
    ],
)
def test_check_geometry_names_the_parameter(field, value, name):
    with pytest.raises(RangeError) as info:
        vt.check_geometry(G._replace(**{field: value}))
    assert info.value.name == name
    assert name in str(info.value) and repr(float(value)) in str(info.value)


def test_pushrod_length_interval_is_tight():
    w0 = B - R_B
    low, high = abs(math.hypot(A, w0) - LT), math.hypot(A, w0 + LT)
    vt.check_geometry(G._replace(pushrod_length=low * (1 + 1e-9)))
    for bad in (low, high):
        with pytest.raises(RangeError, match=re.escape(f"({low!r}, {high!r})")):
            vt.check_geometry(G._replace(pushrod_length=bad))
    # just below the top the tappet arm points straight down (phi0 -> -pi/2): the valve
    # link cannot then reach the valve axis below the arm, and the valve side says so
    with pytest.raises(RangeError) as info:
        vt.check_geometry(G._replace(pushrod_length=high * (1 - 1e-9)))
    assert info.value.name == "valve_link_length"


def test_tappet_lift_outside_range_and_dead_centres():
    low, high = vt.tappet_lift_range(G)
    assert low < -0.02 and 0.034 < high < 0.035
    for lift in (high * (1 + 1e-12) + 1e-15, low - 1e-6, 1.0):
        with pytest.raises(RangeError) as info:
            vt.forward(G, lift, 0.0, 0.0)
        assert info.value.name == "tappet_lift"
        assert f"[{low!r}, {high!r}]" in str(info.value)
    with pytest.raises(SingularConfiguration, match="pushrod and the tappet arm in line .folded"):
        vt.rocker_from_tappet(G, high)
    with pytest.raises(SingularConfiguration, match="in line .stretched out"):
        vt.forward(G, low, 0.1, 0.0)
    # just inside, the angle is finite and the rate large
    near = vt.forward(G, high - 1e-9, 0.1, 0.0)
    assert abs(near.rocker_angular_velocity) > 100.0


def test_valve_side_ranges_and_dead_centres():
    low, high = vt.valve_position_range(G)
    with pytest.raises(SingularConfiguration, match="valve link and the valve arm in line"):
        vt.rocker_from_valve(G, low)
    with pytest.raises(SingularConfiguration, match="valve link and the valve arm in line"):
        vt.rocker_from_valve(G, high)
    with pytest.raises(RangeError) as info:
        vt.rocker_from_valve(G, high + 1e-6)
    assert info.value.name == "valve_position" and repr(high) in str(info.value)
    lift_low, lift_high = vt.valve_lift_range(G)
    with pytest.raises(RangeError) as info:
        vt.inverse(G, lift_high + 1e-6, 0.0, 0.0)
    assert info.value.name == "valve_position"
    phi_low, phi_high = vt.rocker_angle_range(G)
    assert phi_low == -phi_high and 1.7 < phi_high < 1.8
    with pytest.raises(SingularConfiguration, match="perpendicular to the valve axis"):
        vt.valve_from_rocker(G, phi_high)
    with pytest.raises(RangeError) as info:
        vt.valve_from_rocker(G, -2.0)
    assert info.value.name == "rocker_angle"
    assert vt.tappet_rocker_angle_range(G) == (-math.inf, math.inf)


def test_tappet_from_rocker_singular_when_pushrod_horizontal():
    short = G._replace(pushrod_length=0.05, rocker_pivot_y=R_B + 0.06)
    vt.check_geometry(short)
    low, high = vt.tappet_rocker_angle_range(short)
    assert high == pytest.approx(math.acos((A - 0.05) / LT), rel=1e-15)
    with pytest.raises(SingularConfiguration, match="pushrod perpendicular to the tappet axis"):
        vt.tappet_from_rocker(short, high)
    with pytest.raises(RangeError):
        vt.tappet_from_rocker(short, high + 1e-3)


# --- rates --------------------------------------------------------------------------------------


def _tappet_path(t):
    return 0.004 + 0.003 * math.sin(t), 0.003 * math.cos(t), -0.003 * math.sin(t)


def test_forward_rates_match_finite_differences():
    step = 1e-5
    for i in range(63):
        t = 0.1 * i
        m = vt.forward(G, *_tappet_path(t))
        lo, hi = vt.forward(G, *_tappet_path(t - step)), vt.forward(G, *_tappet_path(t + step))
        fd = lambda k: (hi[k] - lo[k]) / (2 * step)  # noqa: E731
        assert abs(m.rocker_angular_velocity - fd(3)) <= 1e-9 * 0.11
        assert abs(m.rocker_angular_acceleration - fd(4)) <= 1e-9 * 0.11
        assert abs(m.valve_velocity - fd(6)) <= 1e-11 * 1.0
        assert abs(m.valve_acceleration - fd(7)) <= 1e-11 * 1.0


def test_inverse_rates_match_finite_differences():
    step = 1e-5

    def path(t):
        return 0.006 + 0.005 * math.sin(t), 0.005 * math.cos(t), -0.005 * math.sin(t)

    for i in range(63):
        t = 0.1 * i
        m = vt.inverse(G, *path(t))
        lo, hi = vt.inverse(G, *path(t - step)), vt.inverse(G, *path(t + step))
        assert abs(m.tappet_velocity - (hi.tappet_lift - lo.tappet_lift) / (2 * step)) <= 1e-11
        assert (
            abs(m.tappet_acceleration - (hi.tappet_velocity - lo.tappet_velocity) / (2 * step))
            <= 1e-11
        )
        assert (
            abs(
                m.rocker_angular_acceleration
                - (hi.rocker_angular_velocity - lo.rocker_angular_velocity) / (2 * step)
            )
            <= 1e-9
        )


def test_forward_inverse_round_trip():
    work = vt.working_range(G)
    for i in range(1, 101):
        lift = work.tappet_low + (work.tappet_high - work.tappet_low) * i / 101
        m = vt.forward(G, lift, 0.3 - 0.01 * i, 2000.0 * math.cos(i))
        back = vt.inverse(G, m.valve_lift, m.valve_velocity, m.valve_acceleration)
        assert abs(back.tappet_lift - lift) <= 1e-12 * 0.03
        assert back.tappet_velocity == pytest.approx(m.tappet_velocity, rel=1e-12, abs=1e-15)
        assert back.tappet_acceleration == pytest.approx(
            m.tappet_acceleration, rel=1e-12, abs=1e-12
        )
        for k in (3, 4, 5):
            assert back[k] == pytest.approx(m[k], rel=1e-12, abs=1e-14)


def _composed_forward(g, lift, velocity, acceleration):
    """forward's chain through the checked pieces motion_from_tappet writes out."""
    phi = vt.rocker_from_tappet(g, lift)
    y3 = vt.valve_from_rocker(g, phi)
    y1 = g.cam_base_radius + lift
    omega, alpha, y3_rate, y3_accel = vt._chain_rates(
        vt._tappet_vectors(g, phi, y1),
        vt._valve_vectors(g, phi, y3),
        velocity,
        acceleration,
        lambda: "pushrod and tappet arm in line",
        lambda: "valve link horizontal",
    )
    closed = vt.rest_position(g)[1]
    return (phi, omega, alpha, closed - y3, -y3_rate, -y3_accel)


@PROPERTY
@given(
    fraction=st.floats(-0.1, 1.1),
    velocity=st.floats(-10.0, 10.0),
    acceleration=st.floats(-1e5, 1e5),
)
def test_motion_from_tappet_is_the_checked_chain_to_the_bit(fraction, velocity, acceleration):
    """The written-out chain gives the checked functions' results bit for bit inside the
    tappet range, and their error (type and message) outside it or at a dead centre."""
    low, high = vt.tappet_lift_range(G)
    lift = low + (high - low) * fraction
    closed = vt.rest_position(G)[1]
    try:
        want = _composed_forward(G, lift, velocity, acceleration)
    except (RangeError, SingularConfiguration) as error:
        with pytest.raises(type(error)) as info:
            vt.motion_from_tappet(G, closed, lift, velocity, acceleration)
        assert str(info.value) == str(error)
        return
    got = vt.motion_from_tappet(G, closed, lift, velocity, acceleration)
    assert got[:3] == (lift, velocity, acceleration)
    assert got[3:] == want


def test_non_finite_rates_are_refused():
    for args, name in [
        ((0.001, math.nan, 0.0), "tappet_velocity"),
        ((0.001, 0.0, math.inf), "tappet_acceleration"),
    ]:
        with pytest.raises(RangeError) as info:
            vt.forward(G, *args)
        assert info.value.name == name
    with pytest.raises(RangeError) as info:
        vt.inverse(G, math.nan, 0.0, 0.0)
    assert info.value.name == "valve_lift"


# --- stdlib against numpy -------------------------------------------------------------------


def _close_columns(got, want, rtol):
    for key in ref.MOTION_FIELDS:
        g, w = np.asarray(got[key]), np.asarray(want[key])
        scale = float(np.max(np.abs(w)))
        assert np.all(np.abs(g - w) <= rtol * np.maximum(np.abs(w), scale)), key


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_stdlib_matches_numpy_over_revolutions(law):
    args = (law, 0.0075, -0.8, 1.1, 0.25, 1.3)
    profile = cl.check_profile(*args)
    angles = -0.8 + TAU * (np.arange(1440) + 0.3) / 1440 + np.repeat([0.0, 5 * TAU], 720)
    for speed, accel in ((300.0, 0.0), (-80.0, 1500.0)):
        s, s1, s2 = ref.cam_lift(*args, angles)
        numpy_tappet = (s, s1 * speed, s2 * speed**2 + s1 * accel)
        rows = [vt.forward(G, *cl.follower_motion(profile, a, speed, accel)) for a in angles]
        mine = {key: np.array([r[k] for r in rows]) for k, key in enumerate(ref.MOTION_FIELDS)}
        _close_columns(mine, ref.forward(GD, *numpy_tappet), 1e-12)
        back = [vt.inverse(G, r.valve_lift, r.valve_velocity, r.valve_acceleration) for r in rows]
        mine_back = {key: np.array([r[k] for r in back]) for k, key in enumerate(ref.MOTION_FIELDS)}
        numpy_back = ref.inverse(
            GD, mine["valve_lift"], mine["valve_velocity"], mine["valve_acceleration"]
        )
        _close_columns(mine_back, numpy_back, 1e-12)
        _close_columns(mine_back, mine, 1e-12)


def test_numpy_revolution_helper_and_cam_law_agree():
    cols = ref.revolution(GD, "cycloidal", 0.007, 0.0, 1.2, 0.1, 1.2, [0.3, 1.25, 2.0, 4.0], 100.0)
    profile = cl.check_profile("cycloidal", 0.007, 0.0, 1.2, 0.1, 1.2)
    for i, angle in enumerate([0.3, 1.25, 2.0, 4.0]):
        m = vt.forward(G, *cl.follower_motion(profile, angle, 100.0, 0.0))
        assert cols["valve_lift"][i] == pytest.approx(m.valve_lift, rel=1e-12, abs=1e-16)
        assert cols["valve_acceleration"][i] == pytest.approx(
            m.valve_acceleration, rel=1e-12, abs=1e-10
        )


# --- contact force and float speed ------------------------------------------------------------

MASS, STIFFNESS, PRELOAD = 0.1, 50e3, 300.0


def test_contact_force_is_m_a_plus_k_x_plus_f0():
    assert vt.contact_force(0.1, 50e3, 300.0, 0.01, -2000.0) == pytest.approx(
        0.1 * -2000.0 + 50e3 * 0.01 + 300.0, rel=1e-15
    )
    for args, name in [
        ((0.0, 1.0, 1.0, 0.0, 0.0), "valve_mass"),
        ((0.1, -1.0, 1.0, 0.0, 0.0), "spring_stiffness"),
        ((0.1, 1.0, -5.0, 0.0, 0.0), "spring_preload"),
        ((0.1, 1.0, 1.0, math.nan, 0.0), "valve_lift"),
    ]:
        with pytest.raises(RangeError) as info:
            vt.contact_force(*args)
        assert info.value.name == name


def _min_contact_force(profile, speed, n=6000):
    """Smallest contact force over a revolution at constant speed, plus the segment ends."""
    forces = []
    for i in range(n):
        angle = profile.rise_start + TAU * i / n
        m = vt.forward(G, *cl.follower_motion(profile, angle, speed, 0.0))
        forces.append(
            vt.contact_force(MASS, STIFFNESS, PRELOAD, m.valve_lift, m.valve_acceleration)
        )
    for segment in cl.SEGMENTS:
        for x in (0.0, 1.0):
            s, s1, s2, _ = cl.segment_lift(profile, segment, x)
            m = vt.forward(G, s, s1 * speed, s2 * speed**2)
            forces.append(
                vt.contact_force(MASS, STIFFNESS, PRELOAD, m.valve_lift, m.valve_acceleration)
            )
    return min(forces)


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_float_speed_separates_contact_from_float(law):
    profile = cl.check_profile(law, 0.007, 0.2, 1.2, 0.1, 1.2)
    speed, where = vt.float_speed(G, profile, MASS, STIFFNESS, PRELOAD)
    assert 300.0 < speed < 600.0
    assert 0.2 <= where <= 0.2 + 2.5
    assert _min_contact_force(profile, 0.99 * speed) > 0.0
    assert _min_contact_force(profile, 1.01 * speed) < 0.0
    # at the reported angle the force vanishes at exactly w_float (a one-sided limit for harmonic)
    local = where - 0.2
    segment, x = ("rise", local / 1.2) if local <= 1.2 else ("return", (local - 1.3) / 1.2)
    s, s1, s2, _ = cl.segment_lift(profile, segment, x)
    m = vt.forward(G, s, s1 * speed, s2 * speed**2)
    force = vt.contact_force(MASS, STIFFNESS, PRELOAD, m.valve_lift, m.valve_acceleration)
    assert abs(force) <= 1e-9 * PRELOAD


def test_float_speed_default_cam_and_scaling():
    speed, where = vt.float_speed(G, cl.DEFAULT_CAM_PROFILE, MASS, STIFFNESS, PRELOAD)
    assert speed == pytest.approx(432.2334, rel=1e-6)
    engine_rpm = 2 * speed * 60 / TAU
    assert 8200 < engine_rpm < 8300
    # 4x the spring gives exactly 2x the speed (power-of-two scaling is exact in floats)
    quad = vt.float_speed(G, cl.DEFAULT_CAM_PROFILE, MASS, 4 * STIFFNESS, 4 * PRELOAD)
    assert quad.camshaft_speed == 2 * speed and quad.camshaft_angle == where
    # the harmonic law's deceleration peaks at the very end of the rise (a one-sided limit)
    harmonic = cl.DEFAULT_CAM_PROFILE._replace(law="harmonic")
    assert vt.float_speed(G, harmonic, MASS, STIFFNESS, PRELOAD).camshaft_angle == 1.2
    # no spring at all: the valve leaves the rocker at any speed
    assert vt.float_speed(G, cl.DEFAULT_CAM_PROFILE, MASS, 0.0, 0.0).camshaft_speed == 0.0
    with pytest.raises(RangeError) as info:
        vt.float_speed(G, cl.DEFAULT_CAM_PROFILE, MASS, STIFFNESS, PRELOAD, samples=3)
    assert info.value.name == "samples"


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_float_speed_of_a_cam_law_driving_the_valve_directly(law):
    # valve_law: L = s. With k = 0 the ratio is F0 beta^2 / (m lift |f2|), smallest at the
    # peak deceleration (e.g. x = 1/2 + sqrt(3)/6 of the 3-4-5 rise, or its mirror point in
    # the return): w^2 = F0 beta^2 / (m lift peak_acceleration)
    profile = cl.check_profile(law, 0.007, 0.0, 1.2, 0.1, 1.2)
    speed, where = vt.float_speed(G, profile, MASS, 0.0, PRELOAD, valve_law=True)
    peak = cl.peak_coefficients(law).acceleration
    assert speed == pytest.approx(math.sqrt(PRELOAD * 1.2**2 / (MASS * 0.007 * peak)), rel=1e-12)
    # the harmonic law's peak is the one-sided limit at the end of the rise (or the return start)
    s, s1, s2, _ = (
        cl.segment_lift(profile, "rise", 1.0) if where == 1.2 else cl.cam_lift(profile, where)
    )
    assert s2 == pytest.approx(-0.007 * peak / 1.2**2, rel=1e-9)
    # with the spring stiffness the rocker geometry no longer matters either
    direct = vt.float_speed(G, profile, MASS, STIFFNESS, PRELOAD, valve_law=True)
    other = G._replace(valve_arm=0.056)
    assert vt.float_speed(other, profile, MASS, STIFFNESS, PRELOAD, valve_law=True) == direct


def test_float_speed_is_the_dense_minimum():
    profile = cl.DEFAULT_CAM_PROFILE
    speed = vt.float_speed(G, profile, MASS, STIFFNESS, PRELOAD).camshaft_speed
    s, s1, s2 = ref.cam_lift(*profile, np.linspace(0.0, 2.5, 200001))
    cols = ref.forward(GD, s, s1, s2)
    decel = cols["valve_acceleration"] < 0.0
    dense = np.sqrt(
        (STIFFNESS * cols["valve_lift"][decel] + PRELOAD)
        / (MASS * -cols["valve_acceleration"][decel])
    )
    assert speed <= dense.min() * (1 + 1e-12)
    assert speed == pytest.approx(dense.min(), rel=1e-9)


# --- properties ---------------------------------------------------------------------------------


@st.composite
def profiles(draw):
    return cl.check_profile(
        draw(st.sampled_from(cl.CAM_LAWS)),
        draw(st.floats(1e-3, 0.012)),
        draw(st.floats(-50.0, 50.0)),
        draw(st.floats(0.2, 2.5)),
        draw(st.floats(0.0, 1.2)),
        draw(st.floats(0.2, 2.5)),
    )


@PROPERTY
@given(profiles(), st.floats(0.0, 1.0), st.integers(-1000, 1000))
def test_property_lift_bounded_periodic_and_equal_to_numpy(profile, phase, turns):
    angle = profile.rise_start + phase * TAU
    s = cl.cam_lift(profile, angle)
    assert 0.0 <= s.s <= profile.lift
    shifted = cl.cam_lift(profile, angle + turns * TAU)
    s1_max = (
        profile.lift
        * cl.peak_coefficients(profile.law).velocity
        / min(profile.rise_angle, profile.return_angle)
    )
    assert abs(shifted.s - s.s) <= s1_max * 1e-15 * (abs(angle) + abs(turns) * TAU) + 1e-18
    n_s, n_s1, n_s2 = ref.cam_lift(*profile, angle)
    peaks = cl.peak_coefficients(profile.law)
    beta = min(profile.rise_angle, profile.return_angle)
    assert abs(float(n_s) - s.s) <= 1e-12 * profile.lift
    assert abs(float(n_s1) - s.s1) <= 1e-12 * profile.lift * peaks.velocity / beta
    assert abs(float(n_s2) - s.s2) <= 1e-12 * profile.lift * peaks.acceleration / beta**2


@PROPERTY
@given(profiles(), st.floats(0.0, 1.0), st.floats(-400.0, 400.0), st.floats(-1e4, 1e4))
def test_property_valve_train_round_trip_and_numpy(profile, phase, speed, accel):
    angle = profile.rise_start + phase * TAU
    tappet = cl.follower_motion(profile, angle, speed, accel)
    m = vt.forward(G, *tappet)
    assert m.valve_lift >= -1e-17 and m.valve_lift <= 1.6 * profile.lift
    back = vt.inverse(G, m.valve_lift, m.valve_velocity, m.valve_acceleration)
    assert abs(back.tappet_lift - tappet.lift) <= 1e-12 * profile.lift
    v_scale = abs(tappet.velocity) + 1e-12
    assert abs(back.tappet_velocity - tappet.velocity) <= 1e-12 * v_scale
    a_scale = abs(tappet.acceleration) + tappet.velocity**2 / 0.028 + 1e-12
    assert abs(back.tappet_acceleration - tappet.acceleration) <= 1e-12 * a_scale
    numpy_m = ref.forward(GD, *tappet)
    assert abs(float(numpy_m["valve_lift"]) - m.valve_lift) <= 1e-12 * profile.lift
    assert abs(float(numpy_m["valve_velocity"]) - m.valve_velocity) <= 1e-12 * 1.6 * v_scale
    assert abs(float(numpy_m["valve_acceleration"]) - m.valve_acceleration) <= 1e-12 * 1.6 * a_scale


@PROPERTY
@given(st.sampled_from(cl.CAM_LAWS), st.floats(2.1, 3.1), st.floats(0.0, 2.0), st.floats(2.1, 3.1))
def test_property_over_long_profiles_are_refused(law, rise, dwell, ret):
    total = rise + dwell + ret
    if total <= TAU:
        assert cl.check_profile(law, 0.005, 0.0, rise, dwell, ret).law == law
        return
    with pytest.raises(RangeError) as info:
        cl.check_profile(law, 0.005, 0.0, rise, dwell, ret)
    assert repr(total) in str(info.value) and repr(TAU) in str(info.value)


def test_contact_lost_needs_a_force_below_rounding_of_its_terms():
    # a = -(k x + F0) / m exactly balances the spring: zero force up to rounding, which is
    # a touching contact, not a float, whatever sign the last bits give the sum
    lift = 0.0071
    balance = -(STIFFNESS * lift + PRELOAD) / MASS
    scale = STIFFNESS * lift + PRELOAD
    for accel in (balance, np.nextafter(balance, 0.0), np.nextafter(balance, -np.inf)):
        force = vt.contact_force(MASS, STIFFNESS, PRELOAD, lift, accel)
        assert abs(force) <= 1e-12 * scale
        assert not vt.contact_lost(MASS, STIFFNESS, PRELOAD, lift, accel)
    pulled = balance * (1.0 + 1e-6)  # the rocker would have to pull by ~1e-6 of the terms
    assert vt.contact_force(MASS, STIFFNESS, PRELOAD, lift, pulled) < -1e-7 * scale
    assert vt.contact_lost(MASS, STIFFNESS, PRELOAD, lift, pulled)
    assert not vt.contact_lost(MASS, STIFFNESS, PRELOAD, lift, balance * (1.0 - 1e-6))


@pytest.mark.parametrize("law", cl.CAM_LAWS)
def test_motion_function_is_follower_motion(law):
    # The model's per-step evaluation (constants worked out once, no checks) gives
    # follower_motion's numbers in every segment, at the boundaries and over revolutions.
    profiles = [
        cl.check_profile(law, 0.007, 0.0, 1.2, 0.1, 1.2),
        cl.check_profile(law, 0.01, -0.7, 2.0, 0.0, 2.0),
    ]
    for profile in profiles:
        motion = cl.motion_function(profile)
        edges = [
            profile.rise_start + offset
            for offset in (
                0.0,
                profile.rise_angle,
                profile.rise_angle + profile.high_dwell_angle,
                profile.rise_angle + profile.high_dwell_angle + profile.return_angle,
            )
        ]
        angles = list(np.linspace(-20.0, 20.0, 4001)) + edges + [e - 1e-12 for e in edges]
        for angle in angles:
            for speed, acceleration in ((157.0, 0.0), (-40.0, 350.0)):
                expected = cl.follower_motion(profile, angle, speed, acceleration)
                assert motion(angle, speed, acceleration) == pytest.approx(
                    tuple(expected), rel=1e-15, abs=1e-300
                )


def test_motion_function_names_a_non_finite_input():
    motion = cl.motion_function(cl.DEFAULT_CAM_PROFILE)
    with pytest.raises(RangeError, match="camshaft_speed"):
        motion(0.3, math.nan, 0.0)
