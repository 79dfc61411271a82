"""Suspension.fmu, static mode: load in, equilibrium deflection out, by continuation."""

from pythonfmu.enums import Fmi2Status

from ..fmi.slave import MechSlave, input_, output, parameter
from ..physics import suspension as physics


class Suspension(MechSlave):
    """Two-spring suspension following its load on the stable branches.

    The equilibrium follows the load continuously from the unloaded state (near branch).
    When the load passes the limit load the near equilibrium vanishes: the FMU logs the
    snap-through, raises the ``snap_through`` flag for that step and continues on the far
    stable branch, or, with ``stop_on_snap_through``, discards the step with an error.
    """

    description = ("Two-spring car suspension, static: equilibrium deflection under a load, "
                   "followed by continuation on the stable branches with snap-through detection")
    VARIABLES = (
        parameter("spring_free_length", physics.COURSEWORK_FREE_LENGTH, "L: free length of "
                  "each spring", unit="m", min=0.0),
        parameter("spring_stiffness", physics.COURSEWORK_STIFFNESS, "k: stiffness of each "
                  "spring", unit="N/m", min=0.0),
        parameter("spring_base_offset", physics.COURSEWORK_BASE_OFFSET, "d: horizontal "
                  "distance of each spring's lower end from the centre line, in (0, L)",
                  unit="m", min=0.0),
        parameter("stop_on_snap_through", False, "true: a snap-through discards the step "
                  "with an error instead of continuing on the far branch"),
        input_("load", 0.0, "W: downward load on the spring apex", unit="N"),
        output("deflection", 0.0, "u: downward deflection of the apex from the unstressed "
               "position", unit="m", depends=("load",)),
        output("spring_force", 0.0, "F(u): vertical force carried by the springs "
               "(equals the load at equilibrium)", unit="N", depends=("load",)),
        output("secant_stiffness", 0.0, "F/u (exact limit 2 k h^2 / L^2 at u = 0)",
               unit="N/m", depends=("load",)),
        output("tangent_stiffness", 0.0, "dF/du: decides stability and natural frequency",
               unit="N/m", depends=("load",)),
        output("stable", True, "tangent_stiffness > 0", depends=("load",)),
        output("snap_through", False, "true on a step where the load passed a limit load "
               "and the equilibrium jumped to the other stable branch", depends=("load",)),
        output("branch", 0, "Stable branch: 0 near (u < h - v*), 1 far (u > h + v*)",
               depends=("load",)),
        output("snap_through_count", 0, "Number of snap-throughs so far", depends=("load",)),
        output("limit_load", 0.0, "F*: largest load the near branch can carry", unit="N"),
        output("limit_deflection", 0.0, "u*: deflection at the limit load", unit="m"),
    )

    def _spring(self):
        v = self.values
        return physics.make_spring(v["spring_free_length"], v["spring_stiffness"],
                                   v["spring_base_offset"])

    def check_parameters(self):
        limit = physics.limit_point(self._spring())
        self.values["limit_load"], self.values["limit_deflection"] = limit.load, limit.deflection

    def outputs_at_start(self, time):
        self.values["branch"] = physics.NEAR  # continuation starts from the unloaded state
        self.update(time, 0.0)

    def update(self, time, step_size):
        v = self.values
        state, snapped = physics.follow_load(
            v["load"], v["branch"], self._spring(), guess=v["deflection"],
            continue_past_limit=not v["stop_on_snap_through"])
        if snapped:
            self.log(f"{self.instance_name} at t = {time!r} s: snap-through: load = "
                     f"{v['load']!r} N passed the limit of branch "
                     f"{'near' if v['branch'] == physics.NEAR else 'far'}; deflection jumps "
                     f"from {v['deflection']!r} m to {state.deflection!r} m",
                     Fmi2Status.warning)
            v["snap_through_count"] += 1
        (v["deflection"], v["spring_force"], v["secant_stiffness"], v["tangent_stiffness"],
         v["stable"], v["branch"]) = state
        v["snap_through"] = snapped
