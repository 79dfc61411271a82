"""Sweeps under faults: failed points make the command fail and are named; a worker process
that dies is replaced and its lost points retried (a bounded number of times, the last one
alone so that no innocent point is blamed); sweep.json stays current (SIGINT and SIGTERM:
test_sweep.py); a stopped sweep resumes without redoing finished points; a --scheduler address
where something other than Dask answers is a clear error within the timeout; counts that
are not positive are refused."""

import json
import socket
import threading
import time
from pathlib import Path

import pytest
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool

import sweep_worker_faults as faults
from mechfmu.cosim.interrupt import InterruptGuard
from mechfmu.tools import parallel, sweep
from mechfmu.cli import main as cli_main
from mechfmu.cosim.scene import SCENE_DIR as SCENES
from test_sweep import FMU_DIR, metric, write_scene

ROOT = Path(__file__).resolve().parents[1]
VARY = "suspension.spring_stiffness=8000:12000:8"
METRIC = "max:suspension.deflection"


def small_sweep(tmp_path, out, **options):
    options.setdefault("jobs", 2)
    return sweep.run_sweep(
        write_scene(tmp_path, stop=0.3),
        [sweep.parse_vary(VARY)],
        [metric(METRIC)],
        out,
        fmu_dir=FMU_DIR,
        progress=False,
        **options,
    )


def rows_by_index(out):
    rows = sweep.read_sweep_csv(out / "sweep.csv")
    indices = [row["index"] for row in rows]
    assert len(indices) == len(set(indices)), indices  # one row per point
    return {row["index"]: row for row in rows}


# --- failed points ------------------------------------------------------------------------------


def test_a_sweep_with_failed_points_exits_non_zero_and_names_them(tmp_path, capsys):
    """The issue's command: every point's stroke time is beyond the actuator's 4 s."""
    out = tmp_path / "out"
    code = cli_main(
        [
            "sweep",
            str(SCENES / "gear_retraction.toml"),
            "--vary",
            "actuator.stroke_time=5:6:3",
            "--metrics",
            "final:gear.gear_angle",
            "--jobs",
            "2",
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(out),
        ]
    )
    err = capsys.readouterr().err
    assert code == 1, err
    assert "sweep failed: 3 of 3 point(s) failed (index 0, 1, 2); index 0: " in err, err
    assert "stroke_time = 5.0 s is outside the valid range (0, 4.0] s" in err
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["failed"] == 3 and summary["failed_indices"] == [0, 1, 2]


# --- workers that die ---------------------------------------------------------------------------


def test_a_killed_worker_is_replaced_and_its_lost_points_retried(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep, "run_point", faults.run_point_or_die)
    monkeypatch.setenv(faults.ONCE, f"3:{faults.marker_path(tmp_path)}")
    out = tmp_path / "out"
    summary = small_sweep(tmp_path, out)
    assert Path(faults.marker_path(tmp_path)).is_file()  # a worker did die
    assert summary["done"] == 8 and summary["failed"] == 0, summary
    assert summary["pool_restarts"] == 1 and summary["retried"] >= 1
    monkeypatch.delenv(faults.ONCE)
    clean = tmp_path / "clean"
    small_sweep(tmp_path, clean)
    rows, expected = rows_by_index(out), rows_by_index(clean)
    assert sorted(rows) == list(range(8))
    assert [rows[i][METRIC] for i in range(8)] == [expected[i][METRIC] for i in range(8)]


def test_a_point_that_always_kills_its_worker_fails_alone_after_its_retries(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.setattr(sweep, "run_point", faults.run_point_or_die)
    monkeypatch.setenv(faults.ALWAYS, "2")
    out = tmp_path / "out"
    code = cli_main(
        [
            "sweep",
            str(write_scene(tmp_path, stop=0.3)),
            "--vary",
            VARY,
            "--metrics",
            METRIC,
            "--jobs",
            "2",
            "--retries",
            "2",
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(out),
        ]
    )
    err = capsys.readouterr().err
    assert code == 1, err
    assert (
        "sweep failed: 1 of 8 point(s) failed (index 2); index 2: worker: its process "
        "died on each of 3 attempt(s), the last one alone" in err
    ), err
    rows = rows_by_index(out)
    assert sorted(rows) == list(range(8))
    assert [i for i, row in rows.items() if row["error"]] == [2]  # no innocent point blamed
    summary = json.loads((out / "sweep.json").read_text())
    assert summary["failed_indices"] == [2] and summary["retries"] == 2


class _BreaksWhileSending:
    """A runner whose pool breaks between two submits, the way a ProcessPoolExecutor does
    when a worker dies: the next submit raises BrokenProcessPool at once, and the points in
    flight fail with it a moment later. One restart mends it."""

    workers = 2

    def __init__(self, refuse_at):
        self.refuse_at, self.submits, self.restarts = refuse_at, 0, 0
        self.in_flight = []
        self.runs = []  # the indices that ran, in order

    def submit(self, index, scene, *arguments):
        self.submits += 1
        if self.restarts == 0 and self.submits == self.refuse_at:
            for future in (future for future in self.in_flight if not future.done()):
                future.set_exception(BrokenProcessPool("a child process terminated"))
            raise BrokenProcessPool("a child process terminated abruptly")
        future = Future()
        self.in_flight.append(future)
        future.index = index
        return future

    def wait(self, futures, timeout):
        for future in futures:
            if not future.done():
                self.runs.append(future.index)
                future.set_result((future.index, {"m": float(future.index)}, None, 0.0, "w"))
        return set(futures)

    @staticmethod
    def lost(error):
        return isinstance(error, BrokenProcessPool)

    def restart(self):
        self.restarts += 1
        self.in_flight = []

    def idle(self):
        pass


@pytest.mark.parametrize("refuse_at", [1, 2, 5, 9])
def test_a_pool_that_breaks_while_points_are_sent_loses_none_and_blames_none(refuse_at):
    """The CI failure of stop 37: the executor refused a submit (its worker had died) before
    it failed the points in flight, and the sweep died with BrokenProcessPool. Now the
    refused point goes back to the queue unrun, the pool restarts once, every point is
    recorded once with its own result and no point spends an attempt it did not run."""
    runner = _BreaksWhileSending(refuse_at)
    recorded = {}

    def record(task, outcome):
        assert task.index not in recorded
        recorded[task.index] = (outcome, task.attempts)

    tasks = (sweep._Task(index, [float(index)], None) for index in range(12))
    summary = {"pool_restarts": 0, "retried": 0}
    with InterruptGuard() as guard:
        sweep._run_points(runner, tasks, (), 2, guard, record, summary, window=8)
    assert sorted(recorded) == list(range(12))
    assert all(outcome == ({"m": float(i)}, None, 0.0, "w") for i, (outcome, _) in recorded.items())
    assert summary["pool_restarts"] == runner.restarts == 1
    in_flight = set(range((refuse_at - 1) // 8 * 8, refuse_at - 1))  # sent since the last wait
    assert summary["retried"] == len(in_flight)
    assert {i: attempts for i, (_, attempts) in recorded.items()} == {
        i: 2 if i in in_flight else 1 for i in range(12)
    }  # the refused point spent no attempt
    assert sorted(runner.runs) == list(range(12))


# --- sweep.json while running -----------------------------------------------------------


def test_sweep_json_is_current_after_every_point(tmp_path):
    out = tmp_path / "out"
    seen = []

    def look(row):
        summary = json.loads((out / "sweep.json").read_text())
        seen.append(
            (summary["done"], summary["failed"], len(sweep.read_sweep_csv(out / "sweep.csv")))
        )

    small_sweep(tmp_path, out, on_point=look)
    assert seen == [(k, 0, k) for k in range(1, 9)]


# --- resuming -----------------------------------------------------------------------------------


def _interrupted_after(tmp_path, out, count, **options):
    seen = []

    def stop(row):
        seen.append(row["index"])
        if len(seen) == count:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        small_sweep(tmp_path, out, on_point=stop, **options)
    return seen


def test_a_stopped_sweep_resumes_without_redoing_finished_points(tmp_path):
    out = tmp_path / "out"
    finished = _interrupted_after(tmp_path, out, 3)
    redone = []
    summary = small_sweep(
        tmp_path, out, resume=True, on_point=lambda row: redone.append(row["index"])
    )
    assert sorted(redone) == sorted(set(range(8)) - set(finished))
    assert summary["done"] == 8 and summary["resumed"] == 3 and not summary["interrupted"]
    clean = tmp_path / "clean"
    small_sweep(tmp_path, clean)
    rows, expected = rows_by_index(out), rows_by_index(clean)
    assert sorted(rows) == list(range(8))
    assert all(rows[i][METRIC] == expected[i][METRIC] for i in range(8))


def test_no_thread_of_a_sweep_outlives_it(tmp_path, monkeypatch):
    """Interrupted, restarted after a worker died, or finished with a point alone: the
    executors' threads are gone when the sweep returns (a later fork would copy their locks;
    CPython 3.12+ warns of forks in a multi-threaded process)."""
    python_threads, os_threads = threading.active_count(), parallel.os_threads()
    _interrupted_after(tmp_path, tmp_path / "stopped", 3)
    assert threading.active_count() == python_threads
    assert parallel.os_threads() <= os_threads
    monkeypatch.setattr(sweep, "run_point", faults.run_point_or_die)
    monkeypatch.setenv(faults.ALWAYS, "1")
    summary = small_sweep(tmp_path, tmp_path / "killing", retries=1)
    assert summary["failed_indices"] == [1] and summary["pool_restarts"] == 1, summary
    assert threading.active_count() == python_threads
    assert parallel.os_threads() <= os_threads


def test_resume_redoes_the_failed_points(tmp_path):
    """spring_base_offset 0.6 m is outside (0, L): those points fail, and a resumed sweep
    runs them again (their failure may have been a dead worker)."""
    scene = write_scene(tmp_path, stop=0.3)
    varies = [
        sweep.parse_vary("suspension.spring_base_offset=0.2:0.6:2"),
        sweep.parse_vary("suspension.spring_stiffness=8000:12000:2"),
    ]
    out = tmp_path / "out"
    first = sweep.run_sweep(
        scene, varies, [metric(METRIC)], out, jobs=2, fmu_dir=FMU_DIR, progress=False
    )
    assert first["failed_indices"] == [2, 3]
    again = []
    second = sweep.run_sweep(
        scene,
        varies,
        [metric(METRIC)],
        out,
        jobs=2,
        fmu_dir=FMU_DIR,
        progress=False,
        resume=True,
        on_point=lambda row: again.append(row["index"]),
    )
    assert sorted(again) == [2, 3] and second["resumed"] == 2
    assert second["failed_indices"] == [2, 3] and sorted(rows_by_index(out)) == [0, 1, 2, 3]


def test_resume_refuses_another_sweep_or_nothing(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(sweep.SweepError, match="nothing to resume in .*: no sweep.json"):
        small_sweep(tmp_path, out, resume=True)
    _interrupted_after(tmp_path, out, 2)
    with pytest.raises(
        sweep.SweepError, match="cannot resume .*: its varies, points differ from this one.s"
    ):
        sweep.run_sweep(
            write_scene(tmp_path, stop=0.3),
            [sweep.parse_vary("suspension.spring_stiffness=8000:12000:9")],
            [metric(METRIC)],
            out,
            jobs=2,
            fmu_dir=FMU_DIR,
            progress=False,
            resume=True,
        )


# --- a --scheduler address where no Dask scheduler answers ---------------------------------------


class FakeServer:
    """A TCP server on 127.0.0.1 that sends ``greeting`` to each connection (None: nothing)
    and keeps it open."""

    def __init__(self, greeting):
        self.greeting, self.connections = greeting, []
        self.socket = socket.create_server(("127.0.0.1", 0))
        self.address = f"tcp://127.0.0.1:{self.socket.getsockname()[1]}"
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while True:
            try:
                connection, _ = self.socket.accept()
            except OSError:
                return
            self.connections.append(connection)
            if self.greeting is not None:
                try:
                    connection.sendall(self.greeting)
                except OSError:
                    pass

    def close(self):
        # shutdown wakes the thread's accept (close alone leaves it blocked for the process's life)
        try:
            self.socket.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.socket.close()
        self.thread.join(timeout=5)
        assert not self.thread.is_alive()
        for connection in self.connections:
            connection.close()


@pytest.mark.parametrize(
    "greeting, message",
    [
        (
            b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n\r\nhello" * 10,
            "something answered there, but not a Dask scheduler",
        ),
        (b"\xff" * 64, "something answered there, but not a Dask scheduler"),
        (None, "something accepted the connection but sent no Dask handshake within 1 s"),
    ],
)
def test_something_else_at_the_scheduler_address_is_a_clear_error(greeting, message):
    server = FakeServer(greeting)
    started = time.monotonic()
    try:
        with pytest.raises(sweep.SweepError) as raised:
            sweep.DaskCluster(server.address, timeout=1.0)
    finally:
        server.close()
    assert time.monotonic() - started < 10
    text = str(raised.value)
    assert text.startswith(f"--scheduler {server.address}: {message}"), text
    assert len(text.splitlines()) == 1


# --- counts that are not positive ------------------------------------------------------------------


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--vary", VARY, "--samples", "0"], "--samples = 0 must be at least 1"),
        (["--vary", VARY, "--samples", "-3"], "--samples = -3 must be at least 1"),
        (["--vary", VARY, "--jobs", "0"], "--jobs = 0 must be at least 1"),
        (["--vary", VARY, "--jobs", "-2"], "--jobs = -2 must be at least 1"),
        (["--vary", VARY, "--retries", "-1"], "--retries = -1 must be at least 0"),
        (["--vary", VARY, "--samples", "4", "--seed", "-1"], "--seed = -1 must be at least 0"),
        (["--vary", "suspension.spring_stiffness=1:2:0"], "COUNT must be at least 1"),
        (["--vary", "suspension.spring_stiffness=1:2:-5"], "COUNT must be at least 1"),
    ],
)
def test_counts_that_are_not_positive_are_refused(tmp_path, capsys, arguments, message):
    out = tmp_path / "out"
    code = cli_main(
        [
            "sweep",
            str(write_scene(tmp_path)),
            *arguments,
            "--metrics",
            METRIC,
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(out),
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and "sweep error: " in err and message in err, err
    assert not (out / "sweep.csv").exists()


def test_sweep_file_counts_are_checked_too(tmp_path):
    path = tmp_path / "negative.toml"
    path.write_text(
        f'scene = "{write_scene(tmp_path).as_posix()}"\n'
        f'vary = ["suspension.spring_stiffness=8000:12000"]\n'
        f'metrics = ["{METRIC}"]\nsamples = -2\nseed = 1\n'
    )
    settings = sweep.load_sweep_file(path)
    settings.pop("description")
    with pytest.raises(sweep.SweepError, match="samples = -2 must be at least 1"):
        sweep.run_sweep(
            **settings, out_dir=tmp_path / "out", jobs=1, fmu_dir=FMU_DIR, progress=False
        )


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--sequences", "-5"], "--sequences = -5 must be at least 1"),
        (["--sequences", "0"], "--sequences = 0 must be at least 1"),
        (["--jobs", "0"], "--jobs = 0 must be at least 1"),
        (["--sequences", "10", "--only", "10"], "--only = 10 must lie in [0, 9]"),
    ],
)
def test_fuzz_refuses_counts_that_are_not_positive(capsys, arguments, message):
    with pytest.raises(SystemExit) as raised:
        cli_main(["fuzz", "PistonActuator", *arguments, "--fmus", str(FMU_DIR)])
    err = capsys.readouterr().err
    assert raised.value.code == 2 and message in err, err
    assert "ok " not in capsys.readouterr().out


def test_an_unusable_out_stops_the_sweep_before_any_point(tmp_path, capsys):
    out = tmp_path / "out"
    out.write_text("a file, not a folder")
    code = cli_main(
        [
            "sweep",
            str(write_scene(tmp_path)),
            "--vary",
            VARY,
            "--metrics",
            METRIC,
            "--fmu-dir",
            str(FMU_DIR),
            "--out",
            str(out),
        ]
    )
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.strip().splitlines() == [f"sweep error: output folder {out} is not a directory"]
    assert out.read_text() == "a file, not a folder"
