"""Compare a result with a reference, column by column: ``mechfmu.compare``.

Two methods:

- ``"pointwise"``: the result and the reference share their time grid (or, with
  ``interpolate=True``, the reference is interpolated linearly onto the result's times) and a
  sample passes when ``|value - reference| <= atol + rtol * |reference|``.
- ``"tube"``: a sample ``(t, y)`` passes when the reference curve, widened by
  ``time_tolerance`` in time and by the value band in value, contains it:
  ``lo - (atol + rtol*|lo|) <= y <= hi + (atol + rtol*|hi|)`` where ``lo`` and ``hi`` are the
  minimum and maximum of the (piecewise linear) reference over ``[t - dt, t + dt]``: its
  samples inside the window and its interpolated values at the window's ends. A small time
  shift at a discontinuity (an event found one step later) passes; a changed amplitude does
  not. The result's time grid may differ from the reference's.

A NaN (or an infinity) passes only where the reference holds the same value. Every column of
the reference must be in the result ("missing column"), every column of the result in the
reference ("extra column", unless ``ignore_extra``); the time grids must agree ("time
grid"). ``Comparison.failures`` lists the first failing sample of each failing column.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from os import PathLike
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd

from .cosim.tolerances import Check, parse_check
from .cosim.text import plot_text

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["FAILURE_COLUMNS", "KINDS", "Comparison", "compare", "parse_tolerance"]

FAILURE_COLUMNS = ["column", "time", "value", "reference", "allowed", "kind"]
KINDS = ("value", "missing column", "extra column", "time grid")
Tolerance = float | tuple[float, float] | Mapping[str, float]


def _ulp_margin(times: np.ndarray) -> float:
    """How far two times that mean the same communication point may differ (s): 1e-9 of the
    smallest interval, at least 64 ulp of the largest |time|."""
    scale = float(np.max(np.abs(times))) if times.size else 0.0
    steps = np.diff(times)
    smallest = float(np.min(steps)) if steps.size else 0.0
    return max(1e-9 * smallest, 64.0 * float(np.spacing(max(scale, 1.0))))


def parse_tolerance(text: str) -> tuple[str, tuple[float, float | None]]:
    """``"COLUMN=RTOL"`` or ``"COLUMN=RTOL,ATOL"`` (the CLI's ``--tol``) as
    ``(column pattern, (rtol, atol or None))``; ValueError naming the text otherwise."""
    name, sep, values = text.partition("=")
    parts = values.split(",")
    try:
        numbers = [float(part) for part in parts]
    except ValueError:
        numbers = []
    if (
        not sep
        or not name.strip()
        or len(numbers) not in (1, 2)
        or not all(math.isfinite(x) and x >= 0 for x in numbers)
    ):
        raise ValueError(
            f"--tol {text!r}: expected COLUMN=RTOL or COLUMN=RTOL,ATOL with "
            f"numbers >= 0 (e.g. gear.gear_angle=1e-6)"
        )
    return name.strip(), (numbers[0], numbers[1] if len(numbers) == 2 else None)


def _tolerance(
    column: str, rtol: float, atol: float, tolerances: Mapping[str, Tolerance] | None
) -> tuple[float, float]:
    """(rtol, atol) of ``column``: the last entry of ``tolerances`` whose key (a column name
    or an fnmatch pattern such as ``gear.*``) matches it, else the defaults. An entry is an
    rtol, an (rtol, atol) pair (atol None: the default) or {"rtol": ..., "atol": ...}."""
    for pattern, value in (tolerances or {}).items():
        if not fnmatchcase(column, pattern):
            continue
        if isinstance(value, Mapping):
            rtol, atol = value.get("rtol", rtol), value.get("atol", atol)
        elif isinstance(value, tuple | list):
            rtol = value[0] if value[0] is not None else rtol
            atol = value[1] if len(value) > 1 and value[1] is not None else atol
        else:
            rtol = float(value)
    return float(rtol), float(atol)


def declared_check(reference: pd.DataFrame) -> Check | None:
    """The tolerances ``reference`` declares (``attrs["check"]``, from the JSON beside its
    CSV or from mechfmu.simulate/reference), or None; ValueError naming the file for a
    malformed declaration."""
    table = reference.attrs.get("check")
    if table is None:
        return None
    return parse_check(table, str(reference.attrs.get("file", "the reference")))


def _frame(data: Any, what: str) -> pd.DataFrame:
    """``data`` (a DataFrame indexed by time or with a ``time`` column, or the path of a
    result CSV) as a float DataFrame indexed by time; ValueError naming ``what``."""
    if isinstance(data, str | PathLike):
        from .io import read_result

        return read_result(data)
    if not isinstance(data, pd.DataFrame):
        raise TypeError(
            f"the {what} must be a pandas DataFrame or a CSV path, got {type(data).__name__}"
        )
    if "time" in data.columns:
        data = data.set_index("time")
    try:
        times = np.asarray(data.index, dtype=float)
        frame = pd.DataFrame(
            data.to_numpy(dtype=float),
            columns=[str(c) for c in data.columns],
            index=pd.Index(times, name="time"),
        )
    except (TypeError, ValueError) as error:
        raise ValueError(f"the {what} must hold numbers only: {error}") from None
    if not np.isfinite(times).all() or (np.diff(times) <= 0).any():
        raise ValueError(f"the {what}'s times must be finite and increase strictly")
    frame.attrs.update(data.attrs)
    return frame


class _Windows:
    """The tube's windows: for each result time t, [t - dt, t + dt] clipped to the
    reference's span, as what ``bounds`` needs for any column of the reference: the range
    of reference samples inside ([lo, hi)) and the interpolation at both ends. Computed once
    per comparison; ``bounds`` is then a few vectorised gathers per column (a sparse table
    of minima and maxima, only as deep as the longest window needs)."""

    def __init__(self, times: np.ndarray, ref_times: np.ndarray, dt: float) -> None:
        n = ref_times.size
        start = np.clip(times - dt, ref_times[0], ref_times[-1])
        stop = np.clip(times + dt, ref_times[0], ref_times[-1])
        self.lo = np.searchsorted(ref_times, start, side="left")
        self.hi = np.searchsorted(ref_times, stop, side="right")
        self.ends = []  # per window end: (j, w): value = (1 - w) * v[j - 1] + w * v[j]
        for edge in (start, stop):
            if n == 1:
                self.ends.append((np.ones(edge.shape, dtype=int), np.zeros(edge.shape)))
                continue
            j = np.clip(np.searchsorted(ref_times, edge, side="right"), 1, n - 1)
            w = np.clip((edge - ref_times[j - 1]) / (ref_times[j] - ref_times[j - 1]), 0.0, 1.0)
            self.ends.append((j, w))
        length = self.hi - self.lo
        self.empty = length <= 0
        self.level = np.floor(np.log2(np.maximum(length, 1))).astype(int)
        self.second = np.maximum(self.hi - (1 << self.level), self.lo)
        self.depth = int(self.level.max(initial=0)) + 1

    def bounds(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lo, hi, nan) per window: the minimum and maximum of the piecewise linear
        reference ``values`` over it (its samples inside and its values at both ends), and
        whether a reference sample inside is NaN."""
        n = values.size
        padded = np.append(values, values[-1:])  # v[j] for j = n (the one-sample case)
        low_table = np.full((self.depth, n), np.inf)
        high_table = np.full((self.depth, n), -np.inf)
        nan = np.isnan(values)
        low_table[0] = np.where(nan, np.inf, values)
        high_table[0] = np.where(nan, -np.inf, values)
        for k in range(1, self.depth):
            half, size = 1 << (k - 1), n - (1 << k) + 1
            low_table[k, :size] = np.minimum(
                low_table[k - 1, :size], low_table[k - 1, half : half + size]
            )
            high_table[k, :size] = np.maximum(
                high_table[k - 1, :size], high_table[k - 1, half : half + size]
            )
        lo = np.minimum(self.lo, n - 1)
        second = np.minimum(self.second, n - 1)
        low = np.where(
            self.empty, np.inf, np.minimum(low_table[self.level, lo], low_table[self.level, second])
        )
        high = np.where(
            self.empty,
            -np.inf,
            np.maximum(high_table[self.level, lo], high_table[self.level, second]),
        )
        for j, w in self.ends:
            end = (1.0 - w) * padded[j - 1] + w * padded[j]
            end = np.where(w == 0.0, padded[j - 1], np.where(w == 1.0, padded[j], end))
            low, high = np.minimum(low, end), np.maximum(high, end)
        counts = np.concatenate(([0], np.cumsum(nan)))
        return low, high, (counts[self.hi] - counts[self.lo]) > 0


def tube_bounds(
    times: np.ndarray, ref_times: np.ndarray, ref_values: np.ndarray, time_tolerance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo, hi, nan) at each of ``times`` (s): the minimum and maximum of the piecewise
    linear reference over [t - dt, t + dt] clipped to its span (its samples inside plus its
    interpolated values at the window's ends), and whether a NaN lies in the window."""
    return _Windows(times, ref_times, time_tolerance).bounds(ref_values)


@dataclass
class _Column:
    """What the comparison of one column found, kept for the summary and the plot."""

    times: np.ndarray
    values: np.ndarray
    reference: np.ndarray  # at ``times``: the reference (pointwise) or nearest window edge
    lower: np.ndarray  # the passing band's lower and upper edge at ``times``
    upper: np.ndarray
    allowed: np.ndarray
    failing: np.ndarray  # bool per sample


@dataclass
class Comparison:
    """The outcome of ``compare``: ``passed``, ``failures`` (one row per failing column,
    ordered by time; structural failures, whose time is NaN, first), ``summary`` (one row
    per compared column) and ``plot()``."""

    passed: bool
    failures: pd.DataFrame
    summary: pd.DataFrame
    method: str
    rtol: float
    atol: float
    time_tolerance: float | None
    samples: int  # result samples compared per column
    result: pd.DataFrame = field(repr=False)
    reference: pd.DataFrame = field(repr=False)
    _columns: dict[str, _Column] = field(default_factory=dict, repr=False)
    # the reference's declared tolerances when they (or some of them) applied, else None
    declared: Check | None = field(default=None, repr=False)
    not_compared: list[str] = field(default_factory=list)  # declared compare = false

    def __repr__(self) -> str:
        return f"<Comparison {self}>"

    @property
    def ok(self) -> bool:
        """Same as ``passed`` (the name ``mechfmu.check.compare`` used)."""
        return self.passed

    @property
    def columns(self) -> list[str]:
        """The columns compared sample by sample."""
        return list(self.summary.index)

    def describe(self, row: Mapping[Any, Any] | pd.Series) -> str:
        """A row of ``failures`` as one line (describe_failure, with where the result's
        file ends when it is shorter than the reference)."""
        times = self.result.index
        end = (len(times), float(times[-1])) if len(times) else None
        return describe_failure(row, end)

    def first_failure(self) -> str:
        """The first row of ``failures`` as one line ('' when everything passed)."""
        if self.failures.empty:
            return ""
        return self.describe(self.failures.iloc[0])

    def tolerance_text(self) -> str:
        """The tolerances that applied, in one phrase: 'rtol 1e-09, atol 1e-12', 'atol per
        column' where the columns' differ, the tube's half width, and 'declared by the
        reference' when the reference's own declaration applied."""
        per_column = len(self.summary) and (self.summary["atol"] != self.atol).any()
        text = f"rtol {self.rtol:g}, " + (
            "atol per column" if per_column else f"atol {self.atol:g}"
        )
        if self.method == "tube":
            text += f", tube of {self.time_tolerance:g} s"
        return f"declared by the reference: {text}" if self.declared is not None else text

    def __str__(self) -> str:
        compared = f"{len(self.summary)} column(s), {self.samples} sample(s)"
        if self.passed:
            worst = ""
            if len(self.summary) and not (self.summary["max_abs"] > 0).any():
                worst = "; every sample within the tube" if self.method == "tube" else "; identical"
            elif len(self.summary):
                row = self.summary.sort_values("ratio", ascending=False).iloc[0]
                worst = (
                    f"; worst: {row.name} at t = {float(row['worst_time'])!r} s, "
                    f"|difference| {row['max_abs']:.3e} ({row['ratio']:.2g} of allowed)"
                )
            return f"match: {compared}{worst}"
        more = len(self.failures) - 1
        extra = f"; {more} more failing column(s)" if more else ""
        return f"MISMATCH: {compared}; first: {self.first_failure()}{extra}"

    def draw(
        self,
        axis: Any,
        column: str,
        *,
        around: float | None = None,
        at: float | None = None,
        legend: bool = True,
    ) -> None:
        """Draw ``column`` on a matplotlib Axes: the band (pointwise) or tube, the reference,
        the result and the first failure (a red cross). ``around``: only the samples within
        that many seconds of time ``at`` (default: the first failure, else the start)."""
        data = self._columns[column]
        reference = self.reference[column]
        ref_times, ref_values = reference.index.to_numpy(), reference.to_numpy()
        shown: slice | np.ndarray = slice(None)
        ref_shown: slice | np.ndarray = slice(None)
        first = int(np.argmax(data.failing)) if data.failing.any() else None
        if around is not None:
            centre = (
                at if at is not None else data.times[first] if first is not None else data.times[0]
            )
            shown = (data.times >= centre - around) & (data.times <= centre + around)
            ref_shown = (ref_times >= centre - around) & (ref_times <= centre + around)
        label = "tube" if self.method == "tube" else "band"
        axis.fill_between(
            data.times[shown],
            data.lower[shown],
            data.upper[shown],
            color="tab:green",
            alpha=0.25,
            linewidth=0,
            label=label,
        )
        axis.plot(
            ref_times[ref_shown],
            ref_values[ref_shown],
            color="tab:green",
            linewidth=1.0,
            marker="." if around is not None else None,
            label="reference",
        )
        axis.plot(
            data.times[shown],
            data.values[shown],
            color="tab:blue",
            linewidth=1.0,
            linestyle="--",
            marker="." if around is not None else None,
            label="result",
        )
        if first is not None:
            axis.plot(
                [data.times[first]],
                [data.values[first]],
                "x",
                color="tab:red",
                markersize=10,
                mew=2,
                label=f"first failure, t = {data.times[first]:.6g} s",
            )
            axis.axvline(data.times[first], color="tab:red", linewidth=0.6)
        units = {**self.reference.attrs.get("units", {}), **self.result.attrs.get("units", {})}
        unit = units.get(column)
        axis.set_ylabel(plot_text(f"[{unit}]") if unit else "")
        axis.grid(True, linewidth=0.3)
        if legend:
            axis.legend(fontsize=7, loc="best")

    def plot(
        self, columns: str | list[str] | None = None, *, max_columns: int = 6, zoom: int = 25
    ) -> Figure:
        """A matplotlib Figure, one row per column (default: the failing ones, else all; at
        most ``max_columns``): the reference, the result, the tolerance band (pointwise) or
        tube, the first failure marked; beside a failing column, the same ``zoom`` samples
        either side of its first failure (0: no zoom)."""
        from matplotlib.figure import Figure

        if columns is None:
            failing = [c for c in self.failures["column"] if c in self._columns]
            columns = list(dict.fromkeys(failing)) or list(self._columns)
        elif isinstance(columns, str):
            columns = [columns]
        columns = [c for c in columns if c in self._columns][:max_columns]
        zoomed = zoom > 0 and any(self._columns[c].failing.any() for c in columns)
        figure = Figure(
            figsize=(11 if zoomed else 8, 1.2 + 2.4 * max(len(columns), 1)), layout="constrained"
        )
        axes = figure.subplots(
            max(len(columns), 1),
            2 if zoomed else 1,
            squeeze=False,
            width_ratios=[2, 1] if zoomed else None,
        )
        for row, name in zip(axes, columns):
            self.draw(row[0], name)
            row[0].set_title(plot_text(name), fontsize=9, loc="left")
            data = self._columns[name]
            if zoomed and data.failing.any():
                i = int(np.argmax(data.failing))
                lo, hi = max(i - zoom, 0), min(i + zoom, data.times.size - 1)
                self.draw(
                    row[1],
                    name,
                    around=max(data.times[i] - data.times[lo], data.times[hi] - data.times[i]),
                    legend=False,
                )
                row[1].set_title(f"around t = {data.times[i]:.6g} s", fontsize=9, loc="right")
            elif zoomed:
                row[1].set_axis_off()
        for axis in axes[-1]:
            axis.set_xlabel("time [s]")
        tolerance = f"rtol {self.rtol:g}, atol {self.atol:g}" + (
            f", time tolerance {self.time_tolerance:g} s" if self.method == "tube" else ""
        )
        figure.suptitle(
            f"{'passed' if self.passed else 'FAILED'} ({self.method}, {tolerance})", fontsize=10
        )
        return figure


def describe_failure(
    row: Mapping[Any, Any] | pd.Series, result_end: tuple[int, float] | None = None
) -> str:
    """One failure row as a line: 'gear.gear_angle at t = 1.5 s: 0.1 vs reference 0.2
    (|difference| 1e-1, allowed 1e-9)' or 'missing column gear.gear_angle'.
    ``result_end``: (rows, last time in s) of the result, to say where a result that ends
    before the reference ends (its file's last line)."""
    kind, column = row["kind"], row["column"]
    time, value, reference, allowed = (
        float(row[key]) for key in ("time", "value", "reference", "allowed")
    )
    if kind == "value":
        size = abs(value - reference)
        return (
            f"{column} at t = {time!r} s: {value!r} vs reference {reference!r} "
            f"(|difference| {size:.3e}, allowed {allowed:.3e})"
        )
    if kind == "time grid" and math.isnan(value) and result_end is not None:
        rows, last = result_end
        return (
            f"time grid: the result ends early, at t = {last!r} s (its file ends at line "
            f"{rows + 1}: cut short?); the reference goes on to t = {reference!r} s and beyond"
        )
    if kind == "time grid" and math.isnan(reference):
        return (
            f"time grid: the result goes on to t = {value!r} s after the reference's last "
            f"time (a longer run than the reference's?)"
        )
    if kind == "extra column":
        return (
            f"extra column {column} (not in the reference; --ignore-extra, or "
            f"ignore_extra=True, leaves such columns out)"
        )
    if kind == "time grid":
        found = "none" if math.isnan(value) else f"{value!r} s"
        expected = "none" if math.isnan(reference) else f"{reference!r} s"
        return (
            f"time grid: the result has time {found} where the reference has {expected} "
            f"(allowed difference {allowed:.3e} s)"
        )
    return f"{kind} {column}"


def _grid_failure(value: float, reference: float, allowed: float) -> dict[str, Any]:
    time = reference if not math.isnan(reference) else value
    return {
        "column": "time",
        "time": time,
        "value": value,
        "reference": reference,
        "allowed": allowed,
        "kind": "time grid",
    }


def _check_grid(
    times: np.ndarray, ref_times: np.ndarray, margin: float, same_grid: bool
) -> dict[str, Any] | None:
    """The first time-grid failure (a failures row) or None. ``same_grid``: the times must
    be the reference's (within ``margin``); otherwise the result must start and end where
    the reference does, within ``margin``."""
    if same_grid:
        n = min(times.size, ref_times.size)
        differ = np.abs(times[:n] - ref_times[:n]) > margin
        if differ.any():
            i = int(np.argmax(differ))
            return _grid_failure(float(times[i]), float(ref_times[i]), margin)
        if times.size != ref_times.size:
            longer = times.size > ref_times.size
            return _grid_failure(
                float(times[n]) if longer else math.nan,
                math.nan if longer else float(ref_times[n]),
                margin,
            )
        return None
    if abs(times[0] - ref_times[0]) > margin:
        return _grid_failure(float(times[0]), float(ref_times[0]), margin)
    if abs(times[-1] - ref_times[-1]) > margin:
        return _grid_failure(float(times[-1]), float(ref_times[-1]), margin)
    return None


def compare(
    result: pd.DataFrame | str | PathLike,
    reference: pd.DataFrame | str | PathLike,
    *,
    rtol: float | None = None,
    atol: float | None = None,
    method: Literal["pointwise", "tube"] | None = None,
    time_tolerance: float | None = None,
    tolerances: Mapping[str, Tolerance] | None = None,
    interpolate: bool = False,
    ignore_extra: bool = False,
) -> Comparison:
    """Compare ``result`` with ``reference``, column by column.

    The tolerances are the reference's own, declared in its ``attrs["check"]`` (the
    ``check`` of the JSON beside a reference CSV or a result: its scene's ``[check]``
    table, mechfmu.cosim.tolerances), where the caller gives none: ``rtol`` given replaces
    the table's rtol and every column's, ``atol`` likewise, ``method`` and
    ``time_tolerance`` theirs; ``tolerances`` apply on top. Without a declaration the
    defaults are rtol 1e-9, atol 1e-12, pointwise. Columns the declaration marks
    ``compare = false`` (solver statistics) are not compared and not extra.

    Args:
        result: a DataFrame indexed by time in s (``mechfmu.read_result``,
            ``mechfmu.simulate``; a ``time`` column works too) or the path of a result CSV.
        reference: the same, for the reference.
        rtol: relative tolerance: the value band is ``atol + rtol * |reference|`` (None:
            the reference's declared one, else 1e-9).
        atol: absolute tolerance, in the column's SI unit (None: declared, else 1e-12).
        method: ``"pointwise"`` (sample by sample) or ``"tube"`` (see the module
            docstring); None: declared, else pointwise.
        time_tolerance: the tube's half width in time (s); default: the reference's largest
            time step. Also how far the tube allows the result's first and last times to be
            from the reference's. Not used by ``"pointwise"``.
        tolerances: per-column overrides, ``{column or fnmatch pattern: rtol}``, or
            ``(rtol, atol)``, or ``{"rtol": ..., "atol": ...}``; the last matching key wins.
        interpolate: pointwise only: interpolate the reference linearly onto the result's
            times instead of requiring the same time grid (the first and last times must
            still agree).
        ignore_extra: columns of the result that the reference lacks are not failures.

    Returns:
        A Comparison: ``passed``; ``failures`` with columns ``column, time, value,
        reference, allowed, kind`` (kind one of "value", "missing column", "extra column",
        "time grid"), the first failing sample of each failing column; for the tube,
        ``reference`` is the window's minimum or maximum nearest to the value and
        ``allowed`` the band there; ``summary`` per compared column (``samples``,
        ``failing``, ``max_abs``, ``max_rel`` (of the column's peak |reference|),
        ``ratio`` (largest deviation / allowed; <= 1 passes), ``worst_time`` (where that
        ratio is), ``max_abs_time``, ``rtol``, ``atol``).

    Raises:
        ValueError: an unknown method, a negative tolerance, a DataFrame that is not a
            result; mechfmu.io.ResultFileError for a malformed file.
    """
    if method is not None and method not in ("pointwise", "tube"):
        raise ValueError(f"method must be 'pointwise' or 'tube', got {method!r}")
    for name, value in (("rtol", rtol), ("atol", atol), ("time_tolerance", time_tolerance)):
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    result_frame = _frame(result, "result")
    reference_frame = _frame(reference, "reference")
    declared = declared_check(reference_frame)
    check = declared or Check()
    given = {"rtol": rtol, "atol": atol, "method": method, "time_tolerance": time_tolerance}
    column_tolerances: dict[str, Tolerance] = {
        pattern: {key: value for key, value in entry.items() if given[key] is None}
        for pattern, entry in check.tolerances().items()
    }
    # whether any of the declaration applied (a tolerance the caller left to it)
    applied = rtol is None or atol is None or method is None or any(column_tolerances.values())
    column_tolerances.update(tolerances or {})
    tolerances = column_tolerances
    rtol = check.rtol if rtol is None else rtol
    atol = check.atol if atol is None else atol
    if method is None:
        method = check.method  # type: ignore[assignment]
        if time_tolerance is None:
            time_tolerance = check.time_tolerance
    not_compared = check.not_compared
    times = result_frame.index.to_numpy(dtype=float)
    ref_times = reference_frame.index.to_numpy(dtype=float)
    rows: list[dict[str, Any]] = []
    missing = [c for c in reference_frame.columns if c not in result_frame.columns]
    rows += [{"column": c, "kind": "missing column"} for c in missing]
    if not ignore_extra:
        rows += [
            {"column": c, "kind": "extra column"}
            for c in result_frame.columns
            if c not in reference_frame.columns
            and not any(fnmatchcase(c, pattern) for pattern in not_compared)
        ]
    shared = [
        c
        for c in reference_frame.columns
        if c in result_frame.columns and not any(fnmatchcase(c, p) for p in not_compared)
    ]
    margin = _ulp_margin(ref_times)
    dt = None
    if method == "tube":
        steps = np.diff(ref_times)
        dt = (
            float(time_tolerance)
            if time_tolerance is not None
            else float(steps.max())
            if steps.size
            else 0.0
        )
        grid = _check_grid(times, ref_times, dt + margin, same_grid=False)
    else:
        grid = _check_grid(times, ref_times, margin, same_grid=not interpolate)
    columns: dict[str, _Column] = {}
    summary_rows = []
    if grid is not None:
        rows.append(grid)
        shared = []
    windows = _Windows(times, ref_times, dt) if dt is not None and shared else None
    for name in shared:
        column_rtol, column_atol = _tolerance(name, rtol, atol, tolerances)
        values = result_frame[name].to_numpy(dtype=float)
        ref_values = reference_frame[name].to_numpy(dtype=float)
        if windows is not None:
            low, high, nan = windows.bounds(ref_values)
            lower = low - (column_atol + column_rtol * np.abs(low))
            upper = high + (column_atol + column_rtol * np.abs(high))
            above = values > high
            nearest = np.where(above, high, low)
            allowed = column_atol + column_rtol * np.abs(nearest)
            deviation = np.where(above, values - high, np.where(values < low, low - values, 0.0))
            passing = (
                ((lower <= values) & (values <= upper) & ~nan)
                | (np.isnan(values) & nan)
                | (values == low)
                | (values == high)
            )
        else:
            expected = np.interp(times, ref_times, ref_values) if interpolate else ref_values
            allowed = column_atol + column_rtol * np.abs(expected)
            deviation = np.abs(values - expected)
            nearest = expected
            lower, upper = expected - allowed, expected + allowed
            passing = (
                ((deviation <= allowed) & np.isfinite(expected))
                | (values == expected)
                | (np.isnan(values) & np.isnan(expected))
            )
        failing = ~passing
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(passing & ~(deviation > 0), 0.0, deviation / allowed)
        ratio = np.where(failing & ~(ratio > 1.0), np.inf, ratio)
        columns[name] = _Column(times, values, nearest, lower, upper, allowed, failing)
        worst = int(np.argmax(ratio)) if ratio.size else 0
        peak = float(np.nanmax(np.abs(ref_values))) if np.isfinite(ref_values).any() else 0.0
        max_abs = float(np.nanmax(deviation)) if np.isfinite(deviation).any() else math.nan
        if np.isnan(deviation).any() and failing.any():
            max_abs = math.inf if math.isnan(max_abs) else max_abs
        summary_rows.append(
            {
                "column": name,
                "samples": int(values.size),
                "failing": int(failing.sum()),
                "max_abs": max_abs,
                "max_rel": max_abs / peak if peak > 0 else (0.0 if max_abs == 0 else math.inf),
                "ratio": float(ratio[worst]) if ratio.size else 0.0,
                "worst_time": float(times[worst]) if ratio.size else math.nan,
                "max_abs_time": float(times[np.nanargmax(deviation)])
                if np.isfinite(deviation).any()
                else math.nan,
                "rtol": column_rtol,
                "atol": column_atol,
            }
        )
        if failing.any():
            i = int(np.argmax(failing))
            rows.append(
                {
                    "column": name,
                    "time": float(times[i]),
                    "value": float(values[i]),
                    "reference": float(nearest[i]),
                    "allowed": float(allowed[i]),
                    "kind": "value",
                }
            )
    failures = pd.DataFrame(rows, columns=FAILURE_COLUMNS).astype(
        {"time": float, "value": float, "reference": float, "allowed": float}
    )
    if len(failures):
        failures = failures.sort_values("time", na_position="first", kind="stable").reset_index(
            drop=True
        )
    summary = pd.DataFrame(
        summary_rows,
        columns=[
            "column",
            "samples",
            "failing",
            "max_abs",
            "max_rel",
            "ratio",
            "worst_time",
            "max_abs_time",
            "rtol",
            "atol",
        ],
    ).set_index("column")
    return Comparison(
        passed=failures.empty,
        failures=failures,
        summary=summary,
        method=str(method),
        rtol=rtol,
        atol=atol,
        time_tolerance=dt,
        declared=declared if declared is not None and applied else None,
        not_compared=[
            c
            for c in result_frame.columns
            if c not in shared
            and c not in reference_frame.columns
            and any(fnmatchcase(c, p) for p in not_compared)
        ],
        samples=int(times.size),
        result=result_frame,
        reference=reference_frame,
        _columns=columns,
    )
