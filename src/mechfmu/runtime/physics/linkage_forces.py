"""Forces in the crank-driven linkages: joint reactions, crank torque, shaking (stdlib).

The four-bar and the slider-crank as bodies and joints (constraint_models), their motion from
either solver, Newton-Euler for all links at once (link_forces.NewtonEuler), and the figures
read beside the forces: the input power, the mechanical advantage and a coupler point's path.

Joint forces follow Norton's convention (Design of Machinery, sect. 11.4): F_ij is the force
link i exerts on link j, in ground axes. Published per joint:

    four-bar:     crank_pivot F12 (ground on crank at O2), crank_pin F32 (coupler on crank
                  at A), rocker_pin F43 (rocker on coupler at B), rocker_pivot F14 (ground on
                  rocker at O4);
    slider-crank: crank_pivot F12, crank_pin F32, slider_pin F43 (slider on connecting rod
                  at B), guide F14 (the slider guide on the slider, normal to its axis);

and crank_torque T12, the torque the drive puts on the crank (counter-clockwise). The
shaking force and moment are what the moving links' inertia puts on the frame,
F_s = -sum m a_G and M_s = -sum (I_G alpha + r_G x m a_G) about the crank pivot; with
gravity and external loads off they equal the frame's pin reactions F21 + F41 and
T21 + r_O4 x F41 (Norton eqs 11.15, 11.16), as the tests check.

Units: m, kg, s, rad, N, N m, W.
"""

import math
from collections import namedtuple
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import SingularConfiguration
from . import constraint_models
from .four_bar import COURSEWORK_FOUR_BAR, FourBar
from .link_forces import MassLayout, NewtonEuler, force_keys, point_position, point_velocity
from .planar import DEFAULT_SINGULARITY_THRESHOLD
from .slider_crank import SliderCrank

# Uniform steel bars 25 mm x 6 mm (7850 kg/m^3): kg per m of length.
STEEL_BAR_MASS_PER_LENGTH = 7850.0 * 0.025 * 0.006


def uniform_bar(length: float, mass_per_length: float = STEEL_BAR_MASS_PER_LENGTH) -> MassLayout:
    """MassLayout (kg, m, kg m^2) of a uniform slender bar along its frame's x axis."""
    mass = mass_per_length * length
    return MassLayout(mass, 0.5 * length, 0.0, mass * length * length / 12.0)


# The coursework four-bar (2, 7, 9, 6 in) as steel bars, and a coupler point 3.5 in along
# A -> B and 2 in to its left.
FourBarMasses = namedtuple("FourBarMasses", "crank coupler rocker")
DEFAULT_FOUR_BAR_MASSES = FourBarMasses(
    *(
        uniform_bar(length)
        for length in (
            COURSEWORK_FOUR_BAR.crank,
            COURSEWORK_FOUR_BAR.coupler,
            COURSEWORK_FOUR_BAR.rocker,
        )
    )
)
DEFAULT_FOUR_BAR_COUPLER_POINT = (0.0889, 0.0508)

# A small single-cylinder engine on the default slider-crank (50 mm crank, 150 mm rod): crank
# web 1.2 kg with its centre of mass 10 mm from the pivot towards the pin, connecting rod
# 0.5 kg with its centre of mass 50 mm from the crank pin (a third of the rod), piston
# assembly 0.4 kg; no counterweight by default.
SliderCrankMasses = namedtuple("SliderCrankMasses", "crank coupler slider")
DEFAULT_SLIDER_CRANK_MASSES = SliderCrankMasses(
    MassLayout(1.2, 0.01, 0.0, 1.5e-3),
    MassLayout(0.5, 0.05, 0.0, 1.2e-3),
    MassLayout(0.4, 0.0, 0.0, 0.0),
)
DEFAULT_SLIDER_CRANK_COUPLER_POINT = (0.075, 0.0)

_FOUR_BAR_JOINTS = ("crank_pivot", "crank_pin", "rocker_pin", "rocker_pivot")
_SLIDER_CRANK_JOINTS = ("crank_pivot", "crank_pin", "slider_pin", "guide")
CRANK, COUPLER, OUTPUT = 0, 1, 2  # body indices of both linkages
FourBarLoads = namedtuple("FourBarLoads", "rocker_torque coupler_force_x coupler_force_y")
SliderCrankLoads = namedtuple("SliderCrankLoads", "slider_force coupler_force_x coupler_force_y")


def _crank_pin(
    a: float, t2: float, w2: float, al2: float
) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
    """Position, velocity and acceleration of the crank pin A (m, m/s, m/s^2)."""
    c, s = math.cos(t2), math.sin(t2)
    return (
        (a * c, a * s),
        (-a * w2 * s, a * w2 * c),
        (-a * al2 * s - a * w2 * w2 * c, a * al2 * c - a * w2 * w2 * s),
    )


def _crank_and_coupler(
    crank: float, t2: float, w2: float, al2: float, motion: Mapping[str, float]
) -> tuple[list[float], list[float], list[float]]:
    """(q, q', q'') of the crank and the coupler (the first two bodies of both linkages):
    the crank about the origin at t2, the coupler's frame at the crank pin."""
    (ax, ay), (vx, vy), (accx, accy) = _crank_pin(crank, t2, w2, al2)
    return (
        [0.0, 0.0, t2, ax, ay, motion["coupler_angle"]],
        [0.0, 0.0, w2, vx, vy, motion["coupler_angular_velocity"]],
        [0.0, 0.0, al2, accx, accy, motion["coupler_angular_acceleration"]],
    )


def four_bar_state(
    lengths: FourBar, t2: float, w2: float, al2: float, motion: Mapping[str, float]
) -> tuple[list[float], list[float], list[float]]:
    """(q, q', q'') in the coordinates of constraint_models.four_bar from the crank's angle
    (rad), speed (rad/s), acceleration (rad/s^2) and the coupler and rocker motion (``motion``:
    coupler_angle, rocker_angle and their rates, as FourBarMotion's fields)."""
    q, qdot, qddot = _crank_and_coupler(lengths.crank, t2, w2, al2, motion)
    q += [lengths.ground, 0.0, motion["rocker_angle"]]
    qdot += [0.0, 0.0, motion["rocker_angular_velocity"]]
    qddot += [0.0, 0.0, motion["rocker_angular_acceleration"]]
    return q, qdot, qddot


def slider_crank_state(
    geometry: SliderCrank, t2: float, w2: float, al2: float, motion: Mapping[str, float]
) -> tuple[list[float], list[float], list[float]]:
    """(q, q', q'') in the coordinates of constraint_models.slider_crank from the crank's
    angle, speed, acceleration and the slider and coupler motion (SliderCrankMotion's
    fields)."""
    q, qdot, qddot = _crank_and_coupler(geometry.crank, t2, w2, al2, motion)
    q += [motion["slider_position"], geometry.offset, 0.0]
    qdot += [motion["slider_speed"], 0.0, 0.0]
    qddot += [motion["slider_acceleration"], 0.0, 0.0]
    return q, qdot, qddot


def four_bar_mechanical_advantage(
    crank: float, rocker: float, t2: float, t3: float, t4: float
) -> float:
    """Torque on the rocker per unit crank torque, omega2/omega4 = c sin(t4 - t3) /
    (a sin(t2 - t3)) (Norton sect. 3.5, losses aside): a function of the position alone.
    SingularConfiguration where crank and coupler are collinear (the rocker's limit
    positions, where it is unbounded: a toggle clamp)."""
    denominator = crank * math.sin(t2 - t3)
    if denominator == 0.0:
        raise SingularConfiguration(
            f"mechanical advantage unbounded: crank and coupler collinear (the rocker at a "
            f"limit position) at crank angle {t2!r} rad, coupler angle {t3!r} rad"
        )
    return rocker * math.sin(t4 - t3) / denominator


def slider_towards_crank(circuit: int) -> float:
    """+-1: the x direction of a positive slider_force, towards the crank (circuit 0 puts
    the slider on the +x side of the crank pin, circuit 1 on the -x side)."""
    return -1.0 if circuit == 0 else 1.0


def slider_crank_mechanical_advantage(crank: float, t2: float, t3: float, circuit: int) -> float:
    """Crank torque (N m) per newton of slider force towards the crank, the piston driving
    (an engine): slider_towards_crank * ds/dtheta2 with ds/dtheta2 = -a sin(t2 - t3) /
    cos(t3) (m). Zero at the dead centres; the rod perpendicular to the axis is the
    kinematics' singular position, refused before this is asked."""
    return slider_towards_crank(circuit) * (-crank * math.sin(t2 - t3) / math.cos(t3))


class _CrankForces:
    """What both linkages share: the equations, the coupler point and the published dict."""

    JOINTS: tuple[str, ...] = ()
    LOADS: Any = None  # the namedtuple of the external loads (inputs of the same names)

    def __init__(
        self,
        mechanism: Any,
        layouts: Sequence[MassLayout],
        gravity: tuple[float, float],
        coupler_point: tuple[float, float],
        threshold: float,
    ) -> None:
        self.equations = NewtonEuler(mechanism, layouts, gravity, threshold)
        self.coupler_point = (float(coupler_point[0]), float(coupler_point[1]))
        self.driver = len(mechanism.joints) - 1  # the crank angle driver comes last
        # (joint index, output names of its force): worked out once, not at every step
        self.joint_outputs = [
            (index, force_keys(f"{name}_force")) for index, name in enumerate(self.JOINTS)
        ]

    def _publish(
        self,
        q: list[float],
        qdot: list[float],
        qddot: list[float],
        forces: list[Any],
        moments: list[Any],
        extra: dict[str, float],
    ) -> dict[str, float]:
        equations = self.equations
        analysis = equations.solve(q, qdot, qddot, forces, moments)
        torque = equations.effort(analysis, self.driver)
        point = point_position(q, COUPLER, self.coupler_point)
        shaking_x, shaking_y = analysis.shaking_force_x, analysis.shaking_force_y
        values = {
            "crank_torque": torque,
            "input_power": torque * qdot[2],
            "shaking_force_x": shaking_x,
            "shaking_force_y": shaking_y,
            "shaking_force_magnitude": math.hypot(shaking_x, shaking_y),
            "shaking_moment": analysis.shaking_moment,
            "kinetic_energy": analysis.kinetic_energy,
            "potential_energy": analysis.potential_energy,
            "coupler_point_x": point[0],
            "coupler_point_y": point[1],
            **extra,
        }
        for index, (x, y, size) in self.joint_outputs:
            fx, fy = equations.on_first_body(analysis, index, q)
            values[x], values[y], values[size] = fx, fy, math.hypot(fx, fy)
        return values

    def outputs(
        self, crank: tuple[float, float, float], values: Mapping[str, Any]
    ) -> dict[str, float]:
        """``analyse`` with the motion and the loads read from a model's ``values`` (the
        loads by their field names)."""
        return self.analyse(
            crank, values, self.LOADS(*(values[name] for name in self.LOADS._fields))
        )

    def analyse(
        self, crank: tuple[float, float, float], motion: Mapping[str, float], loads: Any
    ) -> dict[str, float]:
        """Output values for the crank's (angle, speed, acceleration), the linkage's motion
        and its loads (the subclasses')."""
        raise NotImplementedError

    def coupler_load(
        self, q: list[float], force_x: float, force_y: float
    ) -> list[tuple[int, tuple[float, float], float, float]]:
        """The external force at the coupler point, as link_forces' point forces (none if 0)."""
        if force_x == 0.0 and force_y == 0.0:
            return []
        return [(COUPLER, self.coupler_point, force_x, force_y)]

    def coupler_point_velocity(self, q: list[float], qdot: list[float]) -> tuple[float, float]:
        """Velocity (m/s) of the coupler point."""
        return point_velocity(q, qdot, COUPLER, self.coupler_point)


class FourBarForces(_CrankForces):
    """Forces of a four-bar with links of given MassLayouts (kg, m, kg m^2; body frames as in
    constraint_models.four_bar: each link along its frame's x axis from O2, A and O4),
    gravity (m/s^2, ground axes), a coupler point (m, along A -> B and to its left) and the
    singularity threshold of the constraint Jacobian's condition number."""

    JOINTS = _FOUR_BAR_JOINTS
    LOADS = FourBarLoads

    def __init__(
        self,
        lengths: FourBar,
        layouts: Sequence[MassLayout],
        gravity: tuple[float, float] = (0.0, 0.0),
        coupler_point: tuple[float, float] = DEFAULT_FOUR_BAR_COUPLER_POINT,
        threshold: float = DEFAULT_SINGULARITY_THRESHOLD,
    ) -> None:
        self.lengths = lengths
        super().__init__(
            constraint_models.four_bar(*lengths), layouts, gravity, coupler_point, threshold
        )

    def analyse(
        self,
        crank: tuple[float, float, float],
        motion: Mapping[str, float],
        loads: FourBarLoads = FourBarLoads(0.0, 0.0, 0.0),
    ) -> dict[str, float]:
        """Output values for the crank (angle rad, speed rad/s, acceleration rad/s^2), the
        coupler and rocker ``motion`` (FourBarMotion's fields) and the external loads: a
        torque on the rocker (N m, counter-clockwise) and a force at the coupler point (N,
        ground axes)."""
        t2, w2, al2 = crank
        q, qdot, qddot = four_bar_state(self.lengths, t2, w2, al2, motion)
        advantage = four_bar_mechanical_advantage(
            self.lengths.crank, self.lengths.rocker, t2, q[5], q[8]
        )
        return self._publish(
            q,
            qdot,
            qddot,
            self.coupler_load(q, loads.coupler_force_x, loads.coupler_force_y),
            [(OUTPUT, loads.rocker_torque)] if loads.rocker_torque else [],
            {"mechanical_advantage": advantage},
        )


class SliderCrankForces(_CrankForces):
    """Forces of a slider-crank with crank, connecting rod and slider of given MassLayouts
    (body frames as in constraint_models.slider_crank: the crank along x from the pivot, the
    rod along x from A, the slider's at B), gravity (m/s^2), a coupler point on the rod (m,
    along A -> B and to its left), the circuit (which way the slider force points) and the
    singularity threshold."""

    JOINTS = _SLIDER_CRANK_JOINTS
    LOADS = SliderCrankLoads

    def __init__(
        self,
        geometry: SliderCrank,
        circuit: int,
        layouts: Sequence[MassLayout],
        gravity: tuple[float, float] = (0.0, 0.0),
        coupler_point: tuple[float, float] = DEFAULT_SLIDER_CRANK_COUPLER_POINT,
        threshold: float = DEFAULT_SINGULARITY_THRESHOLD,
    ) -> None:
        self.geometry, self.circuit = geometry, circuit
        self.towards_crank = slider_towards_crank(circuit)
        mechanism = constraint_models.slider_crank(*geometry)
        super().__init__(mechanism, layouts, gravity, coupler_point, threshold)

    def analyse(
        self,
        crank: tuple[float, float, float],
        motion: Mapping[str, float],
        loads: SliderCrankLoads = SliderCrankLoads(0.0, 0.0, 0.0),
    ) -> dict[str, float]:
        """Output values for the crank (angle rad, speed rad/s, acceleration rad/s^2), the
        slider and rod ``motion`` (SliderCrankMotion's fields) and the external loads: a
        force on the slider along its axis towards the crank (N; an engine's gas force) and
        a force at the coupler point (N, ground axes)."""
        t2, w2, al2 = crank
        q, qdot, qddot = slider_crank_state(self.geometry, t2, w2, al2, motion)
        forces = self.coupler_load(q, loads.coupler_force_x, loads.coupler_force_y)
        if loads.slider_force:
            forces.append((OUTPUT, (0.0, 0.0), self.towards_crank * loads.slider_force, 0.0))
        advantage = slider_crank_mechanical_advantage(self.geometry.crank, t2, q[5], self.circuit)
        return self._publish(q, qdot, qddot, forces, [], {"mechanical_advantage": advantage})
