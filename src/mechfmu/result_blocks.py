"""Result files read block by block, in bounded memory: the layer under mechfmu.io.read_result
and the streamed ``mechfmu check``.

``open_result(path)`` gives a ResultSource: its column names (``time`` first), the metadata
of the JSON beside it (``attrs``) and ``blocks()``, an iterator over (row number of the first
row, float64 array of rows x columns) that reads about ``block_bytes`` of the file at a time.
A CSV block is parsed by pandas' C reader (exact floats); a block where anything looks wrong is
read again as text, with the header, to say what and where: every problem is a ResultFileError
whose one-line message names the file, the line and the column, exactly as a whole-file read
names them (a line cut short, text where a number belongs, a blank line, a time that does not
increase, also across two blocks). The file's size and SHA-256 are taken from the bytes as
they are read, so the check that the CSV is the one its JSON describes
(mechfmu.cosim.results.pair_problem) costs no second pass; it runs when the last block has
been read. A Parquet result (``.parquet``, pyarrow) is read by record batches the same way,
its problems named by data row.

Memory: one block of text (2 MiB by default) and its numbers, whatever the file's size; so a
source made for reading by blocks (``max_bytes=None``: ``mechfmu check``, iter_result) takes
a file of any size, one read whole (read_result) at most limits.MAX_CSV_BYTES.
"""

from __future__ import annotations

import csv
import ctypes
import functools
import hashlib
import io
import math
import os
import re
from collections.abc import Iterator
from os import PathLike
from pathlib import Path
from typing import Any

import numpy
import pandas

from .cosim import limits
from .cosim.results import pair_problem
from .cosim.tables import ResultFileError, check_file
from .cosim.tolerances import parse_check

StrPath = str | PathLike

# text read per block of a CSV: 2 MiB takes 8 % fewer instructions than 1 MiB (pandas' cost
# per call); 4 MiB was slower (the block and its tokens no longer fit in the cache)
BLOCK_BYTES = 2 * limits.MIB
BATCH_ROWS = 1 << 16  # rows per record batch of a Parquet file
MAX_HEADER_BYTES = limits.MAX_COLUMNS * (limits.MAX_COLUMN_NAME + 3)  # a header line at most
MAX_LINE_BYTES = 64 * limits.MIB  # a data line at most (ours: a few hundred bytes)

# pandas >= 3 parses floats exactly by default (and deprecates the option); pandas 2's
# default ("high") may be one ulp off, its "round_trip" converter is exact
EXACT_FLOATS: dict[str, Any] = (
    {} if int(pandas.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
)


# glibc's mallopt parameters (malloc.h) and the largest values its own sliding thresholds reach
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
MMAP_THRESHOLD_BYTES, TRIM_THRESHOLD_BYTES = 32 * limits.MIB, 64 * limits.MIB


@functools.cache
def reuse_freed_memory() -> bool:
    """Let the arrays of one block reuse the memory of the previous block's (glibc only).

    glibc maps an allocation over its mmap threshold (128 KiB at first) afresh and unmaps it
    when it is freed, and gives the heap's free top back above its trim threshold, so each
    block's arrays (a few MB of pandas' and numpy's buffers) were faulted in page by page
    again: 1.5 million page faults for a 2 GB pair, a fifth of the check's CPU time
    (measured: 0.7 of 3.0 CPU s for a 400 MB pair, 0.27 s with this). The thresholds are
    fixed at the largest values glibc's own sliding thresholds reach (32 MiB, 64 MiB), so
    the process keeps at most that much freed memory. Returns True when set; elsewhere
    (another C library) nothing is done and it returns False."""
    try:
        if not os.confstr("CS_GNU_LIBC_VERSION"):
            return False
        mallopt = ctypes.CDLL(None).mallopt
    except (ValueError, OSError, AttributeError):  # no glibc: no such name, no mallopt
        return False
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(
        mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
    )


def companion_json(path: StrPath) -> Path:
    """The metadata file of the result at ``path``: ``<stem>.json`` beside it."""
    return Path(path).with_suffix(".json")


# --- the text route: what is wrong, and where ----------------------------------------------


def names_problem(names: list[str]) -> str | None:
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


def check_csv(path: Path, max_bytes: int | None = limits.MAX_CSV_BYTES) -> None:
    """ResultFileError unless ``path`` is a regular file of at most ``max_bytes`` (None: any
    size) whose header (its first record, read alone by the csv module: a header of 10001
    columns costs no parse of the rows) is within the columns' limits."""
    check_file(path, max_bytes, "a CSV file")
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            header = next(csv.reader(handle), None)
    except (OSError, UnicodeDecodeError, csv.Error):
        return  # pandas' reading names these
    problem = names_problem([name.strip() for name in header or []])
    if problem:
        raise ResultFileError(f"{path}: line 1: {problem}")


def raw_rows(path: Path, source: Any = None, first_line: int = 1) -> pandas.DataFrame:
    """Every line of the CSV text ``source`` (default: the file at ``path``) as strings (row
    0 is the header), trailing blank lines dropped; ResultFileError naming ``path`` for an
    empty or unreadable text. ``first_line``: the file's line number of the text's second
    line (the first of a block read with the header in front of it), so messages name
    the file's lines."""
    shift = first_line - 2 if first_line > 1 else 0
    try:
        raw = pandas.read_csv(
            path if source is None else source,
            header=None,
            dtype=str,
            na_filter=False,
            skip_blank_lines=False,
            encoding="utf-8",
        )
    except pandas.errors.EmptyDataError:
        raise ResultFileError(f"{path}: empty file (no header, no data)") from None
    except pandas.errors.ParserError as error:
        # pandas: "Error tokenizing data. C error: Expected 3 fields in line 6, saw 4"
        found = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(error))
        if found:
            expected, line, seen = found.groups()
            raise ResultFileError(
                f"{path}: line {int(line) + shift} has {seen} values, the header {expected} columns"
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
        line = int(numpy.argmax(blank)) + 1
        raise ResultFileError(f"{path}: line {line + shift if line > 1 else line} is blank")
    return raw.iloc[:end]


def header_names(path: Path, cells: Any, first: str | None) -> list[str]:
    """The header row ``cells`` as stripped names, checked: within the limits, ``first``
    (unless None) the first, none empty, none twice; ResultFileError naming line 1."""
    names = [str(name).strip() for name in cells]
    problem = names_problem(names)
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


def problem_cell(
    path: Path,
    cells: numpy.ndarray,
    names: list[str],
    line0: int,
    blank: bool,
    finite: bool = True,
    place: str = "line",
) -> ResultFileError | None:
    """The error for the first cell of ``cells`` (strings or numbers, rows from file line
    ``line0``) that is not a number (not empty either with ``blank``, not finite with
    ``finite``), or None. ``place``: what a row is called ("line"; "row" in Parquet)."""
    for row_index, row in enumerate(cells):
        line = line0 + row_index
        for column, text in zip(names, row):
            if text == "" and blank:
                continue
            if text == "" and place != "line":
                return ResultFileError(
                    f"{path}: {place} {line}, column {column!r}: no value (null)"
                )
            if text == "":
                return ResultFileError(
                    f"{path}: {place} {line}, column {column!r}: empty field (the line has "
                    f"fewer values than the header: cut short?)"
                )
            try:
                value = float(text)
            except (TypeError, ValueError):
                return ResultFileError(
                    f"{path}: {place} {line}, column {column!r}: {text!r} is not a number"
                )
            if finite and not math.isfinite(value):
                return ResultFileError(
                    f"{path}: {place} {line}, column {column!r}: {text!r} is not a finite number"
                )
    return None


def numbers(path: Path, cells: numpy.ndarray, names: list[str], line0: int = 2) -> numpy.ndarray:
    """``cells`` (strings, rows from file line ``line0``) as float64, exactly as Python's
    float() reads each one; ResultFileError naming the line and column of the first that is
    not a finite number."""
    try:
        values = cells.astype(float)
    except ValueError:
        values = None
    if values is None or not numpy.isfinite(values).all():
        raise problem_cell(path, cells, names, line0, blank=False) or ResultFileError(
            f"{path}: a value is not a finite number"
        )
    return values


def time_problem(
    path: Path, times: numpy.ndarray, line0: int, previous: float | None, place: str = "line"
) -> ResultFileError | None:
    """The error for the first time of ``times`` (rows from ``line0``; ``previous``: the
    time of the row before them, or None) that does not increase, or None."""
    if previous is not None:
        times = numpy.concatenate(([previous], times))
        line0 -= 1
    steps = numpy.diff(times)
    if not (steps <= 0.0).any():
        return None
    row = int(numpy.argmax(steps <= 0.0)) + 1
    kind = "repeats" if steps[row - 1] == 0.0 else "is before"
    previous_name = "previous line's" if place == "line" else "previous row's"
    return ResultFileError(
        f"{path}: {place} {row + line0}: time {float(times[row])!r} s {kind} the "
        f"{previous_name} {float(times[row - 1])!r} s (times must increase)"
    )


# --- metadata --------------------------------------------------------------------------------


def metadata(path: Path, found: tuple[int, str] | None = None, pair: bool = True) -> dict:
    """The JSON beside the result at ``path`` as a dict ({} when there is none), read within
    the limits of mechfmu.cosim.limits and, with ``pair``, checked to describe this very file
    (pair_problem: a pair whose two files come from two runs is refused; ``found``: the
    file's size and SHA-256 when they are known already)."""
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
    if pair:
        check_pair(path, meta, found)
    if meta.get("check") is not None:  # a reference's tolerances (its scene's [check] table)
        parse_check(meta["check"], str(meta_path), ResultFileError)
    return meta


def check_pair(path: Path, meta: dict, found: tuple[int, str] | None = None) -> None:
    """ResultFileError unless the result file at ``path`` (CSV or Parquet) is the one
    ``meta`` (its JSON) describes by ``csv_bytes`` and ``csv_sha256`` (the names hold for
    a Parquet file too: its JSON says ``"format": "parquet"``)."""
    problem = pair_problem(path, meta, companion_json(path), found)
    if problem:
        raise ResultFileError(problem)


# --- sources -------------------------------------------------------------------------------


class ResultSource:
    """A result file opened for reading by blocks: ``names`` (``time`` first), ``attrs``
    (the JSON's metadata, ``units`` restricted to the columns, ``file``) and ``blocks()``."""

    path: Path
    names: list[str]
    attrs: dict[str, Any]

    @property
    def columns(self) -> list[str]:
        """The recorded columns (every name but ``time``)."""
        return self.names[1:]

    def _attrs(self, meta: dict[str, Any]) -> dict[str, Any]:
        attrs = dict(meta)
        units = meta.get("units", {})
        attrs["units"] = {name: units[name] for name in self.columns if name in units}
        attrs["file"] = str(self.path)
        return attrs

    def blocks(self) -> Iterator[tuple[int, numpy.ndarray]]:  # pragma: no cover - abstract
        """(number of the first row's line, float64 rows x columns) per block."""
        raise NotImplementedError


class CsvSource(ResultSource):
    """A result CSV read ``block_bytes`` of text at a time (see the module docstring), of at
    most ``max_bytes`` (None: any size)."""

    def __init__(
        self,
        path: StrPath,
        block_bytes: int = BLOCK_BYTES,
        max_bytes: int | None = limits.MAX_CSV_BYTES,
    ) -> None:
        self.path = Path(path)
        self.block_bytes = max(int(block_bytes), 1)
        check_csv(self.path, max_bytes)
        self._header = self._read_header()
        self.names = header_names(self.path, self._header_cells(), "time")
        self._meta = metadata(self.path, pair=False)
        self.attrs = self._attrs(self._meta)

    def _read_header(self) -> bytes:
        try:
            with open(self.path, "rb") as handle:
                header = handle.readline(MAX_HEADER_BYTES + 1)
        except OSError as error:
            raise ResultFileError(
                f"{self.path}: cannot be read: {error.strerror or error}"
            ) from None
        if not header:
            raise ResultFileError(f"{self.path}: empty file (no header, no data)")
        if len(header) > MAX_HEADER_BYTES and not header.endswith(b"\n"):
            raise ResultFileError(
                f"{self.path}: line 1 is longer than the limit of {MAX_HEADER_BYTES} bytes"
            )
        return header

    def _header_cells(self) -> list[str]:
        try:
            text = self._header.decode("utf-8")
        except UnicodeDecodeError:
            raise ResultFileError(f"{self.path}: not UTF-8 text") from None
        if not text.strip("\r\n"):  # a blank first line: the text route names it
            raw = raw_rows(self.path)
            return list(raw.iloc[0])
        try:
            cells = next(csv.reader([text.rstrip("\r\n")]), [])
        except csv.Error as error:
            raise ResultFileError(f"{self.path}: malformed CSV: {error}") from None
        return cells or [""]

    def _texts(self) -> Iterator[bytes]:
        """The data lines, about ``block_bytes`` at a time, each block ending at a line's
        end; every byte read (the header too) goes into the size, and into the SHA-256
        when the JSON has one to compare with."""
        digest = hashlib.sha256() if "csv_sha256" in self._meta else None
        size = 0
        with open(self.path, "rb") as handle:
            header = handle.readline(MAX_HEADER_BYTES + 1)
            if digest is not None:
                digest.update(header)
            size += len(header)
            while True:
                data = handle.read(self.block_bytes)
                if not data:
                    break
                if not data.endswith(b"\n"):
                    rest = handle.readline(MAX_LINE_BYTES)
                    data += rest
                    if len(rest) == MAX_LINE_BYTES and not rest.endswith(b"\n"):
                        line = 1 + self._lines_before + data.count(b"\n") + 1
                        raise ResultFileError(
                            f"{self.path}: line {line} is longer than the limit of "
                            f"{MAX_LINE_BYTES} bytes"
                        )
                if digest is not None:
                    digest.update(data)
                size += len(data)
                yield data
        self.found = (size, digest.hexdigest() if digest is not None else "")

    def blocks(self) -> Iterator[tuple[int, numpy.ndarray]]:
        """(file line of the block's first row, float64 rows x columns) per block; after
        the last, the pair check against the JSON (ResultFileError if they differ)."""
        reuse_freed_memory()
        self._lines_before = 0  # data lines (rows and pending blank lines) before the block
        rows = 0
        blank_from: int | None = None  # the first of trailing blank lines seen so far
        previous: float | None = None
        for data in self._texts():
            line0 = 2 + self._lines_before
            values, blank_lines = self._parse(data, line0)
            if len(values) and blank_from is not None:
                raise ResultFileError(f"{self.path}: line {blank_from} is blank")
            if blank_lines and blank_from is None:
                blank_from = line0 + len(values)
            if len(values):
                problem = time_problem(self.path, values[:, 0], line0, previous)
                if problem:
                    raise problem
                previous = float(values[-1, 0])
                rows += len(values)
                yield line0, values
            self._lines_before += len(values) + blank_lines  # every line a row or blank
        if rows == 0:
            raise ResultFileError(f"{self.path}: no data rows (only the header)")
        check_pair(self.path, self._meta, self.found)

    def _parse(self, data: bytes, line0: int) -> tuple[numpy.ndarray, int]:
        """The rows of ``data`` as float64 and how many blank lines end it; the fast route
        first, the text route where it finds anything wrong."""
        try:
            table = pandas.read_csv(
                io.BytesIO(data),
                header=None,
                dtype=numpy.float64,
                na_filter=False,  # no NA words: an empty field or "NA" fails, to the text route
                skip_blank_lines=False,
                encoding="utf-8",
                **EXACT_FLOATS,
            )
            values = table.to_numpy(dtype=numpy.float64)
            if values.shape[1] == len(self.names) and numpy.isfinite(values).all():
                return values, 0
        except (ValueError, pandas.errors.ParserError, pandas.errors.EmptyDataError):
            pass
        raw = raw_rows(self.path, io.BytesIO(self._header + data), first_line=line0)
        lines = data.count(b"\n") + (0 if data.endswith(b"\n") else 1)
        cells = raw.iloc[1:].to_numpy()
        if cells.shape[1] != len(self.names):  # fewer values on every line than the header
            cells = raw.iloc[1:].reindex(columns=range(len(self.names)), fill_value="")
            cells = cells.to_numpy()
        return numbers(self.path, cells, self.names, line0), lines - len(cells)


class ParquetSource(ResultSource):
    """A result in a Parquet file, read by record batches of ``batch_rows`` rows, of at most
    ``max_bytes`` (None: any size)."""

    def __init__(
        self,
        path: StrPath,
        batch_rows: int = BATCH_ROWS,
        max_bytes: int | None = limits.MAX_CSV_BYTES,
    ) -> None:
        self.path = Path(path)
        self.batch_rows = max(int(batch_rows), 1)
        check_file(self.path, max_bytes, "a Parquet file")
        self._file = _parquet_file(self.path)
        schema = self._file.schema_arrow
        self.names = header_names(self.path, list(schema.names), "time")
        for field in schema:
            if not (_numeric(field.type)):
                raise ResultFileError(
                    f"{self.path}: column {field.name!r} holds {field.type}, not numbers"
                )
        self._meta = metadata(self.path, pair=False)
        self.attrs = self._attrs(self._meta)

    def blocks(self) -> Iterator[tuple[int, numpy.ndarray]]:
        """(number of the block's first data row, float64 rows x columns) per record batch;
        then the pair check against the JSON."""
        row0, previous = 1, None
        try:
            batches = self._file.iter_batches(batch_size=self.batch_rows)
            for batch in batches:
                values = numpy.column_stack(
                    [column.to_numpy(zero_copy_only=False) for column in batch.columns]
                ).astype(numpy.float64)
                if not numpy.isfinite(values).all():
                    cells = values.astype(object)
                    for column in range(values.shape[1]):  # a null reads as NaN: name it
                        nulls = batch.column(column).is_null().to_numpy(zero_copy_only=False)
                        cells[nulls, column] = ""
                    raise problem_cell(
                        self.path, cells, self.names, row0, blank=False, place="row"
                    ) or ResultFileError(f"{self.path}: a value is not a finite number")
                problem = time_problem(self.path, values[:, 0], row0, previous, place="row")
                if problem:
                    raise problem
                if len(values):
                    previous = float(values[-1, 0])
                row0 += len(values)
                yield row0 - len(values), values
        except OSError as error:  # pyarrow's errors (ArrowInvalid, ArrowIOError) are OSErrors
            raise ResultFileError(f"{self.path}: malformed Parquet file: {error}") from None
        if row0 == 1:
            raise ResultFileError(f"{self.path}: no data rows")
        check_pair(self.path, self._meta)


def _numeric(kind: Any) -> bool:
    import pyarrow

    return bool(pyarrow.types.is_floating(kind) or pyarrow.types.is_integer(kind))


def _parquet_file(path: Path) -> Any:
    """A pyarrow ParquetFile; ResultFileError when pyarrow is missing or the file is not
    Parquet."""
    try:
        import pyarrow.parquet
    except ImportError:
        raise ResultFileError(
            f"{path}: reading Parquet needs pyarrow: pip install 'mechfmu[parquet]'"
        ) from None
    try:
        return pyarrow.parquet.ParquetFile(path)
    except (OSError, ValueError) as error:
        raise ResultFileError(f"{path}: malformed Parquet file: {error}") from None


def open_result(
    path: StrPath, block_bytes: int = BLOCK_BYTES, max_bytes: int | None = limits.MAX_CSV_BYTES
) -> ResultSource:
    """The result at ``path`` opened for reading by blocks: a Parquet file when its name
    ends in ``.parquet``, else a CSV (``block_bytes`` of text per block; for Parquet about
    as many rows as that many bytes of CSV hold); a file over ``max_bytes`` is refused
    (None: a file of any size, for a reader that keeps one block at a time)."""
    if Path(path).suffix == ".parquet":
        return ParquetSource(path, batch_rows=max(block_bytes // 160, 1), max_bytes=max_bytes)
    return CsvSource(path, block_bytes, max_bytes)


def read_values(source: ResultSource) -> numpy.ndarray:
    """Every row of ``source`` as one float64 array (rows x columns)."""
    parts = [values for _, values in source.blocks()]
    if len(parts) == 1:
        return parts[0]
    return numpy.concatenate(parts)
