"""Run one FMU under libcosim, the C++ co-simulation library of the Open Simulation Platform,
through its Python wrapper libcosimpy (0.0.6; host side, needs ``pip install libcosimpy``).

    from mechfmu.tools.hosts.libcosim import run_libcosim
    times, values = run_libcosim("fmus/FourBar.fmu", {"solver": "constraint_solver"},
                                 {"crank_angle": lambda t: 0.5 + 6.283185307179586 * t,
                                  "crank_speed": 6.283185307179586},
                                 step=0.005, stop_time=1.0,
                                 outputs=["coupler_angle", "rocker_angle"])

What libcosim does differently from our master and from fmpy, and how this module meets it:

* **Time is an integer number of nanoseconds.** The step is ``round(step * 1e9)`` ns; a step
  that is not a whole number of nanoseconds, or a stop time that is not a whole number of
  steps, is refused rather than silently moved. libcosim converts each integer time point on
  its own, t_k = k * step_ns / 1e9 s (one correctly rounded division, not an accumulated
  sum), and hands the FMU the communication point t_k and the step size t_{k+1} - t_k, which
  differs from ``step`` in the last bits at some steps (found by driving the same FMU through
  fmpy with each candidate convention: only this one reproduces libcosim's outputs bit for
  bit). ``communication_points`` gives these t_k, for another host to be driven
  identically; the returned times are libcosim's observer time points, converted the same way.
* **Samples.** Outputs are recorded by a buffered time-series observer (Real and Integer
  variables only: libcosimpy 0.0.6 has no Boolean or String time series). Its
  ``time_series_real_samples`` trims the result by counting the step numbers equal to 0, so
  a read that includes step 0 (the values after initialisation, at t = 0) loses its LAST
  sample, and a read of step 0 alone returns nothing. Step 0 is therefore read on its own
  with room for two samples and steps 1..n in one read from step 1; the step numbers and
  time points returned are checked, so a change of that behaviour cannot shift the series.
* **Inputs.** A constant is set as an initial value (before the FMU leaves initialisation,
  like a parameter). A callable ``f(t)`` is set to ``f(0)`` the same way and then, through an
  override manipulator, to ``f(t_{k+1})`` before the step from t_k (the end-of-step value,
  what a Gauss-Seidel master gives a component fed by a source already advanced); with any
  callable input the execution advances one ``execution.step()`` at a time, otherwise in
  one ``simulate_until``.
* **Refusals.** When the FMU returns fmi2Discard libcosim does not crash: ``step()`` and
  ``simulate_until`` return False, the execution's state becomes ERROR (its ``error_code``
  stays SUCCESS), its time stays at the start of the refused step (a further ``step()`` would
  simply try again; ``run_libcosim`` stops at the first refusal), and
  ``cosim_last_error_message`` says only ``Simulation error: <instance>: Step not
  complete``. The FMU's own message goes to libcosim's log (stdout, level error, as
  ``[FMI status=error, category=logStatusError] <message>``); libcosimpy 0.0.6 offers no
  log callback, so ``LibcosimError`` carries libcosim's text and the time, not the FMU's.
* **Log level.** libcosimc's default output level prints FMI Library debug lines; the
  level is process-wide, and ``run_libcosim`` sets WARNING unless told otherwise.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import math
import os
import shutil
from numbers import Integral, Real

import numpy as np
from pathlib import Path

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from libcosimpy.CosimEnums import CosimVariableType
    from numpy import ndarray

NANOSECONDS_PER_SECOND = 1_000_000_000


class LibcosimError(RuntimeError):
    """libcosim refused a call or a step.

    ``time``: communication point (s) where the failed step started, or None before any
    step; ``times``, ``values``: the samples recorded up to there (possibly empty).
    """

    def __init__(
        self,
        message: str,
        time: float | None = None,
        times: ndarray | None = None,
        values: dict[str, ndarray] | None = None,
    ) -> None:
        super().__init__(message)
        self.time = time
        self.times = np.array([]) if times is None else times
        self.values = {} if values is None else values


def step_nanoseconds(step: float) -> int:
    """Communication step in integer nanoseconds; ValueError unless a whole, positive number."""
    step = float(step)
    if not (math.isfinite(step) and step > 0.0):
        raise ValueError(f"step = {step!r} s must be finite and > 0")
    step_ns = round(step * NANOSECONDS_PER_SECOND)
    if step_ns < 1 or abs(step * NANOSECONDS_PER_SECOND - step_ns) > 1e-6:
        raise ValueError(
            f"step = {step!r} s is not a whole number of nanoseconds "
            f"(libcosim keeps time as integer ns; nearest: {step_ns} ns)"
        )
    return step_ns


def step_count(step: float, stop_time: float) -> int:
    """Number of steps of ``step`` from 0 to ``stop_time``; ValueError unless whole."""
    step_ns = step_nanoseconds(step)
    stop = float(stop_time)
    if not (math.isfinite(stop) and stop > 0.0):
        raise ValueError(f"stop_time = {stop_time!r} s must be finite and > 0")
    count = round(stop * NANOSECONDS_PER_SECOND / step_ns)
    if abs(count * step_ns - stop * NANOSECONDS_PER_SECOND) > 1e-3:
        raise ValueError(
            f"stop_time = {stop_time!r} s is not a whole number of steps of {step_ns} ns"
        )
    return count


def communication_points(step: float, stop_time: float) -> list[float]:
    """[t_0, ..., t_n] in seconds exactly as libcosim passes them to an FMU.

    t_k = k * step_ns / 1e9 (a correctly rounded division of the integer time point); the
    step from t_k has the size t_{k+1} - t_k, computed in floating point like libcosim does.
    """
    step_ns = step_nanoseconds(step)
    return [k * step_ns / NANOSECONDS_PER_SECOND for k in range(step_count(step, stop_time) + 1)]


def _libcosimpy():
    """The libcosimpy modules used here (imported on first use)."""
    from libcosimpy import CosimEnums, CosimLogging
    from libcosimpy._internal import get_last_error_message
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    return (
        CosimEnums,
        CosimLogging,
        get_last_error_message,
        CosimExecution,
        CosimManipulator,
        CosimObserver,
        CosimLocalSlave,
    )


def _checked(name: str, kind: CosimVariableType, value: float) -> float:
    """``value`` converted for a variable of libcosim type ``kind`` (a CosimVariableType)."""
    kind = kind.name
    if kind == "REAL" and isinstance(value, Real) and not isinstance(value, bool):
        return float(value)
    if kind == "INTEGER" and isinstance(value, Integral) and not isinstance(value, bool):
        return int(value)
    if kind == "BOOLEAN" and isinstance(value, (bool, np.bool_)):
        return bool(value)
    if kind == "STRING" and isinstance(value, str):
        return value
    raise TypeError(f"{name} is {kind.capitalize()}, got {type(value).__name__} {value!r}")


def initialisation_problem(
    fmu_path: Path, values: dict[str, Any], instance: str = "fmu"
) -> str | None:
    """The FMU's own message when it refuses to leave initialisation with ``values``
    (parameters and initial inputs by name), or None when it accepts them.

    libcosim 0.0.6 ends the whole process when an FMU answers fmi2Error in
    fmi2ExitInitializationMode (its initialisation thread throws a cosim::error nobody
    catches: "terminate called after throwing ..."), as our FMUs do for invalid parameters;
    run_libcosim therefore asks the FMU through fmpy first.
    """
    from fmpy import read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    from ...cosim.fmu_file import unpack
    from ...cosim.master import LogBook, accessor

    description = read_model_description(str(fmu_path))
    variables = {v.name: v for v in description.modelVariables}
    logbook = LogBook()
    slave = FMU2Slave(
        guid=description.guid,
        unzipDirectory=str(unpack(fmu_path)),
        modelIdentifier=description.coSimulation.modelIdentifier,
        instanceName=instance,
    )
    slave.instantiate(callbacks=logbook.callbacks, loggingOn=True)
    try:
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        for name, value in values.items():
            if name in variables:
                variable = variables[name]
                accessor(slave, variable.type, "set")([variable.valueReference], [value])
        slave.exitInitializationMode()
        return None
    except FMICallException as error:
        return f"{logbook.last_problem(instance)} [{error}]"
    finally:
        slave.freeInstance()
        shutil.rmtree(slave.unzipDirectory, ignore_errors=True)


def run_libcosim(
    fmu_path: Path,
    parameters: dict[str, Any] | None = None,
    inputs: dict[str, Any] | None = None,
    step: float = 0.01,
    stop_time: float = 1.0,
    outputs: list[str] | None = None,
    instance: str = "fmu",
    log_level: str = "WARNING",
) -> tuple[ndarray, dict[str, ndarray]]:
    """Run the FMU at ``fmu_path`` alone under libcosim from t = 0 to ``stop_time``.

    parameters: {name: value} set as initial values (Real, Integer, Boolean or String).
    inputs: {name: value or callable f(t)}; a value is held, a callable is evaluated at 0
        (initial value) and at the end of every step, see the module's notes.
    outputs: names of Real or Integer variables to record (default: every Real and Integer
        output).
    log_level: libcosim's log output level (a CosimLogLevel name; process-wide) or None
        to leave it; the FMU's warnings and errors are logged at WARNING and ERROR.

    Returns (times, {name: values}): numpy arrays over t_0 = 0, ..., t_n = stop_time
    (floats for Real, ints for Integer). Raises LibcosimError when libcosim refuses the FMU,
    a value or a step (an fmi2Discard of the FMU included), ValueError/TypeError for
    arguments that do not match the FMU.
    """
    (
        CosimEnums,
        CosimLogging,
        last_error,
        CosimExecution,
        CosimManipulator,
        CosimObserver,
        CosimLocalSlave,
    ) = _libcosimpy()
    Kind, Causality = CosimEnums.CosimVariableType, CosimEnums.CosimVariableCausality
    parameters, inputs = dict(parameters or {}), dict(inputs or {})
    step_ns = step_nanoseconds(step)
    count = step_count(step, stop_time)
    if log_level is not None:
        CosimLogging.log_output_level(CosimLogging.CosimLogLevel[str(log_level).upper()])

    if not os.path.isfile(fmu_path):
        raise FileNotFoundError(f"FMU {fmu_path} not found")
    execution = CosimExecution.from_step_size(step_ns)
    slave = CosimLocalSlave(fmu_path=str(fmu_path), instance_name=instance)
    if not slave.ptr():  # libcosimpy would hand libcosim the null pointer: a crash
        raise LibcosimError(f"libcosim cannot load {fmu_path}: {last_error()}")
    index = execution.add_local_slave(slave)
    if index < 0:
        raise LibcosimError(f"libcosim cannot load {fmu_path}: {last_error()}")
    variables = {v.name.decode(): v for v in execution.slave_variables(index)}

    def variable(name: str, causalities: Any, role: Any):
        if name not in variables:
            raise ValueError(
                f"{fmu_path} has no variable {name!r}; its {role}s: "
                + ", ".join(
                    n for n, v in variables.items() if Causality(v.causality) in causalities
                )
            )
        found = variables[name]
        if Causality(found.causality) not in causalities:
            raise ValueError(f"{name} is a {Causality(found.causality).name.lower()}, not a {role}")
        return found, Kind(found.type)

    setters = {
        "REAL": "real_initial_value",
        "INTEGER": "integer_initial_value",
        "BOOLEAN": "boolean_initial_value",
        "STRING": "string_initial_value",
    }

    def set_initial(name: str, causalities: Any, role: Any, value: Any):
        found, kind = variable(name, causalities, role)
        value = _checked(name, kind, value)
        if not getattr(execution, setters[kind.name])(index, found.reference, value):
            raise LibcosimError(f"libcosim refused {name} = {value!r}: {last_error()}")

    for name, value in parameters.items():
        set_initial(name, (Causality.PARAMETER,), "parameter", value)
    varying = {}
    for name, value in inputs.items():
        if callable(value):
            varying[name] = (value, *variable(name, (Causality.INPUT,), "input"))
            value = value(0.0)
        set_initial(name, (Causality.INPUT,), "input", value)

    if outputs is None:
        outputs = [
            n
            for n, v in variables.items()
            if Causality(v.causality) is Causality.OUTPUT
            and Kind(v.type) in (Kind.REAL, Kind.INTEGER)
        ]
    recorded = {}
    for name in outputs:
        if name not in variables:
            raise ValueError(f"{fmu_path} has no variable {name!r}")
        kind = Kind(variables[name].type)
        if kind not in (Kind.REAL, Kind.INTEGER):
            raise ValueError(
                f"{name} is {kind.name.capitalize()}: libcosimpy 0.0.6 records "
                "only Real and Integer time series"
            )
        recorded[name] = (variables[name].reference, kind)

    observer = CosimObserver.create_time_series(buffer_size=count + 2)
    if not execution.add_observer(observer):
        raise LibcosimError(f"libcosim refused the observer: {last_error()}")
    for name, (reference, kind) in recorded.items():
        if not observer.start_time_series(index, reference, kind):
            raise LibcosimError(f"libcosim cannot observe {name}: {last_error()}")
    manipulator = None
    if varying:
        manipulator = CosimManipulator.create_override()
        if not execution.add_manipulator(manipulator):
            raise LibcosimError(f"libcosim refused the manipulator: {last_error()}")
    overriders = {
        "REAL": "slave_real_values",
        "INTEGER": "slave_integer_values",
        "BOOLEAN": "slave_boolean_values",
        "STRING": "slave_string_values",
    }

    def samples(steps_done: Any):
        """(times, values) of steps 0 .. steps_done, checked against the ns grid."""
        values = {}
        times_ns = None
        for name, (reference, kind) in recorded.items():
            read = (
                observer.time_series_real_samples
                if kind is Kind.REAL
                else observer.time_series_integer_samples
            )
            # Step 0 alone: the wrapper's trimming (count of step numbers equal to 0) drops
            # one sample of any read that includes step 0; with room for two, step 0 stays.
            first = read(index, reference, 0, 2)
            rest = read(index, reference, 1, steps_done) if steps_done else ([], [], [])
            time_points = list(first[0][:1]) + list(rest[0])
            step_numbers = list(first[1][:1]) + list(rest[1])
            if step_numbers != list(range(steps_done + 1)):
                raise LibcosimError(
                    f"libcosim's observer returned steps {step_numbers[:3]}"
                    f"...{step_numbers[-3:]} of {name}, expected 0..{steps_done}"
                )
            if times_ns is None:
                times_ns = time_points
                if times_ns != [k * step_ns for k in range(steps_done + 1)]:
                    raise LibcosimError(
                        f"libcosim's time points of {name} are not the {step_ns} ns grid"
                    )
            values[name] = np.array(
                list(first[2][:1]) + list(rest[2]), dtype=float if kind is Kind.REAL else int
            )
        times = np.array([t / NANOSECONDS_PER_SECOND for t in (times_ns or [])])
        return times, values

    def failure(what: str, steps_done: Any):
        message = (
            f"libcosim: {what} failed at t = {steps_done * step_ns / 1e9!r} s: "
            f"{last_error().strip()} (the FMU's own message is in libcosim's log)"
        )
        try:
            times, values = samples(steps_done)
        except Exception:  # nothing recorded yet (e.g. refused at the first step)
            times, values = None, None
        return LibcosimError(message, steps_done * step_ns / NANOSECONDS_PER_SECOND, times, values)

    initial = {
        **parameters,
        **{name: value(0.0) if callable(value) else value for name, value in inputs.items()},
    }
    problem = initialisation_problem(fmu_path, initial, instance)
    if problem is not None:
        raise LibcosimError(
            f"libcosim: initialisation refused at t = 0.0 s: {problem} (found before "
            "libcosim ran: libcosim 0.0.6 ends the process when an FMU refuses to leave "
            "initialisation)",
            0.0,
        )
    try:
        if not varying:
            if not execution.simulate_until(count * step_ns):
                done = execution.status().current_time // step_ns
                raise failure(f"simulate_until({count * step_ns} ns)", done)
        else:
            for k in range(count):
                t_end = (k + 1) * step_ns / NANOSECONDS_PER_SECOND
                for name, (function, found, kind) in varying.items():
                    value = _checked(name, kind, function(t_end))
                    if not getattr(manipulator, overriders[kind.name])(
                        index, [found.reference], [value]
                    ):
                        raise LibcosimError(
                            f"libcosim refused {name} = {value!r} at "
                            f"t = {t_end!r} s: {last_error()}"
                        )
                if not execution.step():
                    raise failure(f"the step from t = {k * step_ns / 1e9!r} s", k)
                if execution.status().current_time != (k + 1) * step_ns:
                    raise LibcosimError(
                        f"libcosim's time {execution.status().current_time} ns "
                        f"after step {k + 1}, expected {(k + 1) * step_ns} ns"
                    )
        return samples(count)
    finally:
        # The execution owns the instance; destroy it first, then the objects it used (the
        # names are rebound, not deleted: the closures above still refer to them).
        execution = None
        manipulator = observer = slave = None
