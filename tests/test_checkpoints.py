"""Checkpoints of long runs: a run stopped by a signal (or at a periodic checkpoint) resumes in
a new process and ends with the result of the run that never stopped, bit for bit."""

import json
import signal

import pytest

from cli_process import run_mechfmu
from mechfmu.cosim.checkpoint import CheckpointError, Checkpoints, load
from mechfmu.cosim.master import Simulation, SimulationInterrupted
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
