"""SliderCrank.fmu: the offset slider-crank driven by its crank (closed form or solver)."""

from typing import Any
from ..fmi.geometry import geometry_effect
from ..fmi.slave import input_, non_negative, motion_outputs, output, parameter
from ..physics import constraint_models
from ..physics import joint_positions
from ..physics import link_forces
from ..physics import linkage_forces as lf
from ..physics import slider_crank as sc
from ..errors import RangeError, require_finite
from . import force_variables as fv
from .linkage import CRANK as _CRANK, LinkageSlave, crank_inputs, solver_variables

_SLIDER = ("slider_position", "slider_speed", "slider_acceleration")
_COUPLER = ("coupler_angle", "coupler_angular_velocity", "coupler_angular_acceleration")

DEFAULT = sc.DEFAULT_SLIDER_CRANK
_LOADS = lf.SliderCrankLoads._fields  # slider_force, coupler_force_x, coupler_force_y
_LOADED = _CRANK + _LOADS
_MASSES = lf.DEFAULT_SLIDER_CRANK_MASSES

# The forces effect's variables (force_variables): masses, counterweight, gravity, loads.
FORCE_VARIABLES = (
    fv.forces_effect(
        "pin forces at the crank pivot, A and B, guide force, crank torque, input power, "
        "shaking force and moment, mechanical advantage, coupler point path"
    ),
    *fv.gravity_variables(),
    *fv.link_mass_variables("crank", _MASSES.crank, "crank (without counterweight)", "pivot -> A"),
    *fv.link_mass_variables("coupler", _MASSES.coupler, "connecting rod", "A -> B"),
    non_negative(
        "slider_mass", _MASSES.slider.mass, "forces: mass of the slider (piston), at B", "kg"
    ),
    non_negative(
        "counterweight_mass",
        0.0,
        "forces: balancing counterweight on the crank, a point mass opposite the crank pin",
        "kg",
    ),
    non_negative(
        "counterweight_radius",
        DEFAULT.crank,
        "forces: distance of the counterweight from the crank pivot",
        "m",
    ),
    *fv.coupler_point_variables(*lf.DEFAULT_SLIDER_CRANK_COUPLER_POINT, "A -> B"),
    input_(
        "slider_force",
        0.0,
        fv.only_with_forces(
            "external force on the slider along its axis, positive towards the crank "
            "(-x on circuit 0, +x on circuit 1): an engine's gas force, pressure times "
            "piston area"
        ),
        "N",
    ),
    *fv.joint_force_outputs("crank_pivot", "F12, ground on crank at the pivot", _LOADED),
    *fv.joint_force_outputs("crank_pin", "F32, connecting rod on crank at A", _LOADED),
    *fv.joint_force_outputs("slider_pin", "F43, slider on connecting rod at B", _LOADED),
    *fv.joint_force_outputs("guide", "F14, guide on slider (normal to the axis)", _LOADED),
    *fv.crank_drive_outputs(_LOADED),
    *fv.shaking_outputs("the crank pivot", _LOADED),
    output(
        "mechanical_advantage",
        0.0,
        "forces: crank torque per newton of slider force towards the crank (the piston "
        "driving, as in an engine): a lever arm, 0 at the dead centres",
        unit="m",
        depends=_CRANK[:1],
    ),
    *fv.coupler_point_outputs(_CRANK[:1]),
)


class SliderCrank(LinkageSlave):
    """Slider and coupler motion from the crank motion.

    The crank pivots at the origin; the slider moves along a line parallel to +x at height
    ``offset``; slider_position is the x of the slider pin B. Angles counter-clockwise from
    +x, coupler angle of A -> B, reported in (-pi, pi].
    """

    description = (
        "Offset slider-crank: crank motion in, slider and coupler motion out; "
        "closed form or the planar constraint solver"
    )
    DRIVE_INPUTS = _CRANK
    VARIABLES = (
        non_negative("crank_length", DEFAULT.crank, "a: crank pivot -> crank pin A", "m"),
        non_negative("coupler_length", DEFAULT.coupler, "b: connecting rod A -> slider pin B", "m"),
        parameter(
            "offset", DEFAULT.offset, "Height of the slider axis above the crank pivot", unit="m"
        ),
        parameter(
            "circuit",
            0,
            "0: slider on the +x side of the crank pin (cos theta3 > 0); "
            "1: mirror branch on the -x side",
            min=0,
            max=1,
        ),
        *solver_variables("closed_form"),
        *crank_inputs(),
        *motion_outputs(
            _SLIDER, "m", "x of the slider pin B along its axis, from the crank pivot", _CRANK
        ),
        *motion_outputs(
            _COUPLER,
            "rad",
            ("theta3: angle of the connecting rod A -> B", "omega3", "alpha3"),
            _CRANK,
        ),
        *geometry_effect(
            "origin at the crank pivot, +x along the slider's line (which runs at y = "
            "offset), +y counter-clockwise from it",
            {
                "crank_pivot": "the crank's ground pivot (the origin)",
                "crank_pin": "A, the crank-rod joint",
                "slider_pin": "B, the rod-slider joint (slider_position, offset)",
            },
            depends=_CRANK[:1],
        ),
        *FORCE_VARIABLES,
    )
    EFFECT_OUTPUTS = {fv.FORCES: fv.outputs_of(FORCE_VARIABLES)}

    def _geometry(self) -> tuple[float, float, float]:
        v = self.values
        return v["crank_length"], v["coupler_length"], v["offset"]

    def check_geometry(self) -> Any:
        self.geometry = sc.check_slider_crank(*self._geometry())
        if self.values["circuit"] not in sc.CIRCUITS:
            raise RangeError("circuit", self.values["circuit"], "{0, 1}")
        self.forces = self.force_analysis()

    def force_analysis(self) -> "lf.SliderCrankForces | None":
        """The forces effect's analysis from the parameters, or None with the effect off."""
        v = self.values
        # every parameter of the effect checked with it off too: a negative mass is refused
        gravity = fv.gravity_setting(v)
        counterweight = link_forces.mass_layout(
            "counterweight", v["counterweight_mass"], 0.0, 0.0, 0.0
        ).mass
        radius = require_finite("counterweight_radius", v["counterweight_radius"], "m")
        if radius < 0.0:
            raise RangeError("counterweight_radius", radius, "[0, inf)", "m", "a distance")
        crank = link_forces.with_point_mass(fv.link_layout(v, "crank"), counterweight, -radius, 0.0)
        slider = link_forces.mass_layout("slider", v["slider_mass"], 0.0, 0.0, 0.0)
        coupler, point = fv.link_layout(v, "coupler"), fv.coupler_point(v)
        if not v[fv.FORCES]:
            return None
        return lf.SliderCrankForces(
            self.geometry,
            int(v["circuit"]),
            [crank, coupler, slider],
            gravity,
            point,
            v["singularity_threshold"],
        )

    def closed_form(self, time: float) -> Any:
        # the lengths and circuit validated once (check_geometry), the inputs by the step
        motion = sc.checked_motion(
            self.geometry, int(self.values["circuit"]), *self.driver_inputs()
        )
        return motion._asdict()

    def mechanism(self) -> Any:
        return constraint_models.slider_crank(*self._geometry())

    def guess(self, time: float) -> Any:
        angle = self.driver_inputs()[0]
        coupler, slider = sc.position(*self._geometry(), angle, self.values["circuit"])
        crank, _, offset = self._geometry()
        return constraint_models.slider_crank_guess(crank, offset, angle, coupler, slider)

    def from_solution(self, solution: Any, time: float) -> Any:
        q, qdot, qddot = solution.q, solution.qdot, solution.qddot
        return {
            "slider_position": q[6],
            "slider_speed": qdot[6],
            "slider_acceleration": qddot[6],
            "coupler_angle": constraint_models.wrap_angle(q[5]),
            "coupler_angular_velocity": qdot[5],
            "coupler_angular_acceleration": qddot[5],
        }

    def geometry_points(self) -> dict[str, float]:
        v = self.values
        return joint_positions.flattened(
            joint_positions.slider_crank_points(
                v["crank_length"], v["offset"], v["crank_angle"], v["slider_position"]
            )
        )
