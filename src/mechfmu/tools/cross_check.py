"""``mechfmu export-cross-check DIR``: our FMUs with their reference results, laid out as the
Modelica Association's fmi-cross-check repository wants test FMUs (host side).

For each model, in ``DIR/fmus/2.0/cs/linux64/mechfmu/<version>/<Model>/``:

- ``<Model>.fmu``: the model built with the start values its component has in the model's
  reference scene (describe.REFERENCE_SCENES): its parameters, effects and fixed inputs, since
  a cross-check run sets nothing but the inputs of ``_in.csv``;
- ``<Model>_ref.csv``: every output, from the scene's reference computed on the exported grid
  (numpy closed forms, scipy integrations: never an FMU run; reference_columns), or, for the
  outputs it has no column for (solver diagnostics; the outputs of effects the scene leaves
  off, which hold their start values), the FMU's own values as fmpy runs it;
- ``<Model>_in.csv`` (models with inputs): every input as our master feeds it in the scene;
- ``<Model>_ref.opt``: start time, stop time, the exported step and a relative tolerance;
- ``<Model>_cc.sh``: the mechfmu commands that made the files; ``ReadMe.md``: what the model
  is, where the reference comes from, and the FMU's documentation (documentation/index.html).

Models without a reference CSV of their own component (HydraulicActuator: its reference scene
uses the landing gear's built-in actuator) are left out, and the command says so. The tables
have MAX_ROWS rows (fmpy's cross-check marks longer ones; the repository allows 1 MB per
file): the exported run takes MAX_ROWS - 1 steps (export_scene), and the FMU's
DefaultExperiment gives that step to the importing tool.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fmpy import read_model_description

from .. import __version__
from ..cosim.files import atomic_write
from ..cosim.master import Simulation
from ..cosim.results import csv_writer
from ..cosim.scene import SCENE_DIR, ComponentSpec, Scene, load_scene
from ..cosim.variables import start_value
from .scene_references import REFERENCES, sample_times
from ..packaging.build import build_model, compile_loader
from ..packaging.describe import REFERENCE_SCENES
from ..runtime.models import MODELS

TOOL, PLATFORM = "mechfmu", "linux64"
MAX_ROWS = 1000  # rows of a CSV (fmpy's cross-check marks longer ones)
REL_TOL = 1e-6  # the _ref.opt tolerance (our FMUs integrate with their own rtol parameters)


def model_folder(out_dir: Path, model: str) -> Path:
    """Where ``model``'s files go in the cross-check layout."""
    return Path(out_dir) / "fmus" / "2.0" / "cs" / PLATFORM / TOOL / __version__ / model


def component_of(scene: Scene, model: str) -> ComponentSpec | None:
    """The scene's component that is ``model``, or None."""
    return next((spec for spec in scene.components.values() if Path(spec.fmu).stem == model), None)


def _table(columns: dict[str, Any]) -> Callable[[Any], None]:
    """The CSV of ``columns`` ('time' and the signals; floats exact) for atomic_write: the
    result CSV's writer (cosim.results.csv_writer)."""
    return csv_writer(columns["time"], {n: v for n, v in columns.items() if n != "time"})


def export_scene(scene: Scene) -> Scene:
    """The scene at the exported step, recording everything: MAX_ROWS - 1 steps from its
    start to its stop time, the grid on which fmpy's cross-check draws its band around a
    reference (np.linspace of MAX_ROWS points), so that a value it compares lies on it; and
    a step finer than most scenes': a cross-check tool sets each step's inputs at its start
    (mechfmu's master at its end, from the components already stepped), and the finer step
    keeps that lag small."""
    step = (scene.stop_time - scene.start_time) / (MAX_ROWS - 1)
    return dataclasses.replace(scene, step=step, record=None)


def input_columns(
    scene: Scene, component: ComponentSpec, variables: list[Any], fmu_dir: Path | None
) -> dict[str, list[float]] | None:
    """Every input among the FMU's ``variables`` (its model description's) over the exported
    grid, as mechfmu's master feeds it in the scene (a fixed input: its value throughout);
    None for a model without inputs."""
    inputs = [v for v in variables if v.causality == "input"]
    if not inputs:
        return None
    fed = {
        c.input: f"{c.source}.{c.output}" for c in scene.connections if c.target == component.name
    }
    fine = export_scene(scene)
    run = Simulation(dataclasses.replace(fine, record=list(fed.values())), fmu_dir).run()
    columns: dict[str, list[float]] = {"time": run.times}
    for variable in inputs:
        if variable.name in fed:
            columns[variable.name] = run.columns[fed[variable.name]]
        else:
            columns[variable.name] = [float(start_value(variable))] * len(run.times)
    return columns


def reference_columns(
    scene: Scene,
    component: ComponentSpec,
    fmu: Path,
    variables: list[Any],
    inputs: dict[str, list[float]] | None,
) -> tuple[dict[str, list[float]], list[str]]:
    """(every numeric output of the FMU ``fmu`` (among its model description's ``variables``)
    over the exported grid, the outputs that have no closed form): the scene's reference
    computed again on that grid (tools/scene_references:
    numpy closed forms and scipy integrations, never an FMU run); where it has no column for
    an output (solver diagnostics such as iteration counts, residuals, work counters; a few
    energies), the exported FMU's own values, run by fmpy as a cross-check tool runs it (with
    the inputs ``inputs``)."""
    import numpy as np
    from fmpy import simulate_fmu

    fine = export_scene(scene)
    closed = REFERENCES[scene.name](fine)
    times = list(sample_times(fine))
    outputs = [v.name for v in variables if v.causality == "output" and v.type != "String"]
    prefix = f"{component.name}."
    own = [name for name in outputs if prefix + name not in closed]
    values: dict[str, Any] = {}
    if own:
        table = None
        if inputs is not None:
            names = list(inputs)
            table = np.array(list(zip(*inputs.values())), dtype=[(n, float) for n in names])
        run = simulate_fmu(
            str(fmu), stop_time=fine.stop_time, input=table, output=own, validate=False
        )
        if len(run) != len(times):
            raise ValueError(f"{fmu.name}: fmpy ran {len(run)} points, the grid has {len(times)}")
        values = {name: list(run[name].astype(float)) for name in own}
    columns = {"time": times}
    for name in outputs:
        columns[name] = list(closed[prefix + name]) if name not in own else values[name]
    return columns, own


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
- `{model}_ref.csv` is the reference of that scene (as `mechfmu references` computes it: numpy
  closed forms, scipy integrations; never an FMU run) on the exported grid, from
  {scene.start_time} s to {scene.stop_time} s{
        "; the outputs " + ", ".join(f"`{name}`" for name in own) + " have none (solver "
        "diagnostics, counters; the outputs of effects the scene leaves off, at their start "
        "values): their columns are this FMU's own values, run by fmpy as a cross-check tool "
        "runs it"
        if own
        else ""
    }.
{
        "- `" + model + "_in.csv` holds the signals mechfmu's master feeds the FMU in that scene."
        if has_inputs
        else ""
    }
- Step size {export_scene(scene).step!r} s (`{model}_ref.opt`, and the FMU's DefaultExperiment):
  {MAX_ROWS - 1} steps from start to stop, finer than the scene's {scene.step!r} s for most
  models, since a cross-check tool sets each step's inputs at its start (mechfmu's master at
  its end, from the components already stepped).
- `{model}_cc.sh` has the commands.
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
    step = export_scene(scene).step
    fmu = build_model(
        model,
        folder,
        staging,
        loader=loader,
        starts=starts_of(component),
        experiment={"stepSize": step},
    )
    variables = read_model_description(str(fmu)).modelVariables  # read once for both
    inputs = input_columns(scene, component, variables, fmu_dir)
    reference, own = reference_columns(scene, component, fmu, variables, inputs)
    atomic_write(folder / f"{model}_ref.csv", _table(reference))
    if inputs is not None:
        atomic_write(folder / f"{model}_in.csv", _table(inputs))
    options = {
        "StartTime": scene.start_time,
        "StopTime": scene.stop_time,
        "StepSize": step,
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
