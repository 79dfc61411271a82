"""A whole camshaft's torque: the lobes of a camshaft scene summed, its fluctuation, and the
same camshaft with its lobes in another sequence (``mechfmu example camshaft``).

The scene (camshaft_inline_four) has one ValveTrain per lobe, named ``intake_<cylinder>``
and ``exhaust_<cylinder>``, cylinders numbered from the camshaft's driven end. The torque
the camshaft needs is the sum of the lobes' camshaft_torque outputs; the shaft between
cylinder c and c + 1 carries the torque of the lobes beyond it (the drive end carries the
total). A phasing assigns each cylinder a place k in the firing sequence: its intake lobe
rises at first_intake + k * (2 pi / cylinders) of camshaft, its exhaust lobe the scene's lobe
separation earlier. "Crank-throw angles" is the mistake of phasing the lobes at the crank
throws' angles (a flat-plane four's 0, 180, 180, 0 degrees) as if the camshaft turned at the
crankshaft's speed.

Physics, before any number: the total is a sum of one lobe's torque T(theta - phi) over the
lobes' phases phi, so it depends on the set of phases only, not on which cylinder gets which:
every firing order of evenly spaced identical lobes gives the same total torque, to rounding.
Even spacing keeps only the harmonics of T that are multiples of the number of lobes of a
kind, and the intake and exhaust sets' leftovers add with a phase of 4 x the separation.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas

from ..cosim.files import figure_bytes
from ..cosim.scene import Scene, SceneError

LOBE = re.compile(r"^(intake|exhaust)_(\d+)$")
TORQUE = "camshaft_torque"


@dataclass(frozen=True)
class Phasing:
    """A sequence of the cams' actions: a name and, per cylinder (1, 2, ...), its place in
    the sequence as a fraction of a camshaft turn (firing order: k / cylinders)."""

    name: str
    turns: tuple[float, ...]  # camshaft turns after cylinder 1's intake, per cylinder


def firing_order(order: Sequence[int]) -> Phasing:
    """The phasing of a firing order (cylinder numbers in firing sequence, e.g. 1, 3, 4, 2):
    each cylinder's intake lobe 1 / cylinders of a camshaft turn after the one before."""
    count = len(order)
    if sorted(order) != list(range(1, count + 1)):
        raise ValueError(f"firing order {order!r} must name each cylinder 1..{count} once")
    turns = tuple(order.index(cylinder) / count for cylinder in range(1, count + 1))
    return Phasing("firing order " + "-".join(map(str, order)), turns)


# The inline four: its firing order, another order, and lobes at the crank throws' angles.
INLINE_FOUR = (
    firing_order((1, 3, 4, 2)),
    firing_order((1, 2, 3, 4)),
    Phasing("crank-throw angles 0-180-180-0 (not halved)", (0.0, 0.5, 0.5, 0.0)),
)


def lobes(scene: Scene) -> dict[int, dict[str, str]]:
    """{cylinder: {"intake": component, "exhaust": component}} of a camshaft scene (its
    components named intake_<n> and exhaust_<n>). SceneError if a cylinder lacks a lobe."""
    found: dict[int, dict[str, str]] = {}
    for name in scene.components:
        match = LOBE.match(name)
        if match:
            found.setdefault(int(match.group(2)), {})[match.group(1)] = name
    if not found or any(set(pair) != {"intake", "exhaust"} for pair in found.values()):
        raise SceneError(
            f"scene {scene.name}: a camshaft scene needs components intake_<n> and "
            f"exhaust_<n> for every cylinder n; found {sorted(scene.components)}"
        )
    if sorted(found) != list(range(1, len(found) + 1)):
        raise SceneError(f"scene {scene.name}: cylinders {sorted(found)} are not 1..n")
    return found


def phasing_parameters(scene: Scene, phasing: Phasing) -> dict[str, float]:
    """The rise_start parameters ({"component.rise_start": rad}) that put the scene's lobes in
    ``phasing``: cylinder 1's intake and every lobe separation as in the scene."""
    cylinders = lobes(scene)
    if len(phasing.turns) != len(cylinders):
        raise ValueError(
            f"{phasing.name}: {len(phasing.turns)} cylinders, the scene has {len(cylinders)}"
        )

    def start(component: str) -> float:
        return float(scene.components[component].parameters.get("rise_start", 0.0))

    first = start(cylinders[1]["intake"])
    values = {}
    for cylinder, turn in zip(sorted(cylinders), phasing.turns):
        intake = first + 2.0 * math.pi * turn
        separation = start(cylinders[cylinder]["intake"]) - start(cylinders[cylinder]["exhaust"])
        values[f"{cylinders[cylinder]['intake']}.rise_start"] = intake
        values[f"{cylinders[cylinder]['exhaust']}.rise_start"] = intake - separation
    return values


def torques(result: pandas.DataFrame, scene: Scene) -> pandas.DataFrame:
    """The camshaft's torques (N.m) from a result with every lobe's camshaft_torque: the
    ``total`` (the drive end's) and ``shaft_<c>`` between cylinder c and c + 1 (the lobes
    beyond it), indexed like ``result``."""
    cylinders = lobes(scene)

    def lobe_torque(cylinder: int) -> Any:
        pair = cylinders[cylinder]
        return result[f"{pair['intake']}.{TORQUE}"] + result[f"{pair['exhaust']}.{TORQUE}"]

    columns = {"total": sum(lobe_torque(c) for c in cylinders)}
    for cylinder in sorted(cylinders)[:-1]:
        columns[f"shaft_{cylinder}"] = sum(lobe_torque(c) for c in cylinders if c > cylinder)
    return pandas.DataFrame(columns, index=result.index)


def fluctuation(torque: Any) -> dict[str, float]:
    """Peak-to-peak, RMS about the mean and the mean (N.m) of a torque over one revolution
    sampled evenly (the last sample, a whole turn after the first, left out)."""
    values = np.asarray(torque, dtype=float)[:-1]
    mean = float(np.mean(values))
    return {
        "peak_to_peak": float(np.max(values) - np.min(values)),
        "rms": float(np.sqrt(np.mean((values - mean) ** 2))),
        "mean": mean,
        "peak": float(np.max(np.abs(values))),
    }


def compare_phasings(
    scene: Scene,
    run: Callable[[Scene, Mapping[str, Any]], pandas.DataFrame],
    phasings: Sequence[Phasing] = INLINE_FOUR,
) -> tuple[pandas.DataFrame, dict[str, pandas.DataFrame]]:
    """Each phasing's camshaft torque: ``run(scene, parameters)`` gives the result (e.g.
    mechfmu.simulate or mechfmu.reference); returns (a table, one row per phasing: the
    total's peak_to_peak, rms, mean and peak and the largest torque any shaft section
    carries, N.m; {phasing name: torques()})."""
    rows, curves = [], {}
    for phasing in phasings:
        result = run(scene, phasing_parameters(scene, phasing))
        torque = torques(result, scene)
        curves[phasing.name] = torque
        figures = fluctuation(torque["total"])
        sections = torque.drop(columns="total").abs().to_numpy()[:-1]
        figures["largest_section_torque"] = float(np.max(sections)) if sections.size else 0.0
        rows.append({"phasing": phasing.name, **figures})
    return pandas.DataFrame(rows).set_index("phasing"), curves


def table_text(table: pandas.DataFrame) -> str:
    """The comparison as Markdown (N.m)."""
    lines = [
        "| phasing | peak-to-peak (N.m) | RMS (N.m) | mean (N.m) | largest in a shaft section (N.m) |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, row in table.iterrows():
        lines.append(
            f"| {name} | {row['peak_to_peak']:.3f} | {row['rms']:.3f} | {row['mean']:.1e} | "
            f"{row['largest_section_torque']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def figure_png(curves: Mapping[str, pandas.DataFrame], angle: Any) -> bytes:
    """PNG: the total camshaft torque of each phasing against the camshaft angle (deg)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    figure, axis = pyplot.subplots(figsize=(9, 4.2))
    degrees = np.degrees(np.asarray(angle, dtype=float))
    for (name, torque), style in zip(curves.items(), ("-", "--", ":", "-.")):
        axis.plot(degrees, torque["total"], style, lw=1.4, label=name)
    axis.axhline(0.0, color="k", lw=0.5)
    axis.set_xlabel("camshaft angle [deg]")
    axis.set_ylabel("camshaft torque [N.m]")
    axis.set_title("Total torque the camshaft needs (eight lobes, one revolution)", fontsize=10)
    axis.grid(True, lw=0.3)
    axis.legend(fontsize=8)
    figure.tight_layout()
    try:
        return figure_bytes(figure, dpi=100)
    finally:
        pyplot.close(figure)
