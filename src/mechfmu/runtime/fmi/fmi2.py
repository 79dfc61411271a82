"""FMI 2.0 binding of MechSlave over pythonfmu 0.7 (runs inside the FMU).

Registers the declared variables (declarations.py) with pythonfmu and writes what pythonfmu's
model description lacks: units, min/max, Outputs with their input dependencies and
InitialUnknowns. It relies on the MechSlave above it for ``values``, ``declared``,
``VARIABLES``, ``_set`` and ``refresh_initial_outputs``.
"""

from collections.abc import Callable
from typing import Any
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability
from pythonfmu import Boolean, Integer, Real, String

from .declarations import describe, register_declared, unit_definitions
from .declarations import Variable

_FMI_TYPES = {float: Real, int: Integer, bool: Boolean, str: String}
_VOCABULARY = (_FMI_TYPES, Fmi2Causality, Fmi2Variability, Fmi2Initial)


class Fmi2Binding(Fmi2Slave):
    """pythonfmu's Fmi2Slave, fed from MechSlave's declarations."""

    def register_declared(self, variable: Variable) -> None:
        """Register one declared variable; its value lives in self.values."""
        register_declared(self, variable, _VOCABULARY)

    def finish_registration(self) -> None:
        """Tables for the per-step gets and sets: value reference -> name of every Real,
        Integer and Boolean, and of every Real input (what a host sets between steps)."""
        reals = {vr: v.name for vr, v in self.vars.items() if isinstance(v, Real)}
        self._real_names = reals
        self._integer_names = {vr: v.name for vr, v in self.vars.items() if isinstance(v, Integer)}
        self._boolean_names = {vr: v.name for vr, v in self.vars.items() if isinstance(v, Boolean)}
        self._real_input_names = {
            vr: name for vr, name in reals.items() if self.declared[name].causality == "input"
        }

    def get_real(self, vrs: list[int]) -> list[float]:
        """fmi2GetReal: one dict look-up per variable (pythonfmu's own calls a getter
        closure per variable and checks its type). In initialisation mode the outputs are
        computed first from what the host has set so far."""
        if self.initializing and self.stale:
            self.refresh_initial_outputs()
        values, names = self.values, self._real_names
        try:
            return [values[names[vr]] for vr in vrs]
        except KeyError:  # not a Real: pythonfmu's own answer (its TypeError)
            return Fmi2Slave.get_real(self, vrs)

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        """fmi2SetReal: Real inputs stored directly; anything else (parameters, outputs,
        not a Real) through pythonfmu's setter, i.e. MechSlave._set with its checks."""
        inputs, store = self._real_input_names, self.values
        for vr, value in zip(vrs, values):
            name = inputs.get(vr)
            if name is None:
                Fmi2Slave.set_real(self, [vr], [value])
            else:
                store[name] = float(value)
                self.stale = True

    def get_integer(self, vrs: list[int]) -> list[int]:
        """fmi2GetInteger: as get_real, each value as int (as pythonfmu's: the C side reads
        a C long)."""
        return self._get_converted(vrs, self._integer_names, int, Fmi2Slave.get_integer)

    def get_boolean(self, vrs: list[int]) -> list[bool]:
        """fmi2GetBoolean: as get_real, each value as bool."""
        return self._get_converted(vrs, self._boolean_names, bool, Fmi2Slave.get_boolean)

    def _get_converted(
        self,
        vrs: list[int],
        names: dict[int, str],
        convert: Callable[[Any], Any],
        own: Callable[[Any, list[int]], list[Any]],
    ) -> list[Any]:
        """The values of ``vrs`` (all in ``names``: value reference -> name) through
        ``convert``, one dict look-up each (pythonfmu's ``own`` calls a getter closure per
        variable and checks its type: 1 us of a 4-integer get); a reference not in
        ``names`` gets ``own``'s answer (its TypeError)."""
        if self.initializing and self.stale:
            self.refresh_initial_outputs()
        values = self.values
        try:
            return [convert(values[names[vr]]) for vr in vrs]
        except KeyError:
            return own(self, vrs)

    def to_xml(self, model_options: Any = dict()) -> Any:
        root = super().to_xml(model_options)
        for element in root.iter("ScalarVariable"):
            variable = self.declared.get(element.get("name"))
            if variable is None:
                continue
            describe(element[0], variable)
        units = unit_definitions(v.unit for v in self.VARIABLES)
        if units is not None:
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
                SubElement(node, "Unknown", index=str(index[variable.name]), dependencies=depends)
            # Calculated outputs are initial unknowns; without a dependencies attribute
            # they may depend on every known (parameters and inputs).
            node = SubElement(structure, "InitialUnknowns")
            for variable in outputs:
                SubElement(node, "Unknown", index=str(index[variable.name]))
        return structure
