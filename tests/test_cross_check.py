"""``mechfmu export-cross-check``: the FMUs and their references in the fmi-cross-check layout,
validated and simulated by fmpy's cross-check tooling with no problem reported.

``make test`` exports two models (a source and a driven linkage); ``make cross-check`` all.
"""

import os

import fmpy
import numpy as np
import pytest
from fmpy.cross_check import validate_result
from fmpy.cross_check.cross_check import cross_check
from fmpy.cross_check.validate_vendor_repo import validate_repo
from fmpy.util import read_csv, read_ref_opt_file

from cli_process import run_mechfmu
from mechfmu.tools.cross_check import model_folder

MODELS = os.environ.get("MECHFMU_CROSS_CHECK_MODELS", "PistonActuator FourBar").split()


def _simulate(options):
    """As fmpy's own cross-check runs a test FMU (python -m fmpy.cross_check --simulate)."""
    inputs = read_csv(options["input_filename"]) if "input_filename" in options else None
    return fmpy.simulate_fmu(
        filename=options["fmu_filename"],
        validate=False,
        step_size=options["step_size"],
        stop_time=options["stop_time"],
        input=inputs,
        output=options["output_variable_names"],
    )


@pytest.fixture(scope="module")
def exported(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("cross_check")
    done = run_mechfmu("export-cross-check", out, *MODELS, "--fmu-dir", fmu_dir, timeout=900)
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def test_the_layout_validates_with_fmpys_cross_check(exported):
    fmus, results, problems = validate_repo(str(exported))
    assert (fmus, results, problems) == (len(MODELS), 0, [])
    for model in MODELS:
        folder = model_folder(exported, model)
        names = {path.name for path in folder.iterdir()}
        assert {f"{model}.fmu", f"{model}_ref.csv", f"{model}_ref.opt", "ReadMe.md"} <= names


def test_fmpys_cross_check_simulates_every_fmu_within_its_reference(exported, tmp_path):
    report = tmp_path / "report.html"
    cross_check(
        fmus_dir=str(exported / "fmus"),
        report=str(report),
        result_dir=None,  # no plots (plotly is not installed); the results are checked below
        simulate=_simulate,
        tool_name="FMPy",
        tool_version=fmpy.__version__,
        skip=lambda options: False,
        readme=None,
    )
    text = report.read_text()
    assert text.count("<tr><td>") == len(MODELS)
    assert "label label-danger" not in text and "label label-warning" not in text, text
    assert text.count("100 %") == len(MODELS) and "is missing" not in text  # documentation


def test_results_in_the_repositorys_layout_pass_its_validation(exported):
    for model in MODELS:
        folder = model_folder(exported, model)
        options = read_ref_opt_file(str(folder / f"{model}_ref.opt"))
        reference = read_csv(str(folder / f"{model}_ref.csv"))
        inputs = folder / f"{model}_in.csv"
        result = _simulate(
            {
                "fmu_filename": str(folder / f"{model}.fmu"),
                "step_size": options["StepSize"],
                "stop_time": options["StopTime"],
                "output_variable_names": list(reference.dtype.names[1:]),
                **({"input_filename": str(inputs)} if inputs.exists() else {}),
            }
        )
        assert validate_result(result, reference, options["StartTime"], options["StopTime"]) is None
        results = exported / "results" / "2.0" / "cs" / "linux64" / "FMPy" / fmpy.__version__
        target = results / "mechfmu" / folder.parent.name / model
        target.mkdir(parents=True)
        (target / "passed").write_text("")
        header = ",".join(f'"{name}"' for name in result.dtype.names)
        # %.17g: every double exactly, in fewer bytes than numpy's %.18e (the repository
        # allows 1 MB per file; FourBar's 1000 rows of 41 outputs took 1.1 MB that way)
        np.savetxt(target / f"{model}_out.csv", result, "%.17g", ",", header=header, comments="")
    fmus, results_count, problems = validate_repo(str(exported))
    assert (fmus, results_count, problems) == (len(MODELS), len(MODELS), [])


def test_a_model_without_a_reference_of_its_own_is_left_out_with_the_reason(tmp_path, fmu_dir):
    done = run_mechfmu("export-cross-check", tmp_path, "HydraulicActuator", "--fmu-dir", fmu_dir)
    assert done.returncode == 0, done.stderr
    assert "left out HydraulicActuator: its reference scene gear_retraction_dynamic" in done.stdout
    assert not (tmp_path / "fmus").exists()
