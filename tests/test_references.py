"""The numpy references against the standard-library physics, the coursework's printed
numbers, and the committed seed report."""

import ast
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

import mechfmu.references
from mechfmu.runtime.physics import landing_gear as plg
from mechfmu.runtime.physics import profiles as pprof
from mechfmu.runtime.physics import suspension as psp
from mechfmu.references import drives
from mechfmu.references import landing_gear as lg
from mechfmu.references import suspension as sp
from mechfmu.tools.report.seed_report import build_report

REPO_ROOT = Path(__file__).resolve().parent.parent
RTOL = 1e-12

GEOMETRIES = [  # (d, h): coursework in m and in ft, d > h, d close to h
    plg.DEFAULT_GEOMETRY[:2],
    lg.design_geometry(1.25, 2.0)[:2],
    (1.7, 0.6),
    (0.9, 1.0),
]
SPRINGS = [  # (L, k, d)
    (psp.COURSEWORK_FREE_LENGTH, psp.COURSEWORK_STIFFNESS, psp.COURSEWORK_BASE_OFFSET),
    (0.3, 2.5e5, 0.05),
    (1.0, 1.0e7, 0.8),
    (0.5, 1.0e4, 0.45),
]
L0, K0, D0 = SPRINGS[0]
W0 = psp.COURSEWORK_MASS * psp.GRAVITY


def close(actual, expected, rtol=RTOL, scale=None):
    """|actual - expected| <= rtol * max(|expected|, scale) elementwise.

    ``scale`` (default: the largest |expected|) keeps values that cross zero from demanding
    an impossible relative accuracy.
    """
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    if scale is None:
        scale = float(np.max(np.abs(expected)))
    bound = rtol * np.maximum(np.abs(expected), scale)
    return bool(np.all(np.abs(actual - expected) <= bound))


def interior_lengths(d, h, n, rng, margin=0.05):
    low, high = abs(h - d), h + d
    return rng.uniform(low + margin * (high - low), high - margin * (high - low), n)


# ---------------------------------------------------------------- landing gear


@pytest.mark.parametrize(
    "x_r, x_e",
    [
        (1.25, 2.0),
        (plg.COURSEWORK_RETRACTED_LENGTH, plg.COURSEWORK_EXTENDED_LENGTH),
        (0.1, 0.35),
        (3.0, 3.1),
        (1.0, 10.0),
    ],
)
def test_design_geometry_matches_physics(x_r, x_e):
    ref = lg.design_geometry(x_r, x_e)
    phys = plg.design_geometry(x_r, x_e)
    for a, b in zip(ref, phys):
        assert math.isclose(a, b, rel_tol=RTOL)
    d, h, theta_1 = ref
    residual = d * d + x_r * d + 0.5 * (x_r**2 - x_e**2)
    assert residual == pytest.approx(0.0, abs=1e-14 * x_e**2)
    # The design conditions: retracted piston perpendicular to d, quarter turn at x_e.
    theta_end = lg.gear_from_piston(x_e, 0.0, 0.0, d, h)[0]
    assert math.isclose(float(theta_end), theta_1 + math.pi / 2, rel_tol=1e-12)


def test_coursework_geometry_printed_digits():
    d, h, theta_1 = lg.design_geometry(1.25, 2.0)
    assert round(d, 5) == 0.64361
    assert f"{h:.4f}" == "1.4060"
    assert round(theta_1, 4) == 1.0953
    assert round(math.degrees(theta_1), 2) == 62.76
    # The same geometry in metres (the physics constants) is the feet geometry times FOOT.
    for ft, m in zip((d, h), plg.DEFAULT_GEOMETRY[:2]):
        assert math.isclose(ft * plg.FOOT, m, rel_tol=RTOL)
    assert math.isclose(theta_1, plg.DEFAULT_GEOMETRY.start_angle, rel_tol=RTOL)
    assert 1.25 / d > 1.0  # the coursework's arcsin(1.25/d) has no value


@pytest.mark.parametrize("d, h", GEOMETRIES)
def test_gear_from_piston_matches_physics(d, h):
    rng = np.random.default_rng(1)
    n = 400
    x = interior_lengths(d, h, n, rng)
    xdot = rng.uniform(-2.0, 2.0, n)
    xddot = rng.uniform(-5.0, 5.0, n)
    theta, omega, alpha = lg.gear_from_piston(x, xdot, xddot, d, h)
    expected = np.array([plg.gear_motion(*args, d, h) for args in zip(x, xdot, xddot)])
    assert close(theta, expected[:, 0])
    assert close(omega, expected[:, 1])
    assert close(alpha, expected[:, 2])


@pytest.mark.parametrize("d, h", GEOMETRIES)
def test_piston_from_gear_matches_physics_and_inverts(d, h):
    rng = np.random.default_rng(2)
    n = 400
    theta = rng.uniform(0.15, math.pi - 0.15, n)
    omega = rng.uniform(-3.0, 3.0, n)
    alpha = rng.uniform(-10.0, 10.0, n)
    x, xdot, xddot = lg.piston_from_gear(theta, omega, alpha, d, h)
    expected = np.array([plg.piston_motion(*args, d, h) for args in zip(theta, omega, alpha)])
    assert close(x, expected[:, 0])
    assert close(xdot, expected[:, 1])
    assert close(xddot, expected[:, 2])
    back = lg.gear_from_piston(x, xdot, xddot, d, h)
    for a, b in zip(back, (theta, omega, alpha)):
        assert close(a, b, rtol=1e-11)


def test_gear_from_piston_outside_assembly_is_nan():
    d, h, _ = lg.design_geometry(1.25, 2.0)
    theta, omega, alpha = lg.gear_from_piston([h + d + 0.01, abs(h - d) - 0.01], 0.1, 0.0, d, h)
    assert np.all(np.isnan(theta)) and np.all(np.isnan(omega)) and np.all(np.isnan(alpha))


def _stroke_times(start_time, stroke_time, rng):
    t = rng.uniform(start_time - 1.0, start_time + stroke_time + 1.0, 500)
    tau = (t - start_time) / stroke_time
    # Away from the physics' 1e-9 time snap, plus the breakpoints themselves.
    t = t[(np.abs(tau) > 1e-6) & (np.abs(tau - 1.0) > 1e-6)]
    return np.concatenate([t, [start_time, start_time + stroke_time]])


@pytest.mark.parametrize("profile", lg.STROKE_PROFILES)
@pytest.mark.parametrize(
    "x0, x1, T, start", [(0.381, 0.6096, 3.0, 0.0), (2.0, 1.25, 1.5, 0.5), (0.1, 0.4, 4.0, -1.0)]
)
def test_stroke_matches_physics(profile, x0, x1, T, start):
    t = _stroke_times(start, T, np.random.default_rng(3))
    ref = lg.stroke(t, x0, x1, T, profile, start_time=start)
    expected = np.array([pprof.stroke(ti, x0, x1, T, profile, start) for ti in t])
    assert close(ref[0], expected[:, 0])
    speed_scale = abs(x1 - x0) / T
    assert close(ref[1], expected[:, 1], scale=speed_scale)
    assert close(ref[2], expected[:, 2], scale=speed_scale / T)


def test_stroke_ends_and_holds():
    x, v, a = lg.stroke([-1.0, 0.0, 3.0, 3.5], 1.25, 2.0, 3.0, "constant_speed")
    assert list(x) == [1.25, 1.25, 2.0, 2.0]
    assert list(v) == [0.0, 0.25, 0.25, 0.0]  # closed interval [0, T]
    assert list(a) == [0.0] * 4
    x, v, a = lg.stroke([0.0, 1.5, 3.0], 1.25, 2.0, 3.0, "cycloidal")
    assert x[0] == 1.25 and x[2] == pytest.approx(2.0, abs=1e-15)
    assert x[1] == pytest.approx(1.625, abs=1e-15)
    assert v[0] == 0.0 and v[2] == pytest.approx(0.0, abs=1e-16)
    assert a[0] == 0.0 and a[2] == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(ValueError):
        lg.stroke(0.0, 1.25, 2.0, 3.0, "harmonic")


@pytest.mark.parametrize("profile", lg.STROKE_PROFILES)
def test_retraction_columns(profile):
    d, h, theta_1 = lg.design_geometry(1.25, 2.0)
    t = np.linspace(0.0, 3.0, 61)
    table = lg.retraction(t, d, h, 1.25, 2.0, 3.0, profile)
    assert list(table) == [
        "piston_extension",
        "piston_speed",
        "piston_acceleration",
        "gear_angle",
        "gear_angular_velocity",
        "gear_angular_acceleration",
    ]
    assert all(column.shape == t.shape for column in table.values())
    assert table["gear_angle"][0] == pytest.approx(theta_1, rel=1e-14)
    assert table["gear_angle"][-1] == pytest.approx(theta_1 + math.pi / 2, rel=1e-14)
    expected = [plg.gear_motion(*pprof.stroke(ti, 1.25, 2.0, 3.0, profile), d, h) for ti in t]
    expected = np.array(expected)
    assert close(table["gear_angle"], expected[:, 0])
    assert close(table["gear_angular_velocity"], expected[:, 1])
    assert close(table["gear_angular_acceleration"], expected[:, 2])


# ---------------------------------------------------------------- suspension


@pytest.mark.parametrize("L, k, d", SPRINGS)
def test_suspension_closed_forms_match_physics(L, k, d):
    spring = psp.make_spring(L, k, d)
    h = psp.rest_height(spring)
    assert math.isclose(float(sp.rest_height(L, d)), h, rel_tol=RTOL)
    u = np.concatenate([np.linspace(-L, 2 * h + 2 * L, 701), [0.0, h, 2 * h, 1e-12, -1e-12]])
    force = np.array([psp.spring_force(ui, spring) for ui in u])
    secant = np.array([psp.secant_stiffness(ui, spring) for ui in u])
    tangent = np.array([psp.tangent_stiffness(ui, spring) for ui in u])
    assert close(sp.spring_force(u, L, k, d), force)
    assert close(sp.secant_stiffness(u, L, k, d), secant)
    assert close(sp.tangent_stiffness(u, L, k, d), tangent, scale=2 * k)
    u_star, F_star = sp.limit_point(L, k, d)
    limit = psp.limit_point(spring)
    assert math.isclose(u_star, limit.deflection, rel_tol=RTOL)
    assert math.isclose(F_star, limit.load, rel_tol=RTOL)
    assert abs(float(sp.tangent_stiffness(u_star, L, k, d))) <= 1e-12 * 2 * k
    # F* is the maximum of F over the near side.
    assert np.all(sp.spring_force(np.linspace(-L, h, 2001), L, k, d) <= F_star * (1 + 1e-15))


def test_secant_stiffness_limit_at_zero():
    h = float(sp.rest_height(L0, D0))
    assert sp.secant_stiffness(0.0, L0, K0, D0) == pytest.approx(2 * K0 * h * h / L0**2, rel=1e-15)
    assert sp.spring_force(0.0, L0, K0, D0) == 0.0
    # Continuous through u = 0 at full precision (the naive F/u is not).
    for u in (1e-8, 1e-12, 1e-15):
        slope = float(sp.tangent_stiffness(0.0, L0, K0, D0))
        assert float(sp.secant_stiffness(u, L0, K0, D0)) == pytest.approx(
            2 * K0 * h * h / L0**2, abs=abs(slope) * u * 10
        )


@pytest.mark.parametrize("L, k, d", SPRINGS)
def test_equilibria_match_physics_branches(L, k, d):
    spring = psp.make_spring(L, k, d)
    _, F_star = sp.limit_point(L, k, d)
    for fraction in np.linspace(-3.0, 3.0, 61):
        W = fraction * F_star
        roots = sp.equilibria(W, L, k, d)
        assert np.all(np.diff(roots) > 0.0)
        assert close(
            sp.spring_force(roots, L, k, d), np.full(roots.size, W), rtol=1e-12, scale=F_star
        )
        if abs(fraction) < 0.98:
            assert roots.size == 3
            mid = roots[1]
            assert sp.tangent_stiffness(mid, L, k, d) < 0.0
        elif abs(fraction) > 1.02:
            assert roots.size == 1
        if fraction <= 0.98:
            near = psp.solve_on_branch(W, psp.NEAR, spring)
            assert math.isclose(roots[0], near, rel_tol=RTOL, abs_tol=RTOL * L)
        if fraction >= -0.98:
            far = psp.solve_on_branch(W, psp.FAR, spring)
            assert math.isclose(roots[-1], far, rel_tol=RTOL, abs_tol=RTOL * L)


def test_equilibria_zero_load():
    h = float(sp.rest_height(L0, D0))
    roots = sp.equilibria(0.0, L0, K0, D0)
    assert roots.size == 3
    assert roots[0] == pytest.approx(0.0, abs=1e-15)
    assert roots[1] == pytest.approx(h, rel=1e-15)
    assert roots[2] == pytest.approx(2 * h, rel=1e-15)


def test_coursework_equilibria_printed_digits():
    roots = sp.equilibria(W0, L0, K0, D0)
    on_range = roots[roots >= 0.0]
    assert on_range.size == 3
    u1, u2, u3 = on_range
    assert round(u1, 4) == 0.1375
    assert round(u2, 4) == 0.3804
    h = float(sp.rest_height(L0, D0))
    assert 0.5 < 2 * h < u3  # the third one, beyond 2h, outside the coursework's [0, 0.5]
    kef = sp.secant_stiffness(np.array([u1, u2]), L0, K0, D0)
    assert f"{kef[0]:.4e}" == "1.5059e+04"
    assert f"{kef[1]:.4e}" == "5.4410e+03"
    assert kef == pytest.approx(W0 / np.array([u1, u2]), rel=1e-12)
    tangent = sp.tangent_stiffness(on_range, L0, K0, D0)
    assert list(tangent > 0.0) == [True, False, True]  # stable, unstable, stable
    # The physics' branch solvers find the two stable ones.
    spring = psp.make_spring(L0, K0, D0)
    assert math.isclose(u1, psp.solve_on_branch(W0, psp.NEAR, spring), rel_tol=RTOL)
    assert math.isclose(u3, psp.solve_on_branch(W0, psp.FAR, spring), rel_tol=RTOL)


def test_follow_load_snaps_once_on_ramp():
    _, F_star = sp.limit_point(L0, K0, D0)
    loads = np.linspace(0.0, 1.5 * F_star, 301)
    path = sp.follow_load(loads, L0, K0, D0)
    assert set(path) == {
        "deflection",
        "spring_force",
        "secant_stiffness",
        "tangent_stiffness",
        "stable",
        "marginal",
        "branch",
        "snap_through",
    }
    # Sample 200 is the limit load to within rounding (200 * step vs F*, which differ in the
    # last bits, either way, depending on the CPU): it is the limit point, marginal, not a
    # snap-through; the snap happens at the next sample.
    at_limit = int(np.argmin(np.abs(loads - F_star)))
    assert at_limit == 200 and abs(loads[at_limit] - F_star) <= 1e-14 * F_star
    first_past = at_limit + 1
    assert path["snap_through"].sum() == 1.0
    assert path["snap_through"][first_past] == 1.0
    assert np.all(path["branch"][:first_past] == sp.NEAR)
    assert np.all(path["branch"][first_past:] == sp.FAR)
    assert path["marginal"][at_limit] == 1.0 and path["stable"][at_limit] == 0.0
    assert abs(path["tangent_stiffness"][at_limit]) <= sp.MARGINAL_RTOL * 2.0 * K0
    others = np.arange(loads.size) != at_limit
    assert np.all(path["stable"][others] == 1.0) and np.all(path["marginal"][others] == 0.0)
    # the neighbours are clearly stable: their stiffness is far outside the marginal band
    assert path["tangent_stiffness"][at_limit - 1] > 1e3 * sp.MARGINAL_RTOL * 2.0 * K0
    assert close(path["spring_force"], loads, scale=F_star)
    jump = np.diff(path["deflection"])
    assert int(np.argmax(jump)) == first_past - 1 and jump.max() > 0.5


def test_limit_load_within_rounding_is_marginal_on_both_sides():
    """A load a few ulps either side of F* (or -F* on the far branch) is the limit point:
    the same classification whatever the last bits are."""
    u_star, F_star = sp.limit_point(L0, K0, D0)
    h = float(sp.rest_height(L0, D0))
    near = F_star * (1.0 + np.array([-4e-16, -2.2e-16, 0.0, 2.2e-16, 4e-16]))
    path = sp.follow_load(near, L0, K0, D0)
    assert np.all(path["marginal"] == 1.0) and np.all(path["stable"] == 0.0)
    assert np.all(path["branch"] == sp.NEAR) and path["snap_through"].sum() == 0.0
    assert np.allclose(path["deflection"], u_star, rtol=0.0, atol=1e-15 * L0)
    far = np.concatenate([[2.0 * F_star], -near])
    path = sp.follow_load(far, L0, K0, D0)
    assert np.all(path["branch"] == sp.FAR) and path["snap_through"].sum() == 1.0
    assert np.all(path["marginal"][1:] == 1.0) and path["marginal"][0] == 0.0
    assert np.allclose(path["deflection"][1:], 2.0 * h - u_star, rtol=0.0, atol=1e-15 * L0)
    spring = psp.make_spring(L0, K0, D0)
    for W in near:
        state, snapped = psp.follow_load(W, psp.NEAR, spring)
        assert not snapped and state.branch == psp.NEAR and state.marginal and not state.stable
        assert math.isclose(state.deflection, u_star, rel_tol=1e-14)
    for W in -near:
        state, snapped = psp.follow_load(W, psp.FAR, spring)
        assert not snapped and state.branch == psp.FAR and state.marginal and not state.stable


def test_ramp_ends_a_rounding_error_off_are_the_ends_in_reference_and_physics():
    """The shaft's acceleration jumps at both ends of its speed ramp; a sample time one
    rounding error either side of an end (t + dt accumulated vs k dt) is that end in both the
    reference and the FMU's physics, so neither classification hinges on the last bit."""
    start, ramp, w0, w1 = 0.3, 0.5, 10.0, 60.0
    slope = (w1 - w0) / ramp
    for end, inside in ((start, slope), (start + ramp, 0.0)):
        times = np.array([np.nextafter(end, -1.0), end, np.nextafter(end, 2.0)])
        columns = drives.rotation(times, 0.2, w0, w1, ramp, start_time=start)
        assert np.all(columns["acceleration"] == inside)
        for i, t in enumerate(times):
            sample = pprof.rotation(float(t), 0.2, w0, w1, ramp, start_time=start)
            assert sample.rate2 == inside
            assert math.isclose(sample.value, columns["angle"][i], rel_tol=1e-14)
            assert math.isclose(sample.rate, columns["speed"][i], rel_tol=1e-14)
    # 1e-6 of the ramp time before it starts is before it: the band is no wider than stated
    early = start - 1e-6 * ramp
    assert drives.rotation([early], 0.2, w0, w1, ramp, start_time=start)["acceleration"][0] == 0
    assert pprof.rotation(early, 0.2, w0, w1, ramp, start_time=start).rate2 == 0.0


def test_follow_load_matches_physics_continuation():
    _, F_star = sp.limit_point(L0, K0, D0)
    up = np.linspace(0.0, 1.6, 81)
    down = up[::-1][1:] * 2.0 - 1.6
    loads = F_star * np.concatenate([up, down, np.linspace(-1.6, 1.6, 161)[1:]])
    path = sp.follow_load(loads, L0, K0, D0)
    spring = psp.make_spring(L0, K0, D0)
    branch = psp.NEAR
    for i, W in enumerate(loads):
        state, snapped = psp.follow_load(W, branch, spring)
        branch = state.branch
        assert path["branch"][i] == branch
        assert path["snap_through"][i] == float(snapped)
        # At the limit load the deflection is a double root: only ~sqrt(eps) conditioned.
        tolerance = 1e-7 if abs(abs(W) - F_star) < 0.01 * F_star else RTOL
        assert math.isclose(
            path["deflection"][i], state.deflection, rel_tol=tolerance, abs_tol=tolerance * L0
        )
        if abs(abs(W) - F_star) >= 0.01 * F_star:
            assert path["stable"][i] == float(state.stable)
        assert path["marginal"][i] == float(state.marginal)
    assert path["snap_through"].sum() == 3.0  # up past F*, down past -F*, up past F*


def test_follow_load_at_the_limit_load_stays_near():
    u_star, F_star = sp.limit_point(L0, K0, D0)
    # One ulp above F* is still the limit load (within LIMIT_LOAD_RTOL); 1e-9 F* above is past.
    path = sp.follow_load(
        [0.0, F_star, np.nextafter(F_star, np.inf), F_star * (1 + 1e-9)], L0, K0, D0
    )
    assert list(path["snap_through"]) == [0.0, 0.0, 0.0, 1.0]
    assert list(path["marginal"]) == [0.0, 1.0, 1.0, 0.0]
    assert path["deflection"][1] == pytest.approx(u_star, abs=1e-7)


# ---------------------------------------------------------------- report


def test_seed_report_is_up_to_date():
    committed = (REPO_ROOT / "data" / "seed_report.md").read_text(encoding="utf-8")
    assert build_report() == committed, "regenerate with: python sims/seed_report.py"


def test_references_use_the_physics_never_the_models():
    """The numpy references may reuse runtime.physics (the gear dynamics' right-hand side)
    but never reach into the FMU classes of runtime.models or runtime.fmi."""
    package = Path(mechfmu.references.__file__).parent
    for path in sorted(package.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = (
                    importlib.util.resolve_name(
                        "." * node.level + (node.module or ""), "mechfmu.references"
                    )
                    if node.level
                    else node.module
                )
                names = [f"{base}.{alias.name}" for alias in node.names]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            for name in names:
                assert not name.startswith(("mechfmu.runtime.models", "mechfmu.runtime.fmi")), (
                    f"{path.name} imports {name}"
                )


def test_every_sample_belongs_to_exactly_one_piece_whatever_the_event_times_round_to():
    from mechfmu.references.breakpoints import piece_of_samples

    event = 0.632  # an event time that a sample falls on, and just either side of it
    starts = [0.0, event, event + 1e-9, 1.5]
    ends = [event, event + 1e-9, 1.5, 2.0]
    times = np.array(
        [
            0.0,
            np.nextafter(event, 0.0),
            event,
            np.nextafter(event, 1.0),
            event + 1e-9,
            1.0,
            1.5,
            2.0,
            np.nextafter(2.0, 3.0),
        ]
    )
    owner = piece_of_samples(starts, ends, times)
    assert list(owner) == [0, 0, 1, 1, 2, 2, 3, 3, 3]
    # a rounding error before the first start still belongs to the first piece
    assert list(piece_of_samples([1e-17], [1.0], [0.0, 0.5])) == [0, 0]
    # beyond the integrated span (an integration that stopped early) is an error naming t
    with pytest.raises(ValueError, match=r"t = 2\.5 s lies outside .*\[0\.0, 2\.0\]"):
        piece_of_samples(starts, ends, [0.0, 2.5])
