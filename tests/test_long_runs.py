"""Long runs (issue 33): the master computes its time points as it goes and streams the rows
to the result file as they come (memory flat in the run's length, the file readable while
it grows), the output's size is estimated and refused over a limit before the first step,
a signal acts within a step, and ``--format parquet`` writes the same columns."""

import json
import os
import signal
import subprocess
import sys
import time
from array import array
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechfmu.check import run_report
from mechfmu.cli import main as cli
from mechfmu.cosim import master, results
from mechfmu.cosim.run import check_output_size, output_estimate, run_scene
from mechfmu.cosim.scene import SCENE_DIR, SceneError, load_scene
from mechfmu.cosim.results import _file_digest
from mechfmu.io import read_result
from mechfmu.tools.bench.long_runs import peak_rss_of_run, scene_file_with_steps

ROOT = Path(__file__).resolve().parents[1]


def test_memory_stays_flat_when_the_run_grows_tenfold(fmu_dir, tmp_path):
    """gear_retraction (two FMUs, 7 columns) through run_scene in a fresh process at 20 000
    and 200 000 steps: the longer run streams its 15 MB CSV and keeps no rows, its peak
    resident memory within 8 MiB of the shorter's (the rows kept as before would add
    200 000 x 7 x 40 bytes = 53 MiB, the whole time grid and the CSV text in memory more)."""
    peaks = {}
    for steps in (20_000, 200_000):
        scene = scene_file_with_steps(str(SCENE_DIR), "gear_retraction", steps, tmp_path)
        peaks[steps] = peak_rss_of_run(scene, tmp_path / f"out{steps}", str(fmu_dir))
        assert peaks[steps]["rows"] == steps + 1
    assert peaks[20_000]["kept"] and not peaks[200_000]["kept"]
    assert peaks[200_000]["bytes"] > 9 * peaks[20_000]["bytes"]
    grown = (peaks[200_000]["peak_kib"] - peaks[20_000]["peak_kib"]) / 1024.0
    assert grown < 8.0, peaks


def _short_chunks(monkeypatch, rows):
    monkeypatch.setattr(master, "CHUNK_ROWS", rows)


@pytest.mark.parametrize("chunk", [1, 5, 4096])
@pytest.mark.parametrize("keep", [True, False])
def test_the_streamed_csv_is_the_csv_of_the_rows_in_memory(
    fmu_dir, tmp_path, monkeypatch, chunk, keep
):
    """valve_float_dynamic (Real and Boolean columns) streamed in chunks of 1, 5 and 4096
    rows: the CSV has the same bytes as write_result's from a run that keeps its rows,
    its JSON seals it (size and SHA-256), and a run that keeps nothing holds no rows."""
    _short_chunks(monkeypatch, chunk)
    scene = load_scene(SCENE_DIR / "valve_float_dynamic.toml")
    result, paths = run_scene(scene, tmp_path / "streamed", fmu_dir, plot=False, keep=keep)
    assert result.kept is keep and result.rows == 13 and result.meta["steps"] == 12
    in_memory, _ = run_scene(scene, tmp_path / "kept", fmu_dir, plot=False, keep=True)
    written = results.write_result(in_memory, tmp_path / "written", plot=False)
    assert paths["csv"].read_bytes() == written["csv"].read_bytes()
    meta = json.loads(paths["json"].read_text())
    assert meta["csv_bytes"] == paths["csv"].stat().st_size
    assert meta["csv_sha256"] == _file_digest(paths["csv"])
    assert (
        meta["format"] == "csv"
        and not (tmp_path / "streamed" / "valve_float_dynamic.partial.csv").exists()
    )
    if not keep:
        assert result.times == [] and all(values == [] for values in result.columns.values())
    frame = read_result(paths["csv"])
    assert len(frame) == 13 and frame["valve.float_events"].iloc[-1] == 3.0


def test_a_streamed_runs_check_reports_the_kept_runs_worst_deviations(fmu_dir, tmp_path):
    """run --check of a run that kept no rows takes each column's worst deviation from the
    comparison (the file read once): the same lines as a run that kept them (gear_retraction)."""
    scene = load_scene(SCENE_DIR / "gear_retraction.toml")
    reports = {}
    for keep in (True, False):
        result, paths = run_scene(scene, tmp_path / str(keep), fmu_dir, plot=False, keep=keep)
        lines, comparison = run_report(result, paths, scene.reference)
        assert comparison is not None and comparison.ok
        reports[keep] = [line for line in lines if line.startswith("    ")]
        assert len(reports[keep]) == len(comparison.summary) > 0  # a line per column compared
    assert reports[False] == reports[True]


def test_parquet_holds_the_same_columns_and_values(fmu_dir, tmp_path):
    """--format parquet: <scene>.parquet with the CSV's columns and the very same floats,
    the JSON beside it sealing its bytes; an older CSV of the scene is removed (it would
    not match the JSON)."""
    out = tmp_path / "out"
    assert cli(["run", "valve_train_dynamic", "--out", str(out), "--no-plot"]) == 0
    csv_frame = pd.read_csv(out / "valve_train_dynamic.csv")
    code = cli(
        ["run", "valve_train_dynamic", "--out", str(out), "--no-plot", "--format", "parquet"]
    )
    assert code == 0
    path = out / "valve_train_dynamic.parquet"
    frame = pd.read_parquet(path)
    assert list(frame.columns) == list(csv_frame.columns)
    assert frame.to_numpy().tobytes() == csv_frame.to_numpy().tobytes()
    meta = json.loads((out / "valve_train_dynamic.json").read_text())
    assert meta["format"] == "parquet" and meta["csv_sha256"] == _file_digest(path)
    assert meta["csv_bytes"] == path.stat().st_size
    assert not (out / "valve_train_dynamic.csv").exists()


def test_an_oversized_run_is_refused_in_one_line_before_it_starts(tmp_path, capsys):
    """A run estimated over the output limit: exit 2, one line naming the steps, the size
    and --max-output, nothing written; --max-output lifts the limit, and a small limit
    refuses a small run."""
    scene = load_scene(SCENE_DIR / "gear_retraction.toml")
    scene.stop_time, scene.path = 1e6, tmp_path / "long.toml"  # 1e8 steps of 0.01 s
    rows, size = output_estimate(scene, 6)
    assert rows == 10**8 + 1 and size == rows * 7 * results.CSV_VALUE_BYTES
    with pytest.raises(SceneError) as refused:
        check_output_size(scene, 6)
    message = str(refused.value)
    assert "\n" not in message
    assert "100000000 steps" in message and "17.5 GB of CSV" in message
    assert "--max-output 19.3GB" in message and "2.15 GB" in message
    check_output_size(scene, 6, max_output=20 * 10**9)  # lifted: no error
    short = tmp_path / "short.toml"
    short.write_text(
        (SCENE_DIR / "gear_retraction.toml")
        .read_text()
        .replace('reference = "reference/', f'reference = "{(SCENE_DIR / "reference").as_posix()}/')
    )
    out = tmp_path / "out"
    assert cli(["run", str(short), "--out", str(out), "--max-output", "1k"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "300 steps" in lines[0] and "--max-output" in lines[0], lines
    assert not out.exists() or list(out.iterdir()) == []
    with pytest.raises(SystemExit):
        cli(["run", str(short), "--max-output", "lots"])
    assert "'lots' is not a size in bytes" in capsys.readouterr().err


def test_the_csv_is_readable_while_the_run_goes_and_a_signal_stops_it_at_once(fmu_dir, tmp_path):
    """A run of 1e7 steps (100 000 s of gear_retraction, its CSV estimated at 1.75 GB): the
    partial CSV grows and reads as a CSV during the run (every row complete); SIGTERM stops
    it within a second (no grid to build first), exit 143, the rows so far sealed by
    <scene>.partial.json."""
    scene = scene_file_with_steps(str(SCENE_DIR), "gear_retraction", 10**7, tmp_path)
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "mechfmu", "run", str(scene), "--out", str(out), "--no-plot"],
        env=dict(os.environ, PYTHONPATH=str(ROOT / "src"), MECHFMU_FMU_DIR=str(fmu_dir)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    partial = out / "gear_retraction.partial.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and (
        not partial.exists() or partial.stat().st_size < 300_000
    ):
        time.sleep(0.05)
    growing = pd.read_csv(partial)
    assert len(growing) > 3000 and growing.notna().all().all()
    assert growing["time"].iloc[-1] == pytest.approx(0.01 * (len(growing) - 1), rel=1e-12)
    sent = time.monotonic()
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert time.monotonic() - sent < 5.0
    assert process.returncode == 143, stderr
    meta = json.loads((out / "gear_retraction.partial.json").read_text())
    assert meta["interrupted"] is True and meta["signal"] == "SIGTERM"
    frame = read_result(partial)  # the pair checks out
    assert len(frame) == meta["steps"] + 1 >= len(growing)


@settings(max_examples=60, deadline=None)
@given(
    chunks=st.lists(st.integers(0, 60), min_size=1, max_size=12),
    points=st.integers(2, 17),
)
def test_the_plot_sample_is_every_kth_row_and_bounded(chunks, points):
    """PlotSample over chunks of any sizes: every k-th row of the whole run (k a power of
    two), never more than PLOT_POINTS rows, and as many as fit (more than half of them
    once the run is longer)."""
    original = results.PLOT_POINTS
    results.PLOT_POINTS = points
    try:
        sample, start = results.PlotSample(), 0
        for size in chunks:
            times = array("d", range(start, start + size))
            sample.add(times, [array("d", [2.0 * t for t in times]), array("i", range(size))])
            start += size
        k = sample.stride
        assert sample.times == [float(t) for t in range(0, start, k)]
        assert sample.columns[0] == [2.0 * t for t in sample.times] if start else True
        assert len(sample.times) <= points
        if start > points:
            assert len(sample.times) > points // 2
    finally:
        results.PLOT_POINTS = original


def test_the_log_keeps_its_problems_and_counts_what_it_drops(monkeypatch):
    """Past MAX_LOG_MESSAGES the log book keeps errors only and counts the others."""
    monkeypatch.setattr(master, "MAX_LOG_MESSAGES", 3)
    book = master.LogBook()
    for i in range(5):
        book.record(b"a", 1, b"warning", f"w{i}".encode())
    book.record(b"a", 3, b"error", b"broken")
    assert [m["message"] for m in book.messages] == ["w0", "w1", "w2", "broken"]
    assert book.dropped == 2 and book.last_problem("a") == "broken"
