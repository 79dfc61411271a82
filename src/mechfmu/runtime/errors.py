"""Errors raised by the mechanism physics (standard library only).

They carry the offending variable, its value and the valid range, so every layer above
(FMU log, master, CLI) can report the same precise message.
"""

import math


class MechanismError(ValueError):
    """Base class: a computation cannot proceed with the given values."""


class RangeError(MechanismError):
    """A value lies outside its valid range (or is NaN or infinite)."""

    def __init__(
        self, name: str, value: float | None, valid: str, unit: str = "", why: str = ""
    ) -> None:
        self.name = name
        self.value = value
        self.valid = valid
        self.unit = unit
        suffix = f" {unit}" if unit and unit != "1" else ""  # "1": dimensionless (FMI's)
        text = f"{name} = {value!r}{suffix} is outside the valid range {valid}{suffix}"
        if why:
            text += f" ({why})"
        super().__init__(text)


class CamDesignError(RangeError):
    """No cam can produce the follower motion with this geometry: ``kind`` (a cusp or an
    undercut of the cam surface) at camshaft angle ``angle`` (rad); the message names the
    parameter to change and its limit."""

    def __init__(
        self,
        kind: str,
        angle: float,
        name: str,
        value: float,
        valid: str,
        unit: str = "",
        why: str = "",
    ) -> None:
        self.kind = kind
        self.angle = angle
        super().__init__(name, value, valid, unit, why)


class SingularConfiguration(MechanismError):
    """The mechanism is at a configuration where the requested quantity is undefined."""


class IntegrationError(MechanismError):
    """An integrator cannot continue: unstable, step size underflow, or too many steps."""


class SnapThrough(MechanismError):
    """The load passed the limit load and the caller asked not to continue past it."""


def require_finite(name: str, value: float, unit: str = "", valid: str = "(-inf, inf)") -> float:
    """Return ``value`` as float or raise RangeError for NaN, +-inf or non-numbers; ``valid``
    is the range the message names (the parameter's own, where the caller checks one)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise RangeError(name, value, valid, unit, "not a number") from None
    if not math.isfinite(number):
        raise RangeError(name, number, valid, unit, "must be finite")
    return number


def require_positive(name: str, value: float, unit: str = "") -> float:
    """Return ``value`` as float or raise RangeError unless it is finite and > 0."""
    number = require_finite(name, value, unit, "(0, inf)")
    if number <= 0.0:
        raise RangeError(name, number, "(0, inf)", unit, "must be positive")
    return number


def require_above(name: str, value: float, low: float, unit: str = "", why: str = "") -> float:
    """Return ``value`` as float or raise RangeError (with ``why``) unless it is finite and
    above ``low``."""
    number = require_finite(name, value, unit, f"({low!r}, inf)")
    if not number > low:
        raise RangeError(name, number, f"({low!r}, inf)", unit, why)
    return number


def require_between(
    name: str,
    value: float,
    low: float,
    high: float,
    unit: str = "",
    low_open: bool = False,
    high_open: bool = False,
    why: str = "",
) -> float:
    """Return ``value`` as float or raise RangeError (with ``why``) unless
    low <(=) value <(=) high."""
    valid = f"{'(' if low_open else '['}{low!r}, {high!r}{')' if high_open else ']'}"
    number = require_finite(name, value, unit, valid)
    below = number <= low if low_open else number < low
    above = number >= high if high_open else number > high
    if below or above:
        raise RangeError(name, number, valid, unit, why)
    return number
