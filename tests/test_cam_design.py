"""mechfmu.cam_profile, the cam files (CSV, DXF re-read by ezdxf, PNG, summary) and the
cam-profile / cam-size commands; parse_assignments (--set)."""

import math

import ezdxf
import numpy as np
import pandas
import pytest

import mechfmu
from mechfmu.cli import main as cli
from mechfmu.cli import parse_assignments
from cli_process import run_mechfmu
from mechfmu.cosim.scene import SceneError
from mechfmu.runtime.errors import CamDesignError, RangeError
from mechfmu.runtime.physics import cam_geometry as cg
from mechfmu.runtime.physics import cam_laws as cl
from mechfmu.tools import cam_design


def test_cam_profile_is_the_runtime_cam_in_si_units():
    table = mechfmu.cam_profile("valve_train", points=720)
    assert list(table.columns)[:7] == [
        "cam_angle",
        "x",
        "y",
        "pitch_x",
        "pitch_y",
        "pressure_angle",
        "radius_of_curvature",
    ]
    assert table.attrs["units"]["cam_angle"] == "rad" and table.attrs["units"]["x"] == "m"
    np.testing.assert_allclose(np.diff(table["cam_angle"]), 2.0 * math.pi / 720, rtol=1e-12)
    follower = cg.check_follower("flat_faced", 0.025)
    profile = cl.check_profile("polynomial_345", 0.007, 0.0, 1.2, 0.1, 1.2)
    for row in table.iloc[::37].itertuples(index=False):
        point = cg.profile_point(follower, profile, row.cam_angle)
        assert (row.x, row.y, row.radius_of_curvature) == (
            point.x,
            point.y,
            point.radius_of_curvature,
        )
    design = table.attrs["design"]
    assert design["least_radius"] == pytest.approx(0.025 - 0.0215522191130, rel=1e-9)
    assert table.attrs["smallest_base_circle"]["limit"] == "curvature"
    assert table["lift"].max() == pytest.approx(0.007, rel=1e-12)


def test_parameters_and_component_choose_the_cam():
    table = mechfmu.cam_profile(
        "valve_train_inverse", parameters={"valve.roller_radius": 0.006}, points=64
    )
    assert table.attrs["follower"]["roller_radius"] == 0.006
    assert table.attrs["mode"] == "inverse"
    with pytest.raises(SceneError, match="no ValveTrain component 'cam'"):
        mechfmu.cam_profile("valve_train", component="cam", points=64)
    with pytest.raises(SceneError, match="0 ValveTrain components"):
        mechfmu.cam_profile("gear_retraction", points=64)
    with pytest.raises(SceneError, match="has no parameter 'base_radius'"):
        mechfmu.cam_profile("valve_train", parameters={"valve.base_radius": 0.02})


@pytest.mark.parametrize(
    "changes, error, text",
    [
        (
            {"valve.cam_base_radius": 0.015, "valve.pushrod_length": 0.2},
            CamDesignError,
            "cam_base_radius = 0.015 m is outside the valid range (0.0215522191130",
        ),
        ({"valve.cam_base_radius": 0.0}, RangeError, "cam_base_radius = 0.0 m"),
        ({"valve.rise_angle": 0.0}, RangeError, "rise_angle = 0.0 rad is outside"),
        (
            {"valve.follower_offset": -0.03},
            RangeError,
            "follower_offset = -0.03 m is outside the valid range (-0.025, 0.025) m",
        ),
    ],
)
def test_bad_cams_get_one_clear_error(changes, error, text):
    with pytest.raises(error) as info:
        mechfmu.cam_profile("valve_train", parameters=changes, points=64)
    assert text in str(info.value)


def test_cam_files_dxf_reads_back_in_millimetres_as_a_closed_curve(tmp_path):
    table = mechfmu.cam_profile("valve_train_inverse", points=1440)
    paths = cam_design.write_cam_files(table, tmp_path)
    assert sorted(paths) == ["csv", "dxf", "md", "png"]
    document = ezdxf.readfile(paths["dxf"])
    assert document.header["$INSUNITS"] == 4 and document.header["$MEASUREMENT"] == 1
    (polyline,) = document.modelspace().query('LWPOLYLINE[layer=="CAM_PROFILE"]')
    assert polyline.closed
    points = np.array(list(polyline.get_points("xy")))
    np.testing.assert_allclose(points[:, 0], table["x"] * 1e3, rtol=0, atol=1e-12)
    np.testing.assert_allclose(points[:, 1], table["y"] * 1e3, rtol=0, atol=1e-12)
    (circle,) = document.modelspace().query('CIRCLE[layer=="BASE_CIRCLE"]')
    assert circle.dxf.radius == pytest.approx(15.0, rel=1e-15)
    back = pandas.read_csv(paths["csv"])
    pandas.testing.assert_frame_equal(back, table, check_exact=True, check_dtype=False)
    assert paths["png"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = paths["md"].read_text()
    assert "| largest pressure angle | 25.87 deg at camshaft angle" in summary
    assert "within the 30 deg limit" in summary


def test_chord_deviation_is_the_polylines_worst_sagitta():
    coarse = mechfmu.cam_profile("valve_train", points=360)
    fine = mechfmu.cam_profile("valve_train", points=1440)
    # sagitta ~ chord^2 / (8 rho): 4 times the points, 16 times smaller
    ratio = cam_design.chord_deviation(coarse) / cam_design.chord_deviation(fine)
    assert ratio == pytest.approx(16.0, rel=0.05)


def test_cam_profile_command(tmp_path, capsys):
    assert cli(["cam-profile", "valve_train", "--points", "720", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| smallest base circle meeting the limits | 21.5522 mm (set by curvature" in out
    assert (tmp_path / "valve_train_valve_cam.dxf").is_file()
    # a pressure angle over its limit: the files are written, the status says so
    status = cli(
        [
            "cam-profile",
            "valve_train_inverse",
            "--set",
            "valve.pressure_angle_limit=0.4",
            "--points",
            "360",
            "--out",
            str(tmp_path),
        ]
    )
    assert status == 1 and "OVER the 22.92 deg limit" in capsys.readouterr().out
    status = cli(
        [
            "cam-profile",
            "valve_train",
            "--set",
            "valve.cam_base_radius=0.015",
            "--out",
            str(tmp_path),
        ]
    )
    assert status == 2
    assert "cam error: cam_base_radius = 0.015 m" in capsys.readouterr().err


def test_cam_size_command(capsys):
    assert cli(["cam-size", "valve_train", "--min-radius-of-curvature", "0.003"]) == 0
    out = capsys.readouterr().out
    assert "smallest cam_base_radius 0.024552219113" in out and "now 0.025 m" in out
    assert cli(["cam-size", "valve_train", "--set", "valve.follower=roller"]) == 0
    assert "roller follower" in capsys.readouterr().out


def test_inverse_tappet_diagram_barely_depends_on_the_base_circle():
    # a larger base circle with the pushrod shortened as much: the rocker rests where it did
    # and the tappet diagram the desired valve motion needs moves by about 0.1 um
    before = cam_design.cam_setup_of("valve_train_inverse")
    after = cam_design.cam_setup_of(
        "valve_train_inverse", {"valve.cam_base_radius": 0.025, "valve.pushrod_length": 0.19}
    )
    phases = np.linspace(0.0, 1.0, 41)
    change = max(
        abs(a.motion(x)[0] - b.motion(x)[0])
        for a, b in zip(before.pieces, after.pieces)
        for x in phases
    )
    assert 1e-8 < change < 2e-7


def test_parse_assignments_reads_toml_values_else_strings():
    assert parse_assignments(
        ["valve.lift=0.008", "valve.follower=roller", 'a.b="x y"', "a.c=true", " a.d = 3 "]
    ) == {"valve.lift": 0.008, "valve.follower": "roller", "a.b": "x y", "a.c": True, "a.d": 3}
    with pytest.raises(ValueError, match="expected component.parameter=value"):
        parse_assignments(["valve.lift"])
    with pytest.raises(ValueError, match="expected component.parameter=value"):
        parse_assignments(["=3"])


@pytest.mark.parametrize("points", [15, 1_000_001, 10**8, 64.0, True])
def test_profile_points_outside_their_range_are_refused_before_any_work(points):
    # 1e8 points ran for minutes and filled the memory before this limit (about 4 us and
    # 96 bytes a point)
    with pytest.raises(ValueError, match=r"must be an integer from 16 to 1000000"):
        mechfmu.cam_profile("valve_train", points=points)


def test_the_command_refuses_absurd_profile_points_in_one_line(tmp_path):
    done = run_mechfmu("cam-profile", "valve_train", "--points", "100000000", "--out", tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith("cam error: points = 100000000 must be an integer from 16")
    assert not list(tmp_path.iterdir())
