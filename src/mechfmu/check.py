"""Compare results with references: CSV against CSV within explicit tolerances, and the
report of a scene run against its reference."""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
from dataclasses import dataclass

import numpy as np

from .cosim.results import read_csv
from pathlib import Path

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .cosim.master import Result


@dataclass
class Deviation:
    column: str
    time: float
    value: float
    reference: float
    allowed: float

    @property
    def size(self) -> float:
        return abs(self.value - self.reference)

    def __str__(self) -> str:
        return (f"{self.column} at t = {self.time!r} s: {self.value!r} vs reference "
                f"{self.reference!r} (|difference| {self.size:.3e}, allowed {self.allowed:.3e})")


@dataclass
class Comparison:
    ok: bool
    columns: list       # compared column names
    samples: int        # result samples inside the reference's time span
    worst: Deviation | None  # largest deviation relative to its allowance (None if no samples)

    def __str__(self) -> str:
        verdict = "match" if self.ok else "MISMATCH"
        worst = f"; worst: {self.worst}" if self.worst else ""
        return f"{verdict}: {len(self.columns)} column(s), {self.samples} sample(s){worst}"


def compare(result_path: Path, reference_path: Path, rtol: float=1e-9, atol: float=1e-12) -> Comparison:
    """Interpolate the reference onto the result's times and compare shared columns.

    A sample passes when |value - reference| <= atol + rtol * |reference|; NaN never passes.
    Raises ValueError when the files share no column or no time span.
    """
    times, columns = read_csv(result_path)
    ref_times, ref_columns = read_csv(reference_path)
    shared = [name for name in columns if name in ref_columns]
    if not shared:
        raise ValueError(f"{result_path} and {reference_path} share no column besides time")
    times, ref_times = np.asarray(times), np.asarray(ref_times)
    span = (times >= ref_times[0] - 1e-12) & (times <= ref_times[-1] + 1e-12)
    if not span.any():
        raise ValueError(f"{result_path} has no time inside the reference's "
                         f"[{ref_times[0]}, {ref_times[-1]}] s")
    worst, worst_score = None, -1.0
    for name in shared:
        values = np.asarray(columns[name])[span]
        reference = np.interp(times[span], ref_times, np.asarray(ref_columns[name]))
        allowed = atol + rtol * np.abs(reference)
        score = np.abs(values - reference) / allowed
        score[~np.isfinite(values)] = np.inf
        i = int(np.argmax(score))
        if score[i] > worst_score:
            worst_score = float(score[i])
            worst = Deviation(name, float(times[span][i]), float(values[i]),
                              float(reference[i]), float(allowed[i]))
    return Comparison(worst_score <= 1.0, shared, int(span.sum()), worst)


def worst_deviations(result: Any, reference_path: Any) -> Any:
    """Per recorded column that the reference CSV shares: (column, worst |difference|,
    unit, time of it in s, that difference as a fraction of the column's peak |reference|).
    The reference is interpolated onto the result's times; ``result`` is a cosim Result."""
    ref_times, reference = read_csv(reference_path)
    times = np.asarray(result.times)
    rows = []
    for name, values in result.columns.items():
        if name not in reference:
            continue
        expected = np.interp(times, np.asarray(ref_times), np.asarray(reference[name]))
        difference = np.abs(np.asarray(values) - expected)
        i = int(np.argmax(difference))
        peak = max(float(np.max(np.abs(expected))), 1e-300)
        rows.append((name, float(difference[i]), result.units.get(name) or "",
                     float(times[i]), float(difference[i]) / peak))
    return rows


def run_report(result: Result, paths: dict[str, Path], reference: Path | None=None, rtol: float=1e-9, atol: float=1e-12, label: str="reference") -> tuple[list[str], Comparison | None]:
    """What ``mechfmu run`` (and every example) prints about a run: steps and wall time, the
    FMUs' non-ok log messages, with a ``reference`` CSV each column's worst deviation and the
    verdict of ``mechfmu check`` at (rtol, atol), then the files written. Returns (lines,
    Comparison or None)."""
    lines = [f"{result.scene.name}: {result.meta['steps']} steps of {result.scene.step} s in "
             f"{result.meta['wall_time_s']:.3f} s wall time"]
    lines += [f"  [{entry['status']}] {entry['message']}" for entry in result.log
              if entry["status"] != "ok"]
    comparison = None
    if reference is not None:
        lines.append(f"  worst deviation from the {label} (absolute; as a fraction of the "
                     f"column's peak |value|):")
        for name, difference, unit, time, fraction in worst_deviations(result, reference):
            lines.append(f"    {name:34s} {difference:.2e} {unit:6s} at t = {time:.5g} s "
                         f"({fraction:.1e} of peak)")
        comparison = compare(paths["csv"], reference, rtol, atol)
        lines.append(f"  against the {label} (rtol {rtol:g}, atol {atol:g}): {comparison}")
    lines += [f"  {kind}: {path}" for kind, path in paths.items()]
    return lines, comparison
