"""A scene's check tolerances: its ``[check]`` table, the one place they are declared.

::

    [check]
    rtol = 1e-9            # relative tolerance (default 1e-9)
    atol = 1e-12           # absolute tolerance, SI units of each column (default 1e-12)
    method = "pointwise"   # or "tube"
    time_tolerance = 0.01  # s, tube method only (default: the reference's largest step)
    why = "closed forms on both sides: rounding only (measured 2e-15 of the peak)"
    [check.columns]        # optional, per column (or fnmatch pattern such as "gear.*")
    "gear.cap_pressure" = { atol = 0.03, why = "Pa" }
    "gear.rhs_evaluations" = { compare = false, why = "solver statistic: no reference" }

A sample passes when ``|value - reference| <= atol + rtol * |reference|`` (or lies in the
tube). ``why`` says what the tolerance rests on: the measured error of the reference and of
the run, not what happens to pass. A column with ``compare = false`` is a recorded output
the reference does not cover (a solver statistic): present in the result, it is not a
failure; the other keys of a column replace the table's for that column.

``mechfmu references`` writes the table into the JSON beside each shipped reference CSV, and
``mechfmu run`` into the JSON beside each result; ``mechfmu.compare`` (and so ``mechfmu
check``, ``mechfmu run --check`` and the pytest fixture) applies the reference's own table
unless the caller gives tolerances.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .limits import message_text
from typing import Any

DEFAULT_RTOL = 1e-9
DEFAULT_ATOL = 1e-12
METHODS = ("pointwise", "tube")
_TABLE_KEYS = {"rtol", "atol", "method", "time_tolerance", "why", "columns"}
_COLUMN_KEYS = {"rtol", "atol", "why", "compare"}


@dataclass(frozen=True)
class ColumnCheck:
    """One ``[check.columns]`` entry: tolerances replacing the table's for the columns its
    pattern matches (None: the table's), or ``compare = False``."""

    rtol: float | None = None
    atol: float | None = None
    compare: bool = True
    why: str = ""

    def as_dict(self) -> dict[str, Any]:
        """The entry as written in the TOML table (keys that are set only)."""
        entry: dict[str, Any] = {
            key: value
            for key, value in (("rtol", self.rtol), ("atol", self.atol))
            if value is not None
        }
        if not self.compare:
            entry["compare"] = False
        if self.why:
            entry["why"] = self.why
        return entry


@dataclass(frozen=True)
class Check:
    """A scene's ``[check]`` table (the defaults when the scene has none): rtol, atol (SI
    units of each column), method ("pointwise" or "tube"), time_tolerance (s, tube only;
    None: the reference's largest step), why, and per-column entries."""

    rtol: float = DEFAULT_RTOL
    atol: float = DEFAULT_ATOL
    method: str = "pointwise"
    time_tolerance: float | None = None
    why: str = ""
    columns: dict[str, ColumnCheck] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """The table as JSON-ready data (read back by ``parse_check``)."""
        table: dict[str, Any] = {"rtol": self.rtol, "atol": self.atol, "method": self.method}
        if self.time_tolerance is not None:
            table["time_tolerance"] = self.time_tolerance
        table["why"] = self.why
        if self.columns:
            table["columns"] = {name: entry.as_dict() for name, entry in self.columns.items()}
        return table

    def tolerances(self) -> dict[str, dict[str, float]]:
        """The per-column tolerances as ``mechfmu.compare`` takes them ({pattern: {"rtol":
        ..., "atol": ...}}), the entries without ``compare = false``."""
        return {
            name: {
                key: value
                for key, value in (("rtol", entry.rtol), ("atol", entry.atol))
                if value is not None
            }
            for name, entry in self.columns.items()
            if entry.compare
        }

    @property
    def not_compared(self) -> list[str]:
        """Patterns of the columns declared ``compare = false``."""
        return [name for name, entry in self.columns.items() if not entry.compare]


def _tolerance(value: Any, where: str, key: str, error: type[Exception]) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise error(f"{where}: {key} = {value!r} must be a number")
    if not (math.isfinite(value) and value >= 0):
        raise error(f"{where}: {key} = {value!r} must be a finite number >= 0")
    return float(value)


def _text(value: Any, where: str, error: type[Exception]) -> str:
    if not isinstance(value, str):
        raise error(f"{where}: why = {value!r} must be a string")
    return value


def refuse_unknown(
    table: dict[str, Any], allowed: set[str], where: str, error: type[Exception]
) -> None:
    """Raise ``error`` naming the keys of the TOML ``table`` that are not ``allowed``, at
    ``where`` (the file, and the table in it)."""
    unknown = set(table) - set(allowed)
    if unknown:
        raise error(
            f"{where}: unknown key(s) {', '.join(message_text(key, 60) for key in sorted(unknown))}; "
            f"allowed: {', '.join(sorted(allowed))}"
        )


def parse_check(table: Any, where: str, error: type[Exception] = ValueError) -> Check:
    """The Check of a ``[check]`` table (parsed TOML, or the JSON of ``Check.as_dict``);
    ``error`` (naming ``where``, the key and the value) for an unknown key, a tolerance
    that is not a finite number >= 0, an unknown method, a time_tolerance without the tube,
    a missing ``why`` or a malformed column entry."""
    where = f"{where}: [check]"
    if not isinstance(table, dict):
        raise error(f"{where} must be a table, got {table!r}")
    refuse_unknown(table, _TABLE_KEYS, where, error)
    method = table.get("method", "pointwise")
    if method not in METHODS:
        raise error(f"{where}: method = {method!r} is not one of {', '.join(METHODS)}")
    time_tolerance = table.get("time_tolerance")
    if time_tolerance is not None:
        time_tolerance = _tolerance(time_tolerance, where, "time_tolerance", error)
        if method != "tube":
            raise error(f'{where}: time_tolerance is the tube\'s: set method = "tube" with it')
    if not isinstance(table.get("why"), str) or not table["why"].strip():
        raise error(
            f"{where}: missing 'why': say what the tolerance rests on (the measured error "
            f"of the reference and of the run)"
        )
    columns = table.get("columns", {})
    if not isinstance(columns, dict):
        raise error(f"{where}: columns must be a table of column = {{ rtol, atol, why }}")
    entries = {}
    for name, entry in columns.items():
        cwhere = f"{where}.columns: {name!r}"
        if not isinstance(entry, dict):
            raise error(f'{cwhere} must be an inline table such as {{ atol = 1e-9, why = "..." }}')
        refuse_unknown(entry, _COLUMN_KEYS, cwhere, error)
        compare = entry.get("compare", True)
        if not isinstance(compare, bool):
            raise error(f"{cwhere}: compare = {compare!r} must be true or false")
        entries[str(name)] = ColumnCheck(
            rtol=_tolerance(entry["rtol"], cwhere, "rtol", error) if "rtol" in entry else None,
            atol=_tolerance(entry["atol"], cwhere, "atol", error) if "atol" in entry else None,
            compare=compare,
            why=_text(entry.get("why", ""), cwhere, error),
        )
    return Check(
        rtol=_tolerance(table.get("rtol", DEFAULT_RTOL), where, "rtol", error),
        atol=_tolerance(table.get("atol", DEFAULT_ATOL), where, "atol", error),
        method=method,
        time_tolerance=time_tolerance,
        why=table["why"],
        columns=entries,
    )
