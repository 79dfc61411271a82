"""Saves FMU states to files, or continues runs from them, in a process of its own.

``python state_worker.py save FOLDER OUT`` runs every FMU of FOLDER (FMI 2.0 or 3.0) through
the first half of its case of tests/c_hosts.py CASES, serialises its state into
OUT/<model>.state and runs the second half; ``resume`` instantiates each FMU afresh in this
new process, deserialises that state, sets it and runs the same second half. Both write the
rows of the second half (time and every output) to OUT/<mode>.json.

The saving run has the effects with outputs of their own on (EFFECTS, where a model declares
them); the resuming instance is initialised with them off, so restoring the state must switch
them on again (the geometry outputs, the force analysis), as a state restored into a new
process's instance does.
"""

import json
import sys
from pathlib import Path

from c_hosts import CASES, input_value
from fmpy import read_model_description
from fmu_driver import Driven

# effect: what else it needs set where a default does not fit (the default cam law's cam
# needs a base circle above 0.0216 m to have no cusp)
EFFECTS = {"geometry": {}, "forces": {}, "cam_geometry": {"cam_base_radius": 0.03}}


def second_half(mode, fmu, out):
    steps, step, inputs = CASES[fmu.stem]
    declared = {v.name for v in read_model_description(str(fmu)).modelVariables}
    effects = {}
    for name, needs in EFFECTS.items():
        if name in declared and mode == "save":
            effects.update({name: True, **needs})
    driven = Driven(
        fmu,
        parameters=effects,
        inputs={name: input_value(spec, 0.0) for name, spec in inputs.items()},
    )
    slave, fmi3 = driven.slave, hasattr(driven.slave, "getFMUState")
    outputs = [v.name for v in driven.description.modelVariables if v.causality == "output"]

    def run(first, last):
        rows = []
        for _ in range(first, last):
            time = driven.time
            outcome = driven.step(step, **{n: input_value(s, time) for n, s in inputs.items()})
            assert outcome is True, (fmu.stem, outcome)
            rows.append([driven.time] + [driven.get(name) for name in outputs])
        return rows

    half = steps // 2
    if mode == "save":
        run(0, half)
        state = slave.getFMUState() if fmi3 else slave.getFMUstate()
        data = slave.serializeFMUState(state) if fmi3 else slave.serializeFMUstate(state)
        (out / f"{fmu.stem}.state").write_bytes(bytes(data))
        (out / f"{fmu.stem}.time").write_text(repr(driven.time))
    else:
        data = (out / f"{fmu.stem}.state").read_bytes()
        if fmi3:
            slave.setFMUState(slave.deserializeFMUState(data))
        else:
            slave.setFMUstate(slave.deSerializeFMUstate(data))
        driven.time = float((out / f"{fmu.stem}.time").read_text())
    rows = run(half, steps)
    driven.close()
    return rows


def main():
    mode, folder, out = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])
    rows = {fmu.stem: second_half(mode, fmu, out) for fmu in sorted(folder.glob("*.fmu"))}
    (out / f"{mode}.json").write_text(json.dumps(rows))


if __name__ == "__main__":
    main()
