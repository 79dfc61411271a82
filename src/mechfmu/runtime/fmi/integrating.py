"""The base of the models that integrate a state inside each communication step.

Runs inside the FMU (standard library + pythonfmu only). LandingGear (dynamics drive),
Suspension (dynamics effect), ValveSpring and HydraulicActuator integrate a state vector
across each communication step; ``IntegratingSlave`` holds what they share:

- the state and the inputs given at the last communication point (the start of the next
  step), and the integrator chosen by the ``integrator_variables`` parameters, whose
  work counters are published as the outputs ``rhs_evaluations`` and ``substeps``;
- a step that is all or nothing: ``advance`` integrates over the host's communication step
  (from its start ``time - step_size``, so a host's rounding of its clock never changes the
  step's length) and returns the new state and what happened on the way, without changing the instance; only when the whole
  step worked does the base commit the state, ``commit`` apply what happened (counters, log
  messages) and ``publish`` write the outputs. On an error MechSlave.do_step restores every
  variable and the internal state below, so a discarded step leaves the instance as before;
- the FMU state: the state, the inputs, the integrator's own state (its step size and
  clock) and whatever ``extra_state`` a model adds.

A model implements ``set_up`` (validate, build its equations, say whether it integrates),
``initial_state``, ``advance`` and ``publish``; if it has them, ``read_inputs``, ``commit``,
``extra_state``/``restore_extra_state`` and ``update_without_state`` (its configurations
that integrate nothing, such as the gear's motion drive).
"""

from ..numerics.integrators import make_integrator
from .slave import MechSlave
from typing import Any


class IntegratingSlave(MechSlave):
    """MechSlave whose outputs follow from a state integrated over each communication step."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.state: Any = None  # the integrated state at the last communication point
        self.held_inputs: Any = None  # the inputs read at that point (read_inputs)

    # --- model contract ---------------------------------------------------------------------
    def set_up(self) -> Any:
        """Validate the parameters and build the equations (raise MechanismError); return
        whether this configuration integrates (False: update_without_state steps it)."""
        raise NotImplementedError

    def read_inputs(self) -> tuple:
        """The inputs given for the current time, checked (raise MechanismError); a tuple
        that ``advance`` receives, with those of the step's start in self.held_inputs."""
        return ()

    def initial_state(self, time: float) -> Any:
        """The state at the start ``time`` (s); may set the model's own start values."""
        raise NotImplementedError

    def advance(self, start: float, time: float, inputs: Any) -> Any:
        """Integrate from ``start`` (s; state self.state, inputs self.held_inputs) to
        ``time`` (s) with ``inputs`` at its end; return (state at ``time``, what happened,
        for ``commit``). Raise MechanismError to discard the step; change nothing that
        internal_state does not restore."""
        raise NotImplementedError

    def commit(self, time: float, happened: Any) -> None:
        """Apply what ``advance`` found (counters, log messages) once the step succeeded."""

    def publish(self, time: float) -> Any:
        """Write the outputs at ``time`` from self.state and self.held_inputs."""
        raise NotImplementedError

    def update_without_state(self, time: float, step_size: float) -> Any:
        """Outputs at ``time`` for a configuration that integrates nothing."""
        raise NotImplementedError

    def extra_state(self) -> Any:
        """JSON-serialisable model state beyond the integrated one (override if any)."""
        return {}

    def restore_extra_state(self, saved: Any) -> None:
        """Inverse of extra_state."""

    # --- MechSlave contract -----------------------------------------------------------------
    def check_parameters(self) -> None:
        self.integrator = None
        integrates = self.set_up()
        v = self.values
        # checked whether or not this configuration integrates: a wrong method or tolerance
        # is refused now, not ignored until a scene switches the dynamics on
        integrator = make_integrator(v["integrator"], v["rtol"], v["atol"], v["max_substep"])
        if integrates:
            self.integrator = integrator

    def outputs_at_start(self, time: float) -> None:
        if self.integrator is None:
            self.update_without_state(time, 0.0)
            return
        self.held_inputs = self.read_inputs()
        self.state = list(self.initial_state(time))
        self._publish_with_counters(time)

    def update(self, time: float, step_size: float) -> None:
        if self.integrator is None:
            self.update_without_state(time, step_size)
            return
        inputs = self.read_inputs()
        state, happened = self.advance(time - step_size, time, inputs)
        # The whole step worked: commit it.
        self.state, self.held_inputs = list(state), inputs
        self.commit(time, happened)
        self._publish_with_counters(time)

    def _publish_with_counters(self, time: float) -> None:
        assert self.integrator is not None  # only integrating configurations publish counters
        self.publish(time)
        stats = self.integrator.stats
        self.values["rhs_evaluations"], self.values["substeps"] = (
            stats.rhs_evaluations,
            stats.substeps,
        )

    def internal_state(self) -> dict[str, Any]:
        extra, integrated = self.step_state()
        saved = dict(extra)
        if integrated is not None:
            state, held_inputs, snapshot = integrated
            saved.update(state=state, held_inputs=list(held_inputs), integrator=snapshot)
        return saved

    def step_state(self) -> tuple[Any, Any]:
        """internal_state for do_step's undo, without its JSON form: (extra_state, None or
        (a copy of the state, the held inputs tuple, the integrator's snapshot))."""
        extra = self.extra_state()
        if self.integrator is None or self.state is None:
            return extra, None
        return extra, (list(self.state), tuple(self.held_inputs), self.integrator.snapshot())

    def restore_step_state(self, saved: tuple[Any, Any]) -> None:
        """Inverse of step_state."""
        extra, integrated = saved
        self.restore_extra_state(extra)
        if integrated is not None and self.integrator is not None:
            state, self.held_inputs, snapshot = integrated
            self.state = list(state)
            self.integrator.restore(snapshot)

    def restore_internal_state(self, saved: dict[str, Any]) -> None:
        self.restore_extra_state(saved)
        if self.integrator is not None and "integrator" in saved:
            self.state = list(saved["state"])
            self.held_inputs = tuple(saved["held_inputs"])
            self.integrator.restore(saved["integrator"])
