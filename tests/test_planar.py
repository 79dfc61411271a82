"""The generic planar constraint solver (physics/planar.py) and its linear algebra.

Mechanisms here are built only from the solver's joints and checked against geometry
written out independently: loop closure, an inverted slider-crank (a pin in a rotating slot,
which exercises a line on a moving body) against its closed form, velocities and
accelerations against finite differences of solved positions, and the singular-position
and branch-jump reports.
"""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechfmu.runtime.numerics import linalg
from mechfmu.runtime.errors import SingularConfiguration
from mechfmu.runtime.physics.planar import (
    GROUND,
    PHI,
    X,
    BranchFollower,
    Driver,
    Mechanism,
    NoConvergence,
    PointOnLine,
    Revolute,
    analyse,
    solve_position,
    translational,
)

PROPERTY = settings(derandomize=True, max_examples=100, deadline=None)


# --- linear algebra -------------------------------------------------------------------------


def test_lu_solve_and_determinant_sign():
    matrix = [[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, 0.0, 1.0]]  # det = -5
    factored = linalg.lu_factor(matrix)
    x = linalg.lu_solve(factored, [4.5, 3.0, 6.0])
    assert x == pytest.approx([1.5, 1.5, 1.5], rel=1e-15)
    assert linalg.determinant_sign(factored) == -1
    assert linalg.determinant_sign(linalg.lu_factor([[2.0, 0.0], [0.0, 3.0]])) == 1
    assert linalg.determinant_sign(linalg.lu_factor([[0.0, 1.0], [1.0, 0.0]])) == -1


def test_condition_number():
    assert linalg.condition_number([[2.0, 0.0], [0.0, 1e-6]]) == pytest.approx(2e6, rel=1e-12)
    assert linalg.condition_number([[1.0, 1.0], [1.0, 1.0]]) == math.inf
    with pytest.raises(linalg.Singular):
        linalg.lu_factor([[1.0, 2.0], [2.0, 4.0]])


# --- mechanisms built from joints -------------------------------------------------------------


def four_bar(a, b, c, d):
    """Crank (0), coupler (1), rocker (2); each frame at its first pin, x along the link."""
    joints = [
        Revolute("crank pivot", 0, (0, 0), GROUND, (0, 0)),
        Revolute("crank pin", 0, (a, 0), 1, (0, 0)),
        Revolute("coupler pin", 1, (b, 0), 2, (c, 0)),
        Revolute("rocker pivot", 2, (0, 0), GROUND, (d, 0)),
        Driver("crank angle", ((0, PHI, 1.0),)),
    ]
    return Mechanism("four-bar", ("crank", "coupler", "rocker"), joints, (a + b + c + d) / 4)


def four_bar_guess(a, d, crank, coupler, rocker):
    return [0.0, 0.0, crank, a * math.cos(crank), a * math.sin(crank), coupler, d, 0.0, rocker]


def slot_mechanism(d):
    """Inverted slider-crank: the crank pin A slides in a slot of a rocker pivoted at
    (0, -d). Closed form: rocker angle = atan2(a sin t + d, a cos t)."""
    joints = [
        Revolute("crank pivot", 0, (0, 0), GROUND, (0, 0)),
        Revolute("rocker pivot", 1, (0, 0), GROUND, (0, -d)),
        PointOnLine("slot", 0, (1.0, 0), 1, (0, 0), (1, 0)),
        Driver("crank angle", ((0, PHI, 1.0),)),
    ]
    return Mechanism("slot", ("crank", "rocker"), joints, d)


def slider_crank(a, b, e):
    """Crank (0), coupler (1), slider block (2) on the line y = e along x."""
    joints = [
        Revolute("crank pivot", 0, (0, 0), GROUND, (0, 0)),
        Revolute("crank pin", 0, (a, 0), 1, (0, 0)),
        Revolute("slider pin", 1, (b, 0), 2, (0, 0)),
        *translational("slider", 2, (0, 0), GROUND, (0, e), (1, 0)),
        Driver("crank angle", ((0, PHI, 1.0),)),
    ]
    return Mechanism("slider-crank", ("crank", "coupler", "slider"), joints, a + b)


def closure(q, a, b, c, d):
    ax, ay = a * math.cos(q[2]), a * math.sin(q[2])
    bx, by = ax + b * math.cos(q[5]), ay + b * math.sin(q[5])
    return max(abs(bx - d - c * math.cos(q[8])), abs(by - c * math.sin(q[8])))


def test_coursework_four_bar_closes_and_stays_on_its_circuit():
    a, b, c, d = 2.0, 7.0, 9.0, 6.0
    mechanism = four_bar(a, b, c, d)
    follower = BranchFollower(mechanism)
    start = math.radians(30.0)
    solution = follower.assemble(four_bar_guess(a, d, start, 1.5, 2.0), [(start, 1.0, 0.0)])
    assert closure(solution.q, a, b, c, d) < 1e-14
    sign = follower.sign
    for k in range(1, 361):
        crank = start + math.radians(k)
        solution = follower.follow([(crank, 1.0, 0.0)], math.radians(1.0))
        assert closure(solution.q, a, b, c, d) < 1e-14
        assert solution.q[2] == crank
        assert 1 <= solution.iterations <= 3
        assert solution.condition < 1e3
    assert follower.sign == sign
    # After a full revolution the linkage is back where it started.
    first = follower.assemble(four_bar_guess(a, d, start, 1.5, 2.0), [(start, 1.0, 0.0)])
    assert math.remainder(solution.q[8] - first.q[8], 2 * math.pi) == pytest.approx(0, abs=1e-13)


def finite_difference_check(mechanism, guess, angle, speed, acceleration, h=1e-4):
    """q', q'' from the solver against central differences of positions along
    crank(t) = angle + speed t + acceleration t^2 / 2 at t = 0."""

    def position(t):
        drive = [(angle + speed * t + 0.5 * acceleration * t * t, 0.0, 0.0)]
        return solve_position(mechanism, guess, drive)[0]

    q0 = position(0.0)
    qdot, qddot, _, _ = analyse(mechanism, q0, [(angle, speed, acceleration)])
    plus, minus = position(h), position(-h)
    plus2, minus2 = position(2 * h), position(-2 * h)
    for i in range(mechanism.size):
        velocity = (8 * (plus[i] - minus[i]) - (plus2[i] - minus2[i])) / (12 * h)
        second = (-plus2[i] + 16 * plus[i] - 30 * q0[i] + 16 * minus[i] - minus2[i]) / (12 * h * h)
        assert qdot[i] == pytest.approx(velocity, rel=1e-8, abs=1e-9)
        assert qddot[i] == pytest.approx(second, rel=1e-5, abs=1e-5)
    return q0, qdot, qddot


@pytest.mark.parametrize(
    "mechanism, guess",
    [
        (four_bar(2.0, 7.0, 9.0, 6.0), four_bar_guess(2.0, 6.0, 1.0, 1.5, 2.0)),
        (slot_mechanism(0.3), [0.0, 0.0, 1.0, 0.0, -0.3, 1.2]),
        (slider_crank(0.05, 0.15, 0.02), [0, 0, 1.0, 0.027, 0.042, -0.15, 0.18, 0.02, 0.0]),
    ],
)
def test_velocity_and_acceleration_against_finite_differences(mechanism, guess):
    finite_difference_check(mechanism, guess, 1.0, 3.0, -7.0)


@PROPERTY
@given(
    st.floats(-math.pi, math.pi),
    st.floats(-50.0, 50.0),
    st.floats(-500.0, 500.0),
    st.floats(0.15, 3.0),
)
def test_slot_against_its_closed_form(angle, speed, acceleration, d):
    """Pin at radius 1 in the slot of a rocker pivoted at distance d > 1 below the crank:
    rocker angle psi = atan2(sin t + d, cos t), rates by differentiating tan(psi)."""
    if d <= 1.0:
        d += 1.01
    mechanism = slot_mechanism(d)
    psi = math.atan2(math.sin(angle) + d, math.cos(angle))
    q, _, _ = solve_position(mechanism, [0, 0, angle, 0, -d, psi + 0.05], [(angle, 0, 0)])
    qdot, qddot, _, _ = analyse(mechanism, q, [(angle, speed, acceleration)])
    assert math.remainder(q[5] - psi, 2 * math.pi) == pytest.approx(0.0, abs=1e-13)
    # psi' = w (1 + d sin t) / r^2 with r^2 = 1 + d^2 + 2 d sin t (pin distance squared)
    r2 = 1 + d * d + 2 * d * math.sin(angle)
    g = (1 + d * math.sin(angle)) / r2
    dg = (d * math.cos(angle) * r2 - (1 + d * math.sin(angle)) * 2 * d * math.cos(angle)) / r2**2
    assert qdot[5] == pytest.approx(speed * g, rel=1e-10, abs=1e-12)
    assert qddot[5] == pytest.approx(acceleration * g + speed * speed * dg, rel=1e-9, abs=1e-9)


def test_slider_crank_on_the_solver_matches_the_slider_axis():
    a, b, e = 0.05, 0.15, 0.02
    mechanism = slider_crank(a, b, e)
    follower = BranchFollower(mechanism)
    follower.assemble([0, 0, 0.0, a, 0, -0.1, a + b, e, 0.0], [(0.0, 10.0, 0.0)])
    for k in range(1, 73):
        crank = math.radians(5.0 * k)
        q = follower.follow([(crank, 10.0, 0.0)], math.radians(5.0) / 10.0).q
        slider = a * math.cos(crank) + math.sqrt(b * b - (e - a * math.sin(crank)) ** 2)
        assert q[6] == pytest.approx(slider, rel=1e-14)
        assert q[7] == pytest.approx(e, abs=1e-15)
        assert q[8] == pytest.approx(0.0, abs=1e-15)


def test_big_drive_changes_are_followed_by_continuation():
    a, b, c, d = 2.0, 7.0, 9.0, 6.0
    follower = BranchFollower(four_bar(a, b, c, d))
    start = math.radians(30.0)
    follower.assemble(four_bar_guess(a, d, start, 1.5, 2.0), [(start, 1.0, 0.0)])
    sign = follower.sign
    # Two and a half turns in one call: the predictor alone cannot get there.
    solution = follower.follow([(start + 5 * math.pi, 1.0, 0.0)], 0.0)
    assert solution.iterations > 3
    assert closure(solution.q, a, b, c, d) < 1e-14
    assert follower.sign == sign
    reference = BranchFollower(four_bar(a, b, c, d))
    direct = reference.assemble(
        four_bar_guess(a, d, start + math.pi, 1.5, 2.0), [(start + math.pi, 1.0, 0.0)]
    )
    assert reference.sign == sign  # same circuit as the guess-assembled configuration
    assert math.remainder(solution.q[8] - direct.q[8], 2 * math.pi) == pytest.approx(0, abs=1e-12)


def test_toggle_position_is_reported_with_the_configuration():
    """Non-Grashof 4-bar (a, b, c, d) = (3, 2, 2.5, 4): the crank's limit is where coupler
    and rocker are collinear, |A - O4| = b + c."""
    a, b, c, d = 3.0, 2.0, 2.5, 4.0
    limit = math.acos((a * a + d * d - (b + c) ** 2) / (2 * a * d))
    mechanism = four_bar(a, b, c, d)
    follower = BranchFollower(mechanism)
    follower.assemble(four_bar_guess(a, d, 0.5, 1.0, 2.0), [(0.5, 1.0, 0.0)])
    crank = 0.5
    with pytest.raises((SingularConfiguration, NoConvergence)) as raised:
        while crank < limit + 0.1:
            crank += 0.01
            follower.follow([(crank, 1.0, 0.0)], 0.01)
    assert crank == pytest.approx(limit, abs=0.011)
    assert "four-bar" in str(raised.value)
    # Exactly at the toggle: singular, with the condition number in the message.
    ax, ay = a * math.cos(limit), a * math.sin(limit)
    toward = math.atan2(-ay, d - ax)
    q = [0, 0, limit, ax, ay, toward, d, 0, toward + math.pi]
    with pytest.raises(SingularConfiguration, match="condition number"):
        analyse(mechanism, q, [(limit, 1.0, 0.0)])


def test_equation_count_must_match_coordinates():
    with pytest.raises(ValueError, match="3 constraint equations for 6 coordinates"):
        Mechanism(
            "short",
            ("a", "b"),
            [Revolute("r", 0, (0, 0), GROUND, (0, 0)), Driver("d", ((0, X, 1.0),))],
            1.0,
        )
