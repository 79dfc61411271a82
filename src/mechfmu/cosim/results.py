"""Result files of a run: CSV, JSON metadata and a PNG plot, each written atomically."""

import csv
import io
import json
import os
import platform
import sys
import tempfile
from importlib import metadata
from pathlib import Path


def atomic_write(path, write):
    """Write ``path`` through ``write(handle)`` on a temporary file, then rename it over."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle = tempfile.NamedTemporaryFile("w", dir=path.parent, prefix=f".{path.name}.",
                                         suffix=".tmp", delete=False, newline="",
                                         encoding="utf-8")
    try:
        with handle:
            write(handle)
        os.replace(handle.name, path)
    except BaseException:
        os.unlink(handle.name)
        raise
    return path


def write_csv(path, times, columns):
    """CSV with 'time' then one column per name; floats in shortest round-trip form."""
    names = list(columns)

    def write(handle):
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["time", *names])
        for i, time in enumerate(times):
            writer.writerow([repr(float(time)), *(repr(float(columns[n][i])) for n in names)])
    return atomic_write(path, write)


def read_csv(path):
    """(times, columns) of a CSV written by write_csv (or any 'time,...' CSV)."""
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    if not rows or not rows[0] or rows[0][0] != "time":
        raise ValueError(f"{path}: first column must be 'time'")
    names = rows[0][1:]
    data = [[float(x) for x in row] for row in rows[1:] if row]
    times = [row[0] for row in data]
    columns = {name: [row[i + 1] for row in data] for i, name in enumerate(names)}
    return times, columns


def versions():
    """Versions of the packages a result depends on."""
    found = {"python": platform.python_version()}
    for package in ("mechfmu", "fmpy", "pythonfmu", "numpy", "matplotlib"):
        try:
            found[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            found[package] = None
    return found


def write_json(path, data):
    return atomic_write(path, lambda handle: json.dump(data, handle, indent=2, default=str))


def write_plot(path, times, columns, units, title):
    """One panel per signal against time, y axes labelled with their units."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot

    names = list(columns)
    figure, axes = pyplot.subplots(len(names), 1, sharex=True, squeeze=False,
                                   figsize=(8, 1.1 + 1.7 * len(names)))
    for axis, name in zip(axes[:, 0], names):
        axis.plot(times, columns[name], linewidth=1.2)
        unit = units.get(name)
        axis.set_ylabel(f"{name.split('.', 1)[1]}\n[{unit}]" if unit else name.split(".", 1)[1],
                        fontsize=8)
        axis.set_title(name, fontsize=8, loc="left")
        axis.grid(True, linewidth=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    figure.suptitle(title)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    pyplot.close(figure)
    path = Path(path)
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_bytes(buffer.getvalue())
    os.replace(temporary, path)
    return path


def write_result(result, out_dir, plot=True):
    """Write <scene>.csv, .json and .png (``.partial`` in the names for a failed run)."""
    out_dir = Path(out_dir)
    stem = result.scene.name + (".partial" if result.partial else "")
    paths = {"csv": write_csv(out_dir / f"{stem}.csv", result.times, result.columns)}
    meta = dict(result.meta)
    meta.update({"scene": result.scene.name, "scene_file": str(result.scene.path),
                 "description": result.scene.description, "partial": result.partial,
                 "start_time": result.scene.start_time, "stop_time": result.scene.stop_time,
                 "step": result.scene.step, "recorded": list(result.columns),
                 "units": result.units, "versions": versions(), "command": sys.argv,
                 "log": [entry for entry in result.log if entry["status"] != "ok"]})
    paths["json"] = write_json(out_dir / f"{stem}.json", meta)
    if plot and result.times:
        paths["png"] = write_plot(out_dir / f"{stem}.png", result.times, result.columns,
                                  result.units, f"{result.scene.name}"
                                  + (" (partial)" if result.partial else ""))
    return paths
