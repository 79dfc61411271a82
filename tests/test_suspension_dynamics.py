"""Suspension dynamics: frequency, energy, dynamic snap-through, stiff springs, effects,
road profiles, reference scenes and FMU state."""

import math
import re

import numpy as np
import pytest

from conftest import REFERENCES, SCENES
from fmu_driver import Driven
from mechfmu.io import read_csv
from mechfmu.cosim.run import run_scene
from mechfmu.runtime.models.road_profile import RoadProfile
from mechfmu.runtime.models.suspension import Suspension
from mechfmu.runtime.physics import profiles, road
from mechfmu.runtime.physics import suspension as statics
from mechfmu.runtime.physics import suspension_dynamics as dyn
from mechfmu.runtime.errors import MechanismError

SPRING = statics.make_spring(0.5, 1.0e4, 0.2)
MASS = 211.0
WEIGHT = MASS * 9.81
U1 = statics.solve_on_branch(WEIGHT, statics.NEAR, SPRING)
LIMIT = statics.limit_point(SPRING)


def slave(parameters, load=WEIGHT, **inputs):
    """A Suspension slave run in this process (no FMU), initialised."""
    model = Suspension(instance_name="in_process")
    model.values.update(parameters)
    model.values.update(load=load, **inputs)
    model.setup_experiment(0.0)
    model.exit_initialization_mode()
    assert model.pending_error is None, model.pending_error
    return model


def run_slave(model, steps, dt, load=None, start=0.0):
    """Step an in-process slave from ``start``; returns its values at every point."""
    rows = [dict(model.values)]
    for i in range(steps):
        if load is not None:
            model.values["load"] = load(start + (i + 1) * dt)
        assert model.do_step(start + i * dt, dt), [m.msg for m in model.log_queue][-1:]
        rows.append(dict(model.values))
    return rows


def upward_crossings(times, values):
    """Times where values cross zero upwards, linearly interpolated between samples."""
    found = []
    for i in range(1, len(values)):
        a, b = values[i - 1], values[i]
        if a < 0.0 <= b:
            found.append(times[i - 1] + (times[i] - times[i - 1]) * a / (a - b))
    return found


# --- small oscillation: tangent, not secant, stiffness ----------------------------------------


def test_small_oscillation_about_u1_has_the_tangent_frequency(fmu_dir):
    tangent = statics.tangent_stiffness(U1, SPRING)
    secant = statics.secant_stiffness(U1, SPRING)
    f_tangent = math.sqrt(tangent / MASS) / (2.0 * math.pi)
    f_secant = math.sqrt(secant / MASS) / (2.0 * math.pi)
    fmu = Driven(
        fmu_dir / "Suspension.fmu",
        parameters={"dynamics": True, "initial_deflection": U1 + 1e-4},
        inputs={"load": WEIGHT},
    )
    try:
        dt, times, offsets = 0.002, [0.0], [fmu.get("deflection") - U1]
        for _ in range(2500):
            assert fmu.step(dt) is True
            times.append(fmu.time)
            offsets.append(fmu.get("deflection") - U1)
    finally:
        fmu.close()
    crossings = upward_crossings(times, offsets)
    assert len(crossings) >= 5
    periods = np.diff(crossings)
    measured = 1.0 / periods.mean()
    error = max(abs(measured - f_tangent) / f_tangent, np.ptp(periods) / periods.mean())
    assert error < 1e-6, (measured, f_tangent)
    # the secant "effective stiffness" predicts a frequency 9 % too high
    assert abs(f_secant - f_tangent) / f_tangent > 1000.0 * error


# --- energy ----------------------------------------------------------------------------------


@pytest.mark.parametrize("effects", [{}, {"tyre": True}])
@pytest.mark.parametrize("method", ["dopri5", "radau"])
def test_free_undamped_motion_conserves_energy(effects, method):
    """Released unloaded under the full weight: a large nonlinear oscillation (0 to 0.27 m)."""
    model = slave({"dynamics": True, "integrator": method, **effects})
    rows = run_slave(model, 300, 0.01)
    energy = [r["kinetic_energy"] + r["potential_energy"] for r in rows]
    scale = max(r["kinetic_energy"] for r in rows)
    assert scale > 100.0 and max(r["deflection"] for r in rows) > 0.2
    assert max(energy) - min(energy) < model.values["rtol"] * scale


def test_damping_dissipates_energy():
    rows = run_slave(slave({"dynamics": True, "damping": True}), 200, 0.01)
    energy = [r["kinetic_energy"] + r["potential_energy"] for r in rows]
    assert all(b <= a + 1e-9 for a, b in zip(energy, energy[1:]))
    assert rows[-1]["deflection"] == pytest.approx(U1, abs=1e-3)  # zeta 0.3: settles


# --- sudden load: dynamic snap-through below the static limit load ----------------------------


def critical_sudden_load():
    """Smallest load that, applied suddenly to the unloaded undamped spring, snaps it through.

    From rest at u = 0 the mass reaches the unstable equilibrium u2(W) with energy to spare
    when W u2 > E_spring(u2) (the work of the load exceeds the stored elastic energy).
    """

    def u2(load):
        low, high = LIMIT.deflection, statics.rest_height(SPRING)
        for _ in range(200):
            middle = 0.5 * (low + high)
            low, high = (
                (middle, high) if statics.spring_force(middle, SPRING) > load else (low, middle)
            )
        return low

    low, high = 0.5 * LIMIT.load, LIMIT.load
    for _ in range(100):
        middle = 0.5 * (low + high)
        if middle * u2(middle) > dyn.spring_energy(u2(middle), SPRING):
            high = middle
        else:
            low = middle
    return high


def test_critical_sudden_load_is_well_below_the_static_limit():
    critical = critical_sudden_load()
    assert 0.68 * LIMIT.load < critical < 0.70 * LIMIT.load  # 2141 N vs F* = 3091 N
    for factor, snaps in ((0.99, False), (1.01, True)):
        model = slave({"dynamics": True}, load=factor * critical)
        rows = run_slave(model, 150, 0.01)
        assert any(r["snap_through"] for r in rows) is snaps, factor


def test_sudden_load_below_the_limit_snaps_through_but_a_slow_ramp_does_not(fmu_dir):
    load = 2500.0
    assert load < 0.81 * LIMIT.load
    fmu = Driven(
        fmu_dir / "Suspension.fmu",
        parameters={
            "dynamics": True,
            "damping": True,
            "damping_coefficient": 200.0,
            "input_interpolation": "hold",
        },
        inputs={"load": 0.0},
    )
    try:
        flags = []
        for i in range(300):
            assert fmu.step(0.01, load=load if i >= 10 else 0.0) is True  # from t = 0.1 s
            flags.append(fmu.get("snap_through"))
        assert sum(flags) == 1 and fmu.get("snap_through_count") == 1
        assert fmu.get("branch") == 1 and fmu.get("stable")
        assert fmu.get("deflection") > 2.0 * statics.rest_height(SPRING) - LIMIT.deflection
        warnings = [m for m in fmu.messages("warning") if "snap-through" in m]
        assert len(warnings) == 1 and "near to the far stable region" in warnings[0]
        snap_time = float(re.search(r"at t = ([0-9.e+-]+) s", warnings[0]).group(1))
        step = flags.index(True)  # the step from 0.01 step to 0.01 (step + 1)
        assert 0.1 < snap_time and 0.01 * step < snap_time <= 0.01 * (step + 1) + 1e-12
    finally:
        fmu.close()
    static = Driven(fmu_dir / "Suspension.fmu")
    try:
        for i in range(1, 301):
            assert static.step(0.01, load=load * i / 300) is True
            assert static.get("branch") == 0 and not static.get("snap_through")
        assert static.get("deflection") == pytest.approx(
            statics.solve_on_branch(load, statics.NEAR, SPRING), rel=1e-12
        )
    finally:
        static.close()


def test_dynamic_snap_through_can_stop_the_run():
    model = slave({"dynamics": True, "stop_on_snap_through": True}, load=2500.0)
    steps = 0
    while steps < 100 and model.do_step(0.01 * steps, 0.01):
        steps += 1
    assert steps < 100
    assert "dynamic snap-through at t = " in model.log_queue[-1].msg
    assert model.values["snap_through_count"] == 0


# --- stiff springs -------------------------------------------------------------------------------


@pytest.mark.parametrize("stiffness", [1e6, 1e7, 1e8])
def test_stiff_spring_runs_stably_with_radau(fmu_dir, stiffness):
    spring = statics.make_spring(0.5, stiffness, 0.2)
    u1 = statics.solve_on_branch(WEIGHT, statics.NEAR, spring)
    fmu = Driven(
        fmu_dir / "Suspension.fmu",
        parameters={"dynamics": True, "spring_stiffness": stiffness, "integrator": "radau"},
        inputs={"load": WEIGHT},
    )
    try:
        deflections, energies = [], []
        for _ in range(20):
            assert fmu.step(0.01) is True
            deflections.append(fmu.get("deflection"))
            energies.append(fmu.get("kinetic_energy") + fmu.get("potential_energy"))
    finally:
        fmu.close()
    assert all(math.isfinite(u) for u in deflections)
    # sudden load from rest: the mass swings between 0 and about 2 u1 (energy conserved)
    assert -1e-3 * u1 < min(deflections) and max(deflections) < 2.01 * u1
    assert max(energies) - min(energies) < 1e-6 * WEIGHT * u1


@pytest.mark.parametrize("method", ["euler", "rk4"])
@pytest.mark.parametrize("stiffness", [1e6, 1e7, 1e8])
def test_stiff_spring_with_an_explicit_method_is_refused_as_unstable(fmu_dir, method, stiffness):
    omega = math.sqrt(2.0 * stiffness * 0.84 / MASS)  # small-deflection stiffness 2 k h^2/L^2
    max_substep = 10.0 / omega  # h omega = 10: beyond euler's and rk4's stability limits
    fmu = Driven(
        fmu_dir / "Suspension.fmu",
        parameters={
            "dynamics": True,
            "spring_stiffness": stiffness,
            "integrator": method,
            "max_substep": max_substep,
        },
        inputs={"load": WEIGHT},
    )
    try:
        outcome = True
        for _ in range(10):
            kept = fmu.get("deflection")
            outcome = fmu.step(0.1)
            if outcome is not True:
                break
            assert math.isfinite(fmu.get("deflection"))
        assert outcome is not True, "an unstable explicit integration was not refused"
        assert "unstable" in outcome and method in outcome and "radau" in outcome
        assert fmu.get("deflection") == kept  # outputs keep their last valid values
    finally:
        fmu.close()


# --- effects: only the enabled ones are computed -------------------------------------------------


@pytest.fixture
def counted(monkeypatch):
    """Wrap each effect's term function with a call counter."""
    calls = {}
    for name in ("damping_force", "tyre_force", "road_at"):
        original = getattr(dyn, name)
        calls[name] = 0

        def wrapper(*args, _name=name, _original=original):
            calls[_name] += 1
            return _original(*args)

        monkeypatch.setattr(dyn, name, wrapper)
    return calls


def test_disabled_effects_are_never_called(counted):
    model = slave({"dynamics": True})
    run_slave(model, 20, 0.01)
    assert model.values["rhs_evaluations"] > 100
    assert counted == {"damping_force": 0, "tyre_force": 0, "road_at": 0}


@pytest.mark.parametrize("enabled", ["damping", "tyre", "road_input"])
def test_each_effect_costs_only_its_own_term(counted, enabled):
    model = slave(
        {"dynamics": True, enabled: True, "initial_deflection": U1}, road_height=0.01, road_rate=0.0
    )
    run_slave(model, 20, 0.01)
    term = {"damping": "damping_force", "tyre": "tyre_force", "road_input": "road_at"}[enabled]
    assert counted[term] >= model.values["rhs_evaluations"]
    assert all(count == 0 for name, count in counted.items() if name != term)


def test_dynamics_off_is_the_static_model():
    static = slave({}, load=0.0)
    rows = run_slave(static, 40, 0.1, load=lambda t: 100.0 * t)
    for row in rows[1:]:
        expected = statics.solve_on_branch(row["load"], statics.NEAR, SPRING)
        assert row["deflection"] == pytest.approx(expected, rel=1e-12, abs=1e-15)
        assert row["velocity"] == 0.0 and row["rhs_evaluations"] == 0
    assert static.integrator is None


def test_effects_other_than_dynamics_need_dynamics():
    model = Suspension(instance_name="in_process")
    model.values.update(tyre=True, damping=True)
    model.exit_initialization_mode()
    assert "damping, tyre need the dynamics effect" in model.pending_error


# --- road profiles ----------------------------------------------------------------------------


def test_bump_is_exact():
    height, duration, start = 0.05, 0.1, 0.3
    assert road.bump(start + duration / 2, height, duration, start).value == height
    for t in (start, start + duration, start - 1.0, start + 2.0):
        assert road.bump(t, height, duration, start) == (0.0, 0.0, 0.0)
    for t in (start + 1e-6, start + duration - 1e-6):  # rate -> 0 continuously at both ends
        assert abs(road.bump(t, height, duration, start).rate) < 1e-4
    peak_rate = road.bump(start + duration / 4, height, duration, start).rate
    assert peak_rate == pytest.approx(math.pi * height / duration, rel=1e-15)


@pytest.mark.parametrize(
    "shape, kwargs",
    [
        ("bump", dict(height=0.05, duration=0.1, start_time=0.1)),
        ("sine", dict(amplitude=0.02, frequency=3.0, start_time=0.05)),
    ],
)
def test_road_rates_are_the_derivatives(shape, kwargs):
    for t in np.linspace(0.11, 0.19, 9):
        h = 1e-6
        sample = road.road(t, shape, **kwargs)
        ahead, behind = road.road(t + h, shape, **kwargs), road.road(t - h, shape, **kwargs)
        assert sample.rate == pytest.approx(
            (ahead.value - behind.value) / (2 * h), rel=1e-7, abs=1e-9
        )
        assert sample.rate2 == pytest.approx(
            (ahead.rate - behind.rate) / (2 * h), rel=1e-6, abs=1e-6
        )


def test_sine_and_step_values():
    assert road.sine(0.05 + 1 / 12, 0.02, 3.0, 0.05).value == pytest.approx(0.02, rel=1e-15)
    assert road.sine(0.0, 0.02, 3.0, 0.05) == (0.0, 0.0, 0.0)
    assert road.step(0.2, 0.03, 0.2).value == 0.03 and road.step(0.19, 0.03, 0.2).value == 0.0


def test_road_profile_fmu_shapes(fmu_dir, tmp_path):
    table = tmp_path / "road.csv"
    table.write_text("time,height\n0,0\n1,0.02\n2,-0.01\n")
    cases = [
        (
            {"shape": "bump", "height": 0.05, "duration": 0.1, "start_time": 0.1},
            [(0.125, 0.025, math.pi * 0.5), (0.15, 0.05, 0.0), (0.2, 0.0, 0.0)],
        ),
        ({"shape": "step", "height": 0.03, "start_time": 0.5}, [(0.4, 0.0, 0.0), (0.5, 0.03, 0.0)]),
        (
            {"shape": "table", "table_file": str(table)},
            [(0.5, 0.01, 0.02), (1.5, 0.005, -0.03), (3.0, -0.01, 0.0)],
        ),
    ]
    for parameters, samples in cases:
        fmu = Driven(fmu_dir / "RoadProfile.fmu", parameters=parameters)
        try:
            for t, height, rate in samples:
                assert fmu.step(t - fmu.time) is True
                assert fmu.get("road_height") == pytest.approx(height, rel=1e-12, abs=1e-17)
                assert fmu.get("road_rate") == pytest.approx(rate, rel=1e-12, abs=1e-14)
        finally:
            fmu.close()


@pytest.mark.parametrize(
    "parameters, words",
    [
        ({"shape": "ramp"}, ["shape = 'ramp'", "bump"]),
        ({"shape": "bump", "duration": 0.0}, ["duration = 0.0"]),
        ({"shape": "sine", "frequency": -1.0}, ["frequency = -1.0"]),
    ],
)
def test_road_profile_refuses_bad_parameters(parameters, words):
    model = RoadProfile(instance_name="in_process")
    model.values.update(parameters)
    model.exit_initialization_mode()
    for word in words:
        assert word in model.pending_error


def test_step_inputs_hermite_is_exact_for_cubics():
    inputs = dyn.StepInputs("interpolate")

    def cubic(t):
        return 0.01 + 0.2 * t - 3.0 * t * t + 5.0 * t**3, 0.2 - 6.0 * t + 15.0 * t * t

    t0, t1 = 0.3, 0.35
    inputs.set_step(t0, t1, (0.0, *cubic(t0)), (10.0, *cubic(t1)))
    for t in np.linspace(t0, t1, 7):
        r, rate, _ = dyn.road_at(inputs, t)
        assert r == pytest.approx(cubic(t)[0], rel=1e-13)
        assert rate == pytest.approx(cubic(t)[1], rel=1e-12)
        assert dyn.load_at(inputs, t) == pytest.approx(10.0 * (t - t0) / (t1 - t0), abs=1e-12)
    with pytest.raises(MechanismError, match="input_interpolation = 'linear'"):
        dyn.StepInputs("linear")


# --- shipped scenes against their solve_ivp references ---------------------------------------


def test_sudden_load_scene_snaps_once(fmu_dir, tmp_path):
    result, _ = run_scene(SCENES / "suspension_sudden_load.toml", tmp_path, fmu_dir, plot=False)
    flags = result.columns["suspension.snap_through"]
    assert sum(flags) == 1 and result.columns["suspension.branch"][-1] == 1
    assert max(result.columns["load.load"]) < LIMIT.load
    assert any("snap-through" in entry["message"] for entry in result.log)


def test_road_bump_scene_starts_at_rest():
    result_reference = read_csv(REFERENCES / "suspension_road_bump.csv")
    times, columns = result_reference
    before = [i for i, t in enumerate(times) if t <= 0.1]
    assert max(abs(columns["suspension.velocity"][i]) for i in before) < 1e-12
    assert max(columns["road.road_height"]) == pytest.approx(0.05, rel=1e-12)


# --- FMU state -------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["dopri5", "radau"])
def test_fmu_state_round_trip_gives_identical_outputs(fmu_dir, method):
    names = [
        "deflection",
        "velocity",
        "acceleration",
        "unsprung_displacement",
        "tyre_force",
        "kinetic_energy",
        "rhs_evaluations",
        "substeps",
        "snap_through_count",
    ]
    fmu = Driven(
        fmu_dir / "Suspension.fmu",
        parameters={
            "dynamics": True,
            "damping": True,
            "tyre": True,
            "road_input": True,
            "integrator": method,
            "initial_deflection": U1,
        },
        inputs={"load": WEIGHT},
    )

    def steps(count):
        rows = []
        for _ in range(count):
            bump = road.bump(fmu.time + 0.01, 0.05, 0.1, 0.05)
            assert fmu.step(0.01, road_height=bump.value, road_rate=bump.rate) is True
            rows.append([fmu.get(name) for name in names])
        return rows

    try:
        steps(8)
        first, second = fmu.replayed(lambda: steps(10))
    finally:
        fmu.close()
    assert first == second
    assert first[-1][0] != first[0][0]


def test_internal_state_restores_the_carried_step():
    model = slave({"dynamics": True, "integrator": "radau", "tyre": True})
    run_slave(model, 5, 0.01)
    saved = model._get_fmu_state()
    assert saved["internal"]["integrator"]["_h"] > 0.0
    after = run_slave(model, 5, 0.01, start=0.05)[-1]
    model._set_fmu_state(saved)
    again = run_slave(model, 5, 0.01, start=0.05)[-1]
    assert after == again


def test_profiles_table_reader_is_shared(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("time,height\n0,0\n2,0.04\n")
    assert road.road(1.0, "table", table=profiles.read_table(path)) == (0.02, 0.02, 0.0)


def test_runner_script(fmu_dir, tmp_path):
    from cli_process import run_script

    done = run_script(
        "run_suspension_dynamics.py", "--out", tmp_path, "--fmu-dir", fmu_dir, "--no-plot"
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("match: ") == 2 and "MISMATCH" not in done.stdout
    assert "snap-throughs at t = 0.6963" in done.stdout
