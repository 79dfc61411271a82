"""Result files as pandas DataFrames: the CSV (and JSON) pair ``mechfmu run`` writes.

A result is a CSV file whose first column is ``time`` (s) and whose other columns are the
recorded variables (``gear.gear_angle``), one row per communication point, floats in their
shortest round-trip form; beside it, ``<stem>.json`` holds the metadata (``units`` maps each
column to its SI unit, then the scene, the step, the package versions, ...).

``read_result`` gives a DataFrame indexed by ``time`` (float, strictly increasing) with one
float64 column per variable, ``df.attrs["units"]`` and the rest of the JSON in ``df.attrs``.
``write_result`` writes one back in the same format, atomically. ``read_table`` reads the other
CSV tables mechfmu writes (sweep rows, study rows) the same careful way. Every malformed file
raises ResultFileError, whose one-line message names the file, and the line and column where
they apply.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Iterable
from os import PathLike
from pathlib import Path
from typing import Any

import numpy
import pandas

from .cosim import limits
from .cosim.files import atomic_write_all, remove_stale_temporaries
from .cosim.results import csv_writer, pair_problem, sealed_pair
from .cosim.tables import ResultFileError, check_file, read_profile_table
from .cosim.tolerances import parse_check

__all__ = [
    "ResultFileError",
    "companion_json",
    "read_profile_table",
    "read_result",
    "read_table",
    "write_result",
]

StrPath = str | PathLike


def companion_json(path: StrPath) -> Path:
    """The metadata file of the result CSV at ``path``: ``<stem>.json`` beside it."""
    return Path(path).with_suffix(".json")


def _check_csv(path: Path) -> None:
    """ResultFileError unless ``path`` is a regular file within MAX_CSV_BYTES whose header
    (its first record, read alone by the csv module: a header of 10001 columns costs no
    parse of the rows) is within the columns' limits."""
    check_file(path, limits.MAX_CSV_BYTES, "a CSV file")
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            header = next(csv.reader(handle), None)
    except (OSError, UnicodeDecodeError, csv.Error):
        return  # pandas' reading names these
    problem = _names_problem([name.strip() for name in header or []])
    if problem:
        raise ResultFileError(f"{path}: line 1: {problem}")


def _raw_rows(path: Path) -> pandas.DataFrame:
    """Every line of the CSV at ``path`` as strings (row 0 is the header), trailing blank
    lines dropped; ResultFileError for a missing, empty or unreadable file."""
    _check_csv(path)
    try:
        raw = pandas.read_csv(
            path, header=None, dtype=str, na_filter=False, skip_blank_lines=False, encoding="utf-8"
        )
    except pandas.errors.EmptyDataError:
        raise ResultFileError(f"{path}: empty file (no header, no data)") from None
    except pandas.errors.ParserError as error:
        # pandas: "Error tokenizing data. C error: Expected 3 fields in line 6, saw 4"
        found = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(error))
        if found:
            expected, line, seen = found.groups()
            raise ResultFileError(
                f"{path}: line {line} has {seen} values, the header {expected} columns"
            ) from None
        detail = str(error).split("C error: ")[-1].strip()
        raise ResultFileError(f"{path}: malformed CSV: {detail}") from None
    except UnicodeDecodeError:
        raise ResultFileError(f"{path}: not UTF-8 text") from None
    except OSError as error:
        raise ResultFileError(f"{path}: cannot be read: {error.strerror or error}") from None
    blank = (raw == "").all(axis=1).to_numpy()
    end = len(raw)
    while end > 1 and blank[end - 1]:
        end -= 1
    if blank[:end].any():
        raise ResultFileError(f"{path}: line {int(numpy.argmax(blank)) + 1} is blank")
    return raw.iloc[:end]


def _header(path: Path, raw: pandas.DataFrame, first: str | None) -> list[str]:
    names = [name.strip() for name in raw.iloc[0]]
    problem = _names_problem(names)
    if problem:
        raise ResultFileError(f"{path}: line 1: {problem}")
    if first is not None and names[0] != first:
        raise ResultFileError(
            f"{path}: line 1: the first column must be {first!r}, got {names[0]!r} (no header?)"
        )
    for index, name in enumerate(names):
        if not name:
            raise ResultFileError(f"{path}: line 1: column {index + 1} has no name")
        if name in names[:index]:
            raise ResultFileError(f"{path}: line 1: column {name!r} appears twice")
    return names


def _names_problem(names: list[str]) -> str | None:
    """Why a CSV header of ``names`` is beyond the limits (columns, name length), or None."""
    if len(names) > limits.MAX_COLUMNS:
        return f"{len(names)} columns, more than the limit of {limits.MAX_COLUMNS}"
    for index, name in enumerate(names):
        if len(name) > limits.MAX_COLUMN_NAME:
            return (
                f"column {index + 1} has a name of {len(name)} characters, more than the "
                f"limit of {limits.MAX_COLUMN_NAME}"
            )
    return None


def _problem_cell(
    path: Path, cells: numpy.ndarray, names: list[str], line0: int, blank: bool, finite: bool = True
) -> ResultFileError | None:
    """The error for the first cell of ``cells`` (strings, rows from file line ``line0``)
    that is not a number (not empty either with ``blank``, not finite with ``finite``), or
    None."""
    for row_index, row in enumerate(cells):
        line = line0 + row_index
        for column, text in zip(names, row):
            if text == "" and blank:
                continue
            if text == "":
                return ResultFileError(
                    f"{path}: line {line}, column {column!r}: empty field (the line has "
                    f"fewer values than the header: cut short?)"
                )
            try:
                value = float(text)
            except ValueError:
                return ResultFileError(
                    f"{path}: line {line}, column {column!r}: {text!r} is not a number"
                )
            if finite and not math.isfinite(value):
                return ResultFileError(
                    f"{path}: line {line}, column {column!r}: {text!r} is not a finite number"
                )
    return None


def _numbers(path: Path, cells: numpy.ndarray, names: list[str]) -> numpy.ndarray:
    """``cells`` (strings) as float64, exactly as Python's float() reads each one;
    ResultFileError naming the line and column of the first that is not a finite number."""
    try:
        values = cells.astype(float)
    except ValueError:
        values = None
    if values is None or not numpy.isfinite(values).all():
        raise _problem_cell(path, cells, names, 2, blank=False) or ResultFileError(
            f"{path}: a value is not a finite number"
        )
    return values


# pandas >= 3 parses floats exactly by default (and deprecates the option); pandas 2's
# default ("high") may be one ulp off, its "round_trip" converter is exact
_EXACT_FLOATS: dict[str, Any] = (
    {} if int(pandas.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
)


def _fast_values(path: Path) -> tuple[numpy.ndarray | None, list[str]]:
    """(float64 array of the data rows, header names) of a well-formed result CSV, parsed by
    pandas' C reader with an exact float conversion; (None, []) when anything
    looks wrong (the caller then reads the file as text to name the problem)."""
    try:
        header = pandas.read_csv(
            path, header=None, nrows=1, dtype=str, na_filter=False, encoding="utf-8"
        )
        names = [name.strip() for name in header.iloc[0]]
        if (
            names[0] != "time"
            or "" in names
            or len(set(names)) != len(names)
            or _names_problem(names)
        ):
            return None, []
        table = pandas.read_csv(
            path,
            header=None,
            skiprows=1,
            dtype=numpy.float64,
            skip_blank_lines=False,
            encoding="utf-8",
            **_EXACT_FLOATS,
        )
    except (ValueError, OSError, pandas.errors.ParserError, pandas.errors.EmptyDataError):
        return None, []
    values = table.to_numpy(dtype=numpy.float64)
    if values.shape[1] != len(names) or len(values) == 0:
        return None, []
    if not numpy.isfinite(values).all():  # also a blank line (NaN): the text path decides
        return None, []
    return values, names


def _metadata(path: Path) -> dict[str, Any]:
    """The JSON beside the result CSV at ``path`` as a dict ({} when there is none), read
    within the limits of mechfmu.cosim.limits and checked to describe this very CSV
    (mechfmu.cosim.results.pair_problem: a pair whose two files come from two runs is
    refused)."""
    meta_path = companion_json(path)
    if not os.path.lexists(meta_path):
        return {}
    meta, problem = limits.load_json(meta_path)
    if problem:
        raise ResultFileError(f"{meta_path}: {problem}")
    if not isinstance(meta, dict):
        raise ResultFileError(f"{meta_path}: must hold a JSON object, got {type(meta).__name__}")
    units = meta.get("units", {})
    if not isinstance(units, dict) or not all(
        isinstance(unit, str) or unit is None for unit in units.values()
    ):
        raise ResultFileError(f"{meta_path}: 'units' must map column names to unit strings")
    problem = pair_problem(path, meta, meta_path)
    if problem:
        raise ResultFileError(problem)
    if meta.get("check") is not None:  # a reference's tolerances (its scene's [check] table)
        parse_check(meta["check"], str(meta_path), ResultFileError)
    return meta


def read_result(path: StrPath) -> pandas.DataFrame:
    """The result CSV at ``path`` (as ``mechfmu run`` writes it, or a reference CSV) as a
    DataFrame.

    The index is ``time`` in s (float64, strictly increasing); one float64 column per
    recorded variable, named as in the file (``gear.gear_angle``), values exactly as written.
    ``df.attrs["units"]`` maps each column to its SI unit (from ``<stem>.json`` beside the
    CSV; {} without one); the JSON's other keys (``scene``, ``step``, ``versions``, ...) are
    in ``df.attrs`` too, and ``df.attrs["file"]`` is ``path``.

    Raises ResultFileError (a ValueError) naming the file, and the line and column, for a
    missing or empty file, a first column that is not ``time``, an unnamed or repeated
    column, no data rows, a line with more or fewer values than the header (a cut last
    line), text or NaN or infinity where a number belongs, a blank line, or a time that does
    not increase; and for a malformed JSON beside it.
    """
    path = Path(path)
    _check_csv(path)
    values, names = _fast_values(path)
    if values is None:  # something is wrong: read it again as text to say what and where
        raw = _raw_rows(path)
        names = _header(path, raw, "time")
        if len(raw) < 2:
            raise ResultFileError(f"{path}: no data rows (only the header)")
        values = _numbers(path, raw.iloc[1:].to_numpy(), names)
    times = [float(time) for time in values[:, 0]]
    steps = numpy.diff(values[:, 0])
    if (steps <= 0.0).any():
        row = int(numpy.argmax(steps <= 0.0)) + 1
        kind = "repeats" if steps[row - 1] == 0.0 else "is before"
        raise ResultFileError(
            f"{path}: line {row + 2}: time {times[row]!r} s {kind} the "
            f"previous line's {times[row - 1]!r} s (times must increase)"
        )
    frame = pandas.DataFrame(
        values[:, 1:], columns=names[1:], index=pandas.Index(values[:, 0], name="time")
    )
    meta = _metadata(path)
    frame.attrs.update(meta)
    units = meta.get("units", {})
    frame.attrs["units"] = {name: units[name] for name in frame.columns if name in units}
    frame.attrs["file"] = str(path)
    return frame


def _result_frame(frame: pandas.DataFrame) -> pandas.DataFrame:
    """``frame`` checked as a result: a numeric time index (or a ``time`` column), string
    column names, numeric finite values; ValueError otherwise."""
    if not isinstance(frame, pandas.DataFrame):
        raise TypeError(f"a result must be a pandas DataFrame, got {type(frame).__name__}")
    if "time" in frame.columns:
        frame = frame.set_index("time")
    names = list(frame.columns)
    bad = [name for name in names if not isinstance(name, str) or not name or name == "time"]
    if bad:
        raise ValueError(
            f"result columns must be non-empty names other than 'time', got {bad[0]!r}"
        )
    if len(set(names)) != len(names):
        raise ValueError("result columns must have distinct names")
    try:
        times = numpy.asarray(frame.index, dtype=float)
        values = frame.to_numpy(dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f"a result holds numbers only (time index and columns): {error}") from None
    if not numpy.isfinite(times).all() or not numpy.isfinite(values).all():
        raise ValueError("a result holds finite numbers only (no NaN, no infinity)")
    if (numpy.diff(times) <= 0.0).any():
        raise ValueError("a result's times must increase strictly")
    return frame


def write_result(frame: pandas.DataFrame, path: StrPath) -> Path:
    """Write ``frame`` as a result CSV at ``path`` and its metadata as ``<stem>.json``
    beside it, both or neither (atomically, with the permissions the umask gives).

    The format is ``mechfmu run``'s: a ``time`` column (s) from the index (or from a
    ``time`` column), then one column per variable, every value as the shortest text that
    reads back to the same float, so ``read_result(write_result(df, p))`` equals ``df``.
    The JSON holds ``df.attrs`` (``units`` restricted to the columns written) and
    ``recorded``, the column names. Raises ValueError for a frame that is not a result
    (non-numeric or non-finite values, times not increasing, unnamed columns) and
    mechfmu.cosim.files.OutputError when a file cannot be written. Returns the CSV's path.
    """
    frame = _result_frame(frame)
    path = Path(path)
    names = [str(name) for name in frame.columns]
    columns = {name: frame[name].to_numpy(dtype=float).tolist() for name in names}
    meta: dict[str, Any] = {str(key): value for key, value in frame.attrs.items() if key != "file"}
    units = meta.get("units") or {}
    meta["units"] = {name: units[name] for name in names if name in units}
    meta["recorded"] = names
    remove_stale_temporaries(path.parent)
    atomic_write_all(
        sealed_pair(
            path,
            companion_json(path),
            csv_writer(frame.index.to_numpy(dtype=float).tolist(), columns),
            meta,
        )
    )
    return path


def read_table(
    path: StrPath,
    *,
    text: Iterable[str] = (),
    integers: Iterable[str] = (),
    required: Iterable[str] = (),
    missing: float | None = math.nan,
) -> pandas.DataFrame:
    """A CSV table mechfmu writes (a sweep's sweep.csv, the study's accuracy_cost.csv) as a
    DataFrame with a default index, one column per header name.

    Columns named in ``text`` stay strings (an empty cell is None); those in ``integers``
    are int64; every other column is float64, an empty cell ``missing`` (NaN: a sweep
    point without a value; with ``missing=None`` such a column holds Python floats and None,
    so an empty cell stays apart from a 'nan' written in the file). ``required`` columns
    must be in the header. Raises ResultFileError naming the file, and the line and column,
    for a missing or empty file, an unnamed, repeated or missing column, a line with more
    values than the header, or text where a number belongs.
    """
    path = Path(path)
    raw = _raw_rows(path)
    names = _header(path, raw, None)
    absent = [name for name in required if name not in names]
    if absent:
        raise ResultFileError(f"{path}: line 1: missing column(s) {', '.join(absent)}")
    text, integers = set(text), set(integers)
    body = raw.iloc[1:]
    frame = pandas.DataFrame(index=pandas.RangeIndex(len(body)))
    for position, name in enumerate(names):
        cells = body.iloc[:, position].to_numpy()
        if name in text:
            frame[name] = pandas.Series(
                [cell if cell != "" else None for cell in cells], dtype=object, index=frame.index
            )
            continue
        if name not in integers:
            problem = _problem_cell(path, cells[:, None], [name], 2, blank=True, finite=False)
            if problem is not None:
                raise problem
        if name in integers:
            try:
                frame[name] = numpy.array([int(cell) for cell in cells], dtype=numpy.int64)
            except ValueError:
                line = 2 + next(i for i, cell in enumerate(cells) if not _is_int(cell))
                raise ResultFileError(
                    f"{path}: line {line}, column {name!r}: "
                    f"{cells[line - 2]!r} is not a whole number"
                ) from None
        elif missing is None and (cells == "").any():
            frame[name] = pandas.Series(
                [float(cell) if cell != "" else None for cell in cells],
                dtype=object,
                index=frame.index,
            )
        else:
            frame[name] = numpy.array(
                [float(cell) if cell != "" else missing for cell in cells], dtype=float
            )
    return frame


def _is_int(text: str) -> bool:
    try:
        int(text)
    except ValueError:
        return False
    return True


def read_csv(path: StrPath) -> tuple[list[float], dict[str, list[float]]]:
    """(times, {column: values}) of a result CSV as lists of floats, read by read_result
    (ResultFileError naming the file, line and column for a malformed file)."""
    table = read_result(path)
    return table.index.tolist(), {name: table[name].tolist() for name in table.columns}
