"""A result is a pair that cannot be mixed (issue 32): two runs write k.csv and k.json into
one folder at once, and both are killed (SIGKILL: no handler runs) at random moments, many
times. Whatever the moment, reading k.csv gives one run's CSV with that run's JSON, or
refuses the pair naming both files; never the CSV of one run with the JSON of the other
(before: 3 of 28 kills left k.csv ending at 299 s beside a k.json of stop_time 300). The
temporary files of the killed writers are removed by the next writer into the folder.

The suite kills 30 times; ``make fuzz-inputs`` 1000 times (MECHFMU_PAIR_KILLS)."""

import contextlib
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

from mechfmu.cosim.files import output_folder
from mechfmu.io import ResultFileError, read_result

WRITER = Path(__file__).with_name("pair_writer.py")
KILLS = int(os.environ.get("MECHFMU_PAIR_KILLS", "30"))
STOPS = (299.0, 300.0)  # the two runs: their rows end at 299 s and at 300 s


def _dead(pid, timeout=10.0):
    """Wait until the killed writer ``pid`` is gone (reaped by its parent)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        assert time.monotonic() < deadline, f"writer {pid} outlived SIGKILL"
        time.sleep(0.001)


def _judge(out):
    """'first run', 'second run' (a consistent pair), 'refused' (a mixed pair named) or
    'absent'; AssertionError for a mixed pair accepted or any other error."""
    try:
        frame = read_result(out / "k.csv")
    except ResultFileError as error:
        message = str(error)
        if message.endswith("k.csv: file not found"):
            return "absent"
        assert " are not one pair: " in message, message
        return "refused"
    last = frame.index[-1]
    assert frame.attrs["stop_time"] == last == frame.attrs["writer"], (last, frame.attrs)
    assert list(frame["a.x"]) == [t * last for t in frame.index]
    return "first run" if last == STOPS[0] else "second run"


def test_killed_writers_never_leave_a_mixed_pair_that_reads(tmp_path):
    generator = random.Random(20261127)
    outcomes, writers = [], []
    forks = subprocess.Popen(
        [sys.executable, str(WRITER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        for kill in range(KILLS):
            out = tmp_path / f"out{kill % 4}"
            out.mkdir(exist_ok=True)
            pause = generator.choice((0.0, 0.05))
            forks.stdin.write(f"{out} {pause!r} {' '.join(map(repr, STOPS))}\n")
            forks.stdin.flush()
            writers = [int(pid) for pid in forks.stdout.readline().split()]
            for pid in generator.sample(writers, 2):
                time.sleep(generator.uniform(0.0, 0.04))
                os.kill(pid, signal.SIGKILL)
            for pid in writers:
                _dead(pid)
            outcomes.append(_judge(out))
    finally:
        for pid in writers:  # after a failure: no writer left behind
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        forks.stdin.close()
        forks.wait(timeout=30)
        forks.stdout.close()
    counts = {kind: outcomes.count(kind) for kind in set(outcomes)}
    assert counts.get("refused", 0) >= 1, counts  # the kills reach the renames' gap
    assert "absent" not in counts, counts  # every writer wrote a whole pair before its kill
    assert counts.get("first run", 0) + counts.get("second run", 0) >= KILLS // 4, counts
    for out in tmp_path.iterdir():  # the next writer into each folder cleans up
        output_folder(out)
        assert not [path.name for path in out.iterdir() if path.name.endswith(".tmp")]
