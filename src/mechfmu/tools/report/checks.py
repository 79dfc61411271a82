"""What ``mechfmu check`` writes besides its terminal lines: a JUnit XML file (``--junit``)
for CI servers, and an HTML page with a plot of every failing column (``--report``).

JUnit: one ``<testsuite name="mechfmu check">``; one ``<testcase>`` per file and column
(``classname`` the file's relative path, ``name`` the column), failing with the first
failure's line as its message and its kind as ``type``; a file that is missing or malformed
is one testcase named ``(file)``, a different time grid one named ``(time grid)`` (its columns
are then skipped: not compared), a result without a reference a skipped ``(file)``.

Names come from the files checked and may hold anything: in the XML every character XML 1.0
cannot hold (a control character, a lone surrogate) is replaced by its escape (``\\x01``,
mechfmu.cosim.text.one_line); the HTML likewise; each plot's file name is a readable ASCII
label of the file and column, at most 60 characters, and a hash of the exact pair, so two
pairs never share a plot and no name is too long (plot_name). A plot that cannot be written
is named in the index, which is always written, last.
"""

from __future__ import annotations

import hashlib
import html
import io
import math
import re
import xml.etree.ElementTree as ET
from os import PathLike
from pathlib import Path

from ...check import CheckRun, FileCheck
from ...cosim.files import OutputError, atomic_write, output_folder
from ...cosim.tables import ResultFileError
from ...cosim.text import one_line


def _cases(check: FileCheck) -> list[tuple[str, str | None, str | None, str]]:
    """(name, failure kind or None, message or None, skipped message or '') per testcase."""
    if check.comparison is None:
        if check.kind == "no reference":
            return [("(file)", None, None, check.problem or "")]
        return [("(file)", check.kind, check.problem, "")]
    comparison = check.comparison
    failures = {row["column"]: row for row in comparison.failures.to_dict("records")}
    cases: list[tuple[str, str | None, str | None, str]] = []
    grid = failures.pop("time", None)
    if grid is not None:
        cases.append(("(time grid)", "time grid", comparison.describe(grid), ""))
    names = list(comparison.reference.columns)
    names += [
        c
        for c in comparison.result.columns
        if c not in comparison.reference.columns and c in failures
    ]
    for name in names:
        row = failures.get(name)
        if row is not None:
            cases.append((name, row["kind"], comparison.describe(row), ""))
        elif name not in comparison.summary.index:
            cases.append((name, None, None, "not compared: the time grids differ"))
        else:
            cases.append((name, None, None, ""))
    return cases


def junit_xml(run: CheckRun) -> str:
    """The JUnit XML text of a check (see the module docstring)."""
    suite = ET.Element("testsuite", name="mechfmu check")
    counts = {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}
    for check in run.files:
        for name, kind, message, skipped in _cases(check):
            case = ET.SubElement(
                suite, "testcase", classname=one_line(check.name), name=one_line(name), time="0"
            )
            counts["tests"] += 1
            if kind is not None:
                counts["failures"] += 1
                failure = ET.SubElement(
                    case, "failure", message=one_line(message or kind), type=one_line(kind)
                )
                failure.text = one_line(f"{check.name}: {message}")
            elif skipped:
                counts["skipped"] += 1
                ET.SubElement(case, "skipped", message=one_line(skipped))
    for key, value in counts.items():
        suite.set(key, str(value))
    root = ET.Element("testsuites", {"name": "mechfmu check"})
    for key, value in counts.items():
        root.set(key, str(value))
    root.append(suite)
    ET.indent(root)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def write_junit(run: CheckRun, path: str | PathLike) -> Path:
    """Write junit_xml(run) to ``path`` atomically; returns the path."""
    return atomic_write(Path(path), junit_xml(run))


STYLE = """body{font-family:sans-serif;margin:1.5em;max-width:70em}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:2px 6px;
text-align:left;font-size:90%}.pass{color:#176317}.fail{color:#b00020}img{max-width:100%}"""


def _number(value: float) -> str:
    return (
        "" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.9g}"
    )


def _text(value: object) -> str:
    """``value`` as HTML text: one line of printable characters, escaped."""
    return html.escape(one_line(str(value)))


def plot_name(file: str, column: str) -> str:
    """The PNG file name of ``column`` of ``file`` in a report: an ASCII label of both (at
    most 60 characters) and 12 hex digits of the SHA-256 of the exact pair, so distinct
    pairs never share a name ('x y' and 'x_y', 'sub/x.csv' and 'sub_x.csv')."""
    label = re.sub(r"[^A-Za-z0-9._-]+", "_", f"{file}__{column}").strip("_.")[:60] or "plot"
    pair = f"{file}\x00{column}".encode("utf-8", "surrogatepass")
    return f"{label}-{hashlib.sha256(pair).hexdigest()[:12]}.png"


def _plot(check: FileCheck, column: str, folder: Path) -> str:
    """The HTML of ``column``'s plot, written to its PNG (or why it could not be)."""
    assert check.comparison is not None
    name = plot_name(check.name, column)
    try:
        buffer = io.BytesIO()
        check.comparison.plot(column).savefig(buffer, format="png", dpi=90)
        atomic_write(folder / name, buffer.getvalue())
    except (OutputError, ResultFileError) as error:  # a plot reads the files whole (2 GiB)
        return f'<p class="fail">plot of {_text(column)} not written: {_text(error)}</p>'
    return f'<p><img src="{html.escape(name)}" alt="{_text(column)}"></p>'


def _summary_table(run: CheckRun) -> str:
    """The failures first: one row per failing file and column (file, column, kind, first
    failing time, worst deviation as a share of its allowance), linked to its section."""
    rows = []
    for number, check in enumerate(run.files):
        if check.passed:
            continue
        anchor = f"file-{number}"
        if check.comparison is None:
            rows.append((anchor, check.name, "(file)", check.kind or "", math.nan, math.nan))
            continue
        summary = check.comparison.summary
        for row in check.comparison.failures.to_dict("records"):
            ratio = (
                summary.loc[row["column"], "ratio"] if row["column"] in summary.index else math.nan
            )
            rows.append((anchor, check.name, row["column"], row["kind"], row["time"], ratio))
    if not rows:
        return "<p>No failures.</p>"
    cells = "".join(
        f'<tr><td><a href="#{anchor}">{_text(name)}</a></td><td>{_text(column)}'
        f"</td><td>{_text(kind)}</td><td>{_number(time)}</td><td>{_number(ratio)}</td></tr>"
        for anchor, name, column, kind, time, ratio in rows
    )
    return (
        "<table><tr><th>file</th><th>column</th><th>kind</th><th>first failure [s]</th>"
        "<th>worst / allowed</th></tr>" + cells + "</table>"
    )


def _file_section(check: FileCheck, anchor: str, folder: Path) -> str:
    """One file's heading, line, failures table and a plot of each failing column (each
    PNG written as it is drawn)."""
    verdict = "pass" if check.passed else "fail"
    parts = [
        f'<h3 id="{anchor}" class="{verdict}">{_text(check.name)}</h3>'
        f'<p class="{verdict}">{_text(check.line())}</p>'
    ]
    comparison = check.comparison
    if comparison is None or comparison.failures.empty:
        return "".join(parts)
    rows = "".join(
        "<tr>"
        + "".join(
            f"<td>{_text(cell)}</td>"
            for cell in (
                str(row["column"]),
                _number(row["time"]),
                _number(row["value"]),
                _number(row["reference"]),
                _number(row["allowed"]),
                str(row["kind"]),
            )
        )
        + "</tr>"
        for row in comparison.failures.to_dict("records")
    )
    parts.append(
        "<table><tr><th>column</th><th>time [s]</th><th>value</th><th>reference"
        "</th><th>allowed</th><th>kind</th></tr>" + rows + "</table>"
    )
    for column in comparison.failures["column"]:
        if column in comparison.summary.index:
            parts.append(_plot(check, column, folder))
    return "".join(parts)


def write_report(run: CheckRun, folder: str | PathLike) -> Path:
    """Write ``folder``/index.html and, for every failing value column, a PNG of the result,
    the reference, the tolerance band or tube and the first failure (plot_name); each file
    atomically, the index last and always (a plot that cannot be written is named there).
    The page opens with the summary and a table of the failures, then each failing file
    (its line, failures and plots), then the files that match, folded. Returns the index's
    path."""
    folder = Path(output_folder(Path(folder)))
    options = run.options
    tolerance = (
        "the references' declared tolerances"
        if options.get("rtol") is None and options.get("atol") is None
        else f"rtol {options.get('rtol')!r}, atol {options.get('atol')!r}"
    )
    body = [
        f"<h1>mechfmu check</h1><p>{_text(run.summary())}</p>",
        f"<p>method {_text(options.get('method') or 'as declared')}, "
        f"{_text(tolerance)}"
        + (
            f", time tolerance {options.get('time_tolerance')!r} s"
            if options.get("method") == "tube"
            else ""
        )
        + (f", per column: {_text(options.get('tolerances'))}" if options.get("tolerances") else "")
        + "</p>",
        "<h2>Failures</h2>",
        _summary_table(run),
    ]
    failing = [(n, c) for n, c in enumerate(run.files) if not c.passed]
    passing = [(n, c) for n, c in enumerate(run.files) if c.passed]
    if failing:
        body.append("<h2>Failing files</h2>")
        body += [_file_section(c, f"file-{n}", folder) for n, c in failing]
    if passing:
        body.append(
            f"<details><summary>{len(passing)} file(s) that match</summary>"
            + "".join(_file_section(c, f"file-{n}", folder) for n, c in passing)
            + "</details>"
        )
    return atomic_write(
        folder / "index.html",
        '<!DOCTYPE html>\n<html><head><meta charset="utf-8"><title>mechfmu '
        f"check</title><style>{STYLE}</style></head><body>\n"
        + "\n".join(body)
        + "\n</body></html>\n",
    )


def tube_example() -> bytes:
    """PNG of the docs' tube-versus-pointwise figure: the suspension's shipped load-ramp
    reference and a result one step (10 ms) late, its snap-through at 3.11 s instead of
    3.10 s; the deflection compared pointwise (fails at the snap) and in a 10 ms tube
    (passes), both with atol 2 % of the deflection's range."""
    import numpy as np
    from matplotlib.figure import Figure

    from ...comparison import compare
    from ...cosim.scene import REFERENCE_DIR
    from ...io import read_result

    reference = read_result(REFERENCE_DIR / "suspension_load_ramp.csv")[["suspension.deflection"]]
    late = reference.copy()
    late.iloc[1:, 0] = reference.iloc[:-1, 0].to_numpy()
    atol = 0.02 * float(np.ptp(reference.iloc[:, 0].to_numpy()))
    figure = Figure(figsize=(9, 3.4), layout="constrained")
    axes = figure.subplots(1, 2, sharey=True)
    for axis, method in zip(axes, ("pointwise", "tube")):
        comparison = compare(late, reference, atol=atol, time_tolerance=0.01, method=method)  # type: ignore[arg-type]
        comparison.draw(axis, "suspension.deflection", around=0.12, at=3.1)
        verdict = "passes" if comparison.passed else "fails"
        axis.set_title(f"{method}: {verdict}", fontsize=10)
        axis.set_xlabel("time [s]")
    axes[0].set_ylabel("suspension.deflection [m]")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    return buffer.getvalue()
