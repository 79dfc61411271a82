"""Regression checks: a result (file or folder of CSV files) against a reference, the report
of a scene run against its reference, and what ``mechfmu check`` prints.

``check_paths`` matches the CSV files of two folders by relative path (or takes two files)
and compares each pair with ``mechfmu.compare``; every problem (a missing file, a malformed
one, a missing or extra column, a different time grid, a value out of tolerance) becomes a
failure naming the file, and the line, column and time where they apply.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .comparison import Comparison, Tolerance
from .cosim import limits
from .comparison import compare as compare_frames

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .cosim.master import Result


def compare(
    result_path: str | PathLike,
    reference_path: str | PathLike,
    rtol: float | None = None,
    atol: float | None = None,
) -> Comparison:
    """The check of ``mechfmu run --check``: the result CSV against a reference CSV.

    The reference is interpolated linearly onto the result's times (which must start and end
    where the reference's do); every column of the reference must be in the result, and the
    result's other recorded columns are not compared. A sample passes when
    ``|value - reference| <= atol + rtol * |reference|``, at the tolerances the reference
    declares (the ``check`` of its JSON: its scene's [check] table) unless ``rtol`` or
    ``atol`` are given. Raises mechfmu.io.ResultFileError (a ValueError) naming the file for
    a malformed one.
    """
    return compare_frames(
        result_path, reference_path, rtol=rtol, atol=atol, interpolate=True, ignore_extra=True
    )


@dataclass
class FileCheck:
    """One file of a check: ``name`` (its relative path), the two paths, and either the
    Comparison or the problem that prevented it (``kind``: "missing file", "malformed
    file" or "no reference"; ``problem`` the one-line message)."""

    name: str
    result: Path | None
    reference: Path | None
    comparison: Comparison | None = None
    kind: str | None = None
    problem: str | None = None

    @property
    def compared(self) -> bool:
        return self.comparison is not None

    @property
    def passed(self) -> bool:
        """True when compared and matching, or when the result has no reference (which is
        listed but not a failure)."""
        if self.comparison is not None:
            return self.comparison.passed
        return self.kind == "no reference"

    def line(self) -> str:
        """The one-line summary ``mechfmu check`` prints for this file."""
        if self.comparison is not None:
            return f"{self.name}: {self.comparison}"
        if self.kind == "missing file":
            return f"{self.name}: MISMATCH: missing file: {self.problem}"
        if self.kind == "no reference":
            return f"{self.name}: not compared: {self.problem}"
        return f"{self.name}: MISMATCH: malformed file: {self.problem}"


@dataclass
class CheckRun:
    """Every FileCheck of one ``mechfmu check``, and the options it ran with."""

    files: list[FileCheck]
    options: dict[str, Any] = field(default_factory=dict)
    error: str | None = None  # why nothing could be compared (exit 2)

    @property
    def exit_code(self) -> int:
        """0 every file matches, 1 any mismatch (a missing or malformed file too), 2 nothing
        comparable (the paths cannot be compared, or no file has a reference)."""
        if self.error:
            return 2
        if not all(f.passed for f in self.files):
            return 1
        return 0 if any(f.result and f.reference for f in self.files) else 2

    def summary(self) -> str:
        """The last line ``mechfmu check`` prints."""
        if self.error:
            return f"check error: {self.error}"
        matched = sum(1 for f in self.files if f.compared and f.passed)
        failed = sum(1 for f in self.files if not f.passed)
        skipped = sum(1 for f in self.files if f.kind == "no reference")
        text = f"{len(self.files)} file(s): {matched} match, {failed} mismatch"
        if skipped:
            text += f", {skipped} without reference (not compared)"
        if self.exit_code == 2:
            text += "; nothing to compare"
        return text

    def unused_tolerances(self) -> list[str]:
        """The ``tolerances`` keys that matched no compared column of any file."""
        from fnmatch import fnmatchcase

        columns = {
            c for f in self.files if f.comparison is not None for c in f.comparison.summary.index
        }
        columns |= {
            c
            for f in self.files
            if f.comparison is not None
            for c in f.comparison.reference.columns
        }
        return [
            key
            for key in self.options.get("tolerances") or {}
            if not any(fnmatchcase(c, key) for c in columns)
        ]


def _results(folder: Path) -> dict[str, Path]:
    """The result files under ``folder`` by relative path, a Parquet file under the name of
    the CSV it stands for (``a/b.parquet`` as ``a/b.csv``; the CSV wins where both are)."""
    found = {}
    for pattern in ("*.parquet", "*.csv"):
        for path in folder.rglob(pattern):
            if path.is_file():
                found[path.relative_to(folder).with_suffix(".csv").as_posix()] = path
    return found


def _pairs(
    result: Path, reference: Path
) -> tuple[list[tuple[str, Path | None, Path | None]], str | None]:
    """(relative name, result file, reference file) for every CSV (or Parquet) file,
    matched by relative path; and an error when the arguments cannot be compared at all."""
    for path, what in ((result, "result"), (reference, "reference")):
        problem = limits.path_problem(path)
        if problem is not None:
            return [], f"{what} {limits.message_text(path)} {problem}"
    if result.is_dir() != reference.is_dir():
        if result.is_dir():
            return [], (
                f"result {result} is a folder but reference {reference} is a file "
                f"(give two folders, two files, or a file and a folder)"
            )
        # a file against its namesake in a folder (a Parquet result against the CSV): the
        # two names _results would give that key, looked up without walking the folder
        key = reference / Path(result.name).with_suffix(".csv")
        namesakes = [path for path in (key, key.with_suffix(".parquet")) if path.is_file()]
        return [(result.name, result, namesakes[0] if namesakes else None)], None
    if not result.is_dir():
        return [(result.name, result, reference)], None
    found, wanted = _results(result), _results(reference)
    names = sorted(set(found) | set(wanted))
    if not names:
        return [], f"no CSV file in {result} nor in {reference}"
    return [
        (
            found[name].relative_to(result).as_posix() if name in found else name,
            found.get(name),
            wanted.get(name),
        )
        for name in names
    ], None


def check_paths(
    result: str | PathLike,
    reference: str | PathLike,
    *,
    rtol: float | None = None,
    atol: float | None = None,
    method: str | None = None,
    time_tolerance: float | None = None,
    tolerances: Mapping[str, Tolerance] | None = None,
    interpolate: bool = False,
    ignore_extra: bool = False,
    block_bytes: int | None = None,
) -> CheckRun:
    """Compare ``result`` with ``reference``: two CSV files, two folders (their CSV files,
    matched by relative path, in sub-folders too) or a file and the folder holding its
    namesake. The options are ``mechfmu.compare``'s (None: each reference's declared
    tolerances, the ``check`` of the JSON beside it, else the defaults). A reference file without a result is a
    "missing file" failure; a result without a reference is listed but not compared; a file
    that cannot be read is a "malformed file" failure naming the line and column. Each pair
    is read block by block (``block_bytes`` of text at a time, default
    result_blocks.BLOCK_BYTES, 2 MiB): the memory it takes does not grow with the files'
    size."""
    from .io import ResultFileError

    options = {
        "rtol": rtol,
        "atol": atol,
        "method": method,
        "time_tolerance": time_tolerance,
        "tolerances": dict(tolerances or {}),
        "interpolate": interpolate,
        "ignore_extra": ignore_extra,
    }
    pairs, error = _pairs(Path(result), Path(reference))
    files = []
    for name, result_file, reference_file in pairs:
        check = FileCheck(name, result_file, reference_file)
        files.append(check)
        if result_file is None:
            check.kind = "missing file"
            check.problem = f"no {Path(result) / name} for reference {reference_file}"
            continue
        if reference_file is None:
            check.kind, check.problem = "no reference", f"no reference file for {result_file}"
            continue
        try:  # both files read block by block: memory bounded whatever their size
            check.comparison = compare_frames(
                result_file,
                reference_file,
                block_bytes=block_bytes,
                **options,  # type: ignore[arg-type]
            )
        except ResultFileError as problem:
            check.kind, check.problem = "malformed file", str(problem)
    return CheckRun(files, options, error)


def worst_deviations(result: Any, reference_path: Any) -> Any:
    """Per recorded column that the reference CSV shares: (column, worst |difference|,
    unit, time of it in s, that difference as a fraction of the column's peak |reference|).
    The reference is interpolated onto the result's times; ``result`` is a cosim Result."""
    from .io import read_result

    frame = read_result(reference_path)
    ref_times = frame.index.to_numpy(dtype=float)
    reference = {name: frame[name].to_numpy(dtype=float) for name in frame.columns}
    times = np.asarray(result.times)
    rows = []
    for name, values in result.columns.items():
        if name not in reference:
            continue
        expected = np.interp(times, np.asarray(ref_times), np.asarray(reference[name]))
        difference = np.abs(np.asarray(values) - expected)
        i = int(np.argmax(difference))
        peak = max(float(np.max(np.abs(expected))), 1e-300)
        rows.append(
            (
                name,
                float(difference[i]),
                result.units.get(name) or "",
                float(times[i]),
                float(difference[i]) / peak,
            )
        )
    return rows


def compared_deviations(comparison: Comparison, units: dict[str, str]) -> Any:
    """worst_deviations' rows from a Comparison's summary (its max_abs, max_abs_time and
    max_rel): for a run whose rows went to its file alone (result.kept False), so that the
    file is read once, block by block, by the comparison."""
    return [
        (
            str(name),
            float(row["max_abs"]),
            units.get(str(name)) or "",
            float(row["max_abs_time"]),
            float(row["max_rel"]),
        )
        for name, row in comparison.summary.iterrows()
    ]


def run_report(
    result: Result,
    paths: dict[str, Path],
    reference: Path | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    label: str = "reference",
) -> tuple[list[str], Comparison | None]:
    """What ``mechfmu run`` (and every example) prints about a run: steps and wall time, the
    FMUs' non-ok log messages, with a ``reference`` CSV each column's worst deviation and the
    verdict of ``mechfmu check`` at (rtol, atol) (None: the reference's declared ones), then
    the files written. Returns (lines, Comparison or None)."""
    lines = [
        (
            f"{result.scene.name}: {result.meta['steps']} steps of {result.scene.step} s "
            f"in {result.meta['wall_time_s']:.3f} s wall time"
        )
    ]
    lines += [
        f"  [{entry['status']}] {entry['message']}"
        for entry in result.log
        if entry["status"] != "ok"
    ]
    comparison = None
    if reference is not None:
        lines.append(
            f"  worst deviation from the {label} (absolute; as a fraction of the "
            f"column's peak |value|):"
        )
        data = paths.get("csv") or paths["parquet"]
        comparison = compare(data, reference, rtol, atol)
        deviations = (
            worst_deviations(result, reference)
            if result.kept
            else compared_deviations(comparison, result.units)
        )
        for name, difference, unit, time, fraction in deviations:
            lines.append(
                f"    {name:34s} {difference:.2e} {unit:6s} at t = {time:.5g} s "
                f"({fraction:.1e} of peak)"
            )
        lines.append(f"  against the {label} ({comparison.tolerance_text()}): {comparison}")
    lines += [f"  {kind}: {path}" for kind, path in paths.items()]
    return lines, comparison
