"""Writers of result pairs for the SIGKILL test (test_result_pairs.py), forked on demand.

Started once, it imports mechfmu's writer, then reads lines ``OUT PAUSE STOP [STOP ...]`` on
stdin and for each STOP forks a writer (printing their process ids once each has written
its first whole pair, so a kill never comes before one) that writes the result <OUT>/k.csv and
k.json through mechfmu.cosim.results.write_result again and again, each time as a new run
whose rows end at STOP s (0 to STOP in 1 s steps), until it is killed. Forking skips the
interpreter's start-up, so a test can kill hundreds of writers in seconds; killed writers
are reaped at once (SIGCHLD ignored), so their process ids are gone as soon as they die.

The rename of the JSON (the first of a pair's two) is followed by a sleep of PAUSE s: the
gap between the two renames, widened as on a slow file system so the kills land in it often.
"""

import os
import signal
import sys
import time
from pathlib import Path
from types import SimpleNamespace

from mechfmu.cosim import files, results


def write_forever(out: Path, stop: float, pause: float, ready: int) -> None:
    replace = os.replace

    def slow_replace(source, target):
        replace(source, target)
        if str(target).endswith(".json"):
            time.sleep(pause)

    files.os.replace = slow_replace  # only mechfmu's writer, in this process
    times = [float(t) for t in range(int(stop) + 1)]
    scene = SimpleNamespace(
        name="k",
        path=out / "k.toml",
        description="",
        start_time=0.0,
        stop_time=stop,
        step=1.0,
        check=None,
    )
    result = SimpleNamespace(
        scene=scene,
        times=times,
        columns={"a.x": [t * stop for t in times]},
        units={"a.x": "m"},
        meta={"writer": stop},
        log=[],
        partial=False,
    )
    parent = os.getppid()
    results.write_result(result, out, plot=False)
    os.write(ready, b"1")  # one whole pair written: the kills may begin
    os.close(ready)
    while os.getppid() == parent:  # a writer outlives neither its killer nor the test
        results.write_result(result, out, plot=False)


def fork_writer(out: Path, stop: float, pause: float) -> tuple[int, int]:
    """(process id, the read end of its pipe) of a new writer."""
    ready, written = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(ready)
        try:
            write_forever(out, stop, pause, written)
        except BaseException as error:
            print(f"writer failed: {error!r}", file=sys.stderr, flush=True)
        finally:
            os._exit(1)
    os.close(written)
    return pid, ready


def main() -> None:
    signal.signal(signal.SIGCHLD, signal.SIG_IGN)  # the kernel reaps the killed writers
    results.versions()  # importlib.metadata's caches, warm in every writer forked
    for line in sys.stdin:
        out, pause, *stops = line.split()
        writers = [fork_writer(Path(out), float(stop), float(pause)) for stop in stops]
        for _, ready in writers:
            os.read(ready, 1)  # b"" if the writer failed before its first pair
            os.close(ready)
        print(" ".join(str(pid) for pid, _ in writers), flush=True)


if __name__ == "__main__":
    main()
