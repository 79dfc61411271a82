"""The table of one FMU's variables that its C loader checks every call against (host side).

The loader (``c_loader/boundary.c``, ``fmi2.c``, ``fmi3.c``) answers a get or set of an
unknown value reference, of a variable of another type, or of a variable the standard does not
let the host set in the instance's state, with an error status, before pythonfmu sees the call.
It learns the variables from this table, generated from the FMU's own modelDescription.xml
(so it cannot drift from it) and compiled into the FMU's binary at build time.
"""

from dataclasses import dataclass
from xml.etree import ElementTree

# The C enums of boundary.h, by the names the model descriptions use.
C_TYPES = {
    "Real": "MF_FLOAT64",
    "Integer": "MF_INT32",
    "Enumeration": "MF_INT32",  # FMI 2.0: read with fmi2GetInteger
    "Boolean": "MF_BOOLEAN",
    "String": "MF_STRING",
    "Float32": "MF_FLOAT32",
    "Float64": "MF_FLOAT64",
    "Int8": "MF_INT8",
    "UInt8": "MF_UINT8",
    "Int16": "MF_INT16",
    "UInt16": "MF_UINT16",
    "Int32": "MF_INT32",
    "UInt32": "MF_UINT32",
    "Int64": "MF_INT64",
    "UInt64": "MF_UINT64",
    "Binary": "MF_BINARY",
    "Clock": "MF_CLOCK",
}
FMI3_ENUMERATION = "MF_INT64"  # FMI 3.0: read with fmi3GetInt64
CAUSALITIES = {
    "parameter": "MF_PARAMETER",
    "calculatedParameter": "MF_CALCULATED_PARAMETER",
    "input": "MF_INPUT",
    "output": "MF_OUTPUT",
    "local": "MF_LOCAL",
    "independent": "MF_INDEPENDENT",
    "structuralParameter": "MF_STRUCTURAL_PARAMETER",
}
VARIABILITIES = {
    "constant": "MF_CONSTANT",
    "fixed": "MF_FIXED",
    "tunable": "MF_TUNABLE",
    "discrete": "MF_DISCRETE",
    "continuous": "MF_CONTINUOUS",
}
INITIALS = {
    None: "MF_INITIAL_NONE",
    "exact": "MF_EXACT",
    "approx": "MF_APPROX",
    "calculated": "MF_CALCULATED",
}
_FLOATS = {"Real", "Float32", "Float64"}


@dataclass(frozen=True)
class TableVariable:
    """One variable as the loader sees it (the C enum names of boundary.h)."""

    reference: int
    name: str
    type: str
    causality: str
    variability: str
    initial: str


def default_initial(causality: str, variability: str) -> str | None:
    """The ``initial`` a variable has when its description gives none (the tables of FMI 2.0
    section 2.2.7 and FMI 3.0 section 2.4.7.5)."""
    if causality in ("parameter", "structuralParameter"):
        return "exact"
    if causality in ("input", "independent"):
        return None
    if variability == "constant":
        return "exact"
    return "calculated"


def _variable(element: ElementTree.Element, kind: str, fmi_version: int) -> TableVariable:
    causality = element.get("causality", "local")
    default_variability = "continuous" if kind in _FLOATS else "discrete"
    variability = element.get("variability", default_variability)
    typed = element if fmi_version == 3 else element[0]
    initial = element.get("initial") or typed.get("initial")
    if initial is None:
        initial = default_initial(causality, variability)
    c_type = FMI3_ENUMERATION if fmi_version == 3 and kind == "Enumeration" else C_TYPES[kind]
    return TableVariable(
        int(element.get("valueReference", "-1")),
        element.get("name", ""),
        c_type,
        CAUSALITIES[causality],
        VARIABILITIES[variability],
        INITIALS[initial],
    )


def _children(root: ElementTree.Element, tag: str) -> list[ElementTree.Element]:
    """The child elements of ``root``'s element ``tag`` (none when it is missing)."""
    element = root.find(tag)
    return [] if element is None else list(element)


def table_variables(description: bytes) -> tuple[dict[str, str], list[TableVariable], list[str]]:
    """(model attributes, variables, log categories) of a modelDescription.xml's bytes: the
    attributes ``fmi_version``, ``identifier`` and ``token`` (guid or instantiationToken)."""
    root = ElementTree.fromstring(description)
    fmi_version = 3 if root.get("fmiVersion", "").startswith("3") else 2
    co_simulation = root.find("CoSimulation")
    if co_simulation is None:
        raise ValueError("the model description has no <CoSimulation> element")
    model = {
        "fmi_version": str(fmi_version),
        "identifier": co_simulation.get("modelIdentifier", ""),
        "token": root.get("guid" if fmi_version == 2 else "instantiationToken", ""),
    }
    variables = []
    for element in _children(root, "ModelVariables"):
        if fmi_version == 2:
            kind = element[0].tag if len(element) else ""
        else:
            kind = element.tag
        if kind in C_TYPES:
            variables.append(_variable(element, kind, fmi_version))
    categories = [category.get("name", "") for category in _children(root, "LogCategories")]
    return model, variables, categories


def c_string(text: str) -> str:
    """``text`` as a C string literal: its UTF-8 bytes, quotes and backslashes escaped, every
    byte outside printable ASCII as a three-digit octal escape (a path or a name with any
    character survives the compiler byte for byte)."""
    characters = []
    for byte in text.encode("utf-8"):
        character = chr(byte)
        if character in '"\\':
            characters.append("\\" + character)
        elif 32 <= byte < 127:
            characters.append(character)
        else:
            characters.append(f"\\{byte:03o}")
    return '"' + "".join(characters) + '"'


def table_source(description: bytes) -> str:
    """C source of ``MF_MODEL`` (boundary.h) for the FMU whose modelDescription.xml is
    ``description``: every variable at the index of its value reference."""
    model, variables, categories = table_variables(description)
    by_reference = {variable.reference: variable for variable in variables}
    if any(reference < 0 for reference in by_reference):
        raise ValueError("a variable has no valueReference")
    count = max(by_reference, default=-1) + 1
    if count > 1_000_000:
        raise ValueError(f"value references up to {count - 1}: too sparse for a table")
    rows = []
    for reference in range(count):
        variable = by_reference.get(reference)
        if variable is None:
            rows.append("    {MF_NONE, 0, 0, 0, 0},")
        else:
            rows.append(
                f"    {{{variable.type}, {variable.causality}, {variable.variability}, "
                f"{variable.initial}, {c_string(variable.name)}}}, /* {reference} */"
            )
    names = ", ".join(c_string(category) for category in categories) or "0"
    return "\n".join(
        [
            f"/* Generated by mechfmu build from {model['identifier']}'s modelDescription.xml:",
            " * the variables its loader checks every call against (boundary.h). */",
            '#include "boundary.h"',
            "",
            f"static const struct mf_variable variables[{max(count, 1)}] = {{",
            *(rows or ["    {MF_NONE, 0, 0, 0, 0},"]),
            "};",
            f"static const char *const categories[{max(len(categories), 1)}] = {{{names}}};",
            "",
            "const struct mf_model MF_MODEL = {",
            f"    {model['fmi_version']},",
            f"    {c_string(model['identifier'])},",
            f"    {c_string(model['token'])},",
            f"    {count},",
            "    variables,",
            f"    {len(categories)},",
            "    categories,",
            "};",
            "",
        ]
    )
