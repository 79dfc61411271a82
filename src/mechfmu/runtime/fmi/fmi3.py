"""FMI 3.0 binding of MechSlave over pythonfmu3 (runs inside an FMU built with
``mechfmu build --fmi-version 3``; binding.py selects it there).

The same declarations as FMI 2.0 (declarations.py): Real becomes Float64, Integer Int32. The
value references are those of the FMI 2.0 FMU (the declared variables in order, from 0); the
independent variable ``time``, which FMI 3.0 requires, comes after them. Outputs read in
initialisation mode are computed from what the host has set so far, as in FMI 2.0. It relies
on the MechSlave above it for ``values``, ``declared``, ``VARIABLES``, ``_set``,
``time_reached`` and ``refresh_initial_outputs``.
"""

from typing import Any
from xml.etree.ElementTree import Element, SubElement

from pythonfmu3 import Fmi3Causality, Fmi3Initial, Fmi3Slave, Fmi3Variability
from pythonfmu3 import Boolean, Float64, Int32, String

from .declarations import describe, reading_initial_outputs, register_declared, unit_definitions

_FMI_TYPES = {float: Float64, int: Int32, bool: Boolean, str: String}
_VOCABULARY = (_FMI_TYPES, Fmi3Causality, Fmi3Variability, Fmi3Initial)
_MODEL_ATTRIBUTES = ("description", "author", "license")


class Fmi3Binding(Fmi3Slave):
    """pythonfmu3's Fmi3Slave, fed from MechSlave's declarations."""

    def register_declared(self, variable: Any) -> None:
        """Register one declared variable; its value lives in self.values."""
        register_declared(self, variable, _VOCABULARY)

    def finish_registration(self) -> None:
        """The independent variable: the instance's time, the end of its last step (s)."""
        self.register_variable(
            Float64(
                "time",
                causality=Fmi3Causality.independent,
                variability=Fmi3Variability.continuous,
                description="Simulation time",
                unit="s",
                getter=lambda: self.time_reached,
            )
        )

    # Outputs read in initialisation mode are computed from what the host has set so far.
    get_float64 = reading_initial_outputs(Fmi3Slave.get_float64)
    get_int32 = reading_initial_outputs(Fmi3Slave.get_int32)
    get_boolean = reading_initial_outputs(Fmi3Slave.get_boolean)

    def to_xml(self, model_options: Any = dict()) -> Any:
        root = super().to_xml(model_options)
        for attribute in _MODEL_ATTRIBUTES:  # class attributes of the model
            value = getattr(type(self), attribute, None)
            if isinstance(value, str):
                root.set(attribute, value)
        for element in root.find("ModelVariables"):
            variable = self.declared.get(element.get("name"))
            if variable is None:
                continue
            describe(element, variable)
        units = unit_definitions([*(v.unit for v in self.VARIABLES), "s"])
        root.insert(list(root).index(root.find("CoSimulation")) + 1, units)
        root.remove(root.find("ModelStructure"))
        root.append(self._model_structure())
        return root

    def _model_structure(self):
        reference = {v.name: i for i, v in enumerate(self.VARIABLES)}
        structure = Element("ModelStructure")
        outputs = [v for v in self.VARIABLES if v.causality == "output"]
        for variable in outputs:
            SubElement(
                structure,
                "Output",
                valueReference=str(reference[variable.name]),
                dependencies=" ".join(str(reference[name]) for name in variable.depends),
            )
        # Without a dependencies attribute an initial unknown may depend on every known.
        for variable in outputs:
            SubElement(structure, "InitialUnknown", valueReference=str(reference[variable.name]))
        return structure
