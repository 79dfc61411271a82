"""Four-bar and slider-crank reference kinematics (numpy, vectorised over crank angles).

An independent derivation, written without the standard-library physics (which uses
Freudenstein's half-angle closed form and explicit rate formulas): positions here come from
intersecting two circles through the diagonal of the loop, and the rates from solving the
once- and twice-differentiated loop equations as stacked 2x2 linear systems.

Four-bar (names as in the physics): crank pivot O2 = (0, 0), rocker pivot O4 = (d, 0), crank
O2 -> A of length a at theta2, coupler A -> B of length b at theta3, rocker O4 -> B of length c
at theta4, all angles counter-clockwise from +x. The diagonal A -> O4 has length f and angle
phi; in the triangle A-B-O4 the angle gamma at A between the diagonal and the coupler follows
from the law of cosines, written with Heron's area so it stays accurate near 0 and pi:

    gamma = atan2(4 area, b^2 + f^2 - c^2),
    4 area = sqrt((b + c + f)(b + c - f)(f + b - c)(f - b + c)).

Circuit 0 (open) puts B to the left of the directed diagonal A -> O4, theta3 = phi + gamma;
circuit 1 (crossed) to its right, theta3 = phi - gamma. Then B = A + b e^(i theta3) and
theta4 is the angle of B - O4.

Slider-crank: crank pivot at the origin, crank a at theta2, coupler b from A to the slider pin
B = (s, offset). |B - A| = b gives s = a cos(theta2) +- sqrt(b^2 - (offset - a sin theta2)^2),
+ for circuit 0 (slider on the +x side of the crank pin), - for circuit 1; theta3 is the
angle of B - A.

Angles are wrapped to (-pi, pi]. Outside the assembly range every output is NaN; exactly at a
toggle or singular position the rates are inf or NaN. Nothing raises.
"""

from typing import Any
import numpy as np
from numpy import ndarray


def _wrap(angle: ndarray | float) -> ndarray:
    """Angles in (-pi, pi]."""
    wrapped = np.pi - np.mod(np.pi - angle, 2.0 * np.pi)
    # np.mod may round up to 2 pi for a tiny negative argument, giving -pi
    return np.where(wrapped <= -np.pi, wrapped + 2.0 * np.pi, wrapped)


def _solve_stacked(matrix: ndarray, rhs: ndarray) -> ndarray:
    """Solve matrix[k] @ x[k] = rhs[k] for every k; rows with a singular or NaN matrix -> NaN.

    matrix has shape (..., 2, 2), rhs (..., 2). Bad rows are replaced by the identity for the
    solve (a single singular matrix would make np.linalg.solve raise for the whole stack).
    """
    det = matrix[..., 0, 0] * matrix[..., 1, 1] - matrix[..., 0, 1] * matrix[..., 1, 0]
    good = np.isfinite(det) & (det != 0.0) & np.all(np.isfinite(rhs), axis=-1)
    safe_matrix = np.where(good[..., None, None], matrix, np.eye(2))
    safe_rhs = np.where(good[..., None], rhs, 0.0)
    solution = np.linalg.solve(safe_matrix, safe_rhs[..., None])[..., 0]
    return np.where(good[..., None], solution, np.nan)


def _broadcast(*values: Any) -> tuple[ndarray, ...]:
    return np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values))


def four_bar(
    ground: float,
    crank: float,
    coupler: float,
    rocker: float,
    circuit: int,
    crank_angle: float | ndarray,
    crank_speed: float,
    crank_acceleration: float,
) -> dict[str, ndarray | float]:
    """Four-bar motion for arrays of crank angle, speed and acceleration.

    Returns a dict of arrays: coupler_angle, rocker_angle, coupler_angular_velocity,
    rocker_angular_velocity, coupler_angular_acceleration, rocker_angular_acceleration,
    transmission_angle (the acute angle between coupler and rocker, from the triangle A-B-O4).
    """
    if circuit not in (0, 1):
        raise ValueError(f"circuit must be 0 or 1, got {circuit!r}")
    d, a, b, c = (float(v) for v in (ground, crank, coupler, rocker))
    t2, w2, al2 = _broadcast(crank_angle, crank_speed, crank_acceleration)
    ax, ay = a * np.cos(t2), a * np.sin(t2)
    dx, dy = d - ax, -ay  # diagonal A -> O4
    f = np.hypot(dx, dy)
    phi = np.arctan2(dy, dx)
    with np.errstate(invalid="ignore", divide="ignore"):
        four_area = np.sqrt((b + c + f) * (b + c - f) * (f + b - c) * (f - b + c))
        gamma = np.arctan2(four_area, b * b + f * f - c * c)
        t3 = phi + gamma if circuit == 0 else phi - gamma
        bx, by = ax + b * np.cos(t3), ay + b * np.sin(t3)
        t4 = np.arctan2(by, bx - d)
        # angle at B between the coupler and rocker lines, folded to [0, pi/2]
        transmission = np.arctan2(four_area, np.abs(b * b + c * c - f * f))

        s2, c2 = np.sin(t2), np.cos(t2)
        s3, c3 = np.sin(t3), np.cos(t3)
        s4, c4 = np.sin(t4), np.cos(t4)
        # d/dt of a e^(i t2) + b e^(i t3) - c e^(i t4) = d, real and imaginary parts:
        #   -b s3 w3 + c s4 w4 = a s2 w2,   b c3 w3 - c c4 w4 = -a c2 w2
        matrix = np.stack(
            [np.stack([-b * s3, c * s4], axis=-1), np.stack([b * c3, -c * c4], axis=-1)], axis=-2
        )
        rates = _solve_stacked(matrix, np.stack([a * s2 * w2, -a * c2 * w2], axis=-1))
        w3, w4 = rates[..., 0], rates[..., 1]
        # second derivative: the same matrix acting on (al3, al4)
        rhs = np.stack(
            [
                a * s2 * al2 + a * c2 * w2**2 + b * c3 * w3**2 - c * c4 * w4**2,
                -a * c2 * al2 + a * s2 * w2**2 + b * s3 * w3**2 - c * s4 * w4**2,
            ],
            axis=-1,
        )
        accelerations = _solve_stacked(matrix, rhs)
    return {
        "coupler_angle": _wrap(t3),
        "rocker_angle": _wrap(t4),
        "coupler_angular_velocity": w3,
        "rocker_angular_velocity": w4,
        "coupler_angular_acceleration": accelerations[..., 0],
        "rocker_angular_acceleration": accelerations[..., 1],
        "transmission_angle": transmission,
    }


def slider_crank(
    crank: float,
    coupler: float,
    offset: float,
    circuit: int,
    crank_angle: ndarray,
    crank_speed: float,
    crank_acceleration: float,
) -> dict[str, ndarray]:
    """Offset slider-crank motion for arrays of crank angle, speed and acceleration.

    Returns a dict of arrays: slider_position, slider_speed, slider_acceleration,
    coupler_angle, coupler_angular_velocity, coupler_angular_acceleration.
    """
    if circuit not in (0, 1):
        raise ValueError(f"circuit must be 0 or 1, got {circuit!r}")
    a, b, e = float(crank), float(coupler), float(offset)
    t2, w2, al2 = _broadcast(crank_angle, crank_speed, crank_acceleration)
    ax, ay = a * np.cos(t2), a * np.sin(t2)
    height = e - ay  # y of B - A
    with np.errstate(invalid="ignore", divide="ignore"):
        reach = np.sqrt(b * b - height * height)
        s = ax + reach if circuit == 0 else ax - reach
        t3 = np.arctan2(height, s - ax)
        s2, c2 = np.sin(t2), np.cos(t2)
        s3, c3 = np.sin(t3), np.cos(t3)
        # d/dt of a e^(i t2) + b e^(i t3) = s + i offset, unknowns (w3, ds/dt):
        #   -b s3 w3 - sdot = a s2 w2,   b c3 w3 = -a c2 w2
        ones = np.ones_like(t3)
        matrix = np.stack(
            [np.stack([-b * s3, -ones], axis=-1), np.stack([b * c3, 0.0 * ones], axis=-1)], axis=-2
        )
        rates = _solve_stacked(matrix, np.stack([a * s2 * w2, -a * c2 * w2], axis=-1))
        w3, speed = rates[..., 0], rates[..., 1]
        rhs = np.stack(
            [
                a * s2 * al2 + a * c2 * w2**2 + b * c3 * w3**2,
                -a * c2 * al2 + a * s2 * w2**2 + b * s3 * w3**2,
            ],
            axis=-1,
        )
        accelerations = _solve_stacked(matrix, rhs)
    return {
        "slider_position": s,
        "slider_speed": speed,
        "slider_acceleration": accelerations[..., 1],
        "coupler_angle": _wrap(t3),
        "coupler_angular_velocity": w3,
        "coupler_angular_acceleration": accelerations[..., 0],
    }
