"""The standard-library ODE integrators: orders, tolerances, work counts, events, stiffness."""

import ast
import math
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechfmu.runtime.numerics import integrators as ig
from mechfmu.runtime.errors import IntegrationError, MechanismError
from mechfmu.runtime.numerics.integrators import METHODS, Event, make_integrator

G = 9.81
ADAPTIVE = ("dopri5", "radau")
FIXED = ("euler", "rk4")


def decay(t, y):
    return [-y[0]]


def oscillator(t, y):
    return [y[1], -y[0]]


def free_fall(t, y):
    return [y[1], -G]


def stiff(lam):
    return lambda t, y: [-lam * (y[0] - math.cos(t))]


def stiff_exact(lam, t):
    """y' = -lam (y - cos t), y(0) = 1."""
    return (lam * lam * math.cos(t) + lam * math.sin(t)) / (lam * lam + 1) + math.exp(-lam * t) / (
        lam * lam + 1
    )


PROBLEMS = {
    "decay": (decay, [1.0], lambda t: [math.exp(-t)]),
    "oscillator": (oscillator, [1.0, 0.0], lambda t: [math.cos(t), -math.sin(t)]),
}


class Counting:
    """rhs wrapper counting its calls independently of Stats."""

    def __init__(self, rhs):
        self.rhs = rhs
        self.calls = 0

    def __call__(self, t, y):
        self.calls += 1
        return self.rhs(t, y)


def global_error(method, problem, t_end=5.0, **options):
    rhs, y0, exact = PROBLEMS[problem]
    integrator = make_integrator(method, **options)
    result = integrator.advance(rhs, 0.0, y0, t_end)
    assert result.t == t_end and result.event is None
    return max(abs(a - b) for a, b in zip(result.y, exact(t_end))), integrator


# --- convergence orders --------------------------------------------------------------------


@pytest.mark.parametrize("problem", PROBLEMS)
@pytest.mark.parametrize("method, order, h", [("euler", 1, 0.01), ("rk4", 4, 0.1)])
def test_observed_order_of_fixed_step_methods(method, order, h, problem):
    coarse, run = global_error(method, problem, max_substep=h)
    fine, _ = global_error(method, problem, max_substep=h / 2)
    assert run.stats.substeps == round(5.0 / h)
    slope = math.log2(coarse / fine)
    assert abs(slope - order) <= 0.3, slope


# --- adaptive methods meet their tolerance -------------------------------------------------


@pytest.mark.parametrize("problem", PROBLEMS)
@pytest.mark.parametrize("method", ADAPTIVE)
def test_adaptive_error_scales_with_rtol(method, problem):
    errors = []
    for rtol in (1e-4, 1e-6, 1e-8, 1e-10):
        error, _ = global_error(method, problem, rtol=rtol, atol=1e-2 * rtol)
        assert error < 100 * rtol, (rtol, error)
        errors.append(error)
    assert errors[-1] < 1e-4 * errors[0]  # six decades of rtol buy at least four of error


@pytest.mark.parametrize("problem", PROBLEMS)
@pytest.mark.parametrize("method", ADAPTIVE)
def test_adaptive_methods_need_far_fewer_steps(method, problem):
    error, run = global_error(method, problem, rtol=1e-8, atol=1e-10)
    assert error < 1e-6
    # fixed-step sub-steps for the same accuracy, extrapolated from their measured orders
    target = max(error, 1e-14)
    euler_error, _ = global_error("euler", problem, max_substep=0.01)
    rk4_error, _ = global_error("rk4", problem, max_substep=0.1)
    euler_steps = 500 * euler_error / target
    rk4_steps = 50 * (rk4_error / target) ** 0.25
    assert run.stats.substeps < euler_steps / 1000
    assert run.stats.substeps < rk4_steps / 2
    assert run.stats.substeps < {"dopri5": 100, "radau": 300}[method]


@settings(derandomize=True, max_examples=15, deadline=None)
@given(lam=st.floats(-20.0, 1.0), y0=st.floats(-10.0, 10.0), method=st.sampled_from(ADAPTIVE))
def test_adaptive_linear_scalar_equation(lam, y0, method):
    integrator = make_integrator(method, rtol=1e-7, atol=1e-9)
    result = integrator.advance(lambda t, y: [lam * y[0]], 0.0, [y0], 1.0)
    exact = y0 * math.exp(lam)
    assert abs(result.y[0] - exact) <= 100 * (1e-7 * max(abs(y0), abs(exact)) + 1e-9)


@pytest.mark.parametrize("method", ADAPTIVE)
def test_adaptive_methods_honour_max_substep(method):
    loose = dict(rtol=1e-4, atol=1e-6)
    _, free = global_error(method, "decay", t_end=2.0, **loose)
    assert free.stats.substeps < 30  # y' = -y alone allows long steps at this tolerance
    _, capped = global_error(method, "decay", t_end=2.0, max_substep=0.05, **loose)
    assert capped.stats.substeps >= 40
    warm = make_integrator(method, max_substep=0.05, **loose)
    t, y = 0.0, [1.0]
    for _ in range(5):
        t, y, _ = warm.advance(decay, t, y, t + 0.5)
    before = warm.stats.substeps
    warm.advance(decay, t, y, t + 0.5)
    assert warm.stats.substeps - before == 10


# --- exact right-hand-side counts ------------------------------------------------------------


@pytest.mark.parametrize("method, per_step", [("euler", 1), ("rk4", 4)])
def test_fixed_step_rhs_counts(method, per_step):
    integrator = make_integrator(method, max_substep=0.01)
    rhs = Counting(oscillator)
    result = integrator.advance(rhs, 0.0, [1.0, 0.0], 1.0)
    assert result.t == 1.0
    assert integrator.stats.substeps == 100
    assert rhs.calls == integrator.stats.rhs_evaluations == per_step * 100
    integrator.advance(rhs, 1.0, result.y, 1.5)  # counters accumulate
    assert integrator.stats.substeps == 150
    assert rhs.calls == integrator.stats.rhs_evaluations == per_step * 150
    integrator.stats.reset()
    assert (integrator.stats.rhs_evaluations, integrator.stats.substeps) == (0, 0)


def test_fixed_step_with_infinite_max_substep_takes_one_substep_per_call():
    for method, per_step in (("euler", 1), ("rk4", 4)):
        integrator = make_integrator(method)
        rhs = Counting(decay)
        t, y = 0.0, [1.0]
        for k in range(10):
            t, y, _ = integrator.advance(rhs, t, y, (k + 1) * 0.01)
        assert integrator.stats.substeps == 10 and rhs.calls == 10 * per_step
        assert abs(y[0] - math.exp(-0.1)) < (1e-3 if method == "euler" else 1e-11)


def test_dopri5_costs_six_rhs_per_step_after_the_first():
    integrator = make_integrator("dopri5", rtol=1e-8, atol=1e-10)
    rhs = Counting(oscillator)
    result = integrator.advance(rhs, 0.0, [1.0, 0.0], 5.0)
    stats = integrator.stats
    attempts = stats.substeps + stats.rejected
    # f(t0, y0) + starting-step heuristic + 6 per attempted step (FSAL)
    assert rhs.calls == stats.rhs_evaluations == 2 + 6 * attempts
    # a warm call: f(t0, y0) once, then 6 per attempted step
    calls, attempts_before = rhs.calls, attempts
    integrator.advance(rhs, 5.0, result.y, 10.0)
    attempts = stats.substeps + stats.rejected
    assert rhs.calls - calls == 1 + 6 * (attempts - attempts_before)
    assert rhs.calls == stats.rhs_evaluations


@pytest.mark.parametrize("problem", PROBLEMS)
def test_radau_counts_every_evaluation(problem):
    rhs, y0, _ = PROBLEMS[problem]
    counted = Counting(rhs)
    integrator = make_integrator("radau")
    integrator.advance(counted, 0.0, y0, 5.0)
    stats = integrator.stats
    assert counted.calls == stats.rhs_evaluations
    assert stats.jacobians >= 1
    # at least f(t0) + the starting heuristic + one Newton sweep (3 stages) per attempt
    assert (
        stats.rhs_evaluations
        >= 2 + 3 * (stats.substeps + stats.rejected) + len(y0) * stats.jacobians
    )


# --- events --------------------------------------------------------------------------------

FALL_TIME = math.sqrt(2.0 / G)
GROUND = Event("ground", lambda t, y: y[0], direction=-1)


def euler_fall_root(h):
    """Root of Euler's own free-fall solution (linear inside each sub-step), 1 m drop."""
    k = 0
    height, speed = 1.0, 0.0
    while height + h * speed > 0.0:
        height, speed, k = height + h * speed, speed - G * h, k + 1
    return k * h + height / -speed


@pytest.mark.parametrize("method", METHODS)
def test_free_fall_ground_event(method):
    max_substep = 1e-3 if method == "euler" else math.inf
    integrator = make_integrator(method, max_substep=max_substep)
    result = integrator.advance(free_fall, 0.0, [1.0, 0.0], 1.0, events=[GROUND])
    assert result.event is GROUND
    if method == "euler":
        # located to 1e-10 on Euler's trajectory, which is O(h) from the exact fall time
        assert abs(result.t - euler_fall_root(1e-3)) <= 1e-10
        assert abs(result.t - FALL_TIME) < G * 1e-3
        assert abs(result.y[0]) <= abs(result.y[1]) * 1e-11
    else:
        # rk4, dopri5 and radau reproduce the quadratic fall exactly (up to rounding)
        assert abs(result.t - FALL_TIME) <= 1e-10
        assert abs(result.y[0]) <= 1e-9
        assert abs(result.y[1] + G * FALL_TIME) <= 1e-8
    assert result.y[0] <= 0.0  # the returned point lies on or just past the surface


def through_half_metre(direction):
    return Event("half", lambda t, y: y[0] - 0.5, direction=direction)


def throw_roots():
    # y = 0.2 + 3 t - G t^2 / 2 = 0.5
    a, b, c = -G / 2, 3.0, -0.3
    d = math.sqrt(b * b - 4 * a * c)
    return sorted(((-b + d) / (2 * a), (-b - d) / (2 * a)))


@pytest.mark.parametrize("method", ("rk4", "dopri5", "radau"))
def test_event_direction_filter(method):
    rising, falling = throw_roots()
    expected = {1: rising, -1: falling, 0: rising}
    for direction, t_expected in expected.items():
        integrator = make_integrator(method, max_substep=0.05)
        event = through_half_metre(direction)
        result = integrator.advance(free_fall, 0.0, [0.2, 3.0], 2.0, events=[event])
        assert result.event is event
        assert abs(result.t - t_expected) <= 1e-10
        assert abs(result.y[0] - 0.5) <= 1e-9


@pytest.mark.parametrize("method", METHODS)
def test_restarting_at_an_event_does_not_retrigger_it(method):
    rising, falling = throw_roots()
    event = through_half_metre(0)
    integrator = make_integrator(method, max_substep=0.01)
    first = integrator.advance(free_fall, 0.0, [0.2, 3.0], 2.0, events=[event])
    second = integrator.advance(free_fall, first.t, first.y, 2.0, events=[event])
    assert second.event is event
    tolerance = 1e-10 if method != "euler" else 0.05
    assert abs(first.t - rising) <= tolerance and abs(second.t - falling) <= tolerance
    assert second.t - first.t > 0.1


@pytest.mark.parametrize("method", METHODS)
def test_event_exactly_at_start_is_not_reported(method):
    integrator = make_integrator(method, max_substep=0.01)
    # starts on the ground, falling: g(t0) == 0 and then negative
    result = integrator.advance(free_fall, 0.0, [0.0, -1.0], 0.1, events=[GROUND])
    assert result.event is None and result.t == 0.1
    # also with both directions, and starting on the surface moving up
    both = Event("level", lambda t, y: y[0], direction=0)
    result = integrator.advance(free_fall, 0.0, [0.0, 1.0], 0.1, events=[both])
    assert result.event is None


@pytest.mark.parametrize("method", METHODS)
def test_earliest_of_several_events_and_non_terminal_ignored(method):
    late = Event("late", lambda t, y: y[0] - 0.2, direction=-1)
    early = Event("early", lambda t, y: y[0] - 0.8, direction=-1)
    ignored = Event("ignored", lambda t, y: y[0] - 0.9, direction=-1, terminal=False)
    integrator = make_integrator(method, max_substep=0.5)
    result = integrator.advance(free_fall, 0.0, [1.0, 0.0], 1.0, events=[late, ignored, early])
    assert result.event is early
    t_expected = math.sqrt(2 * 0.2 / G)
    tolerance = 1e-10 if method != "euler" else 0.5 * G * 0.5
    assert abs(result.t - t_expected) <= tolerance


def test_event_location_counts_rhs_evaluations():
    integrator = make_integrator("rk4")
    rhs = Counting(free_fall)
    integrator.advance(rhs, 0.0, [1.0, 0.0], 1.0, events=[GROUND])
    assert rhs.calls == integrator.stats.rhs_evaluations
    assert rhs.calls > 4  # the trial sub-steps of the root search are counted (3 each)
    assert (rhs.calls - 4) % 3 == 0


# --- stiffness -----------------------------------------------------------------------------


@pytest.mark.parametrize("lam", [1e6, 1e8])
def test_radau_is_stable_and_accurate_on_stiff_problem(lam):
    integrator = make_integrator("radau")
    t, y = 0.0, [1.0]
    for k in range(10):
        t, y, _ = integrator.advance(stiff(lam), t, y, (k + 1) / 10)
        assert abs(y[0] - math.cos(t)) < 1e-6
        assert abs(y[0] - stiff_exact(lam, t)) < 1e-8
    assert integrator.stats.substeps < 2000
    assert integrator.stats.substeps < 100  # steps far beyond 1 / lam
    assert integrator.stats.jacobians <= 5


@pytest.mark.parametrize("lam", [1e6, 1e8])
@pytest.mark.parametrize("method", FIXED)
def test_explicit_fixed_step_methods_report_instability(method, lam):
    integrator = make_integrator(method, max_substep=1e-3)
    with pytest.raises(IntegrationError) as info:
        integrator.advance(stiff(lam), 0.0, [1.0], 1.0)
    message = str(info.value)
    assert message.startswith(f"{method}:") and "unstable" in message
    assert "radau" in message and "max_substep" in message
    assert integrator.stats.substeps < 20  # caught within a few sub-steps


def test_instability_spread_over_calls_never_returns_non_finite():
    integrator = make_integrator("euler")  # one sub-step per call: growth x999 per call
    t, y = 0.0, [1.0]
    with pytest.raises(IntegrationError, match="unstable"):
        for k in range(1000):
            t, y, _ = integrator.advance(stiff(1e6), t, y, t + 1e-3)
            assert math.isfinite(y[0])


@pytest.mark.parametrize("lam, t_end", [(1e6, 1e-2), (1e8, 1e-4)])
def test_dopri5_on_stiff_problem_is_finite_or_raises(lam, t_end):
    integrator = make_integrator("dopri5")
    try:
        result = integrator.advance(stiff(lam), 0.0, [1.0], t_end)
    except IntegrationError as error:
        assert str(error).startswith("dopri5:")
    else:
        assert all(math.isfinite(v) for v in result.y)
        assert abs(result.y[0] - stiff_exact(lam, t_end)) < 1e-6
    attempts = integrator.stats.substeps + integrator.stats.rejected
    # bounded by the stability limit (|h lam| <= ~3.3): not much more than lam t_end / 3.3
    assert attempts < 1.0 * lam * t_end
    assert attempts <= ig.MAX_SUBSTEPS


# --- step size memory ------------------------------------------------------------------------


@pytest.mark.parametrize("method", ADAPTIVE)
def test_step_size_carries_over_between_calls(method):
    warm = make_integrator(method)
    cold = make_integrator(method)
    t, y = 0.0, [1.0, 0.0]
    warm_counts, cold_counts = [], []
    for k in range(10):
        before_w, before_c = warm.stats.substeps, cold.stats.substeps
        t_end = (k + 1) * 0.5
        cold.restart()
        cold.advance(oscillator, t, y, t_end)
        t, y, _ = warm.advance(oscillator, t, y, t_end)
        warm_counts.append(warm.stats.substeps - before_w)
        cold_counts.append(cold.stats.substeps - before_c)
    assert warm_counts[1] <= warm_counts[0]
    assert max(warm_counts[1:]) <= warm_counts[0]
    assert sum(warm_counts[1:]) < sum(cold_counts[1:])
    assert abs(y[0] - math.cos(5.0)) < 1e-6


# --- arguments and failures ------------------------------------------------------------------


def test_unknown_method_names_the_choices():
    with pytest.raises(MechanismError) as info:
        make_integrator("rk45")
    for name in METHODS:
        assert name in str(info.value)
    assert "'rk45'" in str(info.value)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("t_end", [1.0, 0.5])
def test_non_positive_interval_is_rejected(method, t_end):
    integrator = make_integrator(method)
    with pytest.raises(MechanismError, match="t_end") as info:
        integrator.advance(decay, 1.0, [1.0], t_end)
    assert isinstance(info.value, IntegrationError)


@pytest.mark.parametrize(
    "options",
    [
        dict(rtol=-1.0),
        dict(atol=math.nan),
        dict(rtol=0.0),
        dict(max_substep=0.0),
        dict(max_substep=math.nan),
    ],
)
def test_bad_parameters_are_rejected(options):
    with pytest.raises(MechanismError):
        make_integrator("dopri5", **options)


def test_bad_state_and_rhs_are_reported():
    integrator = make_integrator("rk4", max_substep=0.1)
    with pytest.raises(IntegrationError, match="y\\[0\\]"):
        integrator.advance(decay, 0.0, [math.nan], 1.0)
    with pytest.raises(IntegrationError, match="2 values"):
        integrator.advance(lambda t, y: [0.0, 0.0], 0.0, [1.0], 1.0)
    for method in METHODS:
        with pytest.raises(IntegrationError, match="non-finite derivative"):
            make_integrator(method).advance(lambda t, y: [math.nan], 0.0, [1.0], 1.0)
    with pytest.raises(MechanismError):
        Event("bad", lambda t, y: 0.0, direction=2)


@pytest.mark.parametrize("method", ADAPTIVE)
def test_derivative_blowing_up_in_finite_time_raises(method):
    # y' = y^2, y(0) = 1 has its pole at t = 1: no finite answer at t = 2
    integrator = make_integrator(method)
    with pytest.raises(IntegrationError, match=method):
        integrator.advance(lambda t, y: [y[0] * y[0]], 0.0, [1.0], 2.0)


def test_dense_solver_with_partial_pivoting():
    n = 10
    a = [
        [1.0 / (i + j + 1) + (3.0 if i == (j + 3) % n else 0.0) for j in range(n)] for i in range(n)
    ]
    a[0][0] = 0.0  # needs pivoting
    x = [math.sin(i + 1) for i in range(n)]
    b = [sum(a[i][j] * x[j] for j in range(n)) for i in range(n)]
    solved = ig._lu_solve(ig._lu_factor(a), b)
    assert max(abs(u - v) for u, v in zip(solved, x)) < 1e-12
    c = [[a[i][j] * (1 + 0.5j) + (2j if i == j else 0) for j in range(n)] for i in range(n)]
    bc = [sum(c[i][j] * x[j] for j in range(n)) for i in range(n)]
    solved = ig._lu_solve(ig._lu_factor(c), bc)
    assert max(abs(u - v) for u, v in zip(solved, x)) < 1e-12


def test_module_imports_only_the_standard_library():
    source = Path(ig.__file__).read_text()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level > 0:
                assert node.module in (
                    "errors",
                    "linalg",
                    "roots",
                )  # runtime modules, themselves stdlib-only
                continue
            names = [node.module]
        else:
            continue
        for name in names:
            assert name.split(".")[0] in sys.stdlib_module_names, name
