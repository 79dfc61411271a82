"""Time profiles: piston stroke laws and load shapes (standard-library physics)."""

import math

import pytest

from mechfmu.runtime.physics import profiles as pr
from mechfmu.runtime.errors import MechanismError, RangeError

FOOT = 0.3048
X_RETRACTED, X_EXTENDED = 1.25 * FOOT, 2.0 * FOOT

# (start, end) pairs within a factor 2 of each other (the coursework stroke both ways and more)
STROKES = [
    (X_RETRACTED, X_EXTENDED),
    (X_EXTENDED, X_RETRACTED),
    (0.3, 0.5),
    (0.5, 0.3),
    (1.0, 1.75),
]
PROFILES = ["constant_speed", "cycloidal"]


def sample(t, start, end, duration, profile, start_time=0.0):
    return pr.stroke(t, start, end, duration, profile, start_time)


# --- stroke: endpoints and holds -----------------------------------------------------------


@pytest.mark.parametrize("profile", PROFILES)
@pytest.mark.parametrize("start, end", STROKES)
@pytest.mark.parametrize("start_time", [0.0, 1.5, 10.0])
def test_stroke_endpoints_are_exact(profile, start, end, start_time):
    duration = 3.0
    assert sample(start_time, start, end, duration, profile, start_time).value == start
    assert sample(start_time + duration, start, end, duration, profile, start_time).value == end


@pytest.mark.parametrize("profile", PROFILES)
@pytest.mark.parametrize("start, end", STROKES)
def test_stroke_holds_outside(profile, start, end):
    for t in (-100.0, -1.0, -1e-6):
        assert sample(t, start, end, 3.0, profile) == (start, 0.0, 0.0)
    for t in (3.0 + 1e-6, 3.5, 1e6):
        assert sample(t, start, end, 3.0, profile) == (end, 0.0, 0.0)


@pytest.mark.parametrize("profile", PROFILES)
def test_stroke_with_start_time_is_shifted(profile):
    for i in range(31):
        t = 0.1 * i
        shifted = sample(t + 2.0, X_RETRACTED, X_EXTENDED, 3.0, profile, start_time=2.0)
        plain = sample(t, X_RETRACTED, X_EXTENDED, 3.0, profile)
        for a, b in zip(shifted, plain):
            assert a == pytest.approx(b, rel=1e-12, abs=1e-13)


def test_constant_speed_is_linear_with_coursework_speed():
    # the coursework drive: 0.25 ft/s over 3 s from 1.25 ft to 2 ft
    for i in range(31):
        t = 0.1 * i
        s = sample(t, X_RETRACTED, X_EXTENDED, 3.0, "constant_speed")
        assert s.value == pytest.approx(X_RETRACTED + 0.25 * FOOT * t, rel=1e-14)
        assert s.rate == pytest.approx(0.25 * FOOT, rel=1e-14)
        assert s.rate2 == 0.0


def test_cycloidal_midpoint_and_peak_speed():
    s = sample(1.5, X_RETRACTED, X_EXTENDED, 3.0, "cycloidal")
    travel = X_EXTENDED - X_RETRACTED
    assert s.value == pytest.approx(X_RETRACTED + 0.5 * travel, rel=1e-14)
    assert s.rate == pytest.approx(2.0 * travel / 3.0, rel=1e-14)  # twice the mean speed
    assert abs(s.rate2) < 1e-14


# --- stroke: derivatives -------------------------------------------------------------------


@pytest.mark.parametrize("profile", PROFILES)
@pytest.mark.parametrize("start, end", STROKES)
def test_stroke_rates_are_derivatives(profile, start, end):
    duration, step = 2.5, 1e-6
    travel = abs(end - start)
    for i in range(1, 100):
        t = duration * i / 100
        s = sample(t, start, end, duration, profile)
        dv = (
            sample(t + step, start, end, duration, profile).value
            - sample(t - step, start, end, duration, profile).value
        ) / (2 * step)
        dr = (
            sample(t + step, start, end, duration, profile).rate
            - sample(t - step, start, end, duration, profile).rate
        ) / (2 * step)
        assert abs(s.rate - dv) <= 1e-7 * travel / duration, t
        assert abs(s.rate2 - dr) <= 1e-7 * travel / duration**2, t


@pytest.mark.parametrize("start, end", STROKES)
def test_cycloidal_speed_and_acceleration_vanish_at_both_ends(start, end):
    duration = 3.0
    peak_acceleration = 2 * math.pi * abs(end - start) / duration**2
    for t in (0.0, duration):
        s = sample(t, start, end, duration, "cycloidal")
        assert s.rate == 0.0
        assert abs(s.rate2) <= 1e-15 * peak_acceleration
    # and they approach zero continuously from inside
    s = sample(1e-6, start, end, duration, "cycloidal")
    assert abs(s.rate) < 1e-10 and abs(s.rate2) < 1e-5 * peak_acceleration
    s = sample(duration - 1e-6, start, end, duration, "cycloidal")
    assert abs(s.rate) < 1e-10 and abs(s.rate2) < 1e-5 * peak_acceleration


def test_cycloidal_is_monotonic():
    previous = X_RETRACTED
    for i in range(1, 301):
        value = sample(0.01 * i, X_RETRACTED, X_EXTENDED, 3.0, "cycloidal").value
        assert value >= previous
        previous = value


# --- stroke: time snapping at the end ------------------------------------------------------


@pytest.mark.parametrize("profile", PROFILES)
@pytest.mark.parametrize("start_time, duration", [(0.0, 3.0), (0.0, 4.0), (2.0, 1.0)])
def test_times_within_1e_9_of_stroke_end_count_as_end(profile, start_time, duration):
    end_time = start_time + duration
    at_end = sample(end_time, X_RETRACTED, X_EXTENDED, duration, profile, start_time)
    assert at_end.value == X_EXTENDED
    for factor in (1e-10, 5e-10, -1e-10, -5e-10):
        t = start_time + duration * (1 + factor)
        assert sample(t, X_RETRACTED, X_EXTENDED, duration, profile, start_time) == at_end
    # one rounding error past the end, as a master's t + dt produces
    t = start_time + sum([duration / 10] * 10)
    assert sample(t, X_RETRACTED, X_EXTENDED, duration, profile, start_time) == at_end
    # well past the tolerance the profile is genuinely before / after the end
    before = sample(
        start_time + duration * (1 - 1e-6), X_RETRACTED, X_EXTENDED, duration, profile, start_time
    )
    assert before.value <= X_EXTENDED
    assert before.rate > 0.0 and before != at_end
    after = sample(
        start_time + duration * (1 + 1e-6), X_RETRACTED, X_EXTENDED, duration, profile, start_time
    )
    assert after == (X_EXTENDED, 0.0, 0.0)


@pytest.mark.parametrize("profile", PROFILES)
def test_times_within_1e_9_of_stroke_start_count_as_start(profile):
    for t in (0.0, -1e-10, 1e-10):
        assert sample(t, X_RETRACTED, X_EXTENDED, 3.0, profile).value == X_RETRACTED


# --- check_stroke --------------------------------------------------------------------------


@pytest.mark.parametrize("profile", PROFILES)
def test_check_stroke_accepts_valid(profile):
    assert pr.check_stroke(X_RETRACTED, X_EXTENDED, 3.0, profile) is None
    assert pr.check_stroke(X_RETRACTED, X_EXTENDED, 4.0, profile, start_time=1.0) is None


@pytest.mark.parametrize("stroke_time", [4.0000001, 5.0, 100.0])
def test_check_stroke_rejects_slow_stroke(stroke_time):
    with pytest.raises(RangeError) as info:
        pr.check_stroke(X_RETRACTED, X_EXTENDED, stroke_time, "cycloidal")
    text = str(info.value)
    assert "stroke_time" in text and "4" in text
    assert info.value.name == "stroke_time"
    assert info.value.value == stroke_time


@pytest.mark.parametrize("stroke_time", [0.0, -1.0, math.nan, math.inf])
def test_check_stroke_rejects_non_positive_or_non_finite_time(stroke_time):
    with pytest.raises(RangeError) as info:
        pr.check_stroke(X_RETRACTED, X_EXTENDED, stroke_time, "constant_speed")
    assert info.value.name == "stroke_time"
    assert "stroke_time" in str(info.value)


@pytest.mark.parametrize(
    "name, args",
    [
        ("start_extension", (math.nan, X_EXTENDED, 3.0, "cycloidal")),
        ("end_extension", (X_RETRACTED, math.inf, 3.0, "cycloidal")),
        ("start_time", (X_RETRACTED, X_EXTENDED, 3.0, "cycloidal", math.nan)),
    ],
)
def test_check_stroke_rejects_non_finite_parameters(name, args):
    with pytest.raises(RangeError) as info:
        pr.check_stroke(*args)
    assert info.value.name == name


@pytest.mark.parametrize("profile", ["linear", "Cycloidal", "", None])
def test_check_stroke_rejects_unknown_profile(profile):
    with pytest.raises(MechanismError) as info:
        pr.check_stroke(X_RETRACTED, X_EXTENDED, 3.0, profile)
    assert repr(profile) in str(info.value)
    assert "constant_speed" in str(info.value) and "cycloidal" in str(info.value)


# --- load shapes ---------------------------------------------------------------------------


def test_constant_load():
    for t in (-5.0, 0.0, 1.0, 1e9):
        assert pr.load(t, "constant", 2069.91, 99.0, 1.0, 2.0) == (2069.91, 0.0, 0.0)


def test_step_load():
    assert pr.load(0.999, "step", 10.0, 20.0, 1.0, 0.0) == (10.0, 0.0, 0.0)
    assert pr.load(1.0, "step", 10.0, 20.0, 1.0, 0.0) == (20.0, 0.0, 0.0)
    assert pr.load(1.0 - 1e-10, "step", 10.0, 20.0, 1.0, 0.0).value == 20.0  # snapped
    assert pr.load(1.0 - 1e-6, "step", 10.0, 20.0, 1.0, 0.0).value == 10.0
    assert pr.load(50.0, "step", 10.0, 20.0, 1.0, 0.0) == (20.0, 0.0, 0.0)


def test_ramp_load():
    start, duration, a, b = 1.0, 4.0, -100.0, 300.0
    assert pr.load(0.5, "ramp", a, b, start, duration) == (a, 0.0, 0.0)
    assert pr.load(start, "ramp", a, b, start, duration).value == a
    assert pr.load(start + duration, "ramp", a, b, start, duration).value == b
    assert pr.load(start + duration * (1 + 1e-10), "ramp", a, b, start, duration).value == b
    assert pr.load(10.0, "ramp", a, b, start, duration) == (b, 0.0, 0.0)
    for i in range(1, 40):
        t = start + duration * i / 40
        s = pr.load(t, "ramp", a, b, start, duration)
        assert s.value == pytest.approx(a + (b - a) * i / 40, rel=1e-14, abs=1e-12)
        assert s.rate == pytest.approx((b - a) / duration, rel=1e-15)
        assert s.rate2 == 0.0


def test_table_load_uses_interpolation(tmp_path):
    path = tmp_path / "load.csv"
    path.write_text("time,load\n0,0\n1,100\n3,-100\n")
    table = pr.read_table(path)
    assert pr.load(2.0, "table", 0.0, 0.0, 0.0, 0.0, table) == (0.0, -100.0, 0.0)
    assert pr.load(0.5, "table", 0.0, 0.0, 0.0, 0.0, table) == (50.0, 100.0, 0.0)
    assert pr.load(9.0, "table", 0.0, 0.0, 0.0, 0.0, table) == (-100.0, 0.0, 0.0)


def test_check_load():
    for shape in ("constant", "step", "ramp", "table"):
        assert pr.check_load(shape, 1.0, 2.0, 0.0, 1.0) is None
    with pytest.raises(MechanismError) as info:
        pr.check_load("sine", 1.0, 2.0, 0.0, 1.0)
    assert "'sine'" in str(info.value)
    with pytest.raises(RangeError) as info:
        pr.check_load("ramp", 1.0, 2.0, 0.0, 0.0)
    assert info.value.name == "duration"
    with pytest.raises(RangeError) as info:
        pr.check_load("constant", math.nan, 2.0, 0.0, 1.0)
    assert info.value.name == "initial_value"
    with pytest.raises(RangeError) as info:
        pr.check_load("step", 1.0, math.inf, 0.0, 1.0)
    assert info.value.name == "final_value"


# --- read_table and interpolate ------------------------------------------------------------


def test_read_table_with_header(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("time,value\n0.0,1.5\n0.5,2.5\n2.0,-1.0\n")
    assert pr.read_table(path) == ([0.0, 0.5, 2.0], [1.5, 2.5, -1.0])


def test_read_table_without_header_and_with_comments_and_blank_lines(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("# load history\n0,10\n\n  # indented comment\n1e-3, 20\n2,30\n")
    assert pr.read_table(path) == ([0.0, 1e-3, 2.0], [10.0, 20.0, 30.0])


def test_read_table_single_row(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("5,7\n")
    table = pr.read_table(path)
    assert table == ([5.0], [7.0])
    assert pr.interpolate(table, 0.0) == (7.0, 0.0, 0.0)
    assert pr.interpolate(table, 9.0) == (7.0, 0.0, 0.0)


@pytest.mark.parametrize(
    "text, line",
    [
        ("0,1\n1,2\n1,3\n", 3),  # repeated time
        ("0,1\n2,2\n1,3\n", 3),  # decreasing time
        ("time,value\n0,1\n0,2\n", 3),
    ],
)
def test_read_table_rejects_non_increasing_times(tmp_path, text, line):
    path = tmp_path / "t.csv"
    path.write_text(text)
    with pytest.raises(MechanismError) as info:
        pr.read_table(path)
    assert f"line {line}" in str(info.value)
    assert "increase" in str(info.value)


@pytest.mark.parametrize(
    "text, line",
    [
        ("0,1\nabc,2\n", 2),
        ("0,1\n1\n", 2),  # missing value
        ("time,value\n0,1\n1,x\n", 3),
        ("0,1\n1,nan\n", 2),
        ("0,1\ninf,2\n", 2),
    ],
)
def test_read_table_rejects_bad_rows_naming_the_line(tmp_path, text, line):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(MechanismError) as info:
        pr.read_table(path)
    assert f"line {line}" in str(info.value)
    assert "bad.csv" in str(info.value)


def test_read_table_second_header_is_a_bad_row(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("time,value\ntime,value\n0,1\n")
    with pytest.raises(MechanismError) as info:
        pr.read_table(path)
    assert "line 2" in str(info.value)


def test_read_table_missing_file(tmp_path):
    path = tmp_path / "missing.csv"
    with pytest.raises(MechanismError) as info:
        pr.read_table(path)
    assert "missing.csv" in str(info.value)
    assert "cannot be read" in str(info.value)
    assert not isinstance(info.value, OSError)


def test_read_table_without_data_rows(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("time,value\n# nothing\n")
    with pytest.raises(MechanismError) as info:
        pr.read_table(path)
    assert "no data rows" in str(info.value)


def test_interpolate_is_piecewise_linear_and_holds_at_ends():
    table = ([0.0, 1.0, 3.0], [10.0, 20.0, 0.0])
    assert pr.interpolate(table, -5.0) == (10.0, 0.0, 0.0)
    assert pr.interpolate(table, 0.0) == (10.0, 0.0, 0.0)
    assert pr.interpolate(table, 0.25) == (12.5, 10.0, 0.0)
    assert pr.interpolate(table, 1.0) == (20.0, -10.0, 0.0)  # a breakpoint takes the next slope
    assert pr.interpolate(table, 2.0) == (10.0, -10.0, 0.0)
    assert pr.interpolate(table, 3.0) == (0.0, 0.0, 0.0)
    assert pr.interpolate(table, 100.0) == (0.0, 0.0, 0.0)
    # value is continuous at the interior breakpoint
    assert pr.interpolate(table, 1.0 - 1e-12).value == pytest.approx(20.0, abs=1e-10)


@pytest.mark.parametrize("profile", ["constant_speed", "cycloidal"])
def test_stroke_end_is_exact_even_when_start_plus_travel_rounds(profile):
    # 0.5 + (0.1 - 0.5) == 0.09999999999999998 in floating point
    assert 0.5 + (0.1 - 0.5) != 0.1
    end = pr.stroke(2.0, 0.5, 0.1, 2.0, profile)
    assert end.value == 0.1
    if profile == "cycloidal":
        assert end.rate == 0.0 and end.rate2 == 0.0


def test_read_table_header_after_comment(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("# loads for the bump test\ntime,load\n0,1\n1,3\n")
    assert pr.read_table(str(path)) == ([0.0, 1.0], [1.0, 3.0])
