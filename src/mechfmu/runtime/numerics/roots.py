"""Roots of a scalar function bracketed by a sign change (standard library only): the event
location of the integrators and of the exact valve integration."""

import math
from collections.abc import Callable

ROOT_ITERATIONS = 200  # Illinois iterations per root (the bracket at least halves every 3)


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
        tau = min(max(tau, a + margin), b - margin)
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
