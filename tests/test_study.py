"""The accuracy study: its Pareto front, a reduced sweep end to end, and its shipped results."""

import math
import shutil
from collections import defaultdict

import pytest

from conftest import ROOT, SCENES
from mechfmu.cli import main as cli
from mechfmu.tools.study import design, headline_unit, pareto_markdown, read_rows
from mechfmu.tools.study.report import cheapest_for, pareto_front

STUDY = ROOT / "data" / "study"


@pytest.mark.parametrize(
    "costs, errors, front",
    [
        ([1, 2, 3, 4], [4, 3, 2, 1], [0, 1, 2, 3]),  # every point trades cost for error
        ([1, 2, 3, 4], [1, 2, 3, 4], [0]),  # the cheapest is also the best
        ([3, 1, 2, 5], [1e-3, 1e-1, 1e-2, 1e-6], [1, 2, 0, 3]),
        ([1, 1, 2], [5, 3, 3], [1]),  # equal cost: the smaller error; equal error: cheaper
        ([1, math.nan, 2, 3], [1, 1e-9, math.inf, 0.5], [0, 3]),  # non-finite never on the front
        ([], [], []),
    ],
)
def test_pareto_front(costs, errors, front):
    assert pareto_front(costs, errors) == front


def test_cheapest_setting_for_a_target():
    rows = [
        {"max_error": 1e-3, "ms_per_simulated_s": 1.0},
        {"max_error": 1e-7, "ms_per_simulated_s": 9.0},
        {"max_error": 1e-6, "ms_per_simulated_s": 4.0},
    ]
    assert cheapest_for(rows, 1e-2) is rows[0]
    assert cheapest_for(rows, 1e-6) is rows[2]
    assert cheapest_for(rows, 1e-7) is rows[1]
    assert cheapest_for(rows, 1e-8) is None


@pytest.fixture(scope="module")
def quick_study(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("study")
    status = cli(
        [
            "study",
            "--quick",
            "--repeats",
            "1",
            "--workers",
            "2",
            "--out",
            str(out),
            "--fmu-dir",
            str(fmu_dir),
            "--scene-dir",
            str(SCENES),
            "--scenes",
            "gear_extension_gravity",
            "suspension_sudden_load",
        ]
    )
    assert status == 0
    return out, read_rows(out / "accuracy_cost.csv")


def _select(rows, **fields):
    return [r for r in rows if all(r[key] == value for key, value in fields.items())]


def test_quick_study_writes_every_file_and_row(quick_study):
    out, rows = quick_study
    for name in ("gear_extension_gravity", "suspension_sudden_load"):
        assert (out / f"{name}.png").stat().st_size > 10_000
        assert (out / f"{name}_sources.png").stat().st_size > 10_000
        scene = design.load(SCENES, next(s for s in design.SCENES if s.name == name))
        expected = design.points(
            next(s for s in design.SCENES if s.name == name), design.couplings_of(scene), quick=True
        )
        outputs = scene.record
        per_point = defaultdict(set)
        for row in _select(rows, scene=name):
            per_point[
                (
                    row["integrator"],
                    row["tolerance"],
                    row["max_substep"],
                    row["step"],
                    row["coupling"],
                )
            ].add(row["output"])
        assert len(per_point) == len(expected)
        assert all(found == set(outputs) for found in per_point.values())
    table = (out / "pareto.md").read_text()
    assert table.count("\n| ") >= 2 * 9  # a row per target error and scene


def test_quick_study_errors_follow_the_methods_orders(quick_study):
    _, rows = quick_study
    angle = dict(
        scene="gear_extension_gravity",
        output="gear.gear_angle",
        step=0.05,
        coupling="gauss_seidel",
        status="ok",
    )
    (loose,) = _select(rows, integrator="dopri5", tolerance=1e-4, **angle)
    (tight,) = _select(rows, integrator="dopri5", tolerance=1e-8, **angle)
    assert tight["max_error"] < 1e-6 < loose["max_error"] < 1e-3
    assert tight["rhs_evaluations"] > loose["rhs_evaluations"]
    (coarse,) = _select(rows, integrator="euler", max_substep=1e-3, **angle)
    (fine,) = _select(rows, integrator="euler", max_substep=1e-4, **angle)
    assert 5.0 < coarse["max_error"] / fine["max_error"] < 20.0  # first order: 10x per decade
    assert fine["substeps"] >= 2.0 / 1e-4 and fine["communication_steps"] == 40
    for row in (loose, tight, coarse, fine):
        assert row["loop_time_s"] > 0 and row["ms_per_simulated_s"] == pytest.approx(
            row["loop_time_s"] / 2.0 * 1e3
        )


def test_quick_study_shows_the_coupling_error(quick_study):
    # The 2500 N load step of suspension_sudden_load reaches the suspension one
    # communication step late under Jacobi: a coupling error the integrator cannot remove.
    _, rows = quick_study
    common = dict(
        scene="suspension_sudden_load",
        output="suspension.deflection",
        step=0.05,
        integrator="dopri5",
        tolerance=1e-8,
        status="ok",
    )
    (seidel,) = _select(rows, coupling="gauss_seidel", **common)
    (jacobi,) = _select(rows, coupling="jacobi", **common)
    assert seidel["max_error"] < 1e-7
    assert jacobi["max_error"] > 1e3 * seidel["max_error"]


def test_shipped_study_covers_the_whole_sweep_and_its_tables_are_generated(fmu_dir):
    rows = read_rows(STUDY / "accuracy_cost.csv")
    for study_scene in design.SCENES:
        scene = design.load(SCENES, study_scene)
        expected = {
            (p.integrator, p.tolerance, p.max_substep, p.step, p.coupling)
            for p in design.points(study_scene, design.couplings_of(scene))
        }
        found = {
            (r["integrator"], r["tolerance"], r["max_substep"], r["step"], r["coupling"])
            for r in _select(rows, scene=study_scene.name)
        }
        assert found == expected, study_scene.name
        assert (STUDY / f"{study_scene.name}.png").is_file()
        assert (STUDY / f"{study_scene.name}_sources.png").is_file()
    ok = [r for r in rows if r["status"] == "ok"]
    assert len(ok) > 0.8 * len(rows)
    assert all(math.isfinite(r["max_error"]) and r["loop_time_s"] > 0 for r in ok)
    # The docs include pareto.md as is: it must be what the study's code makes of the rows.
    units = {s.name: headline_unit(SCENES, fmu_dir, s) for s in design.SCENES}
    assert (STUDY / "pareto.md").read_text() == pareto_markdown(rows, units)


def test_studying_one_scene_again_keeps_the_others_rows(quick_study, fmu_dir, tmp_path):
    out, rows = quick_study
    shutil.copytree(out, tmp_path, dirs_exist_ok=True)
    status = cli(
        [
            "study",
            "--quick",
            "--repeats",
            "1",
            "--workers",
            "1",
            "--out",
            str(tmp_path),
            "--fmu-dir",
            str(fmu_dir),
            "--scene-dir",
            str(SCENES),
            "--scenes",
            "gear_extension_gravity",
        ]
    )
    assert status == 0
    again = read_rows(tmp_path / "accuracy_cost.csv")

    def lines(folder, scene):  # as written (rows hold NaN, which compares unequal)
        text = (folder / "accuracy_cost.csv").read_text().splitlines()
        return [line for line in text if line.startswith(scene + ",")]

    kept = lines(out, "suspension_sudden_load")
    assert kept and lines(tmp_path, "suspension_sudden_load") == kept
    assert len(_select(again, scene="gear_extension_gravity")) == len(
        _select(rows, scene="gear_extension_gravity")
    )
    assert "#### suspension_sudden_load" in (tmp_path / "pareto.md").read_text()
