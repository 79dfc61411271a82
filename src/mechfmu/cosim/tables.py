"""Table files a scene names, read on the host before it runs (pandas), and the error of
every CSV file mechfmu cannot read.

``read_profile_table`` reads a LoadProfile or RoadProfile ``table_file`` by the rules of the
FMU's own reader, so a bad table is reported with its line and column before any FMU loads
(cosim.scene.check_tables). mechfmu.io re-exports both names.
"""

from __future__ import annotations

import math
import warnings
from os import PathLike
from pathlib import Path

import numpy
import pandas

from . import limits

StrPath = str | PathLike


class ResultFileError(ValueError):
    """A CSV (or its JSON metadata) mechfmu cannot read; the one-line message names the file
    and what is wrong (with the line and column where they apply)."""


def check_file(path: Path, max_bytes: int | None, kind: str) -> None:
    """ResultFileError unless ``path`` is a regular file of at most ``max_bytes`` (None: any)
    (mechfmu.cosim.limits.file_problem); ``kind`` names what a directory is not."""
    problem = limits.file_problem(path, max_bytes)
    if problem:
        if problem.startswith("is a directory"):
            problem = f"is a directory, not {kind}"
        raise ResultFileError(f"{path}: {problem}")


def read_profile_table(path: StrPath) -> pandas.DataFrame:
    """A LoadProfile or RoadProfile ``table_file`` (shape = "table") as a DataFrame, read on
    the host before a run, by the rules of the FMU's own reader
    (mechfmu.runtime.physics.profiles.read_table): the first two values of each line are a
    time in s and a value (further values are ignored); blank lines and lines starting with
    ``#`` are skipped; the first other line may be a header naming the two columns; times
    finite and strictly increasing, values finite, at least one row.

    Returns a DataFrame indexed by ``time`` with one float64 column, named as in the header
    (``value`` without one). Raises ResultFileError naming the file, the line and the column
    for a missing or unreadable file, a line with one value, text where a number belongs, a
    non-finite number, a time that does not increase, or no data rows.
    """
    path = Path(path)
    check_file(path, limits.MAX_TABLE_BYTES, "a table file")
    try:
        with warnings.catch_warnings():  # lines with more values: the first two are kept
            warnings.simplefilter("ignore", pandas.errors.ParserWarning)
            raw = pandas.read_csv(
                path,
                header=None,
                names=[0, 1],
                index_col=False,
                dtype=str,
                na_filter=False,
                skip_blank_lines=False,
                encoding="utf-8",
                engine="python",
                on_bad_lines=lambda fields: fields[:2],
            )
        raw = raw.fillna("")  # a blank line or a line with one value: empty cells
    except pandas.errors.EmptyDataError:
        raise ResultFileError(f"{path}: no data rows (empty file)") from None
    except UnicodeDecodeError:
        raise ResultFileError(f"{path}: not UTF-8 text") from None
    except (OSError, pandas.errors.ParserError) as error:
        raise ResultFileError(f"{path}: cannot be read: {error}") from None
    names = ("time", "value")
    times: list[float] = []
    values: list[float] = []
    header_seen = False
    for number, (first, second) in enumerate(raw.itertuples(index=False), start=1):
        if (not first and not second) or first.lstrip().startswith("#"):
            continue
        try:
            time, value = float(first), float(second)
        except ValueError:
            if not times and not header_seen:
                header_seen = True
                names = (first.strip() or "time", second.strip() or "value")
                continue
            if not second:
                raise ResultFileError(
                    f"{path}: line {number}: expected 'time,value', got only {first!r}"
                ) from None
            bad = 0 if not _is_float(first) else 1
            raise ResultFileError(
                f"{path}: line {number}, column {names[bad]!r}: "
                f"{(first, second)[bad]!r} is not a number"
            ) from None
        for column, number_ in zip(names, (time, value)):
            if not math.isfinite(number_):
                raise ResultFileError(
                    f"{path}: line {number}, column {column!r}: {number_!r} is not a finite number"
                )
        if times and time <= times[-1]:
            raise ResultFileError(
                f"{path}: line {number}: time {time!r} s is not after "
                f"{times[-1]!r} s (times must increase)"
            )
        times.append(time)
        values.append(value)
    if not times:
        raise ResultFileError(f"{path}: no data rows")
    return pandas.DataFrame(
        {names[1]: numpy.asarray(values, dtype=float)},
        index=pandas.Index(numpy.asarray(times, dtype=float), name="time"),
    )


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
