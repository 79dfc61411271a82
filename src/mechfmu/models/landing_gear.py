"""LandingGear.fmu, kinematic mode: piston motion in, gear angle motion out."""

from ..fmi.slave import MechSlave, input_, output, parameter
from ..physics import landing_gear as gear
from ..physics.errors import require_positive
from ..physics.landing_gear import COURSEWORK_BAR_LENGTH, DEFAULT_GEOMETRY

_PISTON = ("piston_extension", "piston_speed", "piston_acceleration")


class LandingGear(MechSlave):
    """Nose landing gear driven by the piston: x, xdot, xddot -> theta, omega, alpha."""

    description = ("Retractable nose landing gear, kinematic mode: gear angle, angular velocity "
                   "and acceleration from the piston motion (law of cosines)")
    VARIABLES = (
        parameter("attachment_distance", DEFAULT_GEOMETRY.attachment_distance,
                  "d: distance from the bar pivot B to the piston attachment on the bar",
                  unit="m", min=0.0),
        parameter("pivot_height", DEFAULT_GEOMETRY.pivot_height,
                  "h: distance from the bar pivot B to the piston's fixed pivot",
                  unit="m", min=0.0),
        parameter("bar_length", COURSEWORK_BAR_LENGTH,
                  "Length of bar AB from pivot B to the wheel axle A", unit="m", min=0.0),
        input_("piston_extension", gear.COURSEWORK_RETRACTED_LENGTH,
               "x: piston length between its two pivots, within [|h - d|, h + d]",
               unit="m", min=0.0),
        input_("piston_speed", 0.0, "dx/dt: rate of change of the piston length", unit="m/s"),
        input_("piston_acceleration", 0.0, "d2x/dt2", unit="m/s2"),
        output("gear_angle", 0.0, "theta: angle at B between the bar and the line to the "
               "piston's fixed pivot", unit="rad", depends=_PISTON[:1], min=0.0, max=3.141592653589793),
        output("gear_angular_velocity", 0.0, "omega = d(theta)/dt", unit="rad/s",
               depends=_PISTON[:2]),
        output("gear_angular_acceleration", 0.0, "alpha = d(omega)/dt", unit="rad/s2",
               depends=_PISTON),
        output("piston_moment_arm", 0.0, "Moment arm of the piston force about B: "
               "d h sin(theta) / x", unit="m", depends=_PISTON[:1], min=0.0),
        output("wheel_speed", 0.0, "Speed of the wheel axle A: bar_length * omega",
               unit="m/s", depends=_PISTON[:2]),
    )

    def check_parameters(self):
        gear.check_geometry(self.values["attachment_distance"], self.values["pivot_height"])
        require_positive("bar_length", self.values["bar_length"], "m")

    def update(self, time, step_size):
        v = self.values
        d, h = v["attachment_distance"], v["pivot_height"]
        motion = gear.gear_motion(v["piston_extension"], v["piston_speed"],
                                  v["piston_acceleration"], d, h)
        arm = gear.piston_moment_arm(v["piston_extension"], d, h)
        v["gear_angle"], v["gear_angular_velocity"], v["gear_angular_acceleration"] = motion
        v["piston_moment_arm"] = arm
        v["wheel_speed"] = v["bar_length"] * motion.angular_velocity
