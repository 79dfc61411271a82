"""Animations through the FMUs: every shipped mechanism scene run with the geometry effect,
and in every frame what is drawn satisfies the mechanism's constraints (link lengths,
sliders on their lines, the valve on its axis, the cam on the tappet's face) to 1e-9 of its
size; frames and times match the result; GIF, MP4 and HTML files read back with their
frames; a result without the geometry gets one error naming the effect; with the effect
off nothing else changes."""

import base64
import contextlib
import io
import math
import re
import sys

import numpy as np
import pytest
from PIL import Image

import mechfmu
from conftest import SCENES
from mechfmu.cli import main as cli
from mechfmu.cosim.scene import Connection, SceneError, load_scene
from mechfmu.runtime.physics import landing_gear as gear
from mechfmu.runtime.physics import suspension as susp
from mechfmu.runtime.physics import valve_train as vt
from mechfmu.tools.animate import AnimationError, with_geometry
from mechfmu.tools.animate.columns import MECHANISMS, geometry_outputs
from mechfmu.tools.docs import model_class

TOLERANCE = 1e-9
MECHANISM_SCENES = sorted(
    path.stem
    for path in SCENES.glob("*.toml")
    if any(spec.fmu in MECHANISMS for spec in load_scene(path).components.values())
)
# at most this many communication steps of each scene (the rest adds no new kind of frame);
# fewer of the one whose implicit integrator is slow to start
STEPS = 50
FEWER_STEPS = {"gear_retraction_dynamic": 15}


def length(shape, first=0, last=-1):
    return float(np.hypot(*(shape.xy[last] - shape.xy[first])))


def cross(p, q):
    return float(p[0] * q[1] - p[1] * q[0])


def near(value, expected, size):
    return abs(value - expected) <= TOLERANCE * size


def run(scene, stop_steps=STEPS, **options):
    chosen = load_scene(SCENES / f"{scene}.toml")
    stop = min(chosen.stop_time, chosen.start_time + stop_steps * chosen.step)
    return mechfmu.simulate(scene, geometry=True, stop_time=stop, **options)


# --- the constraints, one checker per model, on what a frame draws -----------------------------
def check_four_bar(drawn, p, row):
    d, a, b, c = (
        p[k] for k in ("ground_length", "crank_length", "coupler_length", "rocker_length")
    )
    size = max(a, b, c, d)
    assert near(length(drawn["ground_link"]), d, size)
    assert near(length(drawn["crank"]), a, size)
    assert near(length(drawn["coupler"]), b, size)
    assert near(length(drawn["rocker"]), c, size)
    assert np.array_equal(drawn["crank"].xy[1], drawn["coupler"].xy[0])  # pinned at A
    assert np.array_equal(drawn["rocker"].xy[1], drawn["coupler"].xy[1])  # and at B


def check_slider_crank(drawn, p, row):
    a, b = p["crank_length"], p["coupler_length"]
    size = max(a, b)
    assert near(length(drawn["crank"]), a, size)
    assert near(length(drawn["rod"]), b, size)
    slider = drawn["rod"].xy[1]
    assert slider[1] == p["offset"]  # on its line
    block = drawn["slider"].xy
    assert near(float(block[:-1, 0].mean()), slider[0], size)  # the block around its pin
    assert near(float(block[:-1, 1].mean()), slider[1], size)


def check_landing_gear(drawn, p, row, table, name):
    d, h, bar = p["attachment_distance"], p["pivot_height"], p["bar_length"]
    size = max(d, h, bar)
    pivot, attachment, axle = drawn["bar"].xy
    anchor = drawn["piston_pivot"].xy[0]
    assert near(float(np.hypot(*(attachment - pivot))), d, size)
    assert near(float(np.hypot(*(axle - pivot))), bar, size)
    assert near(float(np.hypot(*(anchor - pivot))), h, size)
    along = cross(attachment - pivot, axle - pivot)
    assert abs(along) <= TOLERANCE * size**2  # one straight bar
    angle = table[f"{name}.gear_angle"].iloc[row]
    piston = gear.piston_motion(angle, 0.0, 0.0, d, h).extension
    assert near(float(np.hypot(*(attachment - anchor))), piston, size)
    rod = drawn["rod"].xy
    assert np.array_equal(rod[1], attachment)  # the rod acts at the attachment


def check_suspension(drawn, p, row, table, name):
    spring = susp.make_spring(
        p["spring_free_length"], p["spring_stiffness"], p["spring_base_offset"]
    )
    k, free = spring.stiffness, spring.free_length
    apex = drawn["left_spring"].xy[-1]
    assert np.array_equal(apex, drawn["right_spring"].xy[-1]) and apex[0] == 0.0
    left, right = drawn["left_spring"].xy[0], drawn["right_spring"].xy[0]
    assert left[1] == right[1] and left[0] == -right[0] == -spring.base_offset
    s = length(drawn["left_spring"])
    force = 2 * k * (free - s) * (apex[1] - left[1]) / s  # what the drawn springs carry
    assert abs(force - table[f"{name}.spring_force"].iloc[row]) <= TOLERANCE * k * free


def geometry_of(p):
    return vt.ValveGeometry(*(p[f] for f in vt.ValveGeometry._fields))


def check_chain(drawn, p, size):
    g = geometry_of(p)
    foot, t = drawn["pushrod"].xy
    t2, fulcrum, v = drawn["rocker"].xy
    end = drawn["valve_link"].xy[1]
    assert foot[0] == 0.0 and np.array_equal(t, t2)
    assert near(float(np.hypot(*(t - foot))), g.pushrod_length, size)
    assert near(float(np.hypot(*(t - fulcrum))), g.tappet_arm, size)
    assert near(float(np.hypot(*(v - fulcrum))), g.valve_arm, size)
    assert abs(cross(t - fulcrum, v - fulcrum)) <= TOLERANCE * size**2
    assert near(length(drawn["valve_link"]), g.valve_link_length, size)
    assert end[0] == g.valve_axis_x  # on the valve axis
    # the cam touches its follower: the roller at its radius from the tappet foot, or the
    # flat face within its width (a cam that folds, a cusp, may reach past it elsewhere)
    cam = drawn["cam"].xy
    if p.get("follower", "flat_faced") == "roller":
        gaps = np.abs(np.hypot(*(cam - foot).T) - p["roller_radius"])
        assert gaps.min() <= TOLERANCE * size
        rim = np.hypot(*(drawn["roller"].xy - foot).T)  # the roller drawn round the foot
        assert np.all(np.abs(rim - p["roller_radius"]) <= TOLERANCE * size)
    else:
        face = drawn["tappet_face"].xy
        on_face = (np.abs(cam[:, 1] - foot[1]) <= TOLERANCE * size) & (
            (cam[:, 0] >= face[0, 0]) & (cam[:, 0] <= face[1, 0])
        )
        assert on_face.any()
    return end


def check_valve_train(drawn, p, row, table, name):
    size = p["pushrod_length"]
    end = check_chain(drawn, p, size)
    closed = vt.rest_position(geometry_of(p))[1]
    assert near(closed - end[1], table[f"{name}.valve_lift"].iloc[row], size)
    assert drawn["valve"].xy[0][1] == end[1]  # the stem hangs from the valve foot


def check_valve_spring(drawn, p, row, table, name):
    size = p["pushrod_length"]
    rocker_end = check_chain(drawn, p, size)
    tip = drawn["valve"].xy[0]
    assert tip[1] == drawn["valve"].xy[1][1] and near(
        float(drawn["valve"].xy[:2, 0].mean()), p["valve_axis_x"], size
    )
    closed = vt.rest_position(geometry_of(p))[1]
    lift = table[f"{name}.valve_lift"].iloc[row]
    assert near(tip[1], closed - p["lash"] - lift, size)
    column = f"{name}.penetration"
    if column in table:  # the drawn gap is the contact's: minus its penetration
        assert near(rocker_end[1] - tip[1], -table[column].iloc[row], size)


CHECKS = {
    "FourBar": check_four_bar,
    "SliderCrank": check_slider_crank,
    "LandingGear": check_landing_gear,
    "Suspension": check_suspension,
    "ValveTrain": check_valve_train,
    "ValveSpring": check_valve_spring,
}


def test_every_mechanism_model_has_the_geometry_effect():
    assert set(MECHANISMS) == set(CHECKS)
    for model in MECHANISMS:
        outputs = geometry_outputs(model)
        variables = {v.name: v for v in model_class(model).VARIABLES}
        assert len(variables) == len(model_class(model).VARIABLES)  # no name twice
        assert variables["geometry"].causality == "parameter"
        assert all(variables[o].unit == ("rad" if o == "cam_angle" else "m") for o in outputs)


@pytest.mark.parametrize("scene", MECHANISM_SCENES)
def test_every_frame_satisfies_the_mechanism_constraints(scene, fmu_dir):
    table = run(scene, FEWER_STEPS.get(scene, STEPS), fmu_dir=fmu_dir)
    animation = mechfmu.animate(table, speed=0.1 * (table.index[-1] - table.index[0]), fps=10)
    assert len(animation) == 101  # 100 frames of 1 % of the span, and the start
    components = table.attrs["components"]
    checked = set()
    for frame in range(len(animation)):
        row = int(animation.frame_rows[frame])
        for name, drawn in animation.shapes(frame).items():
            model = components[name]["model"]
            check = CHECKS[model]
            parameters = components[name]["parameters"]
            if model in ("FourBar", "SliderCrank"):
                check(drawn, parameters, row)
            else:
                check(drawn, parameters, row, table, name)
            checked.add(name)
    assert checked == {name for name, c in components.items() if c["model"] in CHECKS}


def test_frames_show_rows_of_the_result_at_their_times(fmu_dir):
    table = run("four_bar_crank_rocker", 120, fmu_dir=fmu_dir)  # 0.6 s in steps of 5 ms
    animation = mechfmu.animate(table, fps=25)  # real time: a frame every 40 ms
    assert len(animation) == 16
    np.testing.assert_allclose(animation.frame_times, np.arange(16) * 0.04, atol=1e-12)
    assert set(animation.frame_times) <= set(table.index)
    slow = mechfmu.animate(table, speed=0.05, fps=10)  # a frame per row (5 ms)
    assert list(slow.frame_rows) == list(range(len(table)))


def test_gif_mp4_and_html_read_back_with_their_frames(fmu_dir, tmp_path):
    pytest.importorskip("imageio_ffmpeg")  # the video extra: installed with the test extra
    import imageio.v2 as imageio

    table = run("valve_float_dynamic", fmu_dir=fmu_dir)  # 1 ms steps: rows repeat in frames
    animation = mechfmu.animate(
        table, speed=0.006, fps=20, panels=["valve.contact_force"], width=320
    )
    frames, durations = animation.gif_frames()
    assert len(frames) < len(animation)  # frames that show the same row are one GIF frame
    gif = Image.open(animation.save(tmp_path / "valve.gif"))
    assert gif.n_frames == len(frames)
    shown = []
    for index in range(gif.n_frames):
        gif.seek(index)
        shown.append(gif.info["duration"])
    assert shown == durations and sum(shown) == round(len(animation) * 1000 / 20)
    video = imageio.get_reader(animation.save(tmp_path / "valve.mp4"), "ffmpeg")
    assert video.count_frames() == len(animation)
    assert video.get_meta_data()["fps"] == 20
    page = (animation.save(tmp_path / "valve.html")).read_text()
    (data,) = re.findall(r'src="data:image/gif;base64,([^"]+)"', page)
    assert Image.open(io.BytesIO(base64.b64decode(data))).n_frames == len(frames)
    assert animation._repr_html_().startswith('<img src="data:image/gif;base64,')


def test_run_animate_writes_a_gif_that_plays(fmu_dir, tmp_path):
    out = tmp_path / "D"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = cli(
            [
                "run",
                "four_bar_crank_rocker",
                "--animate",
                "--out",
                str(out),
                "--fmu-dir",
                str(fmu_dir),
                "--no-plot",
                "--check",
            ]
        )
    assert status == 0, printed.getvalue()
    gif = Image.open(out / "four_bar_crank_rocker.gif")
    assert gif.n_frames == 26  # 1 s in real time at 25 frames/s
    assert "animation:" in printed.getvalue()
    again = tmp_path / "again.gif"
    with contextlib.redirect_stdout(io.StringIO()):
        assert (
            cli(
                [
                    "animate",
                    str(out / "four_bar_crank_rocker.csv"),
                    "--out",
                    str(again),
                    "--speed",
                    "2",
                    "--fps",
                    "10",
                ]
            )
            == 0
        )
    assert Image.open(again).n_frames == 6


def test_a_result_without_geometry_names_the_effect_to_switch_on(fmu_dir, tmp_path, capsys):
    plain = mechfmu.simulate("four_bar_crank_rocker", fmu_dir=fmu_dir, stop_time=0.1)
    with pytest.raises(AnimationError) as caught:
        mechfmu.animate(plain)
    message = str(caught.value)
    assert "linkage (FourBar) lacks the column(s) linkage.crank_pivot_x" in message
    assert "'geometry' effect" in message and "--animate" in message
    path = tmp_path / "plain.csv"
    mechfmu.write_result(plain, path)
    assert cli(["animate", str(path)]) == 2
    assert "animate error: cannot animate this result" in capsys.readouterr().err
    bare = plain.copy()
    bare.attrs = {}
    with pytest.raises(AnimationError, match="no component of a mechanism model"):
        mechfmu.animate(bare)


def test_geometry_recorded_with_the_effect_off_is_refused(fmu_dir):
    scene = load_scene(SCENES / "four_bar_crank_rocker.toml")
    scene.record = None  # every output, the geometry's too, with the effect off
    table = mechfmu.simulate(scene, fmu_dir=fmu_dir, stop_time=0.05)
    assert "linkage.rocker_pin_x" in table
    with pytest.raises(AnimationError, match="all 0 .effect off"):
        mechfmu.animate(table)


@pytest.mark.parametrize(
    "scene",
    [
        "four_bar_solver_crossed",
        "suspension_road_bump",
        "valve_float_dynamic",
        "gear_extension_gravity",
    ],
)
def test_the_geometry_effect_changes_no_other_output(scene, fmu_dir):
    on = run(scene, fmu_dir=fmu_dir, stop_steps=60)
    off = mechfmu.simulate(scene, fmu_dir=fmu_dir, stop_time=on.index[-1])
    assert list(off.columns) == [c for c in on.columns if c in off.columns]
    np.testing.assert_array_equal(on[off.columns].to_numpy(), off.to_numpy())  # bit for bit


def test_options_that_cannot_be_used_are_refused(fmu_dir, tmp_path, monkeypatch):
    table = run("slider_crank_offset", stop_steps=20, fmu_dir=fmu_dir)
    with pytest.raises(AnimationError, match="panel column.s. slider.nothing not in the result"):
        mechfmu.animate(table, panels=["slider.nothing"])
    with pytest.raises(AnimationError, match="width = 50"):
        mechfmu.animate(table, width=50)
    animation = mechfmu.animate(table, speed=0.001)
    with pytest.raises(AnimationError, match="unknown animation format '.avi'"):
        animation.save(tmp_path / "x.avi")
    with pytest.raises(AnimationError, match="fps = 60 is more than a GIF plays"):
        mechfmu.animate(table, speed=0.001, fps=60).save(tmp_path / "x.gif")
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # as if the extra were missing
    with pytest.raises(AnimationError, match=r"needs imageio-ffmpeg.*mechfmu\[video\]"):
        animation.save(tmp_path / "x.mp4")
    assert not (tmp_path / "x.mp4").exists()


def test_with_geometry_needs_a_mechanism():
    scene = load_scene(SCENES / "four_bar_crank_rocker.toml")
    del scene.components["linkage"]
    with pytest.raises(SceneError, match="no component has the 'geometry' effect"):
        with_geometry(scene)
    chosen = with_geometry(load_scene(SCENES / "valve_train_dynamic.toml"))
    assert chosen.components["valve"].effects == ["geometry"]
    assert "valve.valve_tip_y" in chosen.record and "valve_train.cam_angle" in chosen.record
    assert math.isclose(chosen.stop_time, 0.02)


def test_the_valve_with_the_rocker_drive_is_drawn_on_its_axis(fmu_dir):
    scene = load_scene(SCENES / "valve_train_dynamic.toml")
    scene.components["valve"].parameters["drive"] = "rocker"
    scene.connections = [c for c in scene.connections if c.target != "valve"]
    scene.connections += [
        Connection("valve_train", f"valve_{rate}", "valve", f"rocker_{rate}")
        for rate in ("lift", "velocity", "acceleration")
    ]
    scene.record += ["valve.penetration"]
    table = mechfmu.simulate(with_geometry(scene), fmu_dir=fmu_dir, stop_time=0.01)
    animation = mechfmu.animate(table, speed=0.001, fps=10)
    assert not table["valve.cam_angle"].any() and not table["valve.pushrod_end_y"].any()
    p = table.attrs["components"]["valve"]["parameters"]
    closed = vt.rest_position(geometry_of(p))[1]
    size = p["pushrod_length"]
    for frame in range(len(animation)):
        row = int(animation.frame_rows[frame])
        drawn = animation.shapes(frame)["valve"]
        assert "cam" not in drawn and "pushrod" not in drawn  # the valve axis alone
        end, tip = drawn["rocker_end"].xy.mean(axis=0), drawn["valve"].xy[0]
        assert near(end[0], p["valve_axis_x"], size)
        assert near(end[1], closed - table["valve_train.valve_lift"].iloc[row], size)
        assert near(end[1] - tip[1], -table["valve.penetration"].iloc[row], size)
