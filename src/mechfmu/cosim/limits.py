"""The limits every file mechfmu reads is held to, checked before it is parsed.

One layer for every input: scene and sweep files (TOML), result and table CSVs, the JSON
metadata beside a result, FMU archives. Each reader calls the checks of its kind here first,
so a hostile file (a nesting deep enough to exhaust Python's recursion, a 5000-digit number,
bytes that are not UTF-8, a file of gigabytes, a FIFO that never ends) becomes one line
naming the file, the place and the limit, raised as the reader's own exception type
(SceneError, ResultFileError, SweepError, FmuError), never a traceback.

The limits are far above anything mechfmu writes or a person types, and far below what
exhausts memory, the stack or the disk. ``LIMITS`` lists them all; the docs' limits page is
generated from it.
"""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any

KIB = 1024
MIB = 1024 * KIB
GIB = 1024 * MIB

# --- text files: scene and sweep TOML, JSON metadata --------------------------------------
MAX_TOML_BYTES = 1 * MIB  # a scene or sweep file (the shipped ones are 1-4 KiB)
MAX_TOML_DEPTH = 32  # nested tables and arrays in a scene or sweep file (ours: 4)
MAX_JSON_BYTES = 16 * MIB  # a result's JSON metadata (ours: a few KiB)
MAX_JSON_DEPTH = 64  # nested objects and arrays in a JSON file (ours: 4)
MAX_DIGITS = 100  # digits in a row in a number (a double needs 17; 4300 stops int())
INTEGER_RANGE = (-(2**63), 2**63 - 1)  # TOML's integers: 64-bit signed (the TOML spec)
MAX_STRING_CHARACTERS = 64 * KIB  # a string value given to a component (a path, a name)
MAX_STEPS = 10**9  # communication steps of a scene (whatever the output: days of stepping)
# output a run may write unless told otherwise (mechfmu run --max-output; run_scene max_output)
MAX_RUN_OUTPUT_BYTES = 2 * GIB
MAX_SWEEP_POINTS = 1_000_000  # points of a sweep unless told more (mechfmu sweep --max-points)

# --- CSV tables ---------------------------------------------------------------------------
MAX_CSV_BYTES = 2 * GIB  # a result or reference CSV (or Parquet file) read whole (read_result)
MAX_TABLE_BYTES = 256 * MIB  # a profile table a component reads (LoadProfile, RoadProfile)
MAX_COLUMNS = 10_000  # columns of a CSV
MAX_COLUMN_NAME = 1000  # characters of a column name

# --- FMU archives -------------------------------------------------------------------------
MAX_FMU_ENTRIES = 20_000  # members of an FMU archive
MAX_ENTRY_NAME_BYTES = 1024  # a member's path in UTF-8 (each part at most 255: NAME_MAX)
MAX_ENTRY_BYTES = 1 * GIB  # one member unpacked (an embedded libpython: 30 MiB)
MAX_UNPACKED_BYTES = 2 * GIB  # all members unpacked together
MAX_MODEL_DESCRIPTION_BYTES = 64 * MIB  # modelDescription.xml, parsed in memory
MAX_COMPRESSION_RATIO = 100  # unpacked / packed size of a member above RATIO_FLOOR
RATIO_FLOOR = 1 * MIB  # members this small may compress any amount (zero-filled tables)
FREE_SPACE_MARGIN = 64 * MIB  # left free in the unpack folder's file system after unpacking
MAX_ELF_HEADERS_BYTES = 1 * MIB  # where a shared library's program headers must end


@dataclass(frozen=True)
class Limit:
    """One limit: the kind of file, what is limited, the value and its unit, and why."""

    applies_to: str
    what: str
    value: str
    reason: str


def _size(value: int) -> str:
    for unit, size in (("GiB", GIB), ("MiB", MIB), ("KiB", KIB)):
        if value >= size and value % size == 0:
            return f"{value // size} {unit}"
    return f"{value} bytes"


LIMITS = (
    Limit("scene, sweep file (TOML)", "size", _size(MAX_TOML_BYTES), "read whole; ours: 1-4 KiB"),
    Limit(
        "scene, sweep file (TOML)",
        "nesting of tables and arrays",
        f"{MAX_TOML_DEPTH} levels",
        "tomllib recurses per level (RecursionError near 1000); ours: 4",
    ),
    Limit(
        "scene, sweep file (TOML)",
        "integers",
        "64-bit signed",
        "the TOML specification's range; an FMU Integer is 32-bit, a Real a double",
    ),
    Limit(
        "TOML, JSON",
        "digits in a row in a number",
        f"{MAX_DIGITS}",
        "a double needs 17; int() refuses more than 4300",
    ),
    Limit(
        "TOML, JSON, CSV",
        "encoding",
        "UTF-8",
        "the byte that is not is named by line and column",
    ),
    Limit(
        "parameter or input value (scene, --set, Python API)",
        "string length",
        f"{MAX_STRING_CHARACTERS} characters, no NUL",
        "a path or a name; C strings end at NUL",
    ),
    Limit(
        "scene",
        "communication steps ((stop_time - start_time) / step)",
        f"{MAX_STEPS:.0e}",
        "at 10 us a step, 3 hours; the master streams its rows (memory does not grow)",
    ),
    Limit(
        "run (mechfmu run, run_scene)",
        "estimated output (rows x columns x bytes per value)",
        _size(MAX_RUN_OUTPUT_BYTES) + " unless --max-output",
        "refused before the first step, naming the steps and the size",
    ),
    Limit("result JSON metadata", "size", _size(MAX_JSON_BYTES), "read whole; ours: a few KiB"),
    Limit(
        "result JSON metadata",
        "nesting of objects and arrays",
        f"{MAX_JSON_DEPTH} levels",
        "the json module recurses per level; ours: 4",
    ),
    Limit(
        "result, reference CSV or Parquet file",
        "size",
        _size(MAX_CSV_BYTES) + " read whole; no limit read by blocks",
        "read_result and the plots of a check keep its numbers (8 bytes each); check and "
        "iter_result read 2 MiB at a time, in the same memory at any size",
    ),
    Limit(
        "profile table (table_file)",
        "size",
        _size(MAX_TABLE_BYTES),
        "read whole by the host and by the FMU",
    ),
    Limit("CSV", "columns", f"{MAX_COLUMNS}", "ours: one per recorded variable"),
    Limit("CSV", "column name", f"{MAX_COLUMN_NAME} characters", "ours: component.variable"),
    Limit("FMU archive", "members", f"{MAX_FMU_ENTRIES}", "ours: 65; embedded Python: about 70"),
    Limit(
        "FMU archive",
        "member path",
        f"{MAX_ENTRY_NAME_BYTES} bytes, each part 255; relative, no '..', no drive, "
        "no backslash, no NUL, no link, no duplicate",
        "unpacked below its folder, never outside it",
    ),
    Limit(
        "FMU archive",
        "one member unpacked",
        _size(MAX_ENTRY_BYTES),
        "the declared size, checked before anything is unpacked",
    ),
    Limit(
        "FMU archive",
        "all members unpacked",
        _size(MAX_UNPACKED_BYTES),
        "and the unpack folder's free space minus " + _size(FREE_SPACE_MARGIN),
    ),
    Limit(
        "FMU archive",
        "compression ratio of a member",
        f"{MAX_COMPRESSION_RATIO} (members above {_size(RATIO_FLOOR)})",
        "a zip bomb reaches 1000; our largest member: 5",
    ),
    Limit(
        "FMU archive",
        "modelDescription.xml",
        _size(MAX_MODEL_DESCRIPTION_BYTES),
        "parsed in memory",
    ),
    Limit(
        "FMU archive",
        "a shared library's program headers",
        f"within its first {_size(MAX_ELF_HEADERS_BYTES)}",
        "read by streaming; the rest is compared with the declared size",
    ),
)


# --- files --------------------------------------------------------------------------------


NOT_FOUND = "file not found"  # file_problem's answer for a path that does not exist


def message_text(text: Path | str, size: int = 200) -> str:
    """A name from the user (a path, a key) for a one-line message: as it is, or its
    shortened repr (the middle left out) when longer than ``size`` characters or not
    printable (a line break in a hostile file's key)."""
    text = str(text)
    return text if len(text) <= size and text.isprintable() else shortened(text, size)


def _stat(path: Path | str) -> tuple[os.stat_result | None, str | None]:
    """(os.stat of ``path``, None), or (None, NOT_FOUND or "cannot be read: <cause>"): what
    Path.exists and is_file raise instead (a name too long for the file system, a parent
    that cannot be searched, a NUL in the path) as a problem to name."""
    try:
        return os.stat(path), None
    except (FileNotFoundError, NotADirectoryError):  # NotADirectory: a path under a file
        return None, NOT_FOUND
    except (OSError, ValueError) as error:  # ValueError: a NUL in the path
        return None, f"cannot be read: {getattr(error, 'strerror', None) or error}"


def path_problem(path: Path | str) -> str | None:
    """Why ``path`` names nothing usable, or None when it names something (a file or a
    folder): "does not exist", or "cannot be read: <cause>" (_stat)."""
    problem = _stat(path)[1]
    return "does not exist" if problem == NOT_FOUND else problem


def exists(path: Path | str) -> bool:
    """Whether ``path`` names something: Path.exists without its OSError (path_problem)."""
    return path_problem(path) is None


def file_problem(path: Path | str, max_bytes: int | None) -> str | None:
    """Why ``path`` cannot be read as a file of at most ``max_bytes`` (None: of any size), or
    None: missing, a directory, not a regular file (a FIFO or a device would block or never
    end), too large."""
    status, problem = _stat(path)
    if status is None:
        return problem
    if stat.S_ISDIR(status.st_mode):
        return "is a directory, not a file"
    if not stat.S_ISREG(status.st_mode):
        return "is not a regular file (a FIFO, a socket or a device)"
    if max_bytes is not None and status.st_size > max_bytes:
        return f"is {status.st_size} bytes, more than the limit of {_size(max_bytes)}"
    return None


def read_bytes(path: Path | str, max_bytes: int) -> tuple[bytes | None, str | None]:
    """(the bytes of ``path``, None), or (None, the problem) when it is not a regular file of
    at most ``max_bytes`` (checked again on the open file: it may have changed)."""
    problem = file_problem(path, max_bytes)
    if problem:
        return None, problem
    try:
        with open(path, "rb") as handle:
            if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
                return None, "is not a regular file (a FIFO, a socket or a device)"
            data = handle.read(max_bytes + 1)
    except OSError as error:
        return None, f"cannot be read: {error.strerror or error}"
    if len(data) > max_bytes:
        return None, f"is more than the limit of {_size(max_bytes)}"
    return data, None


def position(text: str, index: int) -> str:
    """'line L, column C' (from 1) of character ``index`` of ``text``."""
    line = text.count("\n", 0, index) + 1
    return f"line {line}, column {index - (text.rfind(chr(10), 0, index) + 1) + 1}"


def decoded(data: bytes) -> tuple[str | None, str | None]:
    """(``data`` as UTF-8 text, None) or (None, where the first byte that is not UTF-8 is)."""
    try:
        return data.decode("utf-8"), None
    except UnicodeDecodeError as error:
        good = data[: error.start].decode("utf-8")
        return None, (
            f"not UTF-8 text: byte 0x{data[error.start]:02x} at {position(good, len(good))}"
        )


def read_text(path: Path | str, max_bytes: int) -> tuple[str | None, str | None]:
    """(the UTF-8 text of ``path``, None) or (None, the problem): read_bytes, then decoded."""
    data, problem = read_bytes(path, max_bytes)
    if data is None:
        return None, problem
    return decoded(data)


# --- scanning text before a recursive parser sees it ---------------------------------------


# Tokens that matter to the scan; everything else (keys, punctuation, words) is skipped. A
# string or comment is one token (its brackets and digits do not count); a string that never
# closes runs to the end of its line (basic) or of the text (multi-line), so no token is
# tried again from every position (linear time on any input).
_JSON_TOKENS = re.compile(r'"(?:[^"\\\n]|\\.)*"?|[\[\]{}]|[0-9]+')
_TOML_TOKENS = re.compile(
    r'''"""(?:[^\\]|\\.)*?(?:"""|\Z)|\'\'\'.*?(?:\'\'\'|\Z)|"(?:[^"\\\n]|\\.)*"?'''
    r"|'[^'\n]*'?|#[^\n]*|[\[\]{}]|[0-9][0-9_]*",
    re.DOTALL,
)


def scan_problem(text: str, max_depth: int, kind: str) -> str | None:
    """Where ``text`` (``kind`` "toml" or "json") nests arrays and tables deeper than
    ``max_depth`` or holds more than MAX_DIGITS digits in a row, outside its strings and
    comments; None if nowhere. One linear pass that needs no recursion: it runs before the
    parser, whose recursion the nesting would exhaust."""
    depth = 0
    for token in (_TOML_TOKENS if kind == "toml" else _JSON_TOKENS).finditer(text):
        first = token.group()[0]
        if first in "[{":
            depth += 1
            if depth > max_depth:
                return (
                    f"{position(text, token.start())}: nested deeper than the limit of "
                    f"{max_depth} levels"
                )
        elif first in "]}":
            depth = max(depth - 1, 0)
        elif first.isdigit():
            digits = len(token.group()) - token.group().count("_")
            if digits > MAX_DIGITS:
                return (
                    f"{position(text, token.start())}: a number of {digits} digits in a "
                    f"row, more than the limit of {MAX_DIGITS}"
                )
    return None


# --- parsed data ----------------------------------------------------------------------------


def _key_path(path: tuple) -> str:
    """'components.gear.parameters[2]' (its middle left out past 80 characters)."""
    text = "".join(f"[{part}]" if isinstance(part, int) else f".{part}" for part in path)
    text = text.lstrip(".")
    return text if len(text) <= 80 else f"{text[:50]}...{text[-20:]}"


def structure_problem(data: Any, max_depth: int) -> str | None:
    """Where the parsed ``data`` (dicts, lists, scalars) nests deeper than ``max_depth`` or
    holds an integer outside INTEGER_RANGE; None if nowhere. Dotted keys (``a.b.c = 1``) and
    table headers nest without brackets, so this walk follows the text scan. Iterative."""
    stack: list[tuple[Any, tuple]] = [(data, ())]
    while stack:
        value, path = stack.pop()
        if isinstance(value, dict):
            items = list(value.items())
        elif isinstance(value, list):
            items = list(enumerate(value))
        else:
            if isinstance(value, int) and not isinstance(value, bool):
                if not INTEGER_RANGE[0] <= value <= INTEGER_RANGE[1]:
                    return (
                        f"{_key_path(path)} = {shortened(value)} is outside the 64-bit "
                        f"integer range [-2**63, 2**63 - 1]"
                    )
            continue
        if len(path) >= max_depth and items:
            return f"{_key_path(path)}: nested deeper than the limit of {max_depth} levels"
        stack.extend((item, (*path, key)) for key, item in items)
    return None


def shortened(value: Any, size: int = 60) -> str:
    """repr(value) for a message, its middle left out when longer than ``size``. Integers
    too long for repr (Python's 4300-digit limit) are described by their size."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 10_000:
        return f"<an integer of {value.bit_length()} bits>"
    text = repr(value)
    if len(text) <= size:
        return text
    return f"{text[: size // 2]}...({len(text)} characters)...{text[-10:]}"


def value_problem(value: Any) -> str | None:
    """Why ``value`` cannot be given to a component as a parameter or input, or None: it
    must be a bool, an int in the 64-bit range, a float, or a string of at most
    MAX_STRING_CHARACTERS characters without NUL (C strings end there) that encodes as
    UTF-8. (NaN and infinities pass here: the FMU refuses them with its own message.)"""
    if isinstance(value, bool | float):
        return None
    if isinstance(value, int):
        if INTEGER_RANGE[0] <= value <= INTEGER_RANGE[1]:
            return None
        return "is outside the 64-bit integer range [-2**63, 2**63 - 1]"
    if isinstance(value, str):
        if len(value) > MAX_STRING_CHARACTERS:
            return (
                f"is a string of {len(value)} characters, more than the limit of "
                f"{MAX_STRING_CHARACTERS}"
            )
        if "\x00" in value:
            return "holds a NUL character (a C string ends there)"
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            return "is not encodable as UTF-8 (a lone surrogate)"
        return None
    return f"is a {type(value).__name__}; expected a number, a bool or a string"


def finite_float(value: Any) -> float | None:
    """``value`` (an int or a float, not a bool) as a finite float, or None: also for an
    integer too large for a double (float() would raise OverflowError)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if number - number == 0.0 else None  # not NaN, not infinite


def load_json(path: Path | str, max_bytes: int = MAX_JSON_BYTES) -> tuple[Any, str | None]:
    """(the parsed JSON file at ``path``, None) or (None, the problem): within ``max_bytes``,
    UTF-8, nested at most MAX_JSON_DEPTH levels, no number of more than MAX_DIGITS digits in a
    row, and well-formed (the json module's message with its line and column)."""
    import json

    text, problem = read_text(path, max_bytes)
    if text is None:
        return None, problem
    problem = scan_problem(text, MAX_JSON_DEPTH, "json")
    if problem:
        return None, problem
    try:
        return json.loads(text), None
    except json.JSONDecodeError as error:
        return None, f"malformed JSON: {error.msg} at line {error.lineno}, column {error.colno}"
