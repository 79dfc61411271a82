"""Generic planar kinematics: bodies, joints as constraint equations, Newton-Raphson (stdlib).

Haug's method ("Computer Aided Kinematics and Dynamics of Mechanical Systems", 1989), as the
coursework's valve-train study uses it. Each moving body i has generalised coordinates
q_i = (x_i, y_i, phi_i): the position (m) of its frame's origin and the frame's angle (rad,
counter-clockwise). The ground is ``GROUND`` (None), fixed at the origin with phi = 0.

Each joint contributes constraint equations Phi(q, t) = 0 and, assembled from them,

    Phi_q q'  = -Phi_t                         velocity equation
    Phi_q q'' = gamma = -(Phi_q q')_q q' - 2 Phi_qt q' - Phi_tt     acceleration equation

Time enters only through drivers: a driver imposes sum(w_k q_k) = f(t) and receives
(f, f', f'') at each solve from the caller (an FMU input, a cam law, ...).

Position: Newton-Raphson from a predictor, with a tolerance on the scaled residual and an
iteration limit. Velocity and acceleration: one linear solve each with the same LU.

Singular positions. At a toggle or change point Phi_q loses rank: velocities become
infinite and Newton may wander or converge onto the other assembly circuit. The solver
measures the 1-norm condition number of the scaled Jacobian at every converged position and
raises SingularConfiguration, naming the configuration, above ``singularity_threshold``.
It also tracks the sign of det(Phi_q): on one assembly circuit it never changes, so a flip
between two steps means the solution jumped circuits (or passed through a singular
position), which is reported the same way rather than returned.
"""

import math
from operator import attrgetter
from collections import namedtuple

from ..errors import MechanismError, SingularConfiguration
from ..numerics.linalg import Singular, condition_number, determinant_sign, lu_factor, lu_solve
from . import planar_kernel  # imported whole here: an FMU's runtime loads while it is extracted
from collections.abc import Callable, Sequence
from typing import Any, cast

GROUND = None
X, Y, PHI = 0, 1, 2  # coordinate offsets within a body's triple

DEFAULT_TOLERANCE = 1e-12  # scaled residual: lengths / length_scale, angles in rad
DEFAULT_MAX_ITERATIONS = 25
DEFAULT_SINGULARITY_THRESHOLD = 1e8
MAX_CONTINUATION_HALVINGS = 10


class NoConvergence(MechanismError):
    """Newton-Raphson did not reach the tolerance within its iteration limit."""


def _perp(v: tuple[float, float]) -> tuple[float, float]:
    """v rotated by +90 degrees (d/dphi of A(phi) s is perp(A s))."""
    return (-v[1], v[0])


def _dot(u: tuple[float, float], v: tuple[float, float]) -> float:
    return u[0] * v[0] + u[1] * v[1]


class _Frames:
    """Position, rotated body-frame vectors and rates of each body, read from q (and q')."""

    __slots__ = ("q", "qdot")

    def __init__(self, q: list[float], qdot: Any = None) -> None:
        self.q, self.qdot = q, qdot

    def origin(self, body: int | None) -> tuple[float, float]:
        if body is GROUND:
            return (0.0, 0.0)
        return (self.q[3 * body], self.q[3 * body + 1])

    def angle(self, body: int | None) -> float:
        return 0.0 if body is GROUND else self.q[3 * body + 2]

    def rotate(self, body: int | None, vector: Any) -> tuple[float, float]:
        """A(phi) vector: a body-frame vector in global axes."""
        if body is GROUND:
            return (float(vector[0]), float(vector[1]))
        c, s = math.cos(self.angle(body)), math.sin(self.angle(body))
        return (c * vector[0] - s * vector[1], s * vector[0] + c * vector[1])

    def point(self, body: int | None, local: tuple[float, ...]) -> tuple[float, float]:
        r, a = self.origin(body), self.rotate(body, local)
        return (r[0] + a[0], r[1] + a[1])

    def velocity(self, body: int | None) -> tuple[float, float]:
        if body is GROUND:
            return (0.0, 0.0)
        return (self.qdot[3 * body], self.qdot[3 * body + 1])

    def angular_velocity(self, body: int | None) -> float:
        return 0.0 if body is GROUND else self.qdot[3 * body + 2]


# --- joints -------------------------------------------------------------------------------------
# Each joint has ``equations`` rows, ``kinds`` ("length" or "angle" per row, for scaling) and
# fills its rows of Phi, Phi_q, -Phi_t (velocity right-hand side) and gamma.


Point = tuple[float, float]  # (x, y) in m, in a body's frame


class _PointJoint:
    """A joint between point ``point_i`` of body i and point ``point_j`` of body j (or of the
    ground, body None), each in its body's frame (m)."""

    def __init__(
        self, name: str, body_i: int, point_i: Point, body_j: int | None, point_j: Point
    ) -> None:
        self.name, self.body_i, self.point_i = name, body_i, tuple(point_i)
        self.body_j, self.point_j = body_j, tuple(point_j)


class Revolute(_PointJoint):
    """Point ``point_i`` of body i coincides with point ``point_j`` of body j (2 equations)."""

    kernel = "revolute"  # its form in planar_kernel (compiled fast path)
    equations = 2
    kinds = ("length", "length")

    def residual(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        p, r = f.point(self.body_i, self.point_i), f.point(self.body_j, self.point_j)
        return [p[0] - r[0], p[1] - r[1]]

    def jacobian(self, f: _Frames, rows: list[list[float]]) -> None:
        for body, local, sign in (
            (self.body_i, self.point_i, 1.0),
            (self.body_j, self.point_j, -1.0),
        ):
            if body is GROUND:
                continue
            d = _perp(f.rotate(body, local))
            rows[0][3 * body] += sign
            rows[1][3 * body + 1] += sign
            rows[0][3 * body + 2] += sign * d[0]
            rows[1][3 * body + 2] += sign * d[1]

    def velocity_rhs(self, drive: Sequence[tuple[float, ...]]) -> list[float]:
        return [0.0, 0.0]

    def gamma(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        a_i, a_j = f.rotate(self.body_i, self.point_i), f.rotate(self.body_j, self.point_j)
        w_i, w_j = f.angular_velocity(self.body_i), f.angular_velocity(self.body_j)
        return [a_i[0] * w_i * w_i - a_j[0] * w_j * w_j, a_i[1] * w_i * w_i - a_j[1] * w_j * w_j]


class PointOnLine(_PointJoint):
    """Point ``point_i`` of body i stays on the line of body j through ``point_j`` along
    ``direction_j`` (body-j frame): a sliding joint that permits rotation (1 equation).

    Phi = n_j . (P_i - P_j) with n_j the line's unit normal, A_j perp(u_j).
    """

    kernel = "point_on_line"  # its form in planar_kernel (compiled fast path)
    equations = 1
    kinds = ("length",)

    def __init__(
        self,
        name: str,
        body_i: int,
        point_i: Point,
        body_j: int | None,
        point_j: Point,
        direction_j: Point,
    ) -> None:
        norm = math.hypot(*direction_j)
        if not norm > 0.0:
            raise ValueError(f"{name}: direction must be non-zero")
        super().__init__(name, body_i, point_i, body_j, point_j)
        self.normal_j = _perp((direction_j[0] / norm, direction_j[1] / norm))

    def _parts(self, f: _Frames) -> tuple[tuple[float, float], tuple[float, float]]:
        n = f.rotate(self.body_j, self.normal_j)
        p_i, p_j = f.point(self.body_i, self.point_i), f.point(self.body_j, self.point_j)
        return n, (p_i[0] - p_j[0], p_i[1] - p_j[1])

    def residual(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        n, d = self._parts(f)
        return [_dot(n, d)]

    def jacobian(self, f: _Frames, rows: list[list[float]]) -> None:
        n, d = self._parts(f)
        row = rows[0]
        if self.body_i is not GROUND:
            i = 3 * self.body_i
            row[i] += n[0]
            row[i + 1] += n[1]
            row[i + 2] += _dot(n, _perp(f.rotate(self.body_i, self.point_i)))
        if self.body_j is not GROUND:
            j = 3 * self.body_j
            row[j] -= n[0]
            row[j + 1] -= n[1]
            row[j + 2] += _dot(_perp(n), d) - _dot(n, _perp(f.rotate(self.body_j, self.point_j)))

    def velocity_rhs(self, drive: Sequence[tuple[float, ...]]) -> list[float]:
        return [0.0]

    def gamma(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        n, d = self._parts(f)
        a_i, a_j = f.rotate(self.body_i, self.point_i), f.rotate(self.body_j, self.point_j)
        w_i, w_j = f.angular_velocity(self.body_i), f.angular_velocity(self.body_j)
        v_i, v_j = f.velocity(self.body_i), f.velocity(self.body_j)
        ddot = (
            v_i[0] + _perp(a_i)[0] * w_i - v_j[0] - _perp(a_j)[0] * w_j,
            v_i[1] + _perp(a_i)[1] * w_i - v_j[1] - _perp(a_j)[1] * w_j,
        )
        centripetal = (
            a_i[0] * w_i * w_i - a_j[0] * w_j * w_j,
            a_i[1] * w_i * w_i - a_j[1] * w_j * w_j,
        )
        return [_dot(n, d) * w_j * w_j - 2.0 * w_j * _dot(_perp(n), ddot) + _dot(n, centripetal)]


class RelativeAngle:
    """phi_i - phi_j = angle (rad): with PointOnLine it makes a translational joint."""

    kernel = "relative_angle"  # its form in planar_kernel (compiled fast path)
    equations = 1
    kinds = ("angle",)

    def __init__(self, name: str, body_i: int, body_j: int | None, angle: float = 0.0) -> None:
        self.name, self.body_i, self.body_j, self.angle = name, body_i, body_j, float(angle)

    def residual(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        return [f.angle(self.body_i) - f.angle(self.body_j) - self.angle]

    def jacobian(self, f: _Frames, rows: list[list[float]]) -> None:
        if self.body_i is not GROUND:
            rows[0][3 * self.body_i + 2] += 1.0
        if self.body_j is not GROUND:
            rows[0][3 * self.body_j + 2] -= 1.0

    def velocity_rhs(self, drive: Sequence[tuple[float, ...]]) -> list[float]:
        return [0.0]

    def gamma(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        return [0.0]


def translational(
    name: str,
    body_i: int,
    point_i: tuple[float, float],
    body_j: int | None,
    point_j: tuple[float, float],
    direction_j: tuple[float, float],
    angle: float = 0.0,
) -> tuple[PointOnLine, RelativeAngle]:
    """A prismatic joint: point-on-line plus a locked relative angle (2 equations)."""
    return (
        PointOnLine(name + " (line)", body_i, point_i, body_j, point_j, direction_j),
        RelativeAngle(name + " (angle)", body_i, body_j, angle),
    )


class Driver:
    """sum(weight * q[body, coordinate]) + offset = f(t); f, f', f'' come from ``drive``.

    ``terms``: ((body, X|Y|PHI, weight), ...). ``index`` selects the driver's entry in the
    drive tuple passed to the solver. ``kind``: "length" or "angle", the unit of f.
    """

    kernel = "driver"  # its form in planar_kernel (compiled fast path)
    equations = 1

    def __init__(
        self,
        name: str,
        terms: tuple[tuple[int, int, float], ...],
        index: int = 0,
        offset: float = 0.0,
        kind: str = "angle",
    ) -> None:
        self.name, self.terms, self.index = name, tuple(terms), index
        self.offset, self.kinds = float(offset), (kind,)

    def residual(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        total = self.offset
        for body, coordinate, weight in self.terms:
            total += weight * f.q[3 * body + coordinate]
        return [total - drive[self.index][0]]

    def jacobian(self, f: _Frames, rows: list[list[float]]) -> None:
        for body, coordinate, weight in self.terms:
            rows[0][3 * body + coordinate] += weight

    def velocity_rhs(self, drive: Sequence[tuple[float, ...]]) -> list[float]:
        return [drive[self.index][1]]

    def gamma(self, f: _Frames, drive: Sequence[tuple[float, ...]]) -> list[float]:
        return [drive[self.index][2]]


# --- the mechanism --------------------------------------------------------------------------------

Solution = namedtuple("Solution", "q qdot qddot iterations residual condition")
_solution = Solution._make  # a Solution from a tuple, without the keyword-argument call


class Mechanism:
    """Bodies (names, in coordinate order) and joints; assembles Phi, Phi_q, -Phi_t, gamma.

    length_scale (m): a typical link length. Rows in m are divided by it and angle columns
    multiplied by it, so the residual tolerance and the condition number do not depend on
    the unit of length.
    ``diagnose(q)``: optional callable naming the configuration in error messages;
    ``singularity(q)``: optional callable naming the singular condition nearest to q (for
    example "toggle position: coupler and rocker collinear");
    ``crossing(start_drive, end_drive)``: optional callable returning (position,
    consequence), two texts naming a singular position that a drive change reaches or passes
    and cannot be followed through (a change point, where assembly branches cross, or a
    range where the mechanism does not assemble), or None (see crossing_error).
    """

    def __init__(
        self,
        name: str,
        bodies: tuple,
        joints: list[Any],
        length_scale: float,
        diagnose: Callable | None = None,
        singularity: Callable | None = None,
        crossing: Callable | None = None,
    ) -> None:
        self.name, self.bodies = name, tuple(bodies)
        self.joints = tuple(
            j for joint in joints for j in (joint if isinstance(joint, tuple) else (joint,))
        )
        self.size = 3 * len(self.bodies)
        rows = sum(j.equations for j in self.joints)
        if rows != self.size:
            raise ValueError(
                f"{name}: {rows} constraint equations for {self.size} coordinates "
                f"({len(self.bodies)} bodies); a kinematically driven mechanism "
                f"needs as many equations as coordinates"
            )
        self.length_scale = float(length_scale)
        kinds = [kind for j in self.joints for kind in j.kinds]
        self.row_scale = [1.0 / self.length_scale if k == "length" else 1.0 for k in kinds]
        self.column_scale = [self.length_scale if c % 3 == PHI else 1.0 for c in range(self.size)]
        self.diagnose = diagnose or (lambda q: "q = [" + ", ".join(f"{v:.6g}" for v in q) + "]")
        self.singularity = singularity or (lambda q: "constraint Jacobian rank loss")
        self.crossing = crossing or (lambda start, end: None)
        self.has_crossings = crossing is not None  # whether a drive change can be refused

    def singular_position(self, q: list[float]) -> str:
        """'<nearest singular condition> at <configuration>' for error messages."""
        return f"{self.singularity(q)} at {self.diagnose(q)}"

    # Scaled quantities: rows of lengths divided by L, angle columns multiplied by L.
    def residual(self, q: list[float], drive: Sequence[tuple[float, ...]]) -> list[float]:
        f = _Frames(q)
        values = [v for j in self.joints for v in j.residual(f, drive)]
        return [v * s for v, s in zip(values, self.row_scale)]

    def jacobian(self, q: list[float]) -> list[list[float]]:
        f = _Frames(q)
        matrix = []
        for joint in self.joints:
            rows = [[0.0] * self.size for _ in range(joint.equations)]
            joint.jacobian(f, rows)
            matrix.extend(rows)
        return [
            [v * r * c for v, c in zip(row, self.column_scale)]
            for row, r in zip(matrix, self.row_scale)
        ]

    def velocity_rhs(self, drive: Sequence[tuple[float, ...]]) -> list[float]:
        values = [v for j in self.joints for v in j.velocity_rhs(drive)]
        return [v * s for v, s in zip(values, self.row_scale)]

    def gamma(
        self, q: list[float], qdot: list[float], drive: Sequence[tuple[float, ...]]
    ) -> list[float]:
        f = _Frames(q, qdot)
        values = [v for j in self.joints for v in j.gamma(f, drive)]
        return [v * s for v, s in zip(values, self.row_scale)]

    def unscale(self, scaled: list[float]) -> list[float]:
        """Solution of the scaled system -> coordinates (angle columns were multiplied by L)."""
        return [v * c for v, c in zip(scaled, self.column_scale)]


def _max_abs(values: list[float]) -> float:
    return max(abs(v) for v in values)


def _factor(mechanism: Mechanism, q: list[float]) -> tuple[list[list[float]], Any]:
    matrix = mechanism.jacobian(q)
    try:
        return matrix, lu_factor(matrix)
    except Singular:
        return matrix, None


def solve_position(
    mechanism: Mechanism,
    guess: list[float],
    drive: Sequence[tuple[float, ...]],
    tolerance: float = DEFAULT_TOLERANCE,
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
) -> tuple[list[float], int, float]:
    """Newton-Raphson on Phi(q) = 0 from ``guess``. Returns (q, iterations, residual).

    Stops when the scaled residual is below ``tolerance`` after at least one correction and
    with a last correction small enough that the remaining error is far below it. Raises
    SingularConfiguration on an exactly singular Jacobian or when the residual is below the
    tolerance but the corrections have not become small within ``max_iterations`` (linear
    convergence: a singular root), NoConvergence after ``max_iterations`` otherwise or on a
    non-finite iterate.
    """
    q = [float(v) for v in guess]
    residual = mechanism.residual(q, drive)
    size = math.inf
    for iteration in range(1, max_iterations + 1):
        _, factored = _factor(mechanism, q)
        if factored is None:
            raise SingularConfiguration(
                f"{mechanism.name}: singular constraint Jacobian during Newton iteration "
                f"{iteration}, {mechanism.singular_position(q)}"
            )
        step = mechanism.unscale(lu_solve(factored, residual))
        q = [a - b for a, b in zip(q, step)]
        residual = mechanism.residual(q, drive)
        size = _max_abs(residual)
        if not math.isfinite(size):
            break
        # Below tolerance, more corrections until one is tiny: Newton's error after a
        # correction delta is about C delta^2, so a last delta <= 1e-2 sqrt(tolerance) leaves
        # an error far below the tolerance itself. Near a regular root that is one more
        # correction. At a singular root (a toggle or change point exactly at the drive) the
        # residual is quadratic in the distance: it falls below the tolerance about
        # sqrt(tolerance) away, where the Jacobian still looks regular, and the corrections
        # only halve; following them takes the iterate to where the conditioning shows the
        # singular position (analyse), instead of accepting a point next to it from which
        # the next step can leave on either branch.
        small = max(abs(s / c) for s, c in zip(step, mechanism.column_scale))
        if size <= tolerance and small <= 1e-2 * math.sqrt(tolerance):
            return q, iteration, size
    if size <= tolerance:
        # Converged in the residual, but the corrections did not become tiny within the
        # iteration limit: Newton converges only linearly, the mark of a singular root. The
        # iterate may still be 1e-7 away from it, where the Jacobian looks regular enough to
        # pass the conditioning check, and a next step from there can leave on either branch.
        matrix, factored = _factor(mechanism, q)
        condition = math.inf if factored is None else condition_number(matrix, factored)
        raise SingularConfiguration(
            f"{mechanism.name}: singular position, {mechanism.singular_position(q)}: "
            f"Newton-Raphson converges only linearly here (residual {size:.3g} below the "
            f"tolerance, but the corrections still {small:.3g} after {max_iterations} "
            f"iterations; constraint Jacobian condition number {condition:.3g}): the drive "
            f"is at a singular position, where velocities are unbounded"
        )
    raise NoConvergence(
        f"{mechanism.name}: Newton-Raphson did not converge in {max_iterations} iterations "
        f"(scaled residual {_max_abs(residual):.3g} > tolerance {tolerance:.3g}) "
        f"near {mechanism.diagnose(q)}"
    )


def analyse(
    mechanism: Mechanism,
    q: list[float],
    drive: Sequence[tuple[float, ...]],
    singularity_threshold: float = DEFAULT_SINGULARITY_THRESHOLD,
) -> tuple[list[float], list[float], float, int]:
    """Velocities and accelerations at a solved position q; returns (qdot, qddot, condition,
    determinant sign). Raises SingularConfiguration when the scaled Jacobian's condition
    number exceeds ``singularity_threshold``."""
    matrix, factored = _factor(mechanism, q)
    condition = math.inf if factored is None else condition_number(matrix, factored)
    if not condition <= singularity_threshold:
        raise SingularConfiguration(
            f"{mechanism.name}: singular position, {mechanism.singular_position(q)} "
            f"(constraint Jacobian condition number {condition:.3g} > "
            f"{singularity_threshold:.3g}); velocities are unbounded here and the next "
            f"position may lie on either branch"
        )
    qdot = mechanism.unscale(lu_solve(factored, mechanism.velocity_rhs(drive)))
    qddot = mechanism.unscale(lu_solve(factored, mechanism.gamma(q, qdot, drive)))
    return qdot, qddot, condition, determinant_sign(factored)


def crossing_error(
    mechanism: Mechanism, start: Sequence[tuple[float, ...]], end: Sequence[tuple[float, ...]]
) -> "SingularConfiguration | None":
    """SingularConfiguration for a drive change from ``start`` to ``end`` (lists of (value,
    rate, acceleration)) that passes a singular position the mechanism cannot be followed
    through (``mechanism.crossing``), or None. One message for the solver and for a
    mechanism's closed form alike."""
    passed = mechanism.crossing(start, end)
    if not passed:
        return None
    position, consequence = passed
    return SingularConfiguration(
        f"{mechanism.name}: the drive passes through a singular position, {position}, "
        f"between {[d[0] for d in start]} and {[d[0] for d in end]}: {consequence}"
    )


class BranchFollower:
    """Follows one assembly branch of a driven mechanism from one drive value to the next.

    ``assemble(guess, drive)`` finds the first position; ``follow(drive, dt)`` predicts
    q + q' dt + q'' dt^2/2, corrects by Newton and checks the branch (det sign) and the
    conditioning. When Newton fails or lands on another branch, the drive change is split
    in halves (continuation, up to 2^10 pieces) with the tangent dq/ds as predictor before
    it reports an error. The last solution and drive are the state (``snapshot``/``restore``).
    """

    def __init__(
        self,
        mechanism: Mechanism,
        tolerance: float = DEFAULT_TOLERANCE,
        max_iterations: int = DEFAULT_MAX_ITERATIONS,
        singularity_threshold: float = DEFAULT_SINGULARITY_THRESHOLD,
    ) -> None:
        self.mechanism = mechanism
        self.tolerance, self.max_iterations = tolerance, max_iterations
        # the fast path's stopping rule after a Newton correction, and its iterations
        self.newton_small = 1e-2 * math.sqrt(tolerance)
        self.fast_iterations = range(1, min(max_iterations, 4) + 1)
        self.singularity_threshold = singularity_threshold
        self.solution: Solution | None = None
        self.drive: list[tuple[float, ...]] | None = None
        self.sign = 0
        # The compiled kernels of the fast path (planar_kernel), None for joint types it
        # does not know; the LU row order in use and the condition estimate's start column.
        self.kernel: planar_kernel.MechanismKernel | None
        try:
            self.kernel = planar_kernel.mechanism_kernel(mechanism)  # shared by shape
        except planar_kernel.Unsupported:
            self.kernel = None
        self.order: tuple[int, ...] | None = None
        # planar_kernel.LuKernel of self.order (a cache)
        self.lu_kernel: planar_kernel.LuKernel | None = None
        self.column: int | None = None
        # (qdot, qddot, dt) of the solution before the last, and dt to it
        self.history: tuple[Any, ...] | None = None
        # (LU kernel, factors) of Phi_q at factored_at, if known
        self.factored: tuple[planar_kernel.LuKernel, planar_kernel.Factors] | None = None
        # where the fast path last factored Phi_q (None: solution.q)
        self.factored_at: list[float] | None = None
        # whether the last fast step's guess was within 1e-14 (scaled) of its solution
        self.exact_guess = False
        # _chord's result: (q, residual, Jacobian entries, largest |residual|)
        self.chorded: tuple[Any, ...] = ()

    def snapshot(self) -> dict[str, Any]:
        """The branch state. Solutions and drives are never changed in place, so the
        snapshot shares them (JSON writes the tuples as arrays)."""
        return {
            "solution": self.solution,
            "drive": self.drive,
            "sign": self.sign,
            "order": self.order,
            "column": self.column,
            "history": self.history,
            "factored_at": self.factored_at,
            "exact_guess": self.exact_guess,
        }

    # What a step may change, saved by step_state as references (in this order).
    _STEP_FIELDS = (
        "solution",
        "drive",
        "sign",
        "order",
        "lu_kernel",
        "column",
        "history",
        "factored",
        "factored_at",
        "exact_guess",
    )

    def step_state(self) -> tuple[Any, ...]:
        """The branch state as references, for undoing a step within this instance (a
        slave's do_step): cheaper than snapshot, and it keeps the cached factors."""
        return _step_state(self)

    def restore_step_state(self, state: tuple[Any, ...]) -> None:
        """Inverse of step_state."""
        for name, value in zip(self._STEP_FIELDS, state):
            setattr(self, name, value)

    def restore(self, state: Any) -> None:
        self.solution = None if state["solution"] is None else Solution(*state["solution"])
        self.drive = None if state["drive"] is None else [tuple(d) for d in state["drive"]]
        self.sign = state["sign"]
        self.order = None if state.get("order") is None else tuple(state["order"])
        self.column = state.get("column")
        self.history = None if state.get("history") is None else tuple(state["history"])
        self.factored_at = state.get("factored_at")
        self.exact_guess = bool(state.get("exact_guess", False))
        self.factored = None  # worked out again from factored_at and order when needed

    def _solve(
        self, guess: list[float], drive: Sequence[tuple[float, ...]]
    ) -> tuple[Solution, int]:
        q, iterations, residual = solve_position(
            self.mechanism, guess, drive, self.tolerance, self.max_iterations
        )
        qdot, qddot, condition, sign = analyse(self.mechanism, q, drive, self.singularity_threshold)
        return Solution(q, qdot, qddot, iterations, residual, condition), sign

    def assemble(self, guess: list[float], drive: Sequence[tuple[float, ...]]) -> "Solution":
        drive = [tuple(map(float, d)) for d in drive]
        self.solution, self.sign = self._solve(guess, drive)
        self.drive = drive
        self.history = self.factored = self.factored_at = None
        self.exact_guess = False
        return self.solution

    def follow(
        self, drive: Sequence[tuple[float, ...]], dt: float, floats: bool = False
    ) -> "Solution":
        """Solve at the new drive values; ``dt`` (s) is the time since the last solution.
        ``floats``: the caller passes a list of (value, rate, second derivative) tuples of
        floats, used as given (else converted).

        A drive change that reaches or passes a point where two assembly branches cross (a
        change point, named by the mechanism's ``crossing``) is refused: there the sign of
        det(Phi_q) flips along each branch, so it cannot tell them apart, and the branch
        that keeps the sign is the other one. So is one that jumps a range of drive values
        where the mechanism does not assemble (crossing_error).
        """
        if floats:
            drive = cast(list[tuple[float, ...]], drive)
        else:
            drive = [(float(x), float(rate), float(second)) for x, rate, second in drive]
        last = self.solution
        assert last is not None and self.drive is not None  # follow() comes after assemble()
        if self.mechanism.has_crossings:
            refused = crossing_error(self.mechanism, self.drive, drive)
            if refused:
                raise refused
        kernel = self.kernel
        if kernel is not None:
            solution = self._fast_solve(kernel, last, self._fast_guess(kernel, last, dt), drive)
            if solution is not None:
                self.history = (last.qdot, last.qddot, dt) if dt > 0.0 else None
                self.solution, self.drive = solution, drive
                return solution
        self.history = self.factored = self.factored_at = None
        self.exact_guess = False
        guess = [q + v * dt + 0.5 * a * dt * dt for q, v, a in zip(last.q, last.qdot, last.qddot)]
        try:
            solution, sign = self._solve(guess, drive)
            if sign == self.sign:
                self.solution, self.drive = solution, drive
                return solution
        except NoConvergence:
            pass
        except SingularConfiguration:
            # A singular end point is reported as such; a singular iterate on the way may be
            # the predictor's fault, so continuation gets a chance first.
            if self._end_is_singular(drive):
                raise
        solution = self._continue(drive)
        self.solution, self.drive = solution, drive
        return solution

    def _lu(
        self, kernel: "planar_kernel.MechanismKernel", values: Sequence[float]
    ) -> "tuple[planar_kernel.LuKernel, planar_kernel.Factors] | None":
        """The LU kernel and factors of the scaled Jacobian ``values`` (non-zeros): in the
        row order of the last step while its pivots stay within a factor 2 of their
        columns' largest, else in partial pivoting's order here. None if singular."""
        factored = kernel.factor(values, self.order)
        if factored is not None:
            self.order, self.lu_kernel = factored[0].order, factored[0]
        return factored

    def _fast_guess(
        self, kernel: "planar_kernel.MechanismKernel", last: Solution, dt: float
    ) -> list[float]:
        """Predictor q + q' dt + q'' dt^2/2 + j dt^3/6 + s dt^4/24, the jerk j and snap s
        from the rates at the last two solutions (Taylor's expansion of q' and q'' back over
        the last step h: a(-h) - a = -j h + s h^2/2, v(-h) - v + a h = j h^2/2 - s h^3/6).
        Without history: the generic path's q + q' dt + q'' dt^2/2. ``last``: the last
        solution."""
        if self.history is None or not dt > 0.0:
            return [
                q + v * dt + 0.5 * a * dt * dt for q, v, a in zip(last.q, last.qdot, last.qddot)
            ]
        v_before, a_before, h = self.history
        # With da = a(-h) - a and db = v(-h) - v + a h: j = (6 db + 2 da h)/h^2 and
        # s = 6 da/h^2 + 12 db/h^3, so the guess is linear in q, v, a, v(-h) and a(-h):
        # with c3 = dt^3/6, c4 = dt^4/24, the coefficient of da is
        # ka = 2 c3/h + 6 c4/h^2, that of db kb = 6 c3/h^2 + 12 c4/h^3, and
        # q + (dt - kb) v + (dt^2/2 - ka + kb h) a + ka a(-h) + kb v(-h) (predict_step).
        return kernel.predict_step(last.q, last.qdot, last.qddot, v_before, a_before, dt, h)

    def _fast_solve(
        self,
        kernel: "planar_kernel.MechanismKernel",
        previous: Solution,
        guess: list[float],
        drive: Sequence[tuple[float, ...]],
    ) -> Solution | None:
        """solve_position and analyse on the compiled kernels, for the regular case.

        The first corrections reuse the factors of Phi_q at the last solution (the chord
        method): from the predictor _fast_guess the first one is already tiny, and the
        chord's linear rate (about cond(Phi_q) times the change of Phi_q over the step) small.
        They go on while each is below 1e-8 and 1e-2 times the one before; otherwise
        Newton's own corrections follow, with Phi_q factored at every iterate. The stopping
        rule is solve_position's (scaled residual <= tolerance, last correction <= 1e-2
        sqrt(tolerance)) after a Newton correction, and a correction <= 1e-12 (scaled) after
        a chord one; then one more correction with the factors of Phi_q at the converged
        position, which the velocity, the acceleration, the determinant's sign and the
        condition estimate (planar_kernel.inverse_one_norm) need anyway, leaves Newton's
        quadratic accuracy (the residual reported is the one before it). The factors are
        kept for the next step. Returns None, having changed nothing but the cached LU
        order, whenever anything is not regular (no convergence within 4 corrections or
        max_iterations, a singular or ill-conditioned Jacobian, a change of the det sign):
        _solve then takes the step from the generic guess, with the exact condition number
        and its messages. ``previous``: the last solution.
        """
        tolerance = self.tolerance
        q = guess
        newton_first = False
        if self.exact_guess:
            # The last step's guess was already within 1e-14 of its solution (a motion the
            # predictor follows exactly, such as a dwell): Newton's corrections from the
            # guess, without the chord, if the residual there is within the tolerance.
            residual, values = kernel.residual_jacobian(q, drive)
            size = max(map(abs, residual))
            newton_first = size <= tolerance  # False for NaN too
        if newton_first:
            iteration, rounds, first = 0, 3, math.inf
        else:
            iteration, rounds, first = self._chord(kernel, previous, drive, q)
            if iteration == 0:
                return None
            q, residual, values, size = self.chorded
        rates = kernel.rates(drive)
        for _ in range(rounds):
            # _lu's usual case inline: the kernel of the last row order, its pivots still good
            lu = self.lu_kernel
            factors = lu.factor(values) if lu is not None and lu.order is self.order else None
            if lu is None or factors is None:
                factored = self._lu(kernel, values)
                if factored is None:
                    return None
                lu, factors = factored
            else:
                factored = (lu, factors)
            # One more correction with Phi_q at q: after chord steps it removes their error
            # (their linear rate times the last correction), after Newton's it is at the
            # level of rounding. The rates are solved with the same factors, so when the
            # correction is not negligible (> 1e-14, scaled) Phi_q is factored again at the
            # corrected position.
            corrected, final, qdot = lu.correct_and_solve(factors, residual, q, rates)
            at, q = q, corrected
            if newton_first:
                iteration += 1
                if iteration == 1:
                    first = final
            if final <= 1e-14:
                break
            residual, values = kernel.residual_jacobian(q, drive)
            size = max(map(abs, residual))
        else:
            return None
        if factors[-1] != self.sign:  # lu.sign(factors)
            return None
        condition, column = kernel.condition(lu, factors, values, self.column)
        if not condition <= self.singularity_threshold:
            return None
        self.column, self.factored, self.factored_at = column, factored, at
        self.exact_guess = first <= 1e-14
        qddot = lu.acceleration(factors, q, qdot, drive)  # solve_scaled of gamma
        return _solution((q, qdot, qddot, iteration, size, condition))

    def _chord(
        self,
        kernel: "planar_kernel.MechanismKernel",
        previous: Solution,
        drive: Sequence[tuple[float, ...]],
        q: list[float],
    ) -> tuple[int, int, float]:
        """_fast_solve's corrections from the guess ``q``: chord ones on the factors of the
        last step while they shrink fast, then Newton's (see _fast_solve). Returns
        (iterations, rounds of the final correction, the first correction), with
        (q, residual, Jacobian entries, largest |residual|) at the result in
        ``self.chorded``; (0, 0, inf) when they do not converge within 4."""
        tolerance, newton_small = self.tolerance, self.newton_small
        factored = self.factored
        if factored is None:
            at = previous.q if self.factored_at is None else self.factored_at
            factored = self._lu(kernel, kernel.jacobian(at))
            if factored is None:
                return 0, 0, math.inf
        chord, last, first = True, math.inf, math.inf
        values: tuple[float, ...] = ()  # the Jacobian's non-zeros, set by the first correction
        for iteration in self.fast_iterations:
            if not chord:
                factored = self._lu(kernel, values)
                if factored is None:
                    return 0, 0, math.inf
            lu, factors = factored
            # residual at q, correction, residual and Jacobian at the corrected q
            q, correction, residual, values, size = lu.newton_step(factors, q, drive)
            if not math.isfinite(size):
                return 0, 0, math.inf
            if iteration == 1:
                first = correction
            if size <= tolerance and correction <= (1e-10 if chord else newton_small):
                self.chorded = (q, residual, values, size)
                return iteration, 2, first
            if chord and not (correction <= 1e-8 and correction <= 1e-2 * last):
                chord = False
            last = correction
        return 0, 0, math.inf

    def _end_is_singular(self, drive: Sequence[tuple[float, ...]]) -> bool:
        assert self.solution is not None  # after assemble()
        try:
            _, sign = self._solve(self.solution.q, drive)
            return False
        except SingularConfiguration:
            return True
        except NoConvergence:
            return False

    def _continue(self, drive: Sequence[tuple[float, ...]]) -> "Solution":
        """Split the drive change into 2, 4, ... pieces; each piece predicted along the
        branch tangent dq/ds (J dq/ds = d(drive)/ds on the driver rows)."""
        start = self.drive
        assert start is not None and self.solution is not None  # after assemble()
        last_error: SingularConfiguration | NoConvergence | None = None
        furthest = (0.0, self.solution)  # furthest fraction of the change reached, and where
        for halvings in range(1, MAX_CONTINUATION_HALVINGS + 1):
            pieces = 2**halvings
            q, sign, iterations = list(self.solution.q), self.sign, 0
            try:
                for k in range(1, pieces + 1):
                    s = k / pieces
                    target = [
                        tuple(a + s * (b - a) for a, b in zip(d0, d1))
                        for d0, d1 in zip(start, drive)
                    ]
                    guess = self._tangent_predictor(q, start, drive, 1.0 / pieces)
                    solution, new_sign = self._solve(guess, target)
                    if new_sign != sign:
                        raise SingularConfiguration(
                            f"{self.mechanism.name}: the solution changed assembly branch "
                            f"between {self.mechanism.diagnose(q)} and "
                            f"{self.mechanism.diagnose(solution.q)} (det of the constraint "
                            f"Jacobian changed sign): the motion passes through a singular "
                            f"position, {self.mechanism.singular_position(solution.q)}"
                        )
                    q, iterations = solution.q, iterations + solution.iterations
                    if s > furthest[0]:
                        furthest = (s, solution)
                return solution._replace(iterations=iterations)
            except SingularConfiguration as error:
                last_error = error
            except NoConvergence as error:
                last_error = error
        reached, solution = furthest
        if isinstance(last_error, NoConvergence) and (
            solution.condition > 10.0 * self.solution.condition
            or solution.condition > math.sqrt(self.singularity_threshold)
        ):
            # The Jacobian degrades along the way (or the last position was already next to
            # a singular one: a toggle approached closely, where no piece gets further) and
            # Newton fails beyond: the drive asks for a position past a singular one, where
            # the mechanism does not assemble.
            raise SingularConfiguration(
                f"{self.mechanism.name}: no assembly at the requested drive "
                f"{[d[0] for d in drive]}: the motion reaches a singular position, "
                f"{self.mechanism.singular_position(solution.q)} (condition number "
                f"{solution.condition:.3g}, {reached:.4g} of the way from the last step), and "
                f"Newton-Raphson finds no position beyond it"
            ) from last_error
        assert last_error is not None  # every halving raised one
        raise last_error

    def _tangent_predictor(
        self,
        q: list[float],
        start: Sequence[tuple[float, ...]],
        end: Sequence[tuple[float, ...]],
        fraction: float,
    ) -> list[float]:
        mechanism = self.mechanism
        _, factored = _factor(mechanism, q)
        if factored is None:
            return q
        # d(drive)/ds in the rate slot: J dq/ds = -dPhi/ds is the velocity equation's form.
        change = [(0.0, b[0] - a[0], 0.0) for a, b in zip(start, end)]
        tangent = mechanism.unscale(lu_solve(factored, mechanism.velocity_rhs(change)))
        return [v + fraction * t for v, t in zip(q, tangent)]


_step_state = attrgetter(*BranchFollower._STEP_FIELDS)  # BranchFollower.step_state
