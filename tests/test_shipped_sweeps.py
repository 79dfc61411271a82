"""The shipped sweeps (src/mechfmu/sweeps/) in their quick form, against their references: the
static and dynamic snap-through masses, retraction time against supply pressure, valve float
speed against preload. `make sweeps` runs them in full."""

import math

import pytest

from conftest import SWEEPS
from mechfmu.cli import main as cli
from mechfmu.tools import sweep
from mechfmu.tools.report import sweeps


@pytest.fixture(scope="module")
def quick(fmu_dir, tmp_path_factory):
    """mechfmu example sweeps --quick (sims/run_sweeps.py --quick), run once: (exit status,
    out folder, findings)."""
    out = tmp_path_factory.mktemp("sweeps")
    status = cli(
        [
            "example",
            "sweeps",
            "--quick",
            "--jobs",
            "2",
            "--out",
            str(out),
            "--fmu-dir",
            str(fmu_dir),
        ]
    )
    return status, out, sweeps.analyse(SWEEPS, out)


def test_every_shipped_sweep_file_loads_and_names_its_sweep():
    names = sorted(path.stem for path in SWEEPS.glob("*.toml"))
    assert names == sorted(sweeps.SHIPPED)
    for name in names:
        chosen = sweep.load_sweep_file(SWEEPS / f"{name}.toml")
        assert chosen["scene_path"].is_file() and chosen["varies"] and chosen["metrics"]
        assert chosen["description"]
    static = sweep.load_sweep_file(SWEEPS / f"{sweeps.STATIC}.toml")
    assert (static["varies"][0].start, static["varies"][0].stop) == (0.0, 400.0)


def test_quick_run_agrees_with_the_references(quick):
    status, out, findings = quick
    assert status == 0
    static = findings["suspension"][sweeps.STATIC]
    sudden = findings["suspension"][sweeps.SUDDEN]
    # references: F*/g and the damped threshold of m u'' + c u' + F(u) = m g (scipy)
    assert static["reference_kg"] == pytest.approx(315.0441, abs=1e-3)
    assert sudden["reference_kg"] == pytest.approx(234.0845, abs=1e-3)
    assert static["bracket_kg"] == (315.0, 317.5) and static["inside"]
    assert sudden["bracket_kg"] == (232.5, 235.0) and sudden["inside"]
    assert sudden["reference_kg"] < static["reference_kg"]  # a sudden load snaps sooner
    assert static["deflection_max_error_m"] < 1e-12
    gear = findings["gear"]
    assert gear["points"] == 4 and gear["disagree"] == []
    assert gear["max_error_s"] < 1e-9
    times = dict(gear["times"])
    assert times[3e6] == -1.0  # stalls below ~3.76 MPa
    assert 2.25 < times[2.1e7] < times[1.5e7] < times[9e6] < 2.5
    assert gear["bracket_pa"] == (3e6, 9e6)
    assert 3e6 < gear["lowest_reference_pa"] < 9e6
    valve = findings["valve"]
    assert valve["points"] == 7 and valve["max_relative_error"] < 1e-12
    speeds = [speed for _, speed in valve["speeds"]]
    assert speeds == sorted(speeds)  # a stiffer preload floats later
    assert dict(valve["speeds"])[300.0] == pytest.approx(432.2334, abs=1e-4)


def test_quick_run_writes_the_summary_and_plots(quick):
    _, out, _ = quick
    text = (out / "summary.md").read_text()
    assert text.startswith("# Shipped sweeps")
    assert "| suspension_mass_static | 315.00 .. 317.50 kg | 315.0441 kg | yes |" in text
    assert (out / "suspension_mass.png").read_bytes()[:4] == b"\x89PNG"
    for name in sweeps.SHIPPED:
        rows = sweep.read_sweep_csv(out / name / "sweep.csv")
        assert len(rows) == len(sweep.grid_points([sweep.parse_vary(sweeps.QUICK_VARY[name])]))


def test_snap_bracket():
    rows = [{"m": m, "b": b, "error": None} for m, b in ((1.0, 0.0), (2.0, 0.0), (3.0, 1.0))]
    rows.append({"m": 0.0, "b": None, "error": "refused"})
    assert sweeps.snap_bracket(rows, "m", "b") == (2.0, 3.0)
    rows[0]["b"] = 1.0
    with pytest.raises(ValueError, match="interleave"):
        sweeps.snap_bracket(rows, "m", "b")
    below, above = sweeps.snap_bracket(rows[1:2], "m", "b")
    assert below == 2.0 and math.isnan(above)


def test_failures_name_what_disagrees(quick):
    _, _, findings = quick
    assert sweeps.failures(findings) == []
    findings["suspension"][sweeps.SUDDEN]["inside"] = False
    findings["valve"]["max_relative_error"] = 1e-3
    problems = sweeps.failures(findings)
    assert len(problems) == 2
    assert problems[0].startswith("suspension_mass_sudden: reference mass 234.08")
    assert "valve: float speeds differ by 0.001" in problems[1]
