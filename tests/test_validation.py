"""Every FMU we build passes both validators (issue 20): ``fmpy validate`` and fmu-manipulation-
toolbox's ``fmutool -input X.fmu -check`` (generic XSD conformity and semantic checks).

FMI 2.0 (fmus/) and embedded-Python FMUs here; the FMI 3.0 FMUs in test_fmi3.py, the container
FMUs in test_container.py, fmpy's validation of fmus/ also in test_fmus.py.
"""

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from fmpy.validation import validate_fmu

from fmu_checks import assert_fmutool_clean, fmutool_check
from mechfmu.runtime.models import MODELS

FMUTOOL = Path(sys.executable).parent / "fmutool"  # the console script beside this Python


@pytest.mark.parametrize("model", list(MODELS))
def test_fmi2_fmu_passes_fmutool_check(fmu_dir, model):
    assert_fmutool_clean(fmu_dir / f"{model}.fmu", 2)


@pytest.mark.parametrize("model", list(MODELS))
def test_embedded_fmu_passes_both_validators(embedded_dir, model):
    fmu = embedded_dir / f"{model}.fmu"
    assert validate_fmu(str(fmu)) == []
    assert_fmutool_clean(fmu, 2)


def _break_fmi3_time(fmu, target):
    """A copy of an FMI 3.0 FMU whose independent variable ``time`` is declared an output
    (then not listed among the Outputs): invalid."""
    with zipfile.ZipFile(fmu) as archive:
        members = {info.filename: archive.read(info) for info in archive.infolist()}
    members["modelDescription.xml"] = members["modelDescription.xml"].replace(
        b'causality="independent"', b'causality="output"'
    )
    with zipfile.ZipFile(target, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return target


def test_fmutool_command_passes_our_fmus_and_fails_a_broken_one(fmu_dir, fmu3_dir, tmp_path):
    """The command users run: exit 0 on an FMI 2.0 and an FMI 3.0 FMU; non-zero, naming the
    fault, on a broken copy (so the checks above can fail)."""
    for fmu in (fmu_dir / "LandingGear.fmu", fmu3_dir / "LandingGear.fmu"):
        done = subprocess.run(
            [str(FMUTOOL), "-input", str(fmu), "-check"], capture_output=True, text=True
        )
        assert done.returncode == 0, done.stdout + done.stderr
        assert "No semantic error" in done.stdout + done.stderr
    broken = _break_fmi3_time(fmu3_dir / "CrankDrive.fmu", tmp_path / "broken.fmu")
    errors, _ = fmutool_check(broken)
    assert any("'time' is not listed in <Output>" in e for e in errors), errors
    done = subprocess.run(
        [str(FMUTOOL), "-input", str(broken), "-check"], capture_output=True, text=True
    )
    assert done.returncode != 0
    assert "'time' is not listed in <Output>" in done.stdout + done.stderr
