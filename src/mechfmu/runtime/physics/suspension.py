"""Two-spring car suspension: load <-> deflection (standard library only).

Two symmetric springs of free length L and stiffness k have their lower ends a horizontal
distance d from the centre line; their upper ends meet at height h = sqrt(L^2 - d^2) above
the lower ends, unstressed at deflection u = 0 (u positive downward). With v = h - u and
s = sqrt(d^2 + v^2) the spring length, the vertical force the springs carry is

    F(u) = 2 k (L - s) v / s = 2 k u (2h - u)(h - u) / (s (L + s)).

The second form (L - s = u (2h - u) / (L + s)) has no cancellation, so F and the secant
stiffness F/u stay accurate down to u = 0, where F/u tends to 2 k h^2 / L^2.

Tangent stiffness dF/du = 2 k (1 - L d^2 / s^3); it vanishes at s* = (L d^2)^(1/3), where
F reaches its limit load F* (near branch) and -F* (far branch, the mirror image about
u = h). The two stable branches are u < h - v* ("near") and u > h + v* ("far"),
v* = sqrt(s*^2 - d^2); between them the equilibria are unstable.

At the limit points themselves the equilibrium is marginal (dF/du = 0): there the computed
tangent stiffness is rounding noise of either sign (a few 1e-16 of the stiffness scale 2 k),
so stability is classified with a tolerance: stable if dF/du > MARGINAL_RTOL * 2 k,
marginal if |dF/du| <= MARGINAL_RTOL * 2 k, unstable otherwise. A load within
LIMIT_LOAD_RTOL * F* of a limit load is that limit load (its equilibrium is the limit point,
marginal, and no snap-through happens): at the double root F(u) = F* a relative load error e
moves u by ~sqrt(e) L, so the branch's end cannot be resolved closer than that anyway.
The two tolerances are far apart: a load just outside the band, |W - F*| = 1e-12 F*, has
dF/du ~ 1e-6 * 2 k, three decades above the marginal band, so neither classification
hinges on the last bit.

Lengths in m, stiffness in N/m, forces in N.
"""

import math
from functools import lru_cache
from collections import namedtuple

from ..errors import IntegrationError, RangeError, SnapThrough, require_finite, require_positive

GRAVITY = 9.81  # m/s^2, the coursework's value

# Coursework numbers: L = 0.5 m, k = 1e4 N/m, d = 0.2 m, load 211 kg (180 + 31) under g.
COURSEWORK_FREE_LENGTH = 0.5
COURSEWORK_STIFFNESS = 1.0e4
COURSEWORK_BASE_OFFSET = 0.2
COURSEWORK_MASS = 180.0 + 31.0

NEAR, FAR = 0, 1  # stable branches
# |dF/du| <= MARGINAL_RTOL * 2 k counts as zero stiffness (a limit point; see the module
# docstring): rounding leaves ~1e-15 of 2 k there, a load 1e-12 F* off the limit ~1e-6.
MARGINAL_RTOL = 1e-9
# A load within LIMIT_LOAD_RTOL * F* of a limit load is that limit load.
LIMIT_LOAD_RTOL = 1e-12
MAX_ITERATIONS = 200
# Largest |h - u| (m) solve_on_branch looks for an equilibrium at: beyond about 1e154 m the
# products in spring_force overflow. Loads above 2 k MAX_DEFLECTION are refused by name.
MAX_DEFLECTION = 1e150

Spring = namedtuple("Spring", "free_length stiffness base_offset")
LimitPoint = namedtuple("LimitPoint", "deflection load")
Equilibrium = namedtuple(
    "Equilibrium",
    "deflection spring_force secant_stiffness tangent_stiffness stable branch marginal",
)


def make_spring(
    spring_free_length: float, spring_stiffness: float, spring_base_offset: float
) -> "Spring":
    """Validated Spring(L [m], k [N/m], d [m]); requires L > 0, k > 0, 0 < d < L."""
    L = require_positive("spring_free_length", spring_free_length, "m")
    k = require_positive("spring_stiffness", spring_stiffness, "N/m")
    d = require_finite("spring_base_offset", spring_base_offset, "m")
    if not 0.0 < d < L:
        raise RangeError(
            "spring_base_offset",
            d,
            f"(0, {L!r})",
            "m",
            "must lie strictly between 0 and spring_free_length",
        )
    return Spring(L, k, d)


def rest_height(spring: "Spring") -> float:
    """h = sqrt(L^2 - d^2) (m), computed as sqrt((L - d)(L + d)) for accuracy."""
    L, _, d = spring
    return math.sqrt((L - d) * (L + d))


def spring_length(deflection: float, spring: "Spring") -> float:
    """s = sqrt(d^2 + (h - u)^2) (m)."""
    return math.hypot(spring.base_offset, rest_height(spring) - deflection)


def secant_stiffness(deflection: float, spring: "Spring") -> float:
    """F(u) / u (N/m), exact at u = 0 where it equals the limit 2 k h^2 / L^2."""
    L, k, _ = spring
    h = rest_height(spring)
    s = spring_length(deflection, spring)
    return 2.0 * k * (2.0 * h - deflection) * (h - deflection) / (s * (L + s))


def spring_force(deflection: float, spring: "Spring") -> float:
    """Vertical force F(u) (N) the two springs carry at deflection u (m)."""
    return deflection * secant_stiffness(deflection, spring)


def tangent_stiffness(deflection: float, spring: "Spring") -> float:
    """dF/du = 2 k (1 - L d^2 / s^3) (N/m)."""
    L, k, d = spring
    s = spring_length(deflection, spring)
    return 2.0 * k * (1.0 - L * d * d / (s * s * s))


def stability(tangent: float, spring: "Spring") -> tuple[bool, bool]:
    """(stable, marginal) for a tangent stiffness dF/du (N/m): stable if it exceeds
    MARGINAL_RTOL * 2 k, marginal if |dF/du| is within it (a limit point), neither if the
    equilibrium is unstable."""
    band = MARGINAL_RTOL * 2.0 * spring.stiffness
    return tangent > band, abs(tangent) <= band


@lru_cache(maxsize=16)  # a function of the spring alone (a tuple of floats)
def limit_point(spring: "Spring") -> "LimitPoint":
    """Deflection (m) and load (N) where the near branch ends (dF/du = 0)."""
    L, _, d = spring
    s_star = (L * d * d) ** (1.0 / 3.0)
    v_star = math.sqrt((s_star - d) * (s_star + d))
    u_star = rest_height(spring) - v_star
    return LimitPoint(u_star, spring_force(u_star, spring))


def _branch_interval(branch: int, spring: "Spring") -> tuple[float, float]:
    """Deflection interval (low, high) of a stable branch; one end is infinite."""
    u_star = limit_point(spring).deflection
    if branch == NEAR:
        return -math.inf, u_star
    return 2.0 * rest_height(spring) - u_star, math.inf


def solve_on_branch(
    load: float, branch: int, spring: "Spring", guess: float | None = None, tolerance: float = 1e-13
) -> float:
    """Equilibrium deflection (m) on one stable branch for a load W (N).

    F is strictly increasing on a stable branch, so a bracket plus safeguarded Newton
    converges. The bracket's open end is found by doubling, from a first guess of the
    interval that the load's asymptote |F| ~ 2 k (|h - u| - L) gives; both loops are bounded
    (MAX_ITERATIONS each). Raises SnapThrough when the branch has no equilibrium for this
    load, RangeError when the doubling finds no bracket (a load so large that F overflows
    before it is reached) and IntegrationError if Newton has not converged within its bound.
    """
    W = require_finite("load", load, "N")
    limit = limit_point(spring)
    low, high = _branch_interval(branch, spring)
    band = LIMIT_LOAD_RTOL * limit.load
    if branch == NEAR and abs(W - limit.load) <= band:
        return limit.deflection  # the limit point itself (marginal), see the module docstring
    if branch == FAR and abs(W + limit.load) <= band:
        return low
    if branch == NEAR and W > limit.load:
        raise SnapThrough(
            f"load = {W!r} N exceeds the limit load {limit.load!r} N "
            f"of the near branch (at deflection {limit.deflection!r} m)"
        )
    if branch == FAR and W < -limit.load:
        raise SnapThrough(
            f"load = {W!r} N is below {-limit.load!r} N, "
            f"the far branch's limit (at deflection "
            f"{_branch_interval(FAR, spring)[0]!r} m)"
        )
    load_bound = 2.0 * spring.stiffness * MAX_DEFLECTION
    valid = f"[{-load_bound!r}, {load_bound!r}]"
    if abs(W) > load_bound:
        raise RangeError(
            "load",
            W,
            valid,
            "N",
            f"the equilibrium deflection would lie "
            f"beyond {MAX_DEFLECTION!r} m from the rest height, where the spring "
            f"force overflows",
        )
    # Far out on a branch |F| ~ 2 k (|h - u| - L): starting there, doubling from the free
    # length alone would need log2(|W| / (k L)) steps and run out of them for loads above
    # 2^200 k L, returning a deflection that is no equilibrium.
    scale = spring.free_length + abs(W) / (2.0 * spring.stiffness)
    bracketed = False
    if branch == NEAR:
        low = high - scale
        for _ in range(MAX_ITERATIONS):
            if spring_force(low, spring) <= W:
                bracketed = True
                break
            scale *= 2.0
            low = high - scale
    else:
        high = low + scale
        for _ in range(MAX_ITERATIONS):
            if spring_force(high, spring) >= W:
                bracketed = True
                break
            scale *= 2.0
            high = low + scale
    if not bracketed:
        raise RangeError(
            "load",
            W,
            valid,
            "N",
            f"no equilibrium bracket on the {('near', 'far')[branch]} "
            f"branch within MAX_ITERATIONS = {MAX_ITERATIONS} doublings of the "
            f"search interval: the spring force overflows before it balances "
            f"the load",
        )
    u = guess if guess is not None and low <= guess <= high else 0.5 * (low + high)
    for _ in range(MAX_ITERATIONS):
        residual = spring_force(u, spring) - W
        if residual == 0.0:
            return u
        if residual > 0.0:
            high = u
        else:
            low = u
        slope = tangent_stiffness(u, spring)
        step = residual / slope if slope > 0.0 else math.inf
        candidate = u - step
        if not low < candidate < high:
            candidate = 0.5 * (low + high)
        if abs(candidate - u) <= tolerance * max(1.0, abs(u)) or high - low <= tolerance:
            return _polish(candidate, W, spring, low, high)
        u = candidate
    raise IntegrationError(
        f"load = {W!r} N: the equilibrium deflection did not converge "
        f"within MAX_ITERATIONS = {MAX_ITERATIONS} safeguarded Newton "
        f"iterations (bracket [{low!r}, {high!r}] m)"
    )


def _polish(
    u: float, load: float, spring: "Spring", low: float, high: float, steps: int = 3
) -> float:
    """A few extra Newton steps, each kept only if it reduces the residual.

    The stopping test above is on the step size; these steps take the residual down to
    rounding level, e.g. exactly u -> 0 for a zero load.
    """
    residual = spring_force(u, spring) - load
    for _ in range(steps):
        slope = tangent_stiffness(u, spring)
        if residual == 0.0 or slope <= 0.0:
            break
        candidate = u - residual / slope
        candidate_residual = spring_force(candidate, spring) - load
        if not (low <= candidate <= high and abs(candidate_residual) < abs(residual)):
            break
        u, residual = candidate, candidate_residual
    return u


def equilibrium(deflection: float, spring: "Spring", branch: int | None) -> "Equilibrium":
    """All outputs of the static model at a known deflection."""
    tangent = tangent_stiffness(deflection, spring)
    stable, marginal = stability(tangent, spring)
    return Equilibrium(
        deflection,
        spring_force(deflection, spring),
        secant_stiffness(deflection, spring),
        tangent,
        stable,
        branch,
        marginal,
    )


def follow_load(
    load: float,
    branch: int,
    spring: "Spring",
    guess: float | None = None,
    continue_past_limit: bool = True,
) -> tuple[Equilibrium, bool]:
    """Continuation step: equilibrium for ``load`` starting from ``branch``.

    Stays on the current stable branch while it has an equilibrium; when the load passes
    the branch's limit, jumps to the other stable branch (snap-through) if allowed,
    else raises SnapThrough. Returns (Equilibrium, snapped: bool).
    """
    try:
        u = solve_on_branch(load, branch, spring, guess)
        return equilibrium(u, spring, branch), False
    except SnapThrough:
        if not continue_past_limit:
            raise
    other = FAR if branch == NEAR else NEAR
    u = solve_on_branch(load, other, spring)
    return equilibrium(u, spring, other), True
