"""A second FMI host: every FMU under libcosim (libcosimpy) against the same FMU under fmpy.

Each case runs one FMU with the same parameters and inputs in both hosts on the same
communication points (libcosim's: t_k = k step_ns / 1e9, step t_{k+1} - t_k; see
mechfmu.tools.hosts.libcosim), and every Real output must agree to 1e-12 relative (1e-300 absolute
only for exact zeros) at every sample, every Integer output exactly, with the sample times
equal to the nominal grid k * step to 1e-9 s. The outputs named in each case must move.
"""

import math
import sys

import numpy as np
import pytest

if sys.version_info < (3, 11):
    # the lock installs libcosimpy only where a wheel exists (pyproject's marker)
    pytest.skip(
        f"libcosimpy 0.0.6, which these tests need, has no wheel for CPython "
        f"{sys.version_info[0]}.{sys.version_info[1]} (3.11 and later only)",
        allow_module_level=True,
    )

from fmpy import read_model_description

from fmu_driver import Driven
from mechfmu.tools.hosts.libcosim import (
    LibcosimError,
    communication_points,
    run_libcosim,
    step_nanoseconds,
)
from mechfmu.runtime.fmi.geometry import GEOMETRY_PREFIX
from mechfmu.runtime.models import MODELS


RTOL = 1e-12
FLOOR = 1e-300  # absolute allowance: only an exact 0 in one host may meet a subnormal

TWO_PI = 2.0 * math.pi


def _cosine_lift(peak, duration):
    """Rocker lift, velocity, acceleration of one smooth (1 - cos) opening of `duration` s."""
    w = TWO_PI / duration

    def lift(t):
        return peak * (1.0 - math.cos(w * t)) / 2.0 if t < duration else 0.0

    def velocity(t):
        return peak * w * math.sin(w * t) / 2.0 if t < duration else 0.0

    def acceleration(t):
        return peak * w * w * math.cos(w * t) / 2.0 if t < duration else 0.0

    return lift, velocity, acceleration


VALVE_LIFT, VALVE_VELOCITY, VALVE_ACCELERATION = _cosine_lift(0.0105, 0.008)
CAMSHAFT_SPEED = 157.07963267948966  # 3000 engine rpm
ENGINE_CRANK_SPEED = 314.1592653589793  # 3000 rpm

# id, model, parameters, inputs (value or f(t)), step, stop time, outputs that must move
CASES = [
    (
        "gear_motion_effects",
        "LandingGear",
        # with the forces effect: its loads move too (at least half the outputs must)
        {
            "inertia": True,
            "gravity": True,
            "aero_drag": True,
            "pivot_friction": True,
            "forces": True,
        },
        {
            "piston_extension": lambda t: 0.381 + 0.0762 * t,
            "piston_speed": 0.0762,
            "piston_acceleration": 0.0,
            "airspeed": lambda t: 40.0 + 10.0 * t,
            "piston_force": 0.0,
            "valve_command": 0.0,
        },
        0.01,
        2.0,
        ["gear_angle", "gear_angular_velocity", "piston_force_required", "wheel_speed"],
    ),
    (
        "gear_dynamics_hydraulics",
        "LandingGear",
        {
            "drive": "dynamics",
            "inertia": True,
            "gravity": True,
            "aero_drag": True,
            "pivot_friction": True,
            "end_stops": True,
            "hydraulics": True,
            "integrator": "radau",
            "rtol": 1e-9,
            "atol": 1e-9,
            "max_substep": 0.01,
        },
        {"valve_command": 1.0, "airspeed": 40.0},
        0.01,
        1.0,
        ["gear_angle", "gear_angular_velocity", "cap_pressure", "piston_length"],
    ),
    (
        "hydraulic_actuator",
        "HydraulicActuator",
        {},
        {
            "valve_command": lambda t: math.sin(TWO_PI * t),
            "piston_extension": lambda t: 0.45 + 0.02 * math.sin(math.pi * t),
            "piston_speed": lambda t: 0.02 * math.pi * math.cos(math.pi * t),
        },
        0.01,
        1.0,
        ["piston_force", "cap_pressure", "rod_pressure", "cap_flow"],
    ),
    (
        "piston_cycloidal",
        "PistonActuator",
        {"profile": "cycloidal", "stroke_time": 2.0, "start_time": 0.25},
        {},
        0.01,
        2.5,
        ["piston_extension", "piston_speed", "piston_acceleration"],
    ),
    (
        "suspension_static_ramp",
        "Suspension",
        {},
        {"load": lambda t: 1000.0 * t, "road_height": 0.0, "road_rate": 0.0},
        0.02,
        4.0,
        ["deflection", "spring_force", "secant_stiffness", "tangent_stiffness"],
    ),
    (
        "suspension_sudden_load",
        "Suspension",
        {
            "dynamics": True,
            "damping": True,
            "damping_coefficient": 200.0,
            "input_interpolation": "hold",
        },
        {"load": 2500.0, "road_height": 0.0, "road_rate": 0.0},
        0.01,
        1.5,
        ["deflection", "velocity", "acceleration", "kinetic_energy"],
    ),
    (
        "load_ramp",
        "LoadProfile",
        {
            "shape": "ramp",
            "initial_value": 100.0,
            "final_value": 2000.0,
            "start_time": 0.2,
            "duration": 1.0,
        },
        {},
        0.01,
        1.5,
        ["load"],
    ),
    (
        "road_sine",
        "RoadProfile",
        {"shape": "sine", "amplitude": 0.01, "frequency": 2.0, "start_time": 0.1},
        {},
        0.01,
        1.0,
        ["road_height", "road_rate"],
    ),
    (
        "crank_ramp",
        "CrankDrive",
        {
            "initial_angle": 0.3,
            "initial_speed": 2.0,
            "speed": 10.0,
            "ramp_time": 1.0,
            "start_time": 0.2,
        },
        {},
        0.01,
        1.5,
        ["crank_angle", "crank_speed"],
    ),
    (
        "four_bar_solver",
        "FourBar",
        {"solver": "constraint_solver", "forces": True, "geometry": True},
        {
            "crank_angle": lambda t: math.pi / 6.0 + TWO_PI * t,
            "crank_speed": TWO_PI,
            "crank_acceleration": 0.0,
        },
        0.005,
        1.0,
        [
            "coupler_angle",
            "rocker_angle",
            "rocker_angular_velocity",
            "coupler_angular_acceleration",
            "transmission_angle",
        ],
    ),
    (
        "slider_crank_offset",
        "SliderCrank",
        {"offset": 0.01, "forces": True},
        {
            "crank_angle": lambda t: ENGINE_CRANK_SPEED * t,
            "crank_speed": ENGINE_CRANK_SPEED,
            "crank_acceleration": 0.0,
        },
        0.0001,
        0.02,
        ["slider_position", "slider_speed", "slider_acceleration", "coupler_angle"],
    ),
    (
        "camshaft_ramp",
        "CamshaftDrive",
        {"initial_speed": 0.0, "speed": ENGINE_CRANK_SPEED, "ramp_time": 0.01},
        {},
        0.0001,
        0.02,
        ["camshaft_angle", "camshaft_speed"],
    ),
    (
        "valve_train_spring",
        "ValveTrain",
        {"valve_spring": True, "cam_law": "polynomial_345", "forces": True, "geometry": True},
        {
            "camshaft_angle": lambda t: CAMSHAFT_SPEED * t,
            "camshaft_speed": CAMSHAFT_SPEED,
            "camshaft_acceleration": 0.0,
        },
        0.0002,
        0.04,
        ["tappet_lift", "rocker_angle", "valve_lift", "valve_acceleration", "contact_force"],
    ),
    (
        "valve_spring_opening",
        "ValveSpring",
        {},
        {
            "rocker_lift": VALVE_LIFT,
            "rocker_velocity": VALVE_VELOCITY,
            "rocker_acceleration": VALVE_ACCELERATION,
        },
        0.00005,
        0.01,
        ["valve_lift", "valve_velocity", "contact_force", "seat_force", "spring_force"],
    ),
]


@pytest.fixture(scope="module")
def fmus(fmu_dir):
    """The built FMUs by model name."""
    return {name: fmu_dir / f"{name}.fmu" for name in MODELS}


def run_fmpy(path, parameters, inputs, step, stop_time, outputs):
    """The same run through fmpy (tests/fmu_driver.py): libcosim's communication points and
    step sizes, the inputs set the same way (f(0) before initialisation ends, f(t_{k+1})
    before the step from t_k). Returns (times, values) like run_libcosim."""
    points = communication_points(step, stop_time)
    held = {name: (value(0.0) if callable(value) else value) for name, value in inputs.items()}
    driven = Driven(path, parameters, held)
    try:
        values = {name: [driven.get(name)] for name in outputs}
        times = [driven.time]
        for start, end in zip(points, points[1:]):
            driven.time = start
            status = driven.step(
                end - start,
                **{name: value(end) for name, value in inputs.items() if callable(value)},
            )
            assert status is True, f"fmpy: step from t = {start} s refused: {status}"
            times.append(driven.time)
            for name in outputs:
                values[name].append(driven.get(name))
    finally:
        driven.close()
    return np.array(times), {name: np.array(v) for name, v in values.items()}


def relative_difference(a, b):
    """Largest |a - b| / max(|a|, |b|) over the samples (0 where both are exactly equal)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(a), np.abs(b))
    difference = np.abs(a - b)
    return float(np.max(np.where(difference == 0.0, 0.0, difference / np.maximum(scale, FLOOR))))


def test_every_model_has_a_case():
    assert sorted({case[1] for case in CASES}) == sorted(MODELS)


@pytest.mark.parametrize("case", CASES, ids=[case[0] for case in CASES])
def test_libcosim_agrees_with_fmpy(case, fmus):
    _, model, parameters, inputs, step, stop_time, moving = case
    steps = round(stop_time / step)
    assert 100 <= steps <= 300

    times, values = run_libcosim(fmus[model], parameters, inputs, step, stop_time)
    outputs = [
        v
        for v in read_model_description(str(fmus[model])).modelVariables
        if v.causality == "output"
    ]
    declared = {v.name: v.type for v in outputs}
    # the geometry effect's outputs draw the others (0 while it is off): compared, not counted
    drawing = {v.name for v in outputs if (v.description or "").startswith(GEOMETRY_PREFIX)}
    reals = [name for name, kind in declared.items() if kind == "Real"]
    integers = [name for name, kind in declared.items() if kind == "Integer"]
    assert sorted(values) == sorted(reals + integers)  # every Real and Integer output

    fmpy_times, fmpy_values = run_fmpy(
        fmus[model], parameters, inputs, step, stop_time, reals + integers
    )

    nominal = np.arange(steps + 1) * step
    assert times.shape == fmpy_times.shape == (steps + 1,)
    assert np.max(np.abs(times - nominal)) <= 1e-9
    assert np.max(np.abs(fmpy_times - nominal)) <= 1e-9
    assert np.max(np.abs(times - fmpy_times)) <= 1e-9

    for name in reals:
        a, b = values[name], fmpy_values[name]
        assert np.all(np.isfinite(a)), name
        bad = np.flatnonzero(np.abs(a - b) > RTOL * np.maximum(np.abs(a), np.abs(b)) + FLOOR)
        assert bad.size == 0, (
            f"{name}: {bad.size} sample(s) differ, first at t = "
            f"{times[bad[0]]!r} s: libcosim {a[bad[0]]!r}, fmpy {b[bad[0]]!r}"
        )
        assert relative_difference(a, b) <= RTOL
    for name in integers:
        assert np.array_equal(values[name], fmpy_values[name]), name

    for name in moving:  # not a comparison of constants
        series = values[name]
        assert np.ptp(series) > 1e-6 * np.max(np.abs(series)), name
        assert len(np.unique(series)) >= steps // 10, name
    own = [name for name in reals if name not in drawing]
    changing = [name for name in own if np.ptp(values[name]) > 0.0]
    assert len(changing) >= max(1, len(own) // 2), changing
    if parameters.get("geometry"):  # the joints move in both hosts alike
        assert len([name for name in drawing if np.ptp(values[name]) > 0.0]) >= 4


def test_inputs_as_callables_step_like_simulate_until(fmus):
    """The two libcosim paths (one simulate_until; one execution.step() per step with the
    override manipulator) give the same samples for the same held inputs."""
    parameters = {"drive": "dynamics", "inertia": True, "gravity": True, "end_stops": True}
    held = {"piston_force": 1500.0}
    _, at_once = run_libcosim(fmus["LandingGear"], parameters, held, 0.01, 1.0)
    _, stepped = run_libcosim(
        fmus["LandingGear"], parameters, {"piston_force": lambda t: 1500.0}, 0.01, 1.0
    )
    assert np.ptp(at_once["gear_angle"]) > 0.01
    for name in at_once:
        assert np.array_equal(at_once[name], stepped[name]), name


def test_libcosim_step_sizes_are_differences_of_its_time_points(fmus):
    """Why run_fmpy uses libcosim's points: with the constant step 0.01 s and t = k * 0.01
    the cycloidal stroke differs from libcosim's in the last bits (still within 1e-13)."""
    path = fmus["PistonActuator"]
    parameters = {"profile": "cycloidal", "stroke_time": 2.0}
    _, values = run_libcosim(path, parameters, {}, 0.01, 2.0)
    driven = Driven(path, parameters)
    try:
        other = {name: [driven.get(name)] for name in values}
        for k in range(200):
            driven.time = k * 0.01
            assert driven.step(0.01) is True
            for name in values:
                other[name].append(driven.get(name))
    finally:
        driven.close()
    differing = sum(int(np.sum(values[name] != np.array(other[name]))) for name in values)
    assert differing > 0
    assert max(relative_difference(values[n], other[n]) for n in ("piston_extension",)) < 1e-13


def test_libcosimpy_time_series_read_from_step_0_drops_the_last_sample(fmus):
    """The quirk run_libcosim works around (libcosimpy 0.0.6)."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    from libcosimpy.CosimEnums import CosimVariableType

    execution = CosimExecution.from_step_size(step_nanoseconds(0.01))
    slave = CosimLocalSlave(fmu_path=str(fmus["LoadProfile"]), instance_name="load")
    index = execution.add_local_slave(slave)
    reference = {v.name.decode(): v.reference for v in execution.slave_variables(index)}["load"]
    observer = CosimObserver.create_time_series()
    assert execution.add_observer(observer)
    assert observer.start_time_series(index, reference, CosimVariableType.REAL)
    assert execution.simulate_until(100_000_000)  # 10 steps
    time_points, step_numbers, _ = observer.time_series_real_samples(index, reference, 0, 11)
    assert step_numbers == list(range(10))  # step 10 (t = 0.1 s) is missing
    assert observer.time_series_real_samples(index, reference, 0, 1)[1] == []  # step 0 alone
    assert observer.time_series_real_samples(index, reference, 1, 10)[1] == list(range(1, 11))
    del execution
    times, values = run_libcosim(fmus["LoadProfile"], {}, {}, 0.01, 0.1, ["load"])
    assert len(times) == 11 and times[-1] == 0.1 and values["load"][-1] == 100.0


def test_a_discarded_step_is_a_libcosim_failure(fmus, capfd):
    """fmi2Discard (a NaN crank angle at the third step): libcosim's step() returns False,
    run_libcosim raises with the time, keeps the samples before it, the FMU's message is in
    libcosim's log, and the process goes on (the same FMU runs again afterwards)."""
    path = fmus["FourBar"]
    angle = lambda t: float("nan") if t > 0.025 else 0.5 + TWO_PI * t  # noqa: E731
    inputs = {"crank_angle": angle, "crank_speed": TWO_PI}
    capfd.readouterr()
    with pytest.raises(LibcosimError) as caught:
        run_libcosim(path, {}, inputs, 0.01, 0.1, ["rocker_angle"], instance="refused")
    error = caught.value
    assert "Step not complete" in str(error) and "refused" in str(error)
    assert error.time == pytest.approx(0.02, abs=1e-12)
    assert list(error.times) == pytest.approx([0.0, 0.01, 0.02], abs=1e-12)
    _, good = run_libcosim(
        path,
        {},
        {"crank_angle": lambda t: 0.5 + TWO_PI * t, "crank_speed": TWO_PI},
        0.01,
        0.02,
        ["rocker_angle"],
    )
    assert np.array_equal(error.values["rocker_angle"], good["rocker_angle"])
    log = capfd.readouterr()
    assert "refused at t = 0.03 s: crank_angle = nan rad is outside the valid range" in log.out

    fmpy_run = Driven(path, inputs={"crank_angle": 0.5, "crank_speed": TWO_PI})
    try:  # fmpy sees the same refusal
        assert "crank_angle = nan" in fmpy_run.step(0.01, crank_angle=float("nan"))
    finally:
        fmpy_run.close()


def test_a_discard_stops_simulate_until_where_it_happened(fmus, capfd):
    """A refusal in the middle of simulate_until (a dynamic snap-through with
    stop_on_snap_through, in the step from 0.59 s): False, the time, the samples before it."""
    parameters = {
        "dynamics": True,
        "damping": True,
        "damping_coefficient": 200.0,
        "input_interpolation": "hold",
        "stop_on_snap_through": True,
    }
    inputs = {"load": 2500.0, "road_height": 0.0, "road_rate": 0.0}
    capfd.readouterr()
    with pytest.raises(LibcosimError, match=r"simulate_until.*Step not complete") as caught:
        run_libcosim(fmus["Suspension"], parameters, inputs, 0.01, 1.5, ["deflection"])
    assert "left the near stable region" in capfd.readouterr().out
    error = caught.value
    assert error.time == pytest.approx(0.59, abs=1e-12) and len(error.times) == 60
    _, before = run_fmpy(fmus["Suspension"], parameters, inputs, 0.01, 0.59, ["deflection"])
    assert np.array_equal(error.values["deflection"], before["deflection"])
    assert np.ptp(before["deflection"]) > 0.5


def test_an_invalid_parameter_is_refused_before_libcosim_ends_the_process(fmus):
    # The FMU answers fmi2Error in fmi2ExitInitializationMode; libcosim 0.0.6 would end the
    # process (terminate after an uncaught cosim::error), so the FMU is asked first.
    with pytest.raises(LibcosimError) as caught:
        run_libcosim(
            fmus["PistonActuator"], {"stroke_time": 5.0}, {}, 0.01, 0.5, instance="too_slow"
        )
    message = str(caught.value)
    assert "initialisation refused at t = 0.0 s" in message and caught.value.time == 0.0
    assert "stroke_time = 5.0 s is outside the valid range" in message


def test_arguments_that_do_not_fit_libcosim_are_refused(fmus, tmp_path):
    with pytest.raises(FileNotFoundError):
        run_libcosim(tmp_path / "Missing.fmu", {}, {}, 0.01, 0.1)
    (tmp_path / "Broken.fmu").write_text("not a zip")
    with pytest.raises(LibcosimError, match="Not a zip archive"):  # libcosimpy would crash
        run_libcosim(tmp_path / "Broken.fmu", {}, {}, 0.01, 0.1)
    path = fmus["LoadProfile"]
    with pytest.raises(ValueError, match="whole number of nanoseconds"):
        run_libcosim(path, {}, {}, 1e-10, 1e-9)
    with pytest.raises(ValueError, match="whole number of steps"):
        run_libcosim(path, {}, {}, 0.01, 0.105)
    with pytest.raises(ValueError, match="no variable 'lode'"):
        run_libcosim(path, {"lode": 1.0}, {}, 0.01, 0.1)
    with pytest.raises(TypeError, match="shape is String"):
        run_libcosim(path, {"shape": 1.0}, {}, 0.01, 0.1)
