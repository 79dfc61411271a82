"""FMU states that survive the process (canSerializeFMUstate, FMI 2.0 and 3.0).

A run stopped half-way, its state serialised by one process and deserialised by a new one
(tests/state_worker.py), continues with every output bit for bit as the run that never
stopped; bytes that are truncated, changed, of another FMU or not a state at all are refused
with fmi2Error and a message naming why, and the instance stays recoverable.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException

from fmu_driver import Driven
from mechfmu.runtime.models import MODELS

WORKER = Path(__file__).with_name("state_worker.py")


@pytest.mark.parametrize("version", [2, 3])
def test_a_state_saved_in_one_process_continues_bit_for_bit_in_another(
    fmu_dir, fmu3_dir, tmp_path, version
):
    folder = tmp_path / "fmus"
    folder.mkdir()
    for model in MODELS:  # the registry's models only (fmus/ may hold others)
        (folder / f"{model}.fmu").symlink_to(
            (fmu_dir if version == 2 else fmu3_dir) / f"{model}.fmu"
        )
    for mode in ("save", "resume"):
        done = subprocess.run(
            [sys.executable, str(WORKER), mode, str(folder), str(tmp_path)],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 0, done.stderr[-3000:]
    saved = json.loads((tmp_path / "save.json").read_text())
    resumed = json.loads((tmp_path / "resume.json").read_text())
    assert sorted(saved) == sorted(MODELS)
    for model in MODELS:
        assert len(saved[model]) >= 50, model
        assert resumed[model] == saved[model], model  # JSON keeps every double exactly


@pytest.mark.parametrize("version", [2, 3])
def test_every_fmu_declares_that_it_serialises_its_state(fmu_dir, fmu3_dir, version):
    for model in MODELS:
        path = (fmu_dir if version == 2 else fmu3_dir) / f"{model}.fmu"
        co_simulation = read_model_description(str(path)).coSimulation
        assert co_simulation.canGetAndSetFMUstate and co_simulation.canSerializeFMUstate


def test_damaged_or_foreign_state_bytes_are_refused_with_a_message(fmu_dir):
    gear = Driven(fmu_dir / "LandingGear.fmu", inputs={"piston_extension": 0.4})
    other = Driven(fmu_dir / "PistonActuator.fmu")
    try:
        assert gear.step(0.01, piston_extension=0.401) is True
        data = bytes(gear.slave.serializeFMUstate(gear.slave.getFMUstate()))
        foreign = bytes(other.slave.serializeFMUstate(other.slave.getFMUstate()))
        changed = bytearray(data)
        changed[-3] ^= 0x20
        newer = bytearray(data)
        newer[8] = 2  # format version 2
        cases = {
            data[:40]: "fewer than its 48-byte header",
            data[:-5]: "its header announces",
            bytes(changed): "checksum does not match",
            bytes(newer): "format version 2; this FMU reads version 1",
            foreign: "saved by another FMU or another build of LandingGear",
            b'{"format": 1, "state": {}, "model": "LandingGear", "padding": 0}': (
                "does not start with mechfmu's header"
            ),
        }
        for blob, words in cases.items():
            with pytest.raises(FMICallException, match="status 3"):
                gear.slave.deSerializeFMUstate(blob)
            assert words in gear.logbook.last_problem("under_test"), words
            gear.slave.reset()  # out of the error state
        # intact bytes still restore, after all that
        gear.slave.setFMUstate(gear.slave.deSerializeFMUstate(data))
        assert gear.get("piston_extension") == 0.401
    finally:
        gear.close()
        other.close()
