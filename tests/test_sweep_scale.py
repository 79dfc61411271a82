"""Sweeps of any size (issue 33): points made in chunks, equal to the whole arrays (the grid bit
for bit numpy.linspace's; the Latin hypercube made by permutations beyond scipy's size keeps one
sample per stratum); tasks fed to the workers a few at a time, so memory does not grow with
the number of points; an absurd size refused in one line before anything runs; a sweep
written as Parquet reads back as its CSV."""

import json
import os
import signal
import subprocess
import sys
import time
import tracemalloc
from concurrent.futures import Future

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechfmu.cli import main as cli_main
from mechfmu.cosim.files import OutputError
from mechfmu.cosim.interrupt import InterruptGuard
from mechfmu.tools import sweep
from test_sweep import FMU_DIR, ROOT, metric, write_scene

finite = st.floats(-1e12, 1e12, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    ranges=st.lists(st.tuples(finite, finite, st.integers(1, 12)), min_size=1, max_size=3),
    chunk=st.integers(1, 50),
)
def test_the_grid_in_chunks_is_numpys_grid_bit_for_bit(ranges, chunk):
    varies = [sweep.Vary("c", f"p{i}", a, b, n) for i, (a, b, n) in enumerate(ranges)]
    axes = [np.linspace(a, b, n) for a, b, n in ranges]
    whole = np.stack([m.ravel() for m in np.meshgrid(*axes, indexing="ij")], axis=1)
    parts = list(sweep.grid_chunks(varies, chunk))
    assert [first for first, _ in parts] == list(range(0, len(whole), chunk))
    assert np.array_equal(np.concatenate([points for _, points in parts]), whole)


@settings(max_examples=40, deadline=None)
@given(
    samples=st.integers(1, 3000),
    dimensions=st.integers(1, 4),
    seed=st.integers(0, 2**32),
    chunk=st.integers(1, 700),
)
def test_a_latin_hypercube_made_in_chunks_has_one_sample_per_stratum(
    samples, dimensions, seed, chunk
):
    """Beyond LHS_WHOLE points (here 0) each dimension's strata are a permutation:
    every stratum [k/N, (k+1)/N) holds exactly one sample, the same points whatever the
    chunks, another seed other points; uniform sampling in chunks is one draw of them all."""
    unit = np.concatenate(
        [u for _, u in sweep._unit_chunks(samples, dimensions, seed, "lhs", chunk, 0)]
    )
    assert unit.shape == (samples, dimensions)
    assert ((unit >= 0) & (unit < 1)).all()
    for column in unit.T:
        assert np.array_equal(np.sort(np.floor(column * samples)), np.arange(samples))
    again = np.concatenate(
        [u for _, u in sweep._unit_chunks(samples, dimensions, seed, "lhs", 97, 0)]
    )
    assert np.array_equal(unit, again)
    if samples > 3:
        other = np.concatenate(
            [u for _, u in sweep._unit_chunks(samples, dimensions, seed + 1, "lhs", chunk, 0)]
        )
        assert not np.array_equal(unit, other)
    uniform = np.concatenate(
        [u for _, u in sweep._unit_chunks(samples, dimensions, seed, "random", chunk)]
    )
    assert np.array_equal(uniform, np.random.default_rng(seed).random((samples, dimensions)))


@given(n=st.integers(1, 100_000), seed=st.integers(0, 1000))
@settings(max_examples=40, deadline=None)
def test_the_permutation_is_one(n, seed):
    permutation = sweep.Permutation(n, np.random.default_rng(seed))
    assert np.array_equal(np.sort(permutation(np.arange(n))), np.arange(n))


class _Instant:
    """A runner whose points finish at once (the sweep's machinery alone)."""

    workers = 2

    def __init__(self):
        self.pending = 0
        self.most = 0

    def submit(self, index, scene, *arguments):
        future = Future()
        future.set_result((index, {"m": float(index)}, None, 0.0, "here"))
        self.pending += 1
        self.most = max(self.most, self.pending)
        return future

    def wait(self, futures, timeout):
        self.pending -= len(futures)
        return futures

    @staticmethod
    def lost(error):
        return False

    def restart(self):
        pass

    def idle(self):
        pass


def _machinery(points, runner):
    """Run ``points`` grid points through the sweep's machinery on ``runner``; (how many
    were recorded, the most tasks made and not yet recorded)."""
    counts = {"made": 0, "recorded": 0, "ahead": 0}

    def tasks():
        for first, values in sweep.grid_chunks([sweep.Vary("c", "p", 0.0, 1.0, points)]):
            for offset, value in enumerate(values):
                counts["made"] += 1
                counts["ahead"] = max(counts["ahead"], counts["made"] - counts["recorded"])
                yield sweep._Task(first + offset, [float(value[0])], None)

    def record(task, outcome):
        counts["recorded"] += 1

    with InterruptGuard() as guard:
        sweep._run_points(runner, tasks(), (), 0, guard, record, {"pool_restarts": 0, "retried": 0})
    return counts["recorded"], counts["ahead"]


def test_a_sweep_of_100000_points_holds_a_few_tasks_at_a_time():
    """The tasks come from a generator as the workers take them: at most four per worker
    are in flight or made ahead of the rows; the machinery's memory while 1e4 points pass
    is what it is for 1e3 (under 0.3 MB more: no list of points grows)."""
    runner = _Instant()
    assert _machinery(100_000, runner) == (100_000, 4 * runner.workers)
    assert runner.most <= 4 * runner.workers
    peaks = []
    for points in (1_000, 10_000):
        tracemalloc.start()
        try:
            _machinery(points, _Instant())
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
    assert peaks[1] - peaks[0] < 3e5, peaks


def test_an_absurd_sweep_is_refused_in_one_line_before_anything_runs(tmp_path, capsys):
    scene = write_scene(tmp_path)
    arguments = [
        "sweep",
        str(scene),
        "--vary",
        "suspension.spring_stiffness=8000:12000:100000",
        "--vary",
        "suspension.damping_coefficient=100:200:100000",
        "--metrics",
        "max:suspension.deflection",
        "--fmu-dir",
        str(FMU_DIR),
        "--out",
        str(tmp_path / "out"),
    ]
    started = time.perf_counter()
    assert cli_main(arguments) == 2
    error = capsys.readouterr().err
    assert error == (
        "sweep error: 10000000000 points (a grid of 100000 x 100000), more than the limit "
        "of 1000000; --max-points 10000000000 lifts it\n"
    )
    assert time.perf_counter() - started < 5
    assert not (tmp_path / "out").exists()
    with pytest.raises(sweep.SweepError, match=r"^1000000000 points \(--samples 1000000000\)"):
        sweep.run_sweep(
            scene,
            [sweep.parse_vary("suspension.spring_stiffness=8000:12000")],
            [metric("max:suspension.deflection")],
            tmp_path / "out",
            samples=10**9,
            fmu_dir=FMU_DIR,
            progress=False,
        )
    with pytest.raises(sweep.SweepError, match=r"^4 points \(a grid of 4\), .* limit of 3;"):
        sweep.run_sweep(
            scene,
            [sweep.parse_vary("suspension.spring_stiffness=8000:12000:4")],
            [metric("max:suspension.deflection")],
            tmp_path / "out",
            max_points=3,
            fmu_dir=FMU_DIR,
            progress=False,
        )


def test_parquet_without_pyarrow_is_refused_before_any_point_runs(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow raises ImportError
    out = tmp_path / "out"
    with pytest.raises(OutputError, match=r"needs pyarrow: pip install 'mechfmu\[parquet\]'"):
        sweep.run_sweep(
            write_scene(tmp_path, stop=0.2),
            [sweep.parse_vary("suspension.spring_stiffness=8000:12000:3")],
            [metric("max:suspension.deflection")],
            out,
            jobs=1,
            fmu_dir=FMU_DIR,
            progress=False,
            result_format="parquet",
        )
    assert not (out / "sweep.csv").exists()


def test_a_sweep_written_as_parquet_reads_back_as_its_csv(tmp_path):
    pytest.importorskip("pyarrow")
    out = tmp_path / "out"
    summary = sweep.run_sweep(
        write_scene(tmp_path, stop=0.2),
        [sweep.parse_vary("suspension.spring_stiffness=8000:12000:3")],
        [metric("max:suspension.deflection"), metric("first_time_above:suspension.deflection:9")],
        out,
        jobs=1,
        fmu_dir=FMU_DIR,
        progress=False,
        result_format="parquet",
    )
    assert summary["parquet"] == str(out / "sweep.parquet")
    from_csv = sweep.read_sweep_table(out / "sweep.csv")
    from_parquet = sweep.read_sweep_table(out / "sweep.parquet")
    pd.testing.assert_frame_equal(from_parquet, from_csv)
    assert from_csv["max:suspension.deflection"].notna().all()
    assert from_csv["first_time_above:suspension.deflection:9"].isna().all()  # never above


def test_sigterm_stops_a_sweep_of_a_million_points_at_once(tmp_path):
    """The grid of 1e6 points is not made up front: the first rows appear within seconds,
    SIGTERM ends the command within a point (exit 143), the JSON counts the million."""
    scene = write_scene(tmp_path, stop=0.2)
    out = tmp_path / "out"
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "mechfmu",
            "sweep",
            str(scene),
            "--vary",
            "suspension.spring_stiffness=8000:12000:1000",
            "--vary",
            "suspension.damping_coefficient=1000:2000:1000",
            "--metrics",
            "max:suspension.deflection",
            "--jobs",
            "1",
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(out),
        ],
        env=dict(os.environ, PYTHONPATH=str(ROOT / "src")),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            rows = out / "sweep.csv"
            if rows.is_file() and len(rows.read_text().splitlines()) >= 3:
                break
            time.sleep(0.05)
        else:
            pytest.fail("no rows appeared")
        sent = time.monotonic()
        process.send_signal(signal.SIGTERM)
        _, error = process.communicate(timeout=30)
        stopped = time.monotonic() - sent
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 143, error
    assert stopped < 10
    assert "/1000000 done" in error.decode()
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["points"] == 1_000_000
    assert summary["interrupted"] and summary["signal"] == "SIGTERM"
    assert 2 <= summary["done"] < 1000
