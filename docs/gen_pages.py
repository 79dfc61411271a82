"""Generated parts of the docs site, run by mkdocs-gen-files at every build.

- API reference: one page per module of the installed ``mechfmu`` package, found by walking
  its folder (no module is named here, so moving modules moves their pages), plus the
  ``reference/SUMMARY.md`` that mkdocs-literate-nav turns into the navigation.
- Markers in the hand-written pages (each alone on its line), replaced by what the ``mechfmu docs`` command prints
  (the same command a user runs, called in-process through its console-script entry point):
  ``<!-- mechfmu:interface MODEL -->`` becomes the model's interface table, generated from
  its declarations; ``<!-- mechfmu:limits inputs -->`` the table of the input files' limits
  (mechfmu.cosim.limits.LIMITS); ``<!-- mechfmu:reference-plot SCENE -->`` becomes a plot of the scene's
  committed reference CSV; ``<!-- mechfmu:scenes --tolerances -->`` becomes the table of
  each shipped scene's check tolerances (its [check] table); ``<!-- mechfmu:cam-profile
  SCENE -->`` the drawing and summary ``mechfmu cam-profile SCENE`` writes;
  ``<!-- mechfmu:camshaft-torque SCENE -->`` the total camshaft torque of a camshaft scene in
  each phasing (tools/camshaft.py, on the scene's reference: no FMU is needed), plot and
  table. A registered model without an interface marker on some page fails the build.
- ``<!-- mechfmu:animation SCENE [speed=S] [fps=N] [panel=COLUMN] -->`` becomes the scene
  moving: run on the built FMUs with the geometry effect and animated as a small GIF, by
  the Python API a user calls (mechfmu.simulate(scene, geometry=True), mechfmu.animate). The
  FMUs are found as simulate finds them ($MECHFMU_FMU_DIR: `make docs` builds them first).
- The accuracy study's committed plots (``data/study/*.png``) as ``study/*.png``.
- The tube-versus-pointwise figure of checks.md (``plots/tube_vs_pointwise.png``).
- The forces pages' validation figures (``forces/*.png``), drawn from the runtime's force
  analysis and the references (mechfmu.tools.report.forces).
"""

import contextlib
import io
import re
import tempfile
from importlib.metadata import entry_points
from pathlib import Path, PurePosixPath

import mkdocs_gen_files

import mechfmu

MARKER = re.compile(
    r"^<!-- mechfmu:(interface|reference-plot|scenes|cam-profile|camshaft-torque|limits) (\S+) -->$",
    re.MULTILINE,
)
ANIMATION = re.compile(r"^<!-- mechfmu:animation (\S+)((?: \w+=\S+)*) -->$", re.MULTILINE)
# The docs' animations: small files (a few hundred kB), quick to draw at build time.
ANIMATION_WIDTH = 440
ANIMATION_FPS = 10.0
MODEL_HEADING = re.compile(r"^### `(\w+)\.fmu`$", re.MULTILINE)
STUDY_PLOTS = Path("data/study")


def mechfmu_command(*arguments: str) -> str:
    """What ``mechfmu ARGUMENTS`` prints; a non-zero exit fails the build with its message."""
    (main,) = (point.load() for point in entry_points(group="console_scripts", name="mechfmu"))
    printed, errors = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(errors):
        status = main(list(arguments))
    if status:
        raise RuntimeError(f"mechfmu {' '.join(arguments)} exited {status}: {errors.getvalue()}")
    return printed.getvalue()


def api_pages(package_dir: Path, nav: mkdocs_gen_files.Nav) -> None:
    """One ``::: module`` page per public module under ``package_dir``."""
    for source in sorted(package_dir.rglob("*.py")):
        parts = (package_dir.name, *source.relative_to(package_dir).with_suffix("").parts)
        if parts[-1] == "__main__" or any(p.startswith("_") and p != "__init__" for p in parts):
            continue
        if parts[-1] == "__init__":
            parts = parts[:-1]
            page = PurePosixPath("reference", *parts, "index.md")
        else:
            page = PurePosixPath("reference", *parts).with_suffix(".md")
        nav[parts] = page.relative_to("reference").as_posix()
        with mkdocs_gen_files.open(page, "w") as handle:
            handle.write(f"# `{'.'.join(parts)}`\n\n::: {'.'.join(parts)}\n")
    with mkdocs_gen_files.open("reference/SUMMARY.md", "w") as handle:
        handle.writelines(nav.build_literate_nav())


def reference_plot(scene: str, plots: dict) -> str:
    """Site path of the scene's reference plot, drawn once per build."""
    if scene not in plots:
        with tempfile.TemporaryDirectory() as folder:
            png = Path(folder) / f"{scene}.png"
            mechfmu_command("docs", "--reference-plot", scene, "--out", str(png))
            plots[scene] = f"plots/{scene}.png"
            with mkdocs_gen_files.open(plots[scene], "wb") as handle:
                handle.write(png.read_bytes())
    return plots[scene]


def limits_table() -> str:
    """The limits every input file is checked against (mechfmu.cosim.limits.LIMITS)."""
    from mechfmu.cosim.limits import LIMITS

    rows = [
        f"| {limit.applies_to} | {limit.what} | {limit.value} | {limit.reason} |"
        for limit in LIMITS
    ]
    return "\n".join(["| file | what | limit | why |", "|---|---|---|---|", *rows])


def cam_profile_section(scene: str, page: PurePosixPath) -> str:
    """The drawing and summary of ``mechfmu cam-profile SCENE`` (Markdown)."""
    with tempfile.TemporaryDirectory() as folder:
        mechfmu_command("cam-profile", scene, "--out", folder)
        (summary,) = Path(folder).glob("*_cam.md")
        (png,) = Path(folder).glob("*_cam.png")
        target = f"plots/{png.name}"
        with mkdocs_gen_files.open(target, "wb") as handle:
            handle.write(png.read_bytes())
        text = summary.read_text(encoding="utf-8").split("\n", 2)[2]  # past its heading
    relative = Path(*[".."] * (len(page.parts) - 1), target).as_posix()
    return f"![the cam of {scene}]({relative})\n\n{text}"


def camshaft_torque_section(scene_name: str, page: PurePosixPath) -> str:
    """The camshaft scene's total torque in each phasing, on its reference: plot and table."""
    from mechfmu.cosim.scene import find_file, load_scene
    from mechfmu.tools import camshaft

    scene = load_scene(find_file(scene_name))

    def run(chosen, parameters):
        return mechfmu.reference(chosen, parameters=parameters)

    table, curves = camshaft.compare_phasings(scene, run)
    angle = run(scene, {})["camshaft.camshaft_angle"]
    target = f"plots/{scene_name}_torque.png"
    with mkdocs_gen_files.open(target, "wb") as handle:
        handle.write(camshaft.figure_png(curves, angle))
    relative = Path(*[".."] * (len(page.parts) - 1), target).as_posix()
    return f"![{scene_name}: total camshaft torque]({relative})\n\n{camshaft.table_text(table)}"


def animation(scene: str, options: str, drawn: dict) -> str:
    """Site path of the GIF of ``scene`` with the marker's ``options`` (speed, fps, panel),
    run and drawn once per build."""
    key = scene + options
    if key not in drawn:
        settings = dict(item.split("=", 1) for item in options.split())
        table = mechfmu.simulate(scene, geometry=True)
        animated = mechfmu.animate(
            table,
            speed=float(settings.get("speed", 1.0)),
            fps=float(settings.get("fps", ANIMATION_FPS)),
            panels=[settings["panel"]] if "panel" in settings else [],
            width=ANIMATION_WIDTH,
        )
        drawn[key] = f"moving/{scene}{len(drawn)}.gif"
        with mkdocs_gen_files.open(drawn[key], "wb") as handle:
            handle.write(animated.gif())
    return drawn[key]


def fill_markers(docs_dir: Path) -> None:
    """Replace the markers of every hand-written page; check every model has its table."""
    tables = {}
    for section in re.split(r"\n(?=### `)", mechfmu_command("docs").strip()):
        tables[MODEL_HEADING.match(section).group(1)] = section
    plots, documented, animations = {}, set(), {}
    for source in sorted(docs_dir.rglob("*.md")):
        page = PurePosixPath(source.relative_to(docs_dir).as_posix())
        text = source.read_text(encoding="utf-8")

        def replace(match):
            kind, name = match.groups()
            if kind == "limits":
                return limits_table()
            if kind == "scenes":  # <!-- mechfmu:scenes --tolerances -->
                return mechfmu_command("scenes", name).strip()
            if kind == "cam-profile":
                return cam_profile_section(name, page)
            if kind == "camshaft-torque":
                return camshaft_torque_section(name, page)
            if kind == "interface":
                if name not in tables:
                    raise RuntimeError(f"{page}: no model {name!r}; models: {', '.join(tables)}")
                documented.add(name)
                return tables[name]
            target = reference_plot(name, plots)
            relative = Path(*[".."] * (len(page.parts) - 1), target).as_posix()
            return f"![{name}: reference]({relative})"

        def animate(match):
            scene, options = match.groups()
            target = animation(scene, options, animations)
            relative = Path(*[".."] * (len(page.parts) - 1), target).as_posix()
            return f"![{scene} moving]({relative})"

        filled = ANIMATION.sub(animate, MARKER.sub(replace, text))
        if filled != text:
            with mkdocs_gen_files.open(page.as_posix(), "w") as handle:
                handle.write(filled)
    missing = sorted(set(tables) - documented)
    if missing:
        raise RuntimeError(
            f"models without a docs page (<!-- mechfmu:interface NAME --> "
            f"marker): {', '.join(missing)}"
        )


def study_plots() -> None:
    for png in sorted(STUDY_PLOTS.glob("*.png")):
        with mkdocs_gen_files.open(f"study/{png.name}", "wb") as handle:
            handle.write(png.read_bytes())


def force_plots() -> None:
    """The forces pages' validation figures (mechfmu.tools.report.forces), as forces/*.png."""
    from mechfmu.tools.report.forces import FIGURES

    for name, draw in FIGURES.items():
        with mkdocs_gen_files.open(f"forces/{name}", "wb") as handle:
            handle.write(draw())


def check_plots() -> None:
    """checks.md's tube-versus-pointwise figure, drawn by mechfmu's own comparison."""
    from mechfmu.tools.report.checks import tube_example

    with mkdocs_gen_files.open("plots/tube_vs_pointwise.png", "wb") as handle:
        handle.write(tube_example())


api_pages(Path(mechfmu.__file__).parent, mkdocs_gen_files.Nav())
fill_markers(Path(mkdocs_gen_files.config["docs_dir"]))
study_plots()
check_plots()
force_plots()
