"""Exact solution of a damped linear oscillator driven by a polynomial (standard library only).

    m x'' + c x' + k x = g(tau),   g(tau) = sum g_j tau^j,   m > 0, c >= 0, k >= 0

(SI units: m kg, c N.s/m, k N/m, g N, tau s, x m). The solution is a polynomial particular
solution x_p plus the homogeneous e = x - x_p of e'' + 2 sigma e' + w0^2 e = 0 with
sigma = c / (2 m), w0^2 = k / m and d2 = w0^2 - sigma^2:

    e(tau)  = exp(-sigma tau) [e0 C(tau) + (e0' + sigma e0) S(tau)]
    e'(tau) = exp(-sigma tau) [e0' C(tau) - (sigma e0' + w0^2 e0) S(tau)]

with C = cos(w tau), S = sin(w tau) / w, w = sqrt(d2) (under-damped), C = cosh(mu tau),
S = sinh(mu tau) / mu, mu = sqrt(-d2) (over-damped), and C = 1, S = tau at critical damping
(the limit of both, so the form is continuous across it). k = 0 is allowed: the particular
solution then has degree n + 1 (c > 0) or n + 2 (c = 0).

Also here: Gauss-Legendre quadrature. Small pure functions used by the exact valve
integrator (physics/valve_exact.py) and tested alone against numpy/scipy; the polynomial
arithmetic is numerics/polynomials.py's.
"""

import math
from collections.abc import Callable
from functools import lru_cache


def particular_polynomial(
    mass: float, damping: float, stiffness: float, forcing: tuple[float, ...] | list[float]
) -> tuple[float, ...]:
    """Coefficients of the polynomial x_p with m x_p'' + c x_p' + k x_p = g (``forcing``
    the coefficients of g, N per s^j). Degree of g for k > 0; one more for k = 0 < c (then
    x_p(0) = 0), two more for k = c = 0 (x_p(0) = x_p'(0) = 0)."""
    n = len(forcing)
    if stiffness != 0.0:
        p = [0.0] * (n + 2)
        rate_factors, acceleration_factors = _particular_factors(mass, damping, n)
        for j in range(n - 1, -1, -1):
            p[j] = (
                forcing[j] - rate_factors[j] * p[j + 1] - acceleration_factors[j] * p[j + 2]
            ) / stiffness
        return tuple(p[:n])
    if damping != 0.0:  # q = x_p': m q' + c q = g, then x_p = integral of q from 0
        q = [0.0] * (n + 1)
        for j in range(n - 1, -1, -1):
            q[j] = (forcing[j] - mass * (j + 1) * q[j + 1]) / damping
        return (0.0, *(q[j] / (j + 1) for j in range(n)))
    return (0.0, 0.0, *(forcing[j] / (mass * (j + 1) * (j + 2)) for j in range(n)))


@lru_cache(maxsize=64)  # per oscillator and degree: the exact valve asks at every piece
def _particular_factors(
    mass: float, damping: float, n: int
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(c (j + 1) in N.s/m, m (j + 2) (j + 1) in kg) for j = 0 .. n - 1: the weights of
    x_p's coefficients j + 1 and j + 2 in particular_polynomial's recurrence (the same
    products, in the same order)."""
    return (
        tuple(damping * (j + 1) for j in range(n)),
        tuple(mass * (j + 2) * (j + 1) for j in range(n)),
    )


class Oscillator:
    """The homogeneous part of m x'' + c x' + k x = 0: sigma (1/s), w0^2 (1/s^2), d2 =
    w0^2 - sigma^2 and the fastest rate max(w0, 2 sigma) (1/s) of its solutions."""

    __slots__ = ("sigma", "w02", "d2", "root", "rate")

    def __init__(self, mass: float, damping: float, stiffness: float) -> None:
        self.sigma = 0.5 * damping / mass
        self.w02 = stiffness / mass
        self.d2 = self.w02 - self.sigma * self.sigma
        self.root = math.sqrt(abs(self.d2))
        self.rate = max(math.sqrt(self.w02), 2.0 * self.sigma)

    def basis(self, tau: float) -> tuple[float, float, float]:
        """(exp(-sigma tau), C(tau), S(tau)), see the module docstring."""
        decay = math.exp(-self.sigma * tau)
        r = self.root
        if r * tau < 1e-8:  # critical (or tau tiny): the common limit, to O((r tau)^2)
            return decay, 1.0, tau
        if self.d2 > 0.0:
            angle = r * tau
            return decay, math.cos(angle), math.sin(angle) / r
        # over-damped: exp(-sigma tau) cosh(mu tau) without overflowing
        grow, shrink = math.exp((r - self.sigma) * tau), math.exp(-(r + self.sigma) * tau)
        return 1.0, 0.5 * (grow + shrink), 0.5 * (grow - shrink) / r

    def free(self, e0: float, rate0: float, tau: float) -> tuple[float, float]:
        """(e, e') at tau of the free motion from e(0) = e0, e'(0) = rate0."""
        decay, c, s = self.basis(tau)
        return (
            decay * (e0 * c + (rate0 + self.sigma * e0) * s),
            decay * (rate0 * c - (self.sigma * rate0 + self.w02 * e0) * s),
        )

    def free_bounds(self, e0: float, rate0: float, span: float) -> tuple[float, float]:
        """Bounds (m, m/s) on |e(tau)| and |e'(tau)| for tau in [0, span] (s) of the free
        motion from e(0) = e0, e'(0) = rate0, with exp(-sigma tau) <= 1: |e0| |C| + |e0' +
        sigma e0| |S| and |e0'| |C| + |sigma e0' + w0^2 e0| |S| with |C| <= 1 and |S| <= span
        (also 1/w when under-damped); when under-damped also the amplitudes
        sqrt(e0^2 + ((e0' + sigma e0) / w)^2) and sqrt(e0'^2 + ((sigma e0' + w0^2 e0) / w)^2)
        (Cauchy-Schwarz on cos and sin), the smaller of the two."""
        e_coefficient = rate0 + self.sigma * e0
        rate_coefficient = self.sigma * rate0 + self.w02 * e0
        e_bound = abs(e0) + abs(e_coefficient) * span
        rate_bound = abs(rate0) + abs(rate_coefficient) * span
        if self.d2 > 0.0:
            w = self.root
            e_bound = min(e_bound, math.hypot(e0, e_coefficient / w))
            rate_bound = min(rate_bound, math.hypot(rate0, rate_coefficient / w))
        return e_bound, rate_bound


def exponential_integral(
    coefficients: tuple[float, ...] | list[float], rate: complex
) -> tuple[complex, ...]:
    """Coefficients of the polynomial G with G' + rate G = R for R's ``coefficients``, so
    that exp(rate tau) G(tau) is an antiderivative of R(tau) exp(rate tau) (rate != 0, 1/s;
    G = sum_k (-1)^k R^(k) / rate^(k + 1), by the backward recurrence
    g_j = (r_j - (j + 1) g_(j+1)) / rate)."""
    n = len(coefficients)
    g = [0j] * (n + 1)
    for j in range(n - 1, -1, -1):
        g[j] = (coefficients[j] - (j + 1) * g[j + 1]) / rate
    return tuple(g[:n])


def _legendre(n: int, x: float) -> tuple[float, float]:
    """(P_n(x), P_n'(x)) by the three-term recurrence, for |x| < 1."""
    p0, p1 = 1.0, x
    for j in range(2, n + 1):
        p0, p1 = p1, ((2 * j - 1) * x * p1 - (j - 1) * p0) / j
    return p1, n * (x * p1 - p0) / (x * x - 1.0)


def gauss_legendre(n: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Nodes and weights of the n-point Gauss-Legendre rule on [-1, 1] (Newton on P_n)."""
    nodes, weights = [], []
    for i in range(1, n + 1):
        x = math.cos(math.pi * (i - 0.25) / (n + 0.5))
        for _ in range(100):
            value, slope = _legendre(n, x)
            step = value / slope
            x -= step
            if abs(step) < 1e-16:
                break
        slope = _legendre(n, x)[1]
        nodes.append(x)
        weights.append(2.0 / ((1.0 - x * x) * slope * slope))
    return tuple(reversed(nodes)), tuple(reversed(weights))


GAUSS_8 = gauss_legendre(8)


def integrate(
    function: Callable[[float], float],
    a: float,
    b: float,
    rule: tuple[tuple[float, ...], tuple[float, ...]] = GAUSS_8,
) -> float:
    """Integral of ``function`` over [a, b] by a Gauss-Legendre rule (default 8 points,
    exact for polynomials of degree 15)."""
    half, middle = 0.5 * (b - a), 0.5 * (a + b)
    nodes, weights = rule
    return half * sum(w * function(middle + half * x) for x, w in zip(nodes, weights))
