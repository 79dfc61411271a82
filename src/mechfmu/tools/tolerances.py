"""Measure what each shipped scene's check tolerance rests on (``make tolerances``).

For every shipped scene with a reference, and every column of it, four errors as fractions of
the column's peak |value| in the committed reference:

- ``run``: the worst |result - reference| of the results given (``mechfmu run --all`` into
  one folder per Python: the FMUs compute with the standard library, so this is also the
  spread across CPython versions);
- ``spread``: the worst |result - first result| between those folders;
- ``reference``: the committed reference's own error: |reference - a tighter solve| for the
  integrated references (scipy at rtol 1e-13 instead of 1e-12, atol / 100), 0 for closed
  forms;
- ``dispatch``: the worst |reference - regenerated reference| of the folders of references
  given (``mechfmu references`` under each narrowing of numpy's SIMD dispatch).

The rule the shipped [check] tables follow: R = the smallest power of ten at least 10 times
the worst column's total (run + reference + dispatch), the scene's ``rtol = R`` and each
column's ``atol = R * peak`` rounded up to one significant digit (a column whose peak is 0
keeps the table's atol). ``python -m mechfmu.tools.tolerances --results D1 D2 --references
R1 R2`` prints the measurements, the table the rule gives and whether the declared one
satisfies it.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from collections.abc import Sequence
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

import numpy as np

from ..cosim.scene import REFERENCE_DIR, SCENE_DIR, Scene, load_scene
from ..io import read_result
from ..references import gear_dynamics, suspension_dynamics, valve_spring
from .scene_references import INTEGRATED, REFERENCES

MARGIN = 10.0  # the declared tolerance is at least this many times the measured total


def tighter_reference(scene: Scene) -> dict[str, np.ndarray]:
    """The integrated reference of ``scene`` solved 10 times tighter (rtol 1e-13, atol /
    100): what its committed reference's own error is measured against."""
    saved = (
        gear_dynamics.TOLERANCE,
        suspension_dynamics.TOLERANCE,
        valve_spring.TOLERANCE,
        valve_spring.ATOL,
    )
    gear_dynamics.TOLERANCE = suspension_dynamics.TOLERANCE = valve_spring.TOLERANCE = 1e-13
    length, speed, work = valve_spring.ATOL
    valve_spring.ATOL = (length / 100, speed / 100, work / 100)
    try:
        with warnings.catch_warnings():  # scipy: rtol near its floor of 100 eps
            warnings.simplefilter("ignore")
            columns = REFERENCES[scene.name](scene)
    finally:
        (
            gear_dynamics.TOLERANCE,
            suspension_dynamics.TOLERANCE,
            valve_spring.TOLERANCE,
            valve_spring.ATOL,
        ) = saved
    return {name: np.asarray(values, dtype=float) for name, values in columns.items()}


def _worst(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b), initial=0.0))


def measure(
    name: str, results: Sequence[Path], references: Sequence[Path] = ()
) -> list[dict[str, Any]]:
    """One row per column of scene ``name``'s reference: column, peak, and the errors of
    the module docstring (absolute, in the column's unit)."""
    scene = load_scene(SCENE_DIR / f"{name}.toml")
    reference = read_result(REFERENCE_DIR / f"{name}.csv")
    runs = [read_result(Path(folder) / f"{name}.csv") for folder in results]
    regenerated = [read_result(Path(folder) / f"{name}.csv") for folder in references]
    tight = tighter_reference(scene) if name in INTEGRATED else None
    rows = []
    for column in reference.columns:
        values = reference[column].to_numpy()
        rows.append(
            {
                "column": column,
                "peak": float(np.max(np.abs(values))),
                "least": float(np.min(np.abs(values))),
                "run": max(_worst(run[column].to_numpy(), values) for run in runs),
                "spread": max(
                    _worst(run[column].to_numpy(), runs[0][column].to_numpy()) for run in runs
                ),
                "reference": _worst(tight[column], values) if tight is not None else 0.0,
                "dispatch": max(
                    (_worst(other[column].to_numpy(), values) for other in regenerated),
                    default=0.0,
                ),
            }
        )
    return rows


def ruled_tolerance(rows: list[dict[str, Any]]) -> float:
    """R: the smallest power of ten >= MARGIN times the worst column's (run + reference +
    dispatch) / peak."""
    worst = max(
        (
            (row["run"] + row["reference"] + row["dispatch"]) / row["peak"]
            for row in rows
            if row["peak"] > 0
        ),
        default=0.0,
    )
    return 10.0 ** math.ceil(math.log10(max(MARGIN * worst, 1e-15)))


def round_up(value: float) -> float:
    """``value`` rounded up to one significant digit (2.3e-8 -> 3e-8)."""
    exponent = math.floor(math.log10(value))
    return math.ceil(value / 10.0**exponent - 1e-9) * 10.0**exponent


def proposed_table(rows: list[dict[str, Any]], why: str = "...") -> str:
    """The [check] table the rule gives, as TOML."""
    tolerance = ruled_tolerance(rows)
    lines = ["[check]", f"rtol = {tolerance:g}", f'why = "{why}"', "[check.columns]"]
    for row in rows:
        if row["peak"] > 0:
            lines.append(f'"{row["column"]}" = {{ atol = {round_up(tolerance * row["peak"]):g} }}')
    return "\n".join(lines)


def satisfied(scene: Scene, rows: list[dict[str, Any]]) -> list[str]:
    """The columns whose declared allowance (atol + rtol * the least |reference|, the
    narrowest the band gets) is less than MARGIN times the measured total (run + reference
    + dispatch): the rule's breaches."""
    check = scene.check
    if check is None:
        return ["no [check] table"]
    breaches = []
    for row in rows:
        rtol, atol = check.rtol, check.atol
        for pattern, entry in check.columns.items():
            if fnmatchcase(row["column"], pattern) and entry.compare:
                rtol = entry.rtol if entry.rtol is not None else rtol
                atol = entry.atol if entry.atol is not None else atol
        total = row["run"] + row["reference"] + row["dispatch"]
        narrowest = atol + rtol * row["least"]
        if MARGIN * total > narrowest:
            breaches.append(f"{row['column']}: {MARGIN:g} x {total:.2e} > {narrowest:.2e}")
    return breaches


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m mechfmu.tools.tolerances", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument(
        "--results",
        nargs="+",
        required=True,
        metavar="DIR",
        help="folders of 'mechfmu run --all' (one per Python)",
    )
    parser.add_argument(
        "--references",
        nargs="*",
        default=[],
        metavar="DIR",
        help="folders of 'mechfmu references' (one per numpy dispatch; default: none)",
    )
    parser.add_argument("scenes", nargs="*", help="scene names (default: every reference)")
    args = parser.parse_args(argv)
    names = args.scenes or sorted(path.stem for path in REFERENCE_DIR.glob("*.csv"))
    status = 0
    for name in names:
        rows = measure(name, [Path(d) for d in args.results], [Path(d) for d in args.references])
        print(f"## {name}\n")
        print("| column | peak | run | spread | reference | dispatch |\n|---|---|---|---|---|---|")
        for row in rows:
            peak = row["peak"] or 1.0
            print(
                f"| {row['column']} | {row['peak']:.3g} | "
                + " | ".join(
                    f"{row[key]:.1e} ({row[key] / peak:.1e})"
                    for key in ("run", "spread", "reference", "dispatch")
                )
                + " |"
            )
        print(f"\nrule: R = {ruled_tolerance(rows):g}\n\n```toml\n{proposed_table(rows)}\n```")
        breaches = satisfied(load_scene(SCENE_DIR / f"{name}.toml"), rows)
        print(f"declared: {'satisfies the rule' if not breaches else '; '.join(breaches)}\n")
        status |= bool(breaches)
    return status


if __name__ == "__main__":
    sys.exit(main())
