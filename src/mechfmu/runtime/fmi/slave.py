"""The FMU slave base: declare each variable once, derive everything else from it.

Runs inside the FMU (standard library + pythonfmu or pythonfmu3 only). A model subclasses
``MechSlave``, lists its variables in ``VARIABLES`` (declarations.py: name, type, causality,
unit, range, description, dependencies) and implements ``check_parameters`` and ``update``.
The base class

- keeps the values of the variables in one dict, which the FMI binding (``binding.py``:
  FMI 2.0 over pythonfmu, or FMI 3.0 over pythonfmu3 in an FMU built with
  ``--fmi-version 3``) registers and describes: units, min/max, descriptions, start values,
  outputs with their input dependencies, initial unknowns;
- never lets a Python exception reach pythonfmu's C++ layer. pythonfmu 0.7 turns any
  exception into fmi2Fatal and leaves the GIL state broken, which crashes the host on its
  next call (measured with a probe FMU). Errors are logged instead (status error, naming
  the variable, value and range) and the step returns False, which both pythonfmu libraries
  report as Discard, the only non-OK status pythonfmu 0.7 can return without raising. A
  discarded step leaves the instance as before.
"""

import math
from operator import itemgetter

from ..errors import MechanismError, RangeError, require_finite
from . import geometry
from .binding import Binding
from .state import INVALID, decode, encode
from .declarations import (  # noqa: F401  (the names models declare their variables with)
    EFFECT_PREFIX,
    INTEGRATORS,
    MAX_WALL_TIME,
    UNITS,
    Status,
    Variable,
    effect,
    input_,
    integrator_variables,
    motion_inputs,
    motion_outputs,
    non_negative,
    output,
    parameter,
)
from collections.abc import Callable, Sequence
from typing import Any

# The keys of an FMU state (MechSlave._get_fmu_state), each required to set one back.
_STATE_KEYS = (
    "values",
    "internal",
    "initialized",
    "initializing",
    "start_time",
    "time_reached",
    "pending_error",
)


def _tuple_getter(names: Sequence[str]) -> Callable[[dict[str, Any]], tuple[Any, ...]]:
    """A function of a dict returning the tuple of its values under ``names``."""
    if len(names) == 1:
        name = names[0]
        return lambda values: (values[name],)
    if not names:
        return lambda values: ()
    return itemgetter(*names)


def _all_finite(numbers: Sequence[float]) -> bool:
    """Whether every number is finite. One sum in C: NaN or infinity in it makes the sum
    non-finite; a non-finite sum of finite numbers (an overflow) is looked at one by one."""
    return math.isfinite(sum(numbers)) or all(map(math.isfinite, numbers))


def _same_time(a: float, b: float) -> bool:
    """Equal communication times up to the rounding of a host's own time keeping."""
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


class MechSlave(Binding):
    """Base of every mechfmu model. Subclasses set VARIABLES, check_parameters, update."""

    VARIABLES: tuple[Variable, ...] = ()
    # Outputs only an effect changes, by effect name: with the effect off they keep their
    # start values, so the per-step finiteness check leaves them out (it is what they cost).
    EFFECT_OUTPUTS: dict[str, tuple[str, ...]] = {}
    # False for a model whose update never changes its internal_state (a source's table
    # read at initialisation): its do_step then saves only the values for a rollback.
    STEP_CHANGES_STATE = True
    author = "mechfmu"
    license = "MIT"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.values: dict[str, Any] = {v.name: v.start for v in self.VARIABLES}  # by name
        self.declared = {v.name: v for v in self.VARIABLES}
        self.initialized = False
        self.initializing = False  # between fmi2EnterInitializationMode and fmi2Exit...
        self.stale = True  # initialisation-mode outputs need computing (an input changed)
        self.start_time = 0.0
        self.time_reached = 0.0  # end of the last step taken (s): where the next must start
        self.pending_error: str | None = None  # reported by the next doStep
        self.integrator: Any = (
            None  # an Integrator, set by IntegratingSlave.check_parameters (fmi/integrating.py)
        )
        self.real_inputs = tuple(
            v.name for v in self.VARIABLES if v.causality == "input" and v.kind is float
        )
        self.real_outputs = tuple(
            v.name for v in self.VARIABLES if v.causality == "output" and v.kind is float
        )
        self.real_parameters = tuple(
            v.name for v in self.VARIABLES if v.causality == "parameter" and v.kind is float
        )
        # whether do_step saves the internal state (a model without one has nothing to save)
        self.step_saves_state = (
            self.STEP_CHANGES_STATE and type(self).internal_state is not MechSlave.internal_state
        )
        self._inputs_of = _tuple_getter(self.real_inputs)
        self._outputs_of = _tuple_getter(self.real_outputs)
        # the outputs each effect idles while off: EFFECT_OUTPUTS and the geometry effect's
        # (told apart by their description, fmi/geometry.py)
        drawn = tuple(n for n in self.real_outputs if geometry.is_geometry(self.declared[n]))
        self._effect_outputs = {
            **self.EFFECT_OUTPUTS,
            **({geometry.GEOMETRY: drawn} if drawn else {}),
        }
        for variable in self.VARIABLES:
            self.register_declared(variable)
        self.finish_registration()

    # --- values, as the binding reads and writes them ---------------------------------
    def _set(self, name: str, value: Any) -> None:
        variable = self.declared[name]
        if variable.causality == "output":
            return  # outputs are never set by a host; pythonfmu's state restore calls this
        if variable.causality == "parameter" and self.initialized:
            self.pending_error = (
                f"{name} is a fixed parameter and cannot be changed after "
                f"initialisation (attempted {value!r}); value ignored"
            )
            self.log(self.pending_error, Status.error)
            return
        self.values[name] = variable.kind(value) if variable.kind is not float else float(value)
        self.stale = True

    # --- model contract -------------------------------------------------------------
    def check_parameters(self) -> None:
        """Validate parameters (raise MechanismError); called once at initialisation."""

    def update(self, time: float, step_size: float) -> Any:
        """Compute outputs at ``time`` from the current inputs (raise MechanismError)."""
        raise NotImplementedError

    def outputs_at_start(self, time: float) -> None:
        """Outputs at initialisation; models with internal state may override."""
        self.update(time, 0.0)

    def geometry_points(self) -> dict[str, float]:
        """The values of the geometry effect's outputs from the current values (a model
        that declares the effect implements it: fmi/geometry.py)."""
        raise NotImplementedError

    # --- FMI calls (never raise) ----------------------------------------------------
    def setup_experiment(
        self, start_time: float, stop_time: None = None, tolerance: None = None
    ) -> None:
        self.start_time = self.time_reached = float(start_time)

    def enter_initialization_mode(self) -> None:
        self.initializing, self.stale = True, True

    def _initial_outputs(self) -> str | None:
        """Outputs from the current parameters and inputs (FMI 2.0 InitialUnknowns).

        Read in initialization mode (libcosim passes them on before any FMU leaves it) and
        computed again at fmi2ExitInitializationMode. Returns the error text, or None; on an
        error the outputs keep their declared start values.
        """
        self.stale = False
        values_before = dict(self.values)
        try:
            self._build()
            self.outputs_at_start(self.start_time)
            self._check_outputs(values_before)
            return None
        except Exception as error:  # never raised into C++ (see the module docstring)
            for variable in self.VARIABLES:
                if variable.causality == "output":
                    self.values[variable.name] = variable.start
            return self._describe(error, self.start_time)

    def _build(self) -> None:
        """What the parameters define: checked and built (check_parameters; raises
        MechanismError), the geometry effect's outputs installed when it is on, the per-step
        output check narrowed to what the enabled effects change. A Real parameter that is
        NaN is refused first, whether or not this configuration uses it (the kinematic gear's
        dynamics parameters, say): NaN is never a value."""
        for name in self.real_parameters:
            if math.isnan(self.values[name]):
                raise RangeError(
                    name,
                    self.values[name],
                    "(-inf, inf)",
                    self.declared[name].unit or "",
                    "not a number: every Real parameter needs one, used or not",
                )
        self.check_parameters()
        geometry.install(self)  # the geometry effect's outputs, only when on
        self._watch_live_outputs()

    def _watch_live_outputs(self) -> None:
        """Check at every step only the outputs the enabled effects can change: with an
        effect off (EFFECT_OUTPUTS, the geometry effect) its outputs hold their start
        values."""
        values = self.values
        idle = {
            name
            for switch, names in self._effect_outputs.items()
            if not values[switch]
            for name in names
        }
        self._outputs_of = _tuple_getter(tuple(n for n in self.real_outputs if n not in idle))

    def refresh_initial_outputs(self) -> None:
        """Before the binding reads outputs: in initialisation mode, compute them from the
        parameters and inputs set so far (once per change)."""
        if self.initializing and self.stale:
            self._initial_outputs()

    def exit_initialization_mode(self) -> None:
        self.initializing = False
        # With the inputs the host has set by now; an error is reported at every doStep.
        self.pending_error = self._initial_outputs()
        if self.pending_error is not None:
            self.log(self.pending_error, Status.error)
        self.initialized = True

    def _check_outputs(self, values_before: dict[str, float]) -> None:
        """Raise MechanismError if an output is NaN or infinite (a safety net: the physics
        should have refused the values that led there)."""
        values = self.values
        if _all_finite(self._outputs_of(values)):
            return
        bad = [name for name in self.real_outputs if not math.isfinite(values[name])]
        if bad:
            raise MechanismError(
                "non-finite outputs "
                + ", ".join(f"{name} = {values[name]!r}" for name in bad)
                + " from inputs "
                + ", ".join(f"{name} = {values_before[name]!r}" for name in self.real_inputs)
                + "; the parameters or inputs are probably beyond the model's numerical range"
            )

    def do_step(self, current_time: float, step_size: float) -> bool:
        """One communication step: all of it, or nothing.

        A discarded step leaves the instance exactly as it was before the call (every
        variable and the internal state), so a host can retry it, shorter or with other
        inputs, or roll back with fmi2SetFMUstate.
        """
        values, integrator = self.values, self.integrator
        if (
            self.pending_error is None
            and self.initialized
            and 0.0 < step_size < math.inf
            and (integrator is None or _same_time(current_time, self.time_reached))
            and math.isfinite(sum(self._inputs_of(values)))
        ):
            # The usual step, with the checks of _checked_step passed in one test each (a
            # finite sum: no input is NaN or infinite). The same all-or-nothing contract.
            values_before = values.copy()
            internal_before = self.step_state() if self.step_saves_state else None
            try:
                if integrator is not None:
                    integrator.start_clock(values["max_wall_time"])
                self.update(current_time + step_size, step_size)
                if not math.isfinite(sum(self._outputs_of(values))):
                    self._check_outputs(values_before)
                self.time_reached = current_time + step_size
                return True
            except Exception as error:  # never raised into C++ (see the module docstring)
                values.update(values_before)  # in place: the registered getters hold it
                if internal_before is not None:
                    self.restore_step_state(internal_before)
                self.log(self._describe(error, current_time + step_size), Status.error)
                return False
        return self._checked_step(current_time, step_size)

    def _checked_step(self, current_time: float, step_size: float) -> bool:
        """do_step with every check spelled out: its errors, integrating models."""
        values_before = internal_before = None
        try:
            if self.pending_error is not None:
                # Stays pending: a model with invalid parameters cannot step at all.
                self.log(self.pending_error, Status.error)
                return False
            if not self.initialized:
                raise MechanismError(
                    "doStep before initialisation: call "
                    "fmi2EnterInitializationMode and "
                    "fmi2ExitInitializationMode first"
                )
            if not (math.isfinite(step_size) and step_size > 0.0):
                raise MechanismError(
                    f"communication step size = {step_size!r} s must be finite and > 0"
                )
            if self.integrator is not None and not _same_time(current_time, self.time_reached):
                raise MechanismError(
                    f"doStep from t = {current_time!r} s, but this instance's state is at "
                    f"t = {self.time_reached!r} s: a communication step must start where the "
                    "last one ended (roll back with fmi2SetFMUstate to step again from an "
                    "earlier time)"
                )
            values = self.values
            if not _all_finite(self._inputs_of(values)):
                for name in self.real_inputs:
                    if not math.isfinite(values[name]):
                        require_finite(name, values[name], self.declared[name].unit or "")
            values_before, internal_before = values.copy(), self.internal_state()
            if self.integrator is not None:
                self.integrator.start_clock(values["max_wall_time"])
            self.update(current_time + step_size, step_size)
            self._check_outputs(values_before)
            self.time_reached = current_time + step_size
            return True
        except Exception as error:
            if values_before is not None:
                self.values.update(values_before)  # in place: the registered getters hold it
                self.restore_internal_state(internal_before)
            self.log(self._describe(error, current_time + step_size), Status.error)
            return False

    def _describe(self, error: Exception, time: float) -> str:
        if isinstance(error, MechanismError):
            return f"{self.instance_name} at t = {time!r} s: {error}"
        return f"{self.instance_name} at t = {time!r} s: internal error {error!r}"

    # --- FMU state: every value plus the model's internal state ------------------------
    def internal_state(self) -> Any:
        """JSON-serialisable internal state beyond the variables (override if any)."""
        return {}

    def restore_internal_state(self, state: Any) -> None:
        """Inverse of internal_state."""

    def step_state(self) -> Any:
        """What do_step saves to undo a failed step: internal_state, unless a model has a
        cheaper form (any object; it never leaves the instance)."""
        return self.internal_state()

    def restore_step_state(self, state: Any) -> None:
        """Inverse of step_state."""
        self.restore_internal_state(state)

    def _get_fmu_state(self) -> dict[str, Any]:
        # A failed initialisation leaves no internal state to save (nor to step from).
        internal = None if self.pending_error is not None else self.internal_state()
        return {
            "values": dict(self.values),
            "internal": internal,
            "initialized": self.initialized,
            "initializing": self.initializing,
            "start_time": self.start_time,
            "time_reached": self.time_reached,
            "pending_error": self.pending_error,
        }

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        problem = self._state_problem(state)
        if problem is not None:  # reported as fmi2Error / fmi3Error by the C loader
            self.log(f"{self.instance_name}: {problem}; the instance is unchanged", Status.error)
            return
        values = state["values"]
        rebuild = state["internal"] is not None and (
            not self.initialized
            or any(
                values[v.name] != self.values[v.name]
                for v in self.VARIABLES
                if v.causality == "parameter"
            )
        )
        self.values.update(values)  # in place: the registered getters hold this dict
        if rebuild:
            # A state taken by another instance (another process): build what the parameters
            # define (integrator, mechanism, effects) before the internal state is put back.
            try:
                self._build()
            except Exception as error:  # never raised into C++ (see the module docstring)
                self.log(self._describe(error, state["time_reached"]), Status.error)
        if state["internal"] is not None:
            self.restore_internal_state(state["internal"])
        self.initialized = state["initialized"]
        self.initializing = state["initializing"]
        self.stale = True
        self.start_time = state["start_time"]
        self.time_reached = state["time_reached"]
        self.pending_error = state["pending_error"]

    def _state_problem(self, state: Any) -> str | None:
        """Why ``state`` is no FMU state of this model (None when it is one)."""
        if not isinstance(state, dict):
            return f"an FMU state must be a dict, not {type(state).__name__}"
        if INVALID in state:
            return str(state[INVALID])
        missing = set(_STATE_KEYS) - set(state)
        if missing:
            return f"the FMU state lacks {', '.join(sorted(missing))}"
        values = state["values"]
        if not isinstance(values, dict) or set(values) != set(self.declared):
            return "the FMU state's variables are not this model's"
        for name, value in values.items():
            kind = self.declared[name].kind
            if type(value) is not kind and not (kind is float and type(value) is int):
                return f"the FMU state gives {name} a {type(value).__name__}, not a {kind.__name__}"
        return None

    # pythonfmu calls these on the slave class to serialise and deserialise an FMU state
    # (fmi2SerializeFMUstate, fmi3SerializeFMUState ...): state.py's bit-exact JSON.
    @classmethod
    def _fmu_state_to_bytes(cls, state: dict[str, Any]) -> bytes:
        return encode(cls.__name__, state)

    @classmethod
    def _fmu_state_from_bytes(cls, data: bytes) -> Any:
        return decode(cls.__name__, data)
