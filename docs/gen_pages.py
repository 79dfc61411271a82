"""Generated parts of the docs site, run by mkdocs-gen-files at every build.

- API reference: one page per module of the installed ``mechfmu`` package, found by walking
  its folder (no module is named here, so moving modules moves their pages), plus the
  ``reference/SUMMARY.md`` that mkdocs-literate-nav turns into the navigation.
- Markers in the hand-written pages (each alone on its line), replaced by what the ``mechfmu docs`` command prints
  (the same command a user runs, called in-process through its console-script entry point):
  ``<!-- mechfmu:interface MODEL -->`` becomes the model's interface table, generated from
  its declarations; ``<!-- mechfmu:reference-plot SCENE -->`` becomes a plot of the scene's
  committed reference CSV; ``<!-- mechfmu:scenes --tolerances -->`` becomes the table of
  each shipped scene's check tolerances (its [check] table). A registered model without an
  interface marker on some page fails the build.
- The accuracy study's committed plots (``data/study/*.png``) as ``study/*.png``.
- The tube-versus-pointwise figure of checks.md (``plots/tube_vs_pointwise.png``).
"""

import contextlib
import io
import re
import tempfile
from importlib.metadata import entry_points
from pathlib import Path, PurePosixPath

import mkdocs_gen_files

import mechfmu

MARKER = re.compile(r"^<!-- mechfmu:(interface|reference-plot|scenes) (\S+) -->$", re.MULTILINE)
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


def fill_markers(docs_dir: Path) -> None:
    """Replace the markers of every hand-written page; check every model has its table."""
    tables = {}
    for section in re.split(r"\n(?=### `)", mechfmu_command("docs").strip()):
        tables[MODEL_HEADING.match(section).group(1)] = section
    plots, documented = {}, set()
    for source in sorted(docs_dir.rglob("*.md")):
        page = PurePosixPath(source.relative_to(docs_dir).as_posix())
        text = source.read_text(encoding="utf-8")

        def replace(match):
            kind, name = match.groups()
            if kind == "scenes":  # <!-- mechfmu:scenes --tolerances -->
                return mechfmu_command("scenes", name).strip()
            if kind == "interface":
                if name not in tables:
                    raise RuntimeError(f"{page}: no model {name!r}; models: {', '.join(tables)}")
                documented.add(name)
                return tables[name]
            target = reference_plot(name, plots)
            relative = Path(*[".."] * (len(page.parts) - 1), target).as_posix()
            return f"![{name}: reference]({relative})"

        filled = MARKER.sub(replace, text)
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


def check_plots() -> None:
    """checks.md's tube-versus-pointwise figure, drawn by mechfmu's own comparison."""
    from mechfmu.tools.report.checks import tube_example

    with mkdocs_gen_files.open("plots/tube_vs_pointwise.png", "wb") as handle:
        handle.write(tube_example())


api_pages(Path(mechfmu.__file__).parent, mkdocs_gen_files.Nav())
fill_markers(Path(mkdocs_gen_files.config["docs_dir"]))
study_plots()
check_plots()
