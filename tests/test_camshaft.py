"""A whole camshaft (tools/camshaft.py) on the scene's reference: phasings, the total and
shaft-section torques, their fluctuation; the claim that the sequence of the cams' actions
sets the torque's fluctuation, tested for what it is."""

import math

import numpy as np
import pytest

import mechfmu
from mechfmu.cosim.scene import SceneError, find_file, load_scene
from mechfmu.tools import camshaft as shaft

SCENE = load_scene(find_file("camshaft_inline_four"))


def reference_run(scene, parameters):
    return mechfmu.reference(scene, parameters=parameters)


def test_firing_order_phasing_is_the_scenes():
    parameters = shaft.phasing_parameters(SCENE, shaft.firing_order((1, 3, 4, 2)))
    for name, value in parameters.items():
        component = name.split(".")[0]
        assert value == pytest.approx(
            SCENE.components[component].parameters["rise_start"], abs=1e-15
        )
    assert parameters["intake_3.rise_start"] == pytest.approx(math.pi / 2, abs=1e-15)
    throws = shaft.phasing_parameters(SCENE, shaft.INLINE_FOUR[2])
    assert throws["intake_2.rise_start"] == pytest.approx(math.pi, abs=1e-15)
    assert throws["exhaust_4.rise_start"] == pytest.approx(-math.radians(110.0), abs=1e-15)
    with pytest.raises(ValueError, match="must name each cylinder 1..4 once"):
        shaft.firing_order((1, 3, 3, 2))


def test_a_scene_without_lobes_is_refused():
    with pytest.raises(SceneError, match="needs components intake_<n> and exhaust_<n>"):
        shaft.lobes(load_scene(find_file("valve_train")))


def test_torques_are_the_lobes_summed_from_the_far_end():
    result = mechfmu.reference(SCENE)
    torque = shaft.torques(result, SCENE)
    lobe = {
        c: result[f"intake_{c}.camshaft_torque"] + result[f"exhaust_{c}.camshaft_torque"]
        for c in range(1, 5)
    }
    np.testing.assert_allclose(torque["total"], sum(lobe.values()), rtol=0, atol=1e-12)
    np.testing.assert_allclose(torque["shaft_3"], lobe[4], rtol=0, atol=1e-12)
    np.testing.assert_allclose(torque["shaft_1"], lobe[2] + lobe[3] + lobe[4], rtol=0, atol=1e-12)


def test_sequence_claim_evenly_spaced_lobes_give_one_total_whatever_the_order():
    table, curves = shaft.compare_phasings(SCENE, reference_run)
    correct, other, throws = (curves[p.name]["total"].to_numpy() for p in shaft.INLINE_FOUR)
    scale = np.max(np.abs(correct))
    # the total is a sum over the set of phases: another firing order, the same torque
    assert np.max(np.abs(correct - other)) <= 1e-12 * scale
    figures = table.loc[shaft.INLINE_FOUR[0].name]
    assert figures["peak_to_peak"] == pytest.approx(18.627, abs=2e-3)
    assert figures["rms"] == pytest.approx(6.801, abs=2e-3)
    # what does matter: even spacing; lobes at the crank throws' angles double the swing
    wrong = table.loc[shaft.INLINE_FOUR[2].name]
    assert wrong["peak_to_peak"] / figures["peak_to_peak"] == pytest.approx(2.02, abs=0.01)
    assert wrong["rms"] > 1.4 * figures["rms"]
    # a shaft section inside carries more than the drive end: 15.1 against 9.3 N.m
    assert figures["largest_section_torque"] > 1.6 * figures["peak"]
    # conservative lobes: the mean over a revolution vanishes (to the sum's quadrature)
    assert (table["mean"].abs() < 1e-6 * table["peak"]).all()
