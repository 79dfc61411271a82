"""Landing gear: the reactions at the bar's pivot B and at the actuator's anchor (stdlib).

Airframe axes: origin at the pivot B, x forward along the airframe, y up; with the
airframe level they are the ground's. The gear angle theta (gear_dynamics) sits at B between
the bar and the line to the actuator's fixed pivot C, and the bar hangs straight down at
theta = down_angle, so with beta = theta - down_angle (the bar's swing forward from hanging):

    bar direction      u = (sin beta, -cos beta),     perp(u) = (cos beta, sin beta),
    attachment P = d u,    anchor C = h (-sin down_angle, -cos down_angle)  (fixed),

so |P - C|^2 = d^2 + h^2 - 2 d h cos(theta), the law of cosines of the kinematics, and a
retraction (theta growing) swings the wheel forward and up (counter-clockwise seen with x to
the right). Gravity points along (-sin p, -cos p) for a nose-up pitch p, the drag on the
wheel against the flight direction, -(1/2) rho CdA V|V| (cos p, -sin p) (gear_dynamics'
moments are those forces' moments about B).

The actuator is a two-force member (no mass): it pushes P away from C with the piston force
F (positive extending), along e = (P - C)/x, and C away from P. Newton's law for bar and
wheel (mass m, first moment S = m l_G about B, gear_dynamics.gravity_lever) gives the force
of the airframe on the bar at B,

    R_B = m a_G - W - D - F e,      m a_G = S (alpha perp(u) - omega^2 u),

and the airframe holds the actuator at its anchor with F e (it carries -F e there). Pivot
friction is a pure moment at B and adds no force. With the inertia effect off the motion
drive is quasi-static and m a_G is left out, as in its required piston force.

Units: m, kg, s, rad, N, W.
"""

import math
from collections.abc import Callable

from ..errors import SingularConfiguration
from . import gear_dynamics as gd

# Moment arm of the piston below this fraction of the attachment distance: the required
# piston force is unbounded (the actuator in line with the bar, a dead centre).
DEAD_CENTRE_RATIO = 1e-8


class GearForces:
    """The reactions of one gear configuration: ``values`` (the FMU's, for the effects and
    their parameters), the bar and wheel Body and the Geometry of gear_dynamics."""

    def __init__(self, values: dict, body: gd.Body, geometry: gd.Geometry) -> None:
        self.geometry = geometry
        self.first_moment = gd.gravity_lever(body) if values["inertia"] else 0.0
        pitch = geometry.airframe_pitch
        weight = (body.bar_mass + body.wheel_mass) * values["gravity_acceleration"]
        self.weight = (
            (-weight * math.sin(pitch), -weight * math.cos(pitch)) if values["gravity"] else None
        )
        self.drag: Callable[[float], float] | None = None
        if values["aero_drag"]:
            drag = gd.Drag(values["air_density"], values["drag_area"])
            self.drag = lambda speed: 0.5 * drag.air_density * drag.drag_area * speed * abs(speed)
        self.flight = (math.cos(pitch), -math.sin(pitch))  # the flight direction, airframe axes
        down = geometry.down_angle
        self.anchor = (
            -geometry.pivot_height * math.sin(down),
            -geometry.pivot_height * math.cos(down),
        )

    def reactions(
        self, angle: float, omega: float, alpha: float, piston_force: float, airspeed: float
    ) -> dict[str, float]:
        """pivot_force (airframe on bar at B) and anchor_force (airframe on the actuator at
        C), each x, y and magnitude (N), for the gear angle (rad), its rate (rad/s) and
        acceleration (rad/s^2), the force along the piston (N, extending) and the airspeed
        (m/s, aero_drag)."""
        beta = angle - self.geometry.down_angle
        ux, uy = math.sin(beta), -math.cos(beta)
        d = self.geometry.attachment_distance
        ex, ey = d * ux - self.anchor[0], d * uy - self.anchor[1]
        length = math.hypot(ex, ey)
        ex, ey = ex / length, ey / length
        fx, fy = piston_force * ex, piston_force * ey
        s = self.first_moment
        rx = s * (alpha * -uy - omega * omega * ux) - fx
        ry = s * (alpha * ux - omega * omega * uy) - fy
        if self.weight is not None:
            rx -= self.weight[0]
            ry -= self.weight[1]
        if self.drag is not None:
            drag = self.drag(airspeed)
            rx += drag * self.flight[0]
            ry += drag * self.flight[1]
        return {
            "pivot_force_x": rx,
            "pivot_force_y": ry,
            "pivot_force_magnitude": math.hypot(rx, ry),
            "anchor_force_x": fx,
            "anchor_force_y": fy,
            "anchor_force_magnitude": abs(piston_force),
        }


def check_moment_arm(arm: float, geometry: gd.Geometry, angle: float, length: float) -> None:
    """SingularConfiguration where the piston's moment arm (m) is too small for any finite
    required force: the actuator in line with the bar (a dead centre)."""
    if not abs(arm) > DEAD_CENTRE_RATIO * geometry.attachment_distance:
        raise SingularConfiguration(
            f"piston force unbounded: the actuator is in line with the bar (dead centre, "
            f"moment arm {arm!r} m) at gear angle {angle!r} rad, piston length {length!r} m"
        )
