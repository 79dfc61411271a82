"""Each FMU variable declared once, for both FMI versions (standard library only).

A model lists its variables in ``VARIABLES`` with the constructors below (name, type,
causality, unit, range, description, dependencies). The FMI 2.0 and FMI 3.0 bindings
(``fmi2.py``, ``fmi3.py``) derive registration, model description and units from them.
"""

import enum
from xml.etree.ElementTree import Element, SubElement
from typing import Any
from collections.abc import Callable


class Status(enum.IntEnum):
    """Status of a log message: the same names and numbers in FMI 2.0 and FMI 3.0 (pythonfmu's
    Fmi2Status and pythonfmu3's Fmi3Status both take it)."""

    ok = 0
    warning = 1
    discard = 2
    error = 3
    fatal = 4


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
    "W": {"kg": 1, "m": 2, "s": -3},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "m2": {"m": 2},
    "m3": {"m": 3},
    "m3/s": {"m": 3, "s": -1},
    "kg/m3": {"kg": 1, "m": -3},
    "kg.m2": {"kg": 1, "m": 2},
    "Hz": {"s": -1},
}

# A variable's value: Real, Integer, Boolean or String.
Value = float | int | bool | str


class Variable:
    """One FMU variable, declared once.

    kind: float, int, bool or str. causality: 'parameter', 'input' or 'output'.
    depends: for outputs, the names of the inputs they depend on directly.
    values: for str parameters, the accepted values (documented in the description).
    nominal: for a Real, its typical magnitude (FMI's nominal attribute), where the start
    value does not tell it (an input that starts at 0).
    """

    __slots__ = (
        "name",
        "kind",
        "causality",
        "start",
        "unit",
        "min",
        "max",
        "description",
        "depends",
        "values",
        "nominal",
    )

    def __init__(
        self,
        name: str,
        kind: type,
        causality: str,
        start: Value,
        description: str,
        unit: str | None = None,
        min: float | None = None,
        max: float | None = None,
        depends: tuple[str, ...] = (),
        values: tuple[str, ...] | None = None,
        nominal: float | None = None,
    ) -> None:
        if unit is not None and unit not in UNITS:
            raise ValueError(f"unit {unit!r} of {name} is not in UNITS")
        self.name, self.kind, self.causality, self.start = name, kind, causality, start
        self.description, self.unit, self.min, self.max = description, unit, min, max
        self.depends, self.values, self.nominal = tuple(depends), values, nominal


def with_starts(variables: tuple[Variable, ...], starts: dict[str, Value]) -> tuple[Variable, ...]:
    """``variables`` with the start values ``starts`` (name -> value, of the variable's own
    type) in place of the declared ones (an FMU built with a scene's settings)."""
    unknown = set(starts) - {v.name for v in variables}
    if unknown:
        raise ValueError(f"no variable {', '.join(sorted(unknown))} to give a start value")
    return tuple(
        Variable(
            v.name,
            v.kind,
            v.causality,
            v.kind(starts[v.name]) if v.name in starts else v.start,
            v.description,
            v.unit,
            v.min,
            v.max,
            v.depends,
            v.values,
            v.nominal,
        )
        for v in variables
    )


def parameter(
    name: str,
    start: Value,
    description: str,
    unit: str | None = None,
    min: float | None = None,
    max: float | None = None,
    values: tuple[str, ...] | None = None,
) -> Variable:
    """A fixed parameter; its type follows the start value."""
    return Variable(
        name, type(start), "parameter", start, description, unit, min, max, values=values
    )


def non_negative(name: str, start: float, description: str, unit: str) -> Variable:
    """A Real parameter that cannot be negative (a length, mass, stiffness, pressure ...) in
    ``unit``."""
    return parameter(name, start, description, unit, min=0.0)


def input_(
    name: str,
    start: Value,
    description: str,
    unit: str | None = None,
    min: float | None = None,
    max: float | None = None,
    nominal: float | None = None,
) -> Variable:
    """A continuous input with a start value (and a typical magnitude: nominal)."""
    return Variable(name, type(start), "input", start, description, unit, min, max, nominal=nominal)


def output(
    name: str,
    start: Value,
    description: str,
    unit: str | None = None,
    depends: tuple[str, ...] = (),
    min: float | None = None,
    max: float | None = None,
) -> Variable:
    """An output computed from inputs and parameters (initial = calculated)."""
    return Variable(name, type(start), "output", start, description, unit, min, max, depends)


def motion_units(unit: str) -> tuple[str, str, str]:
    """Units of a coordinate in ``unit`` and of its first two time derivatives."""
    return unit, f"{unit}/s", f"{unit}/s2"


def motion_inputs(
    names: tuple[str, str, str],
    unit: str,
    descriptions: tuple[str, ...],
    start: float = 0.0,
    nominal: float | None = None,
) -> tuple[Variable, ...]:
    """Inputs q, dq/dt, d2q/dt2 of one driving coordinate (``names`` in that order, units
    ``unit``, ``unit``/s, ``unit``/s2); q starts at ``start`` with typical magnitude
    ``nominal`` (in ``unit``), its rates at 0."""
    starts, nominals = (start, 0.0, 0.0), (nominal, None, None)
    return tuple(
        input_(name, value, text, unit=u, nominal=n)
        for name, value, text, u, n in zip(
            names, starts, descriptions, motion_units(unit), nominals
        )
    )


def motion_outputs(
    names: tuple[str, str, str],
    unit: str,
    description: str | tuple[str, str, str],
    depends: tuple[str, ...] = (),
) -> tuple[Variable, ...]:
    """Outputs q, dq/dt, d2q/dt2 of one coordinate (``names`` in that order, units ``unit``,
    ``unit``/s, ``unit``/s2). ``description``: of q (the rates are described as d(q)/dt and
    d(dq/dt)/dt) or of all three. ``depends``: the driving inputs (position, rate,
    acceleration); q depends on the first, its rate on two, its acceleration on all."""
    if isinstance(description, str):
        description = (description, f"d({names[0]})/dt", f"d({names[1]})/dt")
    return tuple(
        output(name, 0.0, text, unit=u, depends=depends[: order + 1])
        for order, (name, text, u) in enumerate(zip(names, description, motion_units(unit)))
    )


EFFECT_PREFIX = "Effect: "


def only_with(parameter_name: str, value: str, description: str) -> str:
    """The description of an input read only while parameter ``parameter_name`` is
    ``value``: "Only with P = V: ...". The master (cosim/master.py) accepts it unfed in
    the other configurations."""
    return f"Only with {parameter_name} = {value}: {description}"


def effect(name: str, description: str) -> Variable:
    """A Boolean parameter that switches a physical effect on (all effects default off).

    Scenes list effects by name; the master finds them by this description prefix.
    """
    return parameter(name, False, EFFECT_PREFIX + description)


INTEGRATORS = ("euler", "rk4", "dopri5", "radau")
MAX_WALL_TIME = 60.0  # s, default wall-clock bound of one communication step


def integrator_variables(
    default: str = "dopri5",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    max_substep: float = 1e-3,
    own_methods: tuple[tuple[str, str], ...] = (),
) -> tuple[Variable, ...]:
    """The parameters and counters every integrating model declares, by the same names.

    A model that declares them is an IntegratingSlave, which keeps its integrator in
    ``self.integrator``: MechSlave then
    bounds the wall-clock time of each communication step by ``max_wall_time``.
    ``own_methods``: (name, description) of methods only this model has (e.g. ValveSpring's
    exact), accepted besides INTEGRATORS.
    """
    methods = INTEGRATORS + tuple(name for name, _ in own_methods)
    return (
        parameter(
            "integrator",
            default,
            "Integration method inside each communication step: "
            + ", ".join(methods)
            + " (euler, rk4: fixed sub-step max_substep; "
            "dopri5: adaptive Dormand-Prince 5(4); radau: implicit Radau IIA, stiff cases"
            + "".join(f"; {name}: {text}" for name, text in own_methods)
            + ")",
            values=methods,
        ),
        parameter("rtol", rtol, "Relative tolerance of the adaptive methods", unit="1", min=0.0),
        parameter(
            "atol",
            atol,
            "Absolute tolerance of the adaptive methods, in the units of each state variable",
            unit="1",
            min=0.0,
        ),
        parameter(
            "max_substep",
            max_substep,
            "Largest internal sub-step (the fixed sub-step of euler and rk4)",
            unit="s",
            min=0.0,
        ),
        parameter(
            "max_wall_time",
            MAX_WALL_TIME,
            "Wall-clock bound of one communication "
            "step; a step that takes longer is discarded with an error (inf: no bound)",
            unit="s",
            min=0.0,
        ),
        output("rhs_evaluations", 0, "Right-hand-side evaluations so far"),
        output("substeps", 0, "Accepted internal sub-steps so far"),
    )


def unit_definitions(units: Any) -> Any:
    """The UnitDefinitions element of the unit names ``units`` (None skipped; None when no
    unit is left); its form is the same in FMI 2.0 and FMI 3.0."""
    used = sorted({unit for unit in units if unit is not None})
    if not used:
        return None
    units = Element("UnitDefinitions")
    for unit in used:
        SubElement(
            SubElement(units, "Unit", name=unit),
            "BaseUnit",
            {key: str(value) for key, value in UNITS[unit].items()},
        )
    return units


def bound_text(variable: Any, bound: Any) -> Any:
    """A min or max attribute value of ``variable`` in the model description."""
    return repr(float(bound)) if variable.kind is float else str(bound)


def describe(element: Any, variable: Any) -> None:
    """Write ``variable``'s unit, min, max and nominal onto its typed element of a model description
    (FMI 2.0: the <Real> inside <ScalarVariable>; FMI 3.0: the <Float64> itself), and its
    start value exactly (pythonfmu and pythonfmu3 write 16 significant digits)."""
    if variable.kind is float and element.get("start") is not None:
        element.set("start", repr(float(variable.start)))
    if variable.unit is not None:
        element.set("unit", variable.unit)
    for attribute in ("min", "max"):
        bound = getattr(variable, attribute)
        if bound is not None:
            element.set(attribute, bound_text(variable, bound))
    if variable.nominal is not None:
        element.set("nominal", repr(float(variable.nominal)))


def fmi_attributes(variable: Variable) -> tuple:
    """(variability, initial or None) of a declared variable, as the names both FMI versions
    use: parameters are fixed and exact; Real inputs and outputs continuous, others discrete;
    outputs calculated (computed at initialisation, so no start value in the description)."""
    if variable.causality == "parameter":
        return "fixed", "exact"
    variability = "continuous" if variable.kind is float else "discrete"
    return variability, ("calculated" if variable.causality == "output" else None)


def registered(
    variable: Variable, vocabulary: tuple[Any, ...], getter: Callable, setter: Callable
) -> Any:
    """The pythonfmu or pythonfmu3 variable object of a declared variable.

    vocabulary: that package's (types, causalities, variabilities, initials): types maps
    float, int, bool, str to its variable classes, the others are its enums; getter(),
    setter(value): the value's accessors.
    """
    types, causalities, variabilities, initials = vocabulary
    variability, initial = fmi_attributes(variable)
    options = dict(variability=getattr(variabilities, variability))
    if initial is not None:
        options["initial"] = getattr(initials, initial)
    return types[variable.kind](
        variable.name,
        causality=getattr(causalities, variable.causality),
        description=variable.description,
        getter=getter,
        setter=setter,
        **options,
    )


def register_declared(slave: Any, variable: Variable, vocabulary: tuple[Any, ...]) -> None:
    """Register ``variable`` on a pythonfmu or pythonfmu3 ``slave``, its value living in
    ``slave.values`` (set through ``slave._set``). ``vocabulary``: the package's (types,
    causalities, variabilities, initials), as ``registered`` takes them."""
    name, values = variable.name, slave.values
    slave.register_variable(
        registered(
            variable,
            vocabulary,
            getter=lambda: values[name],
            setter=lambda value: slave._set(name, value),
        )
    )


def reading_initial_outputs(read: Callable) -> Callable:
    """A binding's get method: ``read`` (the package's own) after refreshing the outputs in
    initialisation mode (MechSlave.refresh_initial_outputs)."""

    def get(self: Any, vrs: Any):
        self.refresh_initial_outputs()
        return read(self, vrs)

    get.__name__ = read.__name__
    return get
