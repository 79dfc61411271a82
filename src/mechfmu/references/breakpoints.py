"""Piecewise references: which solution piece a sample time belongs to (numpy).

A reference integrated in pieces (restarted at events) must answer at every sample time,
whatever the event times round to: a sample that falls a rounding error outside a piece's
[start, end] must not be dropped. Pieces here are contiguous by construction (each starts
where the previous one ended), so they are located by their start times alone:
sample t belongs to the last piece whose start is <= t (numpy.searchsorted over the starts),
samples before the first start belong to the first piece and the last piece is closed at
the end, so every sample has exactly one piece. Times in s.
"""

import numpy as np
from numpy.typing import ArrayLike


def piece_of_samples(
    starts: "ArrayLike", ends: "ArrayLike", times: "ArrayLike", slack: float = 1e-9
) -> np.ndarray:
    """Index of the piece each of ``times`` belongs to (int array).

    ``starts``/``ends``: the pieces' start and end times in order, contiguous (each start
    equal to the previous end). A sample belongs to the last piece starting at or before it;
    the first piece also takes samples before its start and the last piece those after its
    end, but only within ``slack`` (s) times max(1, |t|): a sample further out means the
    pieces do not cover the sampled span (an integration that stopped early), a ValueError
    naming the time and the covered span.
    """
    starts = np.asarray(starts, dtype=float)
    ends = np.asarray(ends, dtype=float)
    times = np.asarray(times, dtype=float)
    if starts.size == 0 or starts.size != ends.size:
        raise ValueError(
            f"{starts.size} piece starts and {ends.size} ends: need as many, at least one"
        )
    if np.any(np.diff(starts) < 0.0):
        raise ValueError("piece starts are not sorted")
    margin = slack * np.maximum(1.0, np.abs(times))
    outside = (times < starts[0] - margin) | (times > ends[-1] + margin)
    if np.any(outside):
        t = float(times[np.flatnonzero(outside)[0]])
        raise ValueError(
            f"sample t = {t!r} s lies outside the integrated span "
            f"[{float(starts[0])!r}, {float(ends[-1])!r}] s"
        )
    return np.clip(np.searchsorted(starts, times, side="right") - 1, 0, starts.size - 1)
