"""Result files of a run: CSV, JSON metadata and a PNG plot, each written atomically."""

from __future__ import annotations

from typing import TYPE_CHECKING
import csv
import json
import platform
import sys
from importlib import metadata

from .files import atomic_write, atomic_write_all, inside, move_aside, save_figure
from pathlib import Path
from typing import Any
from collections.abc import Callable

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .master import Result


def csv_writer(times: list[float], columns: dict[str, list[float]]) -> Callable:
    """A callback writing the CSV text: 'time' then one column per name; floats in shortest
    round-trip form."""
    names = list(columns)

    def write(handle: Any) -> None:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["time", *names])
        for i, time in enumerate(times):
            writer.writerow([repr(float(time)), *(repr(float(columns[n][i])) for n in names)])

    return write


def write_csv(path: Any, times: Any, columns: Any) -> Any:
    """Write the CSV of csv_writer atomically; returns its path."""
    return atomic_write(path, csv_writer(times, columns))


def versions() -> dict[str, str | None]:
    """Versions of the packages a result depends on."""
    found: dict[str, str | None] = {"python": platform.python_version()}
    for package in ("mechfmu", "fmpy", "pythonfmu", "numpy", "matplotlib"):
        try:
            found[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            found[package] = None
    return found


def json_text(data: dict[str, Any]) -> str:
    """The JSON text of a result's or a sweep's metadata (anything else as str)."""
    return json.dumps(data, indent=2, default=str)


def write_json(path: Path, data: dict[str, Any]) -> Path:
    """Write json_text(data) atomically; returns its path."""
    return atomic_write(path, json_text(data))


def write_plot(path: Any, times: Any, columns: Any, units: Any, title: Any) -> Any:
    """One panel per signal against time, y axes labelled with their units."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    names = list(columns)
    figure, axes = pyplot.subplots(
        len(names), 1, sharex=True, squeeze=False, figsize=(8, 1.1 + 1.7 * len(names))
    )
    for axis, name in zip(axes[:, 0], names):
        axis.plot(times, columns[name], linewidth=1.2)
        unit = units.get(name)
        axis.set_ylabel(
            f"{name.split('.', 1)[1]}\n[{unit}]" if unit else name.split(".", 1)[1], fontsize=8
        )
        axis.set_title(name, fontsize=8, loc="left")
        axis.grid(True, linewidth=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    figure.suptitle(title)
    figure.tight_layout()
    try:
        return save_figure(path, figure, dpi=100)
    finally:
        pyplot.close(figure)


RESULT_FILES = ("csv", "json", "png")


def result_stem(result: Result) -> str:
    """'<scene>' for a complete run, '<scene>.partial' for a failed or interrupted one."""
    return result.scene.name + (".partial" if result.partial else "")


def write_result(result: Result, out_dir: Path, plot: bool = True) -> dict[str, Path]:
    """Write <scene>.csv and .json as a pair (both or neither), then .png; ``.partial`` in
    the names for a failed or interrupted run. Every file lands inside ``out_dir``
    (OutputError otherwise). Returns {kind: path}."""
    stem = result_stem(result)
    paths = {kind: inside(out_dir, f"{stem}.{kind}") for kind in RESULT_FILES}
    meta = dict(result.meta)
    meta.update(
        {
            "scene": result.scene.name,
            "scene_file": str(result.scene.path),
            "description": result.scene.description,
            "partial": result.partial,
            "start_time": result.scene.start_time,
            "stop_time": result.scene.stop_time,
            "step": result.scene.step,
            "recorded": list(result.columns),
            "units": result.units,
            # the scene's [check] table, so a baseline made of this result keeps it
            "check": result.scene.check.as_dict() if result.scene.check else None,
            "versions": versions(),
            "command": sys.argv,
            "log": [entry for entry in result.log if entry["status"] != "ok"],
        }
    )
    atomic_write_all(
        {paths["csv"]: csv_writer(result.times, result.columns), paths["json"]: json_text(meta)}
    )
    written = {"csv": paths["csv"], "json": paths["json"]}
    if plot and result.times:
        written["png"] = write_plot(
            paths["png"],
            result.times,
            result.columns,
            result.units,
            f"{result.scene.name}" + (" (partial)" if result.partial else ""),
        )
    return written


def move_aside_complete(scene_name: str, out_dir: Path) -> list[Any]:
    """Rename an older complete result of ``scene_name`` in ``out_dir`` (<scene>.csv, .json,
    .png) to <scene>.previous.*, so a failed or interrupted run leaves no complete-looking
    result that is not its own. Returns the new paths."""
    return move_aside([inside(out_dir, f"{scene_name}.{kind}") for kind in RESULT_FILES])
