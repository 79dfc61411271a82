"""The ``mechfmu`` command line: one argparse tree, every verb and option declared here.

Each verb calls one function of the package (imported when the verb runs, so ``mechfmu
run`` never loads the study's or the benchmarks' code). The scripts in sims/ call
``script_main`` with their verb.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import argparse
import os
import sys
import tempfile
from collections.abc import Iterable
from pathlib import Path

from . import __version__
from .cosim.scene import REFERENCE_DIR, SCENE_DIR, SWEEP_DIR
from .cosim import limits
from .cosim.text import one_line

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .cosim.files import OutputError
    from .cosim.interrupt import InterruptGuard
    from .cosim.master import SimulationError
    from .cosim.scene import SceneError

DESCRIPTION = (
    "Mechanism models as FMI co-simulation FMUs: build them, run scenes, check results "
    "against their references. 'mechfmu VERB --help' describes a verb."
)
# The FMUs are found by one rule (cosim/locate.py) unless --fmu-dir names the folder.
FMU_DIR_HELP = (
    "folder of the built FMUs (default: the first of $MECHFMU_FMU_DIR, ./fmus, this "
    "checkout's fmus/ and the user cache of 'mechfmu build' that holds them)"
)


def parse_assignments(texts: list[str]) -> dict[str, Any]:
    """``--set`` values: each ``component.parameter=value`` as {name: value}, the value read
    as a TOML value when it parses as one (``2.5``, ``true``, ``"cycloidal"``, ``[1, 2]``),
    else taken as a bare string (``cycloidal``). ValueError naming the text for one without
    ``=`` or without a name, or a value beyond mechfmu.cosim.limits (nesting, digits); the
    names and values are checked against the scene and its
    FMUs where they are applied (cosim.scene.apply_parameters), as the API's are."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # Python 3.10
        import tomli as tomllib

    assignments: dict[str, Any] = {}
    for text in texts:
        name, sep, value = text.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise ValueError(
                f"--set {text!r}: expected component.parameter=value (e.g. "
                f"actuator.stroke_time=2.5)"
            )
        problem = limits.scan_problem(value, limits.MAX_TOML_DEPTH, "toml")
        if problem:  # before tomllib, whose recursion a deep value would exhaust
            raise ValueError(f"--set {limits.shortened(text)}: {problem.split(': ', 1)[-1]}")
        try:
            assignments[name] = tomllib.loads(f"value = {value}")["value"]
        except tomllib.TOMLDecodeError:
            assignments[name] = value
    return assignments


def _fmu_folder(args: argparse.Namespace, models: Iterable[str], what: str) -> bool:
    """Set ``args.fmu_dir`` to the folder of ``models`` by the one rule (cosim/locate.py);
    False, having printed the error (every folder tried), when none holds them."""
    from .cosim.locate import fmu_folder
    from .cosim.scene import SceneError

    try:
        args.fmu_dir = str(fmu_folder(models, args.fmu_dir, what))
    except SceneError as error:
        print(f"{what} error: {error}", file=sys.stderr)
        return False
    return True


def _build(args: Any) -> int:
    from .cosim.locate import user_cache
    from .packaging.build import build_all
    from .runtime.models import MODELS

    unknown = [name for name in args.models if name not in MODELS]
    if unknown:
        print(
            f"build error: unknown model(s) {', '.join(unknown)}; models: {', '.join(MODELS)}",
            file=sys.stderr,
        )
        return 2
    out = args.out or user_cache()
    for path in build_all(
        out,
        args.models or None,
        fmi_version=args.fmi_version,
        embed_python=args.embed_python,
        compile_core=not args.no_compile,
    ):
        print(f"built {path}")
    return 0


def _scene_failure(
    error: SimulationError | SceneError | OutputError, guard: InterruptGuard | None = None
) -> int:
    """Exit status and message for a scene that could not run: 2 for a scene or output error,
    1 for a failed simulation (whose partial results and any older result moved aside are
    named), 130/143 when SIGINT/SIGTERM stopped it (``guard``: the command's InterruptGuard)."""
    from .cosim.files import OutputError
    from .cosim.interrupt import exit_code
    from .cosim.master import SimulationInterrupted
    from .cosim.scene import SceneError

    if isinstance(error, (SceneError, OutputError)):
        kind = "scene" if isinstance(error, SceneError) else "output"
        print(f"{kind} error: {one_line(str(error))}", file=sys.stderr)
        return exit_code(guard.take()) if guard is not None and guard.requested else 2
    interrupted = isinstance(error, SimulationInterrupted)
    print(f"{'' if interrupted else 'simulation failed: '}{error}", file=sys.stderr)
    for path in getattr(error, "moved_aside", ()):
        print(f"older complete result moved aside: {path}", file=sys.stderr)
    for kind, path in error.paths.items():
        print(f"partial {kind}: {path}", file=sys.stderr)
    if getattr(error, "output_error", None) is not None:
        print(f"output error: {error.output_error}", file=sys.stderr)
    return exit_code(error.signum) if isinstance(error, SimulationInterrupted) else 1


def _run(args: argparse.Namespace) -> int:
    # Ctrl-C and SIGTERM are noted from here on and taken between steps (cosim.interrupt).
    from .cosim.interrupt import InterruptGuard

    with InterruptGuard() as guard:
        return _run_guarded(args, guard)


def _run_guarded(args: argparse.Namespace, guard: InterruptGuard) -> int:
    from .cosim.scene import find_file

    problem = None
    if not args.all and args.scene is None:
        problem = (
            "name a scene (a shipped scene's name, which 'mechfmu scenes' lists, or a scene "
            "file) or give --all to run every shipped scene"
        )
    elif args.all and args.scene is not None:
        problem = f"give a scene ({args.scene}) or --all, not both"
    elif args.all and args.reference:
        problem = (
            "--reference names one scene's reference; with --all use --check (each scene "
            "against its own)"
        )
    elif args.all and args.set:
        problem = "--set changes one scene's parameters; name the scene instead of --all"
    elif args.all and (args.checkpoint or args.resume):
        problem = "--checkpoint and --resume name one scene's checkpoint; not with --all"
    try:
        args.parameters = parse_assignments(args.set)
    except ValueError as error:
        problem = str(error)
    if problem:
        print(f"mechfmu run: error: {problem}", file=sys.stderr)
        return 2
    if args.all:
        return _run_all(args, guard)
    if args.reference:  # a bad --reference costs nothing: read before the run
        from .io import read_result

        try:
            read_result(args.reference)
        except ValueError as error:
            print(f"check error: {error}", file=sys.stderr)
            return 2
    return _run_one(args, guard, find_file(args.scene))


def _run_all(args: argparse.Namespace, guard: InterruptGuard) -> int:
    """``mechfmu run --all``: every shipped scene into --out, in name order, one after the
    other; a failing scene does not stop the others. Exit status: the worst of the scenes'
    (0 all ran, and matched their references with --check; 1 a run failed or a check did not
    match; 2 a scene or output error), or 130/143 at once when SIGINT/SIGTERM stops it."""
    from .cosim.files import OutputError, output_folder
    from .cosim.interrupt import exit_code

    try:
        output_folder(args.out)  # a bad --out costs nothing
    except OutputError as error:
        print(f"output error: {error}", file=sys.stderr)
        return 2
    scenes = sorted(SCENE_DIR.glob("*.toml"))
    statuses = {}
    for path in scenes:
        statuses[path.stem] = status = _run_one(args, guard, path)
        if status > 2:  # a signal stopped the run: the remaining scenes do not start
            return status
        if guard.requested:
            return exit_code(guard.take())
    failed = [name for name, status in statuses.items() if status]
    print(
        f"ran {len(scenes)} shipped scene(s) into {args.out}: "
        f"{len(scenes) - len(failed)} ok"
        + (f", {len(failed)} not: {', '.join(failed)}" if failed else ""),
        file=sys.stderr if failed else sys.stdout,
    )
    return max(statuses.values(), default=0)


def _run_one(args: argparse.Namespace, guard: InterruptGuard, scene_path: Path) -> int:
    from .check import run_report
    from .cosim.files import OutputError
    from .cosim.interrupt import exit_code, signal_name
    from .cosim.master import SimulationError
    from .cosim.run import run_scene
    from .cosim.scene import Scene, SceneError, load_scene

    try:
        scene: Path | Scene = scene_path
        if getattr(args, "animate", None):
            from .tools.animate import with_geometry

            scene = with_geometry(load_scene(scene_path))
        result, paths = run_scene(
            scene,
            args.out,
            args.fmu_dir,
            plot=not args.no_plot,
            guard=guard,
            parameters=getattr(args, "parameters", None),
            checkpoints=_checkpoints(args),
            resume=Path(args.resume) if args.resume else None,
            fmt=getattr(args, "format", "csv"),
            max_output=getattr(args, "max_output", None),
        )
    except (SceneError, OutputError, SimulationError) as error:
        return _scene_failure(error, guard)
    if guard.requested:  # the signal came after the last step, while the files were written
        print(
            f"interrupted by {signal_name(guard.take())} after the last step; the results "
            f"are complete: {', '.join(str(path) for path in paths.values())}",
            file=sys.stderr,
        )
        return exit_code(guard.signum)
    reference = args.reference or (result.scene.reference if args.check else None)
    label = "reference"
    with tempfile.TemporaryDirectory(prefix="mechfmu-reference-") as scratch:
        try:
            if args.check and args.parameters and not args.reference and reference:
                # the shipped CSV is for the scene's own parameters: computed afresh for these
                reference = _recomputed_reference(result.scene, Path(scratch))
                label = "reference recomputed for --set"
            lines, comparison = run_report(result, paths, reference, args.rtol, args.atol, label)
        except ValueError as error:  # a malformed reference CSV (ResultFileError names it)
            print(f"check error: {error}", file=sys.stderr)
            for kind, path in paths.items():
                print(f"  {kind}: {path}", file=sys.stderr)
            return 2
    print("\n".join(lines))
    note = ended_note(result.meta)
    if note:
        print(note)
    status = 0 if comparison is None or comparison.ok else 1
    if getattr(args, "animate", None):
        data = paths.get("csv") or paths["parquet"]
        animation = data.with_suffix("." + args.animate)
        return max(status, _animate_result(data, animation))
    return status


def _animate_result(
    result: Path | str,
    out: Path | str,
    speed: float = 1.0,
    fps: float | None = None,
    panels: list[str] | None = None,
    width: int | None = None,
) -> int:
    """Write the animation of the result CSV ``result`` to ``out`` and say so; the exit
    status (2 when it cannot be animated or written)."""
    from .cosim.files import OutputError
    from .tools.animate import DEFAULT_FPS, DEFAULT_WIDTH, animate, speed_hint

    try:
        animation = animate(
            result,
            speed=speed,
            fps=DEFAULT_FPS if fps is None else fps,
            panels=panels or (),
            width=DEFAULT_WIDTH if width is None else width,
        )
        path = animation.save(out)
    except (ValueError, OutputError) as error:  # AnimationError, ResultFileError
        print(f"animate error: {error}", file=sys.stderr)
        return 2
    times = animation.frame_times
    print(
        f"  animation: {path} ({len(animation)} frames at {animation.fps:g} frames/s, "
        f"speed {animation.schedule.speed:g}: t = {times[0]:g} .. {times[-1]:g} s)"
    )
    hint = speed_hint(animation)
    if hint:
        print(f"  note: {hint}")
    return 0


def _animate(args: argparse.Namespace) -> int:
    out = args.out or Path(args.result).with_suffix(".gif")
    return _animate_result(args.result, out, args.speed, args.fps, args.panel, args.width)


def _recomputed_reference(scene: Any, folder: Path) -> Path:
    """The closed-form reference of ``scene`` (its parameters as set) as a CSV with its JSON
    (the scene's check tolerances) in ``folder``; SceneError (a ValueError) saying what to do
    for a scene without one."""
    from .api import reference
    from .cosim.scene import SceneError
    from .io import write_result

    try:
        table = reference(scene)
    except SceneError as error:
        raise SceneError(
            f"--check with --set compares with the reference computed for the new "
            f"parameters, and {error}; run without --check, or give --reference CSV"
        ) from None
    return write_result(table, folder / f"{scene.name}.csv")


def _checkpoints(args: argparse.Namespace) -> Any:
    """The run's Checkpoints from --checkpoint and --checkpoint-every (None without)."""
    if not args.checkpoint:
        return None
    from .cosim.checkpoint import Checkpoints

    return Checkpoints(Path(args.checkpoint), seconds=args.checkpoint_every)


def ended_note(meta: dict[str, Any]) -> str | None:
    """The note of a run an FMU ended before its stop time (None for the others)."""
    ended = meta.get("ended_by")
    if not ended:
        return None
    said = f": {ended['message']}" if ended.get("message") else ""
    return (
        f"note: component {ended['component']!r} asked to end the simulation at "
        f"t = {ended['time']!r} s{said}; the run ended there, every row kept"
    )


# name: (default output folder, what it shows); each is a function of tools/examples.py
EXAMPLES = {
    "gear": ("out", "nose-gear retraction against the closed form (make run)"),
    "four_bar": ("out", "the coursework four-bar, both circuits, closed form and solver"),
    "slider_crank": ("out", "offset slider-crank at 3000 rpm on the constraint solver"),
    "suspension": ("out", "suspension load ramp past the limit load: snap-through"),
    "suspension_dynamics": ("out", "road bump and sudden load against solve_ivp"),
    "valve_train": ("out", "valve train forward, inverse and valve float"),
    "camshaft": ("out", "a whole camshaft's torque, firing order against wrong sequences"),
    "sweeps": ("out/sweeps", "the shipped sweeps against their references (make sweeps)"),
}


def _example(args: Any):
    from .cosim.files import OutputError
    from .cosim.master import SimulationError
    from .cosim.scene import SceneError
    from .tools import examples

    try:
        return getattr(examples, args.example)(args)
    except (SceneError, SimulationError, OutputError) as error:
        return _scene_failure(error)


def _export_ssp(args: argparse.Namespace) -> int:
    from .cosim.files import OutputError
    from .cosim.scene import SceneError, find_file
    from .tools.ssp import export_ssp, summary

    try:
        path = export_ssp(find_file(args.scene), args.out, args.fmu_dir)
    except (SceneError, OutputError) as error:
        return _scene_failure(error)
    print(f"wrote {path}: {summary(path)}")
    return 0


def _export_fmu(args: Any):
    from .cosim.scene import SceneError, find_file
    from .tools.container import export_scene_fmu

    schedule = {"scene": None, "sequential": True, "parallel": False}[args.schedule]
    try:
        summary = export_scene_fmu(find_file(args.scene), args.out, args.fmu_dir, schedule)
    except SceneError as error:
        return _scene_failure(error)
    mode = (
        "sequential (Gauss-Seidel in this order)"
        if summary.sequential
        else "parallel (every link one step late)"
    )
    print(
        f"wrote {summary.path}: {len(summary.components)} FMUs "
        f"({', '.join(summary.components)}), {mode}, step {summary.step!r} s, "
        f"outputs: {', '.join(summary.outputs)}"
    )
    return 0


def _check(args: Any) -> int:
    from .check import check_paths
    from .comparison import check_tolerance_value, parse_tolerance
    from .cosim.files import OutputError

    try:
        tolerances: dict[str, Any] = dict(parse_tolerance(text) for text in args.tol)
        for name, value in (
            ("--rtol", args.rtol),
            ("--atol", args.atol),
            ("--time-tolerance", args.time_tolerance),
        ):
            check_tolerance_value(name, value)
        if args.time_tolerance is not None and args.method != "tube":
            raise ValueError("--time-tolerance is the tube's: give --method tube with it")
    except ValueError as error:
        print(f"check error: {error}", file=sys.stderr)
        return 2
    run = check_paths(
        args.result,
        args.reference or REFERENCE_DIR,
        rtol=args.rtol,
        atol=args.atol,
        method=args.method,
        time_tolerance=args.time_tolerance,
        tolerances=tolerances,
        interpolate=args.interpolate,
        ignore_extra=args.ignore_extra,
    )
    for check in run.files:
        print(one_line(check.line()))
    for key in run.unused_tolerances():
        print(f"check warning: --tol {key} matches no column", file=sys.stderr)
    print(run.summary(), file=sys.stderr if run.error else sys.stdout)
    try:
        if args.junit:
            from .tools.report.checks import write_junit

            print(f"junit: {write_junit(run, args.junit)}")
        if args.report:
            from .tools.report.checks import write_report

            print(f"report: {write_report(run, args.report)}")
    except OutputError as error:
        print(f"output error: {error}", file=sys.stderr)
        return 2
    return run.exit_code


def _baseline_update(args: argparse.Namespace) -> int:
    from .baseline import BaselineError, summary, update_baselines
    from .cosim.files import OutputError

    try:
        changes = update_baselines(
            args.results, args.baselines, prune=args.prune, dry_run=args.dry_run
        )
    except (BaselineError, OutputError) as error:
        print(f"baseline error: {error}", file=sys.stderr)
        return 2
    for change in changes:
        print(change.line())
    print(summary(changes, args.baselines, args.dry_run))
    return 0


def _references(args: Any) -> int:
    from .cosim.files import OutputError, output_folder
    from .tools.scene_references import generate, generate_tables

    try:
        for path in generate(args.scenes, output_folder(args.out)):
            print(f"wrote {path} (and its JSON)")
        if args.tables is not None:
            for path in generate_tables(output_folder(args.tables)):
                print(f"wrote {path}")
    except OutputError as error:
        print(f"output error: {error}", file=sys.stderr)
        return 2
    return 0


def _scenes(args: argparse.Namespace) -> int:
    """``mechfmu scenes``: one line per shipped scene (name, stop time, components, the
    first line of its description), then where the files and references are."""
    from .cosim.scene import SceneError, load_scene

    rows = []
    scenes = []
    for path in sorted(SCENE_DIR.glob("*.toml")):
        try:
            scenes.append(scene := load_scene(path))
        except SceneError as error:  # a shipped scene is never malformed; say so if it is
            print(f"scene error: {error}", file=sys.stderr)
            return 2
        components = ", ".join(f"{name} ({spec.fmu})" for name, spec in scene.components.items())
        summary = " ".join(scene.description.split()).split(". ")[0].rstrip(".")
        rows.append((scene.name, f"{scene.stop_time:g} s", components, summary))
    if args.tolerances:
        print(tolerance_table(scenes))
        return 0
    widths = [max(len(row[i]) for row in rows) for i in range(2)]
    for name, stop, components, summary in rows:
        print(f"{name:{widths[0]}}  {stop:>{widths[1]}}  {components}")
        print(f"{'':{widths[0]}}  {'':>{widths[1]}}  {summary}")
    print(
        f"\n{len(rows)} shipped scenes in {SCENE_DIR}, their references in {REFERENCE_DIR}; "
        f"'mechfmu run NAME' runs one, 'mechfmu run --all --check' all of them"
    )
    return 0


def tolerance_table(scenes: list[Any]) -> str:
    """Markdown: each scene's check tolerances (its [check] table) and what they rest on."""
    lines = [
        "| scene | rtol | atol | method | why |",
        "|---|---|---|---|---|",
    ]
    for scene in scenes:
        check = scene.check
        if check is None:
            lines.append(f"| `{scene.name}` | | | | no reference: not checked |")
            continue
        per_column = [name for name, entry in check.columns.items() if entry.atol is not None]
        atol = f"{check.atol:g}" + (f"; per column ({len(per_column)})" if per_column else "")
        method = check.method + (
            f", {check.time_tolerance:g} s" if check.time_tolerance is not None else ""
        )
        why = " ".join(check.why.split()).replace("|", "\\|")
        lines.append(f"| `{scene.name}` | {check.rtol:g} | {atol} | {method} | {why} |")
    return "\n".join(lines)


def _report(args: Any) -> int:
    from .tools.report.seed_report import write_report

    print(f"wrote {write_report(args.out)}")
    return 0


def _docs(args: Any) -> int:
    from .cosim.scene import find_file
    from .tools.docs import interface_tables, reference_plot

    try:
        if args.reference_plot:
            if not args.out:
                print("docs error: --reference-plot needs --out FILE.png", file=sys.stderr)
                return 2
            print(f"wrote {reference_plot(find_file(args.reference_plot), args.out)}")
        else:
            print(interface_tables(args.models))
    except BrokenPipeError:  # the reader stopped: main() ends quietly
        raise
    except (OSError, ValueError) as error:
        print(f"docs error: {error}", file=sys.stderr)
        return 2
    return 0


def _cam_setup_failure(error: Exception) -> int:
    print(f"cam error: {error}", file=sys.stderr)
    return 2


def _cam_profile(args: argparse.Namespace) -> int:
    from .cosim.files import OutputError
    from .cosim.scene import SceneError
    from .runtime.errors import MechanismError
    from .tools.cam_design import cam_profile, summary_markdown, write_cam_files

    try:
        table = cam_profile(args.scene, parse_assignments(args.set), args.component, args.points)
        paths = write_cam_files(table, args.out)
    except OutputError as error:
        print(f"output error: {error}", file=sys.stderr)
        return 2
    except (SceneError, MechanismError, ValueError) as error:
        return _cam_setup_failure(error)
    print(summary_markdown(table), end="")
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    return 1 if table.attrs["design"]["problems"] else 0


def _cam_size(args: argparse.Namespace) -> int:
    from .cosim.scene import SceneError
    from .runtime.errors import MechanismError
    from .tools.cam_design import cam_setup_of, smallest_base_circle

    try:
        setup = cam_setup_of(args.scene, parse_assignments(args.set), args.component)
        sizing = smallest_base_circle(setup, args.min_radius_of_curvature)
    except (SceneError, MechanismError, ValueError) as error:
        return _cam_setup_failure(error)
    where = "" if sizing.angle != sizing.angle else f" at camshaft angle {sizing.angle:.6g} rad"
    print(
        f"{setup.scene.name}.{setup.component} ({setup.follower.kind} follower, "
        f"{setup.profile.law} {setup.parameters['mode']}): smallest cam_base_radius "
        f"{sizing.base_circle_radius!r} m (set by {sizing.limit}{where}); "
        f"now {setup.geometry.cam_base_radius!r} m"
    )
    return 0


def _study(args: argparse.Namespace):
    from .runtime.models import MODELS
    from .tools.parallel import workers_problem
    from .tools.study import command

    problem = workers_problem("--workers", args.workers)
    if problem:
        print(f"study error: {problem}", file=sys.stderr)
        return 2
    if not args.work_precision and not _fmu_folder(args, MODELS, "study"):
        return 2
    return command(args)


def _bench(args: Any):
    from .tools.bench.suite import MODELS_NEEDED, command

    if not _fmu_folder(args, MODELS_NEEDED, "bench"):
        return 2
    return command(args)


def _fuzz(args: Any):
    from .runtime.models import MODELS
    from .tools.fuzz import command

    unknown = [name for name in args.models if name not in MODELS]
    problems = (
        [f"unknown model(s) {', '.join(unknown)}; known: {', '.join(MODELS)}"] if unknown else []
    )
    problems += [
        f"{option} = {value} must be at least 1"
        for option, value in (("--sequences", args.sequences), ("--jobs", args.jobs))
        if value < 1
    ]
    if args.only is not None and not 0 <= args.only < args.sequences:
        problems.append(
            f"--only = {args.only} must lie in [0, {args.sequences - 1}] (a "
            f"sequence index of --sequences {args.sequences})"
        )
    if problems:
        print(f"mechfmu fuzz: error: {problems[0]}", file=sys.stderr)
        raise SystemExit(2)
    if not _fmu_folder(args, args.models or MODELS, "fuzz"):
        return 2
    return command(args)


def _sweep(args: argparse.Namespace) -> int:
    from .tools.sweep import command

    return command(args)


def _at_least_one(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _fmu_dir_option(verb: argparse.ArgumentParser) -> None:
    verb.add_argument("--fmu-dir", metavar="DIR", help=FMU_DIR_HELP)


def _scene_options(verb: argparse.ArgumentParser, out: str = "out", plot: bool = True) -> None:
    """--out, --fmu-dir and --no-plot: the options of every verb that runs scenes."""
    verb.add_argument(
        "--out",
        default=out,
        metavar="DIR",
        help=f"output folder (default: {out}, in the current folder)",
    )
    _fmu_dir_option(verb)
    if plot:
        verb.add_argument("--no-plot", action="store_true", help="skip the PNG (default: write it)")


def _tolerance_options(verb: argparse.ArgumentParser) -> None:
    """--rtol and --atol: replace the reference's declared tolerances."""
    verb.add_argument(
        "--rtol",
        type=float,
        help="relative tolerance (default: the reference's own, declared by its scene's "
        "[check] table and written in the JSON beside it; else 1e-9)",
    )
    verb.add_argument(
        "--atol",
        type=float,
        help="absolute tolerance, in each column's SI unit (default: the reference's own; "
        "else 1e-12)",
    )


def _example_verbs(verbs: argparse._SubParsersAction) -> None:
    example = verbs.add_parser(
        "example",
        help="a worked example: shipped scenes checked "
        "against their references, with what each check found "
        "(sims/run_*.py run these)",
    )
    examples = example.add_subparsers(dest="example", required=True, metavar="NAME")
    for name, (out, what) in EXAMPLES.items():
        verb = examples.add_parser(name, help=what)
        _scene_options(verb, out, plot=name != "sweeps")
        if name == "sweeps":
            verb.add_argument(
                "--quick",
                action="store_true",
                help="a few points of each sweep around its threshold (default: every point)",
            )
            verb.add_argument(
                "--jobs",
                type=_at_least_one,
                default=None,
                help="local worker processes (default: the number of cores)",
            )
            verb.add_argument(
                "--scheduler",
                metavar="tcp://HOST:PORT",
                help="run on this Dask cluster (pip install mechfmu[cluster]; default: "
                "local processes)",
            )
    example.set_defaults(func=_example)


def _set_option(verb: argparse.ArgumentParser) -> None:
    """--set COMPONENT.PARAMETER=VALUE (repeatable), read by parse_assignments."""
    verb.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="COMPONENT.PARAMETER=VALUE",
        help="replace a parameter (or a constant input, or an effect: true/false) of the "
        'scene, in SI units; the value is read as TOML (2.5, true, "text") or as plain '
        "text; repeatable (default: the scene's values)",
    )


def _cam_verb(verbs: argparse._SubParsersAction, name: str, help: str) -> argparse.ArgumentParser:
    """A verb about the cam of a scene's ValveTrain: SCENE, --set, --component."""
    verb = verbs.add_parser(name, help=help)
    verb.add_argument("scene", help="scene TOML file, or the name of a shipped scene")
    _set_option(verb)
    verb.add_argument(
        "--component", help="the ValveTrain component (default: the scene's only one)"
    )
    return verb


def _cam_verbs(verbs: argparse._SubParsersAction) -> None:
    """cam-profile and cam-size: the cam a scene's valve train needs."""
    profile = _cam_verb(
        verbs,
        "cam-profile",
        "the cam of a scene's ValveTrain: profile CSV, DXF (mm), drawing and summary "
        "with the design checks; exit 1 if a check fails (pressure angle), 2 if no cam "
        "can be made (cusp, undercut) or the input is bad",
    )
    profile.add_argument(
        "--points",
        type=int,
        default=3600,
        help="profile points per revolution, 16 to 1000000 (default: 3600, every 0.1 degree)",
    )
    profile.add_argument("--out", default="out", help="output folder (default: out)")
    profile.set_defaults(func=_cam_profile)
    size = _cam_verb(
        verbs,
        "cam-size",
        "the smallest base circle (cam_base_radius) with which a scene's ValveTrain's "
        "cam law and follower make a cam meeting the limits",
    )
    size.add_argument(
        "--min-radius-of-curvature",
        type=float,
        default=0.0,
        metavar="M",
        help="least radius of curvature of the cam surface, m (default: 0, the cusp or "
        "undercut limit itself: add a margin)",
    )
    size.set_defaults(func=_cam_size)


def _measurement_verbs(verbs: argparse._SubParsersAction) -> None:
    """study, bench, fuzz, sweep: the long runs."""
    from .tools.bench import BENCHMARKS, FULL, QUICK

    study = verbs.add_parser("study", help="accuracy study: error against wall time (make study)")
    study.add_argument(
        "--scenes", nargs="*", metavar="NAME", help="study these scenes only (default: all)"
    )
    study.add_argument(
        "--quick",
        action="store_true",
        help="a small corner of the sweep (the 2 coarsest steps, 6 settings; for tests)",
    )
    study.add_argument(
        "--work-precision",
        action="store_true",
        help="instead: our integrators against scipy's solve_ivp on the gear, "
        "suspension and valve right-hand sides (work_precision.csv, "
        "work_precision.md); --quick: 2 tolerances, 1 repeat",
    )
    study.add_argument(
        "--repeats",
        type=_at_least_one,
        default=3,
        help="timed runs per point, median taken (default: 3)",
    )
    study.add_argument(
        "--workers",
        type=_at_least_one,
        default=min(2, os.cpu_count() or 1),
        help="parallel processes, at most 4 per core (default: 2 or the cores there are)",
    )
    study.add_argument(
        "--out", default="data/study", metavar="DIR", help="output folder (default: data/study)"
    )
    study.add_argument(
        "--scene-dir",
        default=str(SCENE_DIR),
        metavar="DIR",
        help="folder of the scene files (default: the shipped scenes)",
    )
    _fmu_dir_option(study)
    study.set_defaults(func=_study)

    bench = verbs.add_parser(
        "bench",
        help="performance benchmarks: master overhead against "
        "fmpy, model cost against null FMUs, effects, the closed-form "
        "floor, a sweep on 1 and 2 workers, the dynamic scenes against "
        "real time, cost growth with the stop time (make bench)",
    )
    bench.add_argument(
        "--repeats",
        type=_at_least_one,
        default=None,
        help=f"measured repeats per case after one warm-up (default: "
        f"{FULL.repeats}, --quick {QUICK.repeats})",
    )
    bench.add_argument(
        "--quick",
        action="store_true",
        help="fewer steps and repeats (for the test; timings are rough)",
    )
    bench.add_argument(
        "--only",
        choices=BENCHMARKS,
        help="run this benchmark alone and print its rows (writes nothing; default: all)",
    )
    bench.add_argument(
        "--out", default="data/bench", metavar="DIR", help="output folder (default: data/bench)"
    )
    _fmu_dir_option(bench)
    _scene_folder_option(bench)
    bench.add_argument(
        "--sweeps",
        default=str(SWEEP_DIR),
        metavar="DIR",
        help="folder of the sweep files (default: the shipped sweeps)",
    )
    bench.add_argument(
        "--sweep-scenes",
        type=_at_least_one,
        default=None,
        help=f"scenes of the sweep benchmark (default: {FULL.sweep_scenes}, "
        f"--quick {QUICK.sweep_scenes})",
    )
    bench.add_argument(
        "--cpu-time",
        action="store_true",
        help="time runs and loops by the process's CPU time, not the wall clock "
        "(a machine shared with other work; FMI-call timers stay on the "
        "wall clock; default: the wall clock)",
    )
    bench.add_argument(
        "--profile",
        action="store_true",
        help="also print cProfile's top 15 functions of each master",
    )
    bench.set_defaults(func=_bench)

    fuzz = verbs.add_parser(
        "fuzz", help="random input sequences through every FMU, each in a child process"
    )
    fuzz.add_argument("models", nargs="*", help="FMU names (default: all)")
    fuzz.add_argument(
        "--sequences",
        type=int,
        default=1000,
        help="random input sequences per FMU (default: 1000)",
    )
    fuzz.add_argument(
        "--seed", type=int, default=0, help="seed of the random sequences (default: 0)"
    )
    _fmu_dir_option(fuzz)
    # the old spelling, kept working: --fmu-dir everywhere now
    fuzz.add_argument("--fmus", dest="fmu_dir", help=argparse.SUPPRESS)
    fuzz.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="FMUs fuzzed at once, each in its own child process (default: the cores)",
    )
    fuzz.add_argument(
        "--only",
        type=int,
        metavar="INDEX",
        help="run only this sequence index, to reproduce a finding (default: all)",
    )
    fuzz.add_argument(
        "--out",
        default="out/fuzz",
        metavar="DIR",
        help="folder for the progress logs (default: out/fuzz)",
    )
    fuzz.set_defaults(func=_fuzz)

    sweep = verbs.add_parser(
        "sweep",
        help="run a scene over a grid or sample of parameter "
        "values on local processes or a Dask cluster, one CSV row of "
        "metrics per point",
    )
    sweep.add_argument(
        "scene", help="sweep or scene TOML file, or the name of a shipped sweep or scene"
    )
    sweep.add_argument(
        "--vary",
        action="append",
        default=[],
        metavar="COMP.PARAM=START:STOP:COUNT",
        help="a parameter (or constant input) and its range; repeat for a grid "
        "(default: the sweep file's)",
    )
    sweep.add_argument(
        "--link",
        action="append",
        default=[],
        metavar="COMP.PARAM=FACTOR*COMP.VARIED",
        help="a parameter that follows a varied one (target = factor * value; default: none)",
    )
    sweep.add_argument(
        "--samples", type=int, help="draw N points instead of the grid (default: the grid)"
    )
    sweep.add_argument(
        "--seed", type=int, help="seed of the sampling, with --samples (default: random)"
    )
    sweep.add_argument(
        "--method",
        choices=("lhs", "random"),
        help="sampling method (default: lhs, Latin hypercube)",
    )
    sweep.add_argument(
        "--metrics",
        nargs="+",
        default=[],
        metavar="NAME",
        help="final:c.v, max:c.v, min:c.v, time_of_max:c.v, "
        "first_time_above:c.v:THRESHOLD, first_time_true:c.v, "
        "max_abs_error:c.v (default: the sweep file's)",
    )
    sweep.add_argument("--out", metavar="DIR", help="output folder (default: out/sweep_<scene>)")
    sweep.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="parallel processes, at most 4 per core (default: the number of cores)",
    )
    sweep.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run on this Dask cluster instead of local processes (pip install "
        "mechfmu[cluster]; default: local processes)",
    )
    sweep.add_argument(
        "--plot", action="store_true", help="one PNG per metric and parameter (default: none)"
    )
    _fmu_dir_option(sweep)
    sweep.add_argument(
        "--retries",
        type=int,
        default=None,
        help="extra attempts of a point whose worker process died, the last one alone (default: 2)",
    )
    sweep.add_argument(
        "--max-points",
        type=int,
        default=limits.MAX_SWEEP_POINTS,
        metavar="N",
        help="refuse a sweep of more than N points before anything runs (default: "
        f"{limits.MAX_SWEEP_POINTS})",
    )
    sweep.add_argument(
        "--format",
        choices=("csv", "parquet"),
        default="csv",
        help="parquet: also write sweep.parquet (the same columns, pyarrow) when the sweep "
        "ends; sweep.csv is written as the points finish either way (default: csv)",
    )
    sweep.add_argument(
        "--resume",
        action="store_true",
        help="continue the stopped sweep in --out: keep its rows without an "
        "error, run the other points (default: start afresh)",
    )
    sweep.set_defaults(func=_sweep)


def _scene_folder_option(verb: argparse.ArgumentParser) -> None:
    verb.add_argument(
        "--scenes",
        default=str(SCENE_DIR),
        metavar="DIR",
        help="folder of the scene files (default: the shipped scenes)",
    )


def _export_cross_check(args: argparse.Namespace) -> int:
    from .cosim.scene import SceneError
    from .tools.cross_check import export_cross_check

    try:
        written, skipped = export_cross_check(Path(args.out), args.models or None, args.fmu_dir)
    except (SceneError, ValueError) as error:
        print(f"mechfmu export-cross-check: error: {error}", file=sys.stderr)
        return 2
    for folder in written:
        print(f"wrote {folder}")
    for reason in skipped:
        print(f"left out {reason}")
    return 0


def _export_verb(
    verbs: argparse._SubParsersAction, name: str, help: str, suffix: str
) -> argparse.ArgumentParser:
    """A verb that writes one scene into one ``suffix`` file for other tools."""
    verb = verbs.add_parser(name, help=help)
    verb.add_argument("scene", help="scene TOML file, or the name of a shipped scene")
    verb.add_argument("out", help=f"the {suffix} file to write")
    _fmu_dir_option(verb)
    return verb


def _animate_verb(verbs: argparse._SubParsersAction) -> None:
    animate = verbs.add_parser(
        "animate",
        help="animate the mechanisms of a result CSV recorded with the geometry effect "
        "(mechfmu run SCENE --animate records it): GIF, MP4 or HTML",
    )
    animate.add_argument("result", help="result CSV (its JSON beside it names the models)")
    animate.add_argument(
        "--out",
        help="the .gif, .mp4 (needs the video extra: imageio-ffmpeg) or .html file to "
        "write (default: RESULT with .gif)",
    )
    animate.add_argument(
        "--speed",
        type=float,
        default=1.0,
        help="playback speed against real time (default 1: real time; 0.01 plays a "
        "hundred times slower)",
    )
    animate.add_argument(
        "--fps", type=float, default=None, help="frames per second (default 25; GIF at most 50)"
    )
    animate.add_argument(
        "--panel",
        action="append",
        default=[],
        metavar="COLUMN",
        help="a result column to plot against time beside the mechanism, with a cursor "
        "(repeatable; default: none)",
    )
    animate.add_argument("--width", type=int, default=None, help="width in pixels (default 720)")
    animate.set_defaults(func=_animate)


def _run_verb(verbs: argparse._SubParsersAction) -> None:
    run = verbs.add_parser(
        "run", help="run a scene (or every shipped scene) and write CSV, JSON and PNG"
    )
    run.add_argument(
        "scene",
        nargs="?",
        help="scene TOML file, or the name of a shipped scene ('mechfmu scenes' lists them)",
    )
    run.add_argument(
        "--all",
        action="store_true",
        help="run every shipped scene into --out (a baseline tree for mechfmu "
        "check); a failing scene does not stop the others",
    )
    _scene_options(run)
    _set_option(run)
    run.add_argument(
        "--check",
        action="store_true",
        help="compare with the scene's reference CSV afterwards, at its declared tolerances",
    )
    run.add_argument(
        "--reference", metavar="CSV", help="compare with this CSV afterwards (one scene)"
    )
    _tolerance_options(run)
    run.add_argument(
        "--checkpoint",
        metavar="FILE",
        help="write a checkpoint of the run to FILE (every --checkpoint-every seconds and "
        "when Ctrl-C or SIGTERM stops it) for --resume (default: none)",
    )
    run.add_argument(
        "--checkpoint-every",
        type=float,
        default=60.0,
        metavar="S",
        help="seconds of wall time between checkpoints; 0: only when stopped (default: 60)",
    )
    run.add_argument(
        "--resume",
        metavar="FILE",
        help="continue the run from this checkpoint (of the same scene and FMUs); the "
        "result equals the uninterrupted run's. A long run's checkpoint continues its "
        "<scene>.partial file: give the same --out and --format (default: start from the "
        "beginning)",
    )
    run.add_argument(
        "--animate",
        nargs="?",
        const="gif",
        choices=("gif", "mp4", "html"),
        help="also record the mechanisms' geometry (the geometry effect) and write "
        "<scene>.gif (or .mp4, .html) into --out, played in real time (default: no "
        "animation; without a format: gif)",
    )
    run.add_argument(
        "--format",
        choices=("csv", "parquet"),
        default="csv",
        help="form of the result's rows: <scene>.csv, or <scene>.parquet (columnar, "
        "pyarrow: pip install 'mechfmu[parquet]'); the same columns and JSON beside "
        "(default: csv)",
    )
    run.add_argument(
        "--max-output",
        metavar="SIZE",
        type=_byte_size,
        default=None,
        help="run even if the result is estimated larger than this, in bytes (500M, 10G, "
        f"4Gi; default: {limits.MAX_RUN_OUTPUT_BYTES // limits.GIB}Gi "
        f"= {limits.MAX_RUN_OUTPUT_BYTES} bytes, a run over it is refused before its first "
        "step)",
    )
    run.set_defaults(func=_run)


def _byte_size(text: str) -> int:
    """A size in bytes from '2000', '1.5e9', '500M', '10G' or '1T' (decimal: k, M, G, T;
    binary: Ki, Mi, Gi, Ti); argparse's error names the text otherwise."""
    units = {"": 1, "k": 10**3, "m": 10**6, "g": 10**9, "t": 10**12}
    units.update({"ki": 2**10, "mi": 2**20, "gi": 2**30, "ti": 2**40})
    raw = text.strip().lower().removesuffix("b")
    number = raw.rstrip("kmgti")
    try:
        value = float(number) * units[raw[len(number) :]]
    except (ValueError, KeyError):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a size in bytes (e.g. 500M, 10G, 2e9)"
        ) from None
    if not 0 < value < 2**63:
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive size below 2^63 bytes")
    return int(value)


def _check_verbs(verbs: argparse._SubParsersAction) -> None:
    check = verbs.add_parser(
        "check",
        help="compare a result CSV (or a folder of them) with a reference CSV (or "
        "folder, matched by relative path); exit 0 all match, 1 any mismatch, 2 nothing "
        "comparable",
    )
    check.add_argument("result", help="result CSV file or folder")
    check.add_argument(
        "reference",
        nargs="?",
        help=f"reference CSV file or folder (default: the shipped scenes' references, "
        f"{REFERENCE_DIR})",
    )
    _tolerance_options(check)
    check.add_argument(
        "--tol",
        action="append",
        default=[],
        metavar="COLUMN=RTOL[,ATOL]",
        help="tolerance of one column (or an fnmatch pattern such as 'gear.*'); "
        "repeatable, the last match wins (default: the reference's own)",
    )
    check.add_argument(
        "--method",
        choices=("pointwise", "tube"),
        help="pointwise (the same time grid) or tube (the reference widened by "
        "--time-tolerance in time) (default: the reference's own, else pointwise)",
    )
    check.add_argument(
        "--time-tolerance",
        type=float,
        metavar="S",
        help="the tube's half width in time, s (default: the reference's own, else its "
        "largest step)",
    )
    check.add_argument(
        "--interpolate",
        action="store_true",
        help="pointwise: interpolate the reference onto the result's times (default: the "
        "same grid)",
    )
    check.add_argument(
        "--ignore-extra",
        action="store_true",
        help="result columns the reference lacks are not failures (default: they are, "
        "unless the reference declares them not compared)",
    )
    check.add_argument("--junit", metavar="FILE", help="write a JUnit XML file (default: none)")
    check.add_argument(
        "--report",
        metavar="DIR",
        help="write DIR/index.html with a plot of every failing column (default: none)",
    )
    check.set_defaults(func=_check)

    baseline = verbs.add_parser("baseline", help="accepted results (baselines) for mechfmu check")
    baseline_verbs = baseline.add_subparsers(dest="baseline_verb", required=True, metavar="VERB")
    update = baseline_verbs.add_parser(
        "update",
        help="accept results as baselines: copy the new and changed CSV files (and "
        "their JSON) and say what changed by how much",
    )
    update.add_argument("results", help="result CSV file or folder (e.g. of mechfmu run --all)")
    update.add_argument("baselines", help="baseline folder (created if missing)")
    update.add_argument(
        "--prune",
        action="store_true",
        help="remove baselines that have no result (default: keep them)",
    )
    update.add_argument(
        "--dry-run", action="store_true", help="only say what would change (default: change it)"
    )
    update.set_defaults(func=_baseline_update)


def parser() -> argparse.ArgumentParser:
    main = argparse.ArgumentParser(prog="mechfmu", description=DESCRIPTION)
    main.add_argument("--version", action="version", version=f"mechfmu {__version__}")
    verbs = main.add_subparsers(dest="verb", required=True, metavar="VERB")

    scenes = verbs.add_parser(
        "scenes",
        help="list the shipped scenes: name, stop time, components, what each shows",
    )
    scenes.add_argument(
        "--tolerances",
        action="store_true",
        help="instead: each scene's check tolerances and what they rest on, as a Markdown "
        "table (default: one entry per scene)",
    )
    scenes.set_defaults(func=_scenes)

    build = verbs.add_parser("build", help="build the FMUs")
    build.add_argument("models", nargs="*", help="model names (default: all)")
    build.add_argument(
        "--out",
        metavar="DIR",
        help="output folder (default: the user cache every command searches, "
        "$XDG_CACHE_HOME/mechfmu/VERSION-pyX.Y)",
    )
    build.add_argument(
        "--fmi-version",
        type=int,
        choices=(2, 3),
        default=2,
        help="FMI 2.0 (pythonfmu) or FMI 3.0 (pythonfmu3) co-simulation (default: 2)",
    )
    build.add_argument(
        "--embed-python",
        action="store_true",
        help="carry this interpreter's libpython and the standard library the "
        "models import, so the FMUs run where no Python is installed (default: use "
        "the host's Python)",
    )
    build.add_argument(
        "--no-compile",
        action="store_true",
        help="leave the valve's exact core as Python source (default: compiled to C by "
        "mypyc where mypy, setuptools and a C compiler are at hand; the same results, "
        "faster)",
    )
    build.set_defaults(func=_build)

    _run_verb(verbs)
    _animate_verb(verbs)
    _example_verbs(verbs)

    export = _export_verb(
        verbs,
        "export-ssp",
        "write a scene as an SSP 1.0 package (the system, its parameters and its FMUs) for "
        "other co-simulation tools",
        ".ssp",
    )
    export.set_defaults(func=_export_ssp)

    container = _export_verb(
        verbs,
        "export-fmu",
        "pack a scene (its FMUs, connections and parameters) into one container FMU (FMI "
        "2.0, fmu-manipulation-toolbox) for tools that take one FMU",
        ".fmu",
    )
    container.add_argument(
        "--schedule",
        choices=("scene", "sequential", "parallel"),
        default="scene",
        help="scene: sequential for gauss_seidel scenes, parallel for jacobi ones; "
        "sequential: each FMU sees the outputs of those stepped before it; parallel: "
        "every link lags one step (default: scene)",
    )
    container.set_defaults(func=_export_fmu)

    cross = verbs.add_parser(
        "export-cross-check",
        help="write the FMUs with their reference results as the fmi-cross-check "
        "repository lays out test FMUs (fmus/2.0/cs/linux64/mechfmu/<version>/<Model>/)",
    )
    cross.add_argument("out", help="the folder to write into (created if missing)")
    cross.add_argument("models", nargs="*", help="model names (default: all)")
    _fmu_dir_option(cross)
    cross.set_defaults(func=_export_cross_check)

    _check_verbs(verbs)

    references = verbs.add_parser(
        "references",
        help="regenerate the shipped scenes' reference CSVs (and their JSON: units and "
        "check tolerances) and their generated input tables",
    )
    _scene_folder_option(references)
    references.add_argument(
        "--out",
        default="reference",
        metavar="DIR",
        help="output folder (default: reference, in the current folder; make references "
        "writes the shipped ones)",
    )
    references.add_argument(
        "--tables",
        default=None,
        metavar="DIR",
        help="also write the scenes' generated input tables, such as the engine's gas force, "
        "into DIR (default: not written; make references writes the shipped ones)",
    )
    references.set_defaults(func=_references)

    report = verbs.add_parser("report", help="write the seed-reproduction report")
    report.add_argument(
        "--out",
        default="data/seed_report.md",
        metavar="FILE",
        help="the Markdown file to write (default: data/seed_report.md)",
    )
    report.set_defaults(func=_report)
    docs = verbs.add_parser(
        "docs",
        help="print FMU interface tables (Markdown), or plot a "
        "scene's reference CSV; make docs builds the site from them",
    )
    docs.add_argument("models", nargs="*", help="models to print (default: all)")
    docs.add_argument(
        "--reference-plot",
        metavar="SCENE",
        help="scene TOML file, or the name of a shipped scene, whose reference to plot "
        "(default: print the tables)",
    )
    docs.add_argument(
        "--out", metavar="FILE", help="PNG file for --reference-plot (required with it)"
    )
    docs.set_defaults(func=_docs)

    _cam_verbs(verbs)
    _measurement_verbs(verbs)
    return main


def _leaf(tree: argparse.ArgumentParser, verb: tuple[str, ...]) -> argparse.ArgumentParser:
    """The parser of the (nested) verb ``verb`` in ``tree``."""
    for word in verb:
        actions = [a for a in tree._actions if isinstance(a, argparse._SubParsersAction)]
        if not actions or word not in actions[0].choices:
            break
        tree = actions[0].choices[word]
    return tree


def main(argv: list[str] | None = None, script: str | None = None) -> int:
    """Run the command line ``argv`` (default: sys.argv[1:]); the exit status. ``script``:
    the sims/ script that runs it (its name is the usage's program name)."""
    tree = parser()
    if script is not None:
        words = tuple(word for word in (argv or []) if not word.startswith("-"))
        _leaf(tree, words[:2]).prog = Path(script).name
    args = tree.parse_args(argv)
    try:
        status = args.func(args)
        sys.stdout.flush()
    except BrokenPipeError:  # the reader went away (mechfmu docs | head): stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except OSError as error:
        # the verbs name the paths they are given; this catches a path the operating system
        # refuses where no verb expected it (a name too long, a folder not searchable): one
        # line, never a traceback
        print(f"mechfmu {args.verb}: error: {_os_error_text(error)}", file=sys.stderr)
        return 1
    return status


def _os_error_text(error: OSError) -> str:
    """An OSError in one line: its cause, and the path it names (shortened when long)."""
    from .cosim.limits import message_text

    cause = error.strerror or str(error)
    named = [message_text(name) for name in (error.filename, error.filename2) if name is not None]
    return f"{cause}: {' -> '.join(named)}" if named else one_line(cause)


def script_main(script: Any, *verb: Any) -> None:
    """Entry point of a script in sims/: ``mechfmu VERB`` followed by the script's own
    arguments, its usage and errors named after the script. The script writes where the
    verb does (default: the current folder) and finds the FMUs as every command does
    (cosim/locate.py). Exits with the verb's status."""
    sys.exit(main([*verb, *sys.argv[1:]], script=str(script)))


if __name__ == "__main__":
    sys.exit(main())
