"""Roots and minima of a scalar function (standard library only): the event location of the
integrators and of the exact valve integration (a root bracketed by a sign change), and the
least value of a function sampled on a grid and refined by golden section (the valve's float
speed, the cam's radius of curvature and pressure angle)."""

import math
import sys
from collections.abc import Callable, Sequence

ROOT_ITERATIONS = 200  # Illinois iterations per root (the bracket at least halves every 3)
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # 0.618...
_EPS = sys.float_info.epsilon


def find_root(
    function: Callable[[float], float],
    a: float,
    g_a: float,
    b: float,
    g_b: float,
    tolerance: float,
    iterations: int = ROOT_ITERATIONS,
) -> float:
    """A point of [a, b] within ``tolerance`` (s) of a root of ``function``, on the side of
    b: g(a) != 0 and g(b) has the other sign or is 0 (Illinois method with a bisection at
    least every third iteration, ``iterations`` at most). Returns the end of the final
    bracket on the b side: a point where ``function`` was evaluated, or b."""
    w_a, w_b = g_a, g_b
    last = 0
    width_checked = b - a
    margin = 0.25 * tolerance
    for k in range(iterations):
        width = b - a
        if width <= tolerance:
            break
        tau = None
        if k % 3 == 2:
            if width > 0.5 * width_checked:
                tau = a + 0.5 * width
            width_checked = width
        if tau is None:
            denominator = w_b - w_a
            tau = b - w_b * width / denominator if denominator != 0.0 else a + 0.5 * width
            if not math.isfinite(tau):
                tau = a + 0.5 * width
        if tau < a + margin:  # min(max(tau, a + margin), b - margin) without two calls
            tau = a + margin
        if b - margin < tau:
            tau = b - margin
        g = function(tau)
        if g != 0.0 and (g > 0.0) == (g_a > 0.0):
            a, g_a, w_a = tau, g, g
            if last == -1:
                w_b *= 0.5
            last = -1
        else:
            b, w_b = tau, g
            if last == 1:
                w_a *= 0.5
            last = 1
    return b


def crosses(g0: float, g1: float, direction: int) -> bool:
    """Whether g went from a nonzero g0 to the other sign or zero (g1), in ``direction``
    (+1 rising only, -1 falling only, 0 either)."""
    if g0 == 0.0:
        return False
    if g0 < 0.0:
        return g1 >= 0.0 and direction >= 0
    return g1 <= 0.0 and direction <= 0


def golden_minimum(
    function: Callable[[float], float], low: float, high: float, tolerance: float = 0.0
) -> tuple[float, float]:
    """(value, abscissa) of the least value of a unimodal ``function`` on [low, high], by
    golden section down to a bracket of ``tolerance`` (in the abscissa's units; at least a
    few ulps); the ends are candidates too. Near a smooth minimum the value's error is of
    the order of the bracket squared."""
    x1 = high - GOLDEN * (high - low)
    x2 = low + GOLDEN * (high - low)
    f1, f2 = function(x1), function(x2)
    best = min((f1, x1), (f2, x2), (function(low), low), (function(high), high))
    for _ in range(200):
        if high - low <= max(tolerance, 4.0 * _EPS * max(1.0, abs(low), abs(high))):
            break
        if f1 <= f2:
            high, x2, f2 = x2, x1, f1
            x1 = high - GOLDEN * (high - low)
            f1 = function(x1)
            best = min(best, (f1, x1))
        else:
            low, x1, f1 = x1, x2, f2
            x2 = low + GOLDEN * (high - low)
            f2 = function(x2)
            best = min(best, (f2, x2))
    return best


def refined_minimum(
    function: Callable[[float], float],
    grid: Sequence[float],
    values: Sequence[float],
    tolerance: float = 0.0,
) -> tuple[float, float]:
    """(value, abscissa) of the least value of ``function`` over [grid[0], grid[-1]]:
    ``values`` = function at the increasing ``grid``; each sampled local minimum (a value
    at most its neighbours', inf values skipped) is refined by golden section between its
    neighbours, unless it equals both (a plateau) (down to ``tolerance``, golden_minimum's). (inf, nan) if every value is
    inf."""
    best = (math.inf, math.nan)
    last = len(grid) - 1
    for i, value in enumerate(values):
        if value == math.inf:
            continue
        left = values[i - 1] if i > 0 else math.inf
        right = values[i + 1] if i < last else math.inf
        if value == left == right:  # a plateau (a dwell): nothing to refine
            found = (value, grid[i])
        elif value <= left and value <= right:
            found = golden_minimum(function, grid[max(i - 1, 0)], grid[min(i + 1, last)], tolerance)
            found = min(found, (value, grid[i]))
        else:
            continue
        if found[0] < best[0]:
            best = found
    return best
