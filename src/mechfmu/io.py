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

import io
import math
from collections.abc import Iterable, Iterator
from os import PathLike
from pathlib import Path
from typing import Any

import numpy
import pandas

from .cosim import limits
from .cosim.files import atomic_write_all, remove_stale_temporaries
from .cosim.results import CountingFile, csv_writer, json_text, sealed_meta, sealed_pair
from .cosim.tables import ResultFileError, read_profile_table
from .result_blocks import (
    BLOCK_BYTES,
    check_csv,
    companion_json,
    header_names,
    open_result,
    problem_cell,
    raw_rows,
    read_values,
)

__all__ = [
    "ResultFileError",
    "companion_json",
    "iter_result",
    "read_profile_table",
    "read_result",
    "read_table",
    "write_result",
]

StrPath = str | PathLike


def read_result(path: StrPath, *, block_bytes: int = BLOCK_BYTES) -> pandas.DataFrame:
    """The result at ``path`` (a CSV as ``mechfmu run`` writes it, a reference CSV, or a
    ``.parquet`` result) as a DataFrame.

    The index is ``time`` in s (float64, strictly increasing); one float64 column per
    recorded variable, named as in the file (``gear.gear_angle``), values exactly as written.
    ``df.attrs["units"]`` maps each column to its SI unit (from ``<stem>.json`` beside the
    file; {} without one); the JSON's other keys (``scene``, ``step``, ``versions``, ...) are
    in ``df.attrs`` too, and ``df.attrs["file"]`` is ``path``.

    The file is read ``block_bytes`` of text at a time (mechfmu.result_blocks): the memory it
    takes is the numbers' (8 bytes per value, twice while the blocks are joined) plus one
    block, so a file over limits.MAX_CSV_BYTES (2 GiB) is refused (iter_result and
    ``mechfmu check`` read any size).

    Raises ResultFileError (a ValueError) naming the file, and the line and column, for a
    missing, empty or too large file, a first column that is not ``time``, an unnamed or repeated
    column, no data rows, a line with more or fewer values than the header (a cut last
    line), text or NaN or infinity where a number belongs, a blank line, or a time that does
    not increase; and for a malformed JSON beside it.
    """
    source = open_result(path, block_bytes, limits.MAX_CSV_BYTES)
    values = read_values(source)
    frame = pandas.DataFrame(
        values[:, 1:], columns=source.columns, index=pandas.Index(values[:, 0], name="time")
    )
    frame.attrs.update(source.attrs)
    return frame


def iter_result(path: StrPath, *, block_bytes: int = BLOCK_BYTES) -> Iterator[pandas.DataFrame]:
    """The result at ``path`` (CSV or ``.parquet``) as DataFrames of consecutive rows, about
    ``block_bytes`` of the file each, indexed by time like read_result's (each with its
    attrs): a file of any size (no limits.MAX_CSV_BYTES) in the memory of one block.
    Raises ResultFileError as read_result does, when the block holding the problem is
    reached (the rows before it have been given)."""
    source = open_result(path, block_bytes, max_bytes=None)
    for _, values in source.blocks():
        frame = pandas.DataFrame(
            values[:, 1:], columns=source.columns, index=pandas.Index(values[:, 0], name="time")
        )
        frame.attrs.update(source.attrs)
        yield frame


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
    """Write ``frame`` as a result CSV at ``path`` (a Parquet file when ``path`` ends in
    ``.parquet``: parquet_pair) and its metadata as ``<stem>.json`` beside it, both or
    neither (atomically, with the permissions the umask gives).

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
    if path.suffix == ".parquet":
        atomic_write_all(parquet_pair(path, frame, meta))
        return path
    atomic_write_all(
        sealed_pair(
            path,
            companion_json(path),
            csv_writer(frame.index.to_numpy(dtype=float).tolist(), columns),
            meta,
        )
    )
    return path


def parquet_pair(path: Path, frame: pandas.DataFrame, meta: dict[str, Any]) -> dict[Path, Any]:
    """The contents of a Parquet result and its JSON for atomic_write_all, JSON first: a
    ``time`` column then one float64 column per variable (pyarrow, compressed by its
    default codec), and ``meta`` with a ``run_id``, ``"format": "parquet"`` and the file's
    size and SHA-256 under the names a CSV's have (``csv_bytes``, ``csv_sha256``: what
    read_result checks, as for a run's ``--format parquet``). ResultFileError without
    pyarrow."""
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        raise ResultFileError(
            f"{path}: writing Parquet needs pyarrow: pip install 'mechfmu[parquet]'"
        ) from None
    arrays = {"time": frame.index.to_numpy(dtype=float)}
    arrays.update({str(name): frame[name].to_numpy(dtype=float) for name in frame.columns})
    sink = io.BytesIO()
    counted = CountingFile(sink)
    pyarrow.parquet.write_table(pyarrow.table(arrays), counted)
    sealed = sealed_meta({**meta, "format": "parquet"}, counted)
    return {companion_json(path): json_text(sealed), path: sink.getvalue()}


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
    check_csv(path)
    raw = raw_rows(path)
    names = header_names(path, raw.iloc[0], None)
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
            problem = problem_cell(path, cells[:, None], [name], 2, blank=True, finite=False)
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
