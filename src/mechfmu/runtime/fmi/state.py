"""An FMU state as bytes and back, bit for bit (runs inside the FMU; standard library only).

FMI's fmi2SerializeFMUstate / fmi3SerializeFMUState reach pythonfmu, which asks the slave
class for ``_fmu_state_to_bytes(state)`` and, to deserialise, ``_fmu_state_from_bytes(bytes)``.
pythonfmu's own versions write plain JSON, which cannot hold a tuple, a complex number or the
runtime's small state objects (an integrator's work counters, a linear-ODE solution), so the
FMUs could not declare canSerializeFMUstate. This module writes JSON with tags for them:

- floats as JSON writes them (the shortest text that reads back to the same double; NaN and
  infinities as ``NaN``, ``Infinity``): bit for bit;
- ``{"__tuple__": [...]}``, ``{"__complex__": [real, imag]}``;
- ``{"__items__": [[key, value], ...]}`` for a dict whose keys are not all strings or that
  uses one of these tag names as a key;
- ``{"__object__": "numerics.integrators:Stats", "fields": {...}}`` (or ``"items"`` for a
  named tuple) for an object of a class of the FMU's own runtime package: rebuilt without
  calling its constructor, and only from that package (no other module is ever imported).

The bytes are ``{"format": FORMAT, "model": <class name>, "state": ...}``. The C loader frames
them (a header with a format version, the FMU's instantiation token and a checksum; see
``packaging/c_loader/boundary.h``), so a truncated or foreign blob is refused there with a
message before it reaches Python. Nothing here raises into pythonfmu: ``encode`` failing gives
empty bytes (the loader refuses them), ``decode`` failing gives ``{INVALID: reason}``, which
MechSlave._set_fmu_state reports as an error.
"""

import importlib
import json
from typing import Any

FORMAT = 1
INVALID = "mechfmu_invalid_state"  # the key of what decode returns for bytes it cannot read
_TAGS = ("__tuple__", "__complex__", "__items__", "__object__")
_ROOT = __name__.rsplit(".", 2)[0]  # this runtime's package: mechfmu.runtime or the FMU's copy
_SCALARS = (str, int, float, bool, type(None))


class StateFormatError(ValueError):
    """A value the state format cannot hold, or bytes that are no state of this format."""


def _class_path(value: Any) -> str:
    cls = type(value)
    module = cls.__module__
    if not module.startswith(_ROOT + "."):
        raise StateFormatError(f"a {cls.__module__}.{cls.__qualname__} is not a runtime object")
    return f"{module[len(_ROOT) + 1 :]}:{cls.__qualname__}"


def _fields(value: Any) -> dict[str, Any]:
    """The attributes of a runtime object: its __dict__ and every slot it fills."""
    fields = dict(getattr(value, "__dict__", {}))
    for cls in type(value).__mro__:
        for name in getattr(cls, "__slots__", ()):
            if name not in ("__dict__", "__weakref__") and hasattr(value, name):
                fields[name] = getattr(value, name)
    return fields


def _tagged(value: Any) -> Any:
    """``value`` with everything plain JSON cannot hold replaced by its tag."""
    if isinstance(value, _SCALARS):
        return value
    if type(value) is list:
        return [_tagged(item) for item in value]
    if type(value) is tuple:
        return {"__tuple__": [_tagged(item) for item in value]}
    if type(value) is complex:
        return {"__complex__": [value.real, value.imag]}
    if type(value) is dict:
        if all(type(key) is str and key not in _TAGS for key in value):
            return {key: _tagged(item) for key, item in value.items()}
        return {"__items__": [[_tagged(key), _tagged(item)] for key, item in value.items()]}
    if isinstance(value, tuple) and hasattr(value, "_fields"):  # a named tuple
        return {"__object__": _class_path(value), "items": [_tagged(item) for item in value]}
    return {
        "__object__": _class_path(value),
        "fields": {name: _tagged(item) for name, item in _fields(value).items()},
    }


def _runtime_class(path: Any) -> type:
    """The class a tag names: only a class of this runtime package."""
    if not isinstance(path, str) or path.count(":") != 1:
        raise StateFormatError(f"{path!r} names no class")
    module_name, qualname = path.split(":")
    parts = module_name.split(".") + qualname.split(".")
    if not all(part.isidentifier() and not part.startswith("_") for part in parts):
        raise StateFormatError(f"{path!r} names no class of the runtime")
    try:
        target: Any = importlib.import_module(f"{_ROOT}.{module_name}")
        for name in qualname.split("."):
            target = getattr(target, name)
    except (ImportError, AttributeError) as error:
        raise StateFormatError(f"{path!r} names no class of the runtime ({error})") from None
    if not isinstance(target, type):
        raise StateFormatError(f"{path!r} is not a class")
    return target


def _untagged(value: Any) -> Any:
    """Inverse of _tagged."""
    if isinstance(value, _SCALARS):
        return value
    if type(value) is list:
        return [_untagged(item) for item in value]
    if type(value) is not dict:
        raise StateFormatError(f"unexpected {type(value).__name__} in a state")
    if len(value) == 1 and "__tuple__" in value:
        return tuple(_untagged(item) for item in value["__tuple__"])
    if len(value) == 1 and "__complex__" in value:
        real, imag = value["__complex__"]
        return complex(real, imag)
    if len(value) == 1 and "__items__" in value:
        return {_untagged(key): _untagged(item) for key, item in value["__items__"]}
    if "__object__" in value:
        cls = _runtime_class(value["__object__"])
        if "items" in value:
            return cls(*(_untagged(item) for item in value["items"]))
        built: Any = object.__new__(cls)
        for name, item in value["fields"].items():
            object.__setattr__(built, name, _untagged(item))
        return built
    return {key: _untagged(item) for key, item in value.items()}


def encode(model: str, state: Any) -> bytes:
    """The bytes of ``model``'s FMU ``state``; empty bytes when a value cannot be written (the
    loader then refuses the serialisation with a message)."""
    try:
        document = {"format": FORMAT, "model": model, "state": _tagged(state)}
        return json.dumps(document, separators=(",", ":")).encode("utf-8")
    except (StateFormatError, TypeError, ValueError, RecursionError):
        return b""


def decode(model: str, data: bytes) -> Any:
    """The FMU state of ``model`` that ``encode`` wrote into ``data``; ``{INVALID: reason}``
    when the bytes are no such state."""
    try:
        document = json.loads(bytes(data).decode("utf-8"))
        if not isinstance(document, dict) or document.get("format") != FORMAT:
            found = document.get("format") if isinstance(document, dict) else None
            raise StateFormatError(f"state format {found!r}; this FMU reads format {FORMAT}")
        if document.get("model") != model:
            raise StateFormatError(f"a state of model {document.get('model')!r}, not of {model!r}")
        return _untagged(document["state"])
    except (StateFormatError, UnicodeDecodeError, ValueError, KeyError, TypeError) as error:
        return {INVALID: f"the serialized FMU state cannot be read: {error}"}
    except RecursionError:
        return {INVALID: "the serialized FMU state cannot be read: nested too deeply"}
