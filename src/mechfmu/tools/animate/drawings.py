"""One drawing per mechanism model: the shapes of each frame, in the model's own frame (m).

Each Drawing takes a DrawnComponent (the result's geometry columns of one component) and
gives, for a result row, a dict {name: Shape}. Links join the recorded joint positions as
they are, so the link lengths, sliders on their lines and the valve on its axis hold in what
is drawn exactly as in the result. Decorations (hatching, coils, blocks, a wheel's rim, the
valve's stem and head) are sized from the mechanism's own lengths; the frames and the
points are those of mechanism's geometry outputs (docs: Animations).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import shapes
from .cam import Cam, cam_of, turned_profile
from .columns import DrawnComponent
from .shapes import BAR, BODY, GROUND, GUIDE, LINK, OUTLINE, SPRING, TRACE, Shape, points


def _distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise distances (m) between two (rows, 2) arrays of points."""
    return np.hypot(*(np.asarray(b) - np.asarray(a)).T)


class Drawing:
    """The shapes of one component at each row of the result; subclasses draw a model."""

    MODEL = ""

    def __init__(self, component: DrawnComponent) -> None:
        self.component = component
        self.name = component.name
        self.rows = len(next(iter(component.columns.values())))

    def point(self, name: str) -> np.ndarray:
        """The (rows, 2) positions (m) of the geometry point ``name``."""
        return self.component.point(name)

    def shapes(self, row: int) -> dict[str, Shape]:
        """The shapes to draw at result row ``row``."""
        raise NotImplementedError

    def trace(self) -> np.ndarray | None:
        """The (rows, 2) path (m) of the point whose track is drawn, or None."""
        return None

    def traced(self, row: int) -> dict[str, Shape]:
        """The trace up to ``row`` as a shape ({} without one)."""
        path = self.trace()
        return {} if path is None else {"trace": Shape(TRACE, path[: row + 1])}


class FourBarDrawing(Drawing):
    """Ground link O2-O4 (dashed) with hatching under both pivots, crank O2-A, coupler A-B,
    rocker O4-B; the trace is the path of the coupler's midpoint (its coupler curve)."""

    MODEL = "FourBar"

    def __init__(self, component: DrawnComponent) -> None:
        super().__init__(component)
        self.o2, self.o4 = self.point("crank_pivot"), self.point("rocker_pivot")
        self.a, self.b = self.point("crank_pin"), self.point("rocker_pin")
        self.size = float(np.max(_distance(self.o2, self.o4)))

    def trace(self) -> np.ndarray:
        return 0.5 * (self.a + self.b)

    def shapes(self, row: int) -> dict[str, Shape]:
        o2, o4, a, b = self.o2[row], self.o4[row], self.a[row], self.b[row]
        return {
            "ground_link": Shape(GUIDE, points(o2, o4)),
            "crank_support": Shape(GROUND, shapes.hatching(o2, 0.25 * self.size)),
            "rocker_support": Shape(GROUND, shapes.hatching(o4, 0.25 * self.size)),
            **self.traced(row),
            "crank": Shape(LINK, points(o2, a)),
            "coupler": Shape(LINK, points(a, b)),
            "rocker": Shape(LINK, points(o4, b)),
        }


class SliderCrankDrawing(Drawing):
    """Crank pivot with hatching, crank, connecting rod, the slider's block on its line
    (dashed, hatched along its travel); the trace is the rod's midpoint."""

    MODEL = "SliderCrank"

    def __init__(self, component: DrawnComponent) -> None:
        super().__init__(component)
        self.o, self.a, self.b = (
            self.point("crank_pivot"),
            self.point("crank_pin"),
            self.point("slider_pin"),
        )
        self.rod = float(np.max(_distance(self.a, self.b)))
        low, high = float(np.min(self.b[:, 0])), float(np.max(self.b[:, 0]))
        margin = 0.2 * self.rod
        self.line = (low - margin, high + margin)

    def trace(self) -> np.ndarray:
        return 0.5 * (self.a + self.b)

    def shapes(self, row: int) -> dict[str, Shape]:
        o, a, b = self.o[row], self.a[row], self.b[row]
        block = (0.3 * self.rod, 0.15 * self.rod)
        line_y = b[1] - 0.5 * block[1]
        return {
            "slider_line": Shape(GUIDE, points((self.line[0], b[1]), (self.line[1], b[1]))),
            "slider_guide": Shape(
                GROUND,
                shapes.hatching(
                    np.array([(self.line[0] + self.line[1]) / 2, line_y]),
                    self.line[1] - self.line[0],
                    strokes=12,
                    depth=0.06 * self.rod,
                ),
            ),
            "crank_support": Shape(GROUND, shapes.hatching(o, 0.25 * self.rod)),
            **self.traced(row),
            "slider": Shape(BODY, shapes.block(b, *block)),
            "crank": Shape(LINK, points(o, a)),
            "rod": Shape(LINK, points(a, b)),
        }


class LandingGearDrawing(Drawing):
    """The airframe's two pivots (hatched, joined by a dashed line), the bar from its pivot
    B through the piston's attachment to the wheel axle A, the wheel, and the hydraulic
    piston: a cylinder from its fixed pivot and a rod of fixed length from the attachment
    (the cylinder as long as the shortest piston, the rod's head inside it); the trace is
    the wheel axle's path."""

    MODEL = "LandingGear"

    def __init__(self, component: DrawnComponent) -> None:
        super().__init__(component)
        self.b, self.anchor = self.point("bar_pivot"), self.point("piston_pivot")
        self.attachment, self.axle = self.point("piston_attachment"), self.point("wheel_axle")
        self.bar = float(np.max(_distance(self.b, self.axle)))
        lengths = _distance(self.anchor, self.attachment)
        shortest, longest = float(np.min(lengths)), float(np.max(lengths))
        self.cylinder = 0.9 * shortest
        # the rod's head stays inside the cylinder: rod in [longest - cylinder, shortest]
        self.rod = 0.5 * (max(longest - self.cylinder, 0.0) + shortest)

    def trace(self) -> np.ndarray:
        return self.axle

    def shapes(self, row: int) -> dict[str, Shape]:
        b, anchor = self.b[row], self.anchor[row]
        attachment, axle = self.attachment[row], self.axle[row]
        along = (attachment - anchor) / float(np.hypot(*(attachment - anchor)))
        width = 0.06 * self.bar
        return {
            "airframe": Shape(GUIDE, points(b, anchor)),
            "bar_support": Shape(GROUND, shapes.hatching(b, 0.2 * self.bar, np.pi / 2)),
            "piston_support": Shape(GROUND, shapes.hatching(anchor, 0.2 * self.bar, np.pi / 2)),
            **self.traced(row),
            "cylinder": Shape(
                OUTLINE, shapes.rectangle(anchor, anchor + self.cylinder * along, width)
            ),
            "rod": Shape(BAR, points(attachment - self.rod * along, attachment)),
            "piston_pivot": Shape(LINK, points(anchor)),
            "wheel": Shape(BODY, shapes.circle(axle, 0.17 * self.bar)),
            "bar": Shape(LINK, points(b, attachment, axle)),
        }


class SuspensionDrawing(Drawing):
    """The two springs from their bases to the apex, the sprung mass on the apex, the base
    joining the springs' lower ends; when the base moves (tyre or road input) a tyre spring
    down to the road (its undeformed length is not modelled: drawn as 0.4 h), else hatching
    under the base."""

    MODEL = "Suspension"

    def __init__(self, component: DrawnComponent) -> None:
        super().__init__(component)
        self.left, self.right = self.point("left_base"), self.point("right_base")
        self.apex = self.point("apex")
        self.road = self.component.columns["road_surface_y"]
        self.span = float(np.max(_distance(self.left, self.right)))
        height = float(np.max(self.apex[:, 1] - self.left[:, 1]))
        self.tyre = 0.4 * height
        self.moving = bool(np.any(self.left[:, 1] != 0.0) or np.any(self.road != 0.0))

    def shapes(self, row: int) -> dict[str, Shape]:
        left, right, apex = self.left[row], self.right[row], self.apex[row]
        centre = 0.5 * (left + right)
        width = 0.1 * self.span
        mass = (0.5 * self.span, 0.18 * self.span)
        drawn = {
            "base": Shape(LINK, points(left, right)),
            "left_spring": Shape(SPRING, shapes.spring(left, apex, coils=7, width=width)),
            "right_spring": Shape(SPRING, shapes.spring(right, apex, coils=7, width=width)),
            "mass": Shape(BODY, shapes.block(apex + np.array([0.0, 0.5 * mass[1]]), *mass)),
        }
        if self.moving:
            road = np.array([0.0, self.road[row] - self.tyre])
            drawn["road"] = Shape(
                GROUND, shapes.hatching(road, 1.3 * self.span, strokes=9, depth=0.08 * self.span)
            )
            drawn["tyre"] = Shape(
                SPRING, shapes.spring(road, centre, coils=4, width=0.15 * self.span)
            )
        else:
            below = centre - np.array([0.0, 0.02 * self.span])
            drawn["support"] = Shape(
                GROUND, shapes.hatching(below, 1.3 * self.span, strokes=9, depth=0.08 * self.span)
            )
        return drawn


class ValveTrainDrawing(Drawing):
    """The cam turning about its centre with its profile (cam.py: the runtime's cam geometry
    for the cam law and follower of the result's parameters; the base circle alone without
    them), the tappet's body in its guide with its flat face or roller, the
    pushrod P-T, the rocker T-pivot-V (hatched pivot), the valve link V-Q, and the valve:
    its stem down from Q with its head, the valve spring from the retainer to its fixed
    seat, the valve seat hatched at the closed head. Decorations are sized from the pushrod
    length."""

    MODEL = "ValveTrain"
    VALVE_TOP = "valve_foot"  # the point the valve's stem hangs from
    ROCKER_END = "valve_foot"  # the point the rocker's valve link ends at

    def __init__(self, component: DrawnComponent) -> None:
        super().__init__(component)
        self.chain = bool(np.any(component.columns["rocker_fulcrum_y"] != 0.0))
        self.centre, self.foot = self.point("cam_centre"), self.point("tappet_foot")
        self.fulcrum, self.t = self.point("rocker_fulcrum"), self.point("pushrod_end")
        self.v = self.point("valve_end")
        self.valve_top = self.point(self.VALVE_TOP)
        self.rocker_end = self.point(self.ROCKER_END)
        self.angle = component.columns["cam_angle"]
        self.cam: Cam | None = cam_of(component.parameters)
        self.base_radius = (
            self.cam.follower.base_circle_radius
            if self.cam is not None
            else float(np.min(self.foot[:, 1]))
        )
        self.roller = self.cam.follower.roller_radius if self.cam is not None else 0.0
        reach = self.valve_top[:, 1]
        self.size = (
            float(np.max(_distance(self.foot, self.t)))
            if self.chain
            else 10.0 * float(np.ptp(reach) or 0.01)
        )
        # a flat face covers the contact's travel across it (s' - e each side of the axis)
        offsets = np.abs(self.cam.face_contact) if self.cam is not None else np.zeros(1)
        self.face = max(2.4 * float(np.max(offsets)), 0.3 * self.size)
        self.closed = float(np.max(reach))  # the valve's highest (closed) top
        self.stem = 0.45 * self.size
        self.seat = self.closed - 0.1 * self.stem - 0.45 * self.stem  # spring seat height

    def _valve(self, row: int) -> dict[str, Shape]:
        top = self.valve_top[row]
        size, stem = self.size, self.stem
        head = top - np.array([0.0, stem])
        head_width, half = 0.22 * size, 0.5 * 0.22 * size
        retainer = top - np.array([0.0, 0.1 * stem])
        seat = np.array([top[0], self.seat])
        closed_head = self.closed - stem
        return {
            "valve_seat": Shape(
                GROUND,
                shapes.pen_lifted(
                    [
                        shapes.hatching(
                            np.array([top[0] + side * 0.85 * head_width, closed_head]),
                            0.6 * head_width,
                            np.pi / 2,
                            strokes=3,
                        )
                        for side in (-1.0, 1.0)
                    ]
                ),
            ),
            "spring_seat": Shape(GROUND, shapes.hatching(seat, 0.18 * size, strokes=4)),
            "valve_spring": Shape(
                SPRING, shapes.spring(seat, retainer, coils=6, width=0.15 * size)
            ),
            "valve": Shape(
                BODY,
                points(
                    top + (-0.01 * size, 0.0),
                    top + (0.01 * size, 0.0),
                    head + (0.01 * size, 0.04 * size),
                    head + (half, 0.0),
                    head + (half, -0.02 * size),
                    head + (-half, -0.02 * size),
                    head + (-half, 0.0),
                    head + (-0.01 * size, 0.04 * size),
                    top + (-0.01 * size, 0.0),
                ),
            ),
            "retainer": Shape(
                BAR, points(retainer - (0.06 * size, 0.0), retainer + (0.06 * size, 0.0))
            ),
        }

    def _chain(self, row: int) -> dict[str, Shape]:
        size, body = self.size, 0.12 * self.size
        centre, foot = self.centre[row], self.foot[row]
        fulcrum, t, v = self.fulcrum[row], self.t[row], self.v[row]
        guide_y = self.base_radius + 0.2 * size
        drawn = {
            "tappet_guide": Shape(
                GROUND,
                shapes.pen_lifted(
                    [
                        shapes.hatching(
                            np.array([side * (0.5 * body + 0.01 * size), guide_y]),
                            0.12 * size,
                            0.0 if side > 0 else np.pi,
                            strokes=3,
                        )
                        for side in (-1.0, 1.0)
                    ]
                ),
            ),
            "rocker_support": Shape(GROUND, shapes.hatching(fulcrum, 0.2 * size, np.pi / 2)),
            "tappet": Shape(
                BODY,
                shapes.block(foot + np.array([0.0, 0.5 * body + 0.6 * self.roller]), body, body),
            ),
            "pushrod": Shape(LINK, points(foot, t)),
            "rocker": Shape(LINK, points(t, fulcrum, v)),
            "valve_link": Shape(LINK, points(v, self.rocker_end[row])),
        }
        if self.roller > 0.0:
            drawn["roller"] = Shape(BODY, shapes.circle(foot, self.roller))
        else:
            half = np.array([0.5 * self.face, 0.0])
            drawn["tappet_face"] = Shape(BAR, points(foot - half, foot + half))
        if self.cam is not None:
            drawn["base_circle"] = Shape(GUIDE, shapes.circle(centre, self.base_radius))
            drawn["cam"] = Shape(BODY, centre + turned_profile(self.cam, float(self.angle[row])))
        else:
            drawn["base_circle"] = Shape(OUTLINE, shapes.circle(centre, self.base_radius))
        return drawn

    def shapes(self, row: int) -> dict[str, Shape]:
        drawn = self._chain(row) if self.chain else {}
        drawn.update(self._valve(row))
        return drawn


class ValveSpringDrawing(ValveTrainDrawing):
    """ValveTrain's drawing with the valve apart from the rocker: the valve link ends at the
    rocker's valve end, the valve's stem starts at its own tip, so a float or a bounce
    shows as a gap; with the rocker drive only the valve axis (the rocker end as a short
    bar)."""

    MODEL = "ValveSpring"
    VALVE_TOP = "valve_tip"
    ROCKER_END = "rocker_end"

    def shapes(self, row: int) -> dict[str, Shape]:
        drawn = super().shapes(row)
        if not self.chain:
            end = self.rocker_end[row]
            drawn["rocker_end"] = Shape(
                BAR, points(end - (0.06 * self.size, 0.0), end + (0.06 * self.size, 0.0))
            )
        return drawn


DRAWINGS: dict[str, type[Drawing]] = {
    cls.MODEL: cls
    for cls in (
        FourBarDrawing,
        SliderCrankDrawing,
        LandingGearDrawing,
        SuspensionDrawing,
        ValveTrainDrawing,
        ValveSpringDrawing,
    )
}


def drawing_of(component: DrawnComponent) -> Drawing:
    """The Drawing of ``component``'s model."""
    return DRAWINGS[component.model](component)


def extent(drawing: Drawing, rows: Any) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) in m of everything ``drawing`` draws at ``rows``."""
    boxes = []
    for row in rows:
        for shape in drawing.shapes(int(row)).values():
            xy = shape.xy[np.isfinite(shape.xy).all(axis=1)]
            if len(xy):
                boxes.append((xy[:, 0].min(), xy[:, 0].max(), xy[:, 1].min(), xy[:, 1].max()))
    array = np.array(boxes)
    return (
        float(array[:, 0].min()),
        float(array[:, 1].max()),
        float(array[:, 2].min()),
        float(array[:, 3].max()),
    )
