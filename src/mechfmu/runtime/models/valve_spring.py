"""ValveSpring.fmu: the valve as a mass on its spring, driven by the rocker through a compliant
contact and stopped by a compliant seat, integrated inside each communication step."""

import math

from ..fmi.integrating import IntegratingSlave
from ..fmi.declarations import motion_inputs, motion_units, only_with
from ..fmi.geometry import geometry_effect
from ..fmi.slave import Status, integrator_variables, output, parameter
from ..physics import cam_geometry, cam_laws, joint_positions, valve_exact
from ..physics import valve_spring as vs
from ..physics import valve_train as vt
from ..errors import IntegrationError, MechanismError, RangeError, require_finite, require_positive
from ..numerics.stepping import advance_through_events
from ..physics.valve_spring import Happening
from .valve_train import CAMSHAFT_DESCRIPTIONS, CAMSHAFT_INPUTS, cam_law_variables, cam_setup
from .valve_train import VALVE_TRAIN_FRAME, VALVE_TRAIN_POINTS, cam_angle_output
from .valve_train import geometry_variables
from typing import Any

_INPUTS = ("rocker_lift", "rocker_velocity", "rocker_acceleration")
_UNITS = motion_units("m")
_CAMSHAFT = CAMSHAFT_INPUTS
_CAMSHAFT_UNITS = motion_units("rad")
# The inputs an output depends on directly, whichever drive feeds the rocker's valve end:
# its position (rocker lift, or camshaft angle), and its rate too.
_ON_POSITION = _INPUTS[:1] + _CAMSHAFT[:1]
_ON_POSITION_AND_RATE = _INPUTS[:2] + _CAMSHAFT[:2]
# Apart from the rocker's work the valve system is passive: T + V can grow by no more than
# the contact work W, over a step and over the run. A step that gains more than
# ENERGY_GROWTH times the energy in play (the sum of the magnitudes of the energy terms), or
# a run whose gains add up to more than ENERGY_GROWTH times the largest energy in play so
# far, is an unstable integration. Measured on the shipped scenes at steps 1e-5 .. 1e-3 s:
# dopri5, radau and rk4 within their stability limits create at most 5e-7 of it (summed over
# the run), explicit Euler at h omega = 0.03 (accurate only to a few per cent) 0.03; past
# the limits rk4 gains 40 % per sub-step and Euler at h omega = 0.33 creates 36 % to 97 %
# over a run while no single step gains 10 %.
ENERGY_GROWTH = 0.1


class ValveSpring(IntegratingSlave):
    """A valve on its spring, pushed open by the rocker's valve end (prescribed motion L(t),
    e.g. ValveTrain's kinematic valve lift) through a compliant contact, closed onto a
    compliant seat (physics/valve_spring.py). The valve's free flight is integrated: when
    the spring cannot hold the valve on the rocker it leaves it (float, a warning with the
    time and drive values, or with stop_on_float a refused step), and a valve that comes
    down without the rocker bounces on its seat (a warning per impact).
    """

    description = (
        "Valve dynamics: valve mass on its spring, driven by the rocker's valve end "
        "through a compliant contact (Kelvin-Voigt) and stopped by a compliant "
        "seat; integrated free flight, float and seat bounce"
    )
    VARIABLES = (
        parameter(
            "valve_mass",
            vs.DEFAULT_MASS,
            "m: moving mass at the valve: valve, "
            "retainer and a third of the spring (ValveTrain's default)",
            unit="kg",
            min=0.0,
        ),
        parameter(
            "spring_stiffness",
            vs.DEFAULT_SPRING_STIFFNESS,
            "k: valve spring stiffness (ValveTrain's default)",
            unit="N/m",
            min=0.0,
        ),
        parameter(
            "spring_preload",
            vs.DEFAULT_SPRING_PRELOAD,
            "F0: valve spring force with the valve closed (ValveTrain's default)",
            unit="N",
            min=0.0,
        ),
        parameter(
            "contact_stiffness",
            vs.DEFAULT_CONTACT_STIFFNESS,
            "k_c: stiffness of the "
            "rocker-valve contact, lumping the pushrod chain referred to the valve "
            "(pushrod valve trains: 1e6 .. 1e7 N/m; 1.6 kHz with the default mass)",
            unit="N/m",
            min=0.0,
        ),
        parameter(
            "contact_damping",
            vs.DEFAULT_CONTACT_DAMPING,
            "c_c: damping of the "
            "rocker-valve contact (default: damping ratio 0.05 with k_c and m); the "
            "contact force max(0, k_c d + c_c d') never pulls",
            unit="N.s/m",
            min=0.0,
        ),
        parameter(
            "seat_stiffness",
            vs.DEFAULT_SEAT_STIFFNESS,
            "k_s: stiffness of the valve "
            "seat (an order above the pushrod chain; 5 kHz with the default mass)",
            unit="N/m",
            min=0.0,
        ),
        parameter(
            "seat_damping",
            vs.DEFAULT_SEAT_DAMPING,
            "c_s: damping of the valve seat "
            "(default: damping ratio 0.047, restitution about 0.86); the seat force "
            "max(0, -k_s x - c_s v) never pulls",
            unit="N.s/m",
            min=0.0,
        ),
        parameter(
            "lash",
            vs.DEFAULT_LASH,
            "Clearance between the rocker end and the valve "
            "tip with the valve closed (0: hydraulic lash adjuster)",
            unit="m",
            min=0.0,
        ),
        parameter(
            "max_valve_lift",
            vs.DEFAULT_MAX_LIFT,
            "Travel limit: the valve lift at "
            "which the spring retainer meets the valve guide (coil bind); a step that "
            "would reach it is refused with an error (default: the default cam's "
            "10.5 mm plus 2 mm)",
            unit="m",
            min=0.0,
        ),
        parameter(
            "stop_on_float",
            False,
            "true: the valve leaving the rocker (float) "
            "discards the step with an error instead of a warning",
        ),
        parameter(
            "input_interpolation",
            "interpolate",
            "The rocker motion inside a step, "
            "from the inputs at both ends: interpolate (quintic Hermite through lift, "
            "velocity and acceleration) or hold (the values at the start of the step, "
            "acceleration held)",
            values=vs.INPUT_MODES,
        ),
        parameter(
            "drive",
            "rocker",
            "What moves the rocker's valve end: rocker (the inputs rocker_lift, "
            "rocker_velocity, rocker_acceleration, e.g. from ValveTrain) or camshaft (the "
            "inputs camshaft_angle, camshaft_speed, camshaft_acceleration through the cam law "
            "and rocker geometry below, ValveTrain's closed forms in forward mode, evaluated "
            "at any time inside the step; the cam law's segment boundaries are located in "
            "time)",
            values=vs.DRIVES,
        ),
        *geometry_variables(),
        *cam_law_variables(),
        *integrator_variables(
            default="dopri5",
            rtol=1e-10,
            atol=1e-12,
            max_substep=2e-5,
            own_methods=(
                (
                    valve_exact.EXACT,
                    "each contact mode solved in closed form on drive pieces of at most "
                    "max_substep, switches located on it",
                ),
            ),
        ),
        # nominal: the magnitude of a valve lift (the default cam's is 10.5 mm), not 1 m
        *motion_inputs(
            _INPUTS,
            "m",
            tuple(
                only_with("drive", "rocker", text)
                for text in (
                    "L: position of the rocker's valve end, the kinematic valve lift "
                    "(opening positive)",
                    "L' = d(rocker_lift)/dt",
                    "L'' = d(rocker_velocity)/dt (for the interpolation inside the step)",
                )
            ),
            nominal=0.01,
        ),
        *motion_inputs(
            _CAMSHAFT,
            "rad",
            tuple(only_with("drive", "camshaft", text) for text in CAMSHAFT_DESCRIPTIONS),
        ),
        output(
            "valve_lift",
            0.0,
            "x: valve opening from the closed valve on its undeformed "
            "seat (negative: pressed into the seat)",
            unit="m",
        ),
        output("valve_velocity", 0.0, "v = dx/dt", unit="m/s"),
        output(
            "valve_acceleration",
            0.0,
            "dv/dt = (contact_force + seat_force - spring_force) / valve_mass",
            unit="m/s2",
            depends=_ON_POSITION_AND_RATE,
        ),
        output(
            "contact_force",
            0.0,
            "F_c: force of the rocker on the valve, max(0, k_c d + c_c d') where d > 0",
            unit="N",
            min=0.0,
            depends=_ON_POSITION_AND_RATE,
        ),
        output(
            "seat_force",
            0.0,
            "F_seat: force of the seat on the valve, max(0, -k_s x - c_s v) where x < 0",
            unit="N",
            min=0.0,
        ),
        output("spring_force", 0.0, "F_s = F0 + k x: valve spring force, closing", unit="N"),
        output(
            "penetration",
            0.0,
            "d = rocker_lift - valve_lift - lash: how far the rocker "
            "presses into the valve tip (negative: a gap)",
            unit="m",
            depends=_ON_POSITION,
        ),
        output(
            "contact_lost",
            False,
            "The valve is off the rocker (d <= 0) while the rocker "
            "holds it open (rocker_lift > lash): float, or a bounce at the closing",
            depends=_ON_POSITION,
        ),
        output(
            "float_events",
            0,
            "Separations of valve and rocker with the rocker open, "
            "before the valve closed (float) so far; a valve rebounding from its seat is "
            "a bounce, not float",
        ),
        output(
            "seat_impacts",
            0,
            "Arrivals of the valve on its seat moving down so far (closings and bounces)",
        ),
        output(
            "camshaft_torque",
            0.0,
            "drive = camshaft: torque the camshaft must supply to the cam, in its direction "
            "of rotation, F_c dL/dtheta (massless, frictionless rocker and tappet: its power "
            "is the contact's, F_c L'); 0 with drive = rocker",
            unit="N.m",
            depends=_ON_POSITION_AND_RATE,
        ),
        output("kinetic_energy", 0.0, "m v^2 / 2", unit="J"),
        output(
            "elastic_energy",
            0.0,
            "F0 x + k x^2 / 2 + k_c d^2 / 2 (d > 0) + k_s x^2 / 2 "
            "(x < 0): valve spring (relative to the closed valve), contact and seat",
            unit="J",
            depends=_ON_POSITION,
        ),
        output(
            "contact_work",
            0.0,
            "Work of the rocker on the valve through the contact "
            "since the start, integral of F_c L' dt (equals the change of kinetic plus "
            "elastic energy when both dampings are 0)",
            unit="J",
        ),
        *geometry_effect(
            VALVE_TRAIN_FRAME + ", with the geometry parameters (drive = rocker: only the "
            "valve axis; the other joints and cam_angle stay 0)",
            {
                **VALVE_TRAIN_POINTS,
                "rocker_end": "the rocker's valve end on the valve axis (ValveTrain's "
                "valve_foot), rocker_lift below its closed position",
                "valve_tip": "the valve's tip on the valve axis, lash below the rocker end "
                "with both closed, valve_lift below that",
            },
            depends=_ON_POSITION,
            extra=(cam_angle_output(_CAMSHAFT[:1]),),
        ),
    )

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.parameters: Any = None  # vs.Parameters
        self.drive: Any = None  # vs.StepDrive read by rhs and events
        self.modes: Any = None  # vs.Modes read by rhs: the contacts engaged while integrating
        self.rhs: Any = None  # Callable (set_up)
        self.events: Any = None  # {vs.Engaged: (Event, ...)}
        self.phase: Any = None  # vs.Phase at the last communication point
        self.engaged: Any = None  # vs.Engaged at the last communication point
        self.created = 0.0  # J: energy the integration has gained so far (see ENERGY_GROWTH)
        self.peak_energy = 0.0  # J: largest energy in play so far
        self.max_lift: Any = None  # m: max_valve_lift, the travel limit
        self.last_float: Any = None  # s: when the valve last left the rocker (float), for messages
        # geometry effect: the valve train drawn, its cam law and closed valve foot height (m)
        self.drawn_geometry: Any = None
        self.cam_law: Any = None
        self.closed_height = 0.0

    # --- set-up (IntegratingSlave: the state is (x, v, W), the inputs (L, L', L'')) ----------
    def set_up(self) -> bool:
        v = self.values
        self.parameters = vs.make_parameters(
            v["valve_mass"],
            v["spring_stiffness"],
            v["spring_preload"],
            v["contact_stiffness"],
            v["contact_damping"],
            v["seat_stiffness"],
            v["seat_damping"],
            v["lash"],
        )
        self.max_lift = require_positive("max_valve_lift", v["max_valve_lift"], "m")
        if v["drive"] not in vs.DRIVES:
            raise MechanismError(f"drive = {v['drive']!r} is not one of {', '.join(vs.DRIVES)}")
        if v["drive"] == "camshaft":
            geometry, profile = cam_setup(v)
            self.drive = vs.CamshaftStepDrive(profile, geometry, v["input_interpolation"])
        else:
            self.drive = vs.StepDrive(v["input_interpolation"])
        if v["geometry"]:  # the valve train it draws (validated: the rocker drive has none)
            self.drawn_geometry, profile = cam_setup(v)
            self.cam_law = cam_laws.motion_function(profile)
            self.closed_height = vt.rest_position(self.drawn_geometry)[1]
        self.modes = vs.Modes()
        self.rhs = vs.build_rhs(self.parameters, self.drive, self.modes)
        self.events = vs.build_events(self.parameters, self.drive, self.max_lift)
        return True

    def check_parameters(self) -> None:
        if self.values["integrator"] != valve_exact.EXACT:
            super().check_parameters()
            return
        self.set_up()
        self.integrator = valve_exact.ExactIntegrator(
            require_positive("max_substep", self.values["max_substep"], "s"),
            self.values["rtol"],
            self.values["atol"],
        )

    def rocker(self, inputs: tuple[float, float, float]) -> tuple[float, float, float]:
        """(L m, L' m/s, L'' m/s^2) of the rocker end for the inputs given at a
        communication point: the inputs themselves (drive = rocker) or ValveTrain's closed
        forms at the camshaft's motion (drive = camshaft)."""
        if isinstance(self.drive, vs.CamshaftStepDrive):
            return self.drive.motion(inputs)
        return inputs

    def initial_state(self, time: float) -> list[float]:
        L, rate, _ = self.rocker(self.held_inputs)
        y = vs.initial_state(self.parameters, L, rate)
        if y[0] > self.max_lift:
            self._refuse_travel(time, y, self.rocker(self.held_inputs))
        self.phase = vs.contact_phase(self.parameters, L, y[0])
        self.engaged = vs.engagement(self.parameters, L, rate, *y[:2])
        return y

    def extra_state(self) -> dict[str, list[bool] | float | None]:
        return {
            "phase": None if self.phase is None else list(self.phase),
            "engaged": None if self.engaged is None else list(self.engaged),
            "created": self.created,
            "peak_energy": self.peak_energy,
            "last_float": self.last_float,
        }

    def restore_extra_state(self, saved: dict[str, Any]) -> None:
        if saved["phase"] is not None:
            self.phase = vs.Phase(*saved["phase"])
            self.engaged = vs.Engaged(*saved["engaged"])
        self.created, self.peak_energy = saved["created"], saved["peak_energy"]
        self.last_float = saved["last_float"]

    # --- stepping ----------------------------------------------------------------------------
    def read_inputs(self) -> tuple[float, ...]:
        names, units = (
            (_CAMSHAFT, _CAMSHAFT_UNITS)
            if isinstance(self.drive, vs.CamshaftStepDrive)
            else (_INPUTS, _UNITS)
        )
        v = self.values
        lift, rate, acceleration = v[names[0]], v[names[1]], v[names[2]]
        # the usual inputs, finite floats, in one test (a finite sum: none NaN or infinite;
        # a sum that overflows is checked one by one below)
        if (
            type(lift) is float
            and type(rate) is float
            and type(acceleration) is float
            and math.isfinite(lift + rate + acceleration)
        ):
            return lift, rate, acceleration
        return tuple([require_finite(name, v[name], unit) for name, unit in zip(names, units)])

    def advance(self, start: float, time: float, end_inputs: tuple[float, float, float]) -> tuple:
        """Integrate to ``time`` through the contact events; return (state, (the float,
        bounce and seat happenings, phase, engaged contacts, energy created, peak energy))."""
        p = self.parameters
        self.drive.set_step(start, time, self.held_inputs, end_inputs)
        found = []
        phase = [self.phase]

        def judge(t: float, y: Any, drive: tuple[float, float, float]):
            phase[0], new = vs.next_phase(p, phase[0], t, y[0], y[1], drive)
            if new:
                found.extend(new)
                for happening in new:
                    if happening.kind == vs.FLOAT and self.values["stop_on_float"]:
                        raise MechanismError(_float_message(happening))

        def on_event(event: Any, t: float, y: Any):
            name, drive = event.name, self.drive.at(t)
            if name == vs.TRAVEL_LIMIT:
                floated = [h.time for h in found if h.kind == vs.FLOAT]
                self._refuse_travel(t, y, drive, floated[-1] if floated else self.last_float)
            if name in vs.SWITCH_EVENTS:
                self.modes.engaged = vs.after_switch(
                    p,
                    self.modes.engaged,
                    vs.SWITCH_EVENTS.index(name),
                    drive[0],
                    drive[1],
                    y[0],
                    y[1],
                )
            judge(t, y, drive)
            return y

        # the rocker end at the step's start: the drive's value there (the held inputs)
        rocker0 = self.rocker(self.held_inputs)
        self.modes.engaged = vs.resume(
            p, self.engaged, rocker0[0], rocker0[1], self.state[0], self.state[1]
        )
        if isinstance(self.integrator, valve_exact.ExactIntegrator):
            y = valve_exact.integrate_exact(
                p,
                self.drive,
                self.modes,
                start,
                self.state,
                time,
                on_event,
                self.integrator,
                self.max_lift,
            )
        else:  # restarted where the camshaft drive's cam law changes segment (none else)
            y = self.state
            edges = [start, *self.drive.breakpoints(start, time), time]
            for a, b in zip(edges[:-1], edges[1:]):
                y = advance_through_events(
                    self.integrator,
                    self.rhs,
                    a,
                    y,
                    b,
                    lambda: self.events[self.modes.engaged],
                    on_event,
                )
        rocker1 = self.drive.at(time)
        judge(time, y, rocker1)
        created, peak = self._check_energy(start, self.state, time, y, rocker0[0], rocker1[0])
        return y, (found, phase[0], self.modes.engaged, created, peak)

    def commit(self, time: float, happened: tuple) -> None:
        found, self.phase, self.engaged, self.created, self.peak_energy = happened
        v = self.values
        for happening in found:
            if happening.kind == vs.FLOAT:
                v["float_events"] += 1
                self.last_float = happening.time
            elif happening.kind == vs.SEAT_IMPACT:
                v["seat_impacts"] += 1
                continue  # a closing: counted, not reported
            self.log(
                f"{self.instance_name}: {_MESSAGES[happening.kind](happening)}", Status.warning
            )

    def _refuse_travel(
        self,
        t: float,
        y: list[float],
        drive: tuple[float, float, float],
        floated: float | None = None,
    ):
        """RangeError: the valve lift reaches max_valve_lift at time t (state y, rocker end
        ``drive`` = (L, L', L''))."""
        cause = (
            f"the valve left the rocker (float) at t = {floated!r} s and flew on"
            if floated is not None
            else f"the rocker pushes it there (rocker lift {drive[0]:.6g} m)"
        )
        raise RangeError(
            "valve_lift",
            y[0],
            f"(-inf, {self.max_lift!r}]",
            "m",
            f"max_valve_lift, the travel limit: the spring retainer meets the valve guide at "
            f"t = {t!r} s with the valve moving at {y[1]:.6g} m/s; {cause}; beyond it the "
            f"valve train is damaged and the model does not apply: lower the camshaft speed, "
            f"stiffen or preload the spring, or raise max_valve_lift",
        )

    def _check_energy(
        self,
        t0: float,
        y0: list[float],
        t1: float,
        y1: list[float],
        rocker0: float,
        rocker1: float,
    ) -> tuple[float, float]:
        """(energy created so far, largest energy in play) after a step from y0 at t0 (s)
        to y1 at t1, the rocker end at rocker0 and rocker1 (m), or IntegrationError when
        the step or the run gained more energy than a passive valve can."""
        gain, scale = vs.energy_gain(self.parameters, rocker0, y0, rocker1, y1)
        created = self.created + max(gain, 0.0)
        peak = max(self.peak_energy, scale)
        if gain > ENERGY_GROWTH * scale or created > ENERGY_GROWTH * peak:
            v = self.values
            raise IntegrationError(
                f"{v['integrator']}: the valve's energy grew by {gain:.6g} J more than the "
                f"rocker's work between t = {t0!r} s and {t1!r} s (energy in play "
                f"{scale:.6g} J; gains since the start {created:.6g} J, largest energy in "
                f"play {peak:.6g} J; a passive valve cannot gain energy): unstable: the "
                f"sub-step max_substep = {v['max_substep']!r} s exceeds the method's "
                f"stability limit; reduce max_substep or use radau or exact"
            )
        return created, peak

    def publish(self, time: float) -> None:
        """Outputs at ``time`` from the state and the inputs given for that time."""
        v, p = self.values, self.parameters
        lift, velocity, work = self.state
        L, rate, _ = self.rocker(self.held_inputs)
        f = vs.forces(p, L, rate, lift, velocity)
        (
            v["valve_lift"],
            v["valve_velocity"],
            v["valve_acceleration"],
            v["contact_force"],
            v["seat_force"],
            v["spring_force"],
            v["penetration"],
        ) = (lift, velocity, f.acceleration, f.contact, f.seat, f.spring, f.penetration)
        v["contact_lost"] = f.penetration <= 0.0 and L - p.lash > 0.0
        if isinstance(self.drive, vs.CamshaftStepDrive):
            lift_rate = self.drive.valve_lift_rate(self.held_inputs)
            v["camshaft_torque"] = cam_geometry.camshaft_torque(f.contact, lift_rate)
        v["kinetic_energy"] = vs.kinetic_energy(p, velocity)
        v["elastic_energy"] = vs.elastic_energy(p, L, lift)
        v["contact_work"] = work

    def geometry_points(self) -> dict[str, float]:
        """The valve on its axis and, with the camshaft drive, the valve train that moves
        the rocker end: ValveTrain's closed forms at the camshaft angle."""
        v, g = self.values, self.drawn_geometry
        if isinstance(self.drive, vs.CamshaftStepDrive):
            angle = self.held_inputs[0]
            train = vt.forward(g, self.cam_law(angle, 0.0, 0.0)[0], 0.0, 0.0)
            chain = joint_positions.valve_train_points(
                g, train.tappet_lift, train.rocker_angle, self.closed_height - train.valve_lift
            )
            points = joint_positions.flattened(chain)
            del points["valve_foot_x"], points["valve_foot_y"]  # the rocker end, below
            points["cam_angle"], rocker_lift = angle, train.valve_lift
        else:
            points, rocker_lift = {}, self.held_inputs[0]
        points.update(
            joint_positions.flattened(
                joint_positions.valve_axis_points(
                    g.valve_axis_x, self.closed_height, v["lash"], rocker_lift, v["valve_lift"]
                )
            )
        )
        return points


def _drive_text(happening: Happening) -> str:
    L, rate, acceleration = happening.drive
    return f"rocker lift {L:.6g} m, velocity {rate:.6g} m/s, acceleration {acceleration:.6g} m/s^2"


def _float_message(happening: Happening) -> str:
    return (
        f"valve float at t = {happening.time!r} s: the valve left the rocker at valve "
        f"lift {happening.lift:.6g} m, valve velocity {happening.velocity:.6g} m/s; "
        f"{_drive_text(happening)} (the spring cannot keep the valve on the rocker)"
    )


def _rebound_message(happening: Happening) -> str:
    return (
        f"valve bounce at t = {happening.time!r} s: rebounding from its seat the valve "
        f"left the closing rocker at valve lift {happening.lift:.6g} m, valve velocity "
        f"{happening.velocity:.6g} m/s; {_drive_text(happening)}"
    )


def _bounce_message(happening: Happening) -> str:
    return (
        f"valve bounce at t = {happening.time!r} s: the valve hit its seat at "
        f"{happening.velocity:.6g} m/s without the rocker; {_drive_text(happening)}"
    )


_MESSAGES = {vs.FLOAT: _float_message, vs.REBOUND: _rebound_message, vs.BOUNCE: _bounce_message}
