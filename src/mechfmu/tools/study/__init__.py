"""The accuracy study: what each digit of accuracy costs in wall time (``mechfmu study``).

For each dynamic scene (design.SCENES) it sweeps the communication step, the integrator
and its tolerance or sub-step, and the master's coupling; measures every recorded output
against the scene's tight reference; and writes, into the output folder:

accuracy_cost.csv   one row per (point, output): errors, cost, work counters, status
<scene>.png         headline error against cost, log-log, Pareto front marked
<scene>_sources.png the coupling error alone and the integration error alone
pareto.md           per scene, the cheapest setting for each target error (the docs' table)
study.json          the sweep's definition, the machine and the study's own wall time

``--scenes`` studies some scenes again: the rows of the others are kept from the existing
accuracy_cost.csv, and the plots and tables are written for every scene it holds.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import csv
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

from ...cosim.files import atomic_write
from ...cosim.master import Simulation
from ...cosim.results import versions
from ..progress import Progress
from . import design, measure, report
from argparse import Namespace

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    import pandas

    from .design import StudyScene


def _write_rows(path: Any, rows: Any):
    def write(handle: Any) -> None:
        writer = csv.DictWriter(handle, fieldnames=measure.COLUMNS, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow(
                {
                    key: (repr(value) if isinstance(value, float) else value)
                    for key, value in row.items()
                }
            )

    return atomic_write(path, write)


NUMBER_COLUMNS, INTEGER_COLUMNS = measure.NUMBER_COLUMNS, measure.INTEGER_COLUMNS


def read_table(path: Path | str) -> pandas.DataFrame:
    """An accuracy_cost.csv as a pandas DataFrame (mechfmu.io.read_table): the counters
    int64, the errors (in the output's SI unit), tolerances and times (s) float64, the
    rest strings. ResultFileError (a ValueError) naming the file, line and column for a
    malformed file."""
    from ...io import read_table as read

    return read(path, text=measure.TEXT_COLUMNS, integers=INTEGER_COLUMNS, required=measure.COLUMNS)


def read_rows(path: Path | str) -> list[dict[str, Any]]:
    """The rows of an accuracy_cost.csv as dicts, numbers as numbers (read_table's)."""
    rows: list[dict[str, Any]] = [
        {str(key): value for key, value in row.items()}
        for row in read_table(path).to_dict("records")
    ]
    for row in rows:
        for key, value in row.items():
            if value is None:
                row[key] = ""  # an empty text cell, as written
            elif key in INTEGER_COLUMNS:
                row[key] = int(value)
            elif key in NUMBER_COLUMNS:
                row[key] = float(value)
    return rows


def headline_unit(scene_dir: Path, fmu_dir: Path, study_scene: StudyScene) -> str:
    """The unit of the scene's headline output, from its FMU's model description."""
    simulation = Simulation(design.load(scene_dir, study_scene), fmu_dir)
    units = {name: variable.unit or "1" for name, _, variable in simulation.recorded}
    return units[study_scene.headline]


def pareto_markdown(rows: list[dict[str, float]], units: dict[str, str]) -> str:
    """pareto.md: for each studied scene in ``units`` (scene name -> its headline output's
    unit), in the design's order, a heading and its cheapest-setting table."""
    return (
        "\n\n".join(
            f"#### {s.name}\n\n" + report.front_table(rows, s, units[s.name])
            for s in design.SCENES
            if s.name in units
        )
        + "\n"
    )


def work_precision_command(args: Namespace) -> int:
    """``mechfmu study --work-precision``: write work_precision.csv and .md into args.out,
    print the summary; the exit status (1 if an error is not finite)."""
    from . import work_precision

    started = time.perf_counter()
    tolerances = work_precision.QUICK_TOLERANCES if args.quick else work_precision.TOLERANCES
    repeats = 1 if args.quick else args.repeats
    frame = work_precision.table(tolerances=tolerances, repeats=repeats)
    out = Path(args.out)
    paths = [
        atomic_write(out / "work_precision.csv", frame.to_csv(index=False)),
        atomic_write(out / "work_precision.md", work_precision.markdown(frame)),
    ]
    print(work_precision.markdown(frame))
    for path in paths:
        print(f"wrote {path}")
    print(
        f"{len(frame)} runs in {time.perf_counter() - started:.0f} s (wall times: median "
        f"of {repeats})"
    )
    return 0 if frame["error"].map(math.isfinite).all() else 1


def command(args: Namespace) -> Any:
    """``mechfmu study`` with the parsed command line ``args`` (options in mechfmu/cli.py);
    the exit status."""
    if getattr(args, "work_precision", False):
        return work_precision_command(args)
    names = args.scenes or [s.name for s in design.SCENES]
    chosen = [s for s in design.SCENES if s.name in names]
    unknown = set(names) - {s.name for s in design.SCENES}
    if unknown:
        print(
            f"study: unknown scene(s) {', '.join(sorted(unknown))}; studied scenes: "
            f"{', '.join(s.name for s in design.SCENES)}",
            file=sys.stderr,
        )
        return 2
    started = time.perf_counter()
    out = Path(args.out)
    # Studying some scenes again keeps the rows of the others from the previous study: read
    # it first, so a malformed one costs nothing.
    previous = out / "accuracy_cost.csv"
    try:
        previous_rows = read_rows(previous) if previous.is_file() else []
    except ValueError as error:  # ResultFileError: the file, line and column
        print(f"study error: {error}", file=sys.stderr)
        return 2
    scenes, points = {}, []
    for study_scene in chosen:
        scene = design.load(args.scene_dir, study_scene)
        print(f"{scene.name}: reference on the {study_scene.steps[0]:g} s grid ...", flush=True)
        scenes[scene.name] = (scene, study_scene, measure.reference(scene, study_scene))
        points += design.points(study_scene, design.couplings_of(scene), args.quick)
    print(
        f"running {len(points)} points on {args.workers} worker(s), {args.repeats} repeat(s) each",
        flush=True,
    )
    meter = Progress(len(points), sys.stdout, label="study", unit="points")
    rows = measure.run_points(
        points,
        scenes,
        args.fmu_dir,
        args.repeats,
        args.workers,
        lambda done, total, point: meter.update(done, note=f"{point.scene}: {point.label()}"),
    )
    kept = [row for row in previous_rows if row["scene"] not in scenes]
    rows = kept + rows
    paths = [_write_rows(previous, rows)]
    reported = [s for s in design.SCENES if any(row["scene"] == s.name for row in rows)]
    units = {s.name: headline_unit(args.scene_dir, args.fmu_dir, s) for s in reported}
    for study_scene in reported:
        unit = units[study_scene.name]
        paths.append(report.plot_front(rows, study_scene, unit, out / f"{study_scene.name}.png"))
        paths.append(
            report.plot_sources(rows, study_scene, unit, out / f"{study_scene.name}_sources.png")
        )
    paths.append(atomic_write(out / "pareto.md", pareto_markdown(rows, units)))
    elapsed = time.perf_counter() - started
    failed = sorted(
        {
            (
                r["scene"],
                r["integrator"],
                r["tolerance"],
                r["max_substep"],
                r["step"],
                r["coupling"],
            )
            for r in rows
            if r["status"] != "ok"
        }
    )
    definition = {
        "scenes": {
            s.name: {
                "component": s.component,
                "headline": s.headline,
                "steps": list(s.steps),
                "fixed_substeps": list(s.substeps),
            }
            for s in chosen
        },
        "tolerances": list(design.TOLERANCES),
        "jacobi_tolerances": list(design.JACOBI_TOLERANCES),
        "quick": args.quick,
        "repeats": args.repeats,
        "workers": args.workers,
        "points": len(points),
        "failed_points": len(failed),
        "rows_kept_from_the_previous_study": sorted({row["scene"] for row in kept}),
        "study_wall_time_s": elapsed,
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor(),
            "cores": os.cpu_count(),
        },
        "versions": versions(),
        "command": sys.argv,
    }
    paths.append(atomic_write(out / "study.json", json.dumps(definition, indent=2)))
    for path in paths:
        print(f"wrote {path}")
    print(
        f"{len(points)} points ({len(failed)} refused by the FMU, recorded with their "
        f"error) in {elapsed:.0f} s"
    )
    return (
        0
        if rows and all(math.isfinite(r["loop_time_s"]) or r["status"] != "ok" for r in rows)
        else 1
    )
