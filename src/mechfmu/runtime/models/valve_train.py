"""ValveTrain.fmu: the coursework's cam-driven rocker-arm valve train on the constraint solver."""

from typing import Any
import math

from ..fmi.geometry import geometry_effect, geometry_output
from ..fmi.slave import (
    non_negative,
    Status,
    effect,
    motion_inputs,
    motion_outputs,
    output,
    parameter,
)
from ..physics import cam_geometry, cam_laws, constraint_models, joint_positions
from ..physics import valve_forces
from ..physics.link_forces import mass_layout
from ..physics import valve_train as vt
from ..errors import MechanismError, RangeError
from . import force_variables as fv
from .linkage import LinkageSlave, solver_variables
from ..fmi.declarations import Variable

_CAM = CAMSHAFT_INPUTS = ("camshaft_angle", "camshaft_speed", "camshaft_acceleration")
CAMSHAFT_DESCRIPTIONS = (
    "Camshaft angle",
    "Camshaft angular speed",
    "Camshaft angular acceleration",
)
_TAPPET = ("tappet_lift", "tappet_velocity", "tappet_acceleration")
_ROCKER = ("rocker_angle", "rocker_angular_velocity", "rocker_angular_acceleration")
_VALVE = ("valve_lift", "valve_velocity", "valve_acceleration")
_MOTION_NAMES = vt.ValveTrainMotion._fields  # the outputs of the closed form, in its order
MODES = ("forward", "inverse")
# positions in the solver's coordinates (x, y, phi per body)
_TAPPET_Y = 3 * constraint_models.TAPPET + 1
_ROCKER_PHI = 3 * constraint_models.ROCKER + 2
_VALVE_Y = 3 * constraint_models.VALVE + 1
GEOMETRY = vt.DEFAULT_VALVE_GEOMETRY
CAM = cam_laws.DEFAULT_CAM_PROFILE

_GEOMETRY_DESCRIPTIONS = {
    "cam_base_radius": "Cam base (prime) circle radius: tappet foot height at zero lift above "
    "the camshaft centre",
    "pushrod_length": "Pushrod length from the tappet foot P to the rocker's tappet end T",
    "rocker_pivot_x": "Rocker pivot x (right of the tappet axis)",
    "rocker_pivot_y": "Rocker pivot y (above the camshaft centre)",
    "tappet_arm": "Rocker arm from the pivot to the pushrod end T",
    "valve_arm": "Rocker arm from the pivot to the valve link end V",
    "valve_axis_x": "x of the valve axis (the valve foot Q slides on it)",
    "valve_link_length": "Valve link length from V down to the valve foot Q",
}


# The valve train's joints (physics/joint_positions.py), shared by ValveTrain and ValveSpring.
VALVE_TRAIN_FRAME = (
    "origin at the camshaft centre of a flat-faced tappet without offset, +x right, +y up "
    "(valve_train.py's frame)"
)
VALVE_TRAIN_POINTS = {
    "cam_centre": "the camshaft centre: the origin, or under a roller or an offset follower "
    "(cam_geometry's follower parameters) where the cam holds it at the tappet foot",
    "tappet_foot": "P, the tappet's flat face on the cam, on the tappet axis x = 0",
    "rocker_fulcrum": "the rocker's pivot on the block (rocker_pivot_x, rocker_pivot_y)",
    "pushrod_end": "T, the pushrod-rocker joint",
    "valve_end": "V, the rocker-valve link joint",
}


def cam_angle_output(depends: tuple[str, ...]) -> Variable:
    """The geometry output of the cam's angle (rad): the camshaft angle it turns by,
    counter-clockwise, from the angle 0 of its cam law."""
    return geometry_output(
        "cam_angle",
        "the cam's angle, counter-clockwise: the camshaft angle of its cam law",
        unit="rad",
        depends=depends,
    )


def geometry_variables() -> tuple:
    """The rocker geometry's parameters (ValveGeometry's fields, m), declared once for
    ValveTrain and ValveSpring's camshaft drive."""
    return tuple(
        parameter(
            name,
            value,
            _GEOMETRY_DESCRIPTIONS[name],
            unit="m",
            min=None if name.startswith("rocker_pivot") or name == "valve_axis_x" else 0.0,
        )
        for name, value in GEOMETRY._asdict().items()
    )


def cam_law_variables() -> tuple:
    """The cam law's parameters (CamProfile's fields), declared once for ValveTrain and
    ValveSpring's camshaft drive."""
    return (
        parameter(
            "cam_law",
            CAM.law,
            "Follower law of rise and return: " + ", ".join(cam_laws.CAM_LAWS),
            values=cam_laws.CAM_LAWS,
        ),
        non_negative(
            "lift",
            CAM.lift,
            "Peak lift of the cam law: tappet lift (forward) or valve lift (inverse)",
            "m",
        ),
        parameter("rise_start", CAM.rise_start, "Camshaft angle where the rise starts", unit="rad"),
        non_negative("rise_angle", CAM.rise_angle, "Camshaft angle of the rise", "rad"),
        non_negative(
            "high_dwell_angle",
            CAM.high_dwell_angle,
            "Camshaft angle of the dwell at full lift",
            "rad",
        ),
        non_negative(
            "return_angle",
            CAM.return_angle,
            "Camshaft angle of the return; the low dwell fills the rest of the revolution",
            "rad",
        ),
    )


def follower_variables() -> tuple:
    """The cam follower's parameters of the cam_geometry effect (ValveTrain)."""
    return (
        parameter(
            "follower",
            "flat_faced",
            "cam_geometry: the follower on the cam: flat_faced (the pushrod tappet; a face "
            "perpendicular to its axis) or roller (a roller of roller_radius on the axis)",
            values=cam_geometry.FOLLOWERS,
        ),
        non_negative(
            "roller_radius", 0.008, "cam_geometry: roller radius Rf (follower = roller)", "m"
        ),
        parameter(
            "follower_offset",
            0.0,
            "cam_geometry: offset e of the follower's axis from the camshaft centre, along +x "
            "(positive: lowers the roller's pressure angle while it rises, the camshaft "
            "turning counter-clockwise)",
            unit="m",
        ),
        parameter(
            "pressure_angle_limit",
            cam_geometry.DEFAULT_PRESSURE_ANGLE_LIMIT,
            "cam_geometry: largest pressure angle the design accepts (Norton: about 30 deg "
            "for a translating roller); beyond it a warning at initialisation",
            unit="rad",
            min=0.0,
            max=math.pi / 2.0,
        ),
    )


_CAM_OUTPUTS = (
    (
        "pressure_angle",
        "rad",
        "Pressure angle: between the follower's axis and the normal at the contact (0 for a flat face)",
    ),
    (
        "radius_of_curvature",
        "m",
        "Radius of curvature of the cam surface at the contact (negative: concave)",
    ),
    (
        "pitch_radius_of_curvature",
        "m",
        "Radius of curvature of the pitch curve, the trace point's path (roller centre; flat face: the face on the axis)",
    ),
    (
        "cam_contact_x",
        "m",
        "Contact point on the cam surface, x in the cam's frame (equal to the fixed frame at camshaft angle 0)",
    ),
    ("cam_contact_y", "m", "Contact point on the cam surface, y in the cam's frame"),
    (
        "face_contact_position",
        "m",
        "Where the contact lies on a flat face, from the follower's axis along +x: ds/dtheta - e (0 for a roller)",
    ),
)


# The forces effect's variables (force_variables): pushrod and rocker masses, gravity, the
# cam's push, each joint's force, the camshaft torque with the links' inertia.
FORCE_VARIABLES = (
    fv.forces_effect(
        "the cam's push on the tappet, the pushrod, rocker pivot, valve link and guide forces, "
        "the camshaft torque and input power with the pushrod's and rocker's inertia (and the "
        "valve's mass and spring with valve_spring)"
    ),
    *fv.gravity_variables(),
    *fv.link_mass_variables(
        "pushrod", valve_forces.DEFAULT_PUSHROD, "tappet and pushrod", "P -> T"
    ),
    *fv.link_mass_variables(
        "rocker", valve_forces.DEFAULT_ROCKER, "rocker", "the pivot -> the valve arm"
    ),
    output(
        "cam_force",
        0.0,
        "forces: the cam's push on the tappet along the follower's axis (roller: the "
        "normal force's axial part; the guide carries the rest)",
        unit="N",
        depends=_CAM,
    ),
    output(
        "cam_torque",
        0.0,
        "forces: torque the camshaft supplies to this cam, cam_force ds/dtheta (with the "
        "pushrod's and rocker's inertia; camshaft_torque when they are massless)",
        unit="N.m",
        depends=_CAM,
    ),
    output(
        "input_power",
        0.0,
        "forces: power the cam delivers, cam_force times the tappet velocity",
        unit="W",
        depends=_CAM,
    ),
    *fv.joint_force_outputs("tappet_guide", "tappet guide on tappet at P", _CAM),
    *fv.joint_force_outputs("pushrod", "rocker on pushrod at T", _CAM),
    *fv.joint_force_outputs("rocker_pivot", "cylinder head on rocker at its pivot", _CAM),
    *fv.joint_force_outputs("valve_link", "rocker on valve link at V", _CAM),
    *fv.joint_force_outputs("valve_guide", "valve guide on valve at Q", _CAM),
)


def cam_setup(values: dict) -> tuple:
    """(ValveGeometry, CamProfile) validated from the parameter values of geometry_variables
    and cam_law_variables (RangeError names the parameter)."""
    geometry = vt.check_geometry(
        vt.ValveGeometry(*(values[name] for name in vt.ValveGeometry._fields))
    )
    profile = cam_laws.check_profile(
        values["cam_law"],
        values["lift"],
        values["rise_start"],
        values["rise_angle"],
        values["high_dwell_angle"],
        values["return_angle"],
    )
    return geometry, profile


def valve_train_geometry_effect() -> tuple:
    """ValveTrain's geometry effect: the joints and the valve foot Q (the valve)."""
    return geometry_effect(
        VALVE_TRAIN_FRAME,
        {
            **VALVE_TRAIN_POINTS,
            "valve_foot": "Q, the valve (link foot) on the valve axis x = valve_axis_x",
        },
        depends=_CAM[:1],
        extra=(cam_angle_output(_CAM[:1]),),
    )


class ValveTrain(LinkageSlave):
    """Tappet, rocker and valve motion from the camshaft motion and a cam law.

    mode = forward: the cam law is the tappet lift (the cam's displacement diagram) and the
    rocker and valve follow. mode = inverse: the cam law is the desired valve lift and the
    outputs give the tappet lift the cam must produce (the inverse problem of the coursework).
    With the valve_spring effect, the contact force between rocker and valve is
    m a + k lift + F0; where it would have to be negative the valve floats (leaves the
    rocker): reported as a warning (or, with stop_on_float, as an error).
    """

    description = (
        "Cam-driven pushrod valve train (tappet, rocker, valve) on the planar "
        "constraint solver: forward (cam law on the tappet) or inverse (desired "
        "valve motion in, cam displacement diagram out); valve spring, float and "
        "camshaft torque; the cam's geometry (profile, pressure angle, radius of curvature)"
    )
    VARIABLES = (
        *geometry_variables(),
        parameter(
            "mode",
            "forward",
            "forward: the cam law is the tappet lift; inverse: the "
            "cam law is the valve lift and the tappet lift is computed",
            values=MODES,
        ),
        *cam_law_variables(),
        *solver_variables("constraint_solver"),
        effect(
            "valve_spring",
            "valve mass, valve spring stiffness and preload: contact force "
            "between rocker and valve, valve float detection",
        ),
        non_negative(
            "valve_mass",
            0.1,
            "Moving mass at the valve: valve, retainer and a third of the spring",
            "kg",
        ),
        non_negative("spring_stiffness", 50e3, "Valve spring stiffness", "N/m"),
        non_negative("spring_preload", 300.0, "Valve spring force with the valve closed", "N"),
        parameter(
            "stop_on_float",
            False,
            "valve_spring: treat loss of contact as an error "
            "(the step is discarded) instead of a warning",
        ),
        *motion_inputs(_CAM, "rad", CAMSHAFT_DESCRIPTIONS),
        *motion_outputs(_TAPPET, "m", "Tappet lift above the cam base circle", _CAM),
        *motion_outputs(_ROCKER, "rad", "Rocker angle from +x (counter-clockwise)", _CAM),
        *motion_outputs(_VALVE, "m", "Valve opening (downward displacement from closed)", _CAM),
        output(
            "contact_force",
            0.0,
            "valve_spring: force the rocker must push on the valve, "
            "m a + k lift + F0 (negative: the valve floats)",
            unit="N",
            depends=_CAM,
        ),
        output(
            "contact_lost",
            False,
            "valve_spring: the required contact force is negative (valve float)",
            depends=_CAM,
        ),
        output("float_events", 0, "valve_spring: losses of contact so far"),
        output(
            "float_camshaft_speed",
            -1.0,
            "valve_spring: constant camshaft speed at which "
            "the valve starts to float with this cam and spring (-1: effect off)",
            unit="rad/s",
        ),
        output(
            "camshaft_torque",
            0.0,
            "valve_spring: torque the camshaft must supply to the cam, in its direction of "
            "rotation: contact_force dL/dtheta (frictionless; zero mean over a revolution at "
            "constant speed)",
            unit="N.m",
            depends=_CAM,
        ),
        effect(
            "cam_geometry",
            "the cam that produces the tappet motion (forward: the cam law; inverse: the "
            "tappet diagram the desired valve motion needs) with the follower below and the "
            "base circle cam_base_radius: pressure angle, radii of curvature and contact "
            "point at each step; a cusp or undercut refused at initialisation, a pressure "
            "angle over its limit warned",
        ),
        *follower_variables(),
        *(
            output(name, 0.0, "cam_geometry: " + text, unit=unit, depends=_CAM[:2])
            for name, unit, text in _CAM_OUTPUTS
        ),
        output(
            "min_radius_of_curvature",
            -1.0,
            "cam_geometry: least radius of curvature of the cam surface where it is convex, "
            "over a revolution (-1: effect off)",
            unit="m",
        ),
        output(
            "max_pressure_angle",
            -1.0,
            "cam_geometry: largest magnitude of the pressure angle over a revolution "
            "(-1: effect off)",
            unit="rad",
        ),
        output(
            "face_width",
            -1.0,
            "cam_geometry: width of flat face the contact sweeps over a revolution, "
            "max - min of ds/dtheta (0 for a roller, -1: effect off)",
            unit="m",
        ),
        *valve_train_geometry_effect(),
        *FORCE_VARIABLES,
    )
    # with valve_spring or cam_geometry off their outputs hold their start values (the
    # figures over a revolution are -1 then, set so by check_geometry): not checked per step
    EFFECT_OUTPUTS = {
        fv.FORCES: fv.outputs_of(FORCE_VARIABLES),
        "valve_spring": ("contact_force", "camshaft_torque", "float_camshaft_speed"),
        "cam_geometry": (
            *(name for name, _, _ in _CAM_OUTPUTS),
            "min_radius_of_curvature",
            "max_pressure_angle",
            "face_width",
        ),
    }

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.geometry = GEOMETRY
        self.profile = CAM
        self.motion = cam_laws.motion_function(CAM)  # follower_motion of self.profile
        self.closed_height = 0.0  # m, valve foot height with the valve closed
        self.cam_follower: Any = None  # cam_geometry.Follower with the cam_geometry effect
        self.drawn_cam_centre = (0.0, 0.0)  # m, the cam's centre (geometry effect)
        self.reported: set = set()  # design warnings logged (initialisation may run twice)

    # --- parameters -------------------------------------------------------------------
    def check_geometry(self) -> Any:
        v = self.values
        if v["mode"] not in MODES:
            raise RangeError("mode", v["mode"], "{" + ", ".join(MODES) + "}")
        self.geometry, self.profile = cam_setup(v)
        self.motion = cam_laws.motion_function(self.profile)
        self.closed_height = vt.rest_position(self.geometry)[1]
        v["float_camshaft_speed"] = -1.0
        if v["valve_spring"]:
            speed = vt.float_speed(
                self.geometry,
                self.profile,
                v["valve_mass"],
                v["spring_stiffness"],
                v["spring_preload"],
                valve_law=v["mode"] == "inverse",
            )
            v["float_camshaft_speed"] = (
                speed.camshaft_speed if math.isfinite(speed.camshaft_speed) else -1.0
            )
        self.cam_follower = None
        for name in ("min_radius_of_curvature", "max_pressure_angle", "face_width"):
            v[name] = -1.0
        if v["cam_geometry"]:
            self._design_cam()
        if v["geometry"]:  # where the cam sits under its follower (a roller, an offset)
            self.drawn_cam_centre = joint_positions.cam_centre(
                cam_geometry.check_follower(
                    v["follower"],
                    self.geometry.cam_base_radius,
                    v["roller_radius"],
                    v["follower_offset"],
                )
            )
        self.forces = self.force_analysis()

    def force_analysis(self) -> "valve_forces.ValveTrainForces | None":
        """The forces effect's analysis from the parameters, or None with the effect off."""
        v = self.values
        # every parameter of the effect checked with it off too: a negative mass is refused
        gravity = fv.gravity_setting(v)
        valve_mass = mass_layout("valve", v["valve_mass"], 0.0, 0.0, 0.0).mass
        pushrod = valve_forces.pushrod_frame(fv.link_layout(v, "pushrod"))
        rocker = fv.link_layout(v, "rocker")
        if not v[fv.FORCES]:
            return None
        spring = None
        if v["valve_spring"]:
            spring = valve_forces.ValveSpringLoad(
                valve_mass, v["spring_stiffness"], v["spring_preload"]
            )
        return valve_forces.ValveTrainForces(
            self.geometry, pushrod, rocker, spring, gravity, v["singularity_threshold"]
        )

    def _design_cam(self) -> None:
        """The cam_geometry effect at initialisation: the follower checked, the cam designed
        over a revolution (a cusp or an undercut refused: CamDesignError), its figures
        published and a pressure angle over the limit warned."""
        v = self.values
        self.cam_follower = cam_geometry.check_follower(
            v["follower"], self.geometry.cam_base_radius, v["roller_radius"], v["follower_offset"]
        )
        found = cam_geometry.require_design(
            self.cam_follower,
            cam_geometry.design(
                self.cam_follower,
                vt.tappet_pieces(self.geometry, self.profile, v["mode"]),
                v["pressure_angle_limit"],
            ),
        )
        v["min_radius_of_curvature"] = found.least_radius
        v["max_pressure_angle"] = abs(found.largest_pressure_angle)
        v["face_width"] = found.face_width
        for problem in found.problems:
            if problem.message not in self.reported:
                self.reported.add(problem.message)
                self.log(problem.message, Status.warning)

    # --- kinematics -------------------------------------------------------------------
    def _law(self):
        v = self.values
        return self.motion(v["camshaft_angle"], v["camshaft_speed"], v["camshaft_acceleration"])

    def closed_form(self, time: float) -> Any:
        law = self._law()
        if self.values["mode"] == "inverse":
            return vt.inverse(self.geometry, *law)._asdict()
        lift, velocity, acceleration = law
        if not math.isfinite(lift + velocity + acceleration):
            return vt.forward(self.geometry, *law)._asdict()  # its error, naming the value
        # forward's arithmetic without its checks (the law is finite) and the rest height
        # it would look up again (closed_height), as (name, value) pairs for _write: the
        # step's closed form in 2.5 us instead of 5
        return zip(
            _MOTION_NAMES,
            vt.motion_from_tappet(self.geometry, self.closed_height, *law),
        )

    def mechanism(self) -> Any:
        return constraint_models.valve_train(self.geometry, self.values["mode"] == "inverse")

    def guess(self, time: float) -> Any:
        return constraint_models.valve_train_guess(self.geometry)

    def drive(self, time: float) -> Any:
        v = self.values
        lift, velocity, acceleration = self.motion(
            v["camshaft_angle"], v["camshaft_speed"], v["camshaft_acceleration"]
        )
        if self.values["mode"] == "inverse":  # the valve foot moves down as the valve opens
            return [(self.closed_height - lift, -velocity, -acceleration)]
        return [(self.geometry.cam_base_radius + lift, velocity, acceleration)]

    def from_solution(self, solution: Any, time: float) -> Any:
        q, qdot, qddot = solution.q, solution.qdot, solution.qddot
        return {
            "tappet_lift": q[_TAPPET_Y] - self.geometry.cam_base_radius,
            "tappet_velocity": qdot[_TAPPET_Y],
            "tappet_acceleration": qddot[_TAPPET_Y],
            "rocker_angle": q[_ROCKER_PHI],
            "rocker_angular_velocity": qdot[_ROCKER_PHI],
            "rocker_angular_acceleration": qddot[_ROCKER_PHI],
            "valve_lift": self.closed_height - q[_VALVE_Y],
            "valve_velocity": -qdot[_VALVE_Y],
            "valve_acceleration": -qddot[_VALVE_Y],
        }

    def geometry_points(self) -> dict[str, float]:
        v = self.values
        points = joint_positions.flattened(
            joint_positions.valve_train_points(
                self.geometry,
                v["tappet_lift"],
                v["rocker_angle"],
                self.closed_height - v["valve_lift"],
                self.drawn_cam_centre,
            )
        )
        points["cam_angle"] = v["camshaft_angle"]
        return points

    # --- valve spring -----------------------------------------------------------------
    def tappet_diagram(self) -> tuple[float, float, float]:
        """(s m, s1 m/rad, s2 m/rad^2) of the tappet at the camshaft angle: the cam law
        (forward), or inverse's tappet motion for the valve law at unit speed (inverse)."""
        s, s1, s2, _ = cam_laws.cam_lift(self.profile, self.values["camshaft_angle"])
        if self.values["mode"] == "inverse":
            motion = vt.inverse(self.geometry, s, s1, s2)
            return motion.tappet_lift, motion.tappet_velocity, motion.tappet_acceleration
        return s, s1, s2

    def valve_lift_rate(self) -> float:
        """dL/dtheta (m/rad) at the camshaft angle: the cam law's (inverse), or the valve's
        through the rocker (forward)."""
        s, s1, _, _ = cam_laws.cam_lift(self.profile, self.values["camshaft_angle"])
        if self.values["mode"] == "inverse":
            return s1
        return vt.valve_lift_rate(self.geometry, self.closed_height, s, s1)

    def after_update(self, time: float) -> Any:
        v = self.values
        if self.forces is not None:
            lift_rate = self.tappet_diagram()[1]
            v.update(self.forces.analyse(v, self.closed_height, lift_rate))
        if v["cam_geometry"]:
            point = cam_geometry.cam_point(
                self.cam_follower, v["camshaft_angle"], *self.tappet_diagram()
            )
            (
                v["pressure_angle"],
                v["radius_of_curvature"],
                v["pitch_radius_of_curvature"],
                v["cam_contact_x"],
                v["cam_contact_y"],
                v["face_contact_position"],
            ) = (
                point.pressure_angle,
                point.radius_of_curvature,
                point.pitch_radius_of_curvature,
                point.x,
                point.y,
                point.face_contact,
            )
        if not v["valve_spring"]:
            return
        force = vt.contact_force(
            v["valve_mass"],
            v["spring_stiffness"],
            v["spring_preload"],
            v["valve_lift"],
            v["valve_acceleration"],
        )
        lost = vt.contact_lost(
            v["valve_mass"],
            v["spring_stiffness"],
            v["spring_preload"],
            v["valve_lift"],
            v["valve_acceleration"],
        )
        v["contact_force"] = force
        v["camshaft_torque"] = cam_geometry.camshaft_torque(force, self.valve_lift_rate())
        if lost and not v["contact_lost"]:
            v["float_events"] += 1
            message = (
                f"valve float at t = {time!r} s: the required contact force is "
                f"{force:.6g} N < 0 at camshaft angle {v['camshaft_angle']:.6g} rad, "
                f"camshaft speed {v['camshaft_speed']:.6g} rad/s; with this cam law "
                f"and spring the valve stays on the rocker only below "
                f"{v['float_camshaft_speed']:.6g} rad/s (constant speed)"
            )
            if v["stop_on_float"]:
                v["contact_lost"] = True
                raise MechanismError(message)
            self.log(message, Status.warning)
        elif not lost and v["contact_lost"]:
            self.log(
                f"valve contact restored at t = {time!r} s (contact force {force:.6g} N)",
                Status.warning,
            )
        v["contact_lost"] = lost
