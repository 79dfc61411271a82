"""Hard use of the FMUs through fmpy: fuzzing, reset, several instances, FMU state,
discarded steps, bounds on time, and what a failed run keeps.

The fuzz runs every FMU in a child process (mechfmu.tools.fuzz), so a crash is a failure here
rather than the end of the test session.
"""

import json
import math
import os
import textwrap
import time

import pytest
from fmpy.fmi1 import FMICallException

from fmu_driver import Driven
from mechfmu.tools import fuzz
from mechfmu.runtime.models import MODELS
from cli_process import run_mechfmu

SEQUENCES = int(os.environ.get("MECHFMU_FUZZ_SEQUENCES", "250"))  # make fuzz-inputs: 1000


def _has_real_inputs(model):
    return any(
        v.causality == "input" and v.kind is float for v in fuzz.declarations(model).values()
    )


DRIVEN = [m for m in MODELS if _has_real_inputs(m)]
SOURCES = [m for m in MODELS if not _has_real_inputs(m)]


def test_every_fmu_survives_random_input_sequences(fmu_dir, tmp_path):
    # The slowest first, so that the two children finish together.
    slowest = ("ValveSpring", "ValveTrain", "HydraulicActuator")
    models = sorted(MODELS, key=lambda name: name not in slowest)
    results = fuzz.fuzz(models, fmu_dir, SEQUENCES, seed=20261121, work_dir=tmp_path, jobs=2)
    failures = [r["failure"] for r in results if r["failure"]]
    assert not failures, "\n".join(failures)
    for result in results:
        assert result["returncode"] == 0 and result["sequences"] == SEQUENCES, result
        # The sequences reach the models' working ranges, not only their refusals...
        assert result["steps_ok"] > 2 * SEQUENCES, result
        # ...and their refusals: each discard came with an error message (checked per step),
        # illegal step sizes were refused with fmi2Error, hostile parameters at initialisation.
        refusals = result["steps_discarded"] + result["refused_at_initialisation"]
        assert refusals > SEQUENCES / 20 and result["steps_refused"] > SEQUENCES / 20, result


PROBE = textwrap.dedent('''
    import math
    import os

    from pythonfmu import Fmi2Causality, Fmi2Slave, Real
    from pythonfmu.enums import Fmi2Status


    class Probe(Fmi2Slave):
        """y follows u; misbehaves as PROBE_MODE says once |u| > 0.3."""

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.u = 0.0
            self.y = 0.0
            self.register_variable(Real("u", causality=Fmi2Causality.input))
            self.register_variable(Real("y", causality=Fmi2Causality.output))

        def do_step(self, current_time, step_size):
            mode = os.environ.get("PROBE_MODE", "none")
            if not (math.isfinite(self.u) and math.isfinite(step_size) and step_size > 0):
                self.log(f"refused u = {self.u!r}, h = {step_size!r}", Fmi2Status.error)
                return False
            if abs(self.u) > 0.3 and mode != "none":
                if mode == "nan":
                    self.y = math.nan
                    return True
                if mode == "silent":
                    return False
                if mode == "raise":
                    raise RuntimeError("probe raised")
                os.abort()
            self.y = self.u
            return True
''')


@pytest.fixture(scope="module")
def probe_dir(tmp_path_factory):
    """The probe as our FMUs are built: pythonfmu's library behind the C loader."""
    from pythonfmu import FmuBuilder

    from mechfmu.packaging import build

    folder = tmp_path_factory.mktemp("probe")
    script = folder / "probe_entry.py"
    script.write_text(PROBE)
    built = FmuBuilder.build_FMU(script, dest=folder / "plain")
    loader = build.compile_loader(folder / "loader")
    assert loader[0] is not None, loader[1]
    fmu = build._rewrite_fmu(built, "Probe", loader, 2, {}, folder / "link")
    (folder / "Probe.fmu").write_bytes(fmu)
    return folder


@pytest.mark.parametrize(
    "mode, words",
    [
        ("none", None),
        ("nan", ["outputs are not finite: y = nan"]),
        ("silent", ["discarded without an error message"]),
        # fmi2Fatal from pythonfmu; the loader forwards nothing after it (without the loader
        # the host's next call died of a segmentation fault)
        ("raise", ["doStep returned status 4", "Fatal py exception"]),
        ("abort", ["ended abnormally (killed by signal 6)", "re-run with --only"]),
    ],
)
def test_the_fuzz_harness_catches_crashes_nan_and_silent_discards(
    probe_dir, tmp_path, monkeypatch, mode, words
):
    monkeypatch.setenv("PROBE_MODE", mode)
    result = fuzz.fuzz_model("Probe", probe_dir, 40, seed=1, work_dir=tmp_path)
    if words is None:
        assert result["failure"] is None and result["sequences"] == 40, result
        assert result["steps_ok"] > 40 and result["steps_discarded"] > 0
    else:
        for word in words:
            assert word in result["failure"], result["failure"]


def test_fuzz_command_reproduces_one_sequence(fmu_dir, tmp_path):
    out = run_mechfmu(
        "fuzz", "CrankDrive", "--only", "7", "--fmus", str(fmu_dir), "--out", str(tmp_path)
    )
    assert out.returncode == 0, out.stdout + out.stderr
    assert "ok   CrankDrive: 1 sequences" in out.stdout
    lines = (tmp_path / "CrankDrive.jsonl").read_text().splitlines()
    assert json.loads(lines[0]) == {"sequence": 7}


# --- reset, several instances, FMU state ------------------------------------------------------


def _plausible_plan(model, index, steps=8):
    """A reproducible sequence of plausible inputs and ordinary step sizes."""
    variables = fuzz.declarations(model)
    rng = fuzz.sequence_rng("plausible", model, index)
    typical = variables["max_substep"].start if "max_substep" in variables else 1e-3
    inputs = {n: v.start for n, v in variables.items() if v.causality == "input"}
    plan = []
    for _ in range(steps):
        inputs = {
            n: fuzz.plausible(rng, variables[n], value) if isinstance(value, float) else value
            for n, value in inputs.items()
        }
        plan.append((typical * rng.uniform(0.5, 5.0), dict(inputs)))
    return {"parameters": {}, "inputs": {}, "steps": plan, "rollback": None}


def _outputs_along(fuzzed, plan):
    fuzzed.start(plan)
    trace, now = [fuzzed.read_outputs()], 0.0
    for size, inputs in plan["steps"]:
        ok = fuzzed.step(now, size, inputs)
        now += size if ok else 0.0
        trace.append((ok, fuzzed.read_outputs()))
    return trace


@pytest.mark.parametrize("model", MODELS)
def test_reset_returns_the_instance_to_its_initial_state(fmu_dir, model):
    plan, other = _plausible_plan(model, 0), _plausible_plan(model, 1)
    fresh = fuzz.Fuzzed(fmu_dir / f"{model}.fmu")
    expected = _outputs_along(fresh, plan)
    fresh.close()
    reused = fuzz.Fuzzed(fmu_dir / f"{model}.fmu")
    # A run with other parameters and inputs first, then fmi2Reset (done by start()).
    _outputs_along(reused, dict(other, parameters=_changed_parameters(model)))
    assert _outputs_along(reused, plan) == expected
    assert sum(ok for ok, _ in expected[1:]) >= 1  # the plan steps, not only refuses
    reused.close()


def _changed_parameters(model):
    """Every Real parameter that has a nonzero start moved by 10 %."""
    return {
        n: v.start * 1.1
        for n, v in fuzz.declarations(model).items()
        if v.causality == "parameter" and v.kind is float and v.start and n != "max_wall_time"
    }


@pytest.mark.parametrize("model", MODELS)
def test_instances_of_one_fmu_in_one_process_share_nothing(fmu_dir, model):
    plans = [_plausible_plan(model, 2), _plausible_plan(model, 3)]
    alone = []
    for plan in plans:
        fuzzed = fuzz.Fuzzed(fmu_dir / f"{model}.fmu")
        alone.append(_outputs_along(fuzzed, plan))
        fuzzed.close()
    first = fuzz.Fuzzed(fmu_dir / f"{model}.fmu", instance="first")
    second = fuzz.Fuzzed(fmu_dir / f"{model}.fmu", instance="second")
    together = [[], []]
    for fuzzed, plan, trace in zip((first, second), plans, together):
        fuzzed.start(plan)
        trace.append(fuzzed.read_outputs())
    clocks = [0.0, 0.0]
    for index in range(len(plans[0]["steps"])):  # interleaved step by step
        for k, fuzzed in enumerate((first, second)):
            size, inputs = plans[k]["steps"][index]
            ok = fuzzed.step(clocks[k], size, inputs)
            clocks[k] += size if ok else 0.0
            together[k].append((ok, fuzzed.read_outputs()))
    assert together == alone
    first.close()
    second.close()


@pytest.mark.parametrize("model", MODELS)
def test_fmu_state_round_trip_covers_every_internal_state(fmu_dir, model):
    """Save the state, step on, roll back, step again: identical outputs, bit for bit."""
    plan = dict(_plausible_plan(model, 4, steps=10), rollback=3)
    fuzzed = fuzz.Fuzzed(fmu_dir / f"{model}.fmu")
    done, discarded, _ = fuzzed.run(plan)  # run() rolls back to step 3, compares (Finding)
    assert done >= 4, f"{model}: only {done} steps succeeded ({discarded} discarded)"
    fuzzed.close()


# --- discarded steps and bounds ---------------------------------------------------------------


@pytest.mark.parametrize("model", DRIVEN)
def test_a_discarded_step_leaves_the_instance_as_before(fmu_dir, model):
    """A step refused half-way (a NaN input) must not advance anything: the run that
    continues after it equals the run that never had it."""
    plan = _plausible_plan(model, 5, steps=6)
    clean = fuzz.Fuzzed(fmu_dir / f"{model}.fmu")
    expected = _outputs_along(clean, plan)
    clean.close()
    name = sorted(
        n for n, v in fuzz.declarations(model).items() if v.causality == "input" and v.kind is float
    )
    fuzzed = fuzz.Fuzzed(fmu_dir / f"{model}.fmu")
    fuzzed.start(plan)
    now, trace = 0.0, [fuzzed.read_outputs()]
    for index, (size, inputs) in enumerate(plan["steps"]):
        if index == 3:
            spoiled = dict(inputs, **{name[0]: math.nan})
            assert fuzzed.step(now, size, spoiled) is False
            assert f"{name[0]} = nan" in fuzzed.logbook.messages[-1]["message"]
            assert "(must be finite)" in fuzzed.logbook.messages[-1]["message"]
        ok = fuzzed.step(now, size, inputs)
        now += size if ok else 0.0
        trace.append((ok, fuzzed.read_outputs()))
    assert trace == expected
    fuzzed.close()


@pytest.mark.parametrize("model", SOURCES)
def test_sources_without_inputs_refuse_a_bad_step_and_go_on(fmu_dir, model):
    # The standard requires a step size > 0: fmi2Error, and the instance in the error state,
    # which restoring a state saved before leaves (its outputs as before).
    driven = Driven(fmu_dir / f"{model}.fmu")
    state, outputs = driven.slave.getFMUstate(), driven.outputs()
    outcome = driven.step(math.nan)
    assert "communicationStepSize = nan s" in outcome and "must be > 0" in outcome, outcome
    assert "status 3" in outcome
    assert "not allowed in state error" in driven.step(0.01)
    driven.slave.setFMUstate(state)
    assert driven.outputs() == outputs
    assert driven.step(0.01) is True
    driven.close()


def test_do_step_before_initialisation_is_refused(fmu_dir):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from mechfmu.cosim.master import LogBook

    path = fmu_dir / "LandingGear.fmu"
    description = read_model_description(str(path))
    logbook = LogBook()
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=extract(str(path)),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName="early",
    )
    slave.instantiate(callbacks=logbook.callbacks, loggingOn=True)
    with pytest.raises(FMICallException, match="error"):
        slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.1)
    assert "fmi2DoStep is not allowed in state instantiated" in logbook.last_problem("early")
    slave.reset()  # out of the error state: initialise and step
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.1)
    slave.terminate()
    slave.freeInstance()


def test_a_step_past_its_wall_clock_bound_is_discarded_and_the_instance_goes_on(fmu_dir):
    driven = Driven(
        fmu_dir / "ValveSpring.fmu",
        parameters={"max_wall_time": 0.05},
        inputs={"rocker_lift": 1e-3},
    )
    before = driven.get("valve_lift")
    started = time.perf_counter()
    message = driven.step(1.0)  # 50 000 sub-steps of 2e-5 s: far more than 0.05 s of work
    elapsed = time.perf_counter() - started
    assert "wall-clock bound of 0.05 s (max_wall_time)" in message, message
    assert elapsed < 1.0 and driven.get("valve_lift") == before
    assert driven.step(1e-4) is True
    driven.close()


def test_a_step_needing_more_sub_steps_than_the_bound_is_refused_at_once(fmu_dir):
    driven = Driven(
        fmu_dir / "Suspension.fmu",
        parameters={"dynamics": True, "integrator": "rk4", "max_substep": 1e-6},
    )
    started = time.perf_counter()
    message = driven.step(10.0)
    assert "needs at least 1e+07 sub-steps" in message, message
    assert time.perf_counter() - started < 0.5
    driven.close()


# --- what a failed run keeps -----------------------------------------------------------------

_FAILING_SCENE = textwrap.dedent(f"""
    # The piston is driven past its stroke: it leaves the gear's assembly range near 2.8 s.
    name = "failing"
    stop_time = 3.0
    step = 0.1
    record = ["gear.gear_angle"]
    connections = [
        "actuator.piston_extension -> gear.piston_extension",
        "actuator.piston_speed -> gear.piston_speed",
        "actuator.piston_acceleration -> gear.piston_acceleration",
    ]
    [components.actuator]
    fmu = "PistonActuator"
    parameters = {{ end_extension = {2.1 * 0.3048!r} }}
    [components.gear]
    fmu = "LandingGear"
    inputs = {{ piston_force = 0.0, valve_command = 0.0, airspeed = 0.0 }}
""")


def test_a_failed_run_exits_non_zero_naming_component_time_and_message(fmu_dir, tmp_path):
    scene = tmp_path / "failing.toml"
    scene.write_text(_FAILING_SCENE)
    out = run_mechfmu(
        "run", str(scene), "--out", str(tmp_path), "--fmu-dir", str(fmu_dir), "--no-plot"
    )
    assert out.returncode == 1, out.stdout + out.stderr
    assert "simulation failed: component 'gear' failed at t = 2." in out.stderr, out.stderr
    assert "piston_extension" in out.stderr and "assembly range" in out.stderr
    assert "partial csv:" in out.stderr and (tmp_path / "failing.partial.csv").is_file()
    meta = json.loads((tmp_path / "failing.partial.json").read_text())
    assert meta["partial"] is True and meta["failed_component"] == "gear"
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "failing.partial.csv",
        "failing.partial.json",
        "failing.toml",
    ]


def test_a_failed_run_frees_every_instance(fmu_dir, tmp_path, monkeypatch):
    from fmpy.fmi2 import FMU2Slave

    from mechfmu.cosim.master import SimulationError
    from mechfmu.cosim.run import run_scene

    freed = []
    original = FMU2Slave.freeInstance

    def counted(self):
        freed.append(self.instanceName)
        return original(self)

    monkeypatch.setattr(FMU2Slave, "freeInstance", counted)
    scene = tmp_path / "failing.toml"
    scene.write_text(_FAILING_SCENE)
    with pytest.raises(SimulationError):
        run_scene(scene, tmp_path, fmu_dir, plot=False)
    assert sorted(freed) == ["actuator", "gear"]


@pytest.mark.parametrize("value", [0.0, -1.0])  # NaN: refused at initialisation (below)
def test_an_invalid_wall_clock_bound_is_named(fmu_dir, value):
    driven = Driven(
        fmu_dir / "Suspension.fmu", parameters={"dynamics": True, "max_wall_time": value}
    )
    message = driven.step(0.01)
    assert f"max_wall_time = {value!r} s is outside the valid range (0, inf] s" in message
    driven.close()


def test_an_integrating_fmu_refuses_a_step_that_does_not_continue_its_time(fmu_dir):
    driven = Driven(
        fmu_dir / "Suspension.fmu", parameters={"dynamics": True}, inputs={"load": 1000.0}
    )
    assert driven.step(0.01) is True
    before = driven.get("deflection")
    driven.time = 0.02  # the host skips 10 ms
    message = driven.step(0.01)
    assert (
        "doStep from t = 0.02 s, but this instance's state is at t = 0.01 s" in message
        and driven.get("deflection") == before
    ), message
    driven.time = 0.01
    assert driven.step(0.01) is True
    driven.close()


@pytest.mark.parametrize("model", MODELS)
def test_a_nan_parameter_is_refused_at_initialisation_even_where_unused(fmu_dir, model):
    # the defaults' configuration of each model (the kinematic gear, the suspension without
    # dynamics, the valve's exact integrator...) accepted NaN for the parameters it does not
    # use: 51 of them over six models
    parameters = [
        v.name
        for v in fuzz.declarations(model).values()
        if v.causality == "parameter" and v.kind is float
    ]
    assert parameters
    for name in parameters:
        driven = Driven(fmu_dir / f"{model}.fmu", parameters={name: math.nan})
        try:
            assert driven.init_error is not None, name
            assert f"{name} = nan" in driven.init_error and "status 3" in driven.init_error
        finally:
            driven.close()
