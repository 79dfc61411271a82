"""A scene's [check] table: parsed with clear errors, written beside its reference, applied by
mechfmu.compare unless the caller gives tolerances."""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, strategies as st

import mechfmu
from conftest import REFERENCES, SCENES
from mechfmu.cosim.scene import SceneError, load_scene, parse_scene
from mechfmu.cosim.tolerances import Check, ColumnCheck, parse_check
from mechfmu.io import ResultFileError, read_result, write_result
from mechfmu.tools.tolerances import round_up, ruled_tolerance

WHY = "measured: 2e-15 of the peak"


def frame(values, **attrs):
    table = pd.DataFrame(
        {name: np.asarray(column, dtype=float) for name, column in values.items()},
        index=pd.Index(np.arange(len(next(iter(values.values()))), dtype=float), name="time"),
    )
    table.attrs.update(attrs)
    return table


@pytest.mark.parametrize(
    "table, words",
    [
        ({"rtol": 1e-9}, ["missing 'why'"]),
        ({"why": WHY, "rtl": 1e-9}, ["unknown key(s) rtl", "allowed: atol, columns"]),
        ({"why": WHY, "rtol": -1.0}, ["rtol = -1.0 must be a finite number >= 0"]),
        ({"why": WHY, "atol": math.inf}, ["atol = inf must be a finite number >= 0"]),
        ({"why": WHY, "atol": "small"}, ["atol = 'small' must be a number"]),
        ({"why": WHY, "method": "band"}, ["method = 'band' is not one of pointwise, tube"]),
        (
            {"why": WHY, "time_tolerance": 0.01},
            ['time_tolerance is the tube\'s: set method = "tube"'],
        ),
        ({"why": WHY, "columns": {"gear.x": 1e-9}}, ["'gear.x' must be an inline table"]),
        ({"why": WHY, "columns": {"gear.x": {"rtol": 1e-9, "tol": 1}}}, ["unknown key(s) tol"]),
        (
            {"why": WHY, "columns": {"gear.x": {"compare": "no"}}},
            ["compare = 'no' must be true or false"],
        ),
    ],
)
def test_a_malformed_check_table_is_named_with_the_scene_and_the_key(tmp_path, table, words):
    data = {
        "stop_time": 1.0,
        "step": 0.5,
        "components": {"load": {"fmu": "LoadProfile"}},
        "check": table,
    }
    with pytest.raises(SceneError) as caught:
        parse_scene(data, tmp_path / "inline.toml")
    assert str(caught.value).startswith(f"{tmp_path / 'inline.toml'}: [check]")
    for word in words:
        assert word in str(caught.value), str(caught.value)


@given(
    key=st.text(min_size=1, max_size=200).filter(
        lambda k: k not in ("why", "rtol", "atol", "method", "time_tolerance", "columns")
    )
)
def test_an_unknown_key_is_named_on_one_line_whatever_it_holds(key):
    # a key read from a result's JSON sidecar may hold line breaks or be very long (found
    # by make fuzz-inputs: "unknown key(s) t<newline>u" made a message of two lines)
    with pytest.raises(ValueError) as caught:
        parse_check({"why": WHY, key: 1.0}, "result.json")
    message = str(caught.value)
    assert "\n" not in message and len(message) < 300
    assert message.startswith("result.json: [check]: unknown key(s) ")
    named = message.split("unknown key(s) ", 1)[1].split("; allowed:", 1)[0]
    assert named == key or named == repr(key) or "characters)..." in named


tolerances = st.floats(min_value=0.0, max_value=1.0, allow_nan=False)
column_checks = st.builds(
    ColumnCheck,
    rtol=st.none() | tolerances,
    atol=st.none() | tolerances,
    compare=st.booleans(),
    why=st.text(max_size=20),
)


@given(
    rtol=tolerances,
    atol=tolerances,
    tube=st.booleans(),
    time_tolerance=st.none() | tolerances,
    columns=st.dictionaries(
        st.from_regex(r"[a-z]+\.[a-z_*]+", fullmatch=True), column_checks, max_size=4
    ),
)
def test_a_check_table_reads_back_from_its_json(rtol, atol, tube, time_tolerance, columns):
    check = Check(
        rtol,
        atol,
        "tube" if tube else "pointwise",
        time_tolerance if tube else None,
        WHY,
        columns,
    )
    assert parse_check(check.as_dict(), "here") == check
    assert set(check.tolerances()) | set(check.not_compared) == set(columns)


def test_the_reference_declares_and_the_caller_overrides():
    times = np.arange(5.0)
    reference = frame({"a.x": 1.0 + times, "a.y": 100.0 * times})
    result = frame({"a.x": 1.0 + times + 1e-6, "a.y": 100.0 * times + 1e-3, "a.n": times})
    declared = Check(
        rtol=1e-5,
        why=WHY,
        columns={
            "a.y": ColumnCheck(atol=2e-3),
            "a.n": ColumnCheck(compare=False, why="a solver statistic"),
        },
    )
    reference.attrs["check"] = declared.as_dict()
    comparison = mechfmu.compare(result, reference)
    assert comparison.passed, str(comparison)
    assert comparison.declared == declared and comparison.not_compared == ["a.n"]
    assert comparison.summary.loc["a.y", "atol"] == 2e-3
    assert comparison.tolerance_text() == "declared by the reference: rtol 1e-05, atol per column"
    # an rtol given replaces the table's and every column's; the columns' atol stays
    tight = mechfmu.compare(result, reference, rtol=1e-9)
    assert [tuple(row) for row in tight.failures[["column", "kind"]].to_numpy()] == [
        ("a.x", "value")
    ]
    assert tight.summary.loc["a.y", "atol"] == 2e-3 and tight.summary.loc["a.y", "rtol"] == 1e-9
    # everything given: the declaration does not apply (compare = false still does)
    given_all = mechfmu.compare(result, reference, rtol=1e-3, atol=1e-2, method="pointwise")
    assert given_all.passed and given_all.declared is None
    # without a declaration: the defaults, and the extra column fails with the way out named
    del reference.attrs["check"]
    plain = mechfmu.compare(result, reference)
    assert (plain.rtol, plain.atol) == (1e-9, 1e-12) and not plain.passed
    assert "extra column a.n (not in the reference; --ignore-extra" in str(plain)


def test_a_tube_that_contains_a_shifted_result_says_so_instead_of_identical():
    reference = frame({"a.x": np.arange(11.0) ** 2})  # times 0, 1, ..., 10 s
    late = reference.copy()
    late.iloc[1:, 0] = reference.iloc[:-1, 0].to_numpy()  # one step late
    comparison = mechfmu.compare(late, reference, method="tube", time_tolerance=1.0)
    assert comparison.passed
    assert str(comparison).endswith("; every sample within the tube")
    assert "identical" in str(mechfmu.compare(reference, reference))


def test_a_malformed_declaration_beside_a_reference_names_its_json(tmp_path):
    path = write_result(
        frame({"a.x": [1.0, 2.0]}, check={"rtol": -1, "why": WHY}), tmp_path / "r.csv"
    )
    with pytest.raises(ResultFileError, match=r"r\.json: \[check\]: rtol = -1 must be"):
        read_result(path)


@pytest.mark.parametrize("name", sorted(p.stem for p in REFERENCES.glob("*.csv")))
def test_each_shipped_table_follows_the_rule_written_in_its_why(name):
    """rtol = R and each column's atol = R x its peak rounded up (tools/tolerances.py), the
    numbers of 'why' being the measurement that gave R: the table cannot drift from the
    reference it describes."""
    scene = load_scene(SCENES / f"{name}.toml")
    reference = read_result(REFERENCES / f"{name}.csv")
    assert f"rtol = {scene.check.rtol:g}" in scene.check.why
    for column in reference.columns:
        peak = float(np.max(np.abs(reference[column])))
        entry = scene.check.columns.get(column)
        if peak > 0:
            expected = round_up(scene.check.rtol * peak)
            found = entry.atol if entry is not None else None
            assert found == pytest.approx(expected), (
                f"{name}: [check.columns] {column!r} = {{ atol = {expected:g} }} by the rule, "
                f"found {found}; 'make tolerances' measures the scene and prints its table"
            )


def test_the_rule_rounds_ten_times_the_worst_total_up_to_a_power_of_ten():
    rows = [
        {"peak": 2.0, "run": 3e-9, "reference": 1e-10, "dispatch": 0.0},
        {"peak": 0.0, "run": 0.0, "reference": 0.0, "dispatch": 0.0},
    ]
    assert ruled_tolerance(rows) == pytest.approx(1e-7)  # 10 x 1.55e-9 -> 1e-7
    assert round_up(2.3e-8) == pytest.approx(3e-8) and round_up(7e-13) == pytest.approx(7e-13)
