"""Result files of a run: CSV, JSON metadata and a PNG plot, each written atomically.

The CSV and its JSON are one pair that cannot be mixed: the JSON holds the run's identifier
(``run_id``), the CSV's size in bytes (``csv_bytes``) and its SHA-256 (``csv_sha256``),
computed from the bytes as they are written (``ChecksumWriter``: a CSV streamed row by row
gets them the same way; the JSON is made last). Readers (mechfmu.io.read_result) compare
the CSV with them (``pair_problem``) and refuse a CSV beside the JSON of another run: a
writer killed between its two renames, or two runs into one folder. The JSON is renamed
into place first, so a CSV never stands beside a JSON older than itself, and the PNG of an
older run is removed before the pair is written, so it never stands beside a newer pair.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import csv
import hashlib
import io
import json
import os
import platform
import secrets
import sys
from importlib import metadata

from .text import plot_text
from .files import OutputError, atomic_write, atomic_write_all, inside, move_aside, save_figure
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


class ChecksumWriter:
    """A text handle for csv.writer: what is written goes to ``sink`` (a binary handle) as
    UTF-8, and its size in bytes and SHA-256 are kept as it goes (no second pass over a
    file that may be large, or streamed)."""

    def __init__(self, sink: Any) -> None:
        self.sink = sink
        self.digest = hashlib.sha256()
        self.size = 0

    def write(self, text: str) -> int:
        data = text.encode("utf-8")
        self.sink.write(data)
        self.digest.update(data)
        self.size += len(data)
        return len(text)

    def seal(self) -> dict[str, Any]:
        """What the JSON records of the CSV written so far: csv_bytes and csv_sha256."""
        return {"csv_bytes": self.size, "csv_sha256": self.digest.hexdigest()}


def new_run_id() -> str:
    """A run's identifier: 32 random hex digits (the JSON's ``run_id``)."""
    return secrets.token_hex(16)


def sealed_pair(
    csv_path: Path, json_path: Path, write_csv_text: Callable[[Any], None], meta: dict[str, Any]
) -> dict[Path, bytes | str]:
    """The contents of a result pair for atomic_write_all, JSON first: the CSV that
    ``write_csv_text`` writes to a text handle, and ``meta`` with its ``run_id`` (kept when
    ``meta`` has one, else new) and the CSV's size and checksum."""
    sink = io.BytesIO()
    handle = ChecksumWriter(sink)
    write_csv_text(handle)
    sealed = {key: value for key, value in meta.items() if key not in PAIR_KEYS}
    sealed["run_id"] = meta.get("run_id") or new_run_id()
    sealed.update(handle.seal())
    return {json_path: json_text(sealed), csv_path: sink.getvalue()}


PAIR_KEYS = ("run_id", "csv_bytes", "csv_sha256")


def _file_digest(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def pair_problem(csv_path: Path, meta: dict[str, Any], json_path: Path) -> str | None:
    """Why the CSV at ``csv_path`` is not the one its JSON (``meta``, read from
    ``json_path``) describes, or None. A JSON without ``csv_sha256`` (written before pairs
    were sealed, or by hand) describes any CSV."""
    if "csv_sha256" not in meta:
        return None
    expected_size, expected_digest = meta.get("csv_bytes"), meta.get("csv_sha256")
    if (
        not isinstance(expected_size, int)
        or isinstance(expected_size, bool)
        or not isinstance(expected_digest, str)
    ):
        return f"{json_path}: 'csv_bytes' and 'csv_sha256' must be an integer and a string"
    try:
        size = os.stat(csv_path).st_size
        digest = _file_digest(csv_path) if size == expected_size else None
    except OSError as error:
        return f"{csv_path}: cannot be read: {error.strerror or error}"
    if size == expected_size and digest == expected_digest:
        return None
    found = f"{size} bytes" + (f", SHA-256 {digest[:16]}..." if digest else "")
    return (
        f"{csv_path} and {json_path.name} are not one pair: the JSON (run "
        f"{str(meta.get('run_id'))[:32]}) describes a CSV of {expected_size} bytes, SHA-256 "
        f"{expected_digest[:16]}..., the CSV has {found}: one of the two comes from another "
        f"run (a writer stopped between them) or was changed; run again to write both"
    )


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
        variable = plot_text(name.split(".", 1)[-1])
        axis.set_ylabel(f"{variable}\n[{plot_text(unit)}]" if unit else variable, fontsize=8)
        axis.set_title(plot_text(name), fontsize=8, loc="left")
        axis.grid(True, linewidth=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    figure.suptitle(plot_text(title))
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
    try:  # an older run's plot must not stand beside this run's pair
        os.unlink(paths["png"])
    except FileNotFoundError:
        pass
    except OSError as error:
        raise OutputError(f"cannot replace {paths['png']}: {error.strerror or error}") from None
    atomic_write_all(
        sealed_pair(paths["csv"], paths["json"], csv_writer(result.times, result.columns), meta)
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
