"""Work-precision (issue 21, goal 5): our integrators against scipy's solve_ivp on the FMUs'
own right-hand sides; a small table: every method has rows, the numbers are finite, our
adaptive methods meet a bound at the tight tolerance, and our dopri5 and radau do the work
of scipy's RK45 and Radau (the same methods and step-size controllers)."""

import math

import pandas as pd
import pytest

from mechfmu.cli import main as cli
from mechfmu.tools.study import work_precision as wp


@pytest.fixture(scope="module")
def frame():
    return wp.table(tolerances=(1e-5, 1e-9), repeats=1)


def test_rows_for_every_problem_and_method(frame):
    for problem in wp.PROBLEMS:
        methods = set(frame.loc[frame["problem"] == problem, "method"])
        assert methods == {*wp.OURS_ADAPTIVE, "rk4", *wp.SCIPY}, problem
    assert list(frame.columns) == list(wp.COLUMNS)
    numbers = frame[["error", "rhs_evaluations", "steps", "wall_time_s"]]
    assert numbers.map(math.isfinite).all().all()
    assert (frame["rhs_evaluations"] > 0).all() and (frame["wall_time_s"] > 0).all()


def test_our_error_at_the_tight_tolerance_is_small(frame):
    tight = frame[(frame["library"] == "mechfmu") & (frame["tolerance"] == 1e-9)]
    assert len(tight) == len(wp.PROBLEMS) * len(wp.OURS_ADAPTIVE)
    # relative to each component's peak; measured 1e-10 .. 3e-8 (gear radau the largest)
    assert (tight["error"] < 1e-6).all(), tight
    loose = frame[(frame["library"] == "mechfmu") & (frame["tolerance"] == 1e-5)]
    for (problem, method), error in tight.set_index(["problem", "method"])["error"].items():
        looser = loose.set_index(["problem", "method"]).loc[(problem, method), "error"]
        assert error < looser, (problem, method)


def test_same_methods_same_work(frame):
    ours = frame[frame["library"] == "mechfmu"].set_index(["problem", "method", "tolerance"])
    theirs = frame[frame["library"] == "scipy"].set_index(["problem", "method", "tolerance"])
    for mine, scipys in (("dopri5", "RK45"), ("radau", "Radau")):
        for problem in wp.PROBLEMS:
            for tolerance in (1e-5, 1e-9):
                a = ours.loc[(problem, mine, tolerance), "rhs_evaluations"]
                b = theirs.loc[(problem, scipys, tolerance), "rhs_evaluations"]
                assert a == pytest.approx(b, rel=0.15), (problem, mine, tolerance)


def test_evaluations_at_target_errors_interpolate_between_runs():
    frame = pd.DataFrame(
        [
            {"problem": "p", "library": "x", "method": "m", "error": 1e-3, "rhs_evaluations": 100},
            {"problem": "p", "library": "x", "method": "m", "error": 1e-7, "rhs_evaluations": 1000},
        ]
    )
    summary = wp.evaluations_at(frame, (1e-5, 1e-9))
    assert summary.loc[0, "at 1e-05"] == pytest.approx(10**2.5)
    assert math.isnan(summary.loc[0, "at 1e-09"])
    assert summary.loc[0, "observed order"] == pytest.approx(4.0)  # 1e4 less error, 10x work


def test_command_writes_the_csv_and_the_table(tmp_path, capsys):
    assert cli(["study", "--work-precision", "--quick", "--out", str(tmp_path)]) == 0
    written = pd.read_csv(tmp_path / "work_precision.csv")
    assert len(written) == len(wp.PROBLEMS) * (
        (len(wp.OURS_ADAPTIVE) + len(wp.SCIPY)) * len(wp.QUICK_TOLERANCES) + 3
    )
    assert "#### valve" in (tmp_path / "work_precision.md").read_text(encoding="utf-8")
    assert "work_precision.csv" in capsys.readouterr().out
