"""mechfmu.compare: pointwise and tube comparisons, every failure kind, and the tube on our
discontinuous scenes (valve float, suspension snap-through, gear stroke end): a result late by
a fraction of a step or a whole step fails pointwise and passes the tube; a changed amplitude
fails both, at the column and time computed here from the data."""

import math

import numpy as np
import pandas as pd
import pytest
from conftest import REFERENCES, SCENES

import mechfmu
from mechfmu.comparison import tube_bounds
from mechfmu.cosim.run import run_scene
from mechfmu.cosim.scene import parse_scene, read_toml
from mechfmu.io import read_result


def frame(times, **columns):
    return pd.DataFrame(columns, index=pd.Index(np.asarray(times, dtype=float), name="time"))


def shifted(reference, delay):
    """``reference`` late by ``delay`` s, on its own time grid: the piecewise linear
    reference evaluated at t - delay (held at its first value before the start)."""
    times = reference.index.to_numpy()
    return frame(
        times,
        **{
            name: np.interp(times - delay, times, reference[name].to_numpy())
            for name in reference.columns
        },
    )


def brute_tube(times, values, ref_times, ref_values, dt, rtol, atol):
    """Per sample: inside the tube? One sample at a time, straight from the definition."""
    inside = []
    for t, y in zip(times, values):
        a, b = max(t - dt, ref_times[0]), min(t + dt, ref_times[-1])
        window = [np.interp(a, ref_times, ref_values), np.interp(b, ref_times, ref_values)]
        window += [v for s, v in zip(ref_times, ref_values) if a <= s <= b]
        low, high = min(window), max(window)
        inside.append(low - (atol + rtol * abs(low)) <= y <= high + (atol + rtol * abs(high)))
    return np.array(inside)


# (scene, columns, column whose jump is the event, per-column atol as a fraction of the
# column's range): the step changes of the smooth parts are inside the atol, the events not.
EVENTS = {
    # (its float count is left out: at the scene's 1 ms samples the first float, at 1.84 ms,
    # is counted at 2 ms, where the valve touches the rocker again for a moment)
    "valve float (contact lost)": (
        "valve_float_dynamic",
        ["valve.contact_lost"],
        "valve.contact_lost",
        0.02,
    ),
    "suspension snap-through": (
        "suspension_load_ramp",
        ["suspension.deflection", "suspension.branch", "suspension.snap_through"],
        "suspension.branch",
        0.02,
    ),
    "gear stroke end": (
        "gear_extension_gravity",
        ["gear.gear_angle", "gear.extension_time"],
        "gear.extension_time",
        0.05,
    ),
}


def event_case(name):
    scene, columns, event, fraction = EVENTS[name]
    reference = read_result(REFERENCES / f"{scene}.csv")[columns]
    tolerances = {c: (0.0, fraction * float(np.ptp(reference[c].to_numpy()))) for c in columns}
    times = reference.index.to_numpy()
    jumps = np.flatnonzero(np.diff(reference[event].to_numpy()) != 0.0)
    assert jumps.size, f"{scene}: {event} never changes"
    return reference, tolerances, times[1] - times[0], times[jumps[0] + 1], event


@pytest.mark.parametrize("name", list(EVENTS))
@pytest.mark.parametrize("steps", [0.4, 1.0])
def test_a_late_event_fails_pointwise_and_passes_the_tube(name, steps):
    reference, tolerances, step, event_time, event = event_case(name)
    late = shifted(reference, steps * step)
    pointwise = mechfmu.compare(late, reference, tolerances=tolerances)
    assert not pointwise.passed
    # every failing column fails first at the event, the smooth parts are within the atol
    assert (pointwise.failures["kind"] == "value").all()
    assert pointwise.failures["time"].tolist() == pytest.approx(
        [event_time] * len(pointwise.failures), abs=1e-9
    )
    row = pointwise.failures.set_index("column").loc[event]
    assert row["value"] != row["reference"]
    tube = mechfmu.compare(
        late, reference, tolerances=tolerances, method="tube", time_tolerance=steps * step * 1.0001
    )
    assert tube.passed, tube.failures
    assert tube.failures.empty
    # and a tube narrower than the delay does not hide it
    narrow = mechfmu.compare(
        late, reference, tolerances=tolerances, method="tube", time_tolerance=0.5 * steps * step
    )
    assert not narrow.passed
    assert narrow.failures.set_index("column").loc[event, "time"] == pytest.approx(
        event_time, abs=1e-9
    )


@pytest.mark.parametrize("name", list(EVENTS))
def test_a_changed_amplitude_fails_both_at_the_first_sample_outside(name):
    reference, tolerances, step, _, _ = event_case(name)
    column = next(iter(tolerances))
    wrong = reference.copy()
    wrong[column] = reference[column] * 1.3  # the genuine error: 30 % too large
    rtol, atol = tolerances[column]
    times = reference.index.to_numpy()
    values, ref_values = wrong[column].to_numpy(), reference[column].to_numpy()
    expected_pointwise = times[np.argmax(np.abs(values - ref_values) > atol)]
    pointwise = mechfmu.compare(wrong, reference, tolerances=tolerances)
    assert not pointwise.passed
    row = pointwise.failures.set_index("column").loc[column]
    assert row["time"] == pytest.approx(expected_pointwise, abs=1e-12)
    assert row["value"] == pytest.approx(1.3 * row["reference"], rel=1e-12)
    assert row["allowed"] == pytest.approx(atol, rel=1e-12)
    tube = mechfmu.compare(
        wrong, reference, tolerances=tolerances, method="tube", time_tolerance=step
    )
    assert not tube.passed
    inside = brute_tube(times, values, times, ref_values, step, rtol, atol)
    assert not inside.all()
    row = tube.failures.set_index("column").loc[column]
    assert row["time"] == pytest.approx(times[np.argmin(inside)], abs=1e-12)
    assert tube.summary.loc[column, "failing"] == int((~inside).sum())


def test_a_snap_through_run_late_passes_the_tube_only(fmu_dir, tmp_path):
    """The FMUs, run: the suspension's load ramp starting 12 ms late (1.2 steps) snaps
    through one step later (at 3.11 s instead of 3.1 s); only the tube accepts it."""
    data = read_toml(SCENES / "suspension_load_ramp.toml")
    data["components"]["load"]["parameters"]["start_time"] = 0.012
    late_scene = parse_scene(data, SCENES / "suspension_load_ramp.toml")
    _, paths = run_scene(late_scene, tmp_path, fmu_dir, plot=False)
    late = read_result(paths["csv"])
    reference = read_result(REFERENCES / "suspension_load_ramp.csv")
    columns = ["suspension.branch", "suspension.snap_through", "suspension.stable"]
    pointwise = mechfmu.compare(late[columns], reference[columns], atol=1e-9)
    assert list(pointwise.failures["column"]) == ["suspension.branch", "suspension.snap_through"]
    assert pointwise.failures["time"].tolist() == pytest.approx([3.1, 3.1], abs=1e-9)
    tube = mechfmu.compare(
        late[columns], reference[columns], atol=1e-9, method="tube", time_tolerance=0.0125
    )
    assert tube.passed, tube.failures
    # the deflection jumps from 0.27 m to 1.09 m a step late: pointwise that fails even at
    # rtol 1e-2 and atol 1e-3 m, the tube passes (its band covers the curvature of the fold, which the
    # reference's straight lines between samples miss by 8e-4 m next to the limit load)
    smooth = ["suspension.deflection"]
    pointwise = mechfmu.compare(late[smooth], reference[smooth], rtol=1e-2, atol=1e-3)
    assert list(pointwise.failures["column"]) == ["suspension.deflection"]
    assert 3.0 <= pointwise.failures["time"].iloc[0] <= 3.1 + 1e-9  # the fold, then the snap
    assert mechfmu.compare(
        late[smooth], reference[smooth], rtol=1e-2, atol=1e-3, method="tube", time_tolerance=0.0125
    ).passed


def test_tube_bounds_match_the_definition_on_random_curves():
    rng = np.random.default_rng(18)
    for _ in range(20):
        ref_times = np.cumsum(rng.uniform(0.01, 0.2, 60))
        ref_values = np.cumsum(rng.normal(size=60)) * rng.choice([1.0, 1e3])
        ref_values[rng.integers(60)] += 50.0  # a spike
        times = np.sort(
            np.concatenate((ref_times[[0, -1]], rng.uniform(ref_times[0], ref_times[-1], 78)))
        )
        dt = rng.uniform(0.0, 0.5)
        low, high, nan = tube_bounds(times, ref_times, ref_values, dt)
        assert not nan.any()
        for t, lo, hi in zip(times, low, high):
            a, b = max(t - dt, ref_times[0]), min(t + dt, ref_times[-1])
            window = [np.interp(a, ref_times, ref_values), np.interp(b, ref_times, ref_values)]
            window += list(ref_values[(ref_times >= a) & (ref_times <= b)])
            assert lo == pytest.approx(min(window), rel=1e-12, abs=1e-12)
            assert hi == pytest.approx(max(window), rel=1e-12, abs=1e-12)
        values = np.interp(times, ref_times, ref_values) + rng.normal(scale=0.3, size=80)
        comparison = mechfmu.compare(
            frame(times, y=values),
            frame(ref_times, y=ref_values),
            method="tube",
            time_tolerance=dt,
            rtol=1e-3,
            atol=0.1,
        )
        inside = brute_tube(times, values, ref_times, ref_values, dt, 1e-3, 0.1)
        assert comparison.summary.loc["y", "failing"] == int((~inside).sum())
        assert comparison.passed == bool(inside.all())


def test_identical_results_pass_with_a_summary_of_zeros():
    reference = read_result(REFERENCES / "gear_retraction.csv")
    comparison = mechfmu.compare(reference, reference.copy())
    assert comparison.passed and comparison.ok
    assert comparison.failures.empty
    assert list(comparison.failures.columns) == [
        "column",
        "time",
        "value",
        "reference",
        "allowed",
        "kind",
    ]
    assert list(comparison.summary.index) == list(reference.columns)
    assert (comparison.summary["max_abs"] == 0.0).all()
    assert (comparison.summary["samples"] == 301).all()
    assert str(comparison).startswith("match: 6 column(s), 301 sample(s)")


def test_paths_are_read_as_results():
    path = REFERENCES / "gear_retraction.csv"
    assert mechfmu.compare(path, str(path)).passed


def test_missing_and_extra_columns_are_failures_naming_the_column():
    reference = frame([0.0, 1.0, 2.0], a=[1.0, 2.0, 3.0], b=[0.0, 0.0, 0.0])
    result = frame([0.0, 1.0, 2.0], a=[1.0, 2.0, 3.0], c=[5.0, 5.0, 5.0])
    comparison = mechfmu.compare(result, reference)
    assert not comparison.passed
    kinds = dict(zip(comparison.failures["column"], comparison.failures["kind"]))
    assert kinds == {"b": "missing column", "c": "extra column"}
    assert comparison.failures["time"].isna().all()
    assert list(comparison.summary.index) == ["a"]
    ignoring = mechfmu.compare(result, reference, ignore_extra=True)
    assert list(ignoring.failures["kind"]) == ["missing column"]
    assert "missing column b" in str(ignoring)


def test_a_different_time_grid_is_a_failure_at_the_first_differing_time():
    reference = frame([0.0, 0.1, 0.2, 0.3], a=[0.0, 1.0, 2.0, 3.0])
    cases = {  # result times: (time, value, reference) of the failure
        (0.0, 0.1, 0.25, 0.3): (0.2, 0.25, 0.2),
        (0.0, 0.1, 0.2): (0.3, math.nan, 0.3),  # ends early (cut short)
        (0.0, 0.1, 0.2, 0.3, 0.4): (0.4, 0.4, math.nan),  # goes on
    }
    for times, (time, value, expected) in cases.items():
        result = frame(times, a=np.arange(len(times), dtype=float))
        comparison = mechfmu.compare(result, reference)
        row = comparison.failures.iloc[0]
        assert len(comparison.failures) == 1 and row["kind"] == "time grid"
        assert row["column"] == "time"
        assert row["time"] == pytest.approx(time)
        assert row["value"] == pytest.approx(value, nan_ok=True)
        assert row["reference"] == pytest.approx(expected, nan_ok=True)
    # the last bits of a time do not matter
    nudged = frame(np.array([0.0, 0.1, 0.2, 0.3]) * (1 + 1e-15), a=[0.0, 1.0, 2.0, 3.0])
    assert mechfmu.compare(nudged, reference).passed


def test_interpolation_accepts_another_grid_over_the_same_span():
    reference = frame([0.0, 1.0, 2.0], a=[0.0, 10.0, 20.0])
    finer = frame([0.0, 0.5, 1.0, 1.5, 2.0], a=[0.0, 5.0, 10.0, 15.0, 20.0])
    assert not mechfmu.compare(finer, reference).passed
    assert mechfmu.compare(finer, reference, interpolate=True).passed
    short = frame([0.0, 0.5, 1.0], a=[0.0, 5.0, 10.0])
    row = mechfmu.compare(short, reference, interpolate=True).failures.iloc[0]
    assert row["kind"] == "time grid" and row["time"] == pytest.approx(2.0)
    wrong = frame([0.0, 0.5, 1.0, 1.5, 2.0], a=[0.0, 5.0, 10.5, 15.0, 20.0])
    row = mechfmu.compare(wrong, reference, interpolate=True, rtol=1e-3).failures.iloc[0]
    assert (row["column"], row["time"], row["kind"]) == ("a", 1.0, "value")
    assert row["allowed"] == pytest.approx(1e-12 + 1e-3 * 10.0)


def test_the_tube_needs_the_span_within_its_time_tolerance():
    reference = frame([0.0, 1.0, 2.0], a=[0.0, 1.0, 2.0])
    early_end = frame([0.0, 1.0, 1.5], a=[0.0, 1.0, 1.5])
    row = mechfmu.compare(early_end, reference, method="tube", time_tolerance=0.1).failures.iloc[0]
    assert row["kind"] == "time grid" and row["time"] == pytest.approx(2.0)
    assert mechfmu.compare(early_end, reference, method="tube", time_tolerance=0.6).passed


def test_failures_are_ordered_by_time_one_row_per_column():
    reference = frame(
        [0.0, 1.0, 2.0, 3.0], a=[1.0, 1.0, 1.0, 1.0], b=[1.0, 1.0, 1.0, 1.0], c=[1.0, 1.0, 1.0, 1.0]
    )
    result = frame(
        [0.0, 1.0, 2.0, 3.0], a=[1.0, 1.0, 1.0, 9.0], b=[1.0, 2.0, 3.0, 4.0], c=[1.0, 1.0, 7.0, 7.0]
    )
    failures = mechfmu.compare(result, reference).failures
    assert list(failures["column"]) == ["b", "c", "a"]
    assert list(failures["time"]) == [1.0, 2.0, 3.0]
    assert list(failures["value"]) == [2.0, 7.0, 9.0]


def test_per_column_tolerances_and_patterns_last_match_wins():
    reference = frame(
        [0.0, 1.0], **{"gear.a": [1.0, 1.0], "gear.b": [1.0, 1.0], "load.c": [1.0, 1.0]}
    )
    result = frame(
        [0.0, 1.0], **{"gear.a": [1.0, 1.001], "gear.b": [1.0, 1.001], "load.c": [1.0, 1.001]}
    )
    comparison = mechfmu.compare(
        result, reference, tolerances={"gear.*": 1e-2, "gear.b": (1e-6, None)}
    )
    assert list(comparison.failures["column"]) == ["gear.b", "load.c"]
    assert comparison.summary.loc["gear.a", "rtol"] == pytest.approx(1e-2)
    assert comparison.summary.loc["gear.b", "rtol"] == pytest.approx(1e-6)
    assert comparison.summary.loc["gear.b", "atol"] == pytest.approx(1e-12)
    comparison = mechfmu.compare(result, reference, tolerances={"load.c": {"atol": 0.01}})
    assert list(comparison.failures["column"]) == ["gear.a", "gear.b"]


def test_nan_passes_only_against_nan():
    reference = frame([0.0, 1.0, 2.0], a=[1.0, math.nan, 3.0])
    assert mechfmu.compare(frame([0.0, 1.0, 2.0], a=[1.0, math.nan, 3.0]), reference).passed
    row = mechfmu.compare(frame([0.0, 1.0, 2.0], a=[1.0, 2.0, 3.0]), reference).failures.iloc[0]
    assert (row["column"], row["time"]) == ("a", 1.0)
    row = mechfmu.compare(
        frame([0.0, 1.0, 2.0], a=[math.nan, math.nan, 3.0]), reference
    ).failures.iloc[0]
    assert (row["column"], row["time"]) == ("a", 0.0)


def test_bad_arguments_are_one_line_errors():
    reference = frame([0.0, 1.0], a=[1.0, 1.0])
    with pytest.raises(ValueError, match="method must be 'pointwise' or 'tube'"):
        mechfmu.compare(reference, reference, method="nearest")
    with pytest.raises(ValueError, match="rtol must be a finite number >= 0"):
        mechfmu.compare(reference, reference, rtol=-1.0)
    with pytest.raises(ValueError, match="times must be finite and increase"):
        mechfmu.compare(frame([1.0, 0.0], a=[1.0, 1.0]), reference)
    with pytest.raises(TypeError, match="DataFrame or a CSV path"):
        mechfmu.compare([1, 2], reference)


def test_plot_shows_reference_result_band_and_the_first_failure():
    reference, tolerances, step, _, _ = event_case("suspension snap-through")
    late = shifted(reference, step)
    for method in ("pointwise", "tube"):
        comparison = mechfmu.compare(
            late, reference, tolerances=tolerances, method=method, time_tolerance=0.5 * step
        )
        figure = comparison.plot()
        failing = list(comparison.failures["column"])
        axes = [axis for axis in figure.axes if axis.get_title(loc="left")]
        assert [axis.get_title(loc="left") for axis in axes] == failing
        labels = [line.get_label() for line in axes[0].lines]
        assert labels[:2] == ["reference", "result"]
        marker = axes[0].lines[2]
        assert marker.get_label().startswith("first failure")
        assert marker.get_xdata()[0] == pytest.approx(comparison.failures.iloc[0]["time"])
        assert len(axes[0].collections) == 1  # the band or tube
        zooms = [axis for axis in figure.axes if axis.get_title(loc="right")]
        first = comparison.failures.iloc[0]["time"]
        assert len(zooms) == len(failing)
        assert zooms[0].get_title(loc="right") == f"around t = {first:.6g} s"
        shown = zooms[0].lines[1].get_xdata()  # the result's samples near the failure
        assert len(shown) == 51 and shown[25] == pytest.approx(first)
    passing = mechfmu.compare(reference, reference).plot()
    assert len([axis for axis in passing.axes if axis.get_title(loc="left")]) == 3


@pytest.mark.parametrize("empty", ["result", "reference", "both"])
def test_a_table_without_rows_is_refused_not_a_vacuous_match(empty):
    # compare(DataFrame(), DataFrame()) said "match: 0 column(s), 0 sample(s)": a regression
    # check that compares nothing passed (a result file with only its header is malformed)
    table = pd.DataFrame({"x": [1.0, 2.0]}, index=pd.Index([0.0, 1.0], name="time"))
    none = table.iloc[:0]
    result, reference = {
        "result": (none, table),
        "reference": (table, none),
        "both": (pd.DataFrame(), pd.DataFrame()),
    }[empty]
    with pytest.raises(ValueError, match="has no rows: nothing to compare"):
        mechfmu.compare(result, reference)
