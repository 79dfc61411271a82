"""The study's report: the Pareto front, the plots and the Markdown tables."""

from __future__ import annotations

from typing import TYPE_CHECKING
import math

import matplotlib
from typing import Any

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from ...cosim.files import save_figure  # noqa: E402
from .design import ADAPTIVE, TIGHTEST  # noqa: E402

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from .design import StudyScene

TARGETS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
COLORS = {"euler": "tab:red", "rk4": "tab:orange", "dopri5": "tab:blue", "radau": "tab:green"}
MARKERS = {"gauss_seidel": "o", "jacobi": "x"}


def pareto_front(costs: list[Any], errors: list[Any]) -> list[Any]:
    """Indices of the points no other point beats in both cost and error, cheapest first.

    A point is on the front when every cheaper point (or equally cheap one listed before
    it) has a larger error. Points with a non-finite cost or error are never on it.
    """
    usable = [i for i in range(len(costs)) if math.isfinite(costs[i]) and math.isfinite(errors[i])]
    front, best = [], math.inf
    for i in sorted(usable, key=lambda i: (costs[i], errors[i])):
        if errors[i] < best:
            front.append(i)
            best = errors[i]
    return front


def headline_rows(rows: list[dict[str, Any]], study_scene: StudyScene) -> list[dict[str, Any]]:
    """The rows of the scene's headline output, successful runs only."""
    return [
        r
        for r in rows
        if r["scene"] == study_scene.name
        and r["output"] == study_scene.headline
        and r["status"] == "ok"
    ]


def setting(row: dict[str, Any]) -> str:
    """How a row's point was set, in words for a table."""
    if row["integrator"] in ADAPTIVE:
        method = f"{row['integrator']}, rtol = atol = {row['tolerance']:g}"
    else:
        method = f"{row['integrator']}, sub-step {row['max_substep']:g} s"
    return method


def cheapest_for(rows: list[dict[str, Any]], target: float) -> dict[str, Any] | None:
    """The cheapest row whose max error is at most ``target``, or None."""
    meeting = [r for r in rows if r["max_error"] <= target]
    return min(meeting, key=lambda r: r["ms_per_simulated_s"]) if meeting else None


def front_table(rows: list[dict[str, Any]], study_scene: StudyScene, unit: str) -> str:
    """Markdown table: for each target error, the cheapest setting that meets it."""
    chosen = headline_rows(rows, study_scene)
    lines = [
        f"| max error on `{study_scene.headline}` | integrator | communication step | "
        f"coupling | error reached | cost (ms per simulated s) | rhs evaluations |",
        "|---|---|---|---|---|---|---|",
    ]
    for target in TARGETS:
        row = cheapest_for(chosen, target)
        if row is None:
            lines.append(f"| {target:g} {unit} | not reached by any setting | | | | | |")
            continue
        lines.append(
            f"| {target:g} {unit} | {setting(row)} | {row['step']:g} s | "
            f"{row['coupling'].replace('_', '-')} | {row['max_error']:.2g} | "
            f"{row['ms_per_simulated_s']:.3g} | {row['rhs_evaluations']} |"
        )
    return "\n".join(lines)


def plot_front(rows: Any, study_scene: Any, unit: str, path: Any) -> Any:
    """Error against cost on log-log axes, every point, the Pareto front as a line."""
    chosen = [r for r in headline_rows(rows, study_scene) if r["max_error"] > 0]
    figure, axes = plt.subplots(figsize=(8, 5.5))
    for row in chosen:
        axes.scatter(
            row["ms_per_simulated_s"],
            row["max_error"],
            s=18,
            color=COLORS[row["integrator"]],
            marker=MARKERS[row["coupling"]],
            alpha=0.75,
        )
    front = [
        chosen[i]
        for i in pareto_front(
            [r["ms_per_simulated_s"] for r in chosen], [r["max_error"] for r in chosen]
        )
    ]
    if front:
        axes.step(
            [r["ms_per_simulated_s"] for r in front],
            [r["max_error"] for r in front],
            where="post",
            color="black",
            linewidth=1.2,
            label="Pareto front",
        )
    for method, color in COLORS.items():
        axes.scatter([], [], color=color, label=method)
    axes.scatter([], [], color="grey", marker="x", label="Jacobi coupling")
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("cost: stepping-loop wall time per simulated second (ms)")
    axes.set_ylabel(f"max |error| of {study_scene.headline} ({unit})")
    axes.set_title(f"{study_scene.name}: accuracy against cost")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    return _save(path, figure)


def plot_sources(rows: Any, study_scene: Any, unit: str, path: Any) -> Any:
    """Two panels: the coupling error alone and the integration error alone.

    Left: error against the communication step with each adaptive method at its tightest
    tolerance, so what remains is the coupling (Gauss-Seidel and Jacobi). Right: error
    against right-hand-side evaluations at the finest communication step under
    Gauss-Seidel, so what varies is the integration inside the FMU.
    """
    chosen = headline_rows(rows, study_scene)
    figure, (left, right) = plt.subplots(1, 2, figsize=(12, 5))
    for method in ADAPTIVE:
        for coupling, style in (("gauss_seidel", "-o"), ("jacobi", "--x")):
            line = sorted(
                (
                    r
                    for r in chosen
                    if r["integrator"] == method
                    and r["tolerance"] == TIGHTEST
                    and r["coupling"] == coupling
                ),
                key=lambda r: r["step"],
            )
            if line:
                left.loglog(
                    [r["step"] for r in line],
                    [max(r["max_error"], 1e-17) for r in line],
                    style,
                    color=COLORS[method],
                    label=f"{method} {TIGHTEST:g}, {coupling.replace('_', '-')}",
                )
    left.set_xlabel("communication step (s)")
    left.set_ylabel(f"max |error| of {study_scene.headline} ({unit})")
    left.set_title("coupling error (integration at its tightest)")
    finest = min(r["step"] for r in chosen) if chosen else None
    for method in COLORS:
        line = sorted(
            (
                r
                for r in chosen
                if r["integrator"] == method
                and r["step"] == finest
                and r["coupling"] == "gauss_seidel"
            ),
            key=lambda r: r["rhs_evaluations"],
        )
        if line:
            right.loglog(
                [r["rhs_evaluations"] for r in line],
                [max(r["max_error"], 1e-17) for r in line],
                "-o",
                color=COLORS[method],
                label=method,
            )
    right.set_xlabel("right-hand-side evaluations")
    right.set_title(f"integration error (communication step {finest:g} s, Gauss-Seidel)")
    for axes in (left, right):
        axes.grid(True, which="both", alpha=0.3)
        if axes.get_legend_handles_labels()[0]:  # a quick study may leave a panel empty
            axes.legend(fontsize=8)
    figure.suptitle(f"{study_scene.name}: the two error sources apart")
    figure.tight_layout()
    return _save(path, figure)


def _save(path: Any, figure: Any):
    """Write the figure atomically and free it."""
    try:
        return save_figure(path, figure, dpi=110)
    finally:
        plt.close(figure)
