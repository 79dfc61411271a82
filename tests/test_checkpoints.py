"""Checkpoints of long runs: a run stopped by a signal (or at a periodic checkpoint) resumes in
a new process and ends with the result of the run that never stopped, bit for bit."""

import json
import signal

import numpy as np
import pandas as pd
import pytest

from cli_process import run_mechfmu
from mechfmu.cosim import master
from mechfmu.cosim.checkpoint import CheckpointError, Checkpoints, load
from mechfmu.cosim.master import Simulation, SimulationInterrupted
from mechfmu.cosim.results import _file_digest
from mechfmu.cosim.run import run_scene
from mechfmu.cosim.scene import SCENE_DIR, load_scene


class StopAfter:
    """An InterruptGuard stand-in: a SIGTERM 'arrives' before step ``steps + 1``."""

    def __init__(self, steps):
        self.asked, self.steps = 0, steps

    @property
    def requested(self):
        self.asked += 1
        return self.asked > self.steps

    def take(self):
        return signal.SIGTERM


def _uninterrupted(scene, fmu_dir, out):
    done = run_mechfmu("run", scene, "--out", out, "--fmu-dir", fmu_dir, "--no-plot")
    assert done.returncode == 0, done.stderr
    return (out / f"{load_scene(scene).name}.csv").read_text()


def _resumed(scene, fmu_dir, out, checkpoint):
    done = run_mechfmu(
        "run", scene, "--resume", checkpoint, "--out", out, "--fmu-dir", fmu_dir, "--no-plot"
    )
    assert done.returncode == 0, done.stderr
    return (out / f"{load_scene(scene).name}.csv").read_text()


@pytest.mark.parametrize("scene_name", ["suspension_road_bump", "four_bar_solver_crossed"])
def test_a_run_stopped_by_a_signal_resumes_in_a_new_process_bit_for_bit(
    fmu_dir, tmp_path, scene_name
):
    scene = SCENE_DIR / f"{scene_name}.toml"
    checkpoint = tmp_path / "run.checkpoint"
    simulation = Simulation(load_scene(scene), fmu_dir)
    with pytest.raises(SimulationInterrupted):
        # +1: the guard is also asked before each component is instantiated
        simulation.run(
            stop=StopAfter(150 + len(simulation.order) + 1), checkpoints=Checkpoints(checkpoint)
        )
    saved = load(checkpoint)
    assert saved.index == 150 and len(saved.times) == 151
    expected = _uninterrupted(scene, fmu_dir, tmp_path / "whole")
    assert _resumed(scene, fmu_dir, tmp_path / "resumed", checkpoint) == expected
    meta = json.loads((tmp_path / "resumed" / f"{scene_name}.json").read_text())
    assert meta["resumed_from"]["index"] == 150


def test_periodic_checkpoints_resume_from_the_last(fmu_dir, tmp_path):
    scene = SCENE_DIR / "gear_retraction_loads.toml"  # the forces effect on: its loads resume too
    checkpoint = tmp_path / "gear.checkpoint"
    result = Simulation(load_scene(scene), fmu_dir).run(checkpoints=Checkpoints(checkpoint, 120))
    assert load(checkpoint).index == 240 and result.meta["checkpoint"]["index"] == 240
    expected = _uninterrupted(scene, fmu_dir, tmp_path / "whole")
    assert _resumed(scene, fmu_dir, tmp_path / "resumed", checkpoint) == expected


def test_a_checkpoint_of_other_settings_or_damaged_is_refused(fmu_dir, tmp_path):
    scene = SCENE_DIR / "gear_retraction.toml"
    checkpoint = tmp_path / "gear.checkpoint"
    Simulation(load_scene(scene), fmu_dir).run(checkpoints=Checkpoints(checkpoint, 100))
    other = tmp_path / "gear_longer.toml"
    other.write_text(scene.read_text().replace("stop_time = 3.0", "stop_time = 3.5"))
    done = run_mechfmu(
        "run", other, "--resume", checkpoint, "--out", tmp_path, "--fmu-dir", fmu_dir
    )
    assert done.returncode == 2 and "with other settings" in done.stderr, done.stderr
    checkpoint.write_text(checkpoint.read_text()[:-50])
    with pytest.raises(CheckpointError, match="cannot be read"):
        load(checkpoint)
    done = run_mechfmu(
        "run", scene, "--resume", checkpoint, "--out", tmp_path, "--fmu-dir", fmu_dir
    )
    assert done.returncode == 2 and "cannot be read" in done.stderr, done.stderr


# --- checkpoints of runs that stream their rows and keep none (long runs) -------------------


def _stopped_streaming_run(scene, fmu_dir, out, checkpoint, steps, fmt="csv"):
    """run_scene keeping no rows (chunks of 7), a checkpoint every 40 points and a SIGTERM
    before step ``steps + 1``; the checkpoint it left."""
    order = len(Simulation(load_scene(scene), fmu_dir).order)
    with pytest.raises(SimulationInterrupted):
        run_scene(
            scene,
            out,
            fmu_dir,
            plot=False,
            guard=StopAfter(steps + order + 1),
            fmt=fmt,
            keep=False,
            checkpoints=Checkpoints(checkpoint, 40),
        )
    return load(checkpoint)


def test_a_streamed_run_resumes_into_its_partial_file_bit_for_bit(fmu_dir, tmp_path, monkeypatch):
    """suspension_road_bump (1500 steps) streamed in chunks of 7 rows, keeping none, stopped
    after 150: the checkpoint holds no rows, only the CSV's size and SHA-256 at row 150;
    resumed in a new process into the same folder, the run ends with the bytes of a run
    that never stopped; into another folder, or after the file changed, it is refused."""
    monkeypatch.setattr(master, "CHUNK_ROWS", 7)
    scene, out = SCENE_DIR / "suspension_road_bump.toml", tmp_path / "out"
    checkpoint = tmp_path / "run.checkpoint"
    saved = _stopped_streaming_run(scene, fmu_dir, out, checkpoint, 150)
    partial = out / "suspension_road_bump.partial.csv"
    assert saved.index == 150 and saved.streamed == 151 and saved.times == []
    assert all(data == b"" for _, data in saved.rows.values())
    assert saved.stream["csv_bytes"] == partial.stat().st_size
    assert saved.stream["csv_sha256"] == _file_digest(partial)
    assert len(partial.read_text().splitlines()) == 152  # the header and rows 0..150
    expected = _uninterrupted(scene, fmu_dir, tmp_path / "whole")
    elsewhere = run_mechfmu(
        "run", scene, "--resume", checkpoint, "--out", tmp_path / "other", "--fmu-dir", fmu_dir
    )
    assert elsewhere.returncode == 2 and "is missing" in elsewhere.stderr, elsewhere.stderr
    assert _resumed(scene, fmu_dir, out, checkpoint) == expected
    assert not partial.exists()
    meta = json.loads((out / "suspension_road_bump.json").read_text())
    assert meta["resumed_from"] == {"index": 150, "time": saved.time} and meta["steps"] == 1500
    # the same checkpoint cannot continue a file that no longer holds its rows
    (out / "suspension_road_bump.csv").rename(partial)
    partial.write_bytes(b"time" + partial.read_bytes()[4:].replace(b"0", b"1", 1))
    changed = run_mechfmu("run", scene, "--resume", checkpoint, "--out", out, "--fmu-dir", fmu_dir)
    assert changed.returncode == 2 and "does not begin with" in changed.stderr, changed.stderr


def test_a_killed_streamed_run_resumes_from_its_last_periodic_checkpoint(
    fmu_dir, tmp_path, monkeypatch
):
    """A run killed after its checkpoint leaves a partial CSV with rows past it (every
    chunk is flushed): the resumed run cuts the file back to the checkpoint's row and
    writes on, ending with the bytes of the run that never stopped."""
    monkeypatch.setattr(master, "CHUNK_ROWS", 7)
    scene, out = SCENE_DIR / "gear_retraction_loads.toml", tmp_path / "out"
    checkpoint = tmp_path / "gear.checkpoint"
    result, paths = run_scene(
        scene, out, fmu_dir, plot=False, keep=False, checkpoints=Checkpoints(checkpoint, 120)
    )
    saved = load(checkpoint)
    assert saved.index == 240 and saved.streamed == 241 and result.rows == 301
    # what SIGKILL after the checkpoint leaves: the partial file with every row written
    partial = paths["csv"].rename(out / "gear_retraction_loads.partial.csv")
    assert len(partial.read_text().splitlines()) == 302 > saved.stream["rows"] + 1
    paths["json"].unlink()
    expected = _uninterrupted(scene, fmu_dir, tmp_path / "whole")
    assert _resumed(scene, fmu_dir, out, checkpoint) == expected


def test_a_streamed_parquet_run_resumes_with_the_same_values(fmu_dir, tmp_path, monkeypatch):
    """--format parquet: the stopped run's closed .partial.parquet gives the resumed run its
    first rows; the result holds the uninterrupted run's columns and values exactly. A
    resume asking for CSV is refused (the rows are in Parquet)."""
    monkeypatch.setattr(master, "CHUNK_ROWS", 7)
    scene, out = SCENE_DIR / "suspension_road_bump.toml", tmp_path / "out"
    checkpoint = tmp_path / "run.checkpoint"
    saved = _stopped_streaming_run(scene, fmu_dir, out, checkpoint, 150, "parquet")
    assert saved.streamed == 151 and saved.stream["format"] == "parquet"
    with pytest.raises(CheckpointError, match="--format parquet"):
        run_scene(scene, out, fmu_dir, plot=False, resume=checkpoint)
    resumed, paths = run_scene(
        scene, out, fmu_dir, plot=False, fmt="parquet", keep=False, resume=checkpoint
    )
    whole, whole_paths = run_scene(scene, tmp_path / "whole", fmu_dir, plot=False, fmt="parquet")
    assert resumed.rows == whole.rows == 1501 and not resumed.kept
    frame, expected = pd.read_parquet(paths["parquet"]), pd.read_parquet(whole_paths["parquet"])
    assert list(frame.columns) == list(expected.columns)
    assert all(np.array_equal(frame[c].to_numpy(), expected[c].to_numpy()) for c in frame)
    assert not (out / "suspension_road_bump.resumed.parquet").exists()
