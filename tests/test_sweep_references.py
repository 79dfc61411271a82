"""Scalar references of the parameter sweeps (src/mechfmu/tools/sweep_references.py)."""

import csv
import math

import numpy as np
import pytest

from conftest import REFERENCES
from mechfmu.references import suspension as statics
from mechfmu.references import suspension_dynamics as dynamics
from mechfmu.tools import sweep_references as sweeps

G = 9.80665
L, K, D = 0.5, 1e4, 0.2  # the coursework suspension


# --- suspension --------------------------------------------------------------------------


def test_static_snap_through_mass_is_the_limit_load_over_g():
    mass = sweeps.static_snap_through_mass()
    assert mass == pytest.approx(315.15, abs=0.005)  # README: F* = 3090.58 N
    assert mass * G == pytest.approx(3090.58, abs=0.005)
    # gravity is a real parameter: the coursework's 9.81 gives the README's 315.04 kg
    assert sweeps.static_snap_through_mass(gravity=9.81) == pytest.approx(315.04, abs=0.005)


def test_undamped_sudden_load_closed_form():
    load = sweeps.sudden_snap_through_load_undamped()
    assert load == pytest.approx(2141.3, abs=0.05)  # README
    assert load / statics.limit_point(L, K, D)[1] == pytest.approx(0.693, abs=5e-4)


@pytest.fixture(scope="module")
def sudden_masses():
    return {c: sweeps.sudden_snap_through_mass(c) for c in (0.0, 200.0, 980.0)}


def test_undamped_threshold_mass_matches_the_energy_closed_form(sudden_masses):
    by_integration = sudden_masses[0.0] * G
    assert by_integration == pytest.approx(sweeps.sudden_snap_through_load_undamped(), rel=1e-5)


def test_damping_raises_the_sudden_threshold_below_the_static_one(sudden_masses):
    masses = [sudden_masses[c] for c in (0.0, 200.0, 980.0)]
    assert masses[0] < masses[1] < masses[2] < sweeps.static_snap_through_mass()
    assert masses[1] == pytest.approx(234.162, abs=0.01)
    assert masses[2] == pytest.approx(281.413, abs=0.01)


@pytest.mark.parametrize("c", [0.0, 980.0])
def test_threshold_by_the_scene_reference(c, sudden_masses):
    """1e-4 either side of the threshold, the dynamic scene reference (no early stops, its own
    snap events) agrees: no snap-through below, at least one above (undamped, the mass then
    swings back and forth through both regions)."""
    threshold = sudden_masses[c]
    times = np.linspace(0.0, 8.0, 9)
    for factor, expected in ((1.0 - 1e-4, 0), (1.0 + 1e-4, 1)):
        m = threshold * factor
        system = dynamics.System((L, K, D), m, c, None, lambda t, W=m * G: W, None)
        _, snaps = dynamics.simulate(system, times, 0.0, 0.0)
        assert (len(snaps) > 0) == bool(expected)
        assert sweeps.sudden_load_snaps(m, c) is bool(expected)


def test_scene_sudden_load_snaps():
    # suspension_sudden_load: 2500 N on 211 kg with c = 200 N s/m snaps (README)
    assert sweeps.sudden_load_snaps(211.0, 200.0, gravity=2500.0 / 211.0)
    assert not sweeps.sudden_load_snaps(211.0, 200.0, gravity=2000.0 / 211.0)


# --- landing gear ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def retraction_times():
    return {p: sweeps.retraction_time(p) for p in (5e6, 1e7, 2.07e7, 2.5e7)}


def test_retraction_time_at_the_scene_pressure(retraction_times):
    with open(REFERENCES / "gear_retraction_dynamic.csv") as handle:
        stored = float(list(csv.DictReader(handle))[-1]["gear.retraction_time"])
    assert round(retraction_times[2.07e7], 3) == 2.260  # README
    assert retraction_times[2.07e7] == pytest.approx(stored, abs=1e-9)


def test_retraction_time_falls_with_supply_pressure(retraction_times):
    pressures = sorted(retraction_times)
    times = [retraction_times[p] for p in pressures]
    assert all(math.isfinite(t) for t in times)
    assert all(a > b for a, b in zip(times, times[1:]))
    assert times[0] == pytest.approx(2.6585, abs=1e-4)


def test_minimum_retraction_pressure():
    p_min = sweeps.minimum_retraction_pressure()
    assert p_min == pytest.approx(3.1246e6, rel=1e-4)
    assert sweeps.minimum_retraction_pressure(include_coulomb=True) > p_min
    assert math.isnan(sweeps.retraction_time(0.9 * p_min, stop_time=100.0))  # stalls
    assert math.isfinite(sweeps.retraction_time(1.05 * p_min, stop_time=100.0))
    # not within the scene's 3 s: the sweep's metric is undefined there
    assert math.isnan(sweeps.retraction_time(1.05 * p_min))


# --- valve float speed ---------------------------------------------------------------------


def test_valve_float_speed_default():
    assert sweeps.valve_float_speed(300.0) == pytest.approx(432.233, abs=5e-4)  # README


def test_valve_float_speed_grows_with_preload():
    speeds = [sweeps.valve_float_speed(f) for f in (0.0, 150.0, 300.0, 600.0)]
    assert math.isfinite(speeds[0]) and speeds[0] > 0.0
    assert all(a < b for a, b in zip(speeds, speeds[1:]))
    assert speeds[0] == pytest.approx(338.762, abs=1e-3)


@pytest.mark.parametrize("law", ["polynomial_345", "harmonic"])
def test_valve_float_speed_checks_the_fmu_physics(law):
    from mechfmu.runtime.models.valve_train import CAM
    from mechfmu.runtime.physics import cam_laws
    from mechfmu.runtime.physics import valve_train as physics

    profile = cam_laws.check_profile(law, *CAM[1:])
    for preload in (50.0, 300.0, 900.0):
        fmu = physics.float_speed(physics.DEFAULT_VALVE_GEOMETRY, profile, 0.1, 5e4, preload)
        assert sweeps.valve_float_speed(preload, cam_law=law) == pytest.approx(
            fmu.camshaft_speed, rel=1e-9
        )


# --- bad input -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: sweeps.valve_float_speed(-1.0), "spring_preload"),
        (lambda: sweeps.valve_float_speed(300.0, valve_mass=0.0), "valve_mass"),
        (lambda: sweeps.valve_float_speed(300.0, spring_stiffness=-5.0), "spring_stiffness"),
        (lambda: sweeps.valve_float_speed(300.0, cam_law="square"), "cam_law"),
        (lambda: sweeps.valve_float_speed(300.0, lobe=1.0), "lobe"),
        (lambda: sweeps.sudden_snap_through_mass(-1.0), "damping_coefficient"),
        (lambda: sweeps.sudden_snap_through_mass(0.0, tolerance=0.0), "tolerance"),
        (lambda: sweeps.sudden_load_snaps(0.0, 0.0), "mass"),
        (lambda: sweeps.static_snap_through_mass(spring_base_offset=0.6), "spring_base_offset"),
        (lambda: sweeps.static_snap_through_mass(gravity=math.nan), "gravity"),
        (lambda: sweeps.retraction_time(-2e7), "supply_pressure"),
        (lambda: sweeps.retraction_time(2e7, no_such_thing=1.0), "no_such_thing"),
    ],
)
def test_bad_input_names_the_value(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_sudden_threshold_as_the_sweep_applies_it():
    """sweeps/suspension_mass_sudden.toml: load 9.81 m (the coursework's g), c = 200 N s/m,
    stepped at t = 0.1 s of a 3 s scene. Just above the threshold the snap still comes well
    inside the 2.9 s left, so the sweep's grid (2.5 kg) sees the threshold itself."""
    threshold = sweeps.sudden_snap_through_mass(200.0, gravity=9.81)
    assert threshold == pytest.approx(234.084, abs=0.01)
    m = threshold * (1.0 + 1e-4)
    system = dynamics.System((L, K, D), m, 200.0, None, lambda t: m * 9.81, None)
    _, snaps = dynamics.simulate(system, np.linspace(0.0, 2.9, 30), 0.0, 0.0)
    assert snaps and snaps[0] < 1.5
