"""``mechfmu export-cross-check DIR``: our FMUs with their reference results, laid out as the
Modelica Association's fmi-cross-check repository wants test FMUs (host side).

For each model, in ``DIR/fmus/2.0/cs/linux64/mechfmu/<version>/<Model>/``:

- ``<Model>.fmu``: the model built with the start values its component has in the model's
  reference scene (describe.REFERENCE_SCENES): its parameters, effects and fixed inputs, since
  a cross-check run sets nothing but the inputs of ``_in.csv``;
- ``<Model>_ref.csv``: the component's columns of the scene's reference CSV, the closed forms
  of ``mechfmu references`` (never an FMU run), named as the FMU names them;
- ``<Model>_in.csv`` (models with connected inputs): the input signals our master feeds the
  component in the scene (the connected sources' outputs at every communication point);
- ``<Model>_ref.opt``: start time, stop time, step size of the scene and a relative tolerance;
- ``<Model>_cc.sh``: the mechfmu commands that made the files; ``ReadMe.md``: what the model
  is, where the reference comes from, and the FMU's documentation (documentation/index.html).

Models without a reference CSV of their own component (HydraulicActuator: its reference scene
uses the landing gear's built-in actuator) are left out, and the command says so. Files are
kept under the repository's 1 MB limit: a longer table keeps every n-th row.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import tempfile
from pathlib import Path
from typing import Any

from fmpy import read_model_description

from .. import __version__
from ..cosim.files import atomic_write
from ..cosim.master import Simulation
from ..cosim.scene import SCENE_DIR, ComponentSpec, Scene, load_scene
from ..cosim.variables import start_value
from ..packaging.build import build_model, compile_loader
from ..packaging.describe import REFERENCE_SCENES
from ..runtime.models import MODELS

TOOL, PLATFORM = "mechfmu", "linux64"
MAX_FILE = 1_000_000  # bytes: the repository's limit for every file but the FMU
REL_TOL = 1e-6  # the _ref.opt tolerance (our FMUs integrate with their own rtol parameters)


def model_folder(out_dir: Path, model: str) -> Path:
    """Where ``model``'s files go in the cross-check layout."""
    return Path(out_dir) / "fmus" / "2.0" / "cs" / PLATFORM / TOOL / __version__ / model


def component_of(scene: Scene, model: str) -> ComponentSpec | None:
    """The scene's component that is ``model``, or None."""
    return next((spec for spec in scene.components.values() if Path(spec.fmu).stem == model), None)


def _csv_text(header: list[str], rows: list[Any]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows([repr(float(x)) for x in row] for row in rows)
    return buffer.getvalue()


def _table(header: list[str], rows: list[Any]) -> str:
    """CSV text (floats exact); every n-th row (and the last) when all of them would pass
    MAX_FILE."""
    every = 1
    while True:
        kept = rows[::every]
        if kept[-1] is not rows[-1]:
            kept.append(rows[-1])
        text = _csv_text(header, kept)
        if len(text.encode()) <= MAX_FILE:
            return text
        every += 1


def reference_columns(scene: Scene, component: ComponentSpec) -> dict[str, list[float]]:
    """The closed-form columns of ``component`` in the scene's reference CSV, by the FMU's
    variable names (and 'time')."""
    assert scene.reference is not None, f"scene {scene.name} has no reference CSV"
    with open(scene.reference, newline="") as handle:
        rows = list(csv.reader(handle))
    prefix = f"{component.name}."
    columns = {"time": [float(row[0]) for row in rows[1:] if row]}
    for index, name in enumerate(rows[0]):
        if name.startswith(prefix):
            columns[name[len(prefix) :]] = [float(row[index]) for row in rows[1:] if row]
    return columns


def scene_run(scene: Scene, component: ComponentSpec, fmu: Path, fmu_dir: Path | None) -> Any:
    """Our master's run of the scene, recording every numeric output of ``component`` (the
    FMU ``fmu``) and the outputs that feed its inputs."""
    description = read_model_description(str(fmu))
    outputs = [
        f"{component.name}.{v.name}"
        for v in description.modelVariables
        if v.causality == "output" and v.type != "String"
    ]
    feeding = [f"{c.source}.{c.output}" for c in scene.connections if c.target == component.name]
    return Simulation(dataclasses.replace(scene, record=outputs + feeding), fmu_dir).run()


def tables(
    scene: Scene, component: ComponentSpec, fmu: Path, fmu_dir: Path | None
) -> tuple[dict[str, list[float]], dict[str, list[float]] | None, list[str]]:
    """(reference columns, input columns or None, outputs taken from our own run): every
    output of the FMU, from the closed form where the scene's reference CSV has it and from our
    master's run where it does not (solver diagnostics such as iteration counts); every input,
    as our master feeds it in the scene (a fixed input: its value throughout)."""
    run = scene_run(scene, component, fmu, fmu_dir)
    closed = reference_columns(scene, component)
    if closed["time"] != run.times:
        raise ValueError(f"scene {scene.name}: the reference CSV is not on the run's time grid")
    prefix = f"{component.name}."
    reference, own = {"time": run.times}, []
    for column, values in run.columns.items():
        if column.startswith(prefix):
            name = column[len(prefix) :]
            reference[name] = closed.get(name, values)
            if name not in closed:
                own.append(name)
    variables = read_model_description(str(fmu)).modelVariables
    inputs = [v for v in variables if v.causality == "input"]
    if not inputs:
        return reference, None, own
    fed = {
        c.input: f"{c.source}.{c.output}" for c in scene.connections if c.target == component.name
    }
    signals = {"time": run.times}
    for variable in inputs:
        if variable.name in fed:
            signals[variable.name] = run.columns[fed[variable.name]]
        else:
            start = start_value(variable)
            signals[variable.name] = [float(start)] * len(run.times)
    return reference, signals, own


def starts_of(component: ComponentSpec) -> dict[str, Any]:
    """The start values the component has in its scene: parameters, effects on, fixed inputs."""
    return {
        **component.parameters,
        **{effect: True for effect in component.effects},
        **component.inputs,
    }


def _readme(model: str, scene: Scene, component: str, has_inputs: bool, own: list[str]) -> str:
    return f"""# {model}

{model} from mechfmu {__version__}: a co-simulation FMU whose model runs in Python (pythonfmu,
with mechfmu's C loader, which finds any CPython 3.10 or newer on the machine; see
`documentation/index.html` inside the FMU for the equations and every variable with its unit).

- Built with the start values its component `{component}` has in the
  mechfmu scene `{scene.name}` (parameters, effects, fixed inputs), so that it needs nothing
  but {"the inputs of `" + model + "_in.csv`" if has_inputs else "its defaults"}.
- `{model}_ref.csv` is the closed-form reference of that scene (`mechfmu references`: numpy,
  never an FMU run), the component's columns, from {scene.start_time} s to {scene.stop_time} s{
        "; the outputs " + ", ".join(f"`{name}`" for name in own) + " have no closed form (solver "
        "diagnostics): their columns are mechfmu's own run of the scene"
        if own
        else ""
    }.
{
        "- `" + model + "_in.csv` holds the signals mechfmu's master feeds the FMU in that scene."
        if has_inputs
        else ""
    }
- Step size {scene.step} s (`{model}_ref.opt`); `{model}_cc.sh` has the commands.
"""


def _commands(model: str, scene: Scene) -> str:
    return (
        "#!/bin/sh\n"
        f"# {model}: the files of this folder, by mechfmu {__version__}\n"
        "mechfmu references  # the closed-form reference CSVs of the shipped scenes\n"
        f"mechfmu export-cross-check OUT {model}  # this folder (scene {scene.name})\n"
    )


def export_model(
    model: str, out_dir: Path, staging: Path, loader: Any, fmu_dir: Path | None
) -> Path | None:
    """Write ``model``'s folder of the cross-check layout; its path, or None when the model
    has no reference of its own."""
    scene = load_scene(SCENE_DIR / f"{REFERENCE_SCENES[model]}.toml")
    component = component_of(scene, model)
    if component is None or scene.reference is None:
        return None
    folder = model_folder(out_dir, model)
    folder.mkdir(parents=True, exist_ok=True)
    fmu = build_model(model, folder, staging, loader=loader, starts=starts_of(component))
    reference, inputs, own = tables(scene, component, fmu, fmu_dir)
    atomic_write(
        folder / f"{model}_ref.csv", _table(list(reference), list(zip(*reference.values())))
    )
    if inputs is not None:
        atomic_write(folder / f"{model}_in.csv", _table(list(inputs), list(zip(*inputs.values()))))
    options = {
        "StartTime": scene.start_time,
        "StopTime": scene.stop_time,
        "StepSize": scene.step,
        "RelTol": REL_TOL,
    }
    atomic_write(
        folder / f"{model}_ref.opt",
        "".join(f"{key}, {value!r}\n" for key, value in options.items()),
    )
    atomic_write(folder / f"{model}_cc.sh", _commands(model, scene))
    atomic_write(
        folder / "ReadMe.md", _readme(model, scene, component.name, inputs is not None, own)
    )
    return folder


def export_cross_check(
    out_dir: Path, models: list[str] | None = None, fmu_dir: Path | None = None
) -> tuple[list[Path], list[str]]:
    """Export ``models`` (default: all) into ``out_dir``; (folders written, models left out
    with the reason). ``fmu_dir``: the built FMUs the scenes' input signals are run with."""
    written, skipped = [], []
    with tempfile.TemporaryDirectory(prefix="mechfmu_xc_") as temp:
        loader = compile_loader(Path(temp) / "loader")
        for model in models or list(MODELS):
            if model not in MODELS:
                raise ValueError(f"unknown model {model!r}; models: {', '.join(MODELS)}")
            staging = Path(temp) / model
            staging.mkdir()
            folder = export_model(model, Path(out_dir), staging, loader, fmu_dir)
            if folder is None:
                skipped.append(
                    f"{model}: its reference scene {REFERENCE_SCENES[model]} has no reference "
                    "of its own component"
                )
            else:
                written.append(folder)
    return written, skipped
