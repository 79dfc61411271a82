"""Forces in the cam-driven valve train: the cam's push, the pushrod, the rocker's pivot, the
valve link and the guides, and the torque the camshaft supplies (stdlib).

The valve train's bodies and joints (constraint_models.valve_train: tappet and pushrod as one
body from the foot P on the cam up to T, the rocker about its pivot, the valve link from V
down to the valve foot Q) with Newton-Euler on its joints (link_forces.NewtonEuler). The cam
drives the tappet whichever way the motion was specified, so the forces are solved on the
forward mechanism (the driver on the tappet foot's height): in inverse mode the desired valve
motion gives the tappet motion, and the same position, rates and forces follow.

Loads: gravity on each body (gravity effect) and, with the valve_spring effect, the valve's
moving mass at Q and its spring's closing force k L + F0 (L the valve lift) on Q, upwards.
Published (ground axes, camshaft centre at the origin, y up), each joint's force on its first
body:

    cam_force              the cam on the tappet, along the follower's axis (+ pushes it up);
    tappet_guide_force_*   the tappet guide on the tappet (normal to the axis);
    pushrod_force_*        the rocker on the pushrod at T;
    rocker_pivot_force_*   the cylinder head on the rocker at its pivot;
    valve_link_force_*     the rocker on the valve link at V (its -y part is the valve
                           spring effect's contact_force where the link is vertical and
                           massless);
    valve_guide_force_*    the valve guide on the valve (normal to its axis);

and cam_torque = cam_force ds/dtheta, the torque the camshaft supplies to this cam in its
direction of rotation (cam_geometry.camshaft_torque of the follower's force: with pushrod and
rocker massless it equals the valve spring effect's camshaft_torque, by virtual work), and the
input power cam_force times the tappet velocity. Units: m, kg, s, rad, N, N m, W.
"""

import math
from collections import namedtuple
from collections.abc import Mapping, Sequence
from typing import Any

from . import constraint_models
from .cam_geometry import camshaft_torque
from .link_forces import MassLayout, NewtonEuler, force_keys
from .planar import DEFAULT_SINGULARITY_THRESHOLD
from .valve_train import ValveGeometry

# A steel tappet and tube pushrod (0.1 kg, centre of mass half-way up the 200 mm rod) and a
# pressed-steel rocker (0.08 kg, centre of mass 7 mm towards the valve arm, I about it
# 3.3e-5 kg m^2: a 70 mm bar).
DEFAULT_PUSHROD = MassLayout(0.1, 0.1, 0.0, 0.1 * 0.2**2 / 12.0)  # along and across P -> T
DEFAULT_ROCKER = MassLayout(0.08, 0.007, 0.0, 0.08 * 0.07**2 / 12.0)

ValveSpringLoad = namedtuple("ValveSpringLoad", "mass stiffness preload")
TAPPET, ROCKER, VALVE = constraint_models.TAPPET, constraint_models.ROCKER, constraint_models.VALVE
# joints of constraint_models.valve_train, in order
TAPPET_GUIDE, ROCKER_PIVOT, PUSHROD_TOP, VALVE_LINK_TOP, VALVE_GUIDE, DRIVER = range(6)
_PUBLISHED = tuple(
    (joint, force_keys(name))
    for joint, name in (
        (TAPPET_GUIDE, "tappet_guide_force"),
        (PUSHROD_TOP, "pushrod_force"),
        (ROCKER_PIVOT, "rocker_pivot_force"),
        (VALVE_LINK_TOP, "valve_link_force"),
        (VALVE_GUIDE, "valve_guide_force"),
    )
)


def pushrod_frame(layout: MassLayout) -> MassLayout:
    """A pushrod's layout given along and across its axis (P -> T, and to its left) as the
    body frame's (the pushrod runs along the frame's y axis: to its left is -x)."""
    return MassLayout(layout.mass, -layout.com_y, layout.com_x, layout.inertia)


def positions(
    g: ValveGeometry, y_tappet: float, rocker_angle: float, y_valve: float
) -> list[float]:
    """Coordinates q of constraint_models.valve_train from the tappet foot's height, the
    rocker angle and the valve foot's height (m, rad): the link angles from the rocker's
    ends (a body-frame vector (0, L) turned by phi is (-L sin phi, L cos phi))."""
    a, b = g.rocker_pivot_x, g.rocker_pivot_y
    c, s = math.cos(rocker_angle), math.sin(rocker_angle)
    top_x, top_y = a - g.tappet_arm * c, b - g.tappet_arm * s
    end_x, end_y = a + g.valve_arm * c, b + g.valve_arm * s
    pushrod = math.atan2(-top_x, top_y - y_tappet)
    link = math.atan2(-(end_x - g.valve_axis_x), end_y - y_valve)
    return [0.0, y_tappet, pushrod, a, b, rocker_angle, g.valve_axis_x, y_valve, link]


class ValveTrainForces:
    """The force analysis of one valve train: its geometry (m), the pushrod's and rocker's
    MassLayouts (body frames of constraint_models.valve_train: the pushrod along its y axis
    from P, the rocker along x from the pivot towards the valve arm), the valve spring's load
    (None without the valve_spring effect), gravity (m/s^2) and the singularity threshold."""

    def __init__(
        self,
        geometry: ValveGeometry,
        pushrod: MassLayout,
        rocker: MassLayout,
        spring: ValveSpringLoad | None = None,
        gravity: tuple[float, float] = (0.0, 0.0),
        threshold: float = DEFAULT_SINGULARITY_THRESHOLD,
    ) -> None:
        self.geometry, self.spring = geometry, spring
        valve = MassLayout(spring.mass if spring else 0.0, 0.0, 0.0, 0.0)
        self.equations = NewtonEuler(
            constraint_models.valve_train(geometry), [pushrod, rocker, valve], gravity, threshold
        )

    def analyse(
        self, motion: Mapping[str, float], closed_height: float, lift_rate: float
    ) -> dict[str, float]:
        """Output values for the valve train's ``motion`` (ValveTrainMotion's fields),
        the valve foot's height with the valve closed (m) and the tappet's ds/dtheta (m/rad,
        for the camshaft torque)."""
        g = self.geometry
        y_tappet = g.cam_base_radius + motion["tappet_lift"]
        q = positions(g, y_tappet, motion["rocker_angle"], closed_height - motion["valve_lift"])
        drive = [(y_tappet, motion["tappet_velocity"], motion["tappet_acceleration"])]
        forces: Sequence[Any] = ()
        if self.spring is not None:
            closing = self.spring.stiffness * motion["valve_lift"] + self.spring.preload
            forces = [(VALVE, (0.0, 0.0), 0.0, closing)]
        analysis, _, _ = self.equations.solve_driven(q, drive, forces)
        cam = self.equations.effort(analysis, DRIVER)
        values = {
            "cam_force": cam,
            "cam_torque": camshaft_torque(cam, lift_rate),
            "input_power": cam * motion["tappet_velocity"],
        }
        for joint, (x, y, size) in _PUBLISHED:
            fx, fy = self.equations.on_first_body(analysis, joint, q)
            values[x], values[y], values[size] = fx, fy, math.hypot(fx, fy)
        return values
