"""Suspension reference statics (numpy), mechanisms.md section 2.

An independent derivation of the closed forms, written without the standard-library physics.
Two springs of free length L and stiffness k have their lower ends a horizontal distance d
from the centre line and their upper ends meet at the rest height h = sqrt(L^2 - d^2)
(unstressed at deflection u = 0, u positive downward). With v = h - u and
s = sqrt(d^2 + v^2) the spring length, the vertical force they carry is

    F(u) = 2 k (L - s) v / s = 2 k (L/s - 1) v.

Since L^2 - s^2 = h^2 - v^2 = u (2h - u), L - s = u (2h - u)/(L + s) and

    F(u) = u * K_sec(u),   K_sec(u) = 2 k (2h - u)(h - u) / (s (L + s)),

free of cancellation, so K_sec(0) = 2 k h^2 / L^2 exactly. Differentiating F with respect to
v gives dF/du = 2 k (1 - L d^2 / s^3): it vanishes at s*^3 = L d^2, the limit point.

Lengths in m, stiffness in N/m, forces in N (any consistent units work).
"""

from typing import Any
import numpy as np
from numpy import ndarray

NEAR, FAR = 0, 1
NEWTON_STEPS = 3
# np.roots returns a double root as a conjugate pair split by ~sqrt(eps); a pair closer to
# the real axis than this (relative to the problem's length scale) counts as one real root.
DOUBLE_ROOT_TOLERANCE = 1e-6


def rest_height(L: float, d: float) -> float:
    """h = sqrt(L^2 - d^2), written as sqrt((L - d)(L + d))."""
    return np.sqrt((L - d) * (L + d))


def _length(u: float | ndarray, L: float, d: float) -> ndarray | float:
    v = rest_height(L, d) - np.asarray(u, dtype=float)
    return np.sqrt(d * d + v * v)


def secant_stiffness(u: float | ndarray, L: float, k: float, d: float) -> Any:
    """F(u)/u = 2 k (2h - u)(h - u) / (s (L + s)); exact at u = 0 (2 k h^2 / L^2)."""
    u = np.asarray(u, dtype=float)
    h = rest_height(L, d)
    s = _length(u, L, d)
    return 2.0 * k * (2.0 * h - u) * (h - u) / (s * (L + s))


def spring_force(u: float | ndarray, L: float, k: float, d: float) -> Any:
    """Vertical spring force F(u) = u K_sec(u) (N)."""
    return np.asarray(u, dtype=float) * secant_stiffness(u, L, k, d)


def tangent_stiffness(u: float | ndarray, L: float, k: float, d: float) -> Any:
    """dF/du = 2 k (1 - L d^2 / s^3)."""
    s = _length(u, L, d)
    return 2.0 * k * (1.0 - L * d * d / (s * s * s))


def limit_point(L: float, k: float, d: float) -> tuple[float, float]:
    """(u*, F*): the near branch's end, where dF/du = 0, from s*^3 = L d^2.

    v* = sqrt(s*^2 - d^2), u* = h - v*, F* = F(u*). The far branch ends at the mirror
    point (2h - u*, -F*).
    """
    s_star = np.cbrt(L * d * d)
    v_star = np.sqrt((s_star - d) * (s_star + d))
    u_star = float(rest_height(L, d) - v_star)
    return u_star, float(spring_force(u_star, L, k, d))


def _polish(u: float, W: float, L: float, k: float, d: float) -> float:
    """A few Newton steps on F(u) - W, each kept only if it lowers the residual."""
    residual = abs(float(spring_force(u, L, k, d)) - W)
    for _ in range(NEWTON_STEPS):
        slope = float(tangent_stiffness(u, L, k, d))
        if slope == 0.0 or residual == 0.0:
            break
        candidate = u - (float(spring_force(u, L, k, d)) - W) / slope
        new_residual = abs(float(spring_force(candidate, L, k, d)) - W)
        if not np.isfinite(candidate) or new_residual >= residual:
            break
        u, residual = candidate, new_residual
    return u


def equilibria(W: float, L: float, k: float, d: float) -> ndarray:
    """Sorted array of every real deflection u with F(u) = W.

    With v = h - u and s = sqrt(d^2 + v^2), F = W reads 2 k L v / s = W + 2 k v. Squaring,
    4 k^2 L^2 v^2 = (W + 2 k v)^2 (d^2 + v^2), and with w = W / (2k):

        v^4 + 2 w v^3 + (w^2 + d^2 - L^2) v^2 + 2 w d^2 v + w^2 d^2 = 0.

    Squaring adds the roots of 2 k L v / s = -(W + 2 k v); each real root is kept only if it
    satisfies the unsquared equation better than the squared-in one (the sign check), then
    polished by Newton steps on F(u) - W.
    """
    W = float(W)
    h = float(rest_height(L, d))
    w = W / (2.0 * k)
    roots = np.roots([1.0, 2.0 * w, w * w + d * d - L * L, 2.0 * w * d * d, w * w * d * d])
    scale = max(L, abs(w))
    candidates = []
    for root in roots:
        if root.imag == 0.0:
            candidates.append(root.real)
        elif 0.0 < root.imag <= DOUBLE_ROOT_TOLERANCE * scale:
            candidates.append(root.real)  # one copy of a (numerically split) double root
    found = []
    for v in candidates:
        s = np.sqrt(d * d + v * v)
        left = 2.0 * k * L * v / s
        right = W + 2.0 * k * v
        if abs(left - right) > abs(left + right):
            continue  # a root of the squared-in equation 2 k L v / s = -(W + 2 k v)
        found.append(_polish(h - v, W, L, k, d))
    found.sort()
    unique: list[float] = []
    for u in found:
        if not unique or u - unique[-1] > 1e-14 * scale:
            unique.append(u)
    return np.array(unique, dtype=float)


def follow_load(W_array: list[float] | ndarray, L: float, k: float, d: float) -> dict[str, Any]:
    """Quasi-static equilibrium path for a load history: a dict of column arrays.

    Starts on the near branch (u < u*). Stays on the current stable branch while it has an
    equilibrium (near branch: W <= F*, far branch: W >= -F*); when it has none, jumps to the
    other stable branch and sets snap_through = 1 for that sample only (also at the first
    sample if the load already exceeds F* there). On the near branch the equilibrium is the
    smallest root, on the far branch the largest.

    Columns: deflection, spring_force, secant_stiffness, tangent_stiffness, stable (1.0 where
    dF/du > 0), branch (0 near, 1 far), snap_through (0/1), all float arrays.
    """
    loads = np.atleast_1d(np.asarray(W_array, dtype=float))
    u_star, F_star = limit_point(L, k, d)
    n = loads.size
    deflection = np.empty(n)
    branch = np.empty(n)
    snap = np.zeros(n)
    current = NEAR
    for i, W in enumerate(loads):
        exists = W <= F_star if current == NEAR else W >= -F_star
        if not exists:
            current = FAR if current == NEAR else NEAR
            snap[i] = 1.0
        roots = equilibria(W, L, k, d)
        u = roots[0] if current == NEAR else roots[-1]
        # Within rounding of the limit load the two roots next to it may come out complex;
        # the branch still ends at the limit point then.
        if current == NEAR and u > u_star:
            u = u_star
        elif current == FAR and u < 2.0 * float(rest_height(L, d)) - u_star:
            u = 2.0 * float(rest_height(L, d)) - u_star
        deflection[i] = u
        branch[i] = current
    tangent = tangent_stiffness(deflection, L, k, d)
    return {
        "deflection": deflection,
        "spring_force": spring_force(deflection, L, k, d),
        "secant_stiffness": secant_stiffness(deflection, L, k, d),
        "tangent_stiffness": tangent,
        "stable": (tangent > 0.0).astype(float),
        "branch": branch,
        "snap_through": snap,
    }
