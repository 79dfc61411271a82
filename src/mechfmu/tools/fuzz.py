"""Fuzzing the FMUs through fmpy: random input sequences, each FMU in a child process.

``mechfmu fuzz [MODEL ...] --sequences 1000 --seed 0`` runs, for every FMU, that many
random sequences in one child process (so a crash of the FMU kills the child, not us, and is
reported as a failure with the sequence that caused it). One FMU instance serves a whole
child: fmi2Reset returns it to its initial state between sequences. A sequence is:

    reset (from the second on), setupExperiment, enterInitializationMode,
    random parameters, random start inputs, exitInitializationMode,
    1..MAX_STEPS steps with random inputs and step sizes, sometimes a get/set FMU state
    round trip, then the checks below.

Values are drawn from the model's declarations (start, min, max, accepted strings): mostly
plausible (a random walk from the start value), sometimes at or past a bound, sometimes
NaN, +-inf, 1e300, zero or negative step sizes, garbage strings.

Checked after every call (``Finding`` when violated):
- no crash, no hang (the parent's time limit), never fmi2Fatal;
- fmi2ExitInitializationMode answers OK, or fmi2Error with an error message (invalid
  parameters: the sequence ends there, refused at initialisation);
- a step with an illegal step size (zero, negative, not finite; the standard requires > 0)
  answers fmi2Error with an error message; restoring the FMU state saved before it (the
  standard's way out of the error state) gives back the outputs of before, and the sequence
  goes on; any other step answers OK or Discard;
- after an OK step every Real output is finite (no silent NaN);
- after a Discard the FMU logged an error message, and its outputs are unchanged;
- rolling back to a saved FMU state and repeating the steps gives identical outputs.

Each sequence is reproducible from (seed, FMU name, index): ``--only INDEX`` re-runs one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import json
import math
import random
import subprocess
import sys
import time
from typing import Any
from pathlib import Path

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from ..runtime.fmi.declarations import Variable

MAX_STEPS = 12
CHILD_TIME_LIMIT = 900.0  # s for one FMU's child process: past it, a hang
FUZZ_WALL_TIME = 1.0  # s, max_wall_time given to integrating FMUs (their hang guard)
_EXTREMES = (1e300, -1e300, 1e-300, -1e-300, 0.0)
_NON_FINITE = (math.nan, math.inf, -math.inf)


# --- what to vary, from the model's own declarations ------------------------------------------


def declarations(model_name: str, description: Any = None) -> dict[str, Variable]:
    """What to vary, by variable name: the model's Variable declarations
    (mechfmu.runtime.fmi.slave.Variable) for one of our models, else the same fields read from
    ``description`` (an fmpy ModelDescription): any FMU can be fuzzed."""
    from ..packaging.describe import model_class
    from ..runtime.models import MODELS

    if model_name in MODELS:
        return {v.name: v for v in model_class(model_name).VARIABLES}
    from ..runtime.fmi.slave import Variable

    kinds = {"Real": float, "Integer": int, "Boolean": bool, "String": str}
    declared = {}
    for v in description.modelVariables:
        if v.causality not in ("parameter", "input", "output") or v.type not in kinds:
            continue
        kind = kinds[v.type]
        start = (
            kind(v.start)
            if v.start is not None and kind is not bool
            else (str(v.start).lower() in ("true", "1") if kind is bool else kind())
        )
        bound = (
            (lambda text: None if text is None else kind(text))
            if kind in (int, float)
            else (lambda text: None)
        )
        declared[v.name] = Variable(
            v.name,
            kind,
            v.causality,
            start,
            v.description or "",
            min=bound(v.min),
            max=bound(v.max),
            nominal=bound(getattr(v, "nominal", None)) if kind is float else None,
        )
    return declared


def _scale(variable: Any):
    """A typical magnitude of a Real variable, for random walks: a quarter of its range, or
    its nominal value, or its start value, or 1."""
    if variable.min is not None and variable.max is not None:
        return max(abs(variable.max - variable.min), 1e-12) / 4
    if getattr(variable, "nominal", None):
        return abs(variable.nominal)
    return abs(variable.start) if variable.start else 1.0


def plausible(rng: Any, variable: Any, current: Any = None) -> Any:
    """A value that a reasonable user might give: near the current or start value."""
    kind, start = variable.kind, variable.start if current is None else current
    if kind is bool:  # switches stay as declared three times in four
        return start if rng.random() < 0.5 else rng.random() < 0.5
    if kind is int:
        return int(start) + rng.choice((-1, 0, 0, 1))
    if kind is str:
        return rng.choice(variable.values) if variable.values else start
    value = start + rng.gauss(0.0, 0.1) * _scale(variable)
    if variable.min is not None and value < variable.min:
        value = variable.min + (variable.min - value)
    if variable.max is not None and value > variable.max:
        value = variable.max - (value - variable.max)
    return value


def hostile(rng: Any, variable: Any) -> Any:
    """A value at or past a bound, an extreme or a non-finite one (a wrong type's worth)."""
    kind = variable.kind
    if kind is bool:
        return rng.random() < 0.5
    if kind is int:
        return rng.choice((0, -1, -(2**31), 2**31 - 1))
    if kind is str:
        return rng.choice(
            ("", "no such value", "\u00e9\u00e8 unicode", "x" * 300, "/nonexistent/file.csv")
        )
    candidates = list(_EXTREMES + _NON_FINITE)
    for bound in (variable.min, variable.max):
        if bound is not None:
            candidates += [
                bound,
                bound - 1e-9 * max(1.0, abs(bound)),
                bound + 1e-9 * max(1.0, abs(bound)),
            ]
    if variable.start:
        candidates += [-variable.start, 1e6 * variable.start]
    return rng.choice(candidates)


def step_size(rng: Any, typical: Any) -> Any:
    """Mostly within a decade below to 20x above ``typical`` (s), log-uniform; one step in
    twenty within two decades either side; one in twenty zero, negative, tiny, huge or not
    finite."""
    draw = rng.random()
    if draw < 0.9:
        return typical * 10.0 ** rng.uniform(-1.0, math.log10(20.0))
    if draw < 0.95:
        return typical * 10.0 ** rng.uniform(-2.0, 2.0)
    return rng.choice((0.0, -1e-3, math.nan, math.inf, -math.inf, 1e-300, 1e6))


def plan_sequence(rng: Any, variables: Any) -> Any:
    """One random sequence: parameters, start inputs, steps (size, inputs) and a rollback."""
    parameters, inputs = {}, {}
    hostile_parameters = rng.random() < 0.2
    for name, variable in variables.items():
        if name == "max_wall_time":  # the fuzz's own guard against slow steps, never varied
            parameters[name] = FUZZ_WALL_TIME
        elif variable.causality == "parameter":
            if hostile_parameters and rng.random() < 0.2:
                parameters[name] = hostile(rng, variable)
            elif rng.random() < 0.4:
                parameters[name] = plausible(rng, variable)
        elif variable.causality == "input":
            inputs[name] = plausible(rng, variable)
    # The step sizes follow the model's own time scale (its largest sub-step), so that a
    # thousand sequences of the stiffest model still run in a minute.
    typical = variables["max_substep"].start if "max_substep" in variables else 1e-3
    steps, current = [], dict(inputs)
    for _ in range(rng.randint(1, MAX_STEPS)):
        changed = {
            name: plausible(rng, variables[name], value)
            for name, value in current.items()
            if rng.random() < 0.7
        }
        if current and rng.random() < 0.15:  # one input at a bound, extreme or not finite
            name = rng.choice(sorted(current))
            changed[name] = hostile(rng, variables[name])
        current.update(
            (name, value)
            for name, value in changed.items()
            if not isinstance(value, float) or math.isfinite(value)
        )
        steps.append((step_size(rng, typical), changed))
    rollback = rng.randrange(len(steps)) if rng.random() < 0.3 else None
    return {"parameters": parameters, "inputs": inputs, "steps": steps, "rollback": rollback}


def sequence_rng(seed: int, model_name: str, index: int) -> Any:
    """The random generator of one sequence: reproducible from its three coordinates."""
    return random.Random(f"{seed}:{model_name}:{index}")


# --- the child: one FMU, many sequences -------------------------------------------------------


class Finding(Exception):
    """A violated invariant: the FMU misbehaved on this sequence."""


class Fuzzed:
    """One instantiated FMU under fmpy, driven sequence after sequence."""

    def __init__(self, path: Any, instance: str = "fuzzed") -> None:
        from fmpy import read_model_description
        from fmpy.fmi2 import FMU2Slave

        from ..cosim.fmu_file import unpack
        from ..cosim.master import LogBook

        self.description = read_model_description(str(path))
        self.variables = {v.name: v for v in self.description.modelVariables}
        self.outputs = [
            v
            for v in self.description.modelVariables
            if v.causality == "output" and v.type == "Real"
        ]
        self.output_refs = [v.valueReference for v in self.outputs]
        self.folder = unpack(path)
        self.logbook = LogBook()
        self.instance = instance
        self.slave = FMU2Slave(
            guid=self.description.guid,
            unzipDirectory=self.folder,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName=instance,
        )
        self.slave.instantiate(callbacks=self.logbook.callbacks, loggingOn=True)
        self.fresh = True

    def set(self, values: Any) -> None:
        for name, value in values.items():
            variable = self.variables[name]
            setter = getattr(self.slave, f"set{variable.type}")
            setter([variable.valueReference], [value])

    def read_outputs(self) -> Any:
        return self.slave.getReal(self.output_refs)

    def errors_logged(self) -> Any:
        return sum(1 for m in self.logbook.messages if m["status"] in ("error", "fatal"))

    def start(self, plan: Any) -> bool:
        """Initialise for ``plan``; False when fmi2ExitInitializationMode refused its
        parameters (fmi2Error with an error message)."""
        from fmpy.fmi1 import FMICallException

        if not self.fresh:
            self.slave.reset()
        self.fresh = False
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.set(plan["parameters"])
        self.set(plan["inputs"])
        errors_before = self.errors_logged()
        try:
            self.slave.exitInitializationMode()
        except FMICallException as error:
            if error.status != 3 or self.errors_logged() == errors_before:
                raise Finding(
                    f"exitInitializationMode returned status {error.status} ({error}); last "
                    f"log: {self.logbook.last_problem(self.instance)}"
                ) from None
            return False
        return True

    def refused_step(self, time_now: Any, size: Any) -> None:
        """A step with an illegal step size: fmi2Error with an error message, then the state
        saved before it restored (outputs as before)."""
        from fmpy.fmi1 import FMICallException

        state, outputs_before = self.slave.getFMUstate(), self.read_outputs()
        errors_before = self.errors_logged()
        try:
            self.slave.doStep(currentCommunicationPoint=time_now, communicationStepSize=size)
        except FMICallException as error:
            if error.status != 3 or self.errors_logged() == errors_before:
                raise Finding(
                    f"doStep(t = {time_now!r}, h = {size!r}) returned status {error.status}, "
                    "not fmi2Error with an error message"
                ) from None
        else:
            raise Finding(f"doStep(t = {time_now!r}, h = {size!r}) accepted an illegal step size")
        finally:
            self.slave.setFMUstate(state)
            self.slave.freeFMUstate(state)
        if self.read_outputs() != outputs_before:
            raise Finding("restoring the state saved before a refused step changed the outputs")

    def step(self, time_now: Any, size: Any, inputs: Any) -> Any:
        """Set inputs and step; True (OK), False (Discard with an error logged) or None (an
        illegal step size, refused with fmi2Error)."""
        from fmpy.fmi1 import FMICallException

        self.set(inputs)
        if not (math.isfinite(size) and size > 0.0):
            self.refused_step(time_now, size)
            return None
        errors_before, outputs_before = self.errors_logged(), self.read_outputs()
        try:
            self.slave.doStep(currentCommunicationPoint=time_now, communicationStepSize=size)
            ok = True
        except FMICallException as error:
            if error.status != 2:  # fmi2Discard is the only non-OK status we may return
                raise Finding(
                    f"doStep returned status {error.status} ({error}); last log: "
                    f"{self.logbook.last_problem(self.instance)}"
                ) from None
            if self.errors_logged() == errors_before:
                raise Finding(
                    f"doStep(t = {time_now!r}, h = {size!r}) discarded without "
                    "an error message in the log"
                ) from None
            ok = False
        outputs = self.read_outputs()
        if not ok and outputs != outputs_before:
            changed = [v.name for v, a, b in zip(self.outputs, outputs_before, outputs) if a != b]
            raise Finding(
                f"a discarded doStep(t = {time_now!r}, h = {size!r}) changed the "
                f"outputs {', '.join(changed[:5])}: it must leave the FMU as before"
            )
        bad = [v.name for v, x in zip(self.outputs, outputs) if not math.isfinite(x)]
        if bad:
            raise Finding(
                f"after {'an OK' if ok else 'a discarded'} doStep(t = {time_now!r}, "
                f"h = {size!r}) outputs are not finite: "
                + ", ".join(
                    f"{n} = {x!r}"
                    for n, x in zip([v.name for v in self.outputs], outputs)
                    if n in bad
                )
            )
        return ok

    def run(self, plan: Any) -> Any:
        """Run one sequence; return (ok steps, discarded steps, refused steps); None when
        its parameters were refused at initialisation."""
        if not self.start(plan):
            return None
        first_message = len(self.logbook.messages)
        now, done, discarded, refused, saved = 0.0, 0, 0, 0, None
        for index, (size, inputs) in enumerate(plan["steps"]):
            if index == plan["rollback"]:
                saved = (self.slave.getFMUstate(), now, index, self.read_outputs())
            outcome = self.step(now, size, inputs)
            if outcome:
                now += size
                done += 1
            elif outcome is None:
                refused += 1
            else:
                discarded += 1
        if saved is not None:
            try:
                self._replay(plan, saved, now)
            except Finding:
                if not self._timed_out(first_message):
                    raise
        return done, discarded, refused

    def _timed_out(self, first_message: Any):
        """Whether a step of this sequence (or of its repeat) hit its wall-clock bound: then
        the repeat may legitimately differ (the bound depends on the machine's load)."""
        return any("(max_wall_time)" in m["message"] for m in self.logbook.messages[first_message:])

    def _replay(self, plan: Any, saved: Any, end_time: Any):
        """Roll back to the saved state, repeat the steps from there: identical outputs."""
        state, now, first, outputs_then = saved
        final = self.read_outputs()
        self.slave.setFMUstate(state)
        self.slave.freeFMUstate(state)
        if self.read_outputs() != outputs_then:
            raise Finding(f"setFMUstate did not restore the outputs of step {first}")
        for size, inputs in plan["steps"][first:]:
            if self.step(now, size, inputs):
                now += size
        replayed = self.read_outputs()
        if replayed != final or now != end_time:
            diff = [(v.name, a, b) for v, a, b in zip(self.outputs, final, replayed) if a != b]
            raise Finding(f"rolled back to step {first} and repeated: outputs differ {diff[:3]}")

    def close(self) -> None:
        """Free the instance and remove the unpacked FMU."""
        import shutil

        try:
            self.slave.freeInstance()
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)


def child(
    path: Any, model_name: str, sequences: int, seed: int, progress: Any, only: Any = None
) -> Any:
    """Fuzz one FMU in this process; append a JSON line per event to ``progress``."""
    from fmpy.fmi1 import FMICallException

    fuzzed = Fuzzed(path)
    variables = declarations(model_name, fuzzed.description)
    indices = [only] if only is not None else range(sequences)
    totals: dict[str, Any] = {
        "sequences": 0,
        "refused_at_initialisation": 0,
        "steps_ok": 0,
        "steps_discarded": 0,
        "steps_refused": 0,
        "findings": [],
    }
    started = time.perf_counter()
    with open(progress, "a", buffering=1) as log:
        for index in indices:
            log.write(json.dumps({"sequence": index}) + "\n")  # so a crash names it
            plan = plan_sequence(sequence_rng(seed, model_name, index), variables)
            try:
                counts = fuzzed.run(plan)
            except (Finding, FMICallException) as finding:  # the latter: after a finding
                totals["findings"].append({"sequence": index, "message": str(finding)})
                fuzzed.fresh = False
                continue
            totals["sequences"] += 1
            if counts is None:
                totals["refused_at_initialisation"] += 1
                continue
            for key, count in zip(("steps_ok", "steps_discarded", "steps_refused"), counts):
                totals[key] += count
        fuzzed.close()
        totals["seconds"] = time.perf_counter() - started
        log.write(json.dumps({"done": totals}) + "\n")
    return totals


# --- the parent: one child per FMU --------------------------------------------------------------


def fuzz_model(
    model_name: str, fmu_dir: Any, sequences: int, seed: int, work_dir: Any, only: Any = None
) -> Any:
    """Run the child for one FMU; a summary dict with 'failure' set when it misbehaved."""
    path = Path(fmu_dir) / f"{model_name}.fmu"
    progress = Path(work_dir) / f"{model_name}.jsonl"
    progress.unlink(missing_ok=True)
    command = [
        sys.executable,
        "-m",
        "mechfmu.tools.fuzz",
        "--child",
        str(path),
        model_name,
        str(sequences),
        str(seed),
        str(progress),
    ]
    if only is not None:
        command.append(str(only))
    started = time.perf_counter()
    try:
        completed = subprocess.run(
            command, capture_output=True, text=True, timeout=CHILD_TIME_LIMIT
        )
        returncode, stderr = completed.returncode, completed.stderr
    except subprocess.TimeoutExpired:
        returncode, stderr = None, f"no answer after {CHILD_TIME_LIMIT:g} s (hang)"
    lines = (
        [json.loads(line) for line in progress.read_text().splitlines()]
        if progress.exists()
        else []
    )
    summary = next((line["done"] for line in lines if "done" in line), None)
    last = next((line["sequence"] for line in reversed(lines) if "sequence" in line), None)
    result = {
        "model": model_name,
        "seconds": time.perf_counter() - started,
        "returncode": returncode,
        "failure": None,
    }
    if summary is None or returncode != 0:
        how = (
            f"killed by signal {-returncode}"
            if returncode is not None and returncode < 0
            else f"exit code {returncode}"
            if returncode is not None
            else "hang"
        )
        result["failure"] = (
            f"{model_name}: the FMU's host process ended abnormally ({how}) "
            f"during sequence {last}; re-run with --only {last}. " + stderr.strip()[-2000:]
        )
        return result
    result.update(summary)
    if summary["findings"]:
        result["failure"] = "; ".join(
            f"{model_name} sequence {f['sequence']}: {f['message']}"
            for f in summary["findings"][:5]
        )
    return result


def fuzz(
    models: Any,
    fmu_dir: Any,
    sequences: int,
    seed: int,
    work_dir: Any,
    jobs: int = 2,
    only: Any = None,
) -> Any:
    """Fuzz ``models`` with up to ``jobs`` children at a time; a list of summaries."""
    from concurrent.futures import ThreadPoolExecutor

    Path(work_dir).mkdir(parents=True, exist_ok=True)
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(
            pool.map(
                lambda name: fuzz_model(name, fmu_dir, sequences, seed, work_dir, only), models
            )
        )


def command(args: Any) -> Any:
    """``mechfmu fuzz`` with the parsed command line ``args`` (options in mechfmu/cli.py);
    the exit status."""
    from ..runtime.models import MODELS

    results = fuzz(
        args.models or list(MODELS),
        args.fmu_dir,
        args.sequences,
        args.seed,
        args.out,
        args.jobs,
        args.only,
    )
    failed = 0
    for result in results:
        if result["failure"]:
            failed += 1
            print(f"FAIL {result['failure']}")
        else:
            print(
                f"ok   {result['model']}: {result['sequences']} sequences "
                f"({result['refused_at_initialisation']} refused at initialisation), "
                f"{result['steps_ok']} steps ok, {result['steps_discarded']} discarded "
                f"with an error message, {result['steps_refused']} illegal step sizes "
                f"refused with fmi2Error, {result['seconds']:.1f} s"
            )
    return 1 if failed else 0


if __name__ == "__main__":  # the child process that fuzz_model starts (never a user command)
    path, model_name, sequences, seed, progress = sys.argv[2:7]
    only = int(sys.argv[7]) if len(sys.argv) > 7 else None
    child(path, model_name, int(sequences), int(seed), progress, only)
