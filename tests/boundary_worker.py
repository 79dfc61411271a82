"""Runs FMI call sequences on our FMUs through fmpy's low-level API, in its own process.

tests/test_fmi_boundary.py starts one worker per FMI version and sends it, one JSON line at a
time, ``{"fmu": path, "calls": [[name, arguments...], ...]}``; the worker runs the calls on a
fresh instance of that FMU and answers one JSON line: the status of every call (0 OK ... 4
Fatal). A call sequence that crashes the FMU kills this process, not pytest: the test sees
the signal. The calls (each FMI version's functions under one name):

- ``setup`` (FMI 2.0 fmi2SetupExperiment from t = 0), ``enter`` (fmi2EnterInitializationMode;
  FMI 3.0 fmi3EnterInitializationMode from t = 0), ``exit``, ``terminate``, ``reset``;
- ``step KIND``: a step from the host's time (advanced by every OK step) of the model's typical
  size, or of size 0, -1e-3 or NaN (KIND ok, zero, negative, nan);
- ``get TYPE VR``, ``set TYPE VR``: one variable; a set writes the variable's start value
  (of TYPE's kind when the variable has another type);
- ``save`` (GetFMUstate into the next slot), ``restore SLOT``, ``free SLOT``, ``bogus``
  (SetFMUstate of a pointer no FMU returned), ``copy SLOT`` (serialise, deserialise into the
  next slot), ``damaged SLOT HOW`` (deserialise the bytes truncated, with one byte flipped,
  or of another FMU);
- ``time`` (FMI 2.0: fmi2GetRealStatus(fmi2LastSuccessfulTime); FMI 3.0: fmi3EnterEventMode,
  which these FMUs do not have), ``logging VALID`` (SetDebugLogging of a known category, or
  of an unknown one).
"""

import ctypes
import json
import math
import os
import struct
import sys

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2LastSuccessfulTime
from fmpy.fmi3 import FMU3Slave

STEP_SIZES = {"zero": 0.0, "negative": -1e-3, "nan": math.nan}
KINDS = {  # the value a set writes, by the type the call names
    "Real": float,
    "Float64": float,
    "Integer": int,
    "Int32": int,
    "Boolean": bool,
    "String": str,
}
SAMPLE = {float: 0.0, int: 0, bool: False, str: "x"}


def fnv1a(data, hash_=0xCBF29CE484222325):
    """FNV-1a, 64 bits (the frame's checksum, packaging/c_loader/boundary.h)."""
    for byte in data:
        hash_ = ((hash_ ^ byte) * 0x100000001B3) % 2**64
    return hash_


def frame(token, payload, fmi_version, machine=1, time=0.0):
    """A serialised FMU state framed as boundary.h documents it, for an FMU of ``token``."""
    head = struct.pack("<IIIIdQ", 1, fmi_version, machine, len(token), time, len(payload))
    checksum = fnv1a(token + payload, fnv1a(head))
    return b"MECHFMUS" + head + struct.pack("<Q", checksum) + token + payload


class Session:
    """One FMU, instantiated afresh for every sequence."""

    def __init__(self, path):
        self.description = read_model_description(path)
        self.fmi3 = self.description.fmiVersion.startswith("3")
        self.folder = extract(path)
        self.by_reference = {v.valueReference: v for v in self.description.modelVariables}
        self.typical = 1e-4 if self.description.modelName.startswith("Valve") else 1e-2

    def start(self):
        options = dict(
            guid=self.description.guid,
            unzipDirectory=self.folder,
            modelIdentifier=self.description.coSimulation.modelIdentifier,
            instanceName="boundary",
        )
        self.slave = (FMU3Slave if self.fmi3 else FMU2Slave)(**options)
        self.slave.instantiate(loggingOn=False)
        self.time, self.slots = 0.0, []

    def value_for(self, kind, reference):
        variable = self.by_reference.get(reference)
        if variable is None or KINDS.get(variable.type) is not kind or variable.start is None:
            return SAMPLE[kind]
        if kind is bool:
            return variable.start in (True, "true", "1")
        return kind(variable.start)

    def accessor(self, verb, type_name):
        return getattr(self.slave, f"{verb}{type_name}")

    def run(self, name, *arguments):
        slave = self.slave
        if name == "setup":
            slave.setupExperiment(startTime=0.0)
        elif name == "enter":
            slave.enterInitializationMode(startTime=0.0) if self.fmi3 else (
                slave.enterInitializationMode()
            )
            self.time = 0.0
        elif name == "exit":
            slave.exitInitializationMode()
        elif name == "terminate":
            slave.terminate()
        elif name == "reset":
            slave.reset()
            self.time = 0.0
        elif name == "step":
            size = STEP_SIZES.get(arguments[0], self.typical)
            slave.doStep(currentCommunicationPoint=self.time, communicationStepSize=size)
            self.time += size
        elif name == "get":
            type_name, reference = arguments
            self.accessor("get", type_name)([reference])
        elif name == "set":
            type_name, reference = arguments
            value = self.value_for(KINDS[type_name], reference)
            self.accessor("set", type_name)([reference], [value])
        elif name == "save":
            state = slave.getFMUState() if self.fmi3 else slave.getFMUstate()
            self.slots.append((state, self.time))
        elif name in ("restore", "free", "copy", "damaged"):
            return self.with_slot(name, *arguments)
        elif name == "bogus":
            bogus = ctypes.c_void_p(0x1234)
            slave.setFMUState(bogus) if self.fmi3 else slave.setFMUstate(bogus)
        elif name == "time":
            if self.fmi3:
                slave.enterEventMode()
            else:
                self.time = slave.getRealStatus(fmi2LastSuccessfulTime)
        elif name == "logging":
            slave.setDebugLogging(True, ["logStatusError" if arguments[0] else "noSuchCategory"])
        else:
            raise ValueError(f"unknown call {name!r}")
        return 0

    def with_slot(self, name, index, *arguments):
        slave = self.slave
        if not self.slots:
            return 0  # no state saved yet: nothing to do (the model expects OK)
        state, time = self.slots[index % len(self.slots)]
        if name == "restore":
            slave.setFMUState(state) if self.fmi3 else slave.setFMUstate(state)
            self.time = time
        elif name == "free":
            slave.freeFMUState(state) if self.fmi3 else slave.freeFMUstate(state)
            self.slots.remove((state, time))
        elif name == "copy":
            data = slave.serializeFMUState(state) if self.fmi3 else slave.serializeFMUstate(state)
            copied = (
                slave.deserializeFMUState(data) if self.fmi3 else slave.deSerializeFMUstate(data)
            )
            self.slots.append((copied, time))
        else:
            data = bytes(
                slave.serializeFMUState(state) if self.fmi3 else slave.serializeFMUstate(state)
            )
            how = arguments[0]
            if how == "truncated":
                data = data[: len(data) // 2]
            elif how == "flipped":
                data = data[:-1] + bytes([data[-1] ^ 0x55])
            else:  # an intact frame, as another FMU (or another build of this one) writes it
                data = frame(b"another-fmu-token", data[-100:], 3 if self.fmi3 else 2)
            slave.deserializeFMUState(data) if self.fmi3 else slave.deSerializeFMUstate(data)
        return 0

    def sequence(self, calls):
        self.start()
        statuses = []
        for call in calls:
            try:
                statuses.append(self.run(*call))
            except FMICallException as error:
                statuses.append(error.status)
        self.slave.freeInstance()
        return statuses


def main():
    # Answers go to the original standard output; whatever fmpy or an FMU prints, to stderr.
    answers = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    sessions = {}
    for line in sys.stdin:
        request = json.loads(line)
        path = request["fmu"]
        if path not in sessions:
            sessions[path] = Session(path)
        answers.write(json.dumps(sessions[path].sequence(request["calls"])) + "\n")
        answers.flush()


if __name__ == "__main__":
    main()
