"""Baselines: accepted results kept as CSV files, which ``mechfmu check`` compares new
results with; ``mechfmu baseline update RESULTS BASELINES`` accepts new results.

Each result CSV (a file, or every ``*.csv`` under a folder, by relative path) is read and
checked first: a malformed one stops the update before anything is written. Then each is
compared exactly (rtol = atol = 0) with its baseline and classed as new, changed (with the
largest absolute and relative difference of every changed column) or unchanged; new and
changed files are copied byte for byte, with their ``<stem>.json`` metadata when there is
one, all atomically (every file or none). Unchanged baselines are not rewritten. Baselines
without a result are kept, or with ``prune`` removed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import pandas as pd

from .comparison import compare
from .cosim import limits
from .cosim.files import OutputError, atomic_write_all, error_cause


class BaselineError(ValueError):
    """Results that cannot be accepted (missing, malformed); nothing was written."""


@dataclass
class BaselineChange:
    """What an update does to one baseline: ``status`` is "new", "changed", "unchanged",
    "removed" or "kept" (a baseline without a result, not pruned); ``details`` says how
    much changed."""

    name: str
    status: str
    details: str = ""

    def line(self) -> str:
        return f"{self.name}: {self.status}" + (f": {self.details}" if self.details else "")


def _changes(result: pd.DataFrame, baseline: pd.DataFrame) -> str:
    """How ``result`` differs from ``baseline`` (DataFrames), as one line."""
    comparison = compare(result, baseline, rtol=0.0, atol=0.0)
    parts = []
    for row in comparison.failures.to_dict("records"):
        if row["kind"] == "missing column":
            parts.append(f"column {row['column']} removed")
        elif row["kind"] == "extra column":
            parts.append(f"column {row['column']} added")
        elif row["kind"] == "time grid":
            parts.append(
                f"time grid changed ({len(baseline)} -> {len(result)} samples, "
                f"{baseline.index[0]!r}..{baseline.index[-1]!r} s -> "
                f"{result.index[0]!r}..{result.index[-1]!r} s)"
            )
    changed = comparison.summary[comparison.summary["failing"] > 0]
    for column, stats in changed.iterrows():
        parts.append(
            f"{column} max |difference| {stats['max_abs']:.3g} "
            f"({stats['max_rel']:.3g} of peak) at t = {stats['max_abs_time']:.6g} s"
        )
    return "; ".join(parts)


def _csv_files(folder: Path) -> dict[str, Path]:
    return {
        p.relative_to(folder).as_posix(): p for p in sorted(folder.rglob("*.csv")) if p.is_file()
    }


def update_baselines(
    results: str | PathLike,
    baselines: str | PathLike,
    *,
    prune: bool = False,
    dry_run: bool = False,
) -> list[BaselineChange]:
    """Accept the result CSVs under ``results`` (a folder, or one CSV file) as the
    baselines under ``baselines`` (a folder); see the module docstring. ``dry_run``: only
    say what would change. Returns one BaselineChange per file, by relative path.

    Raises BaselineError (nothing written) for a missing ``results``, a folder without CSV
    files, or a malformed result (the message names the file, line and column), and
    mechfmu.cosim.files.OutputError when a baseline cannot be written.
    """
    from .io import ResultFileError, read_result

    results, baselines = Path(results), Path(baselines)
    problem = limits.path_problem(results)
    if problem is not None:
        raise BaselineError(
            f"results {limits.message_text(results)} "
            + ("do not exist" if problem == "does not exist" else problem)
        )
    problem = limits.path_problem(baselines)
    if problem not in (None, "does not exist"):
        raise BaselineError(f"baselines {limits.message_text(baselines)} {problem}")
    if problem is None and not baselines.is_dir():
        raise BaselineError(f"baselines {baselines} is not a folder")
    found = _csv_files(results) if results.is_dir() else {results.name: results}
    if not found:
        raise BaselineError(f"no CSV file under {results}")
    existing = _csv_files(baselines) if baselines.is_dir() else {}
    if not results.is_dir():
        existing = {name: path for name, path in existing.items() if name == results.name}
    frames = {}
    for name, path in found.items():
        try:
            frames[name] = read_result(path)
        except ResultFileError as error:
            raise BaselineError(f"not accepted: {error}") from None
    changes, contents = [], {}
    for name, path in found.items():
        target = baselines / name
        if name not in existing:
            frame = frames[name]
            change = BaselineChange(
                name, "new", f"{len(frame.columns)} column(s), {len(frame)} sample(s)"
            )
        else:
            try:
                details = _changes(frames[name], read_result(target))
            except ResultFileError as error:
                details = f"the old baseline was unreadable ({error})"
            change = BaselineChange(name, "changed" if details else "unchanged", details)
        changes.append(change)
        if change.status != "unchanged":
            contents[target] = path.read_bytes()
            meta = path.with_suffix(".json")
            if meta.is_file():
                contents[target.with_suffix(".json")] = meta.read_bytes()
    removed = []
    for name, path in existing.items():
        if name not in found:
            changes.append(
                BaselineChange(
                    name,
                    "removed" if prune else "kept",
                    "" if prune else "no result (--prune removes it)",
                )
            )
            if prune:
                removed.append(path)
    if not dry_run:
        if contents:
            atomic_write_all(contents)
        for path in removed:
            for victim in (path, path.with_suffix(".json")):
                try:
                    if victim.exists():
                        os.unlink(victim)
                except OSError as error:
                    raise OutputError(f"cannot remove {victim}: {error_cause(error)}") from None
    return sorted(changes, key=lambda change: change.name)


def summary(changes: list[BaselineChange], baselines: str | PathLike, dry_run: bool) -> str:
    """The last line of ``mechfmu baseline update``: counts per status."""
    counts = {
        status: sum(1 for c in changes if c.status == status)
        for status in ("new", "changed", "unchanged", "removed", "kept")
    }
    text = ", ".join(f"{count} {status}" for status, count in counts.items() if count)
    return f"{'would update' if dry_run else 'updated'} {baselines}: {text}"
