"""Joint reactions and driving effort of a driven planar mechanism, by Newton-Euler (stdlib).

Each moving body i of a planar.Mechanism (generalised coordinates: its frame's origin O_i and
angle phi_i) carries a MassLayout: its mass m (kg), its centre of mass G at (com_x, com_y) in
the body frame (m) and its moment of inertia I_G about G (kg m^2). With the motion known from
the kinematics (q, q', q''), Newton's and Euler's laws for body i, moments about O_i, read

    m a_G = F_i + R_i,        I_G alpha_i + (G - O_i) x m a_G = M_i + N_i,          (1)

F_i and M_i the applied force and moment (gravity, external loads), R_i and N_i those the
joints exert. A joint's constraint rows Phi_k(q) = 0 exert the generalised force
-Phi_q,k^T lambda_k (Haug, "Computer Aided Kinematics and Dynamics of Mechanical Systems",
1989, sect. 6.3): the rows of Phi_q for body i's (x, y, phi) are exactly the force and the
moment about O_i of a unit multiplier. Equations (1) of all bodies are therefore one square
linear system in the multipliers,

    Phi_q^T lambda = Q_applied - Q_inertia,                                          (2)

Q_applied = (F_i, M_i) and Q_inertia = (m a_G, I_G alpha_i + (G - O_i) x m a_G) stacked per
body: the matrix method of Norton ("Design of Machinery", sect. 11.4), with the pin forces
and the driving torque as unknowns, written once for any mechanism from its joints. The
transposed system is solved with the LU kernels of the constraint solver (planar_kernel), in
the scaled form the solver factors; its condition number says when the joints cannot carry
the loads (a toggle or change point: the forces are unbounded there).

What a joint exerts on its first body (body_i), from its multipliers:
revolute: the force (-lambda_x, -lambda_y) at the joint; point on a line: -lambda times the
line's unit normal, at the point; relative angle: the moment -lambda; driver: the effort
-lambda along its coordinate (a torque for an angle, a force for a length). Body j gets the
opposite.

Units: m, kg, s, rad, N, N m.
"""

import math
from collections import namedtuple
from collections.abc import Sequence
from typing import Any

from ..errors import RangeError, SingularConfiguration, require_finite
from . import planar_kernel
from .planar import DEFAULT_SINGULARITY_THRESHOLD, Driver, Mechanism, PointOnLine, Revolute

MassLayout = namedtuple("MassLayout", "mass com_x com_y inertia")
NO_MASS = MassLayout(0.0, 0.0, 0.0, 0.0)

# One point force: body index, point in the body frame (m), force in ground axes (N).
PointForce = tuple[int, tuple[float, float], float, float]
# One pure moment on a body (N m, counter-clockwise).
BodyMoment = tuple[int, float]

Analysis = namedtuple(
    "Analysis",
    "multipliers shaking_force_x shaking_force_y shaking_moment kinetic_energy "
    "potential_energy condition",
)


def mass_layout(link: str, mass: float, com_x: float, com_y: float, inertia: float) -> MassLayout:
    """A validated MassLayout of ``link``: mass (kg) and moment of inertia about the centre of
    mass (kg m^2) finite and not negative, the centre of mass (m, body frame) finite. The
    RangeError names the parameter, ``<link>_mass`` or ``<link>_inertia``."""
    for name, value, unit in ((f"{link}_mass", mass, "kg"), (f"{link}_inertia", inertia, "kg.m2")):
        if require_finite(name, value, unit, "[0, inf)") < 0.0:
            raise RangeError(
                name, value, "[0, inf)", unit, "a mass or moment of inertia cannot be negative"
            )
    return MassLayout(
        float(mass),
        require_finite(f"{link}_com_along", com_x, "m"),
        require_finite(f"{link}_com_across", com_y, "m"),
        float(inertia),
    )


def with_point_mass(layout: MassLayout, mass: float, x: float, y: float) -> MassLayout:
    """``layout`` with a point mass (kg) added at (x, y) in the body frame (m): the combined
    centre of mass, and the inertia about it by the parallel-axis theorem (a counterweight)."""
    total = layout.mass + mass
    if total == 0.0:
        return layout
    gx = (layout.mass * layout.com_x + mass * x) / total
    gy = (layout.mass * layout.com_y + mass * y) / total
    inertia = (
        layout.inertia
        + layout.mass * ((layout.com_x - gx) ** 2 + (layout.com_y - gy) ** 2)
        + mass * ((x - gx) ** 2 + (y - gy) ** 2)
    )
    return MassLayout(total, gx, gy, inertia)


def rotate(angle: float, x: float, y: float) -> tuple[float, float]:
    """(x, y) turned by ``angle`` (rad): a body-frame vector in ground axes."""
    c, s = math.cos(angle), math.sin(angle)
    return c * x - s * y, s * x + c * y


class NewtonEuler:
    """Equations (2) of one mechanism with fixed mass layouts and gravity.

    ``layouts``: a MassLayout per body of ``mechanism`` (in its body order); ``gravity``:
    the acceleration of gravity in ground axes (m/s^2, (0, 0) for none); ``threshold``:
    largest accepted condition number of the scaled constraint Jacobian (the constraint
    solver's singularity_threshold); ``kernel``: the mechanism's compiled kernels if already
    built (a BranchFollower's), else compiled here.
    """

    def __init__(
        self,
        mechanism: Mechanism,
        layouts: Sequence[MassLayout],
        gravity: tuple[float, float] = (0.0, 0.0),
        threshold: float = DEFAULT_SINGULARITY_THRESHOLD,
        kernel: "planar_kernel.MechanismKernel | None" = None,
    ) -> None:
        if len(layouts) != len(mechanism.bodies):
            raise ValueError(
                f"{mechanism.name}: {len(layouts)} mass layouts for {len(mechanism.bodies)} bodies"
            )
        self.mechanism, self.layouts = mechanism, tuple(layouts)
        self.gravity, self.threshold = (float(gravity[0]), float(gravity[1])), float(threshold)
        self.kernel = kernel or planar_kernel.MechanismKernel(mechanism)
        self.order: tuple[int, ...] | None = None  # LU row order of the last solve
        self.column: int | None = None  # start column of the condition estimate
        self.first_rows: list[int] = []  # first constraint row of each joint
        row = 0
        for joint in mechanism.joints:
            self.first_rows.append(row)
            row += joint.equations

    def snapshot(self) -> list[Any]:
        """The pivoting the next solve starts from (the LU row order and the condition
        estimate's column): results depend on it in the last bits, so an FMU saves it."""
        return [None if self.order is None else list(self.order), self.column]

    def restore(self, state: Sequence[Any]) -> None:
        """Inverse of snapshot."""
        order, self.column = state
        self.order = None if order is None else tuple(order)

    def generalised_forces(
        self,
        q: Sequence[float],
        qdot: Sequence[float],
        qddot: Sequence[float],
        forces: Sequence[PointForce] = (),
        moments: Sequence[BodyMoment] = (),
    ) -> tuple[list[float], float, float, float, float, float]:
        """(Q_applied - Q_inertia of (2), and the inertia's resultant: force x, y (N), moment
        about the ground origin (N m); kinetic and potential energy (J))."""
        gx, gy = self.gravity
        rhs: list[float] = []
        sum_x = sum_y = sum_moment = kinetic = potential = 0.0
        for body, layout in enumerate(self.layouts):
            i = 3 * body
            phi, omega, alpha = q[i + 2], qdot[i + 2], qddot[i + 2]
            m = layout.mass
            sx, sy = rotate(phi, layout.com_x, layout.com_y)  # G - O_i in ground axes
            ax = qddot[i] - alpha * sy - omega * omega * sx  # a_G
            ay = qddot[i + 1] + alpha * sx - omega * omega * sy
            vx = qdot[i] - omega * sy  # v_G
            vy = qdot[i + 1] + omega * sx
            inertia_moment = layout.inertia * alpha + m * (sx * ay - sy * ax)
            rhs += [
                m * gx - m * ax,
                m * gy - m * ay,
                m * (sx * gy - sy * gx) - inertia_moment,
            ]
            gx_position, gy_position = q[i] + sx, q[i + 1] + sy
            sum_x += m * ax
            sum_y += m * ay
            sum_moment += layout.inertia * alpha + m * (gx_position * ay - gy_position * ax)
            kinetic += 0.5 * (m * (vx * vx + vy * vy) + layout.inertia * omega * omega)
            potential -= m * (gx * gx_position + gy * gy_position)
        for body, (lx, ly), fx, fy in forces:
            i = 3 * body
            px, py = rotate(q[i + 2], lx, ly)
            rhs[i] += fx
            rhs[i + 1] += fy
            rhs[i + 2] += px * fy - py * fx
        for body, moment in moments:
            rhs[3 * body + 2] += moment
        return rhs, -sum_x, -sum_y, -sum_moment, kinetic, potential

    def _factored(self, q: Sequence[float]) -> tuple[Any, Any, float]:
        """(LU kernel, factors, condition number) of the scaled constraint Jacobian at q;
        SingularConfiguration where the joints cannot carry loads (above the threshold)."""
        kernel = self.kernel
        values = kernel.jacobian(q)
        factored = kernel.factor(values, self.order)
        if factored is None:
            raise SingularConfiguration(
                f"{self.mechanism.name}: joint forces unbounded, singular constraint "
                f"Jacobian at the {self.mechanism.singular_position(list(q))}"
            )
        lu, factors = factored
        condition, column = kernel.condition(lu, factors, values, self.column)
        if not condition <= self.threshold:
            raise SingularConfiguration(
                f"{self.mechanism.name}: joint forces unbounded at the "
                f"{self.mechanism.singular_position(list(q))} (constraint Jacobian condition "
                f"number {condition:.3g} > {self.threshold:.3g}): the joints cannot carry "
                f"the loads there"
            )
        self.order, self.column = lu.order, column
        return lu, factors, condition

    def _multipliers(
        self,
        lu: Any,
        factors: Any,
        condition: float,
        motion: tuple[Sequence[float], Sequence[float], Sequence[float]],
        forces: Sequence[PointForce],
        moments: Sequence[BodyMoment],
    ) -> Analysis:
        """Solve (2) with the factors of Phi_q for the motion (q, q', q'')."""
        rhs, shaking_x, shaking_y, shaking_moment, kinetic, potential = self.generalised_forces(
            *motion, forces, moments
        )
        scaled = lu.solve_t(factors, [b * c for b, c in zip(rhs, self.kernel.column_scale)])
        multipliers = [m * r for m, r in zip(scaled, self.mechanism.row_scale)]
        return Analysis(
            multipliers, shaking_x, shaking_y, shaking_moment, kinetic, potential, condition
        )

    def solve(
        self,
        q: Sequence[float],
        qdot: Sequence[float],
        qddot: Sequence[float],
        forces: Sequence[PointForce] = (),
        moments: Sequence[BodyMoment] = (),
    ) -> Analysis:
        """The multipliers of (2) (one per constraint row, in the joints' order) and the
        shaking force and moment, for the motion (q, q', q'') and the applied ``forces``
        and ``moments`` (besides gravity). The shaking force and moment are those the moving
        links' inertia puts on the frame: -sum m a_G and -sum (I_G alpha + r_G x m a_G)
        about the ground origin. Raises SingularConfiguration where the joints cannot carry
        the loads (condition number above the threshold)."""
        lu, factors, condition = self._factored(q)
        return self._multipliers(lu, factors, condition, (q, qdot, qddot), forces, moments)

    def solve_driven(
        self,
        q: Sequence[float],
        drive: Sequence[tuple[float, float, float]],
        forces: Sequence[PointForce] = (),
        moments: Sequence[BodyMoment] = (),
    ) -> tuple[Analysis, list[float], list[float]]:
        """``solve`` at an assembled position q whose rates follow from the drivers' values
        ``drive`` ((f, f', f'') each): q' and q'' by the velocity and acceleration equations
        with the same factors of Phi_q (the constraint solver's kernels). Returns (the
        analysis, q', q'')."""
        lu, factors, condition = self._factored(q)
        qdot = lu.solve_scaled(factors, self.kernel.rates(drive))
        qddot = lu.acceleration(factors, q, qdot, drive)
        analysis = self._multipliers(lu, factors, condition, (q, qdot, qddot), forces, moments)
        return analysis, qdot, qddot

    def on_first_body(
        self, analysis: Analysis, joint_index: int, q: Sequence[float]
    ) -> tuple[float, float]:
        """The force (N, ground axes) joint ``joint_index`` exerts on its first body: a
        revolute's pin force, a point-on-line joint's normal force, a length driver's force
        along its coordinate's axis."""
        joint = self.mechanism.joints[joint_index]
        row = self.first_rows[joint_index]
        lam = analysis.multipliers
        if isinstance(joint, Revolute):
            return -lam[row], -lam[row + 1]
        if isinstance(joint, PointOnLine):
            body = joint.body_j
            angle = 0.0 if body is None else q[3 * body + 2]
            nx, ny = rotate(angle, *joint.normal_j)
            return -lam[row] * nx, -lam[row] * ny
        raise TypeError(f"{joint.name}: no force on a body from a {type(joint).__name__}")

    def effort(self, analysis: Analysis, joint_index: int) -> float:
        """What driver ``joint_index`` exerts along its coordinate (N m for an angle, N for a
        length): the driving torque or force; or the moment of a relative-angle joint."""
        joint = self.mechanism.joints[joint_index]
        value = -analysis.multipliers[self.first_rows[joint_index]]
        if isinstance(joint, Driver):
            return value * joint.terms[0][2]
        return value

    def joint_index(self, name: str) -> int:
        """Position of the joint called ``name`` in the mechanism's joints."""
        for index, joint in enumerate(self.mechanism.joints):
            if joint.name == name:
                return index
        raise KeyError(name)


def force_keys(prefix: str) -> tuple[str, str, str]:
    """The names a force (N) is published under: prefix_x, prefix_y, prefix_magnitude."""
    return f"{prefix}_x", f"{prefix}_y", f"{prefix}_magnitude"


def gravity_vector(acceleration: float, direction: float) -> tuple[float, float]:
    """Gravity (m/s^2, ground axes) of magnitude ``acceleration`` pointing at ``direction``
    (rad from +x; -pi/2 is down)."""
    g = require_finite("gravity_acceleration", acceleration, "m/s2", "[0, inf)")
    if g < 0.0:
        raise RangeError("gravity_acceleration", g, "[0, inf)", "m/s2", "a magnitude")
    angle = require_finite("gravity_direction", direction, "rad")
    return g * math.cos(angle), g * math.sin(angle)


def point_velocity(
    q: Sequence[float], qdot: Sequence[float], body: int, local: tuple[float, float]
) -> tuple[float, float]:
    """Velocity (m/s) of a point fixed in ``body`` at ``local`` (body frame, m)."""
    i = 3 * body
    px, py = rotate(q[i + 2], *local)
    omega = qdot[i + 2]
    return qdot[i] - omega * py, qdot[i + 1] + omega * px


def point_position(
    q: Sequence[float], body: int, local: tuple[float, float]
) -> tuple[float, float]:
    """Position (m) of a point fixed in ``body`` at ``local`` (body frame, m)."""
    i = 3 * body
    px, py = rotate(q[i + 2], *local)
    return q[i] + px, q[i + 1] + py
