"""The FMU slave base: declare each variable once, derive everything else from it.

Runs inside the FMU (standard library + pythonfmu only). A model subclasses ``MechSlave``,
lists its variables in ``VARIABLES`` (name, type, causality, unit, range, description,
dependencies) and implements ``check_parameters`` and ``update``. The base class

- registers the variables with pythonfmu and keeps their values in one dict;
- writes a complete model description: units (UnitDefinitions), min/max, descriptions,
  start values, Outputs with their input dependencies and InitialUnknowns;
- never lets a Python exception reach pythonfmu's C++ layer. pythonfmu 0.7 turns any
  exception into fmi2Fatal and leaves the GIL state broken, which crashes the host on its
  next call (measured with a probe FMU). Errors are logged instead (status error, naming
  the variable, value and range) and the step returns fmi2Discard, the only non-OK status
  pythonfmu 0.7 can return without raising. A discarded step leaves the instance as before.
"""

import math
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Boolean, Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

from ..errors import MechanismError, require_finite

# Base-unit exponents of every unit a model may declare (FMI 2.0 UnitDefinitions).
UNITS = {
    "1": {},  # dimensionless (ratios, commands, coefficients)
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "s": {"s": 1},
    "kg": {"kg": 1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N/s": {"kg": 1, "m": 1, "s": -3},
    "N/s2": {"kg": 1, "m": 1, "s": -4},
    "N/m": {"kg": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "N.s/m": {"kg": 1, "s": -1},
    "J": {"kg": 1, "m": 2, "s": -2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "m2": {"m": 2},
    "m3": {"m": 3},
    "m3/s": {"m": 3, "s": -1},
    "kg/m3": {"kg": 1, "m": -3},
    "kg.m2": {"kg": 1, "m": 2},
    "Hz": {"s": -1},
}

_FMI_TYPES = {float: Real, int: Integer, bool: Boolean, str: String}


class Variable:
    """One FMU variable, declared once.

    kind: float, int, bool or str. causality: 'parameter', 'input' or 'output'.
    depends: for outputs, the names of the inputs they depend on directly.
    values: for str parameters, the accepted values (documented in the description).
    nominal: for a Real, its typical magnitude (FMI's nominal attribute), where the start
    value does not tell it (an input that starts at 0).
    """

    __slots__ = ("name", "kind", "causality", "start", "unit", "min", "max",
                 "description", "depends", "values", "nominal")

    def __init__(self, name, kind, causality, start, description, unit=None,
                 min=None, max=None, depends=(), values=None, nominal=None):
        if unit is not None and unit not in UNITS:
            raise ValueError(f"unit {unit!r} of {name} is not in UNITS")
        self.name, self.kind, self.causality, self.start = name, kind, causality, start
        self.description, self.unit, self.min, self.max = description, unit, min, max
        self.depends, self.values, self.nominal = tuple(depends), values, nominal


def parameter(name, start, description, unit=None, min=None, max=None, values=None):
    """A fixed parameter; its type follows the start value."""
    return Variable(name, type(start), "parameter", start, description, unit, min, max,
                    values=values)


def input_(name, start, description, unit=None, min=None, max=None, nominal=None):
    """A continuous input with a start value (and a typical magnitude: nominal)."""
    return Variable(name, type(start), "input", start, description, unit, min, max,
                    nominal=nominal)


def output(name, start, description, unit=None, depends=(), min=None, max=None):
    """An output computed from inputs and parameters (initial = calculated)."""
    return Variable(name, type(start), "output", start, description, unit, min, max, depends)


EFFECT_PREFIX = "Effect: "


def effect(name, description):
    """A Boolean parameter that switches a physical effect on (all effects default off).

    Scenes list effects by name; the master finds them by this description prefix.
    """
    return parameter(name, False, EFFECT_PREFIX + description)


INTEGRATORS = ("euler", "rk4", "dopri5", "radau")
MAX_WALL_TIME = 60.0  # s, default wall-clock bound of one communication step


def integrator_variables(default="dopri5", rtol=1e-8, atol=1e-10, max_substep=1e-3):
    """The parameters and counters every integrating model declares, by the same names.

    A model that declares them is an IntegratingSlave, which keeps its integrator in
    ``self.integrator``: MechSlave then
    bounds the wall-clock time of each communication step by ``max_wall_time``.
    """
    return (
        parameter("integrator", default, "Integration method inside each communication step: "
                  + ", ".join(INTEGRATORS) + " (euler, rk4: fixed sub-step max_substep; "
                  "dopri5: adaptive Dormand-Prince 5(4); radau: implicit Radau IIA, stiff cases)",
                  values=INTEGRATORS),
        parameter("rtol", rtol, "Relative tolerance of the adaptive methods", unit="1", min=0.0),
        parameter("atol", atol, "Absolute tolerance of the adaptive methods, in the units of "
                  "each state variable", unit="1", min=0.0),
        parameter("max_substep", max_substep, "Largest internal sub-step (the fixed sub-step "
                  "of euler and rk4)", unit="s", min=0.0),
        parameter("max_wall_time", MAX_WALL_TIME, "Wall-clock bound of one communication "
                  "step; a step that takes longer is discarded with an error (inf: no bound)",
                  unit="s", min=0.0),
        output("rhs_evaluations", 0, "Right-hand-side evaluations so far"),
        output("substeps", 0, "Accepted internal sub-steps so far"),
    )


def _same_time(a, b):
    """Equal communication times up to the rounding of a host's own time keeping."""
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


class MechSlave(Fmi2Slave):
    """Base of every mechfmu model. Subclasses set VARIABLES, check_parameters, update."""

    VARIABLES = ()
    author = "mechfmu"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.values = {v.name: v.start for v in self.VARIABLES}
        self.declared = {v.name: v for v in self.VARIABLES}
        self.initialized = False
        self.initializing = False  # between fmi2EnterInitializationMode and fmi2Exit...
        self.stale = True  # initialisation-mode outputs need computing (an input changed)
        self.start_time = 0.0
        self.time_reached = 0.0  # end of the last step taken (s): where the next must start
        self.pending_error = None  # reported by the next doStep
        self.integrator = None  # set by IntegratingSlave.check_parameters (fmi/integrating.py)
        self.real_inputs = tuple(v.name for v in self.VARIABLES
                                 if v.causality == "input" and v.kind is float)
        self.real_outputs = tuple(v.name for v in self.VARIABLES
                                  if v.causality == "output" and v.kind is float)
        for variable in self.VARIABLES:
            self._register(variable)

    # --- registration ---------------------------------------------------------------
    def _register(self, variable):
        name = variable.name
        causality = getattr(Fmi2Causality, variable.causality)
        if variable.causality == "parameter":
            options = dict(variability=Fmi2Variability.fixed, initial=Fmi2Initial.exact)
        elif variable.causality == "input":
            options = dict(variability=(Fmi2Variability.continuous if variable.kind is float
                                        else Fmi2Variability.discrete))
        else:
            options = dict(variability=(Fmi2Variability.continuous if variable.kind is float
                                        else Fmi2Variability.discrete),
                           initial=Fmi2Initial.calculated)
        values = self.values
        self.register_variable(_FMI_TYPES[variable.kind](
            name, causality=causality, description=variable.description,
            getter=lambda: values[name],
            setter=lambda value: self._set(name, value), **options))

    def _set(self, name, value):
        variable = self.declared[name]
        if variable.causality == "output":
            return  # outputs are never set by a host; pythonfmu's state restore calls this
        if variable.causality == "parameter" and self.initialized:
            self.pending_error = (f"{name} is a fixed parameter and cannot be changed after "
                                  f"initialisation (attempted {value!r}); value ignored")
            self.log(self.pending_error, Fmi2Status.error)
            return
        self.values[name] = variable.kind(value) if variable.kind is not float else float(value)
        self.stale = True

    # --- model contract -------------------------------------------------------------
    def check_parameters(self):
        """Validate parameters (raise MechanismError); called once at initialisation."""

    def update(self, time, step_size):
        """Compute outputs at ``time`` from the current inputs (raise MechanismError)."""
        raise NotImplementedError

    def outputs_at_start(self, time):
        """Outputs at initialisation; models with internal state may override."""
        self.update(time, 0.0)

    # --- FMI calls (never raise) ----------------------------------------------------
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.start_time = self.time_reached = float(start_time)

    def enter_initialization_mode(self):
        self.initializing, self.stale = True, True

    def _initial_outputs(self):
        """Outputs from the current parameters and inputs (FMI 2.0 InitialUnknowns).

        Read in initialization mode (libcosim passes them on before any FMU leaves it) and
        computed again at fmi2ExitInitializationMode. Returns the error text, or None; on an
        error the outputs keep their declared start values.
        """
        self.stale = False
        values_before = dict(self.values)
        try:
            self.check_parameters()
            self.outputs_at_start(self.start_time)
            self._check_outputs(values_before)
            return None
        except Exception as error:  # never raised into C++ (see the module docstring)
            for variable in self.VARIABLES:
                if variable.causality == "output":
                    self.values[variable.name] = variable.start
            return self._describe(error, self.start_time)

    def get_real(self, vrs):
        if self.initializing and self.stale:
            self._initial_outputs()
        return super().get_real(vrs)

    def get_integer(self, vrs):
        if self.initializing and self.stale:
            self._initial_outputs()
        return super().get_integer(vrs)

    def get_boolean(self, vrs):
        if self.initializing and self.stale:
            self._initial_outputs()
        return super().get_boolean(vrs)

    def exit_initialization_mode(self):
        self.initializing = False
        # With the inputs the host has set by now; an error is reported at every doStep.
        self.pending_error = self._initial_outputs()
        if self.pending_error is not None:
            self.log(self.pending_error, Fmi2Status.error)
        self.initialized = True

    def _check_outputs(self, values_before):
        """Raise MechanismError if an output is NaN or infinite (a safety net: the physics
        should have refused the values that led there)."""
        values = self.values
        bad = [name for name in self.real_outputs if not math.isfinite(values[name])]
        if bad:
            raise MechanismError(
                "non-finite outputs " + ", ".join(f"{name} = {values[name]!r}" for name in bad)
                + " from inputs " + ", ".join(f"{name} = {values_before[name]!r}"
                                              for name in self.real_inputs)
                + "; the parameters or inputs are probably beyond the model's numerical range")

    def do_step(self, current_time, step_size):
        """One communication step: all of it, or nothing.

        A discarded step leaves the instance exactly as it was before the call (every
        variable and the internal state), so a host can retry it, shorter or with other
        inputs, or roll back with fmi2SetFMUstate.
        """
        values_before = internal_before = None
        try:
            if self.pending_error is not None:
                # Stays pending: a model with invalid parameters cannot step at all.
                self.log(self.pending_error, Fmi2Status.error)
                return False
            if not self.initialized:
                raise MechanismError("doStep before initialisation: call "
                                     "fmi2EnterInitializationMode and "
                                     "fmi2ExitInitializationMode first")
            if not (math.isfinite(step_size) and step_size > 0.0):
                raise MechanismError(f"communication step size = {step_size!r} s must be "
                                     f"finite and > 0")
            if self.integrator is not None and not _same_time(current_time, self.time_reached):
                raise MechanismError(
                    f"doStep from t = {current_time!r} s, but this instance's state is at "
                    f"t = {self.time_reached!r} s: a communication step must start where the "
                    "last one ended (roll back with fmi2SetFMUstate to step again from an "
                    "earlier time)")
            values = self.values
            for name in self.real_inputs:
                if not math.isfinite(values[name]):
                    require_finite(name, values[name], self.declared[name].unit or "")
            values_before, internal_before = dict(values), self.internal_state()
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
            self.log(self._describe(error, current_time + step_size), Fmi2Status.error)
            return False

    def _describe(self, error, time):
        if isinstance(error, MechanismError):
            return f"{self.instance_name} at t = {time!r} s: {error}"
        return f"{self.instance_name} at t = {time!r} s: internal error {error!r}"

    # --- FMU state: every value plus the model's internal state ------------------------
    def internal_state(self):
        """JSON-serialisable internal state beyond the variables (override if any)."""
        return {}

    def restore_internal_state(self, state):
        """Inverse of internal_state."""

    def _get_fmu_state(self):
        # A failed initialisation leaves no internal state to save (nor to step from).
        internal = None if self.pending_error is not None else self.internal_state()
        return {"values": dict(self.values), "internal": internal,
                "initialized": self.initialized, "start_time": self.start_time,
                "time_reached": self.time_reached,
                "pending_error": self.pending_error}

    def _set_fmu_state(self, state):
        self.values.update(state["values"])  # in place: the registered getters hold this dict
        if state["internal"] is not None:
            self.restore_internal_state(state["internal"])
        self.initialized = state["initialized"]
        self.start_time = state["start_time"]
        self.time_reached = state["time_reached"]
        self.pending_error = state["pending_error"]

    # --- model description ----------------------------------------------------------
    def to_xml(self, model_options=dict()):
        root = super().to_xml(model_options)
        used_units = set()
        for element in root.iter("ScalarVariable"):
            variable = self.declared.get(element.get("name"))
            if variable is None:
                continue
            typed = element[0]
            if variable.unit is not None:
                typed.set("unit", variable.unit)
                used_units.add(variable.unit)
            for attribute in ("min", "max"):
                bound = getattr(variable, attribute)
                if bound is not None:
                    typed.set(attribute, repr(float(bound)) if variable.kind is float else str(bound))
            if variable.nominal is not None:
                typed.set("nominal", repr(float(variable.nominal)))
        if used_units:
            units = Element("UnitDefinitions")
            for unit in sorted(used_units):
                SubElement(SubElement(units, "Unit", name=unit), "BaseUnit",
                           {key: str(value) for key, value in UNITS[unit].items()})
            root.insert(list(root).index(root.find("CoSimulation")) + 1, units)
        root.remove(root.find("ModelStructure"))
        root.append(self._model_structure())
        return root

    def _model_structure(self):
        index = {v.name: i for i, v in enumerate(self.VARIABLES, start=1)}
        structure = Element("ModelStructure")
        outputs = [v for v in self.VARIABLES if v.causality == "output"]
        if outputs:
            node = SubElement(structure, "Outputs")
            for variable in outputs:
                depends = " ".join(str(index[name]) for name in variable.depends)
                SubElement(node, "Unknown", index=str(index[variable.name]),
                           dependencies=depends)
            # Calculated outputs are initial unknowns; without a dependencies attribute
            # they may depend on every known (parameters and inputs).
            node = SubElement(structure, "InitialUnknowns")
            for variable in outputs:
                SubElement(node, "Unknown", index=str(index[variable.name]))
        return structure
