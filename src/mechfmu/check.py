"""Compare a result CSV with a reference CSV within explicit tolerances."""

from dataclasses import dataclass

import numpy as np

from .cosim.results import read_csv


@dataclass
class Deviation:
    column: str
    time: float
    value: float
    reference: float
    allowed: float

    @property
    def size(self):
        return abs(self.value - self.reference)

    def __str__(self):
        return (f"{self.column} at t = {self.time!r} s: {self.value!r} vs reference "
                f"{self.reference!r} (|difference| {self.size:.3e}, allowed {self.allowed:.3e})")


@dataclass
class Comparison:
    ok: bool
    columns: list       # compared column names
    samples: int        # result samples inside the reference's time span
    worst: Deviation    # largest deviation relative to its allowance (None if no samples)

    def __str__(self):
        verdict = "match" if self.ok else "MISMATCH"
        worst = f"; worst: {self.worst}" if self.worst else ""
        return f"{verdict}: {len(self.columns)} column(s), {self.samples} sample(s){worst}"


def compare(result_path, reference_path, rtol=1e-9, atol=1e-12):
    """Interpolate the reference onto the result's times and compare shared columns.

    A sample passes when |value - reference| <= atol + rtol * |reference|; NaN never passes.
    Raises ValueError when the files share no column or no time span.
    """
    times, columns = read_csv(result_path)
    ref_times, ref_columns = read_csv(reference_path)
    shared = [name for name in columns if name in ref_columns]
    if not shared:
        raise ValueError(f"{result_path} and {reference_path} share no column besides time")
    times, ref_times = np.asarray(times), np.asarray(ref_times)
    span = (times >= ref_times[0] - 1e-12) & (times <= ref_times[-1] + 1e-12)
    if not span.any():
        raise ValueError(f"{result_path} has no time inside the reference's "
                         f"[{ref_times[0]}, {ref_times[-1]}] s")
    worst, worst_score = None, -1.0
    for name in shared:
        values = np.asarray(columns[name])[span]
        reference = np.interp(times[span], ref_times, np.asarray(ref_columns[name]))
        allowed = atol + rtol * np.abs(reference)
        score = np.abs(values - reference) / allowed
        score[~np.isfinite(values)] = np.inf
        i = int(np.argmax(score))
        if score[i] > worst_score:
            worst_score = float(score[i])
            worst = Deviation(name, float(times[span][i]), float(values[i]),
                              float(reference[i]), float(allowed[i]))
    return Comparison(worst_score <= 1.0, shared, int(span.sum()), worst)
