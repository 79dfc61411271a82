"""FourBar.fmu: the four-bar linkage driven by its crank (closed form or constraint solver)."""

from typing import Any
from ..fmi.geometry import geometry_effect
from ..fmi.slave import input_, non_negative, output, parameter
from ..physics import constraint_models
from ..physics import four_bar as fb
from ..physics import joint_positions
from ..physics import linkage_forces as lf
from ..errors import RangeError
from . import force_variables as fv
from .linkage import CRANK as _CRANK, LinkageSlave, crank_inputs, solver_variables

COURSEWORK = fb.COURSEWORK_FOUR_BAR
_LOADS = lf.FourBarLoads._fields  # rocker_torque, coupler_force_x, coupler_force_y
_LOADED = _CRANK + _LOADS
_LINKS = ("crank", "coupler", "rocker")

# The forces effect's variables (force_variables): masses, gravity, loads, forces.
FORCE_VARIABLES = (
    fv.forces_effect(
        "pin forces at O2, A, B and O4, crank torque, input power, shaking force and "
        "moment, mechanical advantage, coupler point path"
    ),
    *fv.gravity_variables(),
    *(
        variable
        for link, layout, along in zip(
            _LINKS, lf.DEFAULT_FOUR_BAR_MASSES, ("O2 -> A", "A -> B", "O4 -> B")
        )
        for variable in fv.link_mass_variables(link, layout, link, along)
    ),
    *fv.coupler_point_variables(*lf.DEFAULT_FOUR_BAR_COUPLER_POINT, "A -> B"),
    input_(
        "rocker_torque",
        0.0,
        fv.only_with_forces(
            "external torque on the rocker, counter-clockwise (a load resists: opposite "
            "to the rocker's angular velocity)"
        ),
        "N.m",
    ),
    *fv.joint_force_outputs("crank_pivot", "F12, ground on crank at O2", _LOADED),
    *fv.joint_force_outputs("crank_pin", "F32, coupler on crank at A", _LOADED),
    *fv.joint_force_outputs("rocker_pin", "F43, rocker on coupler at B", _LOADED),
    *fv.joint_force_outputs("rocker_pivot", "F14, ground on rocker at O4", _LOADED),
    *fv.crank_drive_outputs(_LOADED),
    *fv.shaking_outputs("the crank pivot O2", _LOADED),
    output(
        "mechanical_advantage",
        0.0,
        "forces: rocker torque per unit crank torque, omega2/omega4 (unbounded where "
        "crank and coupler are collinear)",
        unit="1",
        depends=_CRANK[:1],
    ),
    *fv.coupler_point_outputs(_CRANK[:1]),
)


class FourBar(LinkageSlave):
    """Coupler and rocker motion from the crank motion.

    Angles counter-clockwise from the ground link (crank pivot O2 towards rocker pivot O4),
    as in Norton: crank O2 -> A, coupler A -> B, rocker O4 -> B; reported in (-pi, pi].
    """

    description = (
        "Four-bar linkage (Norton's conventions): crank motion in, coupler and "
        "rocker motion out; Freudenstein closed form or the planar constraint solver"
    )
    DRIVE_INPUTS = _CRANK
    VARIABLES = (
        non_negative(
            "ground_length", COURSEWORK.ground, "d: crank pivot O2 to rocker pivot O4", "m"
        ),
        non_negative("crank_length", COURSEWORK.crank, "a: crank O2 -> A", "m"),
        non_negative("coupler_length", COURSEWORK.coupler, "b: coupler A -> B", "m"),
        non_negative("rocker_length", COURSEWORK.rocker, "c: rocker O4 -> B", "m"),
        parameter(
            "circuit",
            0,
            "Assembly circuit: 0 open (sin(theta4 - theta3) > 0), 1 crossed",
            min=0,
            max=1,
        ),
        *solver_variables("closed_form"),
        *crank_inputs(fb.COURSEWORK_CRANK_ANGLE),
        output(
            "coupler_angle",
            0.0,
            "theta3: angle of the coupler A -> B",
            unit="rad",
            depends=_CRANK[:1],
        ),
        output(
            "rocker_angle",
            0.0,
            "theta4: angle of the rocker O4 -> B",
            unit="rad",
            depends=_CRANK[:1],
        ),
        output("coupler_angular_velocity", 0.0, "omega3", unit="rad/s", depends=_CRANK[:2]),
        output("rocker_angular_velocity", 0.0, "omega4", unit="rad/s", depends=_CRANK[:2]),
        output("coupler_angular_acceleration", 0.0, "alpha3", unit="rad/s2", depends=_CRANK),
        output("rocker_angular_acceleration", 0.0, "alpha4", unit="rad/s2", depends=_CRANK),
        output(
            "transmission_angle",
            0.0,
            "mu: acute angle between coupler and rocker (0 at a toggle position)",
            unit="rad",
            depends=_CRANK[:1],
            min=0.0,
        ),
        output(
            "grashof_class",
            0,
            "Grashof class: " + "; ".join(f"{c.code} {c.name}" for c in fb.GRASHOF_CLASSES),
        ),
        *geometry_effect(
            "origin at the crank pivot O2, +x along the ground link towards the rocker "
            "pivot O4, +y counter-clockwise from it",
            {
                "crank_pivot": "O2, the crank's ground pivot (the origin)",
                "rocker_pivot": "O4, the rocker's ground pivot (d, 0)",
                "crank_pin": "A, the crank-coupler joint",
                "rocker_pin": "B, the coupler-rocker joint",
            },
            depends=_CRANK[:1],
        ),
        *FORCE_VARIABLES,
    )
    EFFECT_OUTPUTS = {fv.FORCES: fv.outputs_of(FORCE_VARIABLES)}

    def _lengths(self) -> tuple[float, float, float, float]:
        v = self.values
        return (v["ground_length"], v["crank_length"], v["coupler_length"], v["rocker_length"])

    def check_geometry(self) -> Any:
        fb.check_four_bar(*self._lengths())
        if self.values["circuit"] not in fb.CIRCUITS:
            raise RangeError(
                "circuit", self.values["circuit"], "{0, 1}", "", "0 = open, 1 = crossed"
            )
        self.values["grashof_class"] = fb.grashof_class(*self._lengths())
        self.lengths = fb.check_four_bar(*self._lengths())
        self.forces = self.force_analysis()

    def force_analysis(self) -> "lf.FourBarForces | None":
        """The forces effect's analysis from the parameters, or None with the effect off."""
        v = self.values
        # every parameter of the effect checked with it off too: a negative mass is refused
        gravity = fv.gravity_setting(v)
        layouts = [fv.link_layout(v, link) for link in _LINKS]
        point = fv.coupler_point(v)
        if not v[fv.FORCES]:
            return None
        return lf.FourBarForces(self.lengths, layouts, gravity, point, v["singularity_threshold"])

    def closed_form(self, time: float) -> dict[str, float]:
        # lengths and circuit validated in check_geometry, the inputs finite (do_step)
        motion = fb.checked_motion(self.lengths, self.values["circuit"], *self.driver_inputs())
        return dict(zip(motion._fields, motion))

    def mechanism(self) -> Any:
        return constraint_models.four_bar(*self._lengths())

    def guess(self, time: float) -> Any:
        angle = self.driver_inputs()[0]
        coupler, rocker = fb.position(*self._lengths(), angle, self.values["circuit"])
        ground, crank = self._lengths()[:2]
        return constraint_models.four_bar_guess(ground, crank, angle, coupler, rocker)

    def from_solution(self, solution: Any, time: float) -> Any:
        q, qdot, qddot = solution.q, solution.qdot, solution.qddot
        coupler = constraint_models.wrap_angle(q[5])
        rocker = constraint_models.wrap_angle(q[8])
        return {
            "coupler_angle": coupler,
            "rocker_angle": rocker,
            "coupler_angular_velocity": qdot[5],
            "rocker_angular_velocity": qdot[8],
            "coupler_angular_acceleration": qddot[5],
            "rocker_angular_acceleration": qddot[8],
            "transmission_angle": fb.transmission_angle(coupler, rocker),
        }

    def geometry_points(self) -> dict[str, float]:
        v = self.values
        return joint_positions.flattened(
            joint_positions.four_bar_points(
                v["ground_length"],
                v["crank_length"],
                v["rocker_length"],
                v["crank_angle"],
                v["rocker_angle"],
            )
        )
