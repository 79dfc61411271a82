"""FMUs that describe themselves: documentation, picture, version, default experiment, only
the runtime they need, only the platforms whose binaries have run."""

import re
from importlib.machinery import EXTENSION_SUFFIXES
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

import mechfmu
from mechfmu.cosim.scene import SCENE_DIR, load_scene
from mechfmu.packaging.build import RUNTIME_ROOT, runtime_package
from mechfmu.packaging.closure import runtime_closure
from mechfmu.packaging.compiled import core_extensions
from mechfmu.packaging.describe import DOCS_MODELS, REFERENCE_SCENES, model_class
from mechfmu.runtime.models import MODELS

PNG = b"\x89PNG\r\n\x1a\n"


def _members(path):
    with zipfile.ZipFile(path) as archive:
        return {name: archive.read(name) for name in archive.namelist()}


@pytest.mark.parametrize("model", MODELS)
def test_each_fmu_carries_its_documentation_and_picture(fmu_dir, model):
    members = _members(fmu_dir / f"{model}.fmu")
    page = members["documentation/index.html"].decode()
    table = page.split(f"<h3><code>{model}.fmu</code></h3>")[1]  # the variable table
    assert "<table>" in table
    for variable in model_class(model).VARIABLES:  # every variable, with its unit
        row = re.search(rf"<tr>\s*<td><code>{variable.name}</code></td>(.*?)</tr>", table, re.S)
        assert row is not None, variable.name
        assert f"<td>{variable.unit or ''}</td>" in row.group(1), variable.name
    for image in re.findall(r'<img alt="[^"]*" src="([^"]+)"', page):
        assert members[f"documentation/{image}"].startswith(PNG), image
    assert f"{REFERENCE_SCENES[model]}.png" in page
    assert members["model.png"].startswith(PNG)


@pytest.mark.parametrize("model", MODELS)
def test_each_fmu_names_its_version_and_default_experiment(fmu_dir, model):
    description = read_model_description(str(fmu_dir / f"{model}.fmu"))
    assert description.version == mechfmu.__version__
    scene = load_scene(SCENE_DIR / f"{REFERENCE_SCENES[model]}.toml")
    experiment = description.defaultExperiment
    assert float(experiment.startTime) == scene.start_time
    assert float(experiment.stopTime) == scene.stop_time
    assert float(experiment.stepSize) == scene.step


@pytest.mark.parametrize("model", MODELS)
def test_each_fmu_carries_only_the_runtime_its_model_imports(fmu_dir, model):
    members = _members(fmu_dir / f"{model}.fmu")
    package = f"resources/{runtime_package(model)}/"
    carried = {name[len(package) :] for name in members if name.startswith(package)}
    needed = {str(path) for path in runtime_closure(RUNTIME_ROOT, MODELS[model], "fmi2")}
    # with the exact core's C extensions where the model carries it (tests/test_compiled_core.py)
    assert carried == needed | core_extensions(needed, EXTENSION_SUFFIXES[0])
    assert len(carried) < len(list(RUNTIME_ROOT.rglob("*.py")))
    if model == "LandingGear":  # none of the valve physics, no other mechanism's slave
        assert not {"physics/valve_spring.py", "physics/valve_train.py"} & carried
        assert not {"models/four_bar.py", "models/linkage.py", "models/suspension.py"} & carried
    # binaries: this platform only (pythonfmu's Windows DLLs were never run here)
    binaries = {name.split("/")[1] for name in members if name.startswith("binaries/")}
    assert binaries == {"linux64"}


def test_fmi3_fmus_carry_an_icon_and_their_platform_only(fmu3_dir):
    for model in MODELS:
        members = _members(fmu3_dir / f"{model}.fmu")
        assert members["terminalsAndIcons/icon.png"].startswith(PNG)
        assert "documentation/index.html" in members
        assert {n.split("/")[1] for n in members if n.startswith("binaries/")} == {"x86_64-linux"}


def test_reference_scenes_are_the_first_plotted_on_each_model_page():
    pages = {}
    for page in sorted(Path(DOCS_MODELS).glob("*.md")):
        text = page.read_text()
        interface = re.search(r"<!-- mechfmu:interface (\w+) -->", text)
        plotted = re.search(r"<!-- mechfmu:reference-plot (\w+) -->", text)
        if interface and plotted:
            pages[interface.group(1)] = plotted.group(1)
    assert pages == REFERENCE_SCENES
