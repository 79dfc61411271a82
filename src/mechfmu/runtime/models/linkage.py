"""The shared base of the kinematic linkage FMUs: closed form or the generic constraint solver.

A linkage model computes its outputs from the drive inputs at each communication point,
either by its closed form or by following one assembly branch with the planar constraint
solver (physics/planar.py). The solver's branch is the model's internal state (the last
converged position, rates and drive), saved and restored with the FMU state, so a rolled
back instance re-steps identically. The closed form keeps the last drive too: a drive change
that passes a singular position the mechanism cannot be followed through (a change point
of a four-bar, where two assembly branches cross, or a range where it does not assemble)
is refused by both solvers with the same message (planar.crossing_error), never answered on
the other branch.
"""

from typing import Any

from ..fmi.slave import non_negative, MechSlave, motion_inputs, output, parameter
from ..physics import planar
from ..errors import RangeError, require_finite, require_positive
from ..fmi.declarations import Variable

SOLVERS = ("closed_form", "constraint_solver")
CRANK = ("crank_angle", "crank_speed", "crank_acceleration")


def crank_inputs(start_angle: float = 0.0) -> tuple[Variable, ...]:
    """The crank's angle (rad, starting at ``start_angle``), speed and acceleration inputs of
    a crank-driven linkage (Norton's theta2, omega2, alpha2)."""
    return motion_inputs(
        CRANK,
        "rad",
        ("theta2: crank angle", "omega2 = d(theta2)/dt", "alpha2 = d(omega2)/dt"),
        start_angle,
    )


def solver_variables(
    default: str,
) -> tuple[Variable, Variable, Variable, Variable, Variable, Variable]:
    """The parameters and counters of every model that offers both solvers."""
    return (
        parameter(
            "solver",
            default,
            "closed_form: the mechanism's closed-form solution; "
            "constraint_solver: Newton-Raphson on the joints' constraint equations "
            "(Haug), velocities and accelerations by linear solves",
            values=SOLVERS,
        ),
        non_negative(
            "solver_tolerance",
            planar.DEFAULT_TOLERANCE,
            "Newton tolerance on the "
            "constraint residual (lengths divided by the mechanism's length scale, "
            "angles in rad)",
            "1",
        ),
        parameter(
            "max_iterations",
            planar.DEFAULT_MAX_ITERATIONS,
            "Newton iteration limit per solve (before continuation splits the step)",
            min=1,
        ),
        parameter(
            "singularity_threshold",
            planar.DEFAULT_SINGULARITY_THRESHOLD,
            "Largest accepted condition number of the scaled constraint Jacobian; "
            "above it the position is reported as singular",
            unit="1",
            min=1.0,
        ),
        output(
            "newton_iterations",
            0,
            "Newton iterations of the last communication step (0 with the closed form)",
        ),
        output(
            "constraint_residual",
            0.0,
            "Largest scaled constraint residual after the last solve (0 with the closed form)",
            unit="1",
        ),
    )


class LinkageSlave(MechSlave):
    """Subclasses implement check_geometry, drive, closed_form, mechanism, guess and
    from_solution; each returns or writes values keyed by output name."""

    DRIVE_INPUTS: tuple[
        str, ...
    ] = ()  # (value, rate, acceleration) input names of the mechanism's driver

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.follower: Any = None  # planar.BranchFollower (set_up)
        self.model: Any = None  # planar.Mechanism: the solver's, and the closed form's crossings
        self.last_drive: Any = None  # the closed form's drive at its last communication point
        # the forces effect's analysis (None while it is off); its LU row order is state
        self.forces: Any = None

    def driver_inputs(self) -> tuple[float, float, float]:
        """The current values of DRIVE_INPUTS: (angle, speed, acceleration) of the crank."""
        values = self.values
        return tuple([values[name] for name in self.DRIVE_INPUTS])

    # --- model hooks --------------------------------------------------------------------
    def check_geometry(self) -> None:
        """Validate the model's own parameters (raise MechanismError)."""

    def drive(self, time: float) -> Any:
        """Driver values [(value, rate, acceleration), ...] for the constraint solver."""
        return [self.driver_inputs()]

    def closed_form(self, time: float) -> Any:
        """Output values from the closed form (dict)."""
        raise NotImplementedError

    def mechanism(self) -> Any:
        """The planar.Mechanism of this linkage."""
        raise NotImplementedError

    def guess(self, time: float) -> Any:
        """A starting position on the requested assembly branch (list of coordinates)."""
        raise NotImplementedError

    def from_solution(self, solution: Any, time: float) -> Any:
        """Output values from a planar.Solution (dict)."""
        raise NotImplementedError

    def after_update(self, time: float) -> None:
        """Hook for effects computed from the kinematic outputs (contact forces, ...); here
        the forces effect of a crank-driven linkage (its analysis' ``outputs``)."""
        if self.forces is not None:
            self.values.update(self.forces.outputs(self.driver_inputs(), self.values))

    # --- MechSlave contract -------------------------------------------------------------
    def check_parameters(self) -> Any:
        v = self.values
        if v["solver"] not in SOLVERS:
            raise RangeError("solver", v["solver"], "{" + ", ".join(SOLVERS) + "}")
        require_positive("solver_tolerance", v["solver_tolerance"])
        if not 1 <= v["max_iterations"] <= 1000:
            raise RangeError("max_iterations", v["max_iterations"], "[1, 1000]")
        if require_finite("singularity_threshold", v["singularity_threshold"]) < 1.0:
            raise RangeError("singularity_threshold", v["singularity_threshold"], "[1, inf)")
        self.check_geometry()
        self.follower = None
        self.model = self.mechanism()
        if v["solver"] == "constraint_solver":
            self.follower = planar.BranchFollower(
                self.model, v["solver_tolerance"], v["max_iterations"], v["singularity_threshold"]
            )

    def _drive_now(self, time: float):
        return [tuple(map(float, d)) for d in self.drive(time)]

    def outputs_at_start(self, time: float) -> None:
        if self.follower is None:
            self._write(self.closed_form(time), 0, 0.0)
            if self.model.has_crossings:
                self.last_drive = self._drive_now(time)
        else:
            solution = self.follower.assemble(self.guess(time), self.drive(time))
            self._write(self.from_solution(solution, time), solution.iterations, solution.residual)
        self.after_update(time)

    def update(self, time: float, step_size: float) -> Any:
        if self.follower is None:
            if self.model.has_crossings:
                drive = self._drive_now(time)
                refused = planar.crossing_error(self.model, self.last_drive, drive)
                if refused:
                    raise refused
            self._write(self.closed_form(time), 0, 0.0)
            if self.model.has_crossings:
                self.last_drive = drive
        else:
            # drive(): a list of tuples of floats (inputs are stored as floats)
            solution = self.follower.follow(self.drive(time), step_size, floats=True)
            self._write(self.from_solution(solution, time), solution.iterations, solution.residual)
        self.after_update(time)

    def _write(self, values: Any, iterations: Any, residual: Any) -> None:
        # Validate everything before writing anything: a failed step keeps the last outputs.
        self.values.update(values)
        self.values["newton_iterations"] = iterations
        self.values["constraint_residual"] = residual

    # --- FMU state ----------------------------------------------------------------------
    def internal_state(self) -> Any:
        return {
            "follower": None if self.follower is None else self.follower.snapshot(),
            "last_drive": None if self.last_drive is None else [list(d) for d in self.last_drive],
            "forces": None if self.forces is None else self.forces.equations.snapshot(),
        }

    def step_state(self) -> Any:
        """The branch as references (BranchFollower.step_state), the last drive and the
        force analysis' pivoting: nothing is copied, as none is ever changed in place."""
        follower, forces = self.follower, self.forces
        return (
            None if follower is None else follower.step_state(),
            self.last_drive,
            None if forces is None else forces.equations.snapshot(),
        )

    def restore_step_state(self, state: Any) -> None:
        branch, self.last_drive, pivoting = state
        if branch is not None and self.follower is not None:
            self.follower.restore_step_state(branch)
        if pivoting is not None and self.forces is not None:
            self.forces.equations.restore(pivoting)

    def restore_internal_state(self, state: Any) -> None:
        if self.follower is not None and state.get("follower") is not None:
            self.follower.restore(state["follower"])
        if state.get("last_drive") is not None:
            self.last_drive = [tuple(d) for d in state["last_drive"]]
        if self.forces is not None and state.get("forces") is not None:
            self.forces.equations.restore(state["forces"])
