"""LandingGear.fmu: kinematic (piston motion in) or dynamic (piston force or valve in)."""

import math

from ..fmi.geometry import geometry_effect
from ..fmi.integrating import IntegratingSlave
from ..fmi.slave import Status, effect, input_, integrator_variables
from ..fmi.slave import non_negative, output, parameter
from ..physics import gear_dynamics as gd
from ..physics import gear_forces
from ..physics import hydraulics
from ..physics import joint_positions
from ..physics import landing_gear as gear
from ..errors import MechanismError, require_finite
from ..physics.landing_gear import (
    COURSEWORK_BAR_LENGTH,
    COURSEWORK_EXTENDED_LENGTH,
    COURSEWORK_RETRACTED_LENGTH,
    DEFAULT_GEOMETRY,
)
from .force_variables import outputs_of
from .hydraulic_actuator import HYDRAULIC_PARAMETERS
from typing import Any

_PISTON = ("piston_extension", "piston_speed", "piston_acceleration")
_FORCES = ("piston_force", "airspeed")
DRIVES = ("motion", "dynamics")
_MOMENT_EFFECTS = ("gravity", "aero_drag", "pivot_friction")
_FORCE_DRIVE = ("piston_force", "valve_command")  # the dynamics drive's own inputs


_REACTIONS = _PISTON + _FORCES
# The forces effect's variables: the reactions on the airframe side and the input power.
FORCE_VARIABLES = (
    effect(
        "forces",
        "reactions at the bar pivot B and at the actuator's anchor on the airframe "
        "(airframe axes: origin B, x forward, y up), input power of the piston",
    ),
    *(
        output(
            f"{joint}_force_{part}",
            0.0,
            f"forces: {what}, {part} (airframe axes)",
            unit="N",
            depends=_REACTIONS,
            min=0.0 if part == "magnitude" else None,
        )
        for joint, what in (
            ("pivot", "force of the airframe on the bar at the pivot B"),
            ("anchor", "force of the airframe on the actuator at its fixed pivot"),
        )
        for part in ("x", "y", "magnitude")
    ),
    output(
        "piston_power",
        0.0,
        "forces: power the piston delivers, drive force times piston rate (motion drive: "
        "the required force)",
        unit="W",
        depends=_REACTIONS,
    ),
)


class LandingGear(IntegratingSlave):
    """Nose landing gear about its pivot B.

    drive = motion: the piston motion is prescribed (inputs piston_extension, piston_speed,
    piston_acceleration) and the gear motion follows from the closed forms; with inertia,
    gravity, aero_drag or pivot_friction on, ``piston_force_required`` is the force that
    makes the piston follow that motion (inverse dynamics).
    drive = dynamics: the gear angle is integrated from the moments about B (inertia must be
    on); the piston force is the input ``piston_force``, or, with the hydraulics effect, the
    force of the built-in actuator driven by ``valve_command``.
    """

    description = (
        "Retractable nose landing gear: kinematic (piston motion in, closed forms) "
        "or dynamic (piston force or valve command in) with selectable effects"
    )
    VARIABLES = (
        non_negative(
            "attachment_distance",
            DEFAULT_GEOMETRY.attachment_distance,
            "d: distance from the bar pivot B to the piston attachment on the bar",
            "m",
        ),
        non_negative(
            "pivot_height",
            DEFAULT_GEOMETRY.pivot_height,
            "h: distance from the bar pivot B to the piston's fixed pivot",
            "m",
        ),
        non_negative(
            "bar_length",
            COURSEWORK_BAR_LENGTH,
            "Length of bar AB from pivot B to the wheel axle A",
            "m",
        ),
        parameter(
            "drive",
            "motion",
            "motion: prescribed piston motion (kinematics); "
            "dynamics: integrate the gear from the piston force",
            values=DRIVES,
        ),
        effect(
            "inertia",
            "bar and wheel inertia about B (needed by the dynamics drive; in the "
            "motion drive adds I alpha to the required piston force)",
        ),
        effect("gravity", "weight of bar and wheel, airframe pitched by airframe_pitch"),
        effect("aero_drag", "aerodynamic drag on the wheel from the input airspeed"),
        effect("pivot_friction", "viscous and smoothed Coulomb friction at B"),
        effect(
            "end_stops",
            "stiff contacts with restitution at the piston stroke limits (dynamics drive)",
        ),
        effect(
            "hydraulics",
            "built-in hydraulic actuator driven by valve_command (dynamics "
            "drive): supply pressure, valve, flow limit, fluid compressibility",
        ),
        non_negative("bar_mass", gd.DEFAULT_BAR_MASS, "Mass of bar and strut (uniform)", "kg"),
        non_negative("wheel_mass", gd.DEFAULT_WHEEL_MASS, "Mass of wheel and tyre at A", "kg"),
        parameter(
            "down_angle",
            DEFAULT_GEOMETRY.start_angle,
            "Gear angle at which the bar hangs vertically (airframe level)",
            unit="rad",
        ),
        parameter("airframe_pitch", 0.0, "Nose-up pitch of the airframe", unit="rad"),
        non_negative("gravity_acceleration", gd.STANDARD_GRAVITY, "g", "m/s2"),
        non_negative("air_density", gd.DEFAULT_AIR_DENSITY, "rho", "kg/m3"),
        non_negative("drag_area", gd.DEFAULT_DRAG_AREA, "Cd times frontal area of the wheel", "m2"),
        non_negative(
            "viscous_friction",
            gd.DEFAULT_VISCOUS_FRICTION,
            "Viscous friction coefficient at B",
            "N.m.s/rad",
        ),
        non_negative(
            "coulomb_friction", gd.DEFAULT_COULOMB_FRICTION, "Coulomb friction moment at B", "N.m"
        ),
        non_negative(
            "friction_speed",
            gd.DEFAULT_FRICTION_SPEED,
            "Angular speed over which the Coulomb friction is smoothed (tanh)",
            "rad/s",
        ),
        non_negative(
            "stroke_min",
            COURSEWORK_RETRACTED_LENGTH,
            "Shortest piston length (stop; gear down)",
            "m",
        ),
        non_negative(
            "stroke_max", COURSEWORK_EXTENDED_LENGTH, "Longest piston length (stop; gear up)", "m"
        ),
        non_negative(
            "stop_stiffness",
            gd.DEFAULT_STOP_STIFFNESS,
            "End-stop contact stiffness on the piston length",
            "N/m",
        ),
        parameter(
            "restitution",
            gd.DEFAULT_RESTITUTION,
            "End-stop coefficient of restitution",
            unit="1",
            min=0.0,
            max=1.0,
        ),
        *HYDRAULIC_PARAMETERS,
        parameter(
            "initial_angle",
            DEFAULT_GEOMETRY.start_angle,
            "Gear angle at the start (dynamics drive)",
            unit="rad",
        ),
        parameter(
            "initial_angular_velocity",
            0.0,
            "Angular velocity at the start (dynamics drive)",
            unit="rad/s",
        ),
        non_negative(
            "initial_pressure",
            hydraulics.DEFAULT_RETURN_PRESSURE,
            "Pressure in both chambers at the start (hydraulics)",
            "Pa",
        ),
        *integrator_variables(default="dopri5"),
        input_(
            "piston_extension",
            COURSEWORK_RETRACTED_LENGTH,
            "x: piston length between its two pivots, within [|h - d|, h + d] (motion drive)",
            unit="m",
            min=0.0,
        ),
        input_("piston_speed", 0.0, "dx/dt (motion drive)", unit="m/s"),
        input_("piston_acceleration", 0.0, "d2x/dt2 (motion drive)", unit="m/s2"),
        input_(
            "piston_force",
            0.0,
            "Force along the piston, positive extending (dynamics drive without hydraulics)",
            unit="N",
        ),
        input_(
            "valve_command",
            0.0,
            "Valve opening in [-1, 1], positive extends the piston "
            "(dynamics drive with hydraulics)",
            unit="1",
            min=-1.0,
            max=1.0,
        ),
        input_("airspeed", 0.0, "Airspeed for the drag on the wheel (aero_drag)", unit="m/s"),
        output(
            "gear_angle",
            0.0,
            "theta: angle at B between the bar and the line to the piston's fixed pivot",
            unit="rad",
            depends=_PISTON[:1],
            min=0.0,
            max=math.pi,
        ),
        output(
            "gear_angular_velocity", 0.0, "omega = d(theta)/dt", unit="rad/s", depends=_PISTON[:2]
        ),
        output(
            "gear_angular_acceleration",
            0.0,
            "alpha = d(omega)/dt",
            unit="rad/s2",
            depends=_PISTON + _FORCES,
        ),
        output(
            "piston_moment_arm",
            0.0,
            "Moment arm of the piston force about B: d h sin(theta) / x",
            unit="m",
            depends=_PISTON[:1],
            min=0.0,
        ),
        output(
            "wheel_speed",
            0.0,
            "Speed of the wheel axle A: bar_length * omega",
            unit="m/s",
            depends=_PISTON[:2],
        ),
        output(
            "piston_length",
            0.0,
            "Piston length (equals piston_extension in the motion "
            "drive; integrated in the dynamics drive)",
            unit="m",
            depends=_PISTON[:1],
        ),
        output("piston_rate", 0.0, "Piston length rate", unit="m/s", depends=_PISTON[:2]),
        output(
            "piston_force_required",
            0.0,
            "Motion drive: piston force that produces the "
            "prescribed motion against the enabled effects (inverse dynamics)",
            unit="N",
            depends=_PISTON + ("airspeed",),
        ),
        output(
            "piston_force_applied",
            0.0,
            "Dynamics drive: piston force acting on the gear "
            "(input or hydraulic), without the end-stop force",
            unit="N",
            depends=("piston_force",),
        ),
        output("cap_pressure", 0.0, "Hydraulics: cap-side chamber pressure", unit="Pa"),
        output("rod_pressure", 0.0, "Hydraulics: rod-side chamber pressure", unit="Pa"),
        output(
            "kinetic_energy", 0.0, "1/2 I_B omega^2 (inertia on)", unit="J", depends=_PISTON[:2]
        ),
        output(
            "potential_energy",
            0.0,
            "Gravity potential relative to the bar hanging vertically (gravity on)",
            unit="J",
            depends=_PISTON[:1],
        ),
        output(
            "piston_work",
            0.0,
            "Dynamics drive: work done on the gear by the piston force since the start",
            unit="J",
        ),
        output(
            "retraction_time",
            -1.0,
            "Time the piston first reached stroke_max (gear up); -1 until then (dynamics drive)",
            unit="s",
        ),
        output(
            "extension_time",
            -1.0,
            "Time the piston first reached stroke_min (gear "
            "down) moving inwards; -1 until then (dynamics drive)",
            unit="s",
        ),
        output("stop_contacts", 0, "End-stop contacts started so far"),
        *geometry_effect(
            "earth axes at the bar pivot B: +x forward (horizontal), +y up; the airframe "
            "(and with it the piston's fixed pivot) pitched nose-up by airframe_pitch; the "
            "bar hangs straight down at gear_angle = down_angle - airframe_pitch",
            {
                "bar_pivot": "B, the bar's pivot on the airframe (the origin)",
                "piston_pivot": "the piston's fixed pivot on the airframe, h from B",
                "piston_attachment": "the piston's joint on the bar, d from B",
                "wheel_axle": "A, the wheel's axle at the bar's end, bar_length from B",
            },
            depends=_PISTON[:1],
        ),
        *FORCE_VARIABLES,
    )
    EFFECT_OUTPUTS = {"forces": outputs_of(FORCE_VARIABLES)}

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.ignored_inputs: tuple[str, ...] = ()  # inputs of the other driver last warned about
        self.model: Any = None  # gear_dynamics.Dynamics or InverseDynamics
        self.forces: Any = None  # gear_forces.GearForces with the forces effect on

    # --- set-up (IntegratingSlave: the dynamics drive integrates [theta, omega, work(, p1,
    # p2)]; the motion drive computes closed forms) ----------------------------------------
    def set_up(self) -> bool:
        v = self.values
        d, h = gear.check_geometry(v["attachment_distance"], v["pivot_height"])
        body = gd.make_body(v["bar_length"], v["bar_mass"], v["wheel_mass"])
        geometry = gd.Geometry(
            d,
            h,
            require_finite("down_angle", v["down_angle"], "rad"),
            require_finite("airframe_pitch", v["airframe_pitch"], "rad"),
        )
        if v["drive"] not in DRIVES:
            raise MechanismError(f"drive = {v['drive']!r} is not one of {', '.join(DRIVES)}")
        self.forces = gear_forces.GearForces(v, body, geometry) if v["forces"] else None
        if v["drive"] == "dynamics":
            if not v["inertia"]:
                raise MechanismError(
                    "drive = 'dynamics' needs the inertia effect: without "
                    "inertia the gear has no equation of motion"
                )
            self.model = gd.Dynamics(v, body, geometry)
            return True
        self.model = gd.InverseDynamics(v, body, geometry)
        return False

    def initial_state(self, time: float) -> list[float]:
        return self.model.initial_state()

    def _note_other_driver(self, time: float) -> None:
        """Warn when an input of the driver that ``drive`` did not choose is set.

        ``drive`` chooses the driver and takes precedence: the piston motion (motion) or the
        piston force or valve command (dynamics). An input of the other driver that differs
        from its start value is ignored; a warning names both drivers and the ignored
        inputs when they first appear (again after they change), so the precedence is never
        silent. (Refusing such steps instead made every step of a generic host that sets
        all inputs, such as mechfmu fuzz, fail.)
        """
        v = self.values
        if v["drive"] == "dynamics":
            given = [name for name in _PISTON if v[name] != _STARTS[name]]
            used = "the piston force (piston_force, or valve_command with the hydraulics effect)"
            other = "motion"
        else:
            given = [name for name in _FORCE_DRIVE if v[name] != _STARTS[name]]
            used = "the piston motion (piston_extension, piston_speed, piston_acceleration)"
            other = "dynamics"
        if given and tuple(given) != self.ignored_inputs:
            values = ", ".join(f"{name} = {v[name]!r} {_UNITS[name]}".rstrip() for name in given)
            starts = ", ".join(f"{name} = {_STARTS[name]!r}" for name in given)
            plural = len(given) > 1
            self.log(
                f"{self.instance_name} at t = {time!r} s: both drivers given: "
                f"drive = {v['drive']!r} moves the gear by {used} and takes precedence; "
                f"the {other} drive's input{'s' if plural else ''} {values} "
                f"{'are' if plural else 'is'} ignored (leave "
                f"{'them at their start values' if plural else 'it at its start value'} "
                f"({starts}) or choose drive = {other!r})",
                Status.warning,
            )
        self.ignored_inputs = tuple(given)

    def extra_state(self) -> dict[str, list[Any]]:
        return {"ignored_inputs": list(self.ignored_inputs)}

    def restore_extra_state(self, saved: Any) -> None:
        self.ignored_inputs = tuple(saved["ignored_inputs"])

    # --- stepping -----------------------------------------------------------------------
    def update(self, time: float, step_size: float) -> None:
        self._note_other_driver(time)
        super().update(time, step_size)

    def advance(
        self, start: float, time: float, inputs: tuple[()]
    ) -> tuple[list[float], list[Any]]:
        """Dynamics drive: (state at ``time``, stroke limits crossed); the inputs
        piston_force, valve_command and airspeed are held over the step."""
        return self.model.advance(self.integrator, start, self.state, time, self.values)

    def commit(self, time: float, crossings: list[Any]) -> None:
        """Retraction and extension times, stop contacts and a log line per stroke limit
        reached: (event name, t s, piston length m) from Dynamics.advance."""
        v = self.values
        for name, when, length in crossings:
            if name == "stroke_max" and v["retraction_time"] < 0.0:
                v["retraction_time"] = when
            if name == "stroke_min" and v["extension_time"] < 0.0:
                v["extension_time"] = when
            if self.model.stops:
                v["stop_contacts"] += 1
            self.log(
                f"{self.instance_name} at t = {when!r} s: piston reached {name} ({length!r} m)",
                Status.ok,
            )

    def publish(self, time: float) -> None:
        v = self.values
        self.model.publish(v, time, self.state)
        if self.forces is not None:
            on_bar = self.model.piston_force_on_bar(self.state, v)
            v.update(
                self.forces.reactions(
                    v["gear_angle"],
                    v["gear_angular_velocity"],
                    v["gear_angular_acceleration"],
                    on_bar,
                    v["airspeed"],
                )
            )
            v["piston_power"] = v["piston_force_applied"] * v["piston_rate"]

    def update_without_state(self, time: float, step_size: float) -> None:
        """Motion drive: the outputs from the prescribed piston motion (closed forms)."""
        v = self.values
        d, h = v["attachment_distance"], v["pivot_height"]
        motion, arm = gear.gear_motion_and_moment_arm(
            v["piston_extension"], v["piston_speed"], v["piston_acceleration"], d, h
        )
        v["gear_angle"], v["gear_angular_velocity"], v["gear_angular_acceleration"] = motion
        v["piston_moment_arm"] = arm
        v["wheel_speed"] = v["bar_length"] * motion.angular_velocity
        v["piston_length"], v["piston_rate"] = v["piston_extension"], v["piston_speed"]
        self.model.publish(v, motion)
        if self.forces is not None:
            gear_forces.check_moment_arm(
                arm, self.forces.geometry, motion.angle, v["piston_length"]
            )
            force = v["piston_force_required"]
            v.update(self.forces.reactions(*motion, force, v["airspeed"]))
            v["piston_power"] = force * v["piston_speed"]

    def geometry_points(self) -> dict[str, float]:
        v = self.values
        return joint_positions.flattened(
            joint_positions.gear_points(
                v["attachment_distance"],
                v["pivot_height"],
                v["bar_length"],
                v["gear_angle"],
                v["down_angle"],
                v["airframe_pitch"],
            )
        )


# Start values and units of the inputs, for the other-driver warning.
_STARTS = {v.name: v.start for v in LandingGear.VARIABLES if v.causality == "input"}
_UNITS = {
    v.name: "" if v.unit in (None, "1") else v.unit
    for v in LandingGear.VARIABLES
    if v.causality == "input"
}
