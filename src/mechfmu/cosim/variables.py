"""FMI variables as the master reads, sets and records them (host side), FMI 2.0 and 3.0.

The master moves values through the FMUs' C functions in typed buffers; this module says,
for each type of either version, which function (fmi2GetReal, fmi3GetInt64 ...) and which
C element and ``array`` code carry it, which Python values a scene may give it, and what a
variable's unit is (its own, or that of its declared type). Enumerations are set by the name
of an item or by its value, and read and recorded as their value.
"""

from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING, Any

from .scene import SceneError

if TYPE_CHECKING:  # annotations only
    from fmpy.model_description import ModelVariable

# The type in the name of the get and set functions (fmi2GetInteger, fmi3GetInt64 ...).
_CALLED = {
    2: {"Enumeration": "Integer"},
    3: {"Enumeration": "Int64"},
}
# (C element, array code) of each type's buffer; None: no buffer (String: char pointers).
_ELEMENTS: dict[str, tuple[Any, str | None]] = {
    "Real": (ctypes.c_double, "d"),
    "Float64": (ctypes.c_double, "d"),
    "Float32": (ctypes.c_float, "f"),
    "Integer": (ctypes.c_int32, "i"),
    "Int8": (ctypes.c_int8, "b"),
    "UInt8": (ctypes.c_uint8, "B"),
    "Int16": (ctypes.c_int16, "h"),
    "UInt16": (ctypes.c_uint16, "H"),
    "Int32": (ctypes.c_int32, "i"),
    "UInt32": (ctypes.c_uint32, "I"),
    "Int64": (ctypes.c_int64, "q"),
    "UInt64": (ctypes.c_uint64, "Q"),
    "String": (ctypes.c_char_p, None),
}
_BOOLEANS = {2: (ctypes.c_int32, "i"), 3: (ctypes.c_bool, "B")}  # fmi2Boolean is an int
_FLOATS = {"Real", "Float64", "Float32"}
_INTEGERS = {"Integer", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64"}


def called_type(version: int, fmi_type: str) -> str:
    """The type name in the get/set functions of FMI ``version`` for ``fmi_type``."""
    return _CALLED[version].get(fmi_type, fmi_type)


def element(version: int, fmi_type: str) -> tuple[Any, str | None]:
    """(ctypes element, array code or None) of a buffer of ``fmi_type`` values; KeyError for
    types the master does not move (Binary, Clock)."""
    called = called_type(version, fmi_type)
    if called == "Boolean":
        return _BOOLEANS[version]
    return _ELEMENTS[called]


_SAME = {"Real": "Float64", "Integer": "Int32"}  # FMI 2.0 names of FMI 3.0 types


def connectable(source: tuple[int, str], target: tuple[int, str]) -> bool:
    """Whether an output of (FMI version, type) ``source`` can feed an input of ``target``:
    the same type (Real and Float64, Integer and Int32 are one) in buffers of one layout."""
    (source_version, source_type), (target_version, target_type) = source, target
    return _SAME.get(source_type, source_type) == _SAME.get(target_type, target_type) and (
        element(source_version, source_type) == element(target_version, target_type)
    )


def movable(version: int, fmi_type: str) -> bool:
    """Whether the master can connect and set variables of ``fmi_type``."""
    try:
        element(version, fmi_type)
    except KeyError:
        return False
    return True


def recordable(version: int, fmi_type: str) -> bool:
    """Whether the master records variables of ``fmi_type`` (result columns are numbers)."""
    return movable(version, fmi_type) and element(version, fmi_type)[1] is not None


def unit_of(variable: ModelVariable) -> str | None:
    """The variable's unit: its own, else its declared type's."""
    unit = getattr(variable, "unit", None)
    if unit:
        return str(unit)
    declared = getattr(variable, "declaredType", None)
    return getattr(declared, "unit", None) or None


def _items(variable: ModelVariable) -> dict[str, int]:
    """Item name -> value of an Enumeration variable (from its declared type)."""
    declared = getattr(variable, "declaredType", None)
    return {item.name: int(item.value) for item in getattr(declared, "items", None) or ()}


def scene_value(component: str, variable: ModelVariable, value: Any, where: str) -> Any:
    """The value to set for a scene's ``value`` of ``variable``; SceneError when it does
    not fit the variable's type (an Enumeration takes an item's name or value)."""
    kind = variable.type

    def refuse(expected: str) -> SceneError:
        return SceneError(
            f"{where}: {component}.{variable.name} is {kind}, got "
            f"{type(value).__name__} {value!r}" + (f" ({expected})" if expected else "")
        )

    if kind == "Enumeration":
        items = _items(variable)
        if isinstance(value, str) and value in items:
            return items[value]
        if isinstance(value, int) and not isinstance(value, bool) and value in items.values():
            return value
        names = ", ".join(f"{name} = {number}" for name, number in items.items())
        raise refuse(f"its items: {names}")
    if kind in _FLOATS:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        raise refuse("")
    if kind in _INTEGERS:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise refuse("")
    if kind == "Boolean":
        if isinstance(value, bool):
            return value
        raise refuse("")
    if kind == "String":
        if isinstance(value, str):
            return value
        raise refuse("")
    raise SceneError(f"{where}: {component}.{variable.name} is a {kind}; the master sets no {kind}")


def start_value(variable: ModelVariable) -> Any:
    """The variable's start value as Python (float, int, bool or str; an Enumeration's item
    value), or None when it has none."""
    start, kind = variable.start, variable.type
    if start is None:
        return None
    if kind in _FLOATS:
        return float(start)
    if kind in _INTEGERS or kind == "Enumeration":
        return int(start)
    if kind == "Boolean":
        return start in (True, "true", "1", 1)
    return start
