"""Shaft drive reference (numpy): angle, speed and acceleration of a linearly ramped shaft.

Independent of physics/profiles.rotation: the angle is the integral of the speed profile
w(t) = w0 + (w1 - w0) clip((t - t0) / T, 0, 1), evaluated piecewise in closed form. Before
t0 the shaft turns at w0. Units: rad, rad/s, rad/s^2, s.
"""

import numpy as np
from numpy import ndarray
from collections.abc import Mapping
from typing import Any

# Times within TIME_SNAP * ramp_time of a ramp end count as that end (the physics' value,
# runtime/physics/profiles.TIME_SNAP, restated: references do not import the profiles).
TIME_SNAP = 1e-9


def rotation(
    times: float | ndarray,
    initial_angle: float,
    initial_speed: float,
    speed: float,
    ramp_time: float,
    start_time: float = 0.0,
    ratio: float = 1.0,
) -> dict[str, Any]:
    """Columns 'angle', 'speed', 'acceleration' at ``times``; speeds scaled by ``ratio``
    (0.5 for a camshaft driven from the crankshaft speeds)."""
    t = np.asarray(times, dtype=float) - start_time
    w0, w1 = ratio * initial_speed, ratio * speed
    if ramp_time > 0.0:
        during = np.clip(t, 0.0, ramp_time)
        slope = (w1 - w0) / ramp_time
        angle = (
            initial_angle
            + w0 * np.minimum(t, 0.0)
            + w0 * during
            + 0.5 * slope * during**2
            + w1 * np.maximum(t - ramp_time, 0.0)
        )
        # The acceleration jumps at both ends of the ramp: a sample within TIME_SNAP of the
        # ramp time of an end counts as that end, as in runtime/physics/profiles.rotation,
        # so the classification does not hinge on how the sample time was rounded.
        ramping = (t >= -TIME_SNAP * ramp_time) & (t < ramp_time * (1.0 - TIME_SNAP))
        rate = np.where(ramping, w0 + slope * during, np.where(t < 0.0, w0, w1))
        acceleration = np.where(ramping, slope, 0.0)
    else:
        angle = initial_angle + np.where(t < 0.0, w0 * t, w1 * t)
        rate = np.where(t < 0.0, w0, w1)
        acceleration = np.zeros_like(t)
    return {"angle": angle, "speed": rate, "acceleration": acceleration}


def shaft_rotation(
    times: float | ndarray, parameters: Mapping[str, Any], ratio: float = 1.0
) -> dict[str, Any]:
    """``rotation`` at ``times`` (s) with a CrankDrive's or CamshaftDrive's ``parameters``
    (their FMU parameter names: rad, rad/s, s)."""
    return rotation(
        times,
        parameters["initial_angle"],
        parameters["initial_speed"],
        parameters["speed"],
        parameters["ramp_time"],
        parameters["start_time"],
        ratio,
    )
