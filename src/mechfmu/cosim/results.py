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
import importlib
import io
import json
import math
import os
import platform
import secrets
import sys
from array import array
from importlib import metadata

from .text import plot_text
from .files import (
    OutputError,
    atomic_write,
    error_cause,
    atomic_write_all,
    inside,
    move_aside,
    save_figure,
)
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


class _Counted:
    """Bytes passed on to ``sink`` (a binary handle), their size and SHA-256 kept as they go
    (no second pass over a file that may be large, or streamed)."""

    def __init__(self, sink: Any) -> None:
        self.sink = sink
        self.digest = hashlib.sha256()
        self.size = 0

    def _take(self, data: bytes) -> None:
        self.sink.write(data)
        self.digest.update(data)
        self.size += len(data)

    def seal(self) -> dict[str, Any]:
        """What the JSON records of the data written so far: csv_bytes and csv_sha256."""
        return {"csv_bytes": self.size, "csv_sha256": self.digest.hexdigest()}


class ChecksumWriter(_Counted):
    """A text handle for csv.writer: what is written goes to ``sink`` as UTF-8, counted."""

    def write(self, text: str) -> int:
        self._take(text.encode("utf-8"))
        return len(text)


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
    return {json_path: json_text(sealed_meta(meta, handle)), csv_path: sink.getvalue()}


def sealed_meta(meta: dict[str, Any], counted: _Counted) -> dict[str, Any]:
    """``meta`` with the pair's keys: its ``run_id`` (kept when ``meta`` has one, else new)
    and the size and SHA-256 of the data ``counted`` wrote."""
    sealed = {key: value for key, value in meta.items() if key not in PAIR_KEYS}
    sealed["run_id"] = meta.get("run_id") or new_run_id()
    sealed.update(counted.seal())
    return sealed


PAIR_KEYS = ("run_id", "csv_bytes", "csv_sha256")


def _file_digest(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def pair_problem(
    csv_path: Path,
    meta: dict[str, Any],
    json_path: Path,
    found: tuple[int, str] | None = None,
) -> str | None:
    """Why the CSV at ``csv_path`` is not the one its JSON (``meta``, read from
    ``json_path``) describes, or None. A JSON without ``csv_sha256`` (written before pairs
    were sealed, or by hand) describes any CSV. ``found``: the CSV's size in bytes and
    SHA-256 when the caller has them from reading it (no second pass over the file)."""
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
        size = found[0] if found else os.stat(csv_path).st_size
        digest = None if size != expected_size else found[1] if found else _file_digest(csv_path)
    except OSError as error:
        return f"{csv_path}: cannot be read: {error.strerror or error}"
    if size == expected_size and digest == expected_digest:
        return None
    seen = f"{size} bytes" + (f", SHA-256 {digest[:16]}..." if digest else "")
    return (
        f"{csv_path} and {json_path.name} are not one pair: the JSON (run "
        f"{str(meta.get('run_id'))[:32]}) describes a CSV of {expected_size} bytes, SHA-256 "
        f"{expected_digest[:16]}..., the CSV has {seen}: one of the two comes from another "
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


RESULT_FILES = ("csv", "parquet", "json", "png")
FORMATS = ("csv", "parquet")  # the forms of a run's rows (mechfmu run --format)


def result_stem(result: Result) -> str:
    """'<scene>' for a complete run, '<scene>.partial' for a failed or interrupted one."""
    return result.scene.name + (".partial" if result.partial else "")


def result_meta(result: Result) -> dict[str, Any]:
    """What a result's JSON says about its run (without the pair's keys)."""
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
    return meta


def _unlink(path: Path) -> None:
    """Remove ``path`` if it exists (OutputError naming it when it cannot be removed)."""
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
    except OSError as error:
        raise OutputError(f"cannot replace {path}: {error_cause(error)}") from None


def write_result(result: Result, out_dir: Path, plot: bool = True) -> dict[str, Path]:
    """Write <scene>.csv and .json as a pair (both or neither), then .png; ``.partial`` in
    the names for a failed or interrupted run. Every file lands inside ``out_dir``
    (OutputError otherwise). Returns {kind: path}. (``mechfmu run`` streams its rows
    instead: StreamedResult.)"""
    stem = result_stem(result)
    paths = {kind: inside(out_dir, f"{stem}.{kind}") for kind in RESULT_FILES}
    meta = result_meta(result)
    _unlink(paths["png"])  # an older run's plot must not stand beside this run's pair
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


# --- a run's rows streamed to disk as they are made ---------------------------------------

PLOT_POINTS = 20_000  # rows of a long run the PNG plots (every k-th: PlotSample)
CSV_VALUE_BYTES = 25  # most bytes a value takes in the CSV: repr of a double and a comma
PARQUET_VALUE_BYTES = 9  # about what a float64 takes in Parquet (uncompressed, with pages)
PARQUET_ROW_GROUP = 65_536  # rows per Parquet row group (memory: that many rows)


class PlotSample:
    """Every k-th row of a run, at most PLOT_POINTS of them; k doubles (every other kept
    row let go) when they would be more: what the PNG of a run of any length plots, in
    bounded memory."""

    def __init__(self) -> None:
        self.stride, self.seen = 1, 0
        self.times: list[float] = []
        self.columns: list[list[float]] = []

    def state(self) -> dict[str, Any]:
        """What restore needs (a checkpoint's; at most PLOT_POINTS rows)."""
        return {
            "stride": self.stride,
            "seen": self.seen,
            "times": self.times,
            "columns": self.columns,
        }

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from ``state`` (of state())."""
        self.stride, self.seen = int(state["stride"]), int(state["seen"])
        self.times = [float(time) for time in state["times"]]
        self.columns = [[float(value) for value in kept] for kept in state["columns"]]

    def add(self, times: Any, columns: list[Any]) -> None:
        """Take the rows of a chunk (``times`` s, ``columns`` in the recorded order)."""
        first = (-self.seen) % self.stride  # the chunk's first row on the stride
        self.seen += len(times)
        if not self.columns:
            self.columns = [[] for _ in columns]
        self.times.extend(times[first :: self.stride])
        for kept, values in zip(self.columns, columns):
            kept.extend(float(value) for value in values[first :: self.stride])
        while len(self.times) > PLOT_POINTS:
            self.stride *= 2
            self.times = self.times[::2]
            self.columns = [kept[::2] for kept in self.columns]


class CountingFile(_Counted):
    """A binary sink for pyarrow's ParquetWriter that keeps the size and SHA-256 of what is
    written (ChecksumWriter's, for bytes)."""

    closed = False

    def write(self, data: bytes) -> int:
        self._take(data)
        return len(data)

    def flush(self) -> None:
        self.sink.flush()

    def tell(self) -> int:
        return self.size

    def close(self) -> None:
        self.closed = True


def require_pyarrow() -> Any:
    """pyarrow (the extra ``parquet``), or OutputError saying how to install it."""
    try:
        return importlib.import_module("pyarrow")
    except ImportError:
        raise OutputError(
            "--format parquet needs pyarrow: pip install 'mechfmu[parquet]'"
        ) from None


class StreamedResult:
    """The sink of a run that writes its rows as they come (Simulation.run(sink=...)).

    The rows go to ``<scene>.partial.csv`` (flushed after every chunk: while the run goes,
    and after a crash, the file holds every row handed over, readable as a CSV) or, with
    ``fmt = "parquet"``, to ``<scene>.partial.parquet`` (one row group per PARQUET_ROW_GROUP
    rows; readable once closed: after the run, also a failed or interrupted one). The
    size and SHA-256 of the bytes are kept as they are written (ChecksumWriter), so the
    JSON, made last, seals the pair without a second pass. ``finish``: a complete run's
    JSON is renamed into place first, then the data file to ``<scene>.csv``
    (``.parquet``); a failed one keeps the ``.partial`` name and gets ``.partial.json``.
    The PNG plots PlotSample's rows. Memory: one chunk (or row group) and the sample.

    ``resume``: the ``position()`` a checkpoint took of an earlier stream of this scene
    into ``out_dir``: its ``.partial`` file is continued (``continued`` rows are in it
    already): a CSV is checked against the size and SHA-256 it had then and cut back to
    them; a Parquet file (readable once its run closed it: stopped or failed, not killed)
    has its first rows copied into the new one.
    """

    def __init__(
        self, out_dir: Path, name: str, fmt: str = "csv", resume: dict[str, Any] | None = None
    ) -> None:
        if fmt not in FORMATS:
            raise ValueError(f"format {fmt!r}: must be one of {', '.join(FORMATS)}")
        if fmt == "parquet":
            require_pyarrow()  # missing: said before anything is written
        self.out_dir, self.name, self.format = Path(out_dir), name, fmt
        self.path = inside(self.out_dir, f"{name}.partial.{fmt}")
        self.sample = PlotSample()
        self.continued = 0  # rows of an earlier stream this one continues (resume)
        self.earlier: Any = None  # Parquet: the earlier stream's file, copied in begin
        self.last_time = math.nan  # s, of the last row written
        if resume is not None:
            self._check_resume(resume)
        for kind in RESULT_FILES:  # an older failed run's files describe another stream
            if kind != fmt:
                _unlink(inside(self.out_dir, f"{name}.partial.{kind}"))
        try:
            self.handle = open(self.path, "r+b" if resume and fmt == "csv" else "wb")
        except OSError as error:
            raise OutputError(f"cannot write {self.path}: {error_cause(error)}") from None
        self.counted: Any = (
            ChecksumWriter(self.handle) if fmt == "csv" else CountingFile(self.handle)
        )
        if resume is not None and fmt == "csv":
            self._continue_csv(resume)
        self.names: list[str] = []
        self.parquet: Any = None  # pyarrow's ParquetWriter
        self.pending: list[list[Any]] = []  # Parquet: rows waiting for their row group
        self.finished = False

    def position(self) -> dict[str, Any]:
        """Where the stream stands (every row handed over is in the file, or, Parquet,
        in its pending row group): what a checkpoint keeps to continue it (``resume``)."""
        position = {
            "format": self.format,
            "file": self.path.name,
            "rows": self.sample.seen,
            "time": self.last_time,
            "sample": self.sample.state(),
        }
        if self.format == "csv":
            position.update(self.counted.seal())
        return position

    def _refuse(self, why: str) -> Exception:
        from .checkpoint import CheckpointError  # checkpoint.py is the stream's client

        return CheckpointError(
            f"cannot continue the result file of the checkpoint's run: {self.path} {why}"
        )

    def _check_resume(self, resume: dict[str, Any]) -> None:
        """Refuse a position of another format or file; Parquet: move the earlier file
        aside (its rows are copied by begin)."""
        if resume.get("format") != self.format or resume.get("file") != self.path.name:
            raise self._refuse(
                f"is not it: the checkpoint's rows are in {resume.get('file')!r} "
                f"({resume.get('format')}); resume with --format {resume.get('format')}"
            )
        if not self.path.exists():
            complete = inside(self.out_dir, f"{self.name}.{self.format}")
            raise self._refuse(
                f"is missing: the run went on and completed ({complete} is its result)"
                if complete.exists()
                else "is missing: resume into the output folder of the run that wrote the "
                "checkpoint"
            )
        self.continued = int(resume["rows"])
        if self.format == "parquet":
            earlier = inside(self.out_dir, f"{self.name}.resumed.parquet")
            os.replace(self.path, earlier)
            try:
                self.earlier = importlib.import_module("pyarrow.parquet").ParquetFile(earlier)
                enough = self.earlier.metadata.num_rows >= self.continued
            except Exception as error:  # pyarrow's errors: ArrowInvalid, OSError, ...
                os.replace(earlier, self.path)
                raise self._refuse(
                    f"cannot be read ({error}): a run killed before it closed its Parquet "
                    "file leaves none to continue (CSV is continued after any stop)"
                ) from None
            if not enough:
                os.replace(earlier, self.path)
                raise self._refuse(f"has fewer than the checkpoint's {self.continued} rows")
            self.last_time = float(resume["time"])

    def _continue_csv(self, resume: dict[str, Any]) -> None:
        """The CSV as it was at the checkpoint (size and SHA-256 checked), cut back to it;
        the checksum and the plot's sample go on from there."""
        size = int(resume["csv_bytes"])
        digest, left = hashlib.sha256(), size
        while left > 0:
            block = self.handle.read(min(left, 1 << 20))
            if not block:
                break
            digest.update(block)
            left -= len(block)
        if left or digest.hexdigest() != resume["csv_sha256"]:
            self.handle.close()
            raise self._refuse(
                f"does not begin with the {size} bytes the checkpoint's run had written "
                "(changed, or written by another run since)"
            )
        self.handle.truncate(size)
        self.handle.seek(size)
        self.counted.digest, self.counted.size = digest, size
        self.sample.restore(resume["sample"])
        self.last_time = float(resume["time"])

    def begin(self, names: list[str]) -> None:
        """The recorded columns, in order: the CSV's header (or the Parquet schema)."""
        self.names = list(names)
        if self.format == "csv" and self.continued:
            return  # the header is in the part continued
        if self.format == "csv":
            header = io.StringIO()
            csv.writer(header, lineterminator="\n").writerow(["time", *self.names])
            self._write(header.getvalue())
        else:
            pyarrow = require_pyarrow()
            self.schema = pyarrow.schema(
                [(column, pyarrow.float64()) for column in ["time", *self.names]]
            )
            self.parquet = importlib.import_module("pyarrow.parquet").ParquetWriter(
                self.counted, self.schema
            )
            self.pending = [[] for _ in range(len(self.names) + 1)]
            if self.earlier is not None:
                self._copy_earlier()

    def _copy_earlier(self) -> None:
        """Parquet resume: the earlier file's first ``continued`` rows, row group by row
        group, into this one (their last time checked against the checkpoint's)."""
        expected, left = self.last_time, self.continued
        if self.earlier.schema_arrow.names != ["time", *self.names]:
            raise self._refuse("records other columns than this run")
        for batch in self.earlier.iter_batches(batch_size=PARQUET_ROW_GROUP):
            if left <= 0:
                break
            columns = [array("d", values.to_pylist()[:left]) for values in batch.columns]
            left -= len(columns[0])
            self.rows(columns[0], columns[1:])
        self.earlier.close()
        self.earlier = None
        _unlink(inside(self.out_dir, f"{self.name}.resumed.parquet"))
        if self.last_time != expected:
            raise self._refuse(
                f"holds a row at {self.last_time!r} s where the checkpoint's last was at "
                f"{expected!r} s"
            )

    def rows(self, times: Any, columns: list[Any]) -> None:
        """Write a chunk of rows (``times`` in s; ``columns`` in the order of begin)."""
        self.sample.add(times, columns)
        if len(times):
            self.last_time = float(times[-1])
        if self.format == "csv":
            text = io.StringIO()
            writer = csv.writer(text, lineterminator="\n")
            writer.writerows(
                zip(
                    map(repr, times),
                    *(
                        map(repr, values if values.typecode == "d" else map(float, values))
                        for values in columns
                    ),
                )
            )
            self._write(text.getvalue())
            return
        for kept, values in zip(self.pending, [times, *columns]):
            kept.extend(values)
        if len(self.pending[0]) >= PARQUET_ROW_GROUP:
            self._row_group()

    def _row_group(self) -> None:
        pyarrow = require_pyarrow()
        if self.pending and self.pending[0]:
            table = pyarrow.table(
                [pyarrow.array(values, pyarrow.float64()) for values in self.pending],
                schema=self.schema,
            )
            self._guarded(lambda: self.parquet.write_table(table))
            self.pending = [[] for _ in self.pending]

    def _write(self, text: str) -> None:
        def write() -> None:
            self.counted.write(text)
            self.handle.flush()  # a reader sees every row handed over

        self._guarded(write)

    def _guarded(self, action: Callable[[], Any]) -> None:
        try:
            action()
        except OSError as error:
            raise OutputError(f"cannot write {self.path}: {error_cause(error)}") from None

    def close(self) -> None:
        """Finish the data file (Parquet: the last row group and the footer) and close it."""
        if self.handle.closed:
            return
        try:
            if self.parquet is not None:
                self._row_group()
                self._guarded(self.parquet.close)
        finally:
            self.handle.close()
            if self.earlier is not None:  # stopped before begin copied it: put it back,
                self.earlier.close()  # the checkpoint can still continue it
                self.earlier = None
                os.replace(inside(self.out_dir, f"{self.name}.resumed.parquet"), self.path)

    def abandon(self) -> None:
        """Close the stream of a run that ended without finish (an error that is not the
        run's own: an FMU that cannot be unpacked, an output error): its rows stay readable
        in the ``.partial`` file, which is removed when it holds none."""
        if self.finished:
            return
        self.close()
        if self.sample.seen == 0 and not self.continued:
            _unlink(self.path)

    def finish(self, result: Result, meta: dict[str, Any], plot: bool = True) -> dict[str, Path]:
        """Close the stream and seal the pair (see the class); returns {kind: path}."""
        self.finished = True
        self.close()
        stem = result_stem(result)
        data = inside(self.out_dir, f"{stem}.{self.format}")
        paths = {self.format: data, "json": inside(self.out_dir, f"{stem}.json")}
        png = inside(self.out_dir, f"{stem}.png")
        sealed = sealed_meta({**meta, "format": self.format}, self.counted)
        _unlink(png)  # an older run's plot must not stand beside this run's pair
        for kind in FORMATS:  # nor an older run's data file of the other format
            if kind != self.format:
                _unlink(inside(self.out_dir, f"{stem}.{kind}"))
        atomic_write(paths["json"], json_text(sealed))  # the JSON first: see the module
        if data != self.path:
            try:
                os.replace(self.path, data)
            except OSError as error:
                raise OutputError(f"cannot write {data}: {error_cause(error)}") from None
        if plot and self.sample.times:
            paths["png"] = write_plot(
                png,
                self.sample.times,
                dict(zip(self.names, self.sample.columns)),
                result.units,
                f"{result.scene.name}" + (" (partial)" if result.partial else ""),
            )
        return paths
