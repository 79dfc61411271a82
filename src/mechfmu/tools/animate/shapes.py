"""The pieces every mechanism drawing is made of, as arrays of (x, y) points in m.

A drawing is a dict {name: Shape}; a Shape is a kind (how it is drawn: render.STYLES) and an
(n, 2) array of vertices in the mechanism's own frame. The joints' positions come from the
result's geometry columns unchanged: a link is the segment between two of them, so what is
drawn satisfies the mechanism's constraints exactly as the result does. The rest (ground
hatching, springs' coils, a slider's block, a wheel's rim) is decoration sized from the
mechanism's own lengths.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# How each kind of shape is drawn (render.STYLES has the matplotlib options).
LINK = "link"  # a rigid link between joints: thick, with round joints at its vertices
BAR = "bar"  # a rigid bar without joints (a tappet's face, a piston rod)
GROUND = "ground"  # a fixed support: a base line with hatching
SPRING = "spring"  # a coil spring, drawn as a zigzag
BODY = "body"  # a solid body: a closed, filled outline
OUTLINE = "outline"  # a thin closed or open line (a cam's profile, a cylinder)
GUIDE = "guide"  # a thin dashed line (a slider's line, a base circle)
TRACE = "trace"  # the path a point has followed
KINDS = (GUIDE, GROUND, OUTLINE, TRACE, BODY, SPRING, BAR, LINK)  # drawing order, back to front


class Shape(NamedTuple):
    """A kind (one of KINDS) and its vertices, an (n, 2) float array in m."""

    kind: str
    xy: np.ndarray


def points(*vertices: tuple[float, float] | np.ndarray) -> np.ndarray:
    """The (n, 2) array of the given (x, y) vertices (m)."""
    return np.array([np.asarray(v, dtype=float) for v in vertices], dtype=float).reshape(-1, 2)


def _unit(start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(unit vector from start to end, its left normal, the distance in m); along +x for
    coincident points."""
    step = np.asarray(end, float) - np.asarray(start, float)
    length = float(np.hypot(*step))
    along = step / length if length > 0.0 else np.array([1.0, 0.0])
    return along, np.array([-along[1], along[0]]), length


def spring(
    start: np.ndarray, end: np.ndarray, coils: int = 6, width: float = 0.02, lead: float = 0.15
) -> np.ndarray:
    """A coil spring from ``start`` to ``end`` (m): straight leads of ``lead`` (a fraction of
    the length) at both ends and ``coils`` zigzags of ``width`` (m) between them. Its first
    and last vertices are ``start`` and ``end`` exactly."""
    along, normal, length = _unit(start, end)
    fractions = np.linspace(lead, 1.0 - lead, 2 * coils + 1)
    offsets = np.zeros_like(fractions)
    offsets[1:-1:2], offsets[2:-1:2] = 0.5 * width, -0.5 * width
    zigzag = (
        np.asarray(start, float) + np.outer(fractions * length, along) + np.outer(offsets, normal)
    )
    return np.vstack([points(start), zigzag, points(end)])


def hatching(
    centre: np.ndarray,
    width: float,
    angle: float = -np.pi / 2,
    strokes: int = 5,
    depth: float | None = None,
) -> np.ndarray:
    """Ground hatching at ``centre`` (m): a base line of ``width`` (m) across the direction
    ``angle`` (rad; the side the ground lies on, default below), with ``strokes`` slanted
    strokes of ``depth`` (m; default a quarter of the width) on that side; one polyline,
    pen lifts as NaN rows."""
    side = np.array([np.cos(angle), np.sin(angle)])
    across = np.array([-side[1], side[0]])
    centre = np.asarray(centre, float)
    half = 0.5 * width
    depth = 0.25 * width if depth is None else depth
    pieces = [points(centre - half * across, centre + half * across)]
    for fraction in np.linspace(-0.5, 0.5, strokes):
        top = centre + fraction * width * across
        pieces.append(points(top, top + depth * side - 0.6 * depth * across))
    return pen_lifted(pieces)


def pen_lifted(pieces: list[np.ndarray]) -> np.ndarray:
    """Polylines joined into one array, a NaN row between them (matplotlib lifts the pen)."""
    gap = np.full((1, 2), np.nan)
    joined: list[np.ndarray] = []
    for piece in pieces:
        if joined:
            joined.append(gap)
        joined.append(piece)
    return np.vstack(joined)


def rectangle(start: np.ndarray, end: np.ndarray, width: float, extend: float = 0.0) -> np.ndarray:
    """The closed outline of a bar of ``width`` (m) along the segment start -> end, longer
    by ``extend`` (m) at both ends."""
    along, normal, _ = _unit(start, end)
    a = np.asarray(start, float) - extend * along
    b = np.asarray(end, float) + extend * along
    half = 0.5 * width * normal
    return points(a + half, b + half, b - half, a - half, a + half)


def block(centre: np.ndarray, width: float, height: float, angle: float = 0.0) -> np.ndarray:
    """The closed outline of a ``width`` x ``height`` (m) rectangle centred at ``centre``,
    its width along ``angle`` (rad)."""
    along = np.array([np.cos(angle), np.sin(angle)])
    start = np.asarray(centre, float) - 0.5 * width * along
    return rectangle(start, start + width * along, height)


def circle(centre: np.ndarray, radius: float, samples: int = 48) -> np.ndarray:
    """A closed circle of ``radius`` (m) around ``centre``."""
    angles = np.linspace(0.0, 2.0 * np.pi, samples + 1)
    return np.asarray(centre, float) + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def rotated(xy: np.ndarray, angle: float, about: np.ndarray | None = None) -> np.ndarray:
    """``xy`` turned counter-clockwise by ``angle`` (rad) about ``about`` (default the
    origin)."""
    c, s = np.cos(angle), np.sin(angle)
    centre = np.zeros(2) if about is None else np.asarray(about, float)
    relative = np.asarray(xy, float) - centre
    return centre + relative @ np.array([[c, s], [-s, c]])
