"""FMI 3.0 (issue 20): every model built with ``mechfmu build --fmi-version 3`` from the same
declarations as its FMI 2.0 FMU (runtime/fmi/fmi3.py binds them to pythonfmu3).

The FMI 3.0 FMUs are compared with the FMI 2.0 ones on every shipped scene: our master (FMI
2.0) runs the scene recording every input and output of every component; each component's
FMI 3.0 FMU is then driven alone through fmpy with the inputs the master gave it at each
communication point, and must give the master's outputs to 1e-12 (relative). Our master
stays FMI 2.0 (its stepping loop calls the FMI 2.0 C functions directly); this replay tests
each FMI 3.0 FMU in exactly the conditions of the scene.
"""

import math
import re
import sys
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from c_hosts import (
    CASES,
    PYENV_VERSIONS,
    compile_host,
    extract,
    fmpy_rows,
    hiding,
    largest_relative_difference,
    run_host,
    run_model,
)
from conftest import SCENES
from fmu_checks import assert_fmutool_clean
from fmu_driver import Driven
from mechfmu.cosim.master import Simulation
from mechfmu.packaging import build
from mechfmu.packaging.binary_patch import find_symbol_offset
from mechfmu.cosim.scene import load_scene
from mechfmu.runtime.models import MODELS


@pytest.fixture(scope="module")
def host3(tmp_path_factory):
    return compile_host("host3.c", tmp_path_factory.mktemp("c_host3") / "host3")


@pytest.mark.parametrize("model", list(MODELS))
def test_every_fmi3_fmu_validates_with_fmpy_and_fmutool(fmu3_dir, model):
    fmu = fmu3_dir / f"{model}.fmu"
    assert validate_fmu(str(fmu)) == []
    assert_fmutool_clean(fmu, 3)


@pytest.mark.parametrize("model", list(MODELS))
def test_fmi3_description_comes_from_the_fmi2_declarations(fmu_dir, fmu3_dir, model):
    """Same names, value references, causalities, units, ranges and start values; Real is
    Float64 and Integer Int32; ``time`` is the independent variable, after the declared ones;
    each output depends on the same inputs."""
    two = read_model_description(str(fmu_dir / f"{model}.fmu"))
    three = read_model_description(str(fmu3_dir / f"{model}.fmu"))
    assert three.fmiVersion == "3.0" and three.modelName == two.modelName == model
    kinds = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
    *declared, time = three.modelVariables
    assert (time.name, time.causality, time.type, time.valueReference, time.unit) == (
        "time",
        "independent",
        "Float64",
        len(two.modelVariables),
        "s",
    )
    assert len(declared) == len(two.modelVariables)
    for old, new in zip(two.modelVariables, declared):
        assert (new.name, new.valueReference, new.causality, new.variability, new.description) == (
            old.name,
            old.valueReference,
            old.causality,
            old.variability,
            old.description,
        )
        assert new.type == kinds[old.type], old.name
        assert (new.unit, new.min, new.max) == (old.unit, old.min, old.max), old.name
        if old.causality == "output":
            assert new.start is None and new.initial == "calculated", old.name
        else:
            assert new.start == old.start, old.name  # both exact (repr of the declared value)
    depends = {u.variable.name: sorted(d.name for d in u.dependencies) for u in two.outputs}
    assert {
        u.variable.name: sorted(d.name for d in u.dependencies) for u in three.outputs
    } == depends
    assert sorted(u.variable.name for u in three.initialUnknowns) == sorted(depends)


def _recorded_run(path, fmu_dir):
    """Our master's run of the scene at ``path`` (FMI 2.0) recording every input and output
    of every component it runs; (Simulation, Result)."""
    scene = load_scene(path)
    scene.record = None  # every output, to find the components and their variables
    names = [
        f"{name}.{v.name}"
        for name, component in Simulation(scene, fmu_dir).components.items()
        for v in component.variables.values()
        if v.causality in ("input", "output") and v.type != "String"
    ]
    scene.record = names
    simulation = Simulation(scene, fmu_dir)
    return simulation, simulation.run()


def _replay(fmu, name, simulation, result):
    """Component ``name`` of the scene alone, FMI ``fmu``, fed the master's recorded inputs;
    its outputs at every communication point: {variable: [values]}."""
    spec = simulation.components[name].spec
    fed = [c for c in simulation.connections if c.target == name]
    lagged = {c.input for c in simulation.lagged if c.target == name}
    column = {c.input: result.columns[f"{name}.{c.input}"] for c in fed}
    initial = {c.input: column[c.input][0] for c in fed if c.input not in lagged}
    driven = Driven(
        fmu,
        {**spec.parameters, **{e: True for e in spec.effects}},
        {**spec.inputs, **initial},
        start_time=result.times[0],
        instance=name,
    )
    outputs = [v.name for v in driven.description.modelVariables if v.causality == "output"]
    got = {output: [driven.get(output)] for output in outputs}
    try:
        for k in range(len(result.times) - 1):
            driven.time = result.times[k]  # the master's communication points, exactly
            done = driven.step(
                result.times[k + 1] - result.times[k],
                **{input_: values[k + 1] for input_, values in column.items()},
            )
            assert done is True, (name, k, done)
            for output in outputs:
                got[output].append(driven.get(output))
    finally:
        driven.close()
    return got


@pytest.mark.parametrize("scene", sorted(p.stem for p in SCENES.glob("*.toml")))
def test_fmi3_fmus_give_the_fmi2_outputs_on_every_shipped_scene(fmu_dir, fmu3_dir, scene):
    simulation, result = _recorded_run(SCENES / f"{scene}.toml", fmu_dir)
    compared = 0
    for name, component in simulation.components.items():
        model = component.description.modelName
        got = _replay(fmu3_dir / f"{model}.fmu", name, simulation, result)
        for output, values in got.items():
            expected = np.array(result.columns[f"{name}.{output}"], dtype=float)
            values = np.array(values, dtype=float)
            assert values.shape == expected.shape, (name, output)
            scale = np.maximum(np.abs(values), np.abs(expected))
            worst = np.max(np.abs(values - expected) / np.where(scale > 0, scale, 1.0))
            assert worst <= 1e-12, (name, output, worst)  # measured: 0 (identical)
            compared += values.size
    assert compared > 100


def test_fmi3_fmu_reports_a_refused_input_through_the_logger(fmu3_dir):
    driven = Driven(fmu3_dir / "FourBar.fmu", inputs={"crank_angle": 0.5})
    try:
        assert driven.step(0.01) is True
        refused = driven.step(0.01, crank_speed=math.nan)
        assert "crank_speed = nan" in refused and "discard" in refused
        assert any("crank_speed = nan" in m for m in driven.messages(3))  # status error
        assert driven.step(0.01, crank_speed=1.0) is True  # the instance goes on
    finally:
        driven.close()


@pytest.mark.parametrize("model", list(MODELS))
def test_c_host_runs_the_fmi3_fmu_like_fmpy(host3, fmu3_dir, fmu_dir, tmp_path, model):
    """host3.c (no Python in the process) through the FMI 3 loader: fmpy's FMI 3.0 numbers,
    which are the FMI 2.0 C host's (CASES: the same inputs and steps)."""
    fmu = fmu3_dir / f"{model}.fmu"
    done, rows, loaded = run_model(host3, fmu, tmp_path / model)
    assert done.returncode == 0, done.stderr[-3000:]
    assert len(loaded) == 1 and "libpython3." in loaded[0]
    expected = fmpy_rows(str(fmu))
    assert len(rows) == CASES[model][0] + 1
    assert largest_relative_difference(rows, expected) <= 1e-12
    assert rows == expected  # measured: bit-identical
    assert largest_relative_difference(rows, fmpy_rows(str(fmu_dir / f"{model}.fmu"))) <= 1e-12


def _token(fmu):
    return read_model_description(str(fmu)).guid


def test_fmi3_fmus_unload_and_reload_in_one_c_host(host3, fmu3_dir, tmp_path):
    """Two FMI 3.0 FMUs in one process: the first (whose pythonfmu3 library started the
    interpreter) is terminated, freed and dlclosed after 40 of 100 steps while the second goes
    on; then the first is loaded again and runs from the start. pythonfmu3's library calls
    Py_Finalize when it is unloaded; the loader keeps it loaded (RTLD_NODELETE), so neither
    the second FMU nor the reload loses its interpreter, and every row equals fmpy's."""
    crank = extract(fmu3_dir / "CrankDrive.fmu", tmp_path / "crank")
    gear = extract(fmu3_dir / "LandingGear.fmu", tmp_path / "gear")
    variables = {
        v.name: v.valueReference
        for v in read_model_description(str(fmu3_dir / "LandingGear.fmu")).modelVariables
    }
    command = [
        str(host3),
        "100",
        "0.01",
        "--release-first-after",
        "40",
        "--reload-first",
        "-f",
        str(crank),
        "CrankDrive",
        _token(fmu3_dir / "CrankDrive.fmu"),
        "-o",
        "r:5",
        "-f",
        str(gear),
        "LandingGear",
        _token(fmu3_dir / "LandingGear.fmu"),
        "-i",
        f"{variables['piston_extension']}=0.381,0.0762",
        "-i",
        f"{variables['piston_speed']}=0.0762",
        "-o",
        f"r:{variables['gear_angle']}",
    ]
    done, _, loaded = run_host(command, labelled=True)
    assert done.returncode == 0, done.stderr[-3000:]
    assert len(loaded) == 1  # one interpreter for both FMUs and the reload
    rows = {label: [] for label in "01R"}
    for line in done.stdout.splitlines():
        label, *values = line.split(",")
        rows[label].append([float(x) for x in values])
    assert [len(rows[label]) for label in "01R"] == [41, 101, 101]
    angles = [row[1] for row in rows["R"]]
    assert angles == pytest.approx([10.0 * row[0] for row in rows["R"]], rel=1e-14, abs=1e-15)
    assert rows["0"] == rows["R"][:41]  # the reload repeats the first run exactly
    gear_angle = [row[1] for row in rows["1"]]
    assert gear_angle[-1] - gear_angle[40] > 0.1  # the gear kept turning after the unload


def test_fmi3_fmu_runs_in_a_c_host_on_another_python(host3, fmu3_dir, tmp_path):
    """The FMI 3 loader searches like the FMI 2 one: the build's Python hidden, pyenv's 3.13
    (3.12 when the build's is 3.13) runs the FMI 3.0 FMU (to 1e-12 of fmpy under the build's
    Python)."""
    empty = tmp_path / "empty"
    empty.mkdir()
    minor = 13 if sys.version_info.minor != 13 else 12
    other = max(PYENV_VERSIONS.glob(f"3.{minor}.*"), key=lambda p: p.name)
    hide = hiding(empty, keep_pyenv=(other.name,))
    done, rows, loaded = run_model(host3, fmu3_dir / "ValveSpring.fmu", tmp_path / "valve", hide)
    assert done.returncode == 0, done.stderr[-3000:]
    assert loaded == [str(other / "lib" / f"libpython3.{minor}.so.1.0")]
    assert largest_relative_difference(rows, fmpy_rows(str(fmu3_dir / "ValveSpring.fmu"))) <= 1e-12


def test_fmi3_loader_exports_every_fmi3_function(fmu3_dir):
    """All 75 functions of fmi3Functions.h: co-simulation and the common ones forwarded, the
    other interface types' instantiation refused (these FMUs are co-simulation only)."""
    header = (build.fmi_headers() / "fmi3Functions.h").read_text()
    names = sorted(set(re.findall(r"#define (fmi3\w+)\s+fmi3FullName\(", header)))
    assert len(names) == 75
    with zipfile.ZipFile(fmu3_dir / "LandingGear.fmu") as archive:
        loader = archive.read("binaries/x86_64-linux/LandingGear.so")
        assert b"_Py_NoneStruct" not in loader
        assert "binaries/x86_64-linux/LandingGear.pythonfmu.so" in archive.namelist()
        assert not [n for n in archive.namelist() if n.startswith("sources/")]
    assert [name for name in names if find_symbol_offset(loader, name.encode()) is None] == []


def test_fmi3_outputs_are_computed_in_initialisation_mode(fmu3_dir):
    """Read in initialisation mode (as libcosim reads FMI 2.0 ones), the outputs follow the
    inputs set so far: the landing gear's angle for a piston extension of 0.45 m, not its
    start value, and again after the input changes."""
    from fmpy import extract
    from fmpy.fmi3 import FMU3Slave
    from mechfmu.references.landing_gear import gear_from_piston

    fmu = fmu3_dir / "LandingGear.fmu"
    description = read_model_description(str(fmu))
    refs = {v.name: v for v in description.modelVariables}
    slave = FMU3Slave(
        guid=description.guid,
        unzipDirectory=extract(str(fmu)),
        modelIdentifier="LandingGear",
        instanceName="init",
    )
    slave.instantiate()
    try:
        slave.enterInitializationMode()
        angles = []
        for extension in (0.45, 0.40):
            slave.setFloat64([refs["piston_extension"].valueReference], [extension])
            angles.append(slave.getFloat64([refs["gear_angle"].valueReference])[0])
        slave.exitInitializationMode()
    finally:
        slave.terminate()
        slave.freeInstance()
    for extension, angle in zip((0.45, 0.40), angles):
        theta, _, _ = gear_from_piston(
            np.array([extension]),
            np.zeros(1),
            np.zeros(1),
            float(refs["attachment_distance"].start),
            float(refs["pivot_height"].start),
        )
        assert angle == pytest.approx(theta[0], rel=1e-14)
    assert angles[0] != angles[1]
