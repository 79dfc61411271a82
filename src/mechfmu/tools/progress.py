"""The one progress line of the long commands (``mechfmu sweep``, ``mechfmu study``)."""

import math
import sys
import time
from typing import TextIO


class Progress:
    """One line on ``stream`` (stderr by default), rewritten in place: done/total, failures,
    rate, time left, and an optional note (the last point). ``already``: points done
    before (a resumed sweep), not counted in the rate."""

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        already: int = 0,
        label: str = "sweep",
        unit: str = "scenes",
    ) -> None:
        self.total, self.started, self.already = total, time.perf_counter(), already
        self.stream = stream or sys.stderr
        self.label, self.unit = label, unit

    def update(self, done: int, failed: int = 0, note: str = "") -> None:
        """Show ``done`` of the total, ``failed`` of them failed; a newline at the end."""
        elapsed = time.perf_counter() - self.started
        rate = (done - self.already) / elapsed if elapsed > 0 else 0.0
        left = (self.total - done) / rate if rate > 0 else math.inf
        left_text = f"{left:.0f} s" if math.isfinite(left) else "?"
        end = "\n" if done == self.total else ""
        note = f", {note}" if note else ""
        self.stream.write(
            f"\r{self.label}: {done}/{self.total} done ({failed} failed), "
            f"{rate:.2f} {self.unit}/s, {left_text} left{note}   {end}"
        )
        self.stream.flush()
