"""mechfmu sweep: parsing, points, metrics, and end-to-end sweeps of a cheap scene."""

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mechfmu.tools import sweep
from mechfmu.tools.parallel import MAX_WORKERS_PER_CORE
from mechfmu.cli import main as cli_main
from mechfmu.cosim.master import Simulation
from mechfmu.cosim.scene import REFERENCE_DIR, load_scene

ROOT = Path(__file__).resolve().parents[1]
FMU_DIR = Path(os.environ.get("MECHFMU_FMU_DIR") or ROOT / "fmus")  # make sets it

needs_fmus = pytest.mark.skipif(not (FMU_DIR / "Suspension.fmu").is_file(), reason="FMUs not built")

SCENE = """\
name = "mini_ramp"
stop_time = {stop}
step = 0.01
reference = "{reference}"
connections = ["load.load -> suspension.load"]
record = ["load.load", "suspension.deflection", "suspension.snap_through"]

[components.load]
fmu = "LoadProfile"
parameters = {{ shape = "ramp", initial_value = 0.0, final_value = 4000.0, start_time = 0.0, duration = {stop} }}

[components.suspension]
fmu = "Suspension"
parameters = {{ spring_stiffness = 10000.0 }}
inputs = {{ road_height = 0.0, road_rate = 0.0 }}
"""


def write_scene(tmp_path, stop=1.0):
    path = tmp_path / "mini_ramp.toml"
    reference = REFERENCE_DIR / "suspension_load_ramp.csv"
    path.write_text(SCENE.format(stop=stop, reference=reference.as_posix()))
    return path


# --- parsing ---------------------------------------------------------------------------------


def test_parse_vary():
    vary = sweep.parse_vary("suspension.spring_stiffness=8000:12000:3")
    assert (vary.component, vary.variable, vary.start, vary.stop, vary.count) == (
        "suspension",
        "spring_stiffness",
        8000.0,
        12000.0,
        3,
    )
    assert vary.name == "suspension.spring_stiffness"
    assert sweep.parse_vary("a.b=1e-3:2").count is None  # range only, for sampling


@pytest.mark.parametrize(
    "text",
    [
        "a.b",
        "ab=1:2:3",
        "a.b=1:2:3:4",
        "a.b=x:2:3",
        "a.b=1:2:0",
        "a.b=1:2:1.5",
        "a.b=1:inf:2",
        ".b=1:2:2",
        "a.=1:2:2",
    ],
)
def test_parse_vary_rejects(text):
    with pytest.raises(sweep.SweepError, match="--vary"):
        sweep.parse_vary(text)


def test_parse_metric():
    metric = sweep.parse_metric("first_time_above:suspension.deflection:0.25")
    assert (metric.kind, metric.variable, metric.threshold) == (
        "first_time_above",
        "suspension.deflection",
        0.25,
    )
    assert sweep.parse_metric("max:a.b").threshold is None
    assert sweep.parse_metric("max_abs_error:a.b").kind == "max_abs_error"


@pytest.mark.parametrize(
    "text",
    [
        "mean:a.b",
        "max:ab",
        "max",
        "max:a.b:1",
        "first_time_above:a.b",
        "first_time_above:a.b:x",
        "final:.b",
    ],
)
def test_parse_metric_rejects(text):
    with pytest.raises(sweep.SweepError, match="--metrics"):
        sweep.parse_metric(text)


# --- points ----------------------------------------------------------------------------------


def test_grid_is_the_full_product():
    varies = [sweep.parse_vary("a.x=0:1:3"), sweep.parse_vary("a.y=10:20:2")]
    points = sweep.grid_points(varies)
    assert points.shape == (6, 2)
    assert points.tolist() == [[0, 10], [0, 20], [0.5, 10], [0.5, 20], [1, 10], [1, 20]]
    with pytest.raises(sweep.SweepError, match="COUNT"):
        sweep.grid_points([sweep.parse_vary("a.x=0:1")])


def test_lhs_one_sample_per_stratum_and_reproducible():
    n = 17
    unit = sweep.lhs_unit(n, 3, seed=4)
    for d in range(3):
        strata = np.floor(unit[:, d] * n).astype(int)
        assert sorted(strata) == list(range(n))
    assert np.array_equal(unit, sweep.lhs_unit(n, 3, seed=4))
    assert not np.array_equal(unit, sweep.lhs_unit(n, 3, seed=5))
    varies = [sweep.parse_vary("a.x=2:4"), sweep.parse_vary("a.y=-1:1:5")]
    points = sweep.sample_points(varies, 10, 1)
    assert points.shape == (10, 2)
    assert sorted(np.floor((points[:, 0] - 2) / 2 * 10).astype(int)) == list(range(10))
    assert np.all((points[:, 1] >= -1) & (points[:, 1] < 1))
    random = sweep.sample_points(varies, 10, 1, "random")
    assert np.array_equal(random, sweep.sample_points(varies, 10, 1, "random"))
    with pytest.raises(sweep.SweepError):
        sweep.sample_points(varies, 10, 1, "sobol")


# --- metrics ---------------------------------------------------------------------------------


def metric(text):
    return sweep.parse_metric(text)


def test_metrics_on_small_arrays():
    times = [0.0, 0.1, 0.2, 0.3, 0.4]
    values = [1.0, 3.0, 5.0, 2.0, 4.0]
    flags = [0.0, 0.0, 1.0, 1.0, 0.0]
    assert sweep.evaluate_metric(metric("final:a.b"), times, values) == 4.0
    assert sweep.evaluate_metric(metric("max:a.b"), times, values) == 5.0
    assert sweep.evaluate_metric(metric("min:a.b"), times, values) == 1.0
    assert sweep.evaluate_metric(metric("time_of_max:a.b"), times, values) == 0.2
    # a plateau whose samples differ in the last bits: its first sample, whichever is largest
    plateau = [1.0, 5.0, 5.0 * (1 + 4e-16), 5.0 * (1 - 2e-16), 2.0]
    assert sweep.evaluate_metric(metric("time_of_max:a.b"), times, plateau) == 0.1
    assert (
        sweep.evaluate_metric(
            metric("time_of_max:a.b"), times, [1.0, 5.0, 5.0 * (1 + 1e-6), 5.0, 2.0]
        )
        == 0.2
    )
    assert sweep.evaluate_metric(metric("first_time_above:a.b:2.5"), times, values) == 0.1
    assert math.isnan(sweep.evaluate_metric(metric("first_time_above:a.b:9"), times, values))
    assert sweep.evaluate_metric(metric("first_time_true:a.b"), times, flags) == 0.2
    assert math.isnan(sweep.evaluate_metric(metric("first_time_true:a.b"), times, [0.0] * 5))
    reference = ([0.0, 0.4], [1.0, 5.0])  # linear 1 + 10 t: interpolated onto the times
    assert sweep.evaluate_metric(
        metric("max_abs_error:a.b"), times, values, reference
    ) == pytest.approx(2.0)  # at t = 0.1: 3 vs 2; t = 0.2: 5 vs 3 -> 2; t = 0.3: 2 vs 4 -> 2
    assert math.isnan(sweep.evaluate_metric(metric("max:a.b"), [], []))


def test_safe_name():
    assert sweep.safe_name("first_time_above:s.d:0.5") == "first_time_above_s.d_0.5"


# --- checks before running -------------------------------------------------------------------


@needs_fmus
@pytest.mark.parametrize(
    "vary, metrics, message",
    [
        ("nothing.x=1:2:2", ["max:suspension.deflection"], "no component"),
        ("suspension.stiffness=1:2:2", ["max:suspension.deflection"], "has no variable"),
        ("suspension.load=1:2:2", ["max:suspension.deflection"], "is a input"),
        ("suspension.dynamics=0:1:2", ["max:suspension.deflection"], "Boolean"),
        ("suspension.spring_stiffness=1:2:2", ["max:suspension.velocity"], "not recorded"),
        ("suspension.spring_stiffness=1:2:2", ["max:nothing.velocity"], "not recorded"),
    ],
)
def test_errors_before_running(tmp_path, vary, metrics, message):
    scene = write_scene(tmp_path)
    with pytest.raises(sweep.SweepError, match=message):
        sweep.run_sweep(
            scene,
            [sweep.parse_vary(vary)],
            [metric(m) for m in metrics],
            tmp_path / "out",
            jobs=1,
            fmu_dir=FMU_DIR,
            progress=False,
        )
    assert not (tmp_path / "out" / "sweep.csv").exists()


@needs_fmus
def test_cli_error_exit_code(tmp_path, capsys):
    scene = write_scene(tmp_path)
    code = cli_main(
        [
            "sweep",
            str(scene),
            "--vary",
            "suspension.spring_stiffness=1:2:2",
            "--metrics",
            "mean:suspension.deflection",
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(tmp_path / "out"),
        ]
    )
    assert code == 2
    assert "unknown kind 'mean'" in capsys.readouterr().err


# --- end to end ------------------------------------------------------------------------------

METRICS = [
    "max:suspension.deflection",
    "final:load.load",
    "time_of_max:suspension.deflection",
    "first_time_above:suspension.deflection:0.1",
    "first_time_true:suspension.snap_through",
    "max_abs_error:suspension.deflection",
]


@needs_fmus
def test_grid_sweep_end_to_end(tmp_path, capsys):
    scene_path = write_scene(tmp_path)
    out = tmp_path / "out"
    # 3 x 2 grid: spring_base_offset 0.6 is outside (0, L): those points fail in the FMU
    code = cli_main(
        [
            "sweep",
            str(scene_path),
            "--vary",
            "suspension.spring_stiffness=8000:12000:3",
            "--vary",
            "suspension.spring_base_offset=0.2:0.6:2",
            "--metrics",
            *METRICS,
            "--jobs",
            "2",
            "--plot",
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(out),
        ]
    )
    captured = capsys.readouterr()
    assert code == 1, captured.err  # points failed: the command fails, naming them
    assert "6/6 done (3 failed)" in captured.err
    assert "sweep failed: 3 of 6 point(s) failed (index 1, 3, 5); index 1: " in captured.err
    rows = sweep.read_sweep_csv(out / "sweep.csv")
    assert sorted(row["index"] for row in rows) == list(range(6))
    header = (out / "sweep.csv").read_text().splitlines()[0].split(",")
    assert header == [
        "index",
        "suspension.spring_stiffness",
        "suspension.spring_base_offset",
        *METRICS,
        "error",
        "wall_time_s",
        "worker",
    ]
    by_index = {row["index"]: row for row in rows}
    for index, row in by_index.items():
        assert row["suspension.spring_stiffness"] == [8000.0, 10000.0, 12000.0][index // 2]
        assert row["suspension.spring_base_offset"] == [0.2, 0.6][index % 2]
        assert row["wall_time_s"] > 0
        if index % 2:
            assert "spring_base_offset = 0.6 m is outside the valid range" in row["error"]
            assert all(row[m] is None for m in METRICS)
        else:
            assert row["error"] is None
            assert all(row[m] is not None for m in METRICS)
    # one point against a direct run of the same scene
    scene = load_scene(scene_path)
    scene.components["suspension"].parameters.update(
        spring_stiffness=12000.0, spring_base_offset=0.2
    )
    result = Simulation(scene, FMU_DIR).run()
    deflection = np.array(result.columns["suspension.deflection"])
    times = np.array(result.times)
    row = by_index[4]
    assert row["max:suspension.deflection"] == deflection.max()
    assert row["final:load.load"] == result.columns["load.load"][-1]
    near_max = deflection >= deflection.max() - sweep.TIME_OF_MAX_RTOL * np.abs(deflection).max()
    assert row["time_of_max:suspension.deflection"] == times[np.argmax(near_max)]
    assert row["first_time_above:suspension.deflection:0.1"] == times[np.argmax(deflection > 0.1)]
    from mechfmu.io import read_csv

    ref_times, ref_columns = read_csv(scene.reference)
    expected = np.max(
        np.abs(deflection - np.interp(times, ref_times, ref_columns["suspension.deflection"]))
    )
    assert row["max_abs_error:suspension.deflection"] == expected
    # the JSON
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["method"] == "grid" and summary["jobs"] == 2
    assert summary["points"] == 6 and summary["done"] == 6 and summary["failed"] == 3
    assert summary["interrupted"] is False and summary["finished"]
    assert summary["metrics"] == METRICS
    assert [v["name"] for v in summary["varies"]] == [
        "suspension.spring_stiffness",
        "suspension.spring_base_offset",
    ]
    assert summary["varies"][0]["count"] == 3 and summary["varies"][0]["kind"] == "parameter"
    # the plots
    for name in METRICS:
        for parameter in ("suspension.spring_stiffness", "suspension.spring_base_offset"):
            path = out / f"{sweep.safe_name(name)}_vs_{parameter}.png"
            assert path.read_bytes()[:4] == b"\x89PNG"


@needs_fmus
def test_lhs_sweep_of_an_input(tmp_path):
    """A constant input can be swept; LHS points are reproducible with the seed."""
    scene_path = write_scene(tmp_path, stop=0.2)
    varies = [sweep.parse_vary("suspension.road_height=0:0.01")]
    metrics = [metric("final:suspension.deflection")]
    summary = sweep.run_sweep(
        scene_path,
        varies,
        metrics,
        tmp_path / "a",
        jobs=2,
        samples=3,
        seed=7,
        fmu_dir=FMU_DIR,
        progress=False,
    )
    assert summary["method"] == "lhs" and summary["seed"] == 7 and summary["samples"] == 3
    assert summary["varies"][0]["kind"] == "input"
    rows = sweep.read_sweep_csv(tmp_path / "a" / "sweep.csv")
    expected = sweep.sample_points(varies, 3, 7)[:, 0]
    assert sorted(row["suspension.road_height"] for row in rows) == sorted(expected.tolist())
    assert all(row["error"] is None for row in rows)


@needs_fmus
def test_interrupted_sweep_keeps_rows(tmp_path):
    scene_path = write_scene(tmp_path, stop=0.5)
    seen = []

    def stop_after_two(row):
        seen.append(row["index"])
        if len(seen) == 2:
            raise KeyboardInterrupt

    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        sweep.run_sweep(
            scene_path,
            [sweep.parse_vary("suspension.spring_stiffness=8000:12000:8")],
            [metric("max:suspension.deflection")],
            out,
            jobs=2,
            fmu_dir=FMU_DIR,
            on_point=stop_after_two,
            progress=False,
        )
    rows = sweep.read_sweep_csv(out / "sweep.csv")
    assert [row["index"] for row in rows] == seen
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["interrupted"] is True
    assert summary["done"] == 2 and summary["points"] == 8


def _default_signals():
    """In the child: the default dispositions, whatever the test runner inherited (a shell
    running it in the background ignores SIGINT)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


@needs_fmus
@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_to_the_command(tmp_path, signum, code):
    """Ctrl-C (to the process group, as a terminal sends it) or SIGTERM on ``python -m
    mechfmu sweep``: exit 130 / 143, rows kept, JSON marked interrupted with the signal and
    current (before, SIGTERM left it at done: 0)."""
    scene_path = write_scene(tmp_path, stop=1.0)
    out = tmp_path / "out"
    environment = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "mechfmu",
            "sweep",
            str(scene_path),
            "--vary",
            "suspension.spring_stiffness=8000:12000:40",
            "--metrics",
            "max:suspension.deflection",
            "--jobs",
            "2",
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(out),
        ],
        cwd=tmp_path,
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        preexec_fn=_default_signals,
    )
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            csv_path = out / "sweep.csv"
            if csv_path.is_file() and len(csv_path.read_text().splitlines()) >= 3:
                break
            time.sleep(0.05)
        else:
            pytest.fail("no rows appeared")
        if signum == signal.SIGINT:
            os.killpg(process.pid, signum)  # as the terminal does: the whole group
        else:
            process.send_signal(signum)
        _, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == code, err.decode()
    rows = sweep.read_sweep_csv(out / "sweep.csv")
    assert 2 <= len(rows) < 40
    assert all(row["error"] is None for row in rows)
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["interrupted"] is True and summary["done"] == len(rows)
    assert summary["signal"] == signum.name


# --- links and sweep files -------------------------------------------------------------------


def test_parse_link():
    link = sweep.parse_link("load.final_value=9.80665*suspension.mass")
    assert (link.component, link.variable, link.factor, link.source) == (
        "load",
        "final_value",
        9.80665,
        "suspension.mass",
    )
    assert sweep.parse_link("a.b = c.d").factor == 1.0
    assert sweep.parse_link("a.b=-2e3*c.d").factor == -2000.0


@pytest.mark.parametrize(
    "text", ["a.b", "ab=2*c.d", "a.b=x*c.d", "a.b=2*cd", "a.b=inf*c.d", "a.b=2*"]
)
def test_parse_link_rejects(text):
    with pytest.raises(sweep.SweepError, match="--link"):
        sweep.parse_link(text)


def test_point_values_follow_links():
    varies = [sweep.parse_vary("s.mass=0:400:3"), sweep.parse_vary("s.count=0:10:3")]
    links = [sweep.parse_link("l.final_value=9.5*s.mass")]
    kinds = {
        "s.mass": ("parameter", "Real"),
        "s.count": ("parameter", "Integer"),
        "l.final_value": ("parameter", "Real"),
    }
    assert sweep.point_values(varies, links, kinds, [200.0, 4.6]) == {
        "s.mass": 200.0,
        "s.count": 5,
        "l.final_value": 1900.0,
    }


@needs_fmus
@pytest.mark.parametrize(
    "link, message",
    [
        ("load.final_value=2*suspension.mass", "not varied"),
        ("suspension.spring_stiffness=2*suspension.spring_stiffness", "already varied"),
        ("load.shape=2*suspension.spring_stiffness", "String cannot be swept"),
    ],
)
def test_link_errors_before_running(tmp_path, link, message):
    with pytest.raises(sweep.SweepError, match=message):
        sweep.run_sweep(
            write_scene(tmp_path),
            [sweep.parse_vary("suspension.spring_stiffness=1:2:2")],
            [metric("max:suspension.deflection")],
            tmp_path / "out",
            jobs=1,
            fmu_dir=FMU_DIR,
            progress=False,
            links=[sweep.parse_link(link)],
        )


SWEEP_FILE = """\
description = "the mini ramp's load follows the stiffness"
scene = "mini_ramp.toml"
vary = ["suspension.spring_stiffness=8000:12000:3"]
link = ["load.final_value=0.25*suspension.spring_stiffness"]
metrics = ["final:load.load", "final:suspension.deflection"]
stop_time = 0.3
"""


@needs_fmus
def test_sweep_file_with_a_link_and_a_shorter_scene(tmp_path, capsys):
    """A sweep file: its scene relative to it, links, the scene's stop_time replaced; the
    command line's --metrics replace the file's; out/sweep_<file stem> by default."""
    write_scene(tmp_path)
    path = tmp_path / "stiff_load.toml"
    path.write_text(SWEEP_FILE)
    os.chdir(tmp_path)
    code = cli_main(["sweep", str(path), "--jobs", "1", "--fmu-dir", str(FMU_DIR)])
    assert code == 0, capsys.readouterr().err
    rows = sorted(
        sweep.read_sweep_csv(tmp_path / "out" / "sweep_stiff_load" / "sweep.csv"),
        key=lambda row: row["index"],
    )
    assert [row["load.final_value"] for row in rows] == [2000.0, 2500.0, 3000.0]
    for row in rows:
        # the ramp reaches 0.3 / 0.3 of its (shortened) duration at the last point: its
        # duration is the scene's 1 s, so 30 % of the final value
        assert row["final:load.load"] == pytest.approx(0.3 * row["load.final_value"], rel=1e-12)
    summary = json.loads((tmp_path / "out" / "sweep_stiff_load" / "sweep.json").read_text())
    assert summary["name"] == "stiff_load" and summary["overrides"] == {"stop_time": 0.3}
    assert summary["links"] == [
        {
            "name": "load.final_value",
            "kind": "parameter",
            "type": "Real",
            "factor": 0.25,
            "source": "suspension.spring_stiffness",
        }
    ]
    code = cli_main(
        [
            "sweep",
            str(path),
            "--jobs",
            "1",
            "--fmu-dir",
            str(FMU_DIR),
            "--metrics",
            "max:suspension.deflection",
            "--out",
            "other",
        ]
    )
    assert code == 0
    header = (tmp_path / "other" / "sweep.csv").read_text().splitlines()[0]
    assert header.split(",")[3] == "max:suspension.deflection"


@pytest.mark.parametrize(
    "text, message",
    [
        ('vary = ["a.b=1:2:2"]', "'scene' must name a scene file"),
        ('scene = "x.toml"\nwhatever = 1', "unknown key"),
        ('scene = "x.toml"\nvary = "a.b=1:2:2"', "'vary' must be a list"),
        ('scene = "x.toml"\nvary = ["a.b=1:2"]\nlink = ["a.c=x*a.b"]', "FACTOR 'x'"),
        ('scene = "x.toml"\n[', "malformed TOML"),
    ],
)
def test_bad_sweep_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(sweep.SweepError, match=message):
        sweep.load_sweep_file(path)


@needs_fmus
def test_only_stop_time_and_step_are_overridden(tmp_path):
    with pytest.raises(sweep.SweepError, match="cannot override the scene's coupling"):
        sweep.run_sweep(
            write_scene(tmp_path),
            [sweep.parse_vary("suspension.mass=1:2:2")],
            [metric("max:suspension.deflection")],
            tmp_path / "out",
            jobs=1,
            fmu_dir=FMU_DIR,
            progress=False,
            overrides={"coupling": "jacobi"},
        )


def test_more_local_workers_than_four_per_core_are_refused_before_anything(tmp_path):
    # --jobs 100000 forked worker processes until the machine stalled (a pool forks them all)
    too_many = MAX_WORKERS_PER_CORE * (os.cpu_count() or 1) + 1
    with pytest.raises(sweep.SweepError) as caught:
        sweep.run_sweep(
            write_scene(tmp_path),
            [sweep.parse_vary("suspension.mass=1:2:2")],
            [metric("max:suspension.deflection")],
            tmp_path / "out",
            jobs=too_many,
            fmu_dir=FMU_DIR,
            progress=False,
        )
    assert str(caught.value).startswith(f"--jobs = {too_many} is more than 4 local worker")
    assert not (tmp_path / "out").exists()


@needs_fmus
def test_no_more_workers_start_than_there_are_points(tmp_path):
    summary = sweep.run_sweep(
        write_scene(tmp_path, stop=0.2),
        [sweep.parse_vary("suspension.mass=1:2:1")],
        [metric("max:suspension.deflection")],
        tmp_path / "out",
        jobs=min(4, MAX_WORKERS_PER_CORE * (os.cpu_count() or 1)),
        fmu_dir=FMU_DIR,
        progress=False,
    )
    assert summary["jobs"] == 1 and summary["where"] == "local, 1 process(es)"


# --- one instance per worker, reset between points --------------------------------------------


@needs_fmus
def test_worker_reuses_its_instances(tmp_path):
    """run_point in this thread: the first point creates the two instances, the next ones
    reset and reuse them, and every point equals a fresh run of its scene."""
    scene = sweep.resolve_fmus(load_scene(write_scene(tmp_path, stop=0.5)), FMU_DIR)
    kinds = {"suspension.spring_stiffness": ("parameter", "Real")}
    metrics = [metric("max:suspension.deflection"), metric("final:load.load")]
    pool = sweep.worker_instances()
    created, reused = pool.created, pool.reused
    for count, stiffness in enumerate((8000.0, 12000.0, 8000.0), start=1):
        point = sweep.point_scene(scene, kinds, {"suspension.spring_stiffness": stiffness})
        index, values, error, wall, worker = sweep.run_point(count, point, metrics, {})
        assert error is None and worker == f"{os.uname().nodename}:{os.getpid()}"
        fresh = Simulation(point).run()
        assert values == {
            "max:suspension.deflection": max(fresh.columns["suspension.deflection"]),
            "final:load.load": fresh.columns["load.load"][-1],
        }
        assert pool.created - created <= 2  # at most the first point creates
        assert pool.reused - reused == 2 * count - (pool.created - created)
    assert sweep.worker_instances() is pool


@needs_fmus
def test_reset_instance_after_a_failed_run_equals_a_fresh_one(tmp_path):
    """A run refused in the middle (snap-through with stop_on_snap_through) leaves its
    instances mid-run; reset, they run the next scene exactly as new ones."""
    from mechfmu.cosim.master import Instances, SimulationError

    base = sweep.resolve_fmus(load_scene(write_scene(tmp_path)), FMU_DIR)
    kinds = {"suspension.stop_on_snap_through": ("parameter", "Boolean")}
    failing = sweep.point_scene(base, kinds, {"suspension.stop_on_snap_through": True})
    pool = Instances(keep=True)
    try:
        with pytest.raises(SimulationError, match="exceeds the limit load") as caught:
            Simulation(failing).run(instances=pool)
        assert 0 < len(caught.value.result.times) < base.steps + 1
        again = Simulation(base).run(instances=pool)
        fresh = Simulation(base).run()
        assert again.times == fresh.times and again.columns == fresh.columns
        assert again.log == fresh.log
        assert pool.created == 2 and pool.reused == 2
    finally:
        pool.close()


# --- a Dask cluster on loopback ---------------------------------------------------------------


@pytest.fixture(scope="module")
def dask_scheduler(tmp_path_factory):
    """A Dask scheduler and two single-thread workers on 127.0.0.1, as separate processes
    started by the ``dask`` command; yields the scheduler's address."""
    from distributed import Client

    folder = tmp_path_factory.mktemp("dask")
    scheduler_file = folder / "scheduler.json"
    dask = str(Path(sys.executable).parent / "dask")
    common = ["--no-dashboard", "--scheduler-file", str(scheduler_file)]
    processes = [
        subprocess.Popen(
            [dask, "scheduler", "--host", "127.0.0.1", "--port", "0", *common],
            stdout=subprocess.DEVNULL,
            stderr=open(folder / "scheduler.log", "wb"),
            cwd=folder,
        )
    ]
    try:
        deadline = time.monotonic() + 60
        # the file appears before dask has written it: wait for its content too
        while time.monotonic() < deadline and not (
            scheduler_file.is_file() and scheduler_file.read_text().rstrip().endswith("}")
        ):
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for number in range(2):
            processes.append(
                subprocess.Popen(
                    [
                        dask,
                        "worker",
                        "--host",
                        "127.0.0.1",
                        "--nthreads",
                        "1",
                        "--no-nanny",
                        "--name",
                        f"w{number}",
                        *common,
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=open(folder / f"worker{number}.log", "wb"),
                    cwd=folder,
                )
            )
        with Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for process in reversed(processes):  # the workers first, while they can say goodbye
            process.terminate()
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()


@needs_fmus
def test_sweep_on_a_dask_cluster(tmp_path, dask_scheduler):
    """The same sweep on the loopback cluster and on local processes: the same numbers, bit
    for bit, from both workers; a failing point recorded; the FMUs shipped by content."""
    scene_path = write_scene(tmp_path, stop=0.5)
    varies = [
        sweep.parse_vary("suspension.spring_stiffness=8000:12000:5"),
        sweep.parse_vary("suspension.spring_base_offset=0.2:0.6:2"),
    ]
    metrics = [metric(m) for m in METRICS]
    on_cluster = sweep.run_sweep(
        scene_path,
        varies,
        metrics,
        tmp_path / "dask",
        fmu_dir=FMU_DIR,
        progress=False,
        scheduler=dask_scheduler,
    )
    local = sweep.run_sweep(
        scene_path, varies, metrics, tmp_path / "local", jobs=2, fmu_dir=FMU_DIR, progress=False
    )
    assert on_cluster["where"].startswith(f"Dask {dask_scheduler}, 2 worker(s)")
    assert on_cluster["jobs"] == 2 and on_cluster["scheduler"] == dask_scheduler
    assert on_cluster["done"] == local["done"] == 10
    assert on_cluster["failed"] == local["failed"] == 5
    rows = {r["index"]: r for r in sweep.read_sweep_csv(tmp_path / "dask" / "sweep.csv")}
    expected = {r["index"]: r for r in sweep.read_sweep_csv(tmp_path / "local" / "sweep.csv")}
    assert sorted(rows) == list(range(10))
    for index, row in rows.items():
        for key in (
            "suspension.spring_stiffness",
            "suspension.spring_base_offset",
            *METRICS,
            "error",
        ):
            assert row[key] == expected[index][key], (index, key)
    assert len({row["worker"] for row in rows.values()}) == 2
    for path in {
        spec.fmu for spec in sweep.resolve_fmus(load_scene(scene_path), FMU_DIR).components.values()
    }:
        digest = __import__("hashlib").sha256(Path(path).read_bytes()).hexdigest()
        shipped = sweep.fmu_cache_dir() / digest / Path(path).name
        assert shipped.read_bytes() == Path(path).read_bytes()


def test_unreachable_scheduler_is_a_clear_error():
    started = time.monotonic()
    with pytest.raises(
        sweep.SweepError, match="tcp://127.0.0.1:9: cannot reach a Dask scheduler there within 2 s"
    ):
        sweep.DaskCluster("tcp://127.0.0.1:9", timeout=2.0)
    assert time.monotonic() - started < 15


def test_a_scheduler_without_distributed_names_the_cluster_extra(tmp_path, monkeypatch, capsys):
    """The base install leaves Dask out: --scheduler then says how to get it."""
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    with pytest.raises(sweep.SweepError, match=r"pip install 'mechfmu\[cluster\]'"):
        sweep.DaskCluster("tcp://127.0.0.1:1")
    code = cli_main(
        [
            "sweep",
            str(write_scene(tmp_path, stop=0.2)),
            "--vary",
            "suspension.spring_stiffness=1e4:2e4:2",
            "--metrics",
            "final:suspension.deflection",
            "--scheduler",
            "tcp://127.0.0.1:1",
            "--out",
            str(tmp_path / "out"),
            "--fmu-dir",
            str(FMU_DIR),
        ]
    )
    assert code == 2
    assert "mechfmu[cluster]" in capsys.readouterr().err
