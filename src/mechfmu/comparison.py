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
from collections.abc import Callable, Iterator, Mapping
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


def check_tolerance_value(name: str, value: float | None) -> None:
    """ValueError naming ``name`` unless ``value`` (a tolerance: rtol, atol or the tube's time
    tolerance, in its column's units or s) is None or a finite number >= 0."""
    if value is not None and not (math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")


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
    if not len(frame):
        # as a result file with only its header is malformed: an empty table never matches
        # by default (a regression check that compares nothing must not pass)
        raise ValueError(f"the {what} has no rows: nothing to compare")
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
    # (rows, last time in s) of the result; None when it has no rows
    result_end: tuple[int, float] | None = field(default=None, repr=False)
    # for files compared block by block (no rows kept): the same comparison of the files
    # read whole, made when a plot needs the arrays
    _whole: Callable[[], Comparison] | None = field(default=None, repr=False)
    _loaded: Comparison | None = field(default=None, repr=False)

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
        return describe_failure(row, self.result_end)

    def _plotted(self) -> Comparison:
        """The comparison whose arrays the plots draw: itself, or (files compared block by
        block) the files' comparison read whole, made once."""
        if self._whole is None:
            return self
        if self._loaded is None:
            self._loaded = self._whole()
        return self._loaded

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
        if self._whole is not None:
            return self._plotted().draw(axis, column, around=around, at=at, legend=legend)
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
        either side of its first failure (0: no zoom). Files compared block by block are
        read whole for it."""
        if self._whole is not None:
            return self._plotted().plot(columns, max_columns=max_columns, zoom=zoom)
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
    block_bytes: int | None = None,
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
            ``mechfmu.simulate``; a ``time`` column works too) or the path of a result CSV
            (or ``.parquet``), read block by block: a file of any size is compared in the
            memory of a few blocks (``block_bytes`` of text each), with the outcome the
            whole file would give.
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
        block_bytes: the text read at a time from a file (default: result_blocks.BLOCK_BYTES,
            2 MiB).

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
            result or has no rows; mechfmu.io.ResultFileError for a malformed file.
    """
    if method is not None and method not in ("pointwise", "tube"):
        raise ValueError(f"method must be 'pointwise' or 'tube', got {method!r}")
    for name, value in (("rtol", rtol), ("atol", atol), ("time_tolerance", time_tolerance)):
        check_tolerance_value(name, value)
    options: dict[str, Any] = {
        "rtol": rtol,
        "atol": atol,
        "method": method,
        "time_tolerance": time_tolerance,
        "tolerances": tolerances,
        "interpolate": interpolate,
        "ignore_extra": ignore_extra,
    }
    result_source = _source(result, "result", block_bytes)
    reference_source = _source(reference, "reference", block_bytes)
    settings = _Settings.resolve(reference_source, options)
    comparison = _Engine(result_source, reference_source, settings).run()
    if isinstance(result_source, _FrameSource) and isinstance(reference_source, _FrameSource):
        return comparison
    comparison._whole = lambda: compare(  # the plots of a streamed comparison read the files
        _frame(result, "result"), _frame(reference, "reference"), **options
    )
    return comparison


# --- the comparison, block by block ---------------------------------------------------------
#
# One route for DataFrames and files: a DataFrame is a source of one block, a file a source of
# many (mechfmu.result_blocks). Everything a summary holds is a running quantity (a count, a
# first failure, a maximum and where it is first reached), so a comparison made block by block
# gives what the whole arrays give, to the bit; the reference is held only over the result
# block's span (the tube's window and one sample either side).


class _FrameSource:
    """A DataFrame as a source of one block."""

    def __init__(self, frame: pd.DataFrame) -> None:
        self.frame = frame
        self.columns = list(frame.columns)
        self.attrs = frame.attrs

    def blocks(self) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        yield self.frame.index.to_numpy(dtype=float), self.frame.to_numpy(dtype=float)


class _FileSource:
    """A result file (mechfmu.result_blocks) as a source of blocks."""

    def __init__(self, path: str | PathLike, block_bytes: int | None) -> None:
        from .result_blocks import BLOCK_BYTES, open_result

        # one block at a time: a file of any size (the plots, read whole, keep the limit)
        self.source = open_result(path, block_bytes or BLOCK_BYTES, max_bytes=None)
        self.columns = self.source.columns
        self.attrs = self.source.attrs
        self.path = path

    def blocks(self) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        for _, values in self.source.blocks():
            yield values[:, 0], values[:, 1:]


_Source = _FrameSource | _FileSource


def _source(data: Any, what: str, block_bytes: int | None) -> _Source:
    if isinstance(data, str | PathLike):
        return _FileSource(data, block_bytes)
    return _FrameSource(_frame(data, what))


@dataclass
class _Settings:
    """compare's options resolved against the reference's declaration."""

    rtol: float
    atol: float
    method: str
    time_tolerance: float | None
    tolerances: Mapping[str, Tolerance]
    interpolate: bool
    ignore_extra: bool
    not_compared: list[str]
    declared: Check | None

    @classmethod
    def resolve(cls, reference: _Source, options: dict[str, Any]) -> _Settings:
        declared = declared_check(reference)  # type: ignore[arg-type]
        check = declared or Check()
        given = {key: options[key] for key in ("rtol", "atol", "method", "time_tolerance")}
        column_tolerances: dict[str, Tolerance] = {
            pattern: {key: value for key, value in entry.items() if given[key] is None}
            for pattern, entry in check.tolerances().items()
        }
        # whether any of the declaration applied (a tolerance the caller left to it)
        applied = (
            given["rtol"] is None
            or given["atol"] is None
            or given["method"] is None
            or any(column_tolerances.values())
        )
        column_tolerances.update(options["tolerances"] or {})
        method, time_tolerance = given["method"], given["time_tolerance"]
        if method is None:
            method = check.method
            if time_tolerance is None:
                time_tolerance = check.time_tolerance
        return cls(
            rtol=check.rtol if given["rtol"] is None else given["rtol"],
            atol=check.atol if given["atol"] is None else given["atol"],
            method=str(method),
            time_tolerance=time_tolerance,
            tolerances=column_tolerances,
            interpolate=bool(options["interpolate"]),
            ignore_extra=bool(options["ignore_extra"]),
            not_compared=list(check.not_compared),
            declared=declared if declared is not None and applied else None,
        )


class _Reference:
    """The reference's rows as the comparison walks the result: the shared columns of the
    rows it needs now, and running figures of every row read (count, first and last time,
    smallest step, each column's peak |value|)."""

    def __init__(self, source: _Source, indices: list[int]) -> None:
        self.blocks = source.blocks()
        self.indices = indices
        self.times = np.empty(0)
        self.values = np.empty((0, len(indices)))
        self.count = 0
        self.first = math.nan
        self.last = math.nan
        self.smallest_step = math.inf
        self.peak = np.full(len(indices), -np.inf)  # nanmax |value| per column so far
        self.finite = np.zeros(len(indices), dtype=bool)  # a finite value in the column
        self.exhausted = False

    def _pull(self) -> bool:
        """Read the next block into the buffer; False at the end."""
        if self.exhausted:
            return False
        block = next(self.blocks, None)
        if block is None:
            self.exhausted = True
            return False
        times, values = block
        values = values[:, self.indices]
        if times.size:
            steps = np.diff(np.concatenate(([self.last], times)) if self.count else times)
            if steps.size:
                self.smallest_step = min(self.smallest_step, float(np.min(steps)))
            if not self.count:
                self.first = float(times[0])
            self.last = float(times[-1])
            self.count += times.size
            magnitudes = np.where(np.isnan(values), -np.inf, np.abs(values))
            self.peak = np.maximum(self.peak, magnitudes.max(axis=0))
            self.finite |= np.isfinite(values).any(axis=0)
        self.times = np.concatenate((self.times, times))
        self.values = np.concatenate((self.values, values))
        return True

    def take(self, rows: int) -> tuple[np.ndarray, np.ndarray]:
        """The next ``rows`` rows (fewer at the end), removed from the buffer."""
        while self.times.size < rows and self._pull():
            pass
        times, values = self.times[:rows], self.values[:rows]
        self.times, self.values = self.times[rows:], self.values[rows:]
        return times, values

    def cover(self, start: float, stop: float) -> tuple[np.ndarray, np.ndarray]:
        """The rows from the last at or before ``start`` (else the first) to the first at
        or after ``stop`` (else the last); the rows before them leave the buffer."""
        while (not self.times.size or self.times[-1] < stop) and self._pull():
            pass
        first = max(int(np.searchsorted(self.times, start, side="right")) - 1, 0)
        last = int(np.searchsorted(self.times, stop, side="left"))
        self.times, self.values = self.times[first:], self.values[first:]
        return self.times[: last - first + 1], self.values[: last - first + 1]

    def drain(self) -> None:
        """Read the rest (for the figures), keeping only the first row left."""
        while self._pull():
            self.times, self.values = self.times[:1], self.values[:1]

    def margin(self) -> float:
        """How far two times that mean the same communication point may differ (s): 1e-9
        of the reference's smallest step, at least 64 ulp of its largest |time|."""
        if not self.count:
            return 64.0 * float(np.spacing(1.0))
        scale = max(abs(self.first), abs(self.last))
        smallest = self.smallest_step if self.count > 1 else 0.0
        return max(1e-9 * smallest, 64.0 * float(np.spacing(max(scale, 1.0))))


def _largest_step(source: _Source) -> float:
    """The reference's largest time step (s), read in one pass (0 for one sample)."""
    largest, last = 0.0, None
    for times, _ in source.blocks():
        if times.size:
            steps = np.diff(np.concatenate(([last], times)) if last is not None else times)
            if steps.size:
                largest = max(largest, float(steps.max()))
            last = float(times[-1])
    return largest


class _GridRecords:
    """The same-grid check, block by block: the first row where |result time - reference
    time| exceeds a margin known only at the end. That row is a record (its difference
    exceeds every earlier one), so only the records are kept; those under the smallest
    margin there can be are left out."""

    FLOOR = 64.0 * float(np.spacing(1.0))  # the smallest margin _ulp_margin gives
    LIMIT = 1_000_000  # records kept at most (a grid drifting ever further away)

    def __init__(self) -> None:
        self.largest = 0.0
        self.records: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.kept = 0

    def add(self, times: np.ndarray, ref_times: np.ndarray) -> None:
        difference = np.abs(times - ref_times)
        if not difference.size or not float(difference.max()) > max(self.largest, self.FLOOR):
            return
        before = np.maximum.accumulate(np.concatenate(([self.largest], difference)))[:-1]
        record = (difference > before) & (difference > self.FLOOR)
        self.largest = float(max(self.largest, difference.max()))
        if self.kept < self.LIMIT:
            self.records.append((difference[record], times[record], ref_times[record]))
            self.kept += int(record.sum())

    def first_beyond(self, margin: float) -> tuple[float, float] | None:
        """(result time, reference time) of the first row beyond ``margin``, or None."""
        for difference, times, ref_times in self.records:
            beyond = difference > margin
            if beyond.any():
                i = int(np.argmax(beyond))
                return float(times[i]), float(ref_times[i])
        return None


class _Stats:
    """One column's running summary: what compare's summary row and failure row hold."""

    def __init__(self) -> None:
        self.samples = 0
        self.failing = 0
        self.first: dict[str, Any] | None = None
        self.ratio = -math.inf
        self.worst_time = math.nan
        self.max_abs = -math.inf
        self.max_abs_time = math.nan
        self.any_finite = False  # a finite deviation somewhere
        self.nan_deviation = False

    def add(
        self,
        times: np.ndarray,
        values: np.ndarray,
        nearest: np.ndarray,
        allowed: np.ndarray,
        deviation: np.ndarray,
        passing: np.ndarray,
    ) -> np.ndarray:
        """Take one block's samples in; returns their failing mask."""
        failing = ~passing
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(passing & ~(deviation > 0), 0.0, deviation / allowed)
        ratio = np.where(failing & ~(ratio > 1.0), np.inf, ratio)
        if not times.size:
            return failing
        self.samples += times.size
        worst = int(np.argmax(ratio))
        if ratio[worst] > self.ratio:
            self.ratio, self.worst_time = float(ratio[worst]), float(times[worst])
        if np.isfinite(deviation).any():
            self.any_finite = True
        if not np.isnan(deviation).all():
            i = int(np.nanargmax(deviation))
            if deviation[i] > self.max_abs:
                self.max_abs, self.max_abs_time = float(deviation[i]), float(times[i])
        count = int(failing.sum())
        self.nan_deviation |= bool(np.isnan(deviation).any())
        if count:
            if self.first is None:
                i = int(np.argmax(failing))
                self.first = {
                    "time": float(times[i]),
                    "value": float(values[i]),
                    "reference": float(nearest[i]),
                    "allowed": float(allowed[i]),
                    "kind": "value",
                }
            self.failing += count
        return failing

    def add_passing(
        self, times: np.ndarray, deviation: np.ndarray, ratio: np.ndarray, worst: int, largest: int
    ) -> None:
        """Take in one block of samples that all pass (finite, within their band): what
        ``add`` takes from them, given their deviations and ratios and the rows ``worst``
        and ``largest`` where the ratio and the deviation first reach their maxima."""
        if not times.size:
            return
        self.samples += times.size
        if ratio[worst] > self.ratio:
            self.ratio, self.worst_time = float(ratio[worst]), float(times[worst])
        self.any_finite = True
        if deviation[largest] > self.max_abs:
            self.max_abs, self.max_abs_time = float(deviation[largest]), float(times[largest])

    def row(self, name: str, peak: float, rtol: float, atol: float) -> dict[str, Any]:
        """The summary row (compare's columns)."""
        max_abs = self.max_abs if self.any_finite else math.nan
        max_abs_time = self.max_abs_time if self.any_finite else math.nan
        if self.nan_deviation and self.failing:
            max_abs = math.inf if math.isnan(max_abs) else max_abs
        return {
            "column": name,
            "samples": self.samples,
            "failing": self.failing,
            "max_abs": max_abs,
            "max_rel": max_abs / peak if peak > 0 else (0.0 if max_abs == 0 else math.inf),
            "ratio": self.ratio if self.samples else 0.0,
            "worst_time": self.worst_time if self.samples else math.nan,
            "max_abs_time": max_abs_time,
            "rtol": rtol,
            "atol": atol,
        }


def _pointwise(
    values: np.ndarray, expected: np.ndarray, rtol: float, atol: float
) -> tuple[np.ndarray, ...]:
    """(nearest, lower, upper, allowed, deviation, passing) of samples against the band
    ``atol + rtol * |expected|`` around ``expected``."""
    allowed = atol + rtol * np.abs(expected)
    deviation = np.abs(values - expected)
    passing = (
        ((deviation <= allowed) & np.isfinite(expected))
        | (values == expected)
        | (np.isnan(values) & np.isnan(expected))
    )
    return expected, expected - allowed, expected + allowed, allowed, deviation, passing


def _passing_block(
    values: np.ndarray, expected: np.ndarray, rtol: np.ndarray, atol: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """(deviation, deviation / allowed) of rows x columns ``values`` against ``expected``
    (``rtol``, ``atol``: one per column) when every sample is finite and within its band
    (what ``_pointwise`` computes, elementwise the same operations, in one pass over the
    block instead of one per column: the common case of a long check); else None."""
    deviation = np.abs(values - expected)
    allowed = atol + rtol * np.abs(expected)
    if not (deviation <= allowed).all() or not np.isfinite(expected).all():
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(deviation > 0, deviation / allowed, 0.0)
    return deviation, ratio


def _tube(
    values: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    nan: np.ndarray,
    rtol: float,
    atol: float,
) -> tuple[np.ndarray, ...]:
    """(nearest, lower, upper, allowed, deviation, passing) of samples against the tube
    between the window minima ``low`` and maxima ``high`` widened by the value band."""
    lower = low - (atol + rtol * np.abs(low))
    upper = high + (atol + rtol * np.abs(high))
    above = values > high
    nearest = np.where(above, high, low)
    allowed = atol + rtol * np.abs(nearest)
    deviation = np.where(above, values - high, np.where(values < low, low - values, 0.0))
    passing = (
        ((lower <= values) & (values <= upper) & ~nan)
        | (np.isnan(values) & nan)
        | (values == low)
        | (values == high)
    )
    return nearest, lower, upper, allowed, deviation, passing


class _Engine:
    """One comparison of two sources (see the section's comment)."""

    def __init__(self, result: _Source, reference: _Source, settings: _Settings) -> None:
        self.result, self.reference, self.settings = result, reference, settings
        patterns = settings.not_compared
        self.shared = [
            c
            for c in reference.columns
            if c in result.columns and not any(fnmatchcase(c, p) for p in patterns)
        ]
        self.keep = isinstance(result, _FrameSource)  # arrays kept for the plots
        self.stats = {name: _Stats() for name in self.shared}
        self.kept: dict[str, list[tuple[np.ndarray, ...]]] = {name: [] for name in self.shared}
        self.tolerance = {
            name: _tolerance(name, settings.rtol, settings.atol, settings.tolerances)
            for name in self.shared
        }
        # (rtol, atol) of the shared columns as arrays, for a block at once
        self.bands = (
            np.array([self.tolerance[name][0] for name in self.shared], dtype=float),
            np.array([self.tolerance[name][1] for name in self.shared], dtype=float),
        )

    def _structure_rows(self) -> list[dict[str, Any]]:
        result, reference, settings = self.result, self.reference, self.settings
        rows: list[dict[str, Any]] = [
            {"column": c, "kind": "missing column"}
            for c in reference.columns
            if c not in result.columns
        ]
        if not settings.ignore_extra:
            rows += [
                {"column": c, "kind": "extra column"}
                for c in result.columns
                if c not in reference.columns
                and not any(fnmatchcase(c, p) for p in settings.not_compared)
            ]
        return rows

    def _column_blocks(
        self, times: np.ndarray, values: np.ndarray, ref: _Reference, dt: float | None
    ) -> None:
        """Compare one block of result rows, every shared column."""
        settings = self.settings
        positions = [self.result.columns.index(name) for name in self.shared]
        if dt is not None:
            ref_times, ref_values = ref.cover(times[0] - dt, times[-1] + dt)
            windows = _Windows(times, ref_times, dt)
        elif settings.interpolate:
            ref_times, ref_values = ref.cover(times[0], times[-1])
        else:
            ref_times, ref_values = ref.take(times.size)
            if not self.keep and self._all_pass(times, values[:, positions], ref_values):
                return
        for k, (name, position) in enumerate(zip(self.shared, positions)):
            rtol, atol = self.tolerance[name]
            column = values[:, position]
            if dt is not None:
                arrays = _tube(column, *windows.bounds(ref_values[:, k]), rtol, atol)
            elif settings.interpolate:
                expected = np.interp(times, ref_times, ref_values[:, k])
                arrays = _pointwise(column, expected, rtol, atol)
            else:
                arrays = _pointwise(column, ref_values[:, k], rtol, atol)
            nearest, lower, upper, allowed, deviation, passing = arrays
            failing = self.stats[name].add(times, column, nearest, allowed, deviation, passing)
            if self.keep:
                self.kept[name].append((times, column, nearest, lower, upper, allowed, failing))

    def _all_pass(self, times: np.ndarray, values: np.ndarray, expected: np.ndarray) -> bool:
        """Same grid, pointwise: when every sample of the block passes, take the block into
        the columns' figures at once and say True; else False (nothing taken: the per
        column route follows and names what fails)."""
        if values.shape != expected.shape:
            return False
        passing = _passing_block(values, expected, *self.bands)
        if passing is None:
            return False
        deviation, ratio = passing
        worst, largest = ratio.argmax(axis=0), deviation.argmax(axis=0)
        for k, name in enumerate(self.shared):
            self.stats[name].add_passing(
                times, deviation[:, k], ratio[:, k], int(worst[k]), int(largest[k])
            )
        return True

    def run(self) -> Comparison:
        """Walk the result's blocks once; the Comparison."""
        settings = self.settings
        indices = [self.reference.columns.index(name) for name in self.shared]
        dt = None
        if settings.method == "tube":
            dt = (
                float(settings.time_tolerance)
                if settings.time_tolerance is not None
                else _largest_step(self.reference)
            )
        ref = _Reference(self.reference, indices)
        records = _GridRecords()
        same_grid = settings.method != "tube" and not settings.interpolate
        rows, first, last = 0, math.nan, math.nan
        extra: float | None = None  # same grid: the result's first time past the reference's
        for times, values in self.result.blocks():
            if not times.size:
                continue
            if not rows:
                first = float(times[0])
            rows += times.size
            last = float(times[-1])
            if same_grid:
                if extra is not None:
                    continue  # the grids differ: the rest is only read (checked)
                while ref.times.size < times.size and ref._pull():
                    pass
                n = min(times.size, ref.times.size)
                records.add(times[:n], ref.times[:n])
                if n < times.size:
                    extra = float(times[n])
                    continue
            self._column_blocks(times, values, ref, dt)
        ref.drain()
        margin = ref.margin()
        grid = None
        if same_grid:
            beyond = records.first_beyond(margin)
            if beyond is not None:
                grid = _grid_failure(*beyond, margin)
            elif extra is not None:
                grid = _grid_failure(extra, math.nan, margin)
            elif ref.times.size:  # the reference goes on after the result's last row
                grid = _grid_failure(math.nan, float(ref.times[0]), margin)
        else:
            allowed = margin + (dt or 0.0)
            if rows and ref.count:
                if abs(first - ref.first) > allowed:
                    grid = _grid_failure(first, ref.first, allowed)
                elif abs(last - ref.last) > allowed:
                    grid = _grid_failure(last, ref.last, allowed)
        return self._comparison(grid, ref, dt, (rows, last))

    def _comparison(
        self,
        grid: dict[str, Any] | None,
        ref: _Reference,
        dt: float | None,
        end: tuple[int, float],
    ) -> Comparison:
        settings = self.settings
        rows = self._structure_rows()
        columns: dict[str, _Column] = {}
        summary_rows = []
        shared = self.shared
        if grid is not None:
            rows.append(grid)
            shared = []
        for k, name in enumerate(shared):
            stats = self.stats[name]
            peak = float(ref.peak[k]) if ref.finite[k] else 0.0
            summary_rows.append(stats.row(name, peak, *self.tolerance[name]))
            if stats.first is not None:
                rows.append({"column": name, **stats.first})
            if self.keep:
                parts = self.kept[name]
                columns[name] = _Column(
                    *(np.concatenate([part[i] for part in parts]) for i in range(7))
                )
        failures = pd.DataFrame(rows, columns=FAILURE_COLUMNS).astype(
            {"time": float, "value": float, "reference": float, "allowed": float}
        )
        if len(failures):
            failures = failures.sort_values("time", na_position="first", kind="stable").reset_index(
                drop=True
            )
        summary = pd.DataFrame(summary_rows, columns=SUMMARY_COLUMNS).set_index("column")
        result, reference = self.result, self.reference
        return Comparison(
            passed=failures.empty,
            failures=failures,
            summary=summary,
            method=settings.method,
            rtol=settings.rtol,
            atol=settings.atol,
            time_tolerance=dt,
            declared=settings.declared,
            not_compared=[
                c
                for c in result.columns
                if c not in self.shared
                and c not in reference.columns
                and any(fnmatchcase(c, p) for p in settings.not_compared)
            ],
            samples=end[0],
            result=_frame_of(result),
            reference=_frame_of(reference),
            _columns=columns,
            result_end=end if end[0] else None,
        )


SUMMARY_COLUMNS = [
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
]


def _frame_of(source: _Source) -> pd.DataFrame:
    """The source's DataFrame; for a file, its columns and attrs without rows (a streamed
    comparison keeps no rows)."""
    if isinstance(source, _FrameSource):
        return source.frame
    frame = pd.DataFrame(columns=source.columns, index=pd.Index([], name="time", dtype=float))
    frame.attrs.update(source.attrs)
    return frame
