"""The ``mechfmu`` command: build, run, example, export-ssp, export-fmu, export-cross-check,
check, references, report, docs, study, bench, fuzz, sweep.

One argparse tree: every verb and its options are declared here, and each verb calls one
function of the package (imported when the verb runs, so ``mechfmu run`` never loads the
study's or the benchmarks' code). The scripts in sims/ call ``script_main`` with their verb.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import argparse
import os
import sys
from pathlib import Path

from .cosim.scene import REFERENCE_DIR, SCENE_DIR, SWEEP_DIR

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .cosim.files import OutputError
    from .cosim.interrupt import InterruptGuard
    from .cosim.master import SimulationError
    from .cosim.scene import SceneError

# Where the verbs find (and build writes) the FMUs unless told: the Makefile exports
# MECHFMU_FMU_DIR (fmus-X.Y for another interpreter's venv).
FMU_DIR = os.environ.get("MECHFMU_FMU_DIR") or "fmus"
FMU_DIR_HELP = "folder of built FMUs (default: $MECHFMU_FMU_DIR, else fmus)"


def _build(args: Any) -> int:
    from .packaging.build import build_all

    for path in build_all(
        args.out, args.models or None, fmi_version=args.fmi_version, embed_python=args.embed_python
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
        print(f"{kind} error: {error}", file=sys.stderr)
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

    if args.all == (args.scene is not None):
        print(
            "mechfmu run: error: give a scene or --all (every shipped scene), not both",
            file=sys.stderr,
        )
        return 2
    if args.all and (args.checkpoint or args.resume):
        print(
            "mechfmu run: error: --checkpoint and --resume name one scene's checkpoint; "
            "not with --all",
            file=sys.stderr,
        )
        return 2
    if args.all and args.reference:
        print(
            "mechfmu run: error: --reference names one scene's reference; with --all use "
            "--check (each scene against its own)",
            file=sys.stderr,
        )
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
    from .cosim.scene import SceneError

    try:
        result, paths = run_scene(
            scene_path,
            args.out,
            args.fmu_dir,
            plot=not args.no_plot,
            guard=guard,
            checkpoints=_checkpoints(args),
            resume=Path(args.resume) if args.resume else None,
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
    try:
        lines, comparison = run_report(result, paths, reference, args.rtol, args.atol)
    except ValueError as error:  # a malformed reference CSV (ResultFileError names it)
        print(f"check error: {error}", file=sys.stderr)
        for kind, path in paths.items():
            print(f"  {kind}: {path}", file=sys.stderr)
        return 2
    print("\n".join(lines))
    note = ended_note(result.meta)
    if note:
        print(note)
    return 0 if comparison is None or comparison.ok else 1


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
    "sweeps": ("out/sweeps", "the shipped sweeps against their references (make sweeps)"),
}


def _example(args: Any):
    from .cosim.master import SimulationError
    from .cosim.scene import SceneError
    from .tools import examples

    try:
        return getattr(examples, args.example)(args)
    except (SceneError, SimulationError) as error:
        return _scene_failure(error)


def _export_ssp(args: argparse.Namespace) -> int:
    from .cosim.scene import SceneError, find_file
    from .tools.ssp import export_ssp, summary

    try:
        path = export_ssp(find_file(args.scene), args.out, args.fmu_dir)
    except SceneError as error:
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
    from .comparison import parse_tolerance
    from .cosim.files import OutputError

    try:
        tolerances: dict[str, Any] = dict(parse_tolerance(text) for text in args.tol)
        for name, value in (
            ("--rtol", args.rtol),
            ("--atol", args.atol),
            ("--time-tolerance", args.time_tolerance),
        ):
            if value is not None and not value >= 0:
                raise ValueError(f"{name} must be >= 0, got {value!r}")
        if args.time_tolerance is not None and args.method != "tube":
            raise ValueError("--time-tolerance is the tube's: give --method tube with it")
    except ValueError as error:
        print(f"check error: {error}", file=sys.stderr)
        return 2
    run = check_paths(
        args.result,
        args.reference,
        rtol=args.rtol,
        atol=args.atol,
        method=args.method,
        time_tolerance=args.time_tolerance,
        tolerances=tolerances,
        interpolate=args.interpolate,
        ignore_extra=args.ignore_extra,
    )
    for check in run.files:
        print(check.line())
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
    from .tools.scene_references import generate

    for path in generate(args.scenes, args.out):
        print(f"wrote {path}")
    return 0


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
    except (OSError, ValueError) as error:
        print(f"docs error: {error}", file=sys.stderr)
        return 2
    return 0


def _study(args: argparse.Namespace):
    from .tools.study import command

    return command(args)


def _bench(args: Any):
    from .tools.bench.suite import command

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
    return command(args)


def _sweep(args: argparse.Namespace) -> int:
    from .tools.sweep import command

    return command(args)


def _at_least_one(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _scene_options(verb: argparse.ArgumentParser, out: str = "out", plot: bool = True) -> None:
    """--out, --fmu-dir and --no-plot: the options of every verb that runs scenes."""
    verb.add_argument("--out", default=out, help=f"output folder (default: {out})")
    verb.add_argument("--fmu-dir", default=FMU_DIR, help=FMU_DIR_HELP)
    if plot:
        verb.add_argument("--no-plot", action="store_true", help="skip the PNG")


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
                help="a few points of each sweep around its threshold",
            )
            verb.add_argument(
                "--jobs", type=_at_least_one, default=None, help="local worker processes"
            )
            verb.add_argument(
                "--scheduler",
                metavar="tcp://HOST:PORT",
                help="run on this Dask cluster (pip install mechfmu[cluster])",
            )
    example.set_defaults(func=_example)


def _measurement_verbs(verbs: argparse._SubParsersAction) -> None:
    """study, bench, fuzz, sweep: the long runs."""
    from .tools.bench import BENCHMARKS, FULL, QUICK

    study = verbs.add_parser("study", help="accuracy study: error against wall time (make study)")
    study.add_argument("--scenes", nargs="*", help="study these scenes only (default: all)")
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
        help="timed runs per point, median taken (default 3)",
    )
    study.add_argument(
        "--workers",
        type=_at_least_one,
        default=min(2, os.cpu_count() or 1),
        help="parallel processes (default: 2 or the cores there are)",
    )
    study.add_argument("--out", default="data/study", help="output folder")
    study.add_argument(
        "--scene-dir",
        default=str(SCENE_DIR),
        help="folder of the scene files (default: the shipped scenes)",
    )
    study.add_argument("--fmu-dir", default=FMU_DIR, help=FMU_DIR_HELP)
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
        help=f"measured repeats per case after one warm-up (default "
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
        help="run this benchmark alone and print its rows (writes nothing)",
    )
    bench.add_argument("--out", default="data/bench", help="output folder (default data/bench)")
    bench.add_argument("--fmu-dir", default=FMU_DIR, help=FMU_DIR_HELP)
    _scene_folder_option(bench)
    bench.add_argument(
        "--sweeps",
        default=str(SWEEP_DIR),
        help="folder of the sweep files (default: the shipped sweeps)",
    )
    bench.add_argument(
        "--sweep-scenes",
        type=_at_least_one,
        default=None,
        help=f"scenes of the sweep benchmark (default {FULL.sweep_scenes}, "
        f"--quick {QUICK.sweep_scenes})",
    )
    bench.add_argument(
        "--cpu-time",
        action="store_true",
        help="time runs and loops by the process's CPU time, not the wall clock "
        "(a machine shared with other work; FMI-call timers stay on the "
        "wall clock)",
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
    fuzz.add_argument("--sequences", type=int, default=1000)
    fuzz.add_argument("--seed", type=int, default=0)
    fuzz.add_argument("--fmus", default=FMU_DIR, help=FMU_DIR_HELP)
    fuzz.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    fuzz.add_argument("--only", type=int, help="run only this sequence index (reproduce)")
    fuzz.add_argument("--out", default="out/fuzz", help="folder for the progress logs")
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
        help="a parameter (or constant input) and its range; repeat for a grid",
    )
    sweep.add_argument(
        "--link",
        action="append",
        default=[],
        metavar="COMP.PARAM=FACTOR*COMP.VARIED",
        help="a parameter that follows a varied one (target = factor * value)",
    )
    sweep.add_argument("--samples", type=int, help="draw N points instead of the grid")
    sweep.add_argument("--seed", type=int, help="seed of the sampling (with --samples)")
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
        "max_abs_error:c.v",
    )
    sweep.add_argument("--out", help="output folder (default: out/sweep_<scene>)")
    sweep.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="parallel processes (default: the number of cores)",
    )
    sweep.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run on this Dask cluster instead of local processes (pip install mechfmu[cluster])",
    )
    sweep.add_argument("--plot", action="store_true", help="one PNG per metric and parameter")
    sweep.add_argument("--fmu-dir", default=FMU_DIR, help=FMU_DIR_HELP)
    sweep.add_argument(
        "--retries",
        type=int,
        default=None,
        help="extra attempts of a point whose worker process died, the last one alone (default: 2)",
    )
    sweep.add_argument(
        "--resume",
        action="store_true",
        help="continue the stopped sweep in --out: keep its rows without an "
        "error, run the other points",
    )
    sweep.set_defaults(func=_sweep)


def _scene_folder_option(verb: argparse.ArgumentParser) -> None:
    verb.add_argument(
        "--scenes",
        default=str(SCENE_DIR),
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
    verb.add_argument("--fmu-dir", default=FMU_DIR, help=FMU_DIR_HELP)
    return verb


def parser() -> argparse.ArgumentParser:
    main = argparse.ArgumentParser(prog="mechfmu", description=__doc__.split("\n\n")[0])
    verbs = main.add_subparsers(dest="verb", required=True)

    build = verbs.add_parser("build", help="build the FMUs")
    build.add_argument("models", nargs="*", help="model names (default: all)")
    build.add_argument("--out", default="fmus", help="output folder (default: fmus)")
    build.add_argument(
        "--fmi-version",
        type=int,
        choices=(2, 3),
        default=2,
        help="FMI 2.0 (pythonfmu, default) or FMI 3.0 (pythonfmu3) co-simulation",
    )
    build.add_argument(
        "--embed-python",
        action="store_true",
        help="carry this interpreter's libpython and the standard library the "
        "models import, so the FMUs run where no Python is installed",
    )
    build.set_defaults(func=_build)

    run = verbs.add_parser(
        "run", help="run a scene (or every shipped scene) and write CSV, JSON and PNG"
    )
    run.add_argument("scene", nargs="?", help="scene TOML file, or the name of a shipped scene")
    run.add_argument(
        "--all",
        action="store_true",
        help="run every shipped scene into --out (a baseline tree for mechfmu "
        "check); a failing scene does not stop the others",
    )
    _scene_options(run)
    run.add_argument(
        "--check", action="store_true", help="compare with the scene's reference CSV afterwards"
    )
    run.add_argument("--reference", help="compare with this CSV afterwards (one scene)")
    run.add_argument(
        "--checkpoint",
        metavar="FILE",
        help="write a checkpoint of the run to FILE (every --checkpoint-every seconds and "
        "when Ctrl-C or SIGTERM stops it) for --resume; default: none",
    )
    run.add_argument(
        "--checkpoint-every",
        type=float,
        default=60.0,
        metavar="S",
        help="seconds of wall time between checkpoints (default: 60; 0: only when stopped)",
    )
    run.add_argument(
        "--resume",
        metavar="FILE",
        help="continue the run from this checkpoint (of the same scene and FMUs); the "
        "result equals the uninterrupted run's; default: start from the beginning",
    )
    run.add_argument("--rtol", type=float, default=1e-9)
    run.add_argument("--atol", type=float, default=1e-12)
    run.set_defaults(func=_run)

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
        help="scene (default): sequential for gauss_seidel scenes, parallel "
        "for jacobi ones; sequential: each FMU sees the outputs of those "
        "stepped before it; parallel: every link lags one step",
    )
    container.set_defaults(func=_export_fmu)

    cross = verbs.add_parser(
        "export-cross-check",
        help="write the FMUs with their reference results as the fmi-cross-check "
        "repository lays out test FMUs (fmus/2.0/cs/linux64/mechfmu/<version>/<Model>/)",
    )
    cross.add_argument("out", help="the folder to write into (created if missing)")
    cross.add_argument("models", nargs="*", help="model names (default: all)")
    cross.add_argument("--fmu-dir", default=FMU_DIR, help=FMU_DIR_HELP)
    cross.set_defaults(func=_export_cross_check)

    check = verbs.add_parser(
        "check",
        help="compare a result CSV (or a folder of them) with a reference CSV (or "
        "folder, matched by relative path); exit 0 all match, 1 any mismatch, 2 nothing "
        "comparable",
    )
    check.add_argument("result", help="result CSV file or folder")
    check.add_argument("reference", help="reference CSV file or folder")
    check.add_argument("--rtol", type=float, default=1e-9, help="relative tolerance")
    check.add_argument("--atol", type=float, default=1e-12, help="absolute tolerance")
    check.add_argument(
        "--tol",
        action="append",
        default=[],
        metavar="COLUMN=RTOL[,ATOL]",
        help="tolerance of one column (or an fnmatch pattern such as 'gear.*'); "
        "repeatable, the last match wins",
    )
    check.add_argument(
        "--method",
        choices=("pointwise", "tube"),
        default="pointwise",
        help="pointwise (default; the same time grid) or tube (the reference "
        "widened by --time-tolerance in time)",
    )
    check.add_argument(
        "--time-tolerance",
        type=float,
        metavar="S",
        help="the tube's half width in time, s (default: the reference's largest step)",
    )
    check.add_argument(
        "--interpolate",
        action="store_true",
        help="pointwise: interpolate the reference onto the result's times",
    )
    check.add_argument(
        "--ignore-extra",
        action="store_true",
        help="result columns the reference lacks are not failures",
    )
    check.add_argument("--junit", metavar="FILE", help="write a JUnit XML file")
    check.add_argument(
        "--report", metavar="DIR", help="write DIR/index.html with a plot of every failing column"
    )
    check.set_defaults(func=_check)

    baseline = verbs.add_parser("baseline", help="accepted results (baselines) for mechfmu check")
    baseline_verbs = baseline.add_subparsers(dest="baseline_verb", required=True)
    update = baseline_verbs.add_parser(
        "update",
        help="accept results as baselines: copy the new and changed CSV files (and "
        "their JSON) and say what changed by how much",
    )
    update.add_argument("results", help="result CSV file or folder (e.g. of mechfmu run --all)")
    update.add_argument("baselines", help="baseline folder (created if missing)")
    update.add_argument("--prune", action="store_true", help="remove baselines that have no result")
    update.add_argument("--dry-run", action="store_true", help="only say what would change")
    update.set_defaults(func=_baseline_update)

    references = verbs.add_parser("references", help="regenerate the reference CSVs")
    _scene_folder_option(references)
    references.add_argument(
        "--out",
        default=str(REFERENCE_DIR),
        help="output folder (default: the shipped scenes' reference/)",
    )
    references.set_defaults(func=_references)

    report = verbs.add_parser("report", help="write the seed-reproduction report")
    report.add_argument("--out", default="data/seed_report.md")
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
        help="scene TOML file, or the name of a shipped scene, whose reference to plot",
    )
    docs.add_argument("--out", help="PNG file for --reference-plot")
    docs.set_defaults(func=_docs)

    _measurement_verbs(verbs)
    return main


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    return args.func(args)


def script_main(script: Any, *verb: Any, **paths: Any) -> None:
    """Entry point of a script in sims/: ``mechfmu VERB`` with each option in ``paths``
    (``out="out"`` -> ``--out <repository>/out``) inside the repository that holds the
    script, so the script writes to the same place from any directory, followed by the
    script's own arguments (which win); ``fmu_dir`` is $MECHFMU_FMU_DIR when that is set
    (the Makefile's FMU folder of the interpreter). Exits with the verb's status."""
    root = Path(script).resolve().parent.parent
    if "fmu_dir" in paths and os.environ.get("MECHFMU_FMU_DIR"):
        paths = dict(paths, fmu_dir=os.environ["MECHFMU_FMU_DIR"])  # another interpreter's
    defaults = [
        item
        for option, path in paths.items()
        for item in (f"--{option.replace('_', '-')}", str(root / path))
    ]
    sys.exit(main([*verb, *defaults, *sys.argv[1:]]))


if __name__ == "__main__":
    sys.exit(main())
