"""Our FMUs at the FMI boundary: random call sequences against the standards' state machines.

Hypothesis draws sequences of FMI calls (life cycle, steps of legal and illegal sizes, gets
and sets of every variable under every type and of unknown value references, FMU states saved,
restored, freed, serialised, damaged, and a pointer no FMU returned); a worker process
(tests/boundary_worker.py) runs each sequence on a fresh instance through fmpy's FMU2Slave or
FMU3Slave, and the statuses must be those of a model of the standard's state machine (FMI 2.0
section 4.2.4, FMI 3.0 sections 2.3 and 4.2; docs/other-tools/fmi_boundary.md lists the rules
and the deliberate deviations). A crash kills the worker, not pytest: the test then fails with
the signal and the sequence. Every model, FMI 2.0 and 3.0.

``make test`` runs EXAMPLES sequences per model and version (derandomised: the same ones every
time); ``make boundary`` runs many more, freshly random (MECHFMU_BOUNDARY_EXAMPLES).
"""

import json
import os
import signal
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from fmpy import read_model_description
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mechfmu.runtime.models import MODELS

WORKER = Path(__file__).with_name("boundary_worker.py")
LONG = "MECHFMU_BOUNDARY_EXAMPLES" in os.environ
EXAMPLES = int(os.environ.get("MECHFMU_BOUNDARY_EXAMPLES", "6"))
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
TYPES = {2: ("Real", "Integer", "Boolean", "String"), 3: ("Float64", "Int32", "Boolean", "String")}
ERROR_STATE = {2: "error", 3: "terminated"}  # where an error status leaves an instance
STEPPING = {2: "stepComplete", 3: "stepMode"}
ANY = frozenset(
    {"instantiated", "initialization", "stepComplete", "stepMode", "terminated", "error"}
)
# The allowed states of each call (FMI 2.0 table of section 4.2.4; FMI 3.0 sections 2.3, 4.2).
ALLOWED = {
    2: {
        "setup": {"instantiated"},
        "enter": {"instantiated"},
        "exit": {"initialization"},
        "terminate": {"stepComplete"},
        "step": {"stepComplete"},
        "get": {"initialization", "stepComplete", "terminated", "error"},
        "set": {"instantiated", "initialization", "stepComplete"},
        "time": {"stepComplete", "terminated"},
    },
    3: {
        "enter": {"instantiated"},
        "exit": {"initialization"},
        "terminate": {"stepMode"},
        "step": {"stepMode"},
        "get": {"instantiated", "initialization", "stepMode", "terminated"},
        "set": {"instantiated", "initialization", "stepMode"},
        "time": set(),  # fmi3EnterEventMode: these FMUs have no event mode
    },
}


class Worker:
    """The worker process; started again when a sequence killed it."""

    def __init__(self, log):
        self.process, self.log = None, log

    def run(self, fmu, calls):
        if self.process is None or self.process.poll() is not None:
            self.process = subprocess.Popen(
                [sys.executable, str(WORKER)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=self.log.open("a"),
                text=True,
            )
        self.process.stdin.write(json.dumps({"fmu": str(fmu), "calls": calls}) + "\n")
        self.process.stdin.flush()
        answer = self.process.stdout.readline()
        if not answer:
            code = self.process.wait()
            how = f"signal {signal.Signals(-code).name}" if code < 0 else f"exit code {code}"
            tail = self.log.read_text()[-1500:]
            raise AssertionError(f"the host process died ({how}) during {calls}; its log: {tail}")
        return json.loads(answer)

    def close(self):
        if self.process is not None and self.process.poll() is None:
            self.process.stdin.close()
            self.process.wait(timeout=60)


@pytest.fixture(scope="module")
def worker(tmp_path_factory):
    process = Worker(tmp_path_factory.mktemp("boundary") / "worker.log")
    yield process
    process.close()


@dataclass
class Variable:
    type: str
    causality: str
    variability: str
    initial: str | None


def variables_of(fmu):
    """Value reference -> Variable, with the standards' default ``initial``."""
    table = {}
    for v in read_model_description(str(fmu)).modelVariables:
        initial = v.initial
        if initial is None and v.causality == "parameter":
            initial = "exact"
        elif initial is None and v.causality == "output":
            initial = "calculated"
        table[v.valueReference] = Variable(v.type, v.causality, v.variability, initial)
    return table


def settable(variable, state):
    """Whether the standards let a host set ``variable`` in ``state`` (inputs in the
    instantiated state: FMI 3.0 says so, FMI 2.0 only for variables with initial; fmpy and
    these FMUs allow it in both)."""
    if variable.causality == "independent" or variable.variability == "constant":
        return False
    if state == "instantiated":
        return variable.initial in ("exact", "approx") or variable.causality == "input"
    if state == "initialization":
        return variable.initial == "exact" or variable.causality == "input"
    return variable.causality == "input" or (
        variable.causality == "parameter" and variable.variability == "tunable"
    )


@dataclass
class Machine:
    """The standard's state machine of one instance, as these FMUs implement it."""

    version: int
    variables: dict
    state: str = "instantiated"
    slots: list = field(default_factory=list)

    def fail(self):
        self.state = ERROR_STATE[self.version]
        return {ERROR}

    def expect(self, name, *arguments):
        """The statuses the call may return; the state after it."""
        allowed = ALLOWED[self.version].get(name, ANY)
        if name in ("restore", "free", "copy", "damaged") and not self.slots:
            return {OK}  # the worker skips a slot call when no state was saved
        if self.state not in allowed:
            return self.fail()
        if name in ("get", "set"):
            type_name, reference = arguments
            variable = self.variables.get(reference)
            if variable is None or variable.type != type_name:
                return self.fail()
            if name == "set" and not settable(variable, self.state):
                return self.fail()
            return {OK}
        if name == "step":
            return self.fail() if arguments[0] != "ok" else {OK, WARNING, DISCARD}
        if name in ("bogus", "damaged") or name == "logging" and not arguments[0]:
            return self.fail()
        slot = arguments[0] % len(self.slots) if arguments and self.slots else None
        if name == "save":
            self.slots.append(self.state)
        elif name == "copy":
            self.slots.append(self.slots[slot])
        elif name == "restore":
            self.state = self.slots[slot]
        elif name == "free":
            del self.slots[slot]
        elif name in ("enter", "exit", "terminate", "reset"):
            self.state = {
                "enter": "initialization",
                "exit": STEPPING[self.version],
                "terminate": "terminated",
                "reset": "instantiated",
            }[name]
        return {OK}


def sequences(version, variables):
    """Call sequences: often starting with a proper initialisation, so that every state
    is reached; gets and sets mostly with the variable's own type."""
    types = TYPES[version]
    references = sorted(variables) + [max(variables) + 1, max(variables) + 1000]

    def typed(verb):
        return st.sampled_from(references).flatmap(
            lambda reference: st.tuples(
                st.just(verb),
                st.sampled_from(
                    [variables[reference].type] * 3 + list(types)
                    if reference in variables
                    else list(types)
                ),
                st.just(reference),
            )
        )

    life = ["enter", "exit", "terminate", "reset"] + (["setup"] if version == 2 else [])
    slot = st.integers(0, 3)
    call = st.one_of(
        st.sampled_from(life).map(lambda name: (name,)),
        st.tuples(st.just("step"), st.sampled_from(["ok", "ok", "ok", "zero", "negative", "nan"])),
        typed("get"),
        typed("set"),
        st.just(("save",)),
        st.tuples(st.sampled_from(["restore", "free", "copy"]), slot),
        st.tuples(st.just("damaged"), slot, st.sampled_from(["truncated", "flipped", "foreign"])),
        st.just(("bogus",)),
        st.just(("time",)),
        st.tuples(st.just("logging"), st.booleans()),
    )
    start = ([("setup",)] if version == 2 else []) + [("enter",), ("exit",)]
    prefix = st.sampled_from([[], start, start + [("step", "ok")]])
    return st.tuples(prefix, st.lists(call, max_size=25)).map(lambda p: [*p[0], *p[1]])


CASES = [(version, model) for version in (2, 3) for model in MODELS]


@pytest.mark.parametrize("version, model", CASES, ids=[f"fmi{v}-{m}" for v, m in CASES])
def test_every_call_sequence_gets_the_standards_statuses(worker, fmu_dir, fmu3_dir, version, model):
    fmu = (fmu_dir if version == 2 else fmu3_dir) / f"{model}.fmu"
    variables = variables_of(fmu)

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=not LONG,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(sequences(version, variables))
    def check(calls):
        statuses = worker.run(fmu, calls)
        machine = Machine(version, variables)
        for index, (call, status) in enumerate(zip(calls, statuses)):
            before = machine.state
            expected = machine.expect(*call)
            assert status in expected, (
                f"call {index} {call} in state {before} returned {status}, expected "
                f"{sorted(expected)}; the sequence: {calls[: index + 1]}"
            )
        assert len(statuses) == len(calls)

    check()
