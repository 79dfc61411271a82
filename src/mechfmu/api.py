"""The Python API: scenes run, their references and sweeps, each returned as a pandas
DataFrame.

``simulate`` runs a scene (a shipped scene's name, a scene TOML file or a parsed Scene) on
the built FMUs and returns its recorded variables indexed by time; ``reference`` computes the
closed-form (or scipy-integrated) reference of a shipped scene on the same grid; ``sweep``
runs a parameter sweep and returns one row per point. Units are SI throughout (s, m, rad, N,
Pa, ...); ``df.attrs["units"]`` names the unit of each column.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterable, Mapping, Sequence
from os import PathLike
from pathlib import Path
from typing import Any

import numpy
import pandas

from .cosim import limits
from .cosim.interrupt import InterruptGuard
from .cosim.locate import scene_fmu_folder
from .cosim.master import Simulation, SimulationInterrupted, parameter_values
from .cosim.results import versions
from .cosim.run import choose_scene, simulate as run_simulation
from .cosim.scene import Scene, SceneError, apply_parameters, load_scene

__all__ = ["reference", "simulate", "sweep"]

SceneLike = str | PathLike | Scene
StrPath = str | PathLike


def _plain(value: Any) -> Any:
    """A numpy scalar as the Python number it holds; anything else unchanged."""
    return value.item() if isinstance(value, numpy.generic) else value


def _plain_parameters(parameters: Mapping[str, Any] | None) -> dict[str, Any]:
    """``parameters`` with numpy scalars as Python numbers (apply_parameters
    checks names and values); SceneError when it is not a mapping."""
    if parameters is not None and not isinstance(parameters, Mapping):
        raise SceneError(
            f"parameters must map 'component.parameter' names to values, got "
            f"{type(parameters).__name__} {limits.shortened(parameters)}"
        )
    return {name: _plain(value) for name, value in (parameters or {}).items()}


def _fmu_versions(simulation: Simulation) -> dict[str, dict[str, Any]]:
    return {
        name: {
            "file": str(component.path),
            "model": description.modelName,
            "fmi_version": description.fmiVersion,
            "guid": description.guid,
            "version": description.version,
            "generation_tool": description.generationTool,
            "generated": description.generationDateAndTime,
        }
        for name, component in simulation.components.items()
        for description in [component.description]
    }


def frame(
    times: Sequence[float] | numpy.ndarray,
    columns: Mapping[str, Sequence[float]],
    units: Mapping[str, str | None] | None = None,
    **attrs: Any,
) -> pandas.DataFrame:
    """A result DataFrame: index ``time`` (s, float64), one float64 column per entry of
    ``columns`` in order, ``attrs["units"]`` and the other ``attrs``."""
    table = pandas.DataFrame(
        {name: numpy.asarray(values, dtype=float) for name, values in columns.items()},
        index=pandas.Index(numpy.asarray(times, dtype=float), name="time"),
    )
    table.attrs.update(attrs)
    table.attrs["units"] = {name: (units or {}).get(name) for name in table.columns}
    return table


def simulate(
    scene: SceneLike,
    *,
    parameters: Mapping[str, Any] | None = None,
    start_time: float | None = None,
    stop_time: float | None = None,
    step: float | None = None,
    fmu_dir: StrPath | None = None,
    geometry: bool = False,
) -> pandas.DataFrame:
    """Run ``scene`` and return its recorded variables as a DataFrame.

    ``scene``: the name of a shipped scene (``"gear_retraction"``, found from any working
    directory), a scene TOML file, or a parsed mechfmu.cosim.scene.Scene.
    ``parameters``: {"component.parameter": value} replacing the scene's and the FMUs'
    values (``{"actuator.stroke_time": 2.0}``, in SI units); a constant input the scene
    sets may be given the same way. ``start_time``, ``stop_time`` and ``step`` (s) replace
    the scene's. ``fmu_dir``: the folder of the built FMUs (default: the first of
    $MECHFMU_FMU_DIR, ./fmus, the source checkout's and the user cache that holds them:
    mechfmu.cosim.locate). ``geometry``: switch the geometry effect on in every mechanism
    component and record its outputs (the joints' positions that mechfmu.animate draws).

    Returns a DataFrame indexed by ``time`` (s), one float64 column per recorded variable
    named ``component.variable`` as in the CSV of ``mechfmu run``, and in ``attrs``:
    ``units`` (column -> SI unit), ``scene``, ``scene_file``, ``start_time``, ``stop_time``,
    ``step``, ``coupling``, ``parameters`` (the overrides given), ``components`` (every
    parameter as applied), ``fmus`` (per component: file, model, FMI version, GUID,
    generation tool and date), ``versions`` (Python and packages), ``wall_time_s``,
    ``steps``, ``log`` (the FMUs' messages above ok) and ``check`` (the scene's [check]
    table: ``mechfmu.compare`` applies it when this frame is the reference).

    Raises mechfmu.cosim.scene.SceneError (a ValueError) naming the file and the problem for
    a scene that cannot run: a missing or malformed scene file or table file, an unknown
    component or parameter, FMUs not built, a corrupt FMU (FmuError); and
    mechfmu.cosim.master.SimulationError when a component fails during the run (its
    ``result`` holds the rows computed before). Ctrl-C (SIGINT, in the main thread) stops
    the run between two steps, frees the FMU instances and raises KeyboardInterrupt.
    """
    times: dict[str, float | None] = {
        "start_time": start_time,
        "stop_time": stop_time,
        "step": step,
    }
    if geometry:  # the geometry effect on in every mechanism, its outputs recorded
        from .tools.animate import with_geometry

        scene, times = with_geometry(choose_scene(scene, **times)), {}
    overrides = _plain_parameters(parameters)
    with InterruptGuard() as guard:  # Ctrl-C: taken between steps, every instance freed
        try:
            simulation, result = run_simulation(scene, fmu_dir, overrides, guard, **times)
        except SimulationInterrupted as stopped:
            raise KeyboardInterrupt(str(stopped)) from None
    chosen = simulation.scene
    return frame(
        result.times,
        result.columns,
        result.units,
        scene=chosen.name,
        scene_file=str(chosen.path),
        description=chosen.description,
        start_time=chosen.start_time,
        stop_time=chosen.stop_time,
        step=chosen.step,
        coupling=chosen.coupling,
        parameters=overrides,
        components=parameter_values(simulation),
        fmus=_fmu_versions(simulation),
        versions=versions(),
        wall_time_s=result.meta["wall_time_s"],
        loop_time_s=result.meta.get("loop_time_s"),
        steps=result.meta["steps"],
        log=[entry for entry in result.log if entry["status"] != "ok"],
        check=chosen.check.as_dict() if chosen.check else None,
    )


def configured_scene(
    scene: SceneLike,
    parameters: Mapping[str, Any] | None = None,
    start_time: float | None = None,
    stop_time: float | None = None,
    step: float | None = None,
) -> Scene:
    """The Scene ``scene`` names (a shipped scene's name, a scene file or a Scene, copied)
    with ``parameters`` ({"component.parameter": value}) and the times (s) applied, the
    names checked against the models' declarations: no FMU is needed. SceneError for an
    unknown component or a parameter the model does not declare."""
    from .tools.docs import model_class

    chosen = choose_scene(scene, start_time, stop_time, step)

    def declared(spec: Any) -> tuple[str, list[str]]:
        model: Any = model_class(Path(spec.fmu).stem)
        names = [v.name for v in model.VARIABLES if v.causality == "parameter"]
        return Path(spec.fmu).stem, names

    apply_parameters(chosen, _plain_parameters(parameters), declared)
    return chosen


def reference(
    scene: SceneLike,
    *,
    parameters: Mapping[str, Any] | None = None,
    start_time: float | None = None,
    stop_time: float | None = None,
    step: float | None = None,
) -> pandas.DataFrame:
    """The reference of a shipped scene, computed now from the numpy closed forms (or by
    scipy's solve_ivp at rtol = atol = 1e-12 for the dynamic scenes), as a DataFrame shaped
    like simulate's: index ``time`` (s) at the scene's communication points, one column per
    reference variable, ``attrs["units"]`` from the models' declarations.

    ``scene`` is a shipped scene's name, a scene file or a Scene whose ``name`` is one of
    the shipped scenes with a reference (mechfmu.tools.scene_references.REFERENCES);
    ``parameters`` and the times change it as they change simulate's run, so
    ``reference(s, parameters=p)`` is what ``simulate(s, parameters=p)`` should give. No
    FMU is needed. SceneError for a scene without a reference, an unknown component or
    a parameter the model does not declare.
    """
    from .tools.docs import declared_units
    from .tools.scene_references import REFERENCES, sample_times

    overrides = _plain_parameters(parameters)
    chosen = configured_scene(scene, overrides, start_time, stop_time, step)
    build = REFERENCES.get(chosen.name)
    if build is None:
        raise SceneError(
            f"scene {chosen.name} ({chosen.path}) has no closed-form reference; "
            f"scenes with one: {', '.join(REFERENCES)}"
        )
    columns = build(chosen)
    return frame(
        sample_times(chosen),
        columns,
        declared_units(chosen),
        scene=chosen.name,
        scene_file=str(chosen.path),
        start_time=chosen.start_time,
        stop_time=chosen.stop_time,
        step=chosen.step,
        parameters=overrides,
        kind="reference",
        check=chosen.check.as_dict() if chosen.check else None,
    )


def _varies(vary: Mapping[str, Sequence[float]] | Iterable[str]) -> list:
    from .tools.sweep import SweepError, Vary, parse_vary

    if isinstance(vary, str):
        vary = [vary]
    if isinstance(vary, Mapping):
        varies = []
        for name, bounds in vary.items():
            component, dot, variable = str(name).partition(".")
            values = list(bounds) if isinstance(bounds, (tuple, list)) else None
            if not dot or values is None or len(values) not in (2, 3):
                raise SweepError(
                    f"vary: {name!r}: {bounds!r} must be (start, stop, count) "
                    f"or (start, stop) for sampling, keyed by "
                    f"component.parameter"
                )
            text = f"{name}=" + ":".join(str(_plain(v)) for v in values)
            parsed = parse_vary(text)
            varies.append(Vary(component, variable, parsed.start, parsed.stop, parsed.count))
        return varies
    return [parse_vary(text) for text in vary]


def sweep(
    scene: StrPath,
    vary: Mapping[str, Sequence[float]] | Iterable[str] | None = None,
    metrics: Iterable[str] | None = None,
    *,
    links: Iterable[str] = (),
    samples: int | None = None,
    seed: int | None = None,
    method: str | None = None,
    stop_time: float | None = None,
    step: float | None = None,
    jobs: int | None = None,
    fmu_dir: StrPath | None = None,
    out_dir: StrPath | None = None,
    scheduler: str | None = None,
) -> pandas.DataFrame:
    """Run a parameter sweep (as ``mechfmu sweep``) and return one row per point.

    ``scene``: a shipped sweep's or scene's name, a sweep or scene TOML file. ``vary``:
    {"component.parameter": (start, stop, count)} for a grid (numpy.linspace per
    parameter; ``(start, stop)`` with ``samples``), or the command line's strings
    ``"component.parameter=START:STOP:COUNT"``; ``metrics``: the command line's metric
    names (``"max:gear.gear_angle"``, ``"first_time_above:c.v:THRESHOLD"``, ...); ``links``:
    ``"c.p=FACTOR*c.varied"``. A sweep file gives any of them that are not passed here.
    ``samples``, ``seed``, ``method`` ("lhs" or "random"): sampling instead of the grid;
    ``stop_time``, ``step`` (s) replace the scene's; ``jobs`` local processes (default:
    the cores) or a Dask ``scheduler`` ("tcp://HOST:PORT"); ``out_dir`` keeps sweep.csv and
    sweep.json (default: a temporary folder, removed).

    Returns a DataFrame indexed by the point's ``index`` (in grid or sample order), with one
    column per varied and linked parameter, one per metric (NaN when the event never
    happens or the point failed), ``error`` (None, or the failed point's message),
    ``wall_time_s`` and ``worker``; ``attrs`` holds the sweep's summary (sweep.json).
    Raises mechfmu.tools.sweep.SweepError or SceneError (ValueErrors) for a sweep that
    cannot start.
    """
    from .tools.sweep import (
        SCENE_OVERRIDES,
        definition,
        locate,
        parse_link,
        parse_metric,
        read_sweep_table,
        run_sweep,
    )

    if not isinstance(scene, (str, PathLike)):
        raise TypeError(
            f"sweep: scene must be a sweep or scene file or a shipped one's name, "
            f"got {type(scene).__name__}"
        )
    chosen = definition(locate(str(scene)))
    if vary is not None:
        chosen["varies"] = _varies(vary)
    if metrics is not None:
        chosen["metrics"] = [
            parse_metric(text) for text in ([metrics] if isinstance(metrics, str) else metrics)
        ]
    if links:
        chosen["links"] = [
            parse_link(text) for text in ([links] if isinstance(links, str) else links)
        ]
    for key, value in (("samples", samples), ("seed", seed), ("method", method)):
        if value is not None:
            chosen[key] = value
    chosen["overrides"] = {
        **chosen["overrides"],
        **{
            key: value
            for key, value in (("stop_time", stop_time), ("step", step))
            if value is not None and key in SCENE_OVERRIDES
        },
    }
    folder = scene_fmu_folder(load_scene(chosen["scene_path"], chosen["overrides"]), fmu_dir)
    with tempfile.TemporaryDirectory(prefix="mechfmu-sweep-") as scratch:
        summary = run_sweep(
            **chosen,
            out_dir=Path(out_dir or Path(scratch) / "sweep"),
            jobs=jobs,
            fmu_dir=str(folder),
            progress=False,
            scheduler=scheduler,
        )
        table = read_sweep_table(summary["csv"])
    table = table.set_index("index").sort_index()
    table.attrs.update(summary)
    if out_dir is None:
        table.attrs["csv"] = None
    return table
