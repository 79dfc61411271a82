"""The cam a scene's valve train needs, for a workshop: profile table, DXF, drawing, summary.

``cam_profile(scene, parameters=...)`` evaluates the runtime's cam geometry
(runtime/physics/cam_geometry.py) for a ValveTrain component of a scene at evenly spaced
camshaft angles and returns a pandas DataFrame; ``write_cam_files`` writes its CSV, a DXF of
the profile in millimetres (ezdxf: $INSUNITS = 4, a closed polyline), a PNG drawing (the
profile, base circle, pitch curve and the follower at a few angles, beside the displacement
diagram, pressure angle and radius of curvature) and a Markdown summary with the verdicts.
``smallest_base_circle`` sizes the base circle for the component's cam law and follower
(``mechfmu cam-size``). The CLI verbs are ``mechfmu cam-profile`` and ``mechfmu cam-size``.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas

from ..api import SceneLike, configured_scene
from ..cosim.files import atomic_write_all, figure_bytes, output_folder
from ..cosim.scene import Scene, SceneError
from ..runtime.models.valve_train import cam_setup
from ..runtime.physics import cam_geometry
from ..runtime.physics import valve_train as vt
from .animate.cam import diagram_at
from .scene_references import model_defaults

MODEL = "ValveTrain"
DEFAULT_POINTS = 3600  # profile points per revolution (0.1 degree)
MIN_POINTS = 16
# 0.00036 degree apart; more is no finer a cam for a workshop, only a larger table and DXF
# (a point costs about 4 us and 96 bytes of table: 1e6 take 4 s and 96 MB; 1e8 ran for minutes)
MAX_POINTS = 1_000_000
COLUMNS = {  # column -> SI unit
    "cam_angle": "rad",
    "x": "m",
    "y": "m",
    "pitch_x": "m",
    "pitch_y": "m",
    "pressure_angle": "rad",
    "radius_of_curvature": "m",
    "pitch_radius_of_curvature": "m",
    "face_contact_position": "m",
    "lift": "m",
    "lift_rate": "m/rad",
    "lift_rate2": "m/rad2",
}
DXF_UNITS_MM = 4  # $INSUNITS code of millimetres
MM = 1e3


@dataclass(frozen=True)
class CamSetup:
    """A ValveTrain component's cam: its name, parameters (over the model's defaults), the
    rocker geometry, cam law, follower and the tappet's displacement diagram."""

    scene: Scene
    component: str
    parameters: dict[str, Any]
    geometry: vt.ValveGeometry
    profile: Any  # cam_laws.CamProfile
    follower: cam_geometry.Follower
    pieces: tuple[cam_geometry.Piece, ...]


def cam_setup_of(
    scene: SceneLike,
    parameters: Mapping[str, Any] | None = None,
    component: str | None = None,
) -> CamSetup:
    """The cam of ValveTrain ``component`` (default: the scene's only one) of ``scene`` (a
    shipped scene's name, a scene file or a Scene) with ``parameters``
    ({"component.parameter": value}) applied. SceneError for a scene without (or with
    several and no ``component`` named) ValveTrain components; RangeError (naming the
    parameter and its valid range) for an invalid geometry, cam law or follower."""
    chosen = configured_scene(scene, parameters)
    trains = [name for name, spec in chosen.components.items() if Path(spec.fmu).stem == MODEL]
    if component is None:
        if len(trains) != 1:
            raise SceneError(
                f"scene {chosen.name}: {len(trains)} {MODEL} components"
                + (f" ({', '.join(trains)}); name one with component=" if trains else "")
            )
        component = trains[0]
    elif component not in trains:
        raise SceneError(
            f"scene {chosen.name}: no {MODEL} component {component!r}; its {MODEL} "
            f"components: {', '.join(trains) or 'none'}"
        )
    values = {**model_defaults(MODEL), **chosen.components[component].parameters}
    geometry, profile = cam_setup(values)
    follower = cam_geometry.check_follower(
        values["follower"],
        geometry.cam_base_radius,
        values["roller_radius"],
        values["follower_offset"],
    )
    pieces = vt.tappet_pieces(geometry, profile, values["mode"])
    return CamSetup(chosen, component, values, geometry, profile, follower, pieces)


def cam_profile(
    scene: SceneLike,
    parameters: Mapping[str, Any] | None = None,
    component: str | None = None,
    points: int = DEFAULT_POINTS,
) -> pandas.DataFrame:
    """The cam of a scene's ValveTrain (``component``, default its only one) at ``points``
    camshaft angles evenly spaced over a revolution, as a DataFrame: ``cam_angle`` (rad),
    ``x``, ``y`` (m: the profile, the contact point in the cam's frame), ``pitch_x``,
    ``pitch_y`` (m: the pitch curve), ``pressure_angle`` (rad), ``radius_of_curvature`` and
    ``pitch_radius_of_curvature`` (m), ``face_contact_position`` (m, flat face),
    ``lift``, ``lift_rate``, ``lift_rate2`` (the tappet's s m, ds/dtheta m/rad,
    d2s/dtheta2 m/rad^2). ``attrs``: units, scene, component, follower, the design figures
    (``design``: least radii, largest pressure angle, face width, problems) and
    ``smallest_base_circle``.

    ``parameters`` as mechfmu.simulate's ({"valve.cam_base_radius": 0.03}). Raises
    SceneError, RangeError for bad values, and CamDesignError (a RangeError naming
    cam_base_radius or roller_radius and its limit, with the camshaft angle) when no cam
    can make the motion: a cusp (flat face) or an undercut (roller).
    """
    if (
        isinstance(points, bool)
        or not isinstance(points, int)
        or not MIN_POINTS <= points <= MAX_POINTS
    ):
        raise ValueError(
            f"points = {points!r} must be an integer from {MIN_POINTS} to {MAX_POINTS} "
            f"(profile points per revolution)"
        )
    setup = cam_setup_of(scene, parameters, component)
    found = cam_geometry.require_design(
        setup.follower,
        cam_geometry.design(setup.follower, setup.pieces, setup.parameters["pressure_angle_limit"]),
    )
    rows = []
    for index in range(points):
        angle = 2.0 * math.pi * index / points
        s, s1, s2 = diagram_at(setup.pieces, angle)
        point = cam_geometry.cam_point(setup.follower, angle, s, s1, s2)
        rows.append(
            (
                angle,
                point.x,
                point.y,
                point.pitch_x,
                point.pitch_y,
                point.pressure_angle,
                point.radius_of_curvature,
                point.pitch_radius_of_curvature,
                point.face_contact,
                s,
                s1,
                s2,
            )
        )
    table = pandas.DataFrame(rows, columns=list(COLUMNS))
    sizing = smallest_base_circle(setup)
    table.attrs.update(
        units=dict(COLUMNS),
        scene=setup.scene.name,
        component=setup.component,
        mode=setup.parameters["mode"],
        cam_law=setup.profile._asdict(),
        follower=setup.follower._asdict(),
        pressure_angle_limit=setup.parameters["pressure_angle_limit"],
        design={
            **{key: value for key, value in found._asdict().items() if key != "problems"},
            "problems": [problem._asdict() for problem in found.problems],
        },
        smallest_base_circle=sizing._asdict(),
    )
    return table


def smallest_base_circle(
    setup: CamSetup, min_radius_of_curvature: float = 0.0
) -> cam_geometry.Sizing:
    """The smallest cam_base_radius (m) meeting the limits for ``setup``'s tappet diagram
    and follower (cam_geometry.smallest_base_circle). In inverse mode the diagram is the one
    of the scene's rocker layout: a larger base circle with the pushrod shortened as much
    keeps the rocker's rest position, and changes the diagram by about 0.1 um (0.12 um for
    valve_train_inverse at 25 mm; tests/test_cam_design.py), far below any machining
    tolerance."""
    return cam_geometry.smallest_base_circle(
        setup.follower.kind,
        setup.pieces,
        setup.follower.roller_radius,
        setup.follower.offset,
        setup.parameters["pressure_angle_limit"],
        min_radius_of_curvature,
    )


# --- the files -------------------------------------------------------------------------------


def chord_deviation(table: pandas.DataFrame) -> float:
    """Largest distance (m) between the closed polyline through the profile points and the
    true profile: each chord's sagitta c^2 / (8 |rho|), rho the smaller radius at its ends."""
    x, y = table["x"].to_numpy(), table["y"].to_numpy()
    chord = np.hypot(np.roll(x, -1) - x, np.roll(y, -1) - y)
    rho = table["radius_of_curvature"].abs().to_numpy()
    radius = np.minimum(rho, np.roll(rho, -1))
    return float(np.max(chord**2 / (8.0 * radius)))


def dxf_text(table: pandas.DataFrame) -> str:
    """DXF (R2010) of the cam: the profile as a closed polyline on layer CAM_PROFILE, the
    base circle on BASE_CIRCLE and a centre mark on CENTRE, in millimetres ($INSUNITS = 4,
    $MEASUREMENT = 1: metric), the camshaft centre at the origin, the cam at camshaft
    angle 0."""
    import ezdxf

    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = DXF_UNITS_MM
    document.header["$MEASUREMENT"] = 1
    for name, colour in (("CAM_PROFILE", 7), ("BASE_CIRCLE", 3), ("CENTRE", 1)):
        document.layers.add(name, color=colour)
    space = document.modelspace()
    points = list(zip(table["x"] * MM, table["y"] * MM))
    space.add_lwpolyline(points, format="xy", close=True, dxfattribs={"layer": "CAM_PROFILE"})
    base = table.attrs["follower"]["base_circle_radius"] * MM
    space.add_circle((0.0, 0.0), base, dxfattribs={"layer": "BASE_CIRCLE"})
    mark = 0.2 * base
    space.add_line((-mark, 0.0), (mark, 0.0), dxfattribs={"layer": "CENTRE"})
    space.add_line((0.0, -mark), (0.0, mark), dxfattribs={"layer": "CENTRE"})
    stream = io.StringIO()
    document.write(stream)
    return stream.getvalue()


def _follower_outline(table: pandas.DataFrame, row: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    """Lines (x, y arrays, m, cam frame) of the follower at the camshaft angle of ``row``:
    its face (flat) or roller, and its stem along the axis."""
    follower = table.attrs["follower"]
    angle = row.cam_angle
    along = np.array([np.sin(angle), np.cos(angle)])  # the axis, pointing to the follower
    across = np.array([np.cos(angle), -np.sin(angle)])
    trace = np.array([row.pitch_x, row.pitch_y])
    stem = 0.6 * follower["base_circle_radius"]
    lines = [tuple(np.stack([trace, trace + stem * along], axis=1))]
    if follower["kind"] == "flat_faced":
        design = table.attrs["design"]
        half = max(abs(design["contact_low"]), abs(design["contact_high"])) * 1.15 + 1e-3
        ends = np.stack([trace - half * across, trace + half * across], axis=1)
        lines.append(tuple(ends))
    else:
        turn = np.linspace(0.0, 2.0 * np.pi, 73)
        radius = follower["roller_radius"]
        lines.append((row.pitch_x + radius * np.cos(turn), row.pitch_y + radius * np.sin(turn)))
    return lines


def drawing_png(table: pandas.DataFrame, followers: int = 8) -> bytes:
    """PNG of the cam (its frame, mm): profile, base circle, pitch curve and the follower at
    ``followers`` camshaft angles (the inversion: the follower walks round the cam), beside
    the tappet's lift, the pressure angle (roller) or the contact's place on the face (flat)
    and the radius of curvature against the camshaft angle (degrees)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    figure = pyplot.figure(figsize=(12, 6.5))
    grid = figure.add_gridspec(3, 2, width_ratios=(1.15, 1.0))
    cam = figure.add_subplot(grid[:, 0])
    x, y = table["x"] * MM, table["y"] * MM
    cam.fill(x, y, color="0.88", zorder=0)
    cam.plot(np.append(x, x.iloc[0]), np.append(y, y.iloc[0]), color="k", lw=1.4, label="profile")
    base = table.attrs["follower"]["base_circle_radius"] * MM
    turn = np.linspace(0.0, 2.0 * np.pi, 361)
    cam.plot(base * np.cos(turn), base * np.sin(turn), "g--", lw=0.8, label="base circle")
    px, py = table["pitch_x"] * MM, table["pitch_y"] * MM
    cam.plot(
        np.append(px, px.iloc[0]), np.append(py, py.iloc[0]), "b-.", lw=0.8, label="pitch curve"
    )
    step = max(1, len(table) // followers)
    for row in table.iloc[::step].itertuples(index=False):
        for line_x, line_y in _follower_outline(table, row):
            cam.plot(np.asarray(line_x) * MM, np.asarray(line_y) * MM, color="tab:red", lw=0.8)
    cam.plot([0.0], [0.0], "k+", ms=10)
    cam.set_aspect("equal")
    cam.set_xlabel("x [mm] (cam frame, camshaft angle 0)")
    cam.set_ylabel("y [mm]")
    follower = table.attrs["follower"]
    cam.set_title(
        f"{table.attrs['scene']}: {table.attrs['component']}, {follower['kind']} follower, "
        f"base circle {base:.4g} mm",
        fontsize=9,
    )
    cam.legend(fontsize=7, loc="lower left")
    cam.grid(True, lw=0.3)
    degrees = np.degrees(table["cam_angle"])
    middle = (  # the flat face's pressure angle is 0: where the contact is on the face
        ("face_contact_position", MM, "contact on the face [mm]")
        if follower["kind"] == "flat_faced"
        else ("pressure_angle", 180.0 / np.pi, "pressure angle [deg]")
    )
    panels = (
        ("lift", MM, "tappet lift [mm]"),
        middle,
        ("radius_of_curvature", MM, "radius of curvature [mm]"),
    )
    for index, (column, scale, label) in enumerate(panels):
        axis = figure.add_subplot(grid[index, 1])
        values = table[column] * scale
        if column == "radius_of_curvature":
            values = values.clip(-5.0 * base, 5.0 * base)  # an inflection's radius is unbounded
        axis.plot(degrees, values, lw=1.1)
        axis.set_ylabel(label, fontsize=8)
        axis.grid(True, lw=0.3)
        if index == len(panels) - 1:
            axis.set_xlabel("camshaft angle [deg]")
    figure.tight_layout()
    try:
        return figure_bytes(figure, dpi=100)
    finally:
        pyplot.close(figure)


def verdicts(table: pandas.DataFrame) -> list[tuple[str, str]]:
    """(check, verdict) of the design checks: cusp or undercut, pressure angle, face."""
    design = table.attrs["design"]
    problems = {problem["kind"]: problem for problem in design["problems"]}
    follower = table.attrs["follower"]
    limit = table.attrs["pressure_angle_limit"]
    rows = [("cusp / undercut", "none: the surface is smooth and the follower can reach it")]
    if cam_geometry.PRESSURE_ANGLE in problems:
        problem = problems[cam_geometry.PRESSURE_ANGLE]
        rows.append(
            (
                "pressure angle",
                f"OVER the {math.degrees(limit):.4g} deg limit: {math.degrees(problem['value']):.4g} "
                f"deg at camshaft angle {problem['angle']:.6g} rad",
            )
        )
    else:
        largest = abs(design["largest_pressure_angle"])
        rows.append(
            (
                "pressure angle",
                f"within the {math.degrees(limit):.4g} deg limit (largest {math.degrees(largest):.4g} deg)",
            )
        )
    if follower["kind"] == "flat_faced":
        reach = max(abs(design["contact_low"]), abs(design["contact_high"]))
        rows.append(
            (
                "face",
                f"the contact sweeps {design['face_width'] * MM:.4g} mm of face: a face centred "
                f"on the axis needs a radius of at least {reach * MM:.4g} mm",
            )
        )
    return rows


def summary_markdown(table: pandas.DataFrame) -> str:
    """The summary: the cam's figures and the verdicts, as Markdown."""
    design = table.attrs["design"]
    follower = table.attrs["follower"]
    sizing = table.attrs["smallest_base_circle"]
    law = table.attrs["cam_law"]
    where = "" if math.isnan(sizing["angle"]) else f" at camshaft angle {sizing['angle']:.6g} rad"
    figures = [
        (
            "scene, component",
            f"{table.attrs['scene']}, {table.attrs['component']} ({table.attrs['mode']})",
        ),
        (
            "cam law",
            f"{law['law']}, lift {law['lift'] * MM:.4g} mm, rise {law['rise_angle']:.4g} rad, "
            f"high dwell {law['high_dwell_angle']:.4g} rad, return {law['return_angle']:.4g} rad"
            + (
                " (the desired valve lift; the tappet diagram follows)"
                if table.attrs["mode"] == "inverse"
                else ""
            ),
        ),
        (
            "follower",
            f"{follower['kind']}, offset {follower['offset'] * MM:.4g} mm"
            + (
                f", roller radius {follower['roller_radius'] * MM:.4g} mm"
                if follower["kind"] == "roller"
                else ""
            ),
        ),
        ("base circle radius", f"{follower['base_circle_radius'] * MM:.6g} mm"),
        (
            "least radius of curvature (convex)",
            f"{design['least_radius'] * MM:.6g} mm at camshaft angle {design['least_radius_angle']:.6g} rad",
        ),
        (
            "least pitch-curve radius",
            f"{design['least_pitch_radius'] * MM:.6g} mm at camshaft angle "
            f"{design['least_pitch_radius_angle']:.6g} rad",
        ),
        (
            "largest pressure angle",
            f"{math.degrees(design['largest_pressure_angle']):.4g} deg at camshaft angle "
            f"{design['largest_pressure_angle_angle']:.6g} rad",
        ),
        ("face width swept (flat face)", f"{design['face_width'] * MM:.6g} mm"),
        (
            "smallest base circle meeting the limits",
            f"{sizing['base_circle_radius'] * MM:.6g} mm (set by {sizing['limit']}{where})",
        ),
        (
            "DXF polyline",
            f"{len(table)} points, chord deviation at most {chord_deviation(table) * MM:.2g} mm",
        ),
    ]
    lines = ["| figure | value |", "|---|---|"]
    lines += [f"| {name} | {value} |" for name, value in figures]
    lines += ["", "| check | verdict |", "|---|---|"]
    lines += [f"| {name} | {value} |" for name, value in verdicts(table)]
    return "\n".join(lines) + "\n"


def write_cam_files(table: pandas.DataFrame, out_dir: Any) -> dict[str, Path]:
    """Write ``<scene>_<component>_cam`` .csv (the table, SI units), .dxf, .png and .md into
    ``out_dir`` (created if missing), all or none; returns {kind: path}."""
    folder = output_folder(out_dir)
    stem = f"{table.attrs['scene']}_{table.attrs['component']}_cam"
    csv = table.to_csv(index=False, float_format="%.17g")
    paths = {kind: folder / f"{stem}.{kind}" for kind in ("csv", "dxf", "png", "md")}
    atomic_write_all(
        {
            paths["csv"]: csv,
            paths["dxf"]: dxf_text(table),
            paths["png"]: drawing_png(table),
            paths["md"]: f"# Cam of {table.attrs['scene']}.{table.attrs['component']}\n\n"
            + summary_markdown(table),
        }
    )
    return paths
