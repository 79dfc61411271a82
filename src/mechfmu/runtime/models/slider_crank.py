"""SliderCrank.fmu: the offset slider-crank driven by its crank (closed form or solver)."""

from typing import Any
from ..fmi.slave import input_, output, parameter
from ..physics import constraint_models
from ..physics import slider_crank as sc
from ..errors import RangeError
from .linkage import LinkageSlave, solver_variables

_CRANK = ("crank_angle", "crank_speed", "crank_acceleration")
DEFAULT = sc.DEFAULT_SLIDER_CRANK


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
        parameter(
            "crank_length", DEFAULT.crank, "a: crank pivot -> crank pin A", unit="m", min=0.0
        ),
        parameter(
            "coupler_length",
            DEFAULT.coupler,
            "b: connecting rod A -> slider pin B",
            unit="m",
            min=0.0,
        ),
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
        input_("crank_angle", 0.0, "theta2: crank angle", unit="rad"),
        input_("crank_speed", 0.0, "omega2 = d(theta2)/dt", unit="rad/s"),
        input_("crank_acceleration", 0.0, "alpha2 = d(omega2)/dt", unit="rad/s2"),
        output(
            "slider_position",
            0.0,
            "x of the slider pin B along the slider axis, from the crank pivot",
            unit="m",
            depends=_CRANK[:1],
        ),
        output("slider_speed", 0.0, "d(slider_position)/dt", unit="m/s", depends=_CRANK[:2]),
        output("slider_acceleration", 0.0, "d(slider_speed)/dt", unit="m/s2", depends=_CRANK),
        output(
            "coupler_angle",
            0.0,
            "theta3: angle of the connecting rod A -> B",
            unit="rad",
            depends=_CRANK[:1],
        ),
        output("coupler_angular_velocity", 0.0, "omega3", unit="rad/s", depends=_CRANK[:2]),
        output("coupler_angular_acceleration", 0.0, "alpha3", unit="rad/s2", depends=_CRANK),
    )

    def _geometry(self) -> tuple[float, float, float]:
        v = self.values
        return v["crank_length"], v["coupler_length"], v["offset"]

    def check_geometry(self) -> Any:
        self.geometry = sc.check_slider_crank(*self._geometry())
        if self.values["circuit"] not in sc.CIRCUITS:
            raise RangeError("circuit", self.values["circuit"], "{0, 1}")

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
