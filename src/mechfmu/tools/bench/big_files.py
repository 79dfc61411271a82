"""Benchmark: big result files and big sweeps in bounded memory (issue 33).

- ``mechfmu check`` of a pair of result CSVs of 20 MB, 200 MB and 2 GB (``--quick``: 1 and
  5 MB; Settings.big_file_sizes_mb): peak resident memory of the checking process and its
  throughput, MB of one file per CPU second (the pair is read, hashed and compared: twice
  that many bytes pass; the machine's load average beside it: a busy machine stretches CPU
  time by up to 30 %). Each
  check runs in a child process (peak_mb: VmHWM); the files are
  generated into a temporary folder (6 columns of full-precision numbers and a time column,
  the reference a hard link to the result). The issue's targets: under 500 MB resident and
  at least 100 MB/s for the 2 GB pair. At the middle size also the tube method and a
  reference whose last line is cut.
- Parquet against CSV: a result of the middle size with random values throughout (the
  checked files repeat 997 rows, which would flatter compression), written as Parquet by
  write_result; the files' sizes and read_result's CPU time for each.
- A sweep's machinery at 1e3 and 1e5 points (points made in chunks, tasks fed to a runner
  whose points finish at once, every row appended to a CSV as run_sweep appends them): peak
  resident memory of a child process. It measures what grows with the number of points,
  not the scenes (benchmark "sweep" times real ones).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np

from .report import Row, Target

BENCHMARK = "big_files"
MB = 1_000_000
FULL_SIZES_MB = (20, 200, 2000)
SWEEP_POINTS = (1_000, 100_000)
MEMORY_TARGET = Target(500.0, "<= 500 MB")  # the issue: a 2 GB pair under 500 MB resident
SPEED_TARGET = Target(100.0, ">= 100 MB/s", at_least=True)  # and at 100 MB/s or better


def write_big_result(
    path: Path, size_bytes: int, columns: int = 6, seed: int = 33, fresh: bool = False
) -> Path:
    """A result CSV of about ``size_bytes``: a strictly increasing time column and
    ``columns`` columns of full-precision numbers: 997 rows repeated (the text of a real
    result, written fast), or with ``fresh`` new random rows throughout (what compression
    meets in a real result; slower to write)."""
    rng = np.random.default_rng(seed)

    def rows() -> list[str]:
        return [
            ",".join(repr(float(x)) for x in row) for row in rng.standard_normal((997, columns))
        ]

    template = rows()
    with open(path, "w", encoding="utf-8") as handle:
        handle.write("time," + ",".join(f"part.signal_{k}" for k in range(columns)) + "\n")
        written = first = 0
        while written < size_bytes:
            chunk = [rows() if fresh else template for _ in range(50)]
            text = "".join(
                f"{j}e-3,{chunk[(j - first) // 997 % 50][j % 997]}\n"
                for j in range(first, first + 50_000)
            )
            handle.write(text)
            written += len(text)
            first += 50_000
    return path


CHECK = textwrap.dedent(
    """
    import json, sys, time
    from mechfmu.tools.bench.big_files import peak_mb
    from mechfmu.check import check_paths
    started = time.process_time()
    run = check_paths(sys.argv[1], sys.argv[2], method=sys.argv[3] or None)
    print(json.dumps({
        "exit": run.exit_code,
        "cpu_s": time.process_time() - started,
        "peak_mb": peak_mb(),
        "line": run.files[0].line()[:200],
    }))
    """
)

READ = textwrap.dedent(
    """
    import json, sys, time
    from mechfmu.tools.bench.big_files import peak_mb
    from mechfmu.io import read_result
    started = time.process_time()
    frame = read_result(sys.argv[1])
    print(json.dumps({
        "cpu_s": time.process_time() - started,
        "rows": len(frame),
        "peak_mb": peak_mb(),
    }))
    """
)

SWEEP = textwrap.dedent(
    """
    import csv, io, json, sys
    from mechfmu.tools.bench.big_files import peak_mb
    from concurrent.futures import Future
    from mechfmu.cosim.interrupt import InterruptGuard
    from mechfmu.tools import sweep

    class Instant:
        workers = 2
        def submit(self, index, scene, *arguments):
            future = Future()
            future.set_result((index, {"m": float(index)}, None, 0.0, "here"))
            return future
        def wait(self, futures, timeout):
            return futures
        lost = staticmethod(lambda error: False)
        def restart(self): pass
        def idle(self): pass

    points = int(sys.argv[1])
    varies = [sweep.Vary("c", "p", 0.0, 1.0, points // 10), sweep.Vary("c", "q", 0.0, 1.0, 10)]
    handle = open(sys.argv[2], "w", newline="")
    writer = csv.writer(handle, lineterminator="\\n")

    def tasks():
        for first, values in sweep.grid_chunks(varies):
            for offset, value in enumerate(values):
                yield sweep._Task(first + offset, [float(v) for v in value], None)

    def record(task, outcome):
        writer.writerow([task.index, *task.point, outcome[0]["m"], "", outcome[2], outcome[3]])
        handle.flush()

    with InterruptGuard() as guard:
        sweep._run_points(Instant(), tasks(), (), 0, guard, record,
                          {"pool_restarts": 0, "retried": 0})
    handle.close()
    print(json.dumps({"peak_mb": peak_mb()}))
    """
)


def peak_mb() -> float:
    """This process's peak resident memory in MB: VmHWM of /proc/self/status (reset by
    exec, unlike ru_maxrss, which a child started by fork and exec inherits from its
    parent), else ru_maxrss."""
    try:
        with open("/proc/self/status", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _child(code: str, *arguments: str) -> dict:
    import json

    out = subprocess.run(
        [sys.executable, "-c", code, *arguments],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"},
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def _check_rows(folder: Path, size_mb: int, label: str, method: str = "") -> list[Row]:
    result = folder / f"result_{size_mb}.csv"
    reference = folder / f"reference_{size_mb}.csv"
    found = _child(CHECK, str(result), str(reference), method)
    if found["exit"] != 0 and "cut" not in label:
        raise RuntimeError(f"bench check of {result}: {found['line']}")
    megabytes = result.stat().st_size / MB
    big = size_mb >= 2000
    return [
        Row(
            BENCHMARK,
            f"check {label}: peak resident",
            found["peak_mb"],
            "MB",
            1,
            target=MEMORY_TARGET if big else None,
            notes=f"{megabytes:.0f} MB per file; child process, VmHWM",
        ),
        Row(
            BENCHMARK,
            f"check {label}: throughput",
            megabytes / found["cpu_s"],
            "MB/s",
            1,
            target=SPEED_TARGET if big else None,
            notes=(
                f"one file's MB per CPU s ({found['cpu_s']:.2f} CPU s; both files read); "
                f"load {os.getloadavg()[0]:.1f} (CPU time too grows on a busy machine)"
            ),
        ),
    ]


def _parquet_rows(folder: Path, size_mb: int) -> list[Row]:
    from ...io import read_result, write_result

    csv_path = write_big_result(folder / f"fresh_{size_mb}.csv", size_mb * MB, fresh=True)
    parquet_path = write_result(read_result(csv_path), folder / f"copy_{size_mb}.parquet")
    csv_read = _child(READ, str(csv_path))
    parquet_read = _child(READ, str(parquet_path))
    note = f"{csv_read['rows']} rows x 7 columns, random values (no row repeated)"
    return [
        Row(BENCHMARK, f"{size_mb} MB result: CSV size", csv_path.stat().st_size / MB, "MB", 1),
        Row(
            BENCHMARK,
            f"{size_mb} MB result: Parquet size",
            parquet_path.stat().st_size / MB,
            "MB",
            1,
            notes="pyarrow's default codec (snappy)",
        ),
        Row(
            BENCHMARK,
            f"{size_mb} MB result: read_result CSV",
            csv_read["cpu_s"],
            "s",
            1,
            notes=note,
        ),
        Row(
            BENCHMARK,
            f"{size_mb} MB result: read_result Parquet",
            parquet_read["cpu_s"],
            "s",
            1,
            notes=f"{note}; CPU s",
        ),
    ]


def measure(
    sizes: tuple[int, ...] = FULL_SIZES_MB, sweep_points: tuple[int, ...] = SWEEP_POINTS
) -> list[Row]:
    """The rows (see the module docstring) for result files of ``sizes`` MB (the second
    also for the tube, Parquet and a cut line) and sweeps of ``sweep_points``; files in a
    temporary folder, removed after."""
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="mechfmu_bench_big_") as name:
        folder = Path(name)
        for size in sizes:
            result = write_big_result(folder / f"result_{size}.csv", size * MB)
            os.link(result, folder / f"reference_{size}.csv")
            rows += _check_rows(folder, size, f"{size} MB pair (pointwise)")
            if size == sizes[1]:
                rows += _check_rows(folder, size, f"{size} MB pair (tube)", "tube")
                rows += _parquet_rows(folder, size)
                cut = folder / f"reference_{size}.csv"
                cut.unlink()
                with open(result, "rb") as source, open(cut, "wb") as target:
                    while block := source.read(1 << 24):
                        target.write(block)
                    target.write(b"1e99,1,2\n")
                rows += _check_rows(folder, size, f"{size} MB pair, last line cut")
            for path in folder.iterdir():
                path.unlink()
        for points in sweep_points:
            found = _child(SWEEP, str(points), str(folder / "sweep.csv"))
            rows.append(
                Row(
                    BENCHMARK,
                    f"sweep of {points} points: peak resident",
                    found["peak_mb"],
                    "MB",
                    1,
                    notes="the machinery alone: points made, fed, rows appended",
                )
            )
    return rows
