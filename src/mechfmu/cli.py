"""The ``mechfmu`` command: build, run, export-ssp, check, references, report, docs, study, bench,
fuzz, sweep."""

import argparse
import sys
from pathlib import Path


def _build(args):
    from .build import build_all
    for path in build_all(args.out, args.models or None):
        print(f"built {path}")
    return 0


def _resolve_scene(text):
    path = Path(text)
    if path.suffix != ".toml" and not path.exists():
        path = Path("sims/scenes") / f"{text}.toml"
    return path


def _run(args):
    # Ctrl-C and SIGTERM are noted from here on and taken between steps (cosim.interrupt).
    from .cosim.interrupt import InterruptGuard
    with InterruptGuard() as guard:
        return _run_guarded(args, guard)


def _run_guarded(args, guard):
    from .check import compare
    from .cosim.files import OutputError
    from .cosim.interrupt import exit_code, signal_name
    from .cosim.master import SimulationError, SimulationInterrupted
    from .cosim.run import run_scene
    from .cosim.scene import SceneError
    try:
        result, paths = run_scene(_resolve_scene(args.scene), args.out, args.fmu_dir,
                                  plot=not args.no_plot, guard=guard)
    except SceneError as error:
        print(f"scene error: {error}", file=sys.stderr)
        return exit_code(guard.take()) if guard.requested else 2
    except OutputError as error:
        print(f"output error: {error}", file=sys.stderr)
        return exit_code(guard.take()) if guard.requested else 2
    except SimulationError as error:
        interrupted = isinstance(error, SimulationInterrupted)
        print(f"{'' if interrupted else 'simulation failed: '}{error}", file=sys.stderr)
        for path in error.moved_aside:
            print(f"older complete result moved aside: {path}", file=sys.stderr)
        for kind, path in error.paths.items():
            print(f"partial {kind}: {path}", file=sys.stderr)
        if error.output_error is not None:
            print(f"output error: {error.output_error}", file=sys.stderr)
        return exit_code(error.signum) if interrupted else 1
    if guard.requested:  # the signal came after the last step, while the files were written
        print(f"interrupted by {signal_name(guard.take())} after the last step; the results "
              f"are complete: {', '.join(str(path) for path in paths.values())}",
              file=sys.stderr)
        return exit_code(guard.signum)
    for entry in result.log:
        if entry["status"] != "ok":
            print(f"[{entry['status']}] {entry['message']}")
    print(f"{result.scene.name}: {result.meta['steps']} steps in "
          f"{result.meta['wall_time_s']:.3f} s")
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    reference = args.reference or (result.scene.reference if args.check else None)
    if reference:
        comparison = compare(paths["csv"], reference, args.rtol, args.atol)
        print(f"check against {reference}: {comparison}")
        return 0 if comparison.ok else 1
    return 0


def _export_ssp(args):
    from .cosim.scene import SceneError
    from .ssp import export_ssp, summary
    try:
        path = export_ssp(_resolve_scene(args.scene), args.out, args.fmu_dir)
    except SceneError as error:
        print(f"scene error: {error}", file=sys.stderr)
        return 2
    print(f"wrote {path}: {summary(path)}")
    return 0


def _check(args):
    from .check import compare
    try:
        comparison = compare(args.result, args.reference, args.rtol, args.atol)
    except (OSError, ValueError) as error:
        print(f"check error: {error}", file=sys.stderr)
        return 2
    print(comparison)
    return 0 if comparison.ok else 1


def _references(args):
    from .references.generate import generate
    for path in generate(args.scenes, args.out):
        print(f"wrote {path}")
    return 0


def _report(args):
    from .report.seed_report import write_report
    print(f"wrote {write_report(args.out)}")
    return 0


def _docs(args):
    from .docs import interface_tables
    print(interface_tables())
    return 0


def _study(arguments):
    from .study import main as study
    return study(arguments)


def _bench(arguments):
    from .bench import main as bench
    return bench(arguments)


# Verbs that parse their own options (``mechfmu study --help``): everything after the verb
# goes to them unparsed.
def _fuzz(arguments):
    from .fuzz import main as fuzz
    return fuzz(arguments)


def _sweep(arguments):
    from .sweep import main as sweep
    return sweep(arguments)


PASS_THROUGH = {"study": _study, "bench": _bench, "fuzz": _fuzz, "sweep": _sweep}


def parser():
    main = argparse.ArgumentParser(prog="mechfmu", description=__doc__)
    verbs = main.add_subparsers(dest="verb", required=True)

    build = verbs.add_parser("build", help="build the FMUs")
    build.add_argument("models", nargs="*", help="model names (default: all)")
    build.add_argument("--out", default="fmus", help="output folder (default: fmus)")
    build.set_defaults(func=_build)

    run = verbs.add_parser("run", help="run a scene and write CSV, JSON and PNG")
    run.add_argument("scene", help="scene TOML file, or a name in sims/scenes/")
    run.add_argument("--out", default="out", help="output folder (default: out)")
    run.add_argument("--fmu-dir", default="fmus", help="folder of built FMUs (default: fmus)")
    run.add_argument("--no-plot", action="store_true", help="skip the PNG")
    run.add_argument("--check", action="store_true",
                     help="compare with the scene's reference CSV afterwards")
    run.add_argument("--reference", help="compare with this CSV afterwards")
    run.add_argument("--rtol", type=float, default=1e-9)
    run.add_argument("--atol", type=float, default=1e-12)
    run.set_defaults(func=_run)

    export = verbs.add_parser("export-ssp", help="write a scene as an SSP 1.0 package (the "
                              "system, its parameters and its FMUs) for other co-simulation tools")
    export.add_argument("scene", help="scene TOML file, or a name in sims/scenes/")
    export.add_argument("out", help="the .ssp file to write")
    export.add_argument("--fmu-dir", default="fmus", help="folder of built FMUs (default: fmus)")
    export.set_defaults(func=_export_ssp)

    check = verbs.add_parser("check", help="compare a result CSV with a reference CSV")
    check.add_argument("result")
    check.add_argument("reference")
    check.add_argument("--rtol", type=float, default=1e-9, help="relative tolerance")
    check.add_argument("--atol", type=float, default=1e-12, help="absolute tolerance")
    check.set_defaults(func=_check)

    references = verbs.add_parser("references", help="regenerate the reference CSVs")
    references.add_argument("--scenes", default="sims/scenes")
    references.add_argument("--out", default="data/reference")
    references.set_defaults(func=_references)

    report = verbs.add_parser("report", help="write the seed-reproduction report")
    report.add_argument("--out", default="data/seed_report.md")
    report.set_defaults(func=_report)
    docs = verbs.add_parser("docs", help="print the README's FMU interface tables")
    docs.set_defaults(func=_docs)

    # Listed for --help; main() hands their arguments over before parsing (PASS_THROUGH).
    verbs.add_parser("study", help="accuracy study: error against wall time (make study; "
                     "mechfmu study --help)")
    verbs.add_parser("bench", help="performance benchmarks (make bench; mechfmu bench --help)")
    verbs.add_parser("fuzz", help="random input sequences through every FMU, each in a child "
                     "process (mechfmu fuzz --help)")
    verbs.add_parser("sweep", help="run a scene over a grid or sample of parameter values on a "
                     "local process pool, one CSV row of metrics per point (mechfmu sweep --help)")
    return main


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in PASS_THROUGH:
        return PASS_THROUGH[argv[0]](argv[1:])
    args = parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
