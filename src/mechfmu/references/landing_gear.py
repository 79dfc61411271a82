"""Landing-gear reference kinematics (numpy, vectorised), mechanisms.md section 1.

An independent derivation of the closed forms, written without the standard-library physics
(only its named constants may be imported by callers). Geometry: a piston of length ``x``
joins a fixed pivot at distance ``h`` from the bar pivot B to a point at distance ``d`` from
B on the bar; ``theta`` is the angle at B between the two, so the law of cosines gives

    x^2 = h^2 + d^2 - 2 d h cos(theta).

Units are whatever the caller uses consistently (m or ft; rad; s). Arrays broadcast.
Outside the assembly range [|h - d|, h + d] the angle is NaN; at its ends sin(theta) = 0
and the rates are infinite or NaN (the reference does not raise, it reports).
"""

import numpy as np
from numpy import ndarray

STROKE_PROFILES = ("constant_speed", "cycloidal")


def design_geometry(retracted_length: float, extended_length: float) -> tuple[float, float, float]:
    """Attachment distance d, pivot height h and start angle theta_1 from the design conditions.

    The piston is perpendicular to d at x_r (so h^2 = d^2 + x_r^2, cos(theta_1) = d/h,
    sin(theta_1) = x_r/h) and the bar has turned by pi/2 at x_e (cos(theta_1 + pi/2) =
    -sin(theta_1)). Subtracting the two laws of cosines:
    x_e^2 - x_r^2 = 2 d h (sin(theta_1) + cos(theta_1)) = 2 d (x_r + d), i.e.

        d^2 + x_r d + (x_r^2 - x_e^2)/2 = 0,

    solved here with np.roots (positive root). Returns (d, h, theta_1) as floats.
    """
    x_r = float(retracted_length)
    x_e = float(extended_length)
    if not (np.isfinite(x_r) and np.isfinite(x_e) and 0.0 < x_r < x_e):
        raise ValueError(f"need 0 < retracted_length < extended_length, got {x_r!r}, {x_e!r}")
    roots = np.roots([1.0, x_r, 0.5 * (x_r * x_r - x_e * x_e)])
    real = roots[np.abs(roots.imag) <= 1e-12 * x_e].real
    d = float(np.max(real[real > 0.0]))
    h = float(np.sqrt(d * d + x_r * x_r))
    theta_1 = float(np.arctan(x_r / d))
    return d, h, theta_1


def gear_from_piston(
    x: float | list[float] | ndarray,
    xdot: float | ndarray,
    xddot: float | ndarray,
    d: float,
    h: float,
) -> tuple:
    """Gear angle, angular velocity and angular acceleration for a piston motion.

    theta = arccos((h^2 + d^2 - x^2) / (2 d h)); differentiating the law of cosines once,
    x xdot = d h sin(theta) omega; twice, xdot^2 + x xddot = d h (cos(theta) omega^2 +
    sin(theta) alpha). Returns (theta, omega, alpha) as arrays.
    """
    x, xdot, xddot = (np.asarray(a, dtype=float) for a in (x, xdot, xddot))
    with np.errstate(invalid="ignore", divide="ignore"):
        theta = np.arccos((h * h + d * d - x * x) / (2.0 * d * h))
        dh_sin = d * h * np.sin(theta)
        omega = x * xdot / dh_sin
        alpha = (xdot * xdot + x * xddot - d * h * np.cos(theta) * omega * omega) / dh_sin
    return theta, omega, alpha


def piston_from_gear(
    theta: ndarray, omega: float | ndarray, alpha: float | ndarray, d: float, h: float
) -> tuple[ndarray, ndarray, ndarray]:
    """Piston length, speed and acceleration for a gear-angle motion.

    x = sqrt(h^2 + d^2 - 2 d h cos(theta)), xdot = d h sin(theta) omega / x,
    xddot = (d h (cos(theta) omega^2 + sin(theta) alpha) - xdot^2) / x.
    Returns (x, xdot, xddot) as arrays.
    """
    theta, omega, alpha = (np.asarray(a, dtype=float) for a in (theta, omega, alpha))
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.sqrt(h * h + d * d - 2.0 * d * h * np.cos(theta))
        xdot = d * h * np.sin(theta) * omega / x
        xddot = (d * h * (np.cos(theta) * omega * omega + np.sin(theta) * alpha) - xdot * xdot) / x
    return x, xdot, xddot


def stroke(
    t: float | list[float] | ndarray,
    start_extension: float,
    end_extension: float,
    stroke_time: float,
    profile: str,
    start_time: float = 0.0,
) -> tuple[ndarray, ndarray, ndarray]:
    """Piston extension, speed and acceleration of a stroke at times ``t`` (arrays).

    tau = (t - start_time) / stroke_time. Before the stroke x holds start_extension, after it
    end_extension, with zero speed and acceleration.

    constant_speed: x = x0 + travel tau; speed travel/T on the closed interval tau in [0, 1]
    (0 outside); acceleration 0 everywhere (the end impulses are not represented).
    cycloidal: x = x0 + travel (tau - sin(2 pi tau)/(2 pi)), speed travel (1 - cos(2 pi tau))/T,
    acceleration 2 pi travel sin(2 pi tau)/T^2; zero speed and acceleration at both ends.
    """
    if profile not in STROKE_PROFILES:
        raise ValueError(f"profile = {profile!r} is not one of {', '.join(STROKE_PROFILES)}")
    if not stroke_time > 0.0:
        raise ValueError(f"stroke_time must be positive, got {stroke_time!r}")
    t = np.asarray(t, dtype=float)
    x0, x1, T = float(start_extension), float(end_extension), float(stroke_time)
    travel = x1 - x0
    tau = (t - start_time) / T
    inside = (tau >= 0.0) & (tau <= 1.0)
    tau_in = np.clip(tau, 0.0, 1.0)
    if profile == "constant_speed":
        x = x0 + travel * tau_in
        speed = np.full_like(tau, travel / T)
        accel = np.zeros_like(tau)
    else:
        angle = 2.0 * np.pi * tau_in
        x = x0 + travel * (tau_in - np.sin(angle) / (2.0 * np.pi))
        speed = travel * (1.0 - np.cos(angle)) / T
        accel = 2.0 * np.pi * travel * np.sin(angle) / (T * T)
    x = np.where(tau < 0.0, x0, np.where(tau > 1.0, x1, x))
    speed = np.where(inside, speed, 0.0)
    accel = np.where(inside, accel, 0.0)
    return x, speed, accel


def retraction(
    t: ndarray,
    d: float,
    h: float,
    start_extension: float,
    end_extension: float,
    stroke_time: float,
    profile: str,
) -> dict[str, ndarray]:
    """Piston-driven retraction sampled at times ``t``: a dict of column arrays.

    Columns: piston_extension, piston_speed, piston_acceleration (from ``stroke``, starting at
    t = 0) and gear_angle, gear_angular_velocity, gear_angular_acceleration (from
    ``gear_from_piston``).
    """
    x, xdot, xddot = stroke(t, start_extension, end_extension, stroke_time, profile)
    theta, omega, alpha = gear_from_piston(x, xdot, xddot, d, h)
    return {
        "piston_extension": x,
        "piston_speed": xdot,
        "piston_acceleration": xddot,
        "gear_angle": theta,
        "gear_angular_velocity": omega,
        "gear_angular_acceleration": alpha,
    }
