"""The cam a valve-train drawing turns: its profile in the cam's own frame.

The cam of ValveTrain (and of ValveSpring's camshaft drive) lifts a translating flat-faced
tappet whose face is perpendicular to the tappet axis, the +y axis of the valve train's frame.
Turning counter-clockwise by the camshaft angle theta it holds the face at the height
rho = r_b + s(theta) (s: the tappet lift of the cam law, or of the inverse mode's computed
tappet motion). In the cam's frame the face is the line p . n(theta) = rho(theta) with
n = (sin theta, cos theta); the profile is the envelope of these lines (Norton, Design of
Machinery, ch. 8, flat-faced follower):

    p(theta) = rho n(theta) + rho' n'(theta),   n' = (cos theta, -sin theta),

rho' = ds/dtheta. Turned by theta into the valve train's frame the point of contact is
(s'(theta), r_b + s(theta)): the tappet's face touches the cam s' to the right of its axis.

``profile_points`` is the one function a drawing takes the profile from.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from ...runtime.physics import cam_laws
from ...runtime.physics import valve_train as vt

PROFILE_SAMPLES = 360  # points of the drawn profile around the cam


class Cam(NamedTuple):
    """A cam to draw: ``angles`` (rad, increasing over one turn from 0), its profile
    ``profile`` at those angles in the cam's frame (m, (n, 2)), the base circle radius
    (m), and ``at(angle)``: the profile point of one camshaft angle (rad)."""

    angles: np.ndarray
    profile: np.ndarray
    base_radius: float
    at: Any


def _lift_function(parameters: Mapping[str, Any]) -> Any:
    """s(theta) and ds/dtheta (m, m/rad) of the tappet for ValveTrain's ``parameters``:
    the cam law itself (forward mode), or the tappet motion that gives the cam law's valve
    lift (inverse mode, valve_train.inverse at unit camshaft speed)."""
    profile = cam_laws.check_profile(
        *(
            parameters[name]
            for name in (
                "cam_law",
                "lift",
                "rise_start",
                "rise_angle",
                "high_dwell_angle",
                "return_angle",
            )
        )
    )
    if parameters.get("mode", "forward") != "inverse":

        def forward(angle: float) -> tuple[float, float]:
            lift = cam_laws.cam_lift(profile, angle)
            return lift.s, lift.s1

        return forward
    geometry = vt.check_geometry(
        vt.ValveGeometry(*(parameters[f] for f in vt.ValveGeometry._fields))
    )

    def inverse(angle: float) -> tuple[float, float]:
        motion = vt.inverse(geometry, *cam_laws.follower_motion(profile, angle, 1.0, 0.0))
        return motion.tappet_lift, motion.tappet_velocity

    return inverse


def profile_points(parameters: Mapping[str, Any], angles: np.ndarray) -> np.ndarray:
    """The cam profile's points (m, (n, 2), in the cam's frame) that touch the tappet's face
    at the camshaft angles ``angles`` (rad), for ValveTrain's ``parameters``."""
    lift_of = _lift_function(parameters)
    base = float(parameters["cam_base_radius"])
    rows = []
    for angle in np.asarray(angles, float).ravel():
        s, slope = lift_of(float(angle))
        rho, normal = base + s, np.array([np.sin(angle), np.cos(angle)])
        rows.append(rho * normal + slope * np.array([np.cos(angle), -np.sin(angle)]))
    return np.array(rows, dtype=float).reshape(-1, 2)


CAM_PARAMETERS = (
    "cam_base_radius",
    "cam_law",
    "lift",
    "rise_start",
    "rise_angle",
    "high_dwell_angle",
    "return_angle",
)


def cam_of(parameters: Mapping[str, Any]) -> Cam | None:
    """The Cam of a valve train with these parameters (a result's metadata), or None when
    they do not hold the cam's parameters."""
    if not all(name in parameters for name in CAM_PARAMETERS):
        return None
    angles = np.linspace(0.0, 2.0 * np.pi, PROFILE_SAMPLES, endpoint=False)
    return Cam(
        angles,
        profile_points(parameters, angles),
        float(parameters["cam_base_radius"]),
        lambda angle: profile_points(parameters, np.array([angle]))[0],
    )


def turned_profile(cam: Cam, angle: float) -> np.ndarray:
    """The closed profile of ``cam`` turned counter-clockwise by the camshaft ``angle`` (rad)
    into the valve train's frame, with the exact point of contact with the tappet's face
    among its vertices (it is the profile's highest point)."""
    reduced = float(np.mod(angle, 2.0 * np.pi))
    index = int(np.searchsorted(cam.angles, reduced))
    ring = np.vstack([cam.profile[:index], cam.at(reduced), cam.profile[index:]])
    c, s = np.cos(angle), np.sin(angle)
    turned = ring @ np.array([[c, s], [-s, c]])
    return np.vstack([turned, turned[:1]])


def cam_contact_offsets(cam: Cam) -> np.ndarray:
    """Where the cam touches the tappet's face at each of its sample angles: the contact's
    x in the valve train's frame, s'(theta) (m)."""
    return cam.profile[:, 0] * np.cos(cam.angles) - cam.profile[:, 1] * np.sin(cam.angles)
