"""``mechfmu baseline update``: new, changed (by how much), unchanged, kept and removed
baselines; copies byte for byte; a malformed result writes nothing."""

import shutil

import pytest
from conftest import REFERENCES

from mechfmu.cli import main as cli
from mechfmu.io import read_result, write_result


def update(capsys, *arguments):
    code = cli(["baseline", "update", *map(str, arguments)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.fixture
def results(tmp_path):
    folder = tmp_path / "results"
    (folder / "valve").mkdir(parents=True)
    for scene in ("gear_retraction", "suspension_load_ramp"):
        write_result(read_result(REFERENCES / f"{scene}.csv"), folder / f"{scene}.csv")
    shutil.copy(REFERENCES / "valve_train.csv", folder / "valve" / "valve_train.csv")
    return folder


def test_first_update_copies_every_result_as_new(results, tmp_path, capsys):
    baselines = tmp_path / "baselines"
    code, out, _ = update(capsys, results, baselines)
    assert code == 0
    assert "gear_retraction.csv: new: 6 column(s), 301 sample(s)" in out.splitlines()
    assert "valve/valve_train.csv: new: 16 column(s), 401 sample(s)" in out.splitlines()
    assert out.splitlines()[-1] == f"updated {baselines}: 3 new"
    for name in ("gear_retraction.csv", "gear_retraction.json", "valve/valve_train.csv"):
        assert (baselines / name).read_bytes() == (results / name).read_bytes()
    # and then mechfmu check accepts the results against them
    assert cli(["check", str(results), str(baselines)]) == 0


def test_changes_are_reported_per_column_with_size_and_time(results, tmp_path, capsys):
    baselines = tmp_path / "baselines"
    update(capsys, results, baselines)
    before = (baselines / "suspension_load_ramp.csv").stat().st_mtime_ns
    gear = read_result(results / "gear_retraction.csv")
    gear.iloc[120, gear.columns.get_loc("gear.gear_angle")] += 2e-3
    write_result(gear.drop(columns=["actuator.piston_speed"]), results / "gear_retraction.csv")
    (results / "valve" / "valve_train.csv").unlink()
    code, out, _ = update(capsys, results, baselines, "--dry-run")
    assert (
        code == 0
        and out.splitlines()[-1] == f"would update {baselines}: 1 changed, 1 unchanged, 1 kept"
    )
    assert read_result(baselines / "gear_retraction.csv").shape == (301, 6)  # untouched
    code, out, _ = update(capsys, results, baselines)
    lines = out.splitlines()
    changed = next(line for line in lines if line.startswith("gear_retraction.csv: changed: "))
    assert "column actuator.piston_speed removed" in changed
    peak = read_result(REFERENCES / "gear_retraction.csv")["gear.gear_angle"].abs().max()
    assert (
        f"gear.gear_angle max |difference| 0.002 ({2e-3 / peak:.3g} of peak) at t = 1.2 s"
        in changed
    )
    assert "suspension_load_ramp.csv: unchanged" in lines
    assert "valve/valve_train.csv: kept: no result (--prune removes it)" in lines
    assert (baselines / "suspension_load_ramp.csv").stat().st_mtime_ns == before
    assert read_result(baselines / "gear_retraction.csv").shape == (301, 5)
    code, out, _ = update(capsys, results, baselines, "--prune")
    assert "valve/valve_train.csv: removed" in out.splitlines()
    assert not (baselines / "valve" / "valve_train.csv").exists()
    assert out.splitlines()[-1] == f"updated {baselines}: 2 unchanged, 1 removed"


def test_a_malformed_result_is_not_accepted_and_nothing_is_written(results, tmp_path, capsys):
    baselines = tmp_path / "baselines"
    update(capsys, results, baselines)
    gear = read_result(results / "gear_retraction.csv")
    write_result(gear * 2.0, results / "gear_retraction.csv")
    path = results / "suspension_load_ramp.csv"
    path.write_text(path.read_text()[:-15])  # the last line cut
    saved = (baselines / "gear_retraction.csv").read_bytes()
    code, out, err = update(capsys, results, baselines)
    assert code == 2 and out == ""
    assert err.startswith(f"baseline error: not accepted: {path}: line 402")
    assert (baselines / "gear_retraction.csv").read_bytes() == saved
    code, _, err = update(capsys, tmp_path / "nothing", baselines)
    assert code == 2 and f"results {tmp_path / 'nothing'} do not exist" in err
