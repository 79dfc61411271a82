"""The cam a valve-train drawing turns: its profile, from the runtime's cam geometry.

The profile is cam_geometry's (mechfmu.runtime.physics.cam_geometry, Norton's cam design):
``cam_point`` of the follower the result's parameters name (ValveTrain's ``follower``,
``roller_radius``, ``follower_offset``; a flat face on the axis without them, as ValveSpring's
camshaft drive has) at each camshaft angle, for the tappet's displacement diagram over a
revolution (valve_train.tappet_pieces: the cam law in forward mode, the tappet motion the
desired valve lift needs in inverse mode). Points are in the cam's frame, which coincides
with the fixed frame at camshaft angle 0; the cam turns counter-clockwise by the camshaft
angle. A cam law that no cam can follow (a cusp for a flat face, an undercut for a roller)
is drawn as its envelope is, folded: cam_geometry's design checks say where.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from ...runtime.physics import cam_geometry, cam_laws
from ...runtime.physics import valve_train as vt
from ...runtime.physics.cam_laws import TAU

PROFILE_SAMPLES = 360  # points of the drawn profile around the cam
CAM_LAW = ("cam_law", "lift", "rise_start", "rise_angle", "high_dwell_angle", "return_angle")


class Cam(NamedTuple):
    """A cam to draw: its ``follower`` (cam_geometry.Follower), the tappet's displacement
    diagram as cam_geometry Pieces, and its profile sampled at ``angles`` (rad, increasing
    in [0, 2 pi)): ``profile`` (m, (n, 2), the cam's frame) and ``face_contact`` (m: where
    each point touches a flat face, from the follower's axis; 0 for a roller)."""

    follower: cam_geometry.Follower
    pieces: tuple[cam_geometry.Piece, ...]
    angles: np.ndarray
    profile: np.ndarray
    face_contact: np.ndarray


def diagram_at(pieces: tuple[cam_geometry.Piece, ...], angle: float) -> tuple[float, float, float]:
    """(s m, s1 m/rad, s2 m/rad^2) of the displacement diagram ``pieces`` at the camshaft
    ``angle`` (rad): the piece that holds it, each closed on the left as the cam law's (the
    drawing's and mechfmu cam-profile's)."""
    for piece in reversed(pieces):
        offset = math.fmod(angle - piece.start, TAU)
        offset += TAU if offset < 0.0 else 0.0
        if offset < piece.span:
            return piece.motion(offset / piece.span)
    return pieces[0].motion(0.0)  # rounding just before the first piece's start


def point_at(cam: Cam, angle: float) -> cam_geometry.CamPoint:
    """cam_geometry.cam_point of ``cam`` at the camshaft ``angle`` (rad)."""
    return cam_geometry.cam_point(cam.follower, angle, *diagram_at(cam.pieces, angle))


def cam_of(parameters: Mapping[str, Any]) -> Cam | None:
    """The Cam of a valve train with these parameters (a result's metadata: ValveTrain's or
    ValveSpring's), or None when they do not hold the cam law and base circle."""
    if not all(name in parameters for name in (*CAM_LAW, "cam_base_radius")):
        return None
    profile = cam_laws.check_profile(*(parameters[name] for name in CAM_LAW))
    follower = cam_geometry.check_follower(
        str(parameters.get("follower", "flat_faced")),
        float(parameters["cam_base_radius"]),
        float(parameters.get("roller_radius", 0.0)),
        float(parameters.get("follower_offset", 0.0)),
    )
    mode = str(parameters.get("mode", "forward"))
    geometry = (
        vt.check_geometry(vt.ValveGeometry(*(parameters[f] for f in vt.ValveGeometry._fields)))
        if mode == "inverse"
        else vt.DEFAULT_VALVE_GEOMETRY  # forward: the cam law is the tappet's own
    )
    pieces = vt.tappet_pieces(geometry, profile, mode)
    rows = []
    for piece in pieces:  # each piece with both its ends: the corners where laws meet
        count = max(8, int(np.ceil(PROFILE_SAMPLES * piece.span / TAU)))
        for phase in np.linspace(0.0, 1.0, count + 1):
            angle = float((piece.start + phase * piece.span) % TAU)
            point = cam_geometry.cam_point(follower, angle, *piece.motion(float(phase)))
            rows.append((angle, point.x, point.y, point.face_contact))
    table = np.array(sorted(rows), dtype=float)
    return Cam(follower, pieces, table[:, 0], table[:, 1:3], table[:, 3])


def turned_profile(cam: Cam, angle: float) -> np.ndarray:
    """The closed profile of ``cam`` turned counter-clockwise by the camshaft ``angle``
    (rad), about its centre (the fixed frame's origin at the cam's centre), with the exact
    point of contact with the follower at that angle among its vertices."""
    reduced = float(np.mod(angle, TAU))
    index = int(np.searchsorted(cam.angles, reduced))
    contact = point_at(cam, reduced)
    ring = np.vstack([cam.profile[:index], [contact.x, contact.y], cam.profile[index:]])
    c, s = np.cos(angle), np.sin(angle)
    turned = ring @ np.array([[c, s], [-s, c]])
    return np.vstack([turned, turned[:1]])
