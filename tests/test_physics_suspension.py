"""Two-spring suspension statics (mechanisms.md section 2) against the coursework and closed forms.

Layers: validation; coursework equilibria and stiffnesses; tangent stiffness against finite
differences; the secant stiffness at u -> 0 against a 50-digit ``decimal`` reference; the limit
point; continuation through snap-through in both directions; stiff springs; property tests.
"""

import math
from decimal import Decimal, localcontext

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechfmu.runtime.physics import suspension as sus
from mechfmu.runtime.errors import MechanismError, RangeError, SnapThrough

L, K, DB = 0.5, 1.0e4, 0.2
SPRING = sus.make_spring(L, K, DB)
W_COURSEWORK = 211 * 9.81
H = sus.rest_height(SPRING)
LIMIT = sus.limit_point(SPRING)

PROPERTY = settings(derandomize=True, max_examples=200, deadline=None)


def relative_error(got, expected):
    return abs(got - expected) / abs(expected)


def decimal_secant(u, spring, digits=50):
    """F(u)/u from the textbook form 2 k (L - s)(h - u) / (s u) at ``digits`` digits."""
    with localcontext() as ctx:
        ctx.prec = digits
        Ld, kd, dd, ud = (
            Decimal(v) for v in (spring.free_length, spring.stiffness, spring.base_offset, u)
        )
        h = (Ld * Ld - dd * dd).sqrt()
        v = h - ud
        s = (dd * dd + v * v).sqrt()
        return 2 * kd * (Ld - s) * v / (s * ud)


def bisect_root(f, low, high, iterations=200):
    f_low = f(low)
    assert f_low * f(high) < 0
    for _ in range(iterations):
        mid = 0.5 * (low + high)
        if (f(mid) > 0) == (f_low > 0):
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)


# --- validation ----------------------------------------------------------------------------


def test_make_spring_returns_validated_floats():
    spring = sus.make_spring(0.5, 10000, 0.2)
    assert spring == (0.5, 1.0e4, 0.2)
    assert all(type(v) is float for v in spring)


@pytest.mark.parametrize(
    "args, name",
    [
        ((0.0, K, DB), "spring_free_length"),
        ((-0.5, K, DB), "spring_free_length"),
        ((math.nan, K, DB), "spring_free_length"),
        ((math.inf, K, DB), "spring_free_length"),
        ((L, 0.0, DB), "spring_stiffness"),
        ((L, -1.0, DB), "spring_stiffness"),
        ((L, math.nan, DB), "spring_stiffness"),
        ((L, K, 0.0), "spring_base_offset"),
        ((L, K, -0.1), "spring_base_offset"),
        ((L, K, L), "spring_base_offset"),
        ((L, K, 0.7), "spring_base_offset"),
        ((L, K, math.nan), "spring_base_offset"),
    ],
)
def test_make_spring_rejects_invalid_parameters(args, name):
    with pytest.raises(RangeError) as info:
        sus.make_spring(*args)
    assert info.value.name == name
    assert name in str(info.value)
    assert isinstance(info.value, MechanismError)


# --- basic closed forms --------------------------------------------------------------------


def test_rest_height_and_zero_force_at_rest():
    assert relative_error(H, math.sqrt(0.21)) < 1e-15
    assert round(H, 4) == 0.4583
    assert sus.spring_force(0.0, SPRING) == 0.0
    assert sus.spring_length(0.0, SPRING) == pytest.approx(L, rel=1e-15)


def test_secant_limit_at_zero_is_2kh2_over_L2():
    assert (
        relative_error(sus.secant_stiffness(0.0, SPRING), 2 * K * (L * L - DB * DB) / L**2) < 1e-15
    )
    assert relative_error(sus.secant_stiffness(0.0, SPRING), 16800.0) < 1e-15


def test_force_matches_textbook_form_away_from_zero():
    for i in range(-20, 41):
        u = 0.05 * i
        if u == 0.0:
            continue
        v = H - u
        s = math.hypot(DB, v)
        textbook = 2 * K * (L - s) * v / s
        assert abs(sus.spring_force(u, SPRING) - textbook) <= 1e-12 * K * L


def test_force_is_antisymmetric_about_h():
    for i in range(1, 30):
        u = 0.03 * i
        assert sus.spring_force(2 * H - u, SPRING) == pytest.approx(
            -sus.spring_force(u, SPRING), rel=1e-12, abs=1e-9
        )


# --- coursework equilibria -----------------------------------------------------------------


def test_coursework_near_root_and_secant_stiffness():
    eq, snapped = sus.follow_load(W_COURSEWORK, sus.NEAR, SPRING)
    assert not snapped
    assert eq.branch == sus.NEAR
    assert round(eq.deflection, 4) == 0.1375
    assert relative_error(eq.spring_force, W_COURSEWORK) < 1e-12
    assert float(f"{eq.secant_stiffness:.4e}") == 1.5059e4
    assert eq.stable is True and eq.tangent_stiffness > 0
    assert eq.deflection == sus.solve_on_branch(W_COURSEWORK, sus.NEAR, SPRING)


def test_coursework_unstable_root_and_secant_stiffness():
    def residual(u):
        return sus.spring_force(u, SPRING) - W_COURSEWORK

    u2 = bisect_root(residual, LIMIT.deflection, H)
    assert round(u2, 4) == 0.3804
    assert float(f"{sus.secant_stiffness(u2, SPRING):.4e}") == 5.4410e3
    eq = sus.equilibrium(u2, SPRING, None)
    assert eq.tangent_stiffness < 0 and eq.stable is False


def test_all_coursework_equilibria_including_outside_0_to_half_metre():
    # sign changes of F - W on a fine grid over a wide range: exactly three roots
    grid = [-2.0 + 0.001 * i for i in range(5001)]
    values = [sus.spring_force(u, SPRING) - W_COURSEWORK for u in grid]
    changes = [grid[i] for i in range(len(grid) - 1) if values[i] * values[i + 1] < 0]
    assert len(changes) == 3
    near = sus.solve_on_branch(W_COURSEWORK, sus.NEAR, SPRING)
    far = sus.solve_on_branch(W_COURSEWORK, sus.FAR, SPRING)
    assert changes[0] < near < changes[0] + 0.001
    assert changes[2] < far < changes[2] + 0.001
    assert far > 0.5  # the coursework's interval [0, 0.5] m misses it
    assert relative_error(sus.spring_force(far, SPRING), W_COURSEWORK) < 1e-9
    assert sus.tangent_stiffness(far, SPRING) > 0


# --- tangent stiffness ---------------------------------------------------------------------


def test_tangent_stiffness_is_derivative_of_force():
    step = 1e-5
    for i in range(-40, 81):
        u = 0.0123 + 0.025 * i
        central = (sus.spring_force(u + step, SPRING) - sus.spring_force(u - step, SPRING)) / (
            2 * step
        )
        assert abs(sus.tangent_stiffness(u, SPRING) - central) <= 1e-7 * 2 * K, u


def test_tangent_stiffness_closed_form_values():
    assert relative_error(sus.tangent_stiffness(0.0, SPRING), 2 * K * (1 - DB * DB / L**2)) < 1e-14
    # at u = h the springs are horizontal: s = d
    assert relative_error(sus.tangent_stiffness(H, SPRING), 2 * K * (1 - L / DB)) < 1e-14


# --- secant stiffness near zero ------------------------------------------------------------


@pytest.mark.parametrize("u", [1e-15, -1e-15, 5e-16, 1e-14])
def test_secant_stiffness_near_zero_equals_limit(u):
    limit = 2 * K * H * H / L**2
    assert relative_error(sus.secant_stiffness(u, SPRING), limit) <= 1e-12
    assert relative_error(sus.spring_force(u, SPRING) / u, limit) <= 1e-12


@pytest.mark.parametrize("u", [1e-3, 1e-8, -1e-3, -1e-8, 1e-10, 1e-12])
def test_secant_stiffness_against_50_digit_reference(u):
    exact = decimal_secant(u, SPRING)
    got = sus.secant_stiffness(u, SPRING)
    assert float(abs(Decimal(got) - exact) / exact) < 1e-14
    # the naive float form loses digits here, so the comparison is discriminating
    if abs(u) <= 1e-8:
        v = H - u
        s = math.hypot(DB, v)
        naive = 2 * K * (L - s) * v / (s * u)
        assert float(abs(Decimal(naive) - exact) / exact) > 1e-10


# --- limit point ---------------------------------------------------------------------------


def test_limit_point_is_a_force_maximum_with_zero_tangent():
    u_star, f_star = LIMIT
    assert 0.0 < u_star < H
    assert abs(sus.tangent_stiffness(u_star, SPRING)) <= 1e-12 * K
    assert f_star == sus.spring_force(u_star, SPRING)
    for delta in (1e-2, 1e-4, 1e-6):
        assert sus.spring_force(u_star - delta, SPRING) < f_star
        assert sus.spring_force(u_star + delta, SPRING) < f_star
    assert f_star > W_COURSEWORK  # the coursework load has a near equilibrium


def test_limit_point_closed_form():
    with localcontext() as ctx:
        ctx.prec = 50
        Ld, kd, dd = Decimal(L), Decimal(K), Decimal(DB)
        s_star = (Ld * dd * dd) ** (Decimal(1) / 3)
        v_star = (s_star * s_star - dd * dd).sqrt()
        h = (Ld * Ld - dd * dd).sqrt()
        f_star = 2 * kd * (Ld - s_star) * v_star / s_star
        u_star = h - v_star
    assert relative_error(LIMIT.load, float(f_star)) < 1e-13
    assert relative_error(LIMIT.deflection, float(u_star)) < 1e-13
    # far branch mirror: minimum -F* at 2h - u*
    assert relative_error(sus.spring_force(2 * H - LIMIT.deflection, SPRING), -LIMIT.load) < 1e-13


# --- continuation and snap-through ---------------------------------------------------------


def _ramp(start, stop, count):
    return [start + (stop - start) * i / (count - 1) for i in range(count)]


def test_loading_ramp_snaps_once_to_far_branch():
    f_star = LIMIT.load
    branch, guess = sus.NEAR, None
    snaps = []
    limit_band = sus.LIMIT_LOAD_RTOL * f_star  # loads within it are the limit load itself
    for load in _ramp(0.0, 1.3 * f_star, 131):
        eq, snapped = sus.follow_load(load, branch, SPRING, guess)
        if load <= f_star + limit_band:
            assert eq.branch == sus.NEAR and not snapped, load
            assert eq.deflection <= LIMIT.deflection
        else:
            assert eq.branch == sus.FAR, load
            assert eq.deflection > 2 * H - LIMIT.deflection
            assert relative_error(sus.spring_force(eq.deflection, SPRING), load) <= 1e-9
        if snapped:
            snaps.append(load)
            assert load > f_star
        at_limit = abs(load - f_star) <= limit_band
        assert eq.marginal == at_limit and eq.stable != at_limit
        assert eq.tangent_stiffness > 0 or at_limit
        assert abs(eq.spring_force - load) <= 1e-9 * max(abs(load), K * L * 1e-6)
        branch, guess = eq.branch, eq.deflection
    assert len(snaps) == 1
    assert snaps[0] - f_star <= 0.01 * f_star + 1e-9 * f_star  # the first load past F*


def test_unloading_from_far_branch_snaps_back_once():
    f_star = LIMIT.load
    branch, guess = sus.FAR, None
    snaps = []
    limit_band = sus.LIMIT_LOAD_RTOL * f_star  # loads within it are the limit load itself
    for load in _ramp(1.3 * f_star, -1.3 * f_star, 261):
        eq, snapped = sus.follow_load(load, branch, SPRING, guess)
        assert eq.marginal == (abs(load + f_star) <= limit_band and eq.branch == sus.FAR)
        if load >= -f_star - limit_band:
            assert eq.branch == sus.FAR and not snapped, load
        else:
            assert eq.branch == sus.NEAR, load
            assert eq.deflection < 0.0  # springs stretched upward
        if snapped:
            snaps.append(load)
        assert abs(sus.spring_force(eq.deflection, SPRING) - load) <= 1e-9 * max(
            abs(load), K * L * 1e-6
        )
        branch, guess = eq.branch, eq.deflection
    assert len(snaps) == 1 and snaps[0] < -f_star


def test_no_continuation_past_limit_raises_snap_through():
    f_star = LIMIT.load
    with pytest.raises(SnapThrough) as info:
        sus.follow_load(1.01 * f_star, sus.NEAR, SPRING, continue_past_limit=False)
    assert repr(f_star) in str(info.value)
    assert "limit load" in str(info.value)
    with pytest.raises(SnapThrough) as info:
        sus.follow_load(-1.01 * f_star, sus.FAR, SPRING, continue_past_limit=False)
    assert repr(-f_star) in str(info.value)
    # below the limit nothing is raised
    eq, snapped = sus.follow_load(0.99 * f_star, sus.NEAR, SPRING, continue_past_limit=False)
    assert not snapped and eq.branch == sus.NEAR


def test_solve_on_branch_raises_snap_through_past_limit():
    with pytest.raises(SnapThrough):
        sus.solve_on_branch(LIMIT.load * (1 + 1e-9), sus.NEAR, SPRING)
    with pytest.raises(SnapThrough):
        sus.solve_on_branch(-LIMIT.load * (1 + 1e-9), sus.FAR, SPRING)


def test_load_exactly_at_limit_converges_to_limit_deflection():
    u = sus.solve_on_branch(LIMIT.load, sus.NEAR, SPRING)
    assert relative_error(sus.spring_force(u, SPRING), LIMIT.load) < 1e-12
    # F is flat there: the deflection is only determined to about sqrt(eps)
    assert abs(u - LIMIT.deflection) < 1e-6


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_loads_raise_range_error(bad):
    for branch in (sus.NEAR, sus.FAR):
        with pytest.raises(RangeError) as info:
            sus.solve_on_branch(bad, branch, SPRING)
        assert info.value.name == "load"
        with pytest.raises(RangeError):
            sus.follow_load(bad, branch, SPRING)


# --- stiff springs -------------------------------------------------------------------------


@pytest.mark.parametrize("k", [1e6, 1e7, 1e8])
def test_stiff_springs_converge(k):
    spring = sus.make_spring(L, k, DB)
    for branch in (sus.NEAR, sus.FAR):
        eq, snapped = sus.follow_load(W_COURSEWORK, branch, spring)
        assert not snapped
        assert relative_error(sus.spring_force(eq.deflection, spring), W_COURSEWORK) <= 1e-9
        assert eq.stable
    near = sus.solve_on_branch(W_COURSEWORK, sus.NEAR, spring)
    # small-deflection limit: u ~ W / (2 k h^2 / L^2)
    assert relative_error(near, W_COURSEWORK / (2 * k * H * H / L**2)) < 100 * W_COURSEWORK / k


# --- property tests ------------------------------------------------------------------------

springs = st.builds(
    lambda length, ratio, log_k: sus.make_spring(length, 10.0**log_k, ratio * length),
    st.floats(0.05, 5.0),
    st.floats(0.02, 0.98),
    st.floats(1.0, 8.0),
)


def _check_solution(spring, load, branch):
    u = sus.solve_on_branch(load, branch, spring)
    assert math.isfinite(u)
    L_, k_, _ = spring
    assert abs(sus.spring_force(u, spring) - load) <= 1e-9 * max(abs(load), k_ * L_ * 1e-6)
    assert sus.tangent_stiffness(u, spring) > 0
    return u


@PROPERTY
@given(springs, st.floats(-2.0, 0.999))
def test_property_near_branch(spring, fraction):
    limit = sus.limit_point(spring)
    u = _check_solution(spring, fraction * limit.load, sus.NEAR)
    assert u <= limit.deflection


@PROPERTY
@given(springs, st.floats(-0.999, 2.0))
def test_property_far_branch(spring, fraction):
    limit = sus.limit_point(spring)
    u = _check_solution(spring, fraction * limit.load, sus.FAR)
    assert u >= 2 * sus.rest_height(spring) - limit.deflection


@PROPERTY
@given(springs, st.floats(-1.0, 1.0))
def test_property_secant_near_zero(spring, scale):
    u = scale * 1e-9 * spring.free_length
    L_, k_, d_ = spring
    limit = 2 * k_ * (L_ - d_) * (L_ + d_) / (L_ * L_)
    assert abs(sus.secant_stiffness(u, spring) - limit) <= 1e-7 * limit
