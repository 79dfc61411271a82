"""Hard cases: the inputs that try to break the physics and the FMUs.

Every case ends in one of two ways: finite outputs within a stated tolerance of an independent
reference (a closed form evaluated in 60-digit ``decimal`` or exact ``fractions`` arithmetic,
or a numpy reference of ``mechfmu.references``), or a specific MechanismError whose message
names the condition. Never NaN, never a hang, never a bare Python exception.

Cases already covered elsewhere are not repeated here (the coverage table is in the report of
the change that added this file); what is here: the gear's dead centres approached to 1e-16
relative from both sides, both gear drivers at once (the drive parameter's precedence, never
silent), the coursework's rounded constants, loads within 1e-16 .. 1e-3 of the limit load,
the secant stiffness at tiny deflections against its exact limit, non-Grashof crank limits
approached to 1e-15 rad (closed form and constraint solver), change points on the constraint
solver, slider-crank dead centres and limit positions, the valve train's rocker dead
centres, cam laws with acceleration jumps at high speed, and the iteration bounds.
"""

import math
from decimal import Decimal, localcontext
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from fmu_driver import Driven
from mechfmu.runtime.models.landing_gear import LandingGear
from mechfmu.runtime.physics import cam_laws, constraint_models, planar
from mechfmu.runtime.physics import four_bar as fb
from mechfmu.runtime.physics import landing_gear as lg
from mechfmu.runtime.physics import slider_crank as sc
from mechfmu.runtime.physics import suspension as sus
from mechfmu.runtime.physics import valve_train as vt
from mechfmu.runtime.errors import (
    IntegrationError,
    MechanismError,
    RangeError,
    SingularConfiguration,
    SnapThrough,
)
from mechfmu.references import landing_gear as gear_reference
from mechfmu.references import linkages as linkage_reference
from mechfmu.references import valve_train as valve_reference

EPS = 2.0**-52

# Derandomised, bounded and with a deadline: the file runs in well under a minute.
HARD = settings(
    derandomize=True,
    max_examples=150,
    deadline=5000,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)


# --- 60-digit arithmetic ----------------------------------------------------------------------

PREC = 60


def D(value):
    """The exact value of a float (or int) as a Decimal."""
    return Decimal(value)


def dsin_cos(x):
    """(sin x, cos x) of a float x, |x| < 8, by Taylor series at the current precision."""
    x = Decimal(x)
    x2 = x * x
    term, sine, n = x, x, 1
    tiny = Decimal(10) ** -(PREC + 5)
    while abs(term) > tiny:
        term = -term * x2 / ((n + 1) * (n + 2))
        sine += term
        n += 2
    term, cosine, n = Decimal(1), Decimal(1), 0
    while abs(term) > tiny:
        term = -term * x2 / ((n + 1) * (n + 2))
        cosine += term
        n += 2
    return sine, cosine


def relative(got, exact):
    """|got - exact| / |exact| with exact a Decimal (got a float)."""
    return float(abs(D(got) - exact) / abs(exact))


def powers_of_ten(low, high):
    """Magnitudes m 10^k, k an integer in [low, high], m in [1, 10): every decade alike."""
    return st.builds(lambda k, m: m * 10.0**k, st.integers(low, high), st.floats(1.0, 9.99))


# --- landing gear: the dead centres from both sides, down to 1e-15 relative --------------------


def _gear_exact(x, v, a, d, h):
    """(inside, distance to the nearer dead centre, omega, alpha) at float inputs, 60 digits.

    With A = x^2 - (h - d)^2 and B = (h + d)^2 - x^2 (exact products of floats),
    d h sin(theta) = sqrt(A B) / 2, d h cos(theta) = (h^2 + d^2 - x^2) / 2,
    omega = x v / (d h sin theta), alpha = (v^2 + x a - d h cos(theta) omega^2) / (d h sin).
    """
    with localcontext() as ctx:
        ctx.prec = PREC
        X, V, Acc, Dd, Hh = D(x), D(v), D(a), D(d), D(h)
        low, high = abs(Hh - Dd), Hh + Dd
        distance = min(X - low, high - X)
        if distance <= 0:
            return False, distance, None, None
        dh_sin = ((X * X - low * low) * (high * high - X * X)).sqrt() / 2
        dh_cos = (Hh * Hh + Dd * Dd - X * X) / 2
        omega = X * V / dh_sin
        alpha = (V * V + X * Acc - dh_cos * omega * omega) / dh_sin
        scale = (V * V + abs(X * Acc) + abs(dh_cos) * omega * omega) / dh_sin
        return True, distance, omega, (alpha, scale)


@HARD
@given(
    d=st.floats(0.01, 10.0),
    ratio=st.floats(0.05, 20.0),
    at_high=st.booleans(),
    inside=st.booleans(),
    log_eps=st.floats(-16.0, -3.0),
    speed=st.floats(1e-6, 10.0),
    backwards=st.booleans(),
    accel=st.floats(-100.0, 100.0),
)
def test_gear_dead_centres_approached_from_both_sides(
    d, ratio, at_high, inside, log_eps, speed, backwards, accel
):
    """x -> h + d and x -> |h - d| (sin theta -> 0) from inside and outside, 1e-3 .. 1e-16
    relative: finite omega and alpha within 1e-12 of the 60-digit closed form inside; at a
    dead centre (within DEAD_CENTRE_ULPS) SingularConfiguration "dead centre"; outside
    RangeError "assembly range". Never NaN."""
    assume(abs(ratio - 1.0) > 1e-3)
    speed = -speed if backwards else speed
    h = d * ratio
    low, high = lg.assembly_range(d, h)
    eps = 10.0**log_eps
    sign = 1.0 if inside else -1.0
    x = high * (1.0 - sign * eps) if at_high else low * (1.0 + sign * eps)
    is_inside, distance, omega, alpha = _gear_exact(x, speed, accel, d, h)
    band = (lg.DEAD_CENTRE_ULPS + 1) * EPS * high  # where the input cannot tell the side
    try:
        motion = lg.gear_motion(x, speed, accel, d, h)
    except SingularConfiguration as error:
        event("dead centre")
        assert "dead centre" in str(error) and repr(x) in str(error)
        assert abs(float(distance)) <= band, (x, float(distance))
    except RangeError as error:
        event("outside")
        assert error.name == "piston_extension" and "assembly range" in str(error)
        assert not low <= x <= high  # refused only outside the float interval
        assert not is_inside or float(distance) <= band
    else:
        event("finite")
        assert is_inside and float(distance) > band / 2
        assert all(math.isfinite(value) for value in motion)
        assert 0.0 < motion.angle < math.pi
        assert relative(motion.angular_velocity, omega) <= 1e-12
        exact_alpha, scale = alpha
        assert float(abs(D(motion.angular_acceleration) - exact_alpha)) <= 1e-12 * float(scale)
        arm = lg.piston_moment_arm(x, d, h)
        assert math.isfinite(arm) and arm > 0.0
    # inside by more than a few rounding units the linkage is never refused
    if is_inside and float(distance) > 4 * band:
        lg.gear_motion(x, speed, accel, d, h)


def _gear_slave(drive, **inputs):
    model = LandingGear(instance_name="gear")
    model.values.update(drive=drive, inertia=True)
    model.exit_initialization_mode()
    assert model.pending_error is None, model.pending_error
    model.values.update(inputs)
    return model


def _gear_run(drive, steps, stray=None):
    """An in-process LandingGear stepped ``steps`` times from rest (dynamics: a constant
    800 N piston force); ``stray`` inputs of the other driver set from the second step on.
    Returns (outputs after every step, warnings logged)."""
    model = _gear_slave(
        drive,
        **(
            {"piston_extension": 0.5, "piston_speed": 0.1}
            if drive == "motion"
            else {"piston_force": 800.0}
        ),
    )
    rows = []
    for k in range(steps):
        if stray and k == 1:
            model.values.update(stray)
        assert model.do_step(0.01 * k, 0.01), model.log_queue[-1].msg
        rows.append(
            tuple(
                model.values[name]
                for name in ("gear_angle", "gear_angular_velocity", "gear_angular_acceleration")
            )
        )
    warnings = [entry.msg for entry in model.log_queue if "both drivers given" in entry.msg]
    return rows, warnings


@pytest.mark.parametrize(
    "drive, stray, other",
    [
        ("motion", {"piston_force": 500.0}, "dynamics"),
        ("motion", {"valve_command": 0.5, "piston_force": -3.0}, "dynamics"),
        ("dynamics", {"piston_extension": 0.5}, "motion"),
        ("dynamics", {"piston_speed": 0.1, "piston_acceleration": 2.0}, "motion"),
    ],
)
def test_landing_gear_both_drivers_given_the_drive_parameter_takes_precedence(drive, stray, other):
    """Both drivers at once (the piston motion and the piston force or valve command): the
    ``drive`` parameter selects the driver and takes precedence; the other driver's inputs
    are ignored, bit for bit (the same outputs as without them), and never silently: a
    warning names both drivers and every ignored input with its value, once when they
    appear."""
    clean, none = _gear_run(drive, 5)
    rows, warnings = _gear_run(drive, 5, stray)
    assert rows == clean and none == []
    assert len(warnings) == 1
    message = warnings[0]
    assert f"drive = {drive!r}" in message and "takes precedence" in message
    assert f"drive = {other!r}" in message and "ignored" in message
    for name, value in stray.items():
        assert f"{name} = {value!r}" in message
    assert all(math.isfinite(v) for row in rows for v in row)


def test_landing_gear_fmu_warns_of_both_drivers_through_fmpy(fmu_dir):
    """The built FMU: the step succeeds with the motion drive's closed form and the ignored
    piston force is named in a warning."""
    gear = Driven(fmu_dir / "LandingGear.fmu")
    try:
        assert gear.step(0.01, piston_extension=0.5, piston_speed=0.1) is True
        angle = gear.get("gear_angle")
        assert gear.step(0.01, piston_force=800.0) is True
        assert gear.get("gear_angle") == angle
        warnings = [m for m in gear.messages("warning") if "both drivers given" in m]
        assert len(warnings) == 1 and "piston_force = 800.0 N is ignored" in warnings[0]
    finally:
        gear.close()


def test_landing_gear_motion_drive_with_consistent_inputs_is_exact():
    """The check does not disturb the motion drive: the closed form, bit for bit."""
    model = _gear_slave("motion", piston_extension=0.5, piston_speed=-0.2, piston_acceleration=0.3)
    assert model.do_step(0.0, 0.01)
    d, h = lg.DEFAULT_GEOMETRY.attachment_distance, lg.DEFAULT_GEOMETRY.pivot_height
    assert tuple(
        model.values[name]
        for name in ("gear_angle", "gear_angular_velocity", "gear_angular_acceleration")
    ) == tuple(lg.gear_motion(0.5, -0.2, 0.3, d, h))


def test_gear_with_the_coursework_rounded_constants():
    """The coursework's rounded d = 0.64361 ft, h = 1.4060 ft and its script's constants
    h^2 + d^2 = 2.3911, 2 d h = 1.8098, theta_1 = 1.0953 (data/seed_report.md): finite, equal
    to the numpy reference with the same constants, and off the exact design by the
    documented amounts (piston 1.250044 .. 2.000033 ft instead of 1.25 .. 2 ft)."""
    exact_d, exact_h, theta_1 = lg.design_geometry(1.25, 2.0)  # feet
    d, h = 0.64361, 1.4060
    stroke = np.linspace(1.25, 2.0, 301)
    for x in stroke:
        motion = lg.gear_motion(float(x), 0.25, 0.0, d, h)
        theta, omega, alpha = gear_reference.gear_from_piston(x, 0.25, 0.0, d, h)
        assert all(math.isfinite(v) for v in motion)
        assert motion.angle == pytest.approx(float(theta), rel=1e-12)
        assert motion.angular_velocity == pytest.approx(float(omega), rel=1e-12)
        assert motion.angular_acceleration == pytest.approx(float(alpha), rel=1e-9, abs=1e-12)
        # the deviation from the exact design is the first-order change of the law of
        # cosines g = h^2 + d^2 - 2 d h cos(theta) - x^2 = 0 under dd, dh (second order
        # terms below 0.1 % of it): dtheta = -(g_d dd + g_h dh) / g_theta
        exact = lg.gear_motion(float(x), 0.25, 0.0, exact_d, exact_h).angle
        c, s_ = math.cos(exact), math.sin(exact)
        first_order = -(
            (2 * exact_d - 2 * exact_h * c) * (d - exact_d)
            + (2 * exact_h - 2 * exact_d * c) * (h - exact_h)
        ) / (2 * exact_d * exact_h * s_)
        assert abs((motion.angle - exact) - first_order) <= 1e-3 * abs(first_order) + 1e-13
        assert abs(first_order) < 2e-4
    # The script's constants: x = sqrt(2.3911 - 1.8098 cos(theta)) with theta_1 = 1.0953.
    # h + d and |h - d| from (h + d)^2 = 2.3911 + 1.8098, (h - d)^2 = 2.3911 - 1.8098.
    with localcontext() as ctx:
        ctx.prec = PREC
        s = (Decimal("2.3911") + Decimal("1.8098")).sqrt()
        t = (Decimal("2.3911") - Decimal("1.8098")).sqrt()
    script_h, script_d = float((s + t) / 2), float((s - t) / 2)
    for angle, documented, design in (
        (1.0953, 1.250044, 1.25),
        (1.0953 + math.pi / 2, 2.000033, 2.0),
    ):
        x = lg.piston_motion(angle, 0.0, 0.0, script_d, script_h).extension
        with localcontext() as ctx:
            ctx.prec = PREC
            exact = (Decimal("2.3911") - Decimal("1.8098") * dsin_cos(angle)[1]).sqrt()
        assert relative(x, exact) <= 1e-14
        assert round(x, 6) == documented and abs(x - design) > 3e-5


# --- suspension: the limit load, the merging equilibria, tiny deflections ---------------------


def _spring_decimal(spring):
    L, k, d = (D(v) for v in spring)
    return L, k, d, ((L - d) * (L + d)).sqrt()


def _force_decimal(u, spring):
    """F(u) = 2 k (L - s)(h - u) / s at 60 digits (u a float or a Decimal)."""
    L, k, d, h = _spring_decimal(spring)
    v = h - D(u)
    s = (d * d + v * v).sqrt()
    return 2 * k * (L - s) * v / s


def _limit_decimal(spring):
    """(u*, F*, |F''(u*)|) at 60 digits: s*^3 = L d^2, F'' = -6 k L d^2 v / s^5."""
    L, k, d, h = _spring_decimal(spring)
    s_star = (L * d * d) ** (Decimal(1) / 3)
    v_star = (s_star * s_star - d * d).sqrt()
    f_star = 2 * k * (L - s_star) * v_star / s_star
    curvature = 6 * k * L * d * d * v_star / s_star**5
    return h - v_star, f_star, curvature


def _bisect_decimal(spring, low, high, target, rising):
    """The root of F(u) = target in [low, high] by bisection at 60 digits; ``rising``: F
    increases with u there."""
    for _ in range(130):
        middle = (low + high) / 2
        if (_force_decimal(middle, spring) > target) == rising:
            high = middle
        else:
            low = middle
    return (low + high) / 2


def _near_root_decimal(load, spring, u_star):
    """The stable (near-branch) root of F(u) = W below u*, by bisection at 60 digits."""
    return _bisect_decimal(spring, u_star - 2 * D(spring.free_length), u_star, D(load), True)


def _unstable_root_decimal(load, spring, u_star):
    """The unstable root of F(u) = W between u* and h, by bisection at 60 digits."""
    _, _, _, h = _spring_decimal(spring)
    return _bisect_decimal(spring, u_star, h, D(load), False)


springs = st.builds(
    lambda length, ratio, log_k: sus.make_spring(length, 10.0**log_k, ratio * length),
    st.floats(0.05, 5.0),
    st.floats(0.05, 0.95),
    st.floats(1.0, 8.0),
)


@HARD
@given(spring=springs, side=st.sampled_from([-1, 0, 1]), log_delta=st.floats(-15.7, -3.0))
def test_loads_next_to_the_limit_load(spring, side, log_delta):
    """W = F* (1 + side 10^log_delta), within 1e-16 .. 1e-3 below, at and above the limit load.
    Below (and at): the near (stable) equilibrium, never the unstable one that merges with
    it, with a residual at rounding level and within the conditioning of the 60-digit root;
    above: SnapThrough naming the limit load, and the continuation lands on the far branch."""
    limit = sus.limit_point(spring)
    load = limit.load * (1.0 + side * 10.0**log_delta)
    with localcontext() as ctx:
        ctx.prec = PREC
        u_star, f_star, curvature = _limit_decimal(spring)
        assert relative(limit.load, f_star) <= 1e-13  # the float limit load itself
        force_scale = 16 * EPS * float(f_star)  # rounding of F near F*
        # within LIMIT_LOAD_RTOL of F* the load is the limit load: its equilibrium is the
        # limit point (marginal), whatever the last bits of W and F* are
        within = abs(load - limit.load) <= sus.LIMIT_LOAD_RTOL * limit.load
        if within:
            event("within the limit band")
            eq, snapped = sus.follow_load(load, sus.NEAR, spring)
            assert not snapped and eq.branch == sus.NEAR and eq.marginal and not eq.stable
            assert eq.deflection == pytest.approx(float(u_star), rel=1e-12)
            assert abs(eq.tangent_stiffness) <= sus.MARGINAL_RTOL * 2.0 * spring.stiffness
            return
        if load > limit.load:
            event("above")
            with pytest.raises(SnapThrough, match="limit load") as raised:
                sus.solve_on_branch(load, sus.NEAR, spring)
            assert repr(limit.load) in str(raised.value)
            with pytest.raises(SnapThrough):
                sus.follow_load(load, sus.NEAR, spring, continue_past_limit=False)
            far, snapped = sus.follow_load(load, sus.NEAR, spring)
            assert snapped and far.branch == sus.FAR and far.tangent_stiffness > 0.0
            # solve_on_branch stops at steps below 1e-13 max(1, |u|) (its tolerance)
            allowed = force_scale + far.tangent_stiffness * 2e-13 * max(1.0, far.deflection)
            assert float(abs(_force_decimal(far.deflection, spring) - D(load))) <= allowed
            return
        event("below" if load < limit.load else "at")
        eq, snapped = sus.follow_load(load, sus.NEAR, spring)
        u = eq.deflection
        assert not snapped and eq.branch == sus.NEAR and math.isfinite(u)
        # backward: the exact force at the returned deflection balances the load
        assert float(abs(_force_decimal(u, spring) - D(load))) <= force_scale + max(
            eq.tangent_stiffness, 0.0
        ) * 2e-13 * max(1.0, abs(u))
        # on the stable side of the limit point (up to the flatness of F there)
        band = math.sqrt(2.0 * force_scale / float(curvature))
        assert u <= float(u_star) + band
        assert eq.tangent_stiffness >= -float(curvature) * band
        if D(load) < f_star:
            root = _near_root_decimal(load, spring, u_star)
            other = _unstable_root_decimal(load, spring, u_star)
            # forward: within what the residual allows where F is flat,
            # |du| <= dF / F'(u) or sqrt(2 dF / |F''|)
            slope = float(curvature * (u_star - root))
            allowed = min(force_scale / slope if slope > 0 else math.inf, 2.0 * band)
            assert abs(u - float(root)) <= 2.0 * allowed + 4 * EPS * abs(u)
            if float(other - root) > 8.0 * allowed:  # distinguishable: not the unstable one
                event("two equilibria told apart")
                assert abs(u - float(other)) > 2.0 * allowed
                assert eq.stable and eq.tangent_stiffness > 0.0


@HARD
@given(
    spring=springs,
    magnitude=st.floats(-300.0, -12.0),
    sign=st.sampled_from([-1.0, 1.0]),
    subnormal=st.booleans(),
)
def test_secant_stiffness_at_tiny_deflections_is_its_exact_limit(
    spring, magnitude, sign, subnormal
):
    """F(u)/u for |u| down to 1e-300 m (and subnormal) against its exact limit
    2 k h^2 / L^2 = 2 k (L^2 - d^2) / L^2, a rational function of the float parameters
    evaluated in Fractions, plus the first term of its series, -3 d^2 / (2 h L^2) u:
    within 1e-12 relative, and F(u) / u too where F(u) does not underflow."""
    u = sign * (5e-324 * 2.0 ** int(-magnitude / 6.0) if subnormal else 10.0**magnitude)
    L, k, d = (Fraction(v) for v in spring)
    limit = 2 * k * (L * L - d * d) / (L * L)
    h = sus.rest_height(spring)
    slope = -float(limit) * 3.0 * spring.base_offset**2 / (2.0 * h * spring.free_length**2)
    expected = Fraction(float(limit)) + Fraction(slope) * Fraction(u)
    values = [sus.secant_stiffness(u, spring)]
    if abs(u) * float(limit) > 1e-290:  # F(u) itself a normal float, not a rounded subnormal
        values.append(sus.spring_force(u, spring) / u)
    for value in values:
        assert math.isfinite(value)
        assert abs(Fraction(value) - expected) <= Fraction(1, 10**12) * limit
    assert sus.secant_stiffness(0.0, spring) == pytest.approx(float(limit), rel=4 * EPS)


def test_rounded_rest_height_shifts_every_equilibrium():
    """The coursework's h = 0.4583 m (rounded) against the exact sqrt(L^2 - d^2): F depends
    on u only through h - u, so the rounded model is the exact one shifted by
    dh = 0.4583 - h = 42.43 um; its spurious preload F(0) = -0.7128 N and its u1 = 0.1374990
    m (data/seed_report.md) follow from the physics and agree with the 60-digit form."""
    spring = sus.make_spring(0.5, 1e4, 0.2)
    h = sus.rest_height(spring)
    shift = 0.4583 - h
    assert round(shift * 1e6, 2) == 42.43
    with localcontext() as ctx:
        ctx.prec = PREC
        v = Decimal("0.4583")
        s = (Decimal("0.2") ** 2 + v * v).sqrt()
        preload = 2 * Decimal(10000) * (Decimal("0.5") - s) * v / s  # rounded model at u = 0
    physics = sus.spring_force(-shift, spring)  # exact model, shifted
    assert math.isfinite(physics) and round(physics, 4) == -0.7128
    assert relative(physics, preload) <= 1e-9  # the shift is a float
    u1 = sus.solve_on_branch(211 * 9.81, sus.NEAR, spring) + shift
    assert round(u1, 7) == 0.1374990


# --- four-bar: the non-Grashof crank limits, approached to 1e-15 rad -------------------------


def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _four_bar_exact(lengths, circuit, t2, w2, al2):
    """The four-bar at a float crank angle, 60 digits: Norton's loop solved by circle
    intersection (B left of the diagonal A -> O4 on the open circuit), the rates from the
    differentiated loop in unit vectors; None outside the assembly. Returns
    (margin, e3, e4, w3, w4, al3, al4, al_scale) with margin the distance of |A - O4| from
    the nearer of b + c and |b - c| (m)."""
    d, a, b, c = (D(v) for v in lengths)
    W2, AL2 = D(w2), D(al2)
    sin2, cos2 = dsin_cos(t2)
    e2 = (cos2, sin2)
    pin = (a * cos2, a * sin2)
    diagonal = (d - pin[0], -pin[1])
    f = (diagonal[0] ** 2 + diagonal[1] ** 2).sqrt()
    margin = min(b + c - f, f - abs(b - c))
    if margin <= 0:
        return margin, None
    u = (diagonal[0] / f, diagonal[1] / f)
    normal = (-u[1], u[0])
    along = (b * b - c * c + f * f) / (2 * f)
    height = (b * b - along * along).sqrt() * (1 if circuit == 0 else -1)
    pin_b = (pin[0] + along * u[0] + height * normal[0], pin[1] + along * u[1] + height * normal[1])
    e3 = ((pin_b[0] - pin[0]) / b, (pin_b[1] - pin[1]) / b)
    e4 = ((pin_b[0] - d) / c, pin_b[1] / c)
    w3 = a * W2 * _cross(e2, e4) / (b * -_cross(e3, e4))
    w4 = a * W2 * _cross(e3, e2) / (c * _cross(e3, e4))
    # loop a e2 + b e3 - c e4 = d, twice differentiated: i alpha e - w^2 e terms
    rx = a * AL2 * e2[1] + a * W2 * W2 * e2[0] + b * w3 * w3 * e3[0] - c * w4 * w4 * e4[0]
    ry = -a * AL2 * e2[0] + a * W2 * W2 * e2[1] + b * w3 * w3 * e3[1] - c * w4 * w4 * e4[1]
    m11, m12, m21, m22 = -b * e3[1], c * e4[1], b * e3[0], -c * e4[0]
    det = m11 * m22 - m12 * m21
    al3 = (rx * m22 - m12 * ry) / det
    al4 = (m11 * ry - rx * m21) / det
    al_scale = abs(al3) + abs(al4) + w3 * w3 + w4 * w4 + W2 * W2 + abs(AL2)
    return margin, (e3, e4, w3, w4, al3, al4, al_scale)


@st.composite
def triple_rockers(draw):
    """Non-Grashof four-bars (S + L > P + Q by more than 1 %) whose crank has a limit."""
    lengths = tuple(draw(st.floats(0.5, 5.0)) for _ in range(4))
    ordered = sorted(lengths)
    assume(ordered[0] + ordered[3] > 1.01 * (ordered[1] + ordered[2]))
    assume(ordered[3] < 0.99 * (ordered[0] + ordered[1] + ordered[2]))
    assume(fb.crank_angle_range(*lengths) is not None)
    scale = draw(st.floats(0.01, 10.0))
    return tuple(scale * v for v in lengths)


@HARD
@given(
    lengths=triple_rockers(),
    circuit=st.sampled_from([0, 1]),
    upper=st.booleans(),
    side=st.sampled_from(["inside", "inside", "at", "outside"]),
    delta=powers_of_ten(-15, -1),
    speed=st.floats(-20.0, 20.0),
    accel=st.floats(-100.0, 100.0),
)
def test_non_grashof_crank_limits_approached_to_1e_15(
    lengths, circuit, upper, side, delta, speed, accel
):
    """A triple-rocker's crank driven to its limit angle (coupler and rocker collinear)
    from inside by 1e-15 .. 0.1 rad, at it and beyond: inside, finite and within the
    conditioning of the 60-digit loop; at the toggle, SingularConfiguration "toggle" with
    the crank angle; beyond, RangeError "no assembly" with the admissible interval."""
    assert fb.grashof_class(*lengths) == 5
    low, high = fb.crank_angle_range(*lengths)
    # the limit angles: acos(low) (largest) and, if high < 1, acos(high) (smallest)
    if upper or high >= 1.0:
        limit, inward = math.acos(low), -1.0
    else:
        limit, inward = math.acos(high), 1.0
    t2 = {"inside": limit + inward * delta, "at": limit, "outside": limit - inward * delta}[side]
    d, a, b, c = lengths
    allowance = (fb.TOGGLE_ULPS + 8) * EPS * (a + b + c + d)
    with localcontext() as ctx:
        ctx.prec = PREC
        margin, exact = _four_bar_exact(lengths, circuit, t2, speed, accel)
    margin = float(margin)
    try:
        motion = fb.motion(*lengths, circuit, t2, speed, accel)
    except SingularConfiguration as error:
        event("toggle")
        assert "toggle position: coupler and rocker collinear" in str(error)
        assert f"crank angle {t2!r} rad" in str(error)
        assert abs(margin) <= allowance
    except RangeError as error:
        event("no assembly")
        assert error.name == "crank_angle" and error.value == t2
        assert "no assembly" in str(error) and f"[{low!r}, {high!r}]" in str(error)
        assert exact is None or margin <= allowance
    else:
        event("finite")
        assert exact is not None or abs(margin) <= allowance
        assert all(math.isfinite(v) for v in motion)
        e3, e4, w3, w4, al3, al4, al_scale = exact
        with localcontext() as ctx:
            ctx.prec = PREC
            # angles: the loop closes with the returned angles (backward error)
            s3, c3 = dsin_cos(motion.coupler_angle)
            s4, c4 = dsin_cos(motion.rocker_angle)
            s2, c2 = dsin_cos(t2)
            closure = max(
                abs(D(a) * c2 + D(b) * c3 - D(c) * c4 - D(d)),
                abs(D(a) * s2 + D(b) * s3 - D(c) * s4),
            )
            assert float(closure) <= 64 * EPS * (a + b + c + d)
            # the same circuit as the exact one: the angles within their conditioning
            tolerance = 4 * EPS * (a + b + c + d) / margin
            assert abs(float(_cross((c3, s3), e3))) <= math.sqrt(tolerance) + 1e-12
            assert abs(float(_cross((c4, s4), e4))) <= math.sqrt(tolerance) + 1e-12
            # the rates, ~ 1/sqrt(margin): relative error ~ eps (b + c) / margin
            # (plus 1e-300 rad/s: subnormal rates carry no relative precision)
            for got, want in (
                (motion.coupler_angular_velocity, w3),
                (motion.rocker_angular_velocity, w4),
            ):
                assert (
                    float(abs(D(got) - want))
                    <= (tolerance + 1e-12) * (float(abs(want)) + abs(speed)) + 1e-300
                )
            for got, want in (
                (motion.coupler_angular_acceleration, al3),
                (motion.rocker_angular_acceleration, al4),
            ):
                assert (
                    float(abs(D(got) - want)) <= 3 * (tolerance + 1e-12) * float(al_scale) + 1e-300
                )
    if exact is not None and margin > 4 * allowance:
        fb.motion(*lengths, circuit, t2, speed, accel)  # inside: never refused


NON_GRASHOF = (4.0, 3.0, 2.0, 2.5)  # ground, crank, coupler, rocker: the crank stops at 1.3716


@pytest.mark.parametrize("circuit", [0, 1])
def test_constraint_solver_approaches_a_toggle_to_1e_14_then_reports_it(circuit):
    """The constraint solver stepped towards the crank limit of a triple-rocker, 0.1 .. 1e-14
    rad short of it: finite, within the conditioning (4 eps (a + b + c + d) / margin) of the
    60-digit loop; at the limit and beyond: SingularConfiguration naming the toggle position
    and the crank angle reached (never a bare non-convergence)."""
    lengths = NON_GRASHOF
    limit = math.acos(fb.crank_angle_range(*lengths)[0])
    follower = planar.BranchFollower(constraint_models.four_bar(*lengths))
    t = 0.5
    t3, t4 = fb.position(*lengths, t, circuit)
    follower.assemble(
        constraint_models.four_bar_guess(lengths[0], lengths[1], t, t3, t4), [(t, 1.0, 0.3)]
    )
    for k in range(1, 15):
        target = limit - 10.0**-k
        solution = follower.follow([(target, 1.0, 0.3)], target - t)
        t = target
        with localcontext() as ctx:
            ctx.prec = PREC
            margin, exact = _four_bar_exact(lengths, circuit, t, 1.0, 0.3)
            e3, e4, w3, w4, al3, al4, al_scale = exact
            tolerance = 4 * EPS * sum(lengths) / float(margin) + 1e-12
            assert all(math.isfinite(v) for v in solution.qdot + solution.qddot)
            assert float(abs(D(solution.qdot[8]) - w4)) <= tolerance * float(abs(w4))
            assert float(abs(D(solution.qdot[5]) - w3)) <= tolerance * float(abs(w3))
            assert float(abs(D(solution.qddot[8]) - al4)) <= 3 * tolerance * float(al_scale)
    kept = follower.snapshot()
    for past in (0.0, 1e-9, 1e-6, 1e-2, 0.5):
        follower.restore(kept)
        with pytest.raises(SingularConfiguration) as raised:
            follower.follow([(limit + past, 1.0, 0.3)], past + 1e-14)
        text = str(raised.value)
        assert "toggle position: coupler and rocker collinear at crank angle 1.3715642" in text
        assert "condition number" in text and (
            "singular position" in text or "no assembly" in text
        ), text


def _branch_distance(lengths, t2, circuit, q):
    """Largest angle difference between the solver's coupler/rocker and the closed form's."""
    t3, t4 = fb.position(*lengths, t2, circuit)
    return max(
        abs(math.remainder(q[5] - t3, 2 * math.pi)), abs(math.remainder(q[8] - t4, 2 * math.pi))
    )


CHANGE_POINT_LINKAGES = {
    "parallelogram": lambda a, d: (d, a, d, a),  # ground, crank, coupler, rocker
    "kite": lambda a, d: (d, a, a, d),
}


@settings(HARD, max_examples=80)
@given(
    kind=st.sampled_from(sorted(CHANGE_POINT_LINKAGES)),
    a=st.floats(0.2, 0.9),
    circuit=st.sampled_from([0, 1]),
    at_pi=st.booleans(),
    direction=st.sampled_from([-1, 1]),
    log_step=st.floats(-3.5, -0.6),
    before=st.integers(1, 6),
    miss=st.one_of(
        st.just(0.0),
        st.builds(
            lambda sign, log: sign * 10.0**log, st.sampled_from([-1.0, 1.0]), st.floats(-16.0, -1.0)
        ),
    ),
)
def test_change_point_is_reported_never_a_silent_branch_switch(
    kind, a, circuit, at_pi, direction, log_step, before, miss
):
    """Parallelogram and kite linkages (S + L = P + Q) driven through a change point (all four
    links collinear at crank angle 0 or pi) by the constraint solver, in steps of 3e-4 ..
    0.25 rad, one of them landing on the change point or 1e-16 .. 0.1 rad beside it: every
    returned position lies on the physical branch it started on (the open/crossed label of
    that branch flips at the change point), or the solver reports the change point by name
    (SingularConfiguration). It never continues on the other branch."""
    lengths = CHANGE_POINT_LINKAGES[kind](a, 1.0)
    assert fb.grashof_class(*lengths) == 6
    centre = math.pi if at_pi else 0.0
    step = 10.0**log_step
    landing = centre + direction * miss

    def angle(k):  # the k-th drive value, exact at k = before (no accumulated rounding)
        return landing + direction * (k - before) * step

    def side(t):  # > 0 past the change point in the drive's direction
        return direction * math.remainder(t - centre, 2 * math.pi)

    assume(abs(side(angle(0))) > 1e-6)  # start on a branch, not on the crossing
    start_side = side(angle(0)) > 0
    follower = planar.BranchFollower(constraint_models.four_bar(*lengths))
    t = angle(0)
    t3, t4 = fb.position(*lengths, t, circuit)
    follower.assemble(
        constraint_models.four_bar_guess(lengths[0], lengths[1], t, t3, t4), [(t, direction, 0.0)]
    )
    try:
        for k in range(1, before + 8):
            t = angle(k)
            solution = follower.follow([(t, direction, 0.0)], step)
            assert all(math.isfinite(v) for v in solution.q + solution.qdot + solution.qddot)
            if abs(side(t)) < 1e-6:
                continue  # the two branches are not yet apart
            # the starting branch's label: it flips where the branch passes the change point
            label = circuit if (side(t) > 0) == start_side else 1 - circuit
            mine = _branch_distance(lengths, t, label, solution.q)
            other = _branch_distance(lengths, t, 1 - label, solution.q)
            assert mine <= 1e-8 and mine < other, (t, mine, other)
    except SingularConfiguration as error:
        event("reported")
        text = str(error)
        assert "change point: all four links collinear" in text, text
        assert abs(math.remainder(t - centre, 2 * math.pi)) <= step + abs(miss) + 1e-9
    else:
        event("passed on its branch")


@pytest.mark.parametrize("kind", sorted(CHANGE_POINT_LINKAGES))
@pytest.mark.parametrize("centre", [0.0, math.pi])
def test_closed_form_at_and_next_to_a_change_point(kind, centre):
    """At the change point the closed form names it (SingularConfiguration, "change point");
    10^-3 .. 10^-7 rad either side it is finite and within the conditioning of the 60-digit
    loop, and closer it is finite or, inside the toggle band, names the change point. Its circuit label is the open/crossed sign rule, so a fixed circuit passes from one
    physical branch to the other at the change point: the rates differ on the two sides."""
    lengths = CHANGE_POINT_LINKAGES[kind](0.6, 1.0)
    for circuit in (0, 1):
        with pytest.raises(SingularConfiguration, match="change point: all four links collinear"):
            fb.motion(*lengths, circuit, centre, 1.0, 0.0)
        for k in range(3, 12):
            rates = []
            for sign in (-1.0, 1.0):
                t2 = centre + sign * 10.0**-k
                try:
                    motion = fb.motion(*lengths, circuit, t2, 1.0, 0.0)
                except SingularConfiguration as error:
                    # inside the toggle band, |f - (b -+ c)| <= TOGGLE_ULPS eps (b + c):
                    # |theta2| ~ sqrt(eps), about 1e-7 rad
                    assert "change point: all four links collinear" in str(error)
                    with localcontext() as ctx:
                        ctx.prec = PREC
                        margin = float(_four_bar_exact(lengths, circuit, t2, 1.0, 0.0)[0])
                    assert margin <= (fb.TOGGLE_ULPS + 8) * EPS * sum(lengths)
                    continue
                with localcontext() as ctx:
                    ctx.prec = PREC
                    margin, exact = _four_bar_exact(lengths, circuit, t2, 1.0, 0.0)
                    tolerance = 4 * EPS * sum(lengths) / float(margin) + 1e-12
                    w3, w4 = exact[2], exact[3]
                    scale = float(abs(w3) + abs(w4)) + 1.0
                    assert abs(motion.coupler_angular_velocity - float(w3)) <= tolerance * scale
                    assert abs(motion.rocker_angular_velocity - float(w4)) <= tolerance * scale
                rates.append(motion.rocker_angular_velocity)
            if len(rates) == 2:
                assert abs(rates[0] - rates[1]) > 0.1  # the label changed branch


# --- slider-crank: dead centres and limit positions ------------------------------------------


@HARD
@given(
    a=st.floats(0.01, 2.0),
    ratio=st.floats(1.2, 6.0),
    offset=st.floats(-0.95, 0.95),
    circuit=st.sampled_from([0, 1]),
    folded=st.booleans(),
    speed=st.floats(-500.0, 500.0),
    accel=st.floats(-1e4, 1e4),
)
def test_slider_crank_dead_centres_are_regular(a, ratio, offset, circuit, folded, speed, accel):
    """At the dead centres (crank and coupler collinear, the slider at the end of its
    stroke) of an offset slider-crank whose crank turns fully, nothing is singular: the slider
    speed is 0 (to rounding), the acceleration and the coupler rates are finite and equal to
    the numpy reference, for the closed form and for the constraint solver stepping onto the
    dead centre exactly."""
    b = ratio * a
    e = offset * (b - a)  # |e| < b - a: the crank turns fully
    assert sc.crank_angle_range(a, b, e) is None
    reach = (b - a) if folded else (a + b)
    run = math.sqrt((reach - e) * (reach + e)) * (1.0 if circuit == 0 else -1.0)
    t2 = math.atan2(-e, -run) if folded else math.atan2(e, run)
    motion = sc.motion(a, b, e, circuit, t2, speed, accel)
    assert all(math.isfinite(v) for v in motion)
    expected = linkage_reference.slider_crank(a, b, e, circuit, np.array([t2]), speed, accel)
    scales = {
        "slider_position": a + b,
        "slider_speed": a * abs(speed),
        "slider_acceleration": a * (speed * speed + abs(accel)),
        "coupler_angular_velocity": abs(speed),
        "coupler_angular_acceleration": speed * speed + abs(accel),
    }
    # the dead centre: the slider stands still (a w times the rounding of the crank angle)
    assert abs(motion.slider_speed) <= 64 * EPS * (a + b) * abs(speed) * b / (b - abs(e)) + 1e-300
    for key, scale in scales.items():
        assert (
            abs(getattr(motion, key) - float(expected[key][0]))
            <= 1e-12 * (abs(float(expected[key][0])) + scale) + 1e-300
        ), key
    # the solver, stepping onto the dead centre from 0.3 rad before it
    follower = planar.BranchFollower(constraint_models.slider_crank(a, b, e))
    before = t2 - 0.3
    t3, s = sc.position(a, b, e, before, circuit)
    follower.assemble(
        constraint_models.slider_crank_guess(a, e, before, t3, s), [(before, speed, accel)]
    )
    for fraction in (0.5, 0.9, 1.0):
        solution = follower.follow([(before + 0.3 * fraction, speed, accel)], 0.15)
    assert abs(solution.q[6] - motion.slider_position) <= 1e-12 * (a + b)
    # the solver's positions meet a residual tolerance of 1e-12 (scaled): rates to ~1e-11
    assert abs(solution.qdot[6] - motion.slider_speed) <= 1e-10 * scales["slider_speed"] + 1e-300
    assert (
        abs(solution.qddot[6] - motion.slider_acceleration)
        <= 1e-10 * scales["slider_acceleration"] + 1e-300
    )


def _slider_exact(a, b, e, circuit, t2, w2, al2):
    """(margin, speed, acceleration, w3) of the slider-crank at a float crank angle, 60 digits;
    margin = b - |e - a sin(t2)| (m), None beyond the limit positions."""
    A, B, E, W2, AL2 = D(a), D(b), D(e), D(w2), D(al2)
    sin2, cos2 = dsin_cos(t2)
    rise = E - A * sin2
    margin = B - abs(rise)
    if margin <= 0:
        return margin, None
    run = ((B - rise) * (B + rise)).sqrt() * (1 if circuit == 0 else -1)
    w3 = -A * W2 * cos2 / run
    speed = -A * W2 * sin2 - w3 * rise
    al3 = (A * W2 * W2 * sin2 + w3 * w3 * rise - A * AL2 * cos2) / run
    acceleration = -A * AL2 * sin2 - A * W2 * W2 * cos2 - al3 * rise - w3 * w3 * run
    return margin, (speed, acceleration, w3, al3)


@HARD
@given(
    a=st.floats(0.5, 2.0),
    b=st.floats(0.2, 1.5),
    offset=st.floats(-0.5, 0.5),
    circuit=st.sampled_from([0, 1]),
    which=st.integers(0, 3),
    side=st.sampled_from(["inside", "inside", "at", "outside"]),
    delta=powers_of_ten(-16, -2),
)
def test_slider_crank_limit_positions_approached_to_1e_16(
    a, b, offset, circuit, which, side, delta
):
    """A slider-crank whose crank cannot turn fully (the coupler reaches the slider axis only
    for some crank angles) driven to a limit position (coupler perpendicular to the slider
    axis) from inside by 1e-16 .. 0.1 rad, at it and beyond: inside finite and within the
    conditioning of the 60-digit closed form; at it SingularConfiguration "perpendicular";
    beyond RangeError "no assembly". Never NaN."""
    e = offset * b
    interval = sc.crank_angle_range(a, b, e)
    assume(interval is not None)
    low, high = interval
    ends = [
        (math.asin(low), 1.0),
        (math.asin(high), -1.0),
        (math.pi - math.asin(high), 1.0),
        (math.pi - math.asin(low), -1.0),
    ]
    limit, inward = ends[which]
    assume(-1.0 < (low if which in (0, 3) else high) < 1.0)  # a limit, not sin = +-1
    t2 = {"inside": limit + inward * delta, "at": limit, "outside": limit - inward * delta}[side]
    allowance = (sc.SINGULAR_ULPS + 8) * EPS * (a + b + abs(e))
    with localcontext() as ctx:
        ctx.prec = PREC
        margin, exact = _slider_exact(a, b, e, circuit, t2, 3.0, -2.0)
    margin = float(margin)
    try:
        motion = sc.motion(a, b, e, circuit, t2, 3.0, -2.0)
    except SingularConfiguration as error:
        event("limit position")
        assert "coupler perpendicular to the slider axis" in str(error)
        assert repr(t2) in str(error) and abs(margin) <= allowance
    except RangeError as error:
        event("no assembly")
        assert error.name == "crank_angle" and "no assembly" in str(error)
        assert exact is None or margin <= allowance
    else:
        event("finite")
        assert exact is not None or abs(margin) <= allowance
        assert all(math.isfinite(v) for v in motion)
        speed, acceleration, w3, al3 = exact
        tolerance = 4 * EPS * (a + b + abs(e)) / margin + 1e-12
        assert abs(motion.coupler_angular_velocity - float(w3)) <= tolerance * (
            float(abs(w3)) + 3.0
        )
        assert abs(motion.slider_speed - float(speed)) <= tolerance * (float(abs(speed)) + 3.0 * a)
        # s'' = -a al2 sin - a w2^2 cos - al3 rise - w3^2 run: the terms' sizes
        assert abs(motion.slider_acceleration - float(acceleration)) <= 3 * tolerance * (
            float(abs(acceleration)) + float(abs(al3) + w3 * w3) * b + 11.0 * a
        )
    if exact is not None and margin > 4 * allowance:
        sc.motion(a, b, e, circuit, t2, 3.0, -2.0)  # inside: never refused


# --- valve train: the rocker's dead centres on the tappet side --------------------------------

G = vt.DEFAULT_VALVE_GEOMETRY


def _tappet_side_exact(g, lift, velocity, phi):
    """(margin, omega) of the tappet-side triangle (pushrod L1, tappet arm lt, pivot distance R)
    at a float tappet lift, 60 digits: omega = e_y v / (e . t1) with e = T - P and
    t1 = perp(T - O); T is the circle intersection nearer to the one the float angle ``phi``
    gives. margin = the smallest of the triangle inequalities' slacks (m)."""
    a, b, lt, length = (
        D(g.rocker_pivot_x),
        D(g.rocker_pivot_y),
        D(g.tappet_arm),
        D(g.pushrod_length),
    )
    y1 = D(g.cam_base_radius) + D(lift)
    w = b - y1
    distance = (a * a + w * w).sqrt()
    margin = min(length + lt - distance, distance + lt - length, distance + length - lt)
    if margin <= 0:
        return margin, None
    u = (a / distance, w / distance)  # from P towards the pivot O
    along = (length * length - lt * lt + distance * distance) / (2 * distance)
    height = (length * length - along * along).sqrt()
    sin_phi, cos_phi = dsin_cos(phi)
    guess = (a - lt * cos_phi, b - lt * sin_phi)
    candidates = [
        (along * u[0] - sign * height * u[1], y1 + along * u[1] + sign * height * u[0])
        for sign in (1, -1)
    ]
    top = min(candidates, key=lambda p: (p[0] - guess[0]) ** 2 + (p[1] - guess[1]) ** 2)
    e = (top[0], top[1] - y1)
    t1 = (-(top[1] - b), top[0] - a)
    return margin, e[1] * D(velocity) / (e[0] * t1[0] + e[1] * t1[1])


@HARD
@given(
    high_end=st.booleans(),
    side=st.sampled_from(["inside", "inside", "at", "outside"]),
    delta=powers_of_ten(-17, -3),
    velocity=st.floats(1e-3, 5.0),
    sign=st.sampled_from([-1.0, 1.0]),
)
def test_valve_train_tappet_dead_centres_approached_to_1e_17_m(
    high_end, side, delta, velocity, sign
):
    """The tappet lift driven to the ends of tappet_lift_range, where the pushrod and the
    rocker's tappet arm come in line (folded at the top, stretched at the bottom), from inside
    by 1e-17 .. 1e-3 m, at them and beyond: inside finite, the rocker rate within the
    conditioning of the 60-digit triangle; at a dead centre SingularConfiguration "in line";
    beyond RangeError naming tappet_lift and the interval."""
    low, high = vt.tappet_lift_range(G)
    end, inward = (high, -1.0) if high_end else (low, 1.0)
    velocity *= sign
    lift = {"inside": end + inward * delta, "at": end, "outside": end - inward * delta}[side]
    perimeter = G.pushrod_length + G.tappet_arm + G.rocker_pivot_y
    allowance = 4 * (vt.SINGULAR_ULPS + 4) * EPS * perimeter
    try:
        motion = vt.forward(G, lift, velocity, 0.0)
    except SingularConfiguration as error:
        event("dead centre")
        assert "pushrod and the tappet arm in line" in str(error)
        assert ("folded" if high_end else "stretched out") in str(error)
        with localcontext() as ctx:
            ctx.prec = PREC
            margin, _ = _tappet_side_exact(G, lift, velocity, 0.0)
        assert abs(float(margin)) <= allowance
    except RangeError as error:
        event("outside")
        assert error.name == "tappet_lift" and f"[{low!r}, {high!r}]" in str(error)
        assert not low <= lift <= high
    else:
        event("finite")
        assert all(math.isfinite(v) for v in motion)
        with localcontext() as ctx:
            ctx.prec = PREC
            margin, omega = _tappet_side_exact(G, lift, velocity, motion.rocker_angle)
            assert margin > 0 or abs(float(margin)) <= allowance
            tolerance = 8 * EPS * perimeter / float(margin) + 1e-12
            assert relative(motion.rocker_angular_velocity, omega) <= tolerance


# --- valve train: cam laws whose acceleration jumps, at high speed ----------------------------

GEOMETRY_DICT = G._asdict()


@pytest.mark.parametrize("law", cam_laws.CAM_LAWS)
def test_cam_laws_at_high_speed_jump_where_the_law_says(law):
    """The cam laws through the rocker geometry at camshaft speeds of 1e2 .. 1e5 rad/s: every
    output finite and equal to the numpy reference over a revolution, and at the four segment
    boundaries the valve acceleration jumps by the rocker ratio times the law's jump of s''
    times w^2 (the harmonic law: lift pi^2 / (2 beta^2) at each end) and is continuous for the
    other laws (to 1e-12 of its peak)."""
    profile = cam_laws.DEFAULT_CAM_PROFILE._replace(law=law)
    lift, beta = profile.lift, profile.rise_angle
    peak = cam_laws.peak_coefficients(law).acceleration * lift / beta**2
    boundaries = [
        (0.0, ("rise", 0.0), None),
        (1.2, ("rise", 1.0), (lift, 0.0, 0.0, 0.0)),
        (1.3, None, ("return", 0.0)),
        (2.5, ("return", 1.0), (0.0, 0.0, 0.0, 0.0)),
    ]
    angles = np.linspace(0.0, 2.0 * math.pi, 2001)[:-1]
    for speed in (1e2, 1e3, 1e4, 1e5):
        # a whole revolution against the numpy reference (constant speed)
        s, s1, s2 = valve_reference.cam_lift(*profile, angles)
        expected = valve_reference.forward(GEOMETRY_DICT, s, s1 * speed, s2 * speed**2)
        for i, angle in enumerate(angles):
            motion = vt.forward(G, *cam_laws.follower_motion(profile, float(angle), speed, 0.0))
            assert all(math.isfinite(v) for v in motion)
            assert (
                abs(motion.valve_acceleration - expected["valve_acceleration"][i])
                <= 1e-11 * 1.6 * peak * speed**2
            )
        # the jumps at the segment boundaries
        for angle, left_segment, right in boundaries:
            if left_segment is None:  # the high dwell ends: left is the dwell itself
                left = cam_laws.CamLift(lift, 0.0, 0.0, 0.0)
            elif left_segment[0] == "rise" and left_segment[1] == 0.0:
                left = cam_laws.CamLift(0.0, 0.0, 0.0, 0.0)  # the low dwell before the rise
            else:
                left = cam_laws.segment_lift(profile, *left_segment)
            right = cam_laws.cam_lift(profile, angle)  # segments are closed on the left
            before = vt.forward(G, left.s, left.s1 * speed, left.s2 * speed**2)
            after = vt.forward(G, right.s, right.s1 * speed, right.s2 * speed**2)
            assert left.s == right.s and left.s1 == right.s1 == 0.0
            jump = after.valve_acceleration - before.valve_acceleration
            ratio = float(
                valve_reference.forward(GEOMETRY_DICT, right.s, 1.0, 0.0)["valve_velocity"]
            )
            law_jump = (right.s2 - left.s2) * speed**2
            if cam_laws.CONTINUITY[law].acceleration:
                assert abs(jump) <= 1e-12 * 1.6 * peak * speed**2, (angle, speed)
            else:
                assert abs(right.s2 - left.s2) == pytest.approx(
                    lift * math.pi**2 / (2.0 * beta**2), rel=1e-14
                )
                assert jump == pytest.approx(ratio * law_jump, rel=1e-12)


def test_valve_train_solver_at_high_speed_across_the_harmonic_jumps():
    """The constraint solver driven by the harmonic cam law at 3000 rad/s of camshaft (ten
    times its float speed) in 60 steps per revolution, each landing on or straddling a jump
    of the acceleration: every step finite and equal to the closed form (the solver's
    acceleration is a linear solve, so the jump is exact at the sample)."""
    profile = cam_laws.DEFAULT_CAM_PROFILE._replace(law="harmonic")
    speed, steps = 3000.0, 60
    follower = planar.BranchFollower(constraint_models.valve_train(G))
    closed = vt.rest_position(G)[1]
    dt = 2.0 * math.pi / speed / steps
    angles = (
        [1.2 * k / 10 for k in range(11)]
        + [1.3, 2.5]
        + [2.0 * math.pi * k / steps for k in range(steps + 1)]
    )
    for k, angle in enumerate(sorted(angles)):
        law = cam_laws.follower_motion(profile, angle, speed, 0.0)
        drive = [(G.cam_base_radius + law.lift, law.velocity, law.acceleration)]
        solution = (
            follower.assemble(constraint_models.valve_train_guess(G), drive)
            if k == 0
            else follower.follow(drive, dt)
        )
        exact = vt.forward(G, *law)
        valve = 3 * constraint_models.VALVE + 1
        assert all(math.isfinite(v) for v in solution.q + solution.qdot + solution.qddot)
        assert closed - solution.q[valve] == pytest.approx(exact.valve_lift, abs=1e-15)
        assert -solution.qdot[valve] == pytest.approx(exact.valve_velocity, rel=1e-10, abs=1e-12)
        assert -solution.qddot[valve] == pytest.approx(exact.valve_acceleration, rel=1e-9, abs=1e-6)


def test_valve_train_fmu_far_past_float_reports_it(fmu_dir):
    """ValveTrain (constraint solver, valve spring) with the harmonic law at five times its
    float speed: finite outputs equal to the closed form at every step, the float flagged
    (contact_lost, float_events, a warning with the computed float speed), and the contact
    force m a + k lift + F0 negative where the valve floats."""
    profile = cam_laws.DEFAULT_CAM_PROFILE._replace(law="harmonic")
    predicted = vt.float_speed(G, profile, 0.1, 50e3, 300.0).camshaft_speed
    speed, steps = 5.0 * predicted, 200
    dt = 2.0 * math.pi / speed / steps
    fmu = Driven(
        fmu_dir / "ValveTrain.fmu",
        {"cam_law": "harmonic", "valve_spring": True},
        {"camshaft_angle": 0.0, "camshaft_speed": speed},
    )
    try:
        lost, forces = [], []
        for k in range(1, steps + 1):
            angle = speed * k * dt
            assert fmu.step(dt, camshaft_angle=angle) is True
            exact = vt.forward(G, *cam_laws.follower_motion(profile, angle, speed, 0.0))
            for name in ("valve_lift", "valve_velocity", "valve_acceleration"):
                value = fmu.get(name)
                assert math.isfinite(value)
                assert value == pytest.approx(getattr(exact, name), rel=1e-9, abs=1e-9)
            force = fmu.get("contact_force")
            assert force == pytest.approx(
                0.1 * exact.valve_acceleration + 50e3 * exact.valve_lift + 300.0, rel=1e-9, abs=1e-6
            )
            lost.append(bool(fmu.get("contact_lost")))
            forces.append(force)
        assert fmu.get("float_camshaft_speed") == predicted
        assert fmu.get("float_events") >= 1 and any(lost)
        assert all(f < 0.0 for f, flag in zip(forces, lost) if flag)
        warnings = [m for m in fmu.messages("warning") if "valve float" in m]
        assert warnings and all(f"{predicted:.6g} rad/s" in m for m in warnings)
    finally:
        fmu.close()


# --- iteration bounds ---------------------------------------------------------------------------

SPRING = sus.make_spring(0.5, 1e4, 0.2)


@pytest.mark.parametrize("stiffness", [10.0, 1e4, 1e8])
def test_huge_loads_are_solved_or_refused_by_name(stiffness):
    """Loads of 1e3 .. 1e300 N: the stable equilibrium (bracketed from the load's asymptote,
    so 200 doublings always suffice) with a residual at rounding level, or, where the
    deflection would pass MAX_DEFLECTION (the spring force overflows beyond it), RangeError
    naming the load and the bound. (Before: doubling from the free length ran out for loads
    above about 2^200 k L and returned a deflection that balanced nothing.)"""
    spring = sus.make_spring(0.5, stiffness, 0.2)
    bound = 2.0 * stiffness * sus.MAX_DEFLECTION
    for exponent in range(3, 301, 7):
        for branch, load in ((sus.NEAR, -(10.0**exponent)), (sus.FAR, 10.0**exponent)):
            if abs(load) > bound:
                with pytest.raises(RangeError) as raised:
                    sus.solve_on_branch(load, branch, spring)
                assert raised.value.name == "load" and repr(bound) in str(raised.value)
                assert "overflows" in str(raised.value)
                continue
            u = sus.solve_on_branch(load, branch, spring)
            assert math.isfinite(u)
            with localcontext() as ctx:
                ctx.prec = PREC
                residual = abs(_force_decimal(u, spring) - D(load))
            assert float(residual) <= 16 * EPS * (abs(load) + stiffness * 0.5)


def test_the_bracket_and_newton_bounds_are_reported(monkeypatch):
    """Both loops of solve_on_branch are bounded by MAX_ITERATIONS and say so when they run
    out: the doubling (the load check disabled, so the force overflows to NaN) with
    RangeError, the safeguarded Newton (bound lowered to 2) with IntegrationError."""
    monkeypatch.setattr(sus, "MAX_DEFLECTION", math.inf)
    with pytest.raises(RangeError) as raised:
        sus.solve_on_branch(-1e300, sus.NEAR, SPRING)
    assert "within MAX_ITERATIONS = 200 doublings" in str(raised.value)
    monkeypatch.setattr(sus, "MAX_DEFLECTION", 1e150)
    monkeypatch.setattr(sus, "MAX_ITERATIONS", 2)
    with pytest.raises(IntegrationError) as raised:
        sus.solve_on_branch(211 * 9.81, sus.NEAR, SPRING)
    assert "did not converge within MAX_ITERATIONS = 2" in str(raised.value)
    assert isinstance(raised.value, MechanismError)


def test_newton_on_the_constraint_solver_is_bounded():
    """solve_position stops after max_iterations with NoConvergence (a MechanismError) naming
    the bound; and at a drive exactly on a change point, where Newton only converges
    linearly, it follows the corrections until the conditioning shows the singular position
    instead of accepting a point beside it."""
    lengths = (1.0, 0.6, 1.0, 0.6)  # a parallelogram, change points at 0 and pi
    mechanism = constraint_models.four_bar(*lengths)
    guess = constraint_models.four_bar_guess(1.0, 0.6, 0.7, 0.3, 1.1)
    with pytest.raises(planar.NoConvergence) as raised:
        planar.solve_position(mechanism, guess, [(0.1, 0.0, 0.0)], max_iterations=2)
    assert "did not converge in 2 iterations" in str(raised.value)
    assert isinstance(raised.value, MechanismError)
    q, iterations, residual = planar.solve_position(
        mechanism, constraint_models.four_bar_guess(1.0, 0.6, 0.0, 0.01, 0.02), [(0.0, 0.0, 0.0)]
    )
    assert iterations > 10 and residual <= planar.DEFAULT_TOLERANCE  # linear convergence
    with pytest.raises(SingularConfiguration, match="change point: all four links collinear"):
        planar.analyse(mechanism, q, [(0.0, 1.0, 0.0)])


def test_events_per_step_are_bounded():
    """advance_through_events gives up after MAX_EVENTS_PER_STEP events in one communication
    step (a chattering contact) with IntegrationError, never a hang."""
    from mechfmu.runtime.numerics import stepping
    from mechfmu.runtime.numerics.integrators import Advance, Event

    class Chattering:
        def advance(self, rhs, t, y, t_end, events):
            return Advance(t + 1e-9 * (t_end - t), y, events[0])

    calls = []
    event = Event("contact", lambda t, y: y[0], 0)
    with pytest.raises(IntegrationError, match="more than 1000 events"):
        stepping.advance_through_events(
            Chattering(),
            lambda t, y: [0.0],
            0.0,
            [1.0],
            1.0,
            [event],
            lambda e, t, y: calls.append(t) or y,
        )
    assert len(calls) == stepping.MAX_EVENTS_PER_STEP
