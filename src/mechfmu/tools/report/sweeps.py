"""The shipped sweeps (src/mechfmu/sweeps/*.toml) run, checked against their references, reported.

``run_shipped`` runs them with mechfmu.tools.sweep (``quick``: a few points of each, around the
thresholds, for the tests); ``analyse`` reads their sweep.csv files and compares them with
mechfmu.tools.sweep_references; ``report`` writes summary.md and the suspension's two sweeps on
one plot; ``failures`` names what disagrees. Nothing here is typed in: the thresholds come from the references, the sweeps'
settings from their files and scenes.
"""

from typing import Any
import math
from pathlib import Path

import numpy as np

from .. import sweep
from ...cosim.files import atomic_write, save_figure
from ...cosim.scene import find_file, load_scene
from ...references import suspension as suspension_reference
from .. import sweep_references as reference

STATIC, SUDDEN = "suspension_mass_static", "suspension_mass_sudden"
GEAR, VALVE = "gear_retraction_pressure", "valve_float_preload"
SHIPPED = (STATIC, SUDDEN, GEAR, VALVE)
# --quick: a few points of each sweep, across its threshold (the tests' small versions)
QUICK_VARY = {
    STATIC: "suspension.mass=310:320:5",
    SUDDEN: "suspension.mass=230:237.5:4",
    GEAR: "gear.supply_pressure=3e6:2.1e7:4",
    VALVE: "valve.spring_preload=0:600:7",
}


def run_shipped(
    sweep_dir: Any,
    out_dir: Any,
    fmu_dir: str | None = None,
    jobs: int | None = None,
    quick: bool = False,
    scheduler: Any = None,
    names: Any = SHIPPED,
    progress: bool = True,
) -> Any:
    """Run the shipped sweeps into out_dir/<name>/; returns {name: summary}."""
    summaries = {}
    for name in names:
        chosen = sweep.load_sweep_file(find_file(name, (sweep_dir,)))
        chosen.pop("description")
        if quick:
            chosen["varies"] = [sweep.parse_vary(QUICK_VARY[name])]
        summaries[name] = sweep.run_sweep(
            **chosen,
            out_dir=Path(out_dir) / name,
            jobs=jobs,
            fmu_dir=fmu_dir,
            scheduler=scheduler,
            progress=progress,
        )
    return summaries


def _rows(out_dir: Any, name: str):
    rows = sweep.read_sweep_csv(Path(out_dir) / name / "sweep.csv")
    return sorted(rows, key=lambda row: row["index"])


def _suspension_settings(sweep_dir: Any, name: str):
    """(the Suspension's scene parameters, g of the load link load.final_value = g * mass)
    of a shipped suspension sweep, from its file and its scene."""
    settings = sweep.load_sweep_file(find_file(name, (sweep_dir,)))
    scene = load_scene(settings["scene_path"], settings["overrides"])
    (link,) = settings["links"]
    return scene.components["suspension"].parameters, link.factor


def snap_bracket(rows: Any, parameter: Any, metric: Any) -> Any:
    """(largest parameter value that stays on the near branch, smallest that ends on the far
    one) among the successful rows; ``metric`` is the final branch (0 near, 1 far)."""
    good = [row for row in rows if row["error"] is None]
    near = [row[parameter] for row in good if row[metric] == 0.0]
    far = [row[parameter] for row in good if row[metric] == 1.0]
    below = max(near) if near else math.nan
    above = min(far) if far else math.nan
    if near and far and below > above:
        raise ValueError(f"{metric}: near and far points interleave around {above}..{below}")
    return below, above


def analyse_suspension(sweep_dir: Any, out_dir: Any) -> Any:
    """The static and the sudden snap-through masses: the sweeps' brackets and the
    references', plus the static sweep's deflections against the closed form."""
    findings = {}
    for name, in_time in ((STATIC, False), (SUDDEN, True)):
        rows = _rows(out_dir, name)
        parameters, gravity = _suspension_settings(sweep_dir, name)
        geometry = dict(
            spring_free_length=parameters.get("spring_free_length", 0.5),
            spring_stiffness=parameters.get("spring_stiffness", 1e4),
            spring_base_offset=parameters.get("spring_base_offset", 0.2),
        )
        if in_time:
            damping = parameters.get("damping_coefficient", 0.0)
            expected = reference.sudden_snap_through_mass(damping, **geometry, gravity=gravity)
        else:
            expected = reference.static_snap_through_mass(**geometry, gravity=gravity)
        below, above = snap_bracket(rows, "suspension.mass", "final:suspension.branch")
        found = {
            "reference_kg": expected,
            "bracket_kg": (below, above),
            "inside": below < expected <= above,
            "points": len(rows),
            "failed": [(row["suspension.mass"], row["error"]) for row in rows if row["error"]],
        }
        if not in_time:  # the final deflection of a slow ramp: the closed-form path
            L, k, d = (
                geometry[key]
                for key in ("spring_free_length", "spring_stiffness", "spring_base_offset")
            )
            errors = [
                abs(
                    row["final:suspension.deflection"]
                    - suspension_reference.follow_load(
                        np.array([0.0, row["load.final_value"]]), L, k, d
                    )["deflection"][-1]
                )
                for row in rows
                if row["error"] is None
            ]
            found["deflection_max_error_m"] = max(errors) if errors else math.nan
        findings[name] = found
    return findings


def analyse_gear(out_dir: Any) -> Any:
    """Retraction times against the reference's; the lowest pressure that retracts."""
    rows = [row for row in _rows(out_dir, GEAR) if row["error"] is None]
    errors, disagree = [], []
    for row in rows:
        measured = row["final:gear.retraction_time"]
        expected = reference.retraction_time(row["gear.supply_pressure"])
        if math.isnan(expected) or measured < 0.0:
            if not (math.isnan(expected) and measured < 0.0):
                disagree.append((row["gear.supply_pressure"], measured, expected))
        else:
            errors.append(abs(measured - expected))
    retracting = [
        row["gear.supply_pressure"] for row in rows if row["final:gear.retraction_time"] >= 0.0
    ]
    stalled = [
        row["gear.supply_pressure"] for row in rows if row["final:gear.retraction_time"] < 0.0
    ]
    bracket = (max(stalled) if stalled else math.nan, min(retracting) if retracting else math.nan)
    lowest = math.nan
    if stalled and retracting:
        lowest = reference.lowest_retracting_pressure(*bracket)
    return {
        "points": len(rows),
        "max_error_s": max(errors) if errors else math.nan,
        "disagree": disagree,
        "bracket_pa": bracket,
        "lowest_reference_pa": lowest,
        "times": [(row["gear.supply_pressure"], row["final:gear.retraction_time"]) for row in rows],
    }


def analyse_valve(out_dir: Any) -> Any:
    """Float speeds against the reference's (relative error)."""
    rows = [row for row in _rows(out_dir, VALVE) if row["error"] is None]
    errors = [
        abs(
            row["final:valve.float_camshaft_speed"]
            / reference.valve_float_speed(row["valve.spring_preload"])
            - 1.0
        )
        for row in rows
    ]
    return {
        "points": len(rows),
        "max_relative_error": max(errors) if errors else math.nan,
        "speeds": [
            (row["valve.spring_preload"], row["final:valve.float_camshaft_speed"]) for row in rows
        ],
    }


def analyse(sweep_dir: Any, out_dir: Any) -> Any:
    return {
        "suspension": analyse_suspension(sweep_dir, out_dir),
        "gear": analyse_gear(out_dir),
        "valve": analyse_valve(out_dir),
    }


def markdown(findings: Any, summaries: Any = None) -> Any:
    """The findings as the Markdown of summary.md."""
    lines = ["# Shipped sweeps", ""]
    if summaries:
        lines += [
            "| sweep | points | failed | wall time | scenes/s | where |",
            "|---|---:|---:|---:|---:|---|",
        ]
        for name, summary in summaries.items():
            lines.append(
                f"| {name} | {summary['done']} | {summary['failed']} | "
                f"{summary['wall_time_s']:.1f} s | {summary['scenes_per_s']:.1f} | "
                f"{summary['where']} |"
            )
        lines.append("")
    lines += [
        "| snap-through mass | sweep: stays .. snaps | reference | inside |",
        "|---|---|---:|---|",
    ]
    for name, found in findings["suspension"].items():
        below, above = found["bracket_kg"]
        lines.append(
            f"| {name} | {below:.2f} .. {above:.2f} kg | "
            f"{found['reference_kg']:.4f} kg | {'yes' if found['inside'] else '**no**'} |"
        )
    static = findings["suspension"][STATIC]
    lines += [
        "",
        f"Static final deflections against the closed-form path: largest difference "
        f"{static['deflection_max_error_m']:.2e} m.",
    ]
    for name, found in findings["suspension"].items():
        for mass, error in found["failed"]:
            lines.append(f"{name}: {mass:g} kg failed: {error}")
    gear = findings["gear"]
    below, above = gear["bracket_pa"]
    lines += [
        "",
        f"Gear: {gear['points']} supply pressures; retraction times against the "
        f"reference: largest difference {gear['max_error_s']:.2e} s; "
        f"{len(gear['disagree'])} disagreement(s) on whether it retracts. "
        f"Lowest pressure that retracts within the scene: between {below:.4g} and "
        f"{above:.4g} Pa (reference {gear['lowest_reference_pa']:.5g} Pa).",
    ]
    valve = findings["valve"]
    lines += [
        "",
        f"Valve: {valve['points']} preloads; float speeds against the reference: "
        f"largest relative difference {valve['max_relative_error']:.2e}.",
    ]
    return "\n".join(lines) + "\n"


def plot_suspension(out_dir: Any, findings: Any) -> Any:
    """Deflection against mass, static (final) and sudden (largest), with the reference
    snap-through masses; returns the PNG's path."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    figure, axis = pyplot.subplots(figsize=(7, 4.5))
    for name, metric, label in (
        (STATIC, "final:suspension.deflection", "slow load: final"),
        (SUDDEN, "max:suspension.deflection", "sudden load: largest"),
    ):
        rows = [row for row in _rows(out_dir, name) if row["error"] is None]
        (line,) = axis.plot(
            [row["suspension.mass"] for row in rows],
            [row[metric] for row in rows],
            "o-",
            markersize=2.5,
            label=label,
        )
        axis.axvline(
            findings["suspension"][name]["reference_kg"],
            color=line.get_color(),
            linestyle="--",
            linewidth=0.8,
        )
    axis.set_xlabel("mass m (kg), load m g")
    axis.set_ylabel("deflection u (m)")
    axis.set_title("Snap-through: dashed lines are the reference masses")
    axis.grid(True, linewidth=0.3)
    axis.legend()
    figure.tight_layout()
    try:
        return save_figure(Path(out_dir) / "suspension_mass.png", figure, dpi=100)
    finally:
        pyplot.close(figure)


# The scenes' declared tolerances or tighter
TOLERANCES = {
    "gear_max_error_s": 1e-6,
    "valve_max_relative_error": 1e-9,
    "static_deflection_m": 1e-9,
}


def failures(findings: Any) -> Any:
    """What disagrees with the references, as sentences (empty: all agree)."""
    found = []
    for name, suspension in findings["suspension"].items():
        if not suspension["inside"]:
            found.append(
                f"{name}: reference mass {suspension['reference_kg']:.4f} kg outside "
                f"the sweep's bracket {suspension['bracket_kg']}"
            )
    static = findings["suspension"][STATIC]["deflection_max_error_m"]
    if not static <= TOLERANCES["static_deflection_m"]:
        found.append(f"static deflections differ from the closed form by {static:.3g} m")
    gear = findings["gear"]
    if gear["disagree"] or not gear["max_error_s"] <= TOLERANCES["gear_max_error_s"]:
        found.append(
            f"gear: retraction times differ by {gear['max_error_s']:.3g} s; "
            f"disagreements {gear['disagree']}"
        )
    valve = findings["valve"]["max_relative_error"]
    if not valve <= TOLERANCES["valve_max_relative_error"]:
        found.append(f"valve: float speeds differ by {valve:.3g} (relative)")
    return found


def report(sweep_dir: Any, out_dir: Any, summaries: Any = None) -> Any:
    """Analyse, write summary.md and the suspension plot; returns (findings, Markdown)."""
    findings = analyse(sweep_dir, out_dir)
    text = markdown(findings, summaries)
    atomic_write(Path(out_dir) / "summary.md", text)
    plot_suspension(out_dir, findings)
    return findings, text
