"""The docs site: its generated parts come from the declarations and data, and it builds
strictly (a broken link, reference or include fails the suite)."""

import html
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from conftest import ROOT, SCENES
from mechfmu.io import read_csv
from mechfmu.cosim.scene import load_scene
from mechfmu.tools.docs import TYPES, declared_units, interface_table, model_class
from mechfmu.runtime.models import MODELS

CELL = re.compile(r"\s*(?<!\\)\|\s*")  # a table cell border (a description may hold "\|")


def table_rows(markdown):
    """The body rows of the Markdown table in ``markdown``, as lists of cells."""
    lines = [line for line in markdown.splitlines() if line.startswith("| `")]
    return [CELL.split(line.strip())[1:-1] for line in lines]


@pytest.mark.parametrize("name", list(MODELS))
def test_interface_table_lists_every_declared_variable_with_its_unit(name):
    variables = model_class(name).VARIABLES
    rows = table_rows(interface_table(name))
    assert [row[0] for row in rows] == [f"`{v.name}`" for v in variables]
    for row, variable in zip(rows, variables):
        _, causality, kind, unit, bounds, default, meaning = row
        assert (causality, kind, unit) == (
            variable.causality,
            TYPES[variable.kind],
            variable.unit or "",
        )
        if variable.kind is float:
            assert unit, f"{name}.{variable.name} is Real without a unit"
        if variable.kind is float and variable.causality != "output":
            assert float(default) == pytest.approx(variable.start, rel=1e-5, abs=1e-300)
        if variable.min is not None or variable.max is not None:
            low, high = (float(x) for x in bounds.strip("[]").split(", "))
            assert low == pytest.approx(
                -math.inf if variable.min is None else variable.min, rel=1e-5
            )
            assert high == pytest.approx(
                math.inf if variable.max is None else variable.max, rel=1e-5
            )
        assert meaning.replace("\\|", "|") == variable.description


def test_reference_plots_label_every_real_column_with_its_declared_unit():
    scenes = [load_scene(path) for path in sorted(SCENES.glob("*.toml"))]
    plotted = [scene for scene in scenes if scene.reference is not None]
    assert len(plotted) >= 15
    for scene in plotted:
        units = declared_units(scene)
        _, columns = read_csv(scene.reference)
        for column in columns:
            component, variable = column.split(".", 1)
            model = model_class(Path(scene.components[component].fmu).stem)
            (kind,) = (v.kind for v in model.VARIABLES if v.name == variable)
            assert (column in units) == (kind is float), (scene.name, column)
    gear = declared_units(load_scene(SCENES / "gear_retraction.toml"))
    assert gear["gear.gear_angular_acceleration"] == "rad/s2"
    assert gear["actuator.piston_speed"] == "m/s"


def test_docs_site_builds_strictly(tmp_path, fmu_dir):
    site = tmp_path / "site"
    env = dict(
        os.environ,
        NO_MKDOCS_2_WARNING="1",
        DISABLE_MKDOCS_2_WARNING="true",
        MECHFMU_FMU_DIR=str(fmu_dir),  # the model pages' animations run the FMUs
    )
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    pages = {path: path.read_text(encoding="utf-8") for path in site.rglob("*.html")}
    for name in MODELS:
        # The generated table's heading and one code cell per variable, on exactly one page.
        holding = [path for path, text in pages.items() if f'id="{name.lower()}fmu"' in text]
        assert len(holding) == 1, (name, holding)
        text = pages[holding[0]]
        assert all(
            f"<td><code>{v.name}</code></td>" in text for v in model_class(name).VARIABLES
        ), name
    images = 0
    for path, text in pages.items():
        for source in re.findall(r'<img[^>]* src="([^"]+)"', text):
            if "://" not in source and not source.startswith("data:"):
                image = (path.parent / source).resolve()
                assert image.is_file() and image.stat().st_size > 1000, (path, source)
                images += 1
    assert images >= 20  # the models' reference plots and the study's
    # each mechanism's page shows its reference scene moving
    frames = {path.name: Image.open(path).n_frames for path in (site / "moving").glob("*.gif")}
    assert len(frames) == 7 and min(frames.values()) > 10, frames
    showing = {path.stem for path, text in pages.items() if 'src="../moving/' in text}
    assert showing == {
        "four_bar",
        "slider_crank",
        "landing_gear",
        "suspension",
        "valve_train",
        "valve_spring",
    }
    assert links_from_disk(site, pages) > 1000


def links_from_disk(site, pages):
    """Follow every internal link (href, src) of every page as a browser does from disk
    (file://): each must name a file, not a folder, and an anchor must be an id of the page
    it names. Returns the number of links followed. 404.html is left out: only a web server
    shows it, for a missing page, with links from the site's root."""
    ids = {path: set(re.findall(r'\bid="([^"]+)"', text)) for path, text in pages.items()}
    followed = 0
    for path, text in pages.items():
        if path == site / "404.html":
            continue
        for link in re.findall(r'\b(?:href|src)="([^"]+)"', text):
            if re.match(r"^[a-z][a-z0-9+.-]*:", link) or link.startswith("//"):
                continue  # http:, https:, mailto:, data:: not the site's own
            target, _, anchor = link.partition("#")
            target = target.split("?")[0]
            resolved = (path.parent / target).resolve() if target else path
            where = f"{path.relative_to(site)}: {link}"
            assert resolved.is_file(), f"{where} -> {resolved} is not a file"
            if anchor and resolved.suffix == ".html":
                assert html.unescape(anchor) in ids[resolved], f"{where}: no id {anchor!r}"
            followed += 1
    return followed
