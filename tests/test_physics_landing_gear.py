"""Landing-gear kinematics (mechanisms.md section 1) against the coursework and closed forms.

Layers: coursework design numbers; derivatives against finite differences; round trips between
the two drivers; range and singularity errors; property tests over random geometry; accuracy
next to the singular piston lengths against a 50-digit ``decimal`` reference.
"""

import math
from decimal import Decimal, localcontext

import pytest
from hypothesis import given, settings, assume
from hypothesis import strategies as st

from mechfmu.runtime.physics import landing_gear as lg
from mechfmu.runtime.errors import MechanismError, RangeError, SingularConfiguration

FOOT = 0.3048
GEOMETRY = lg.DEFAULT_GEOMETRY
D, H, THETA_1 = GEOMETRY
X_RETRACTED = 1.25 * FOOT
X_EXTENDED = 2.0 * FOOT
LOW, HIGH = abs(H - D), H + D

PROPERTY = settings(derandomize=True, max_examples=200, deadline=None)


def relative_error(got, expected):
    return abs(got - expected) / abs(expected)


# --- coursework design --------------------------------------------------------------------


def test_foot_is_exact():
    assert lg.FOOT == FOOT
    assert lg.COURSEWORK_RETRACTED_LENGTH == X_RETRACTED
    assert lg.COURSEWORK_EXTENDED_LENGTH == X_EXTENDED
    assert lg.COURSEWORK_STROKE_TIME == 3.0


def test_design_geometry_matches_coursework_digits():
    g = lg.design_geometry(X_RETRACTED, X_EXTENDED)
    assert g == GEOMETRY
    assert round(g.attachment_distance / FOOT, 5) == 0.64361
    assert round(g.pivot_height / FOOT, 4) == 1.4060
    assert round(g.start_angle, 4) == 1.0953
    assert round(math.degrees(g.start_angle), 2) == 62.76


def test_design_geometry_solves_the_coursework_quadratic():
    d_ft = D / FOOT
    # d^2 + 1.25 d - 1.21875 = 0 (feet), the coursework's design equation
    assert abs(d_ft * d_ft + 1.25 * d_ft - 1.21875) < 1e-14
    # h^2 = d^2 + x_r^2 (piston perpendicular to d when retracted)
    assert relative_error(H * H, D * D + X_RETRACTED**2) < 1e-15
    # theta_1 = atan(x_r / d), not the coursework's arcsin(1.25 / 0.64361) (argument > 1)
    assert relative_error(THETA_1, math.atan(X_RETRACTED / D)) < 1e-15
    assert 1.25 / 0.64361 > 1.0


def test_design_geometry_in_feet_is_scale_invariant():
    g_ft = lg.design_geometry(1.25, 2.0)
    assert relative_error(g_ft.attachment_distance * FOOT, D) < 1e-15
    assert relative_error(g_ft.pivot_height * FOOT, H) < 1e-15
    assert g_ft.start_angle == pytest.approx(THETA_1, rel=1e-15)


def test_angle_at_retracted_and_extended_lengths():
    retracted = lg.gear_motion(X_RETRACTED, 0.1, 0.0, D, H)
    extended = lg.gear_motion(X_EXTENDED, 0.1, 0.0, D, H)
    assert abs(retracted.angle - THETA_1) < 1e-14
    assert abs(extended.angle - (THETA_1 + math.pi / 2)) < 1e-14


def test_constant_piston_speed_reaches_dead_centre_shortly_after_3_s():
    # 0.25 ft/s from 1.25 ft: x = 2 ft at t = 3 s, x = h + d a little later (spec section 1)
    t_dead = ((H + D) / FOOT - 1.25) / 0.25
    assert 3.0 < t_dead < 3.3
    assert round((H + D) / FOOT, 4) == 2.0496


@pytest.mark.parametrize(
    "retracted, extended, name",
    [
        (0.0, 0.6, "retracted_length"),
        (-0.3, 0.6, "retracted_length"),
        (math.nan, 0.6, "retracted_length"),
        (0.3, math.inf, "extended_length"),
        (0.3, 0.3, "extended_length"),
        (0.6, 0.3, "extended_length"),
    ],
)
def test_design_geometry_rejects_invalid_lengths(retracted, extended, name):
    with pytest.raises(RangeError) as info:
        lg.design_geometry(retracted, extended)
    assert info.value.name == name
    assert name in str(info.value)


def test_check_geometry():
    assert lg.check_geometry(D, H) == (D, H)
    for d, h, name in [
        (0.0, H, "attachment_distance"),
        (D, -1.0, "pivot_height"),
        (math.nan, H, "attachment_distance"),
        (0.3, 0.3, "attachment_distance"),
    ]:
        with pytest.raises(RangeError) as info:
            lg.check_geometry(d, h)
        assert info.value.name == name
    assert lg.assembly_range(D, H) == (LOW, HIGH)


# --- derivatives against finite differences ------------------------------------------------


def _piston_path(t):
    """Smooth piston motion inside the assembly range: x0 + a sin(t)."""
    x0 = 0.5 * (LOW + HIGH)
    a = 0.4 * (HIGH - LOW)
    return x0 + a * math.sin(t), a * math.cos(t), -a * math.sin(t)


def _gear_along_path(t):
    return lg.gear_motion(*_piston_path(t), D, H)


def test_omega_and_alpha_are_derivatives_of_the_angle():
    step = 1e-5
    times = [0.05 * i for i in range(0, 130)]
    omega_scale = max(abs(_gear_along_path(t).angular_velocity) for t in times)
    alpha_scale = max(abs(_gear_along_path(t).angular_acceleration) for t in times)
    assert omega_scale > 0.1 and alpha_scale > 0.1
    for t in times:
        motion = _gear_along_path(t)
        d_angle = (_gear_along_path(t + step).angle - _gear_along_path(t - step).angle) / (2 * step)
        d_omega = (
            _gear_along_path(t + step).angular_velocity
            - _gear_along_path(t - step).angular_velocity
        ) / (2 * step)
        assert abs(motion.angular_velocity - d_angle) <= 1e-8 * omega_scale, t
        assert abs(motion.angular_acceleration - d_omega) <= 1e-8 * alpha_scale, t


def test_angle_follows_law_of_cosines_in_the_middle():
    for i in range(1, 50):
        x = LOW + (HIGH - LOW) * i / 50
        theta = lg.gear_motion(x, 0.0, 0.0, D, H).angle
        assert 0.0 < theta < math.pi
        assert theta == pytest.approx(
            math.acos((H * H + D * D - x * x) / (2 * D * H)), rel=1e-13, abs=1e-13
        )


def test_piston_motion_is_derivative_of_extension():
    step = 1e-5

    def path(t):
        return lg.piston_motion(
            1.0 + 0.9 * math.sin(t), 0.9 * math.cos(t), -0.9 * math.sin(t), D, H
        )

    for i in range(60):
        t = 0.1 * i
        p = path(t)
        dx = (path(t + step).extension - path(t - step).extension) / (2 * step)
        dv = (path(t + step).speed - path(t - step).speed) / (2 * step)
        assert abs(p.speed - dx) <= 1e-9 * D
        assert abs(p.acceleration - dv) <= 1e-9 * D


# --- round trips ---------------------------------------------------------------------------


def test_round_trip_gear_then_piston_reproduces_piston_motion():
    for i in range(1, 100):
        t = 0.07 * i
        x, v, a = _piston_path(t)
        g = lg.gear_motion(x, v, a, D, H)
        back = lg.piston_motion(*g, D, H)
        assert relative_error(back.extension, x) <= 1e-12
        assert abs(back.speed - v) <= 1e-12 * abs(v) + 1e-15 * (HIGH - LOW)
        assert abs(back.acceleration - a) <= 1e-12 * abs(a) + 1e-15 * (HIGH - LOW)


def test_round_trip_at_design_lengths():
    for x in (X_RETRACTED, X_EXTENDED):
        g = lg.gear_motion(x, 0.25 * FOOT, 0.1, D, H)
        back = lg.piston_motion(*g, D, H)
        assert relative_error(back.extension, x) <= 1e-12
        assert relative_error(back.speed, 0.25 * FOOT) <= 1e-12
        assert relative_error(back.acceleration, 0.1) <= 1e-12


def test_constant_piston_speed_law_has_the_coursework_omega():
    # omega = x xdot / (d h sin theta); at x_r the piston is perpendicular to d: sin = x_r / h
    speed = 0.25 * FOOT
    g = lg.gear_motion(X_RETRACTED, speed, 0.0, D, H)
    assert (
        relative_error(g.angular_velocity, X_RETRACTED * speed / (D * H * X_RETRACTED / H)) < 1e-13
    )
    assert relative_error(g.angular_velocity, speed / D) < 1e-13


# --- errors --------------------------------------------------------------------------------


@pytest.mark.parametrize("x", [LOW * (1 - 1e-12), HIGH * (1 + 1e-12), 0.0, -HIGH, 10.0])
def test_outside_assembly_range_raises_range_error(x):
    with pytest.raises(RangeError) as info:
        lg.gear_motion(x, 0.1, 0.0, D, H)
    error = info.value
    assert error.name == "piston_extension"
    assert error.value == x
    text = str(error)
    assert "piston_extension" in text
    assert repr(x) in text
    assert f"[{LOW!r}, {HIGH!r}]" in text
    assert isinstance(error, MechanismError) and isinstance(error, ValueError)


def test_moment_arm_outside_range_raises_range_error():
    with pytest.raises(RangeError) as info:
        lg.piston_moment_arm(HIGH * 1.01, D, H)
    assert info.value.name == "piston_extension"


@pytest.mark.parametrize("position", [0, 1, 2])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_inputs_raise_range_error(position, bad):
    names = ("piston_extension", "piston_speed", "piston_acceleration")
    args = [X_EXTENDED, 0.1, 0.0]
    args[position] = bad
    with pytest.raises(RangeError) as info:
        lg.gear_motion(*args, D, H)
    assert info.value.name == names[position]
    assert names[position] in str(info.value)

    gear_names = ("gear_angle", "gear_angular_velocity", "gear_angular_acceleration")
    gear_args = [THETA_1, 0.1, 0.0]
    gear_args[position] = bad
    with pytest.raises(RangeError) as info:
        lg.piston_motion(*gear_args, D, H)
    assert info.value.name == gear_names[position]


def test_non_numeric_input_raises_range_error():
    with pytest.raises(RangeError):
        lg.gear_motion("long", 0.1, 0.0, D, H)


@pytest.mark.parametrize("x, which", [(HIGH, "h + d"), (LOW, "|h - d|")])
@pytest.mark.parametrize("speed", [0.25 * FOOT, -1.0])
def test_dead_centres_are_singular(x, which, speed):
    with pytest.raises(SingularConfiguration) as info:
        lg.gear_motion(x, speed, 0.0, D, H)
    assert which in str(info.value)
    assert not isinstance(info.value, RangeError)


def test_moment_arm_is_zero_at_dead_centres():
    assert lg.piston_moment_arm(HIGH, D, H) == 0.0
    assert lg.piston_moment_arm(LOW, D, H) == 0.0


# --- moment arm ----------------------------------------------------------------------------


def test_piston_moment_arm_is_dh_sin_theta_over_x():
    for i in range(1, 40):
        x = LOW + (HIGH - LOW) * i / 40
        theta = lg.gear_motion(x, 0.0, 0.0, D, H).angle
        arm = lg.piston_moment_arm(x, D, H)
        assert relative_error(arm, D * H * math.sin(theta) / x) < 1e-13
        assert 0.0 < arm <= D  # the arm cannot exceed the lever d


def test_moment_arm_at_retracted_length_is_d():
    # piston perpendicular to d at x_r: the whole of d is the moment arm
    assert relative_error(lg.piston_moment_arm(X_RETRACTED, D, H), D) < 1e-14


def test_moment_arm_is_virtual_work_ratio():
    # power balance: F xdot = M omega with M = F * arm  =>  arm = xdot / omega
    for x in (0.3, 0.4, X_RETRACTED, X_EXTENDED):
        g = lg.gear_motion(x, 0.7, 0.0, D, H)
        assert relative_error(lg.piston_moment_arm(x, D, H), 0.7 / g.angular_velocity) < 1e-13


# --- property tests ------------------------------------------------------------------------


def _signed(low, high):
    """0, or a magnitude in [low, high] of either sign (no subnormal rates)."""
    magnitude = st.floats(low, high)
    return st.one_of(st.just(0.0), magnitude, magnitude.map(lambda v: -v))


geometry_values = st.tuples(
    st.floats(0.01, 10.0),  # d
    st.floats(0.05, 20.0),  # h / d
)


def _interior_configuration(geometry, fraction):
    """(d, h, x) for a drawn geometry with x a fraction of the way through the assembly range."""
    d, ratio = geometry
    assume(abs(ratio - 1.0) > 1e-3)
    h = d * ratio
    low, high = lg.assembly_range(d, h)
    x = low + fraction * (high - low)
    assume(low < x < high)
    return d, h, x


@PROPERTY
@given(geometry_values, st.floats(1e-3, 1 - 1e-3), _signed(1e-6, 10.0), _signed(1e-6, 100.0))
def test_property_outputs_finite_and_velocity_identity(geometry, fraction, speed, accel):
    d, h, x = _interior_configuration(geometry, fraction)
    g = lg.gear_motion(x, speed, accel, d, h)
    assert all(math.isfinite(v) for v in g)
    assert 0.0 < g.angle < math.pi
    lhs = x * speed
    rhs = d * h * math.sin(g.angle) * g.angular_velocity
    assert abs(lhs - rhs) <= 1e-10 * abs(lhs)
    if speed == 0.0:
        assert g.angular_velocity == 0.0
    arm = lg.piston_moment_arm(x, d, h)
    assert math.isfinite(arm) and arm > 0.0
    assert abs(arm - d * h * math.sin(g.angle) / x) <= 1e-10 * arm


@PROPERTY
@given(geometry_values, st.floats(1e-3, 1 - 1e-3), _signed(1e-6, 10.0), _signed(1e-6, 100.0))
def test_property_round_trip(geometry, fraction, speed, accel):
    d, h, x = _interior_configuration(geometry, fraction)
    g = lg.gear_motion(x, speed, accel, d, h)
    back = lg.piston_motion(*g, d, h)
    assert abs(back.extension - x) <= 1e-12 * x
    # scales of the terms that make up xdot and xddot (cancellation is legitimate)
    speed_scale = abs(speed)
    accel_scale = abs(accel) + speed * speed / x + d * h * g.angular_velocity**2 / x
    assert abs(back.speed - speed) <= 1e-12 * speed_scale
    assert abs(back.acceleration - accel) <= 1e-12 * accel_scale


# --- accuracy next to the singular lengths (50-digit decimal reference) ---------------------

_PI_50 = Decimal("3.14159265358979323846264338327950288419716939937510582097494459")


def _asin_decimal(z):
    """asin(z) for 0 <= z <= 0.5 by its Taylor series, at the current decimal precision."""
    total, term, n = z, z, 0
    z2 = z * z
    eps = Decimal(10) ** -55
    while term > eps:
        n += 1
        term = term * z2 * (2 * n - 1) * (2 * n - 1) / ((2 * n) * (2 * n + 1))
        total += term
    return total


def _exact(x, d, h):
    """(theta, omega for xdot = 1) at float inputs, to 50 digits, via half-angle forms.

    sin^2(theta/2) = (x^2 - (h-d)^2) / (4dh), cos^2(theta/2) = ((h+d)^2 - x^2) / (4dh),
    d h sin(theta) = sqrt(A B) / 2 with A = x^2 - (h-d)^2, B = (h+d)^2 - x^2.
    """
    with localcontext() as ctx:
        ctx.prec = 60
        X, Dd, Hh = Decimal(x), Decimal(d), Decimal(h)
        A = X * X - (Hh - Dd) ** 2
        B = (Hh + Dd) ** 2 - X * X
        four_dh = 4 * Dd * Hh
        sin_half = (A / four_dh).sqrt()
        cos_half = (B / four_dh).sqrt()
        if sin_half <= cos_half:
            theta = 2 * _asin_decimal(sin_half)
        else:
            theta = _PI_50 - 2 * _asin_decimal(cos_half)
        omega = 2 * X / (A * B).sqrt()
        return float(theta), omega


def _backward_bound(x, d, h, exact_value, index, ulps=2):
    """Largest change of the exact result when x moves by ``ulps`` ulps (input uncertainty)."""
    spread = 0.0
    for sign in (-1, 1):
        moved = x + sign * ulps * math.ulp(x)
        low, high = abs(h - d), h + d
        if not low < moved < high:
            continue
        value = _exact(moved, d, h)[index]
        spread = max(spread, abs(float(Decimal(value) - Decimal(exact_value))))
    return spread


EPSILONS = [1e-3, 1e-6, 1e-9, 1e-10, 1e-11, 1e-12]


@pytest.mark.parametrize("eps", EPSILONS)
def test_near_extended_dead_centre_angle_is_accurate(eps):
    x = HIGH * (1 - eps)
    g = lg.gear_motion(x, 1.0, 0.0, D, H)
    theta, omega = _exact(x, D, H)
    assert math.isfinite(g.angle) and math.isfinite(g.angular_velocity)
    assert g.angle < math.pi
    # the angle itself: a few ulps of pi plus what a 2-ulp change of x does to it
    assert abs(g.angle - theta) <= 4 * math.ulp(math.pi) + _backward_bound(x, D, H, theta, 0)
    # and within 1e-9 rad absolutely at every eps down to 1e-12
    assert abs(g.angle - theta) < 1e-9
    # omega (1 / sin theta) to full precision for the given x: the rounding error of h + d
    # is added back (TwoSum), so the distance to the dead centre is exact
    assert relative_error(g.angle, theta) < 1e-15
    assert float(abs(Decimal(g.angular_velocity) - omega) / omega) < 1e-13


@pytest.mark.parametrize("eps", EPSILONS + [1e-14])
def test_near_retracted_dead_centre_is_accurate_to_full_precision(eps):
    # for the coursework geometry |h - d| is exact in floating point, so the product form
    # keeps full relative accuracy of sin(theta) here
    with localcontext() as ctx:
        ctx.prec = 60
        assert Decimal(H) - Decimal(D) == Decimal(LOW)
    x = LOW * (1 + eps)
    g = lg.gear_motion(x, 1.0, 0.0, D, H)
    theta, omega = _exact(x, D, H)
    assert relative_error(g.angle, theta) < 1e-14
    assert float(abs(Decimal(g.angular_velocity) - omega) / omega) < 1e-14


@PROPERTY
@given(geometry_values, st.floats(-12.0, -3.0), st.booleans())
def test_property_near_dead_centres_finite_and_backward_accurate(geometry, log_eps, at_high):
    d, ratio = geometry
    assume(abs(ratio - 1.0) > 1e-2)
    h = d * ratio
    low, high = lg.assembly_range(d, h)
    eps = 10.0**log_eps
    x = high * (1 - eps) if at_high else low * (1 + eps)
    assume(low < x < high)
    g = lg.gear_motion(x, 1.0, 1.0, d, h)
    assert all(math.isfinite(v) for v in g)
    assert 0.0 < g.angle < math.pi
    theta, _ = _exact(x, d, h)
    assert abs(g.angle - theta) <= 8 * math.ulp(math.pi) + _backward_bound(x, d, h, theta, 0, 4)
