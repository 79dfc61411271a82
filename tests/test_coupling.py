"""The master's coupling schemes, its batched FMI calls and the FMI-call timer."""

import copy
import dataclasses

import numpy as np
import pytest

from conftest import SCENES
from mechfmu.cosim.master import Simulation
from mechfmu.cosim.scene import SceneError, load_scene, parse_scene
from test_scenes import gear_scene


def _run(scene, fmu_dir, **options):
    result = Simulation(scene, fmu_dir).run(**options)
    return result, {name: np.array(values) for name, values in result.columns.items()}


def test_jacobi_feeds_the_outputs_at_the_start_of_the_step(fmu_dir, tmp_path):
    # The kinematic gear depends only on its current inputs, so under Jacobi (inputs from
    # the step's start) it shows, at each point, exactly the Gauss-Seidel value of the
    # point before: the one-step lag of the coupling, and nothing else.
    data = gear_scene(stop_time=3.0, step=0.1)
    data["components"]["actuator"]["parameters"] = {"profile": "cycloidal", "stroke_time": 3.0}
    seidel = parse_scene(data, tmp_path / "inline.toml")
    jacobi = parse_scene({**data, "coupling": "jacobi"}, tmp_path / "inline.toml")
    _, gs = _run(seidel, fmu_dir)
    result, jc = _run(jacobi, fmu_dir)
    assert result.meta["coupling"] == "jacobi"
    for name in (
        "gear.gear_angle",
        "gear.gear_angular_velocity",
        "gear.gear_angular_acceleration",
        "gear.piston_length",
    ):
        assert np.array_equal(jc[name][1:], gs[name][:-1]), name
        assert np.ptp(gs[name]) > 0.0  # the signal moves, so the lag is visible
    assert np.array_equal(jc["actuator.piston_extension"], gs["actuator.piston_extension"])


def test_unknown_coupling_is_refused_with_the_choices(tmp_path):
    with pytest.raises(SceneError, match="coupling = 'newton' is not one of gauss_seidel, jacobi"):
        parse_scene(gear_scene(coupling="newton"), tmp_path / "inline.toml")


def test_fmi_call_timer_measures_a_part_of_the_loop(fmu_dir):
    scene = load_scene(SCENES / "gear_retraction.toml")
    plain, columns = _run(scene, fmu_dir)
    timed, timed_columns = _run(scene, fmu_dir, time_fmi_calls=True)
    assert "fmi_call_time_s" not in plain.meta
    assert 0.0 < timed.meta["fmi_call_time_s"] < timed.meta["loop_time_s"]
    assert timed.meta["loop_time_s"] < timed.meta["wall_time_s"]
    # by call: every component's doStep and its reads, adding up to the total
    calls = timed.meta["fmi_call_times_s"]
    assert {f"{name}.fmi2DoStep" for name in scene.components} <= set(calls)
    assert all(name.split(".")[0] in scene.components for name in calls)
    assert sum(calls.values()) == pytest.approx(timed.meta["fmi_call_time_s"], rel=1e-9)
    for name in columns:  # timing changes nothing in the results
        assert np.array_equal(columns[name], timed_columns[name])


def test_recorded_integer_and_boolean_outputs_keep_their_values(fmu_dir):
    scene = load_scene(SCENES / "suspension_sudden_load.toml")
    _, columns = _run(scene, fmu_dir)
    snaps = columns["suspension.snap_through_count"]
    assert set(np.unique(columns["suspension.stable"])) <= {0.0, 1.0}
    assert snaps[0] == 0.0 and snaps[-1] == 1.0 and np.all(np.diff(snaps) >= 0)


def test_radau_locates_an_event_after_a_long_accepted_step(fmu_dir):
    # At a 0.1 s communication step, radau at 1e-6 takes long steps; locating the end of
    # the retraction inside one used to stall Newton on a tiny trial sub-step. The event is
    # now located on the step's collocation polynomial.
    scene = load_scene(SCENES / "gear_retraction_dynamic.toml")
    components = copy.deepcopy(scene.components)
    components["gear"].parameters.update(rtol=1e-6, atol=1e-6, max_substep=0.1)
    coarse = dataclasses.replace(scene, step=0.1, components=components)
    _, columns = _run(coarse, fmu_dir)
    assert columns["gear.retraction_time"][-1] == pytest.approx(2.2597, abs=2e-3)
