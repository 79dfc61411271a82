"""The constraint solver's compiled kernels (planar_kernel) against planar.py's generic
assembly and linear algebra, on the coursework's mechanisms at configurations along a motion."""

import math
import random

import pytest

from mechfmu.runtime.numerics import linalg
from mechfmu.runtime.physics import constraint_models, planar, planar_kernel
from mechfmu.runtime.physics import four_bar as fb
from mechfmu.runtime.physics import valve_train as vt


def mechanisms():
    """(mechanism, follower, drives) triples: a mechanism assembled, and drive values along
    its motion."""
    four_bar = constraint_models.four_bar(*fb.COURSEWORK_FOUR_BAR)
    ground, crank, _, _ = fb.COURSEWORK_FOUR_BAR
    start = 0.3
    coupler, rocker = fb.position(*fb.COURSEWORK_FOUR_BAR, start, 0)
    yield (
        four_bar,
        constraint_models.four_bar_guess(ground, crank, start, coupler, rocker),
        [[(start + 0.05 * k, 2.0 + 0.1 * k, -1.5)] for k in range(60)],
    )
    slider = constraint_models.slider_crank(0.05, 0.2, 0.01)
    yield (
        slider,
        constraint_models.slider_crank_guess(0.05, 0.01, 0.0, 0.0, 0.25 - 0.0),
        [[(0.07 * k, 100.0, 3.0)] for k in range(60)],
    )
    geometry = vt.DEFAULT_VALVE_GEOMETRY
    valve = constraint_models.valve_train(geometry)
    yield (
        valve,
        constraint_models.valve_train_guess(geometry),
        [[(geometry.cam_base_radius + 0.0002 * k, 0.5, 20.0)] for k in range(40)],
    )


def relative(a, b):
    return max(abs(x - y) for x, y in zip(a, b)) / max(1.0, max(map(abs, b)))


@pytest.mark.parametrize("case", list(mechanisms()), ids=["four-bar", "slider-crank", "valve"])
def test_kernels_match_the_generic_assembly_and_solves(case):
    mechanism, guess, drives = case
    kernel = planar_kernel.MechanismKernel(mechanism)
    follower = planar.BranchFollower(mechanism)
    follower.assemble(guess, drives[0])
    rng = random.Random(21)
    worst = math.inf
    for drive in drives[1:]:
        q = list(follower.follow(drive, 1e-3).q)
        qdot = [rng.uniform(-1.0, 1.0) for _ in q]
        assert relative(kernel.residual(q, drive), mechanism.residual(q, drive)) < 1e-14
        dense = kernel.dense(kernel.jacobian(q))
        generic = mechanism.jacobian(q)
        assert (
            relative([v for row in dense for v in row], [v for row in generic for v in row]) < 1e-14
        )
        residual, values = kernel.residual_jacobian(q, drive)
        assert values == kernel.jacobian(q) and residual == kernel.residual(q, drive)
        assert relative(kernel.gamma(q, qdot, drive), mechanism.gamma(q, qdot, drive)) < 1e-13
        assert kernel.one_norm(kernel.jacobian(q)) == pytest.approx(
            linalg.one_norm(generic), rel=1e-14
        )
        factored = linalg.lu_factor(generic)
        lu = kernel.lu(tuple(factored[1]))
        factors = lu.factor(kernel.jacobian(q))
        assert factors is not None
        b = [rng.uniform(-1.0, 1.0) for _ in q]
        assert relative(lu.solve(factors, b), linalg.lu_solve(factored, b)) < 1e-12
        transposed = [list(column) for column in zip(*generic)]
        assert (
            relative(lu.solve_t(factors, b), linalg.lu_solve(linalg.lu_factor(transposed), b))
            < 1e-12
        )
        assert lu.sign(factors) == linalg.determinant_sign(factored)
        # Hager's estimate: a lower bound of ||A^-1||_1; from (1/n, ..., 1/n), as LAPACK
        # starts, within 10 % here; from a unit vector a lower bound still.
        exact = linalg.condition_number(generic) / linalg.one_norm(generic)
        estimate, column = planar_kernel.inverse_one_norm(lu, factors, len(q))
        assert exact * 0.9 <= estimate <= exact * (1.0 + 1e-12) and 0 <= column < len(q)
        for start in (0, len(q) - 1):
            estimate, column = planar_kernel.inverse_one_norm(lu, factors, len(q), start)
            assert estimate <= exact * (1.0 + 1e-12) and 0 <= column < len(q)
        # The solver's own, started from the column of the step before, along the motion.
        solution = follower.solution
        assert solution.condition <= linalg.condition_number(generic) * (1.0 + 1e-12)
        worst = min(worst, solution.condition / linalg.condition_number(generic))
    assert worst >= 0.9


def test_fixed_row_order_refuses_a_small_pivot():
    # [[eps, 1], [1, 1]] factored in the natural order would divide by eps.
    mechanism_pattern = [(0, 0), (0, 1), (1, 0), (1, 1)]
    lu = planar_kernel.LuKernel(mechanism_pattern, 2, (0, 1), (1.0, 1.0))
    assert lu.factor((1e-3, 1.0, 1.0, 1.0)) is None
    swapped = planar_kernel.LuKernel(mechanism_pattern, 2, (1, 0), (1.0, 1.0))
    factors = swapped.factor((1e-3, 1.0, 1.0, 1.0))
    x = swapped.solve(factors, [1.0, 2.0])
    assert x == pytest.approx([1.0 / (1.0 - 1e-3), 2.0 - 1.0 / (1.0 - 1e-3)], rel=1e-14)
    assert swapped.sign(factors) == -1  # det = 1e-3 - 1


def test_an_exact_guess_skips_the_chord_and_keeps_the_solution():
    # A valve train whose drive holds still, then moves: while it holds, the predictor is
    # exact and the fast path starts with Newton's correction from the guess (no chord);
    # the positions, rates and iterations stay those of the generic solver.
    geometry = vt.DEFAULT_VALVE_GEOMETRY
    valve = constraint_models.valve_train(geometry)
    follower = planar.BranchFollower(valve)
    height = geometry.cam_base_radius
    follower.assemble(constraint_models.valve_train_guess(geometry), [(height, 0.0, 0.0)])
    drives = [[(height, 0.0, 0.0)]] * 5 + [
        [(height + 2e-5 * k * k, 4e-5 * k / 1e-3, 4e-5 / 1e-6)] for k in range(1, 6)
    ]
    seen_exact = False
    for drive in drives:
        exact = follower.exact_guess
        seen_exact = seen_exact or exact
        state = follower.snapshot()
        solution = follower.follow(drive, 1e-3)
        assert 1 <= solution.iterations <= 3
        q, iterations, residual = planar.solve_position(valve, list(solution.q), drive)
        qdot, qddot, _, _ = planar.analyse(valve, q, drive)
        assert relative(solution.q, q) < 1e-13
        assert relative(solution.qdot, qdot) < 1e-12
        assert relative(solution.qddot, qddot) < 1e-10
        # rolled back, the step is taken again the same way, to the same numbers
        follower.restore(state)
        assert follower.exact_guess == exact
        again = follower.follow(drive, 1e-3)
        assert relative(again.q, solution.q) < 1e-15 and again.iterations == solution.iterations
    assert seen_exact and not follower.exact_guess  # the moving drive is not predicted exactly


def test_one_kernel_per_mechanism_shape_in_a_process():
    """Followers of the same mechanism (built twice) share one compiled kernel and its LU
    kernels; another geometry gets its own; the cache keeps KERNEL_CACHE_SIZE shapes."""
    planar_kernel._KERNELS.clear()
    first = planar.BranchFollower(constraint_models.four_bar(*fb.COURSEWORK_FOUR_BAR))
    again = planar.BranchFollower(constraint_models.four_bar(*fb.COURSEWORK_FOUR_BAR))
    assert first.kernel is not None and first.kernel is again.kernel
    ground, crank, coupler, rocker = fb.COURSEWORK_FOUR_BAR
    other = planar.BranchFollower(constraint_models.four_bar(ground, crank * 1.1, coupler, rocker))
    assert other.kernel is not first.kernel
    # the shared kernel follows both as a kernel of its own would
    start = 0.3
    coupler_angle, rocker_angle = fb.position(*fb.COURSEWORK_FOUR_BAR, start, 0)
    guess = constraint_models.four_bar_guess(ground, crank, start, coupler_angle, rocker_angle)
    for follower in (first, again):
        follower.assemble(guess, [(start, 2.0, 0.0)])
        assert follower.follow([(start + 0.01, 2.0, 0.0)], 5e-3).q == first.solution.q
    for k in range(planar_kernel.KERNEL_CACHE_SIZE + 3):
        planar.BranchFollower(constraint_models.four_bar(ground + 1e-3 * k, crank, coupler, rocker))
    assert len(planar_kernel._KERNELS) == planar_kernel.KERNEL_CACHE_SIZE
