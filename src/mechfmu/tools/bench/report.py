"""Benchmark rows and their files: bench.csv, bench.md and machine.json (each atomic)."""

from typing import Any
import csv
import datetime
import json
import os
import platform
from dataclasses import dataclass
from pathlib import Path

from ...cosim.files import atomic_write
from ...cosim.results import versions

CSV_COLUMNS = ("benchmark", "case", "value", "unit", "target", "meets_target", "repeats", "notes")
RATIO_UNIT = "ratio"
PARTS_SEPARATOR = " / "  # a ratio's notes start with "<numerator case> / <denominator case>"


@dataclass(frozen=True)
class Target:
    """A limit on a value, with the way the issue states it (e.g. '<= 1/3'): an upper
    limit, or a lower one with ``at_least`` (e.g. a speed-up '>= 1.7')."""

    limit: float
    label: str
    at_least: bool = False

    def met_by(self, value: float) -> bool:
        return value >= self.limit if self.at_least else value <= self.limit


@dataclass(frozen=True)
class Row:
    """One measurement: a time (value in ``unit``) or a ratio of two other rows."""

    benchmark: str
    case: str
    value: float
    unit: str
    repeats: int
    target: Target | None = None
    notes: str = ""

    def meets_target(self) -> str:
        """'true', 'false', or '' when the row has no target."""
        if self.target is None:
            return ""
        return "true" if self.target.met_by(self.value) else "false"

    def csv_fields(self) -> tuple[str, str, str, str, str, str, int, str]:
        return (
            self.benchmark,
            self.case,
            repr(float(self.value)),
            self.unit,
            self.target.label if self.target else "",
            self.meets_target(),
            self.repeats,
            self.notes,
        )


def ratio_row(
    case: str, numerator: Row, denominator: Row, target: Target | None = None, notes: str = ""
) -> Row:
    """The row ``numerator.value / denominator.value``; its notes name the two parts."""
    if numerator.unit != denominator.unit:
        raise ValueError(
            f"ratio of {numerator.case!r} ({numerator.unit}) to "
            f"{denominator.case!r} ({denominator.unit}): units differ"
        )
    parts = f"{numerator.case}{PARTS_SEPARATOR}{denominator.case}"
    return Row(
        numerator.benchmark,
        case,
        numerator.value / denominator.value,
        RATIO_UNIT,
        min(numerator.repeats, denominator.repeats),
        target,
        f"{parts}; {notes}" if notes else parts,
    )


def ratio_parts(row: Row) -> tuple[str, str]:
    """(numerator case, denominator case) named in a ratio row's notes."""
    numerator, denominator = row.notes.split("; ")[0].split(PARTS_SEPARATOR)
    return numerator, denominator


def write_csv(path: Path, rows: list[Row]) -> Path:
    def write(handle: Any) -> None:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(CSV_COLUMNS)
        writer.writerows(row.csv_fields() for row in rows)

    return atomic_write(path, write)


def _three_digits(value: float) -> str:
    return f"{value:.3g}" if abs(value) < 1e4 else f"{value:.0f}"


def markdown_table(rows: list[Row]) -> str:
    """The rows as a Markdown table (values to 3 significant digits)."""
    lines = ["| benchmark | case | value | unit | target | met |", "|---|---|---:|---|---|---|"]
    for row in rows:
        met = {"true": "yes", "false": "**no**", "": ""}[row.meets_target()]
        lines.append(
            f"| {row.benchmark} | {row.case} | {_three_digits(row.value)} | "
            f"{row.unit} | {row.target.label if row.target else ''} | {met} |"
        )
    return "\n".join(lines)


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo (Linux), else what platform reports."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as handle:
            for line in handle:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine() -> dict[str, Any]:
    """What the timings depend on: CPU, cores, OS, package versions, date (UTC)."""
    found = versions()
    return {
        "cpu": cpu_model(),
        "logical_cores": os.cpu_count(),
        "os": platform.platform(),
        "python": found["python"],
        "numpy": found["numpy"],
        "fmpy": found["fmpy"],
        "pythonfmu": found["pythonfmu"],
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }


def machine_line(info: dict[str, str | int]) -> str:
    return (
        f"Machine: {info['cpu']}, {info['logical_cores']} logical cores, {info['os']}; "
        f"Python {info['python']}, numpy {info['numpy']}, fmpy {info['fmpy']}, "
        f"pythonfmu {info['pythonfmu']}; {info['date']}."
    )


def write_outputs(out_dir: str | Path, rows: list[Row], info: dict[str, Any]) -> dict[str, Path]:
    """Write bench.csv, bench.md and machine.json into ``out_dir``; return their paths."""
    out_dir = Path(out_dir)
    text = f"{markdown_table(rows)}\n\n{machine_line(info)}\n"
    return {
        "csv": write_csv(out_dir / "bench.csv", rows),
        "md": atomic_write(out_dir / "bench.md", text),
        "machine": atomic_write(out_dir / "machine.json", json.dumps(info, indent=2)),
    }
