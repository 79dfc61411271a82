"""Our master as an importer of FMUs that are not ours, FMI 2.0 and 3.0.

The FMUs are the suite's own small C FMUs (tests/foreign_fmus/, built here with the system C
compiler): every variable type of each version, declared types with units, enumerations,
strings, a DefaultExperiment, and one FMU that asks to end the simulation. Each run is
compared with fmpy's simulate_fmu on the same FMU, start values and output grid.
"""

import json
import math

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from cli_process import run_mechfmu
from foreign_fmus import build_foreign_fmus
from mechfmu.cosim import master
from mechfmu.cosim.master import Simulation
from mechfmu.cosim.run import run_scene
from mechfmu.cosim.scene import SceneError, parse_scene


@pytest.fixture(scope="module")
def foreign(tmp_path_factory):
    return build_foreign_fmus(tmp_path_factory.mktemp("foreign"))


def _scene(tmp_path, name, components, **times):
    data = {"name": name, "components": components, **times}
    return parse_scene(data, tmp_path / f"{name}.toml")


PARAMETERS = {"gain": 3.0, "offset": 2, "enabled": True, "label": "L", "mode": "Fast"}
INPUTS = {"u": 0.25, "k": 4, "b": True, "s": "hello", "e": "Slow"}
FMI3_INPUTS = {**INPUTS, "u32": 0.5, "byte_in": 250}
# The same settings as fmpy start values (enumerations by their value).
START_VALUES = {**PARAMETERS, "mode": 3, **INPUTS, "e": 2}


@pytest.mark.parametrize("version", [2, 3])
def test_the_foreign_fmus_are_valid(foreign, version):
    for model in ("TestSignals", "TestStair"):
        assert validate_fmu(str(foreign[version, model])) == []


@pytest.mark.parametrize("version", [2, 3])
def test_every_type_gives_fmpys_numbers_and_declared_units(foreign, tmp_path, version):
    fmu = foreign[version, "TestSignals"]
    extra = {"u32": 0.5, "byte_in": 250} if version == 3 else {}
    scene = _scene(
        tmp_path,
        f"signals{version}",
        {
            "sig": {
                "fmu": str(fmu),
                "parameters": PARAMETERS,
                "inputs": {**INPUTS, **extra},
            }
        },
    )
    simulation = Simulation(scene)
    # no times in the scene: the FMU's DefaultExperiment (0 to 2 s by 0.1 s)
    assert (simulation.scene.start_time, simulation.scene.stop_time) == (0.0, 2.0)
    assert simulation.scene.step == 0.1
    result = simulation.run()
    expected = simulate_fmu(str(fmu), start_values={**START_VALUES, **extra}, output_interval=0.1)
    assert result.times == list(expected["time"])
    for column, values in result.columns.items():
        name = column.split(".", 1)[1]
        assert np.array_equal(np.array(values), expected[name].astype(float)), name
    # y = gain u + x, x the integral of u, n = k + offset + steps, the enumeration's value
    assert result.columns["sig.y"][-1] == 3.0 * 0.25 + result.columns["sig.x"][-1]
    assert result.columns["sig.x"][-1] == pytest.approx(0.5, abs=1e-15)
    assert result.columns["sig.n"][-1] == 4 + 2 + 20 and result.columns["sig.mode_out"][0] == 2
    assert result.units["sig.y"] == "m" and result.units["sig.x"] == "m.s"
    if version == 3:
        assert result.columns["sig.y32"][0] == 1.0 and result.columns["sig.w"][0] == 251
    assert "sig.s_out" not in result.columns  # a String output is not a number: not recorded


@pytest.mark.parametrize("version", [2, 3])
def test_an_fmu_that_asks_to_end_ends_the_run_cleanly(foreign, tmp_path, version):
    fmu = foreign[version, "TestStair"]
    scene_file = tmp_path / "stair.toml"
    scene_file.write_text(f'[components.stair]\nfmu = "{fmu}"\n')
    out = run_mechfmu("run", str(scene_file), "--out", str(tmp_path / "out"), "--no-plot")
    assert out.returncode == 0, out.stdout + out.stderr
    # FMI 2.0: fmi2Discard with fmi2Terminated at t = 0.75 s, inside the step from 0.7 s;
    # FMI 3.0: terminateSimulation with the step that reaches it (to 0.8 s)
    end = 0.75 if version == 2 else 0.8
    assert f"asked to end the simulation at t = {end!r} s" in out.stdout
    expected = simulate_fmu(str(fmu), output_interval=0.1)
    rows = (tmp_path / "out" / "stair.csv").read_text().splitlines()
    assert len(rows) - 1 == len(expected) == 9
    assert [float(row.split(",")[0]) for row in rows[1:]] == list(expected["time"])
    assert [float(row.split(",")[1]) for row in rows[1:]] == list(expected["counter"])
    meta = json.loads((tmp_path / "out" / "stair.json").read_text())
    assert meta["ended_by"]["component"] == "stair" and meta["ended_by"]["time"] == end
    assert meta["partial"] is False


@pytest.mark.parametrize("version", [2, 3])
def test_the_row_at_the_end_an_fmu_asked_for_reaches_the_streamed_file(
    foreign, tmp_path, monkeypatch, version
):
    """A run that keeps no rows and hands them over two at a time: the row at the time the
    FMU ended the run (0.75 s, FMI 2.0; 0.8 s, FMI 3.0) is the streamed CSV's last."""
    monkeypatch.setattr(master, "CHUNK_ROWS", 2)
    scene_file = tmp_path / "stair.toml"
    scene_file.write_text(f'[components.stair]\nfmu = "{foreign[version, "TestStair"]}"\n')
    result, paths = run_scene(scene_file, tmp_path / "out", plot=False, keep=False)
    end = 0.75 if version == 2 else 0.8
    rows = paths["csv"].read_text().splitlines()
    assert not result.kept and result.rows == len(rows) - 1 == 9
    assert float(rows[-1].split(",")[0]) == end and result.meta["ended_by"]["time"] == end
    assert json.loads(paths["json"].read_text())["partial"] is False


def test_fmus_of_both_versions_connect_in_one_scene(foreign, tmp_path):
    scene = _scene(
        tmp_path,
        "mixed",
        {
            "first": {"fmu": str(foreign[3, "TestSignals"]), "inputs": FMI3_INPUTS},
            "second": {"fmu": str(foreign[2, "TestSignals"]), "inputs": {"b": False, "e": 1}},
        },
        connections=[
            "first.y -> second.u",
            "first.n -> second.k",
            "first.s_out -> second.s",
        ],
        record=["first.y", "second.y", "second.n"],
        stop_time=1.0,
        step=0.1,
    )
    simulation = Simulation(scene)
    assert simulation.order == ["first", "second"]
    result = simulation.run()
    first, second = result.columns["first.y"], result.columns["second.y"]
    # second.u follows first.y (Gauss-Seidel: the value at the end of the same step)
    x = 0.0
    for index in range(1, len(result.times)):
        x += first[index] * 0.1
        assert second[index] == pytest.approx(2.0 * first[index] + x, rel=1e-14)
    n_first = [4 + 3 + i for i in range(len(result.times))]  # k + offset + steps
    assert result.columns["second.n"] == [n + 3 + i for i, n in enumerate(n_first)]


def test_enumerations_take_an_item_by_name_or_value_and_refuse_others(foreign, tmp_path):
    fmu = str(foreign[2, "TestSignals"])
    for value in ("Medium", 7, 2.0):
        scene = _scene(tmp_path, "enum", {"sig": {"fmu": fmu, "inputs": {"e": value}}})
        with pytest.raises(SceneError, match=r"sig\.e is Enumeration") as caught:
            Simulation(scene)
        assert "Off = 1, Slow = 2, Fast = 3" in str(caught.value)


def test_default_experiments_fill_only_the_times_a_scene_leaves_out(foreign, fmu_dir, tmp_path):
    agree = _scene(
        tmp_path,
        "agree",
        {
            "a": {"fmu": str(foreign[2, "TestStair"])},
            "b": {"fmu": str(foreign[3, "TestSignals"]), "inputs": FMI3_INPUTS},
        },
        record=["a.counter", "b.y"],
    )
    assert math.isnan(agree.stop_time) and agree.missing_times == (
        "start_time",
        "stop_time",
        "step",
    )
    assert Simulation(agree).scene.stop_time == 2.0  # both say 0 to 2 s by 0.1 s
    own = _scene(tmp_path, "own", {"a": {"fmu": str(foreign[2, "TestStair"])}}, stop_time=0.5)
    assert (Simulation(own).scene.stop_time, Simulation(own).scene.step) == (0.5, 0.1)
    # LandingGear's DefaultExperiment (its reference scene, 0 to 3 s by 0.01 s) disagrees
    disagree = _scene(
        tmp_path,
        "disagree",
        {
            "a": {"fmu": str(foreign[2, "TestStair"])},
            "gear": {"fmu": str(fmu_dir / "LandingGear.fmu"), "inputs": {"piston_extension": 0.4}},
        },
        record=["a.counter", "gear.gear_angle"],
    )
    with pytest.raises(SceneError, match=r"no stop_time in the scene, and the FMUs' Default"):
        Simulation(disagree)
