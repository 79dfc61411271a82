"""Result files compared and read block by block (issue 33): the same outcome as the whole
arrays give, on random results with block boundaries anywhere; a malformed line named by its
number wherever it falls; memory that does not grow with the file (peak resident size of a
child process, measured)."""

import json
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from mechfmu.check import check_paths
from mechfmu.comparison import compare
from mechfmu.io import ResultFileError, iter_result, read_result, write_result


def frame(times, columns):
    return pd.DataFrame(columns, index=pd.Index(np.asarray(times, dtype=float), name="time"))


@st.composite
def pairs(draw):
    """A reference and a result near it: the same grid, or a grid shifted, cut or longer;
    values within, at and beyond the tolerance; columns missing or extra now and then."""
    rows = draw(st.integers(1, 40))
    steps = draw(st.lists(st.floats(1e-3, 1.0), min_size=rows, max_size=rows))
    times = np.cumsum(steps) - steps[0] + draw(st.floats(-5.0, 5.0))
    names = ["a.x", "b.y", "c.z"][: draw(st.integers(1, 3))]
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    reference = {name: rng.normal(size=rows) * 10.0 ** rng.integers(-3, 3) for name in names}
    result = {}
    for name, values in reference.items():
        noise = rng.choice([0.0, 1e-13, 1e-9, 1e-6, 1e-3], size=rows) * rng.normal(size=rows)
        result[name] = values + noise
    result_times = times.copy()
    grid = draw(st.sampled_from(["same", "same", "shifted", "cut", "longer", "jitter"]))
    if grid == "shifted" and rows > 1:
        result_times = times + draw(st.floats(-0.5, 0.5)) * float(np.min(np.diff(times)))
    elif grid == "cut" and rows > 2:
        keep = draw(st.integers(1, rows - 1))
        result_times = times[:keep]
        result = {name: values[:keep] for name, values in result.items()}
    elif grid == "longer":
        result_times = np.append(times, times[-1] + 0.5)
        result = {name: np.append(values, 0.0) for name, values in result.items()}
    elif grid == "jitter" and rows > 1:
        at = draw(st.integers(0, rows - 1))
        result_times = times.copy()
        result_times[at] += draw(st.sampled_from([1e-15, 1e-12, 1e-6])) * float(
            np.min(np.diff(times))
        )
        if not (np.diff(result_times) > 0).all():
            result_times = times
    if draw(st.booleans()) and len(names) > 1:
        result.pop(names[-1])
    if draw(st.booleans()):
        result["extra.w"] = np.zeros(len(result_times))
    return frame(times, reference), frame(result_times, result)


OPTIONS = st.sampled_from(
    [
        {},
        {"rtol": 1e-6, "atol": 1e-9},
        {"interpolate": True, "ignore_extra": True},
        {"method": "tube"},
        {"method": "tube", "time_tolerance": 0.3, "rtol": 1e-3},
        {"tolerances": {"a.*": (1e-4, 1e-6)}},
    ]
)


def same(left, right):
    """Two Comparisons agree: verdict, every failure and summary figure (NaN as NaN), and
    the line mechfmu check prints."""
    assert left.passed == right.passed
    pd.testing.assert_frame_equal(left.failures, right.failures, check_exact=True)
    pd.testing.assert_frame_equal(left.summary, right.summary, check_exact=True)
    assert str(left) == str(right)
    assert left.samples == right.samples
    assert left.tolerance_text() == right.tolerance_text()


@settings(
    max_examples=50,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(pair=pairs(), options=OPTIONS, block=st.integers(1, 400))
def test_files_compared_block_by_block_give_what_the_whole_arrays_give(
    tmp_path, pair, options, block
):
    reference, result = pair
    result_path = write_result(result, tmp_path / "result.csv")
    reference_path = write_result(reference, tmp_path / "reference.csv")
    whole = compare(result, reference, **options)
    streamed = compare(result_path, reference_path, block_bytes=block, **options)
    same(streamed, whole)
    # a Parquet result, read by record batches of about block / 160 rows, likewise
    parquet_path = write_result(result, tmp_path / "columnar.parquet")  # its own JSON
    same(compare(parquet_path, reference_path, block_bytes=block * 160, **options), whole)
    # and the frames read back, whole and by blocks, are the frames written
    pd.testing.assert_frame_equal(read_result(result_path, block_bytes=block), result)
    joined = pd.concat(list(iter_result(reference_path, block_bytes=block)))
    pd.testing.assert_frame_equal(joined, reference, check_freq=False)


def test_a_drifting_grid_is_found_where_the_whole_grid_finds_it(tmp_path):
    """The same-grid check keeps only the records of |t - t_ref|: a grid drifting away a
    little more every row fails at the row where the drift passes the margin (here 1e-9 of
    the 1 ms step, near row 1000), read in blocks of about 100 rows."""
    times = np.arange(3000) * 1e-3
    drift = times + np.arange(3000) * 1e-15
    reference = frame(times, {"a.x": np.sin(times)})
    result = frame(drift, {"a.x": np.sin(times)})
    write_result(reference, tmp_path / "r.csv")
    write_result(result, tmp_path / "x.csv")
    streamed = compare(tmp_path / "x.csv", tmp_path / "r.csv", block_bytes=4000)
    whole = compare(result, reference)
    same(streamed, whole)
    row = streamed.failures.iloc[0]
    assert row["kind"] == "time grid"
    assert row["reference"] == pytest.approx(1.0, abs=2e-3)  # 1e-12 of drift there


def _write(path, lines):
    path.write_text("".join(line + "\n" for line in lines))
    return path


@pytest.mark.parametrize("block", [7, 64, 1 << 20])
@pytest.mark.parametrize(
    ("bad", "message"),
    [
        ("5.0,x", "line 7, column 'a.x': 'x' is not a number"),
        ("5.0", "line 7, column 'a.x': empty field (the line has fewer values than the header"),
        ("5.0,1,2", "line 7 has 3 values, the header 2 columns"),
        ("3.5,1", "line 7: time 3.5 s is before the previous line's 4.0 s"),
        ("5.0,inf", "line 7, column 'a.x': 'inf' is not a finite number"),
        ("", "line 7 is blank"),
    ],
)
def test_a_malformed_line_is_named_by_its_number_whatever_the_blocks(tmp_path, bad, message, block):
    lines = ["time,a.x", *(f"{t}.0,{t}" for t in range(5)), bad, "6.0,1", "7.0,2"]
    path = _write(tmp_path / "bad.csv", lines)
    with pytest.raises(ResultFileError) as caught:
        read_result(path, block_bytes=block)
    assert str(caught.value) == f"{path}: {message}" or message in str(caught.value)
    good = _write(tmp_path / "good.csv", ["time,a.x", *(f"{t}.0,{t}" for t in range(8))])
    run = check_paths(good, path, block_bytes=block)
    assert run.exit_code == 1
    assert run.files[0].kind == "malformed file"
    assert message in run.files[0].problem


@pytest.mark.parametrize("block", [5, 1 << 20])
def test_trailing_blank_lines_are_allowed_and_a_cut_last_line_is_named(tmp_path, block):
    path = _write(tmp_path / "r.csv", ["time,a.x", "0.0,1", "1.0,2", "", ""])
    assert read_result(path, block_bytes=block)["a.x"].tolist() == [1.0, 2.0]
    cut = tmp_path / "cut.csv"
    cut.write_text("time,a.x,b.y\n0.0,1,2\n1.0,3,4\n2.0,5")
    with pytest.raises(ResultFileError, match=r"line 4, column 'b.y': empty field"):
        read_result(cut, block_bytes=block)


def test_a_pair_whose_csv_changed_is_refused_after_the_last_block(tmp_path):
    path = write_result(frame([0.0, 1.0, 2.0], {"a.x": [1.0, 2.0, 3.0]}), tmp_path / "r.csv")
    meta = json.loads(path.with_suffix(".json").read_text())
    path.write_text(path.read_text().replace("3.0", "4.0"))
    with pytest.raises(ResultFileError, match="are not one pair"):
        read_result(path, block_bytes=8)
    assert meta["csv_bytes"] == path.stat().st_size  # same size: the digest tells


MEASURE = textwrap.dedent(
    """
    import sys
    from mechfmu.check import check_paths
    from mechfmu.tools.bench.big_files import peak_mb
    run = check_paths(sys.argv[1], sys.argv[2], block_bytes=int(sys.argv[3]))
    print(run.exit_code, int(peak_mb() * 1024))
    """
)


def _peak_kib(result, reference, block):
    out = subprocess.run(
        [sys.executable, "-c", MEASURE, str(result), str(reference), str(block)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    ).stdout.split()
    return int(out[0]), int(out[1])


def _big_result(path, megabytes):
    """A result CSV of about ``megabytes`` MB: 6 columns of full-precision numbers."""
    rng = np.random.default_rng(7)
    rest = [",".join(repr(float(x)) for x in rng.standard_normal(6)) for _ in range(997)]
    with open(path, "w") as handle:
        handle.write("time," + ",".join(f"part.s{k}" for k in range(6)) + "\n")
        rows = 0
        while handle.tell() < megabytes * 1e6:
            handle.write("".join(f"{j}e-3,{rest[j % 997]}\n" for j in range(rows, rows + 50_000)))
            rows += 50_000
    return path


def test_check_memory_does_not_grow_with_the_file(tmp_path):
    """A 60 MB pair (2 x 60 MB, 0.5 M rows of 7 numbers each: 28 MB as floats per file)
    checked in 1 MiB blocks takes less than 30 MB above a 0.1 MB pair checked the same way:
    the whole files in memory would take more than their 56 MB of floats."""
    big = _big_result(tmp_path / "big.csv", 60)
    twin = tmp_path / "twin.csv"
    os.link(big, twin)
    small = tmp_path / "small.csv"
    with open(big) as handle:
        small.write_text("".join(next(handle) for _ in range(1000)))
    small_twin = tmp_path / "small_twin.csv"
    os.link(small, small_twin)
    code, small_peak = _peak_kib(small, small_twin, 1 << 20)
    assert code == 0
    code, big_peak = _peak_kib(big, twin, 1 << 20)
    assert code == 0
    assert (big_peak - small_peak) / 1024 < 30, (small_peak, big_peak)


# --- exact numbers, passing blocks, files over the whole-read limit --------------------------


def _spellings(value, digits, style):
    """``value`` written the ways a CSV may hold it: Python's repr, %e / %g / %f with
    ``digits`` digits (up to 25: more than a double holds, so the text is not a double's
    shortest form and must be rounded correctly)."""
    return {
        "repr": repr(value),
        "e": f"{value:.{digits}e}",
        "g": f"{value:.{digits}g}",
        "f": f"{value:.{digits}f}",
    }[style]


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    values=st.lists(
        st.tuples(
            st.floats(allow_nan=False, allow_infinity=False, width=64),
            st.integers(1, 25),
            st.sampled_from(["repr", "e", "g", "f"]),
        ),
        min_size=1,
        max_size=60,
    ),
    block=st.integers(1, 300),
)
def test_numbers_read_back_as_python_float_reads_their_text(tmp_path, values, block):
    """Every number of a result CSV is the double Python's float() makes of its text, to the
    bit, whatever the spelling and the blocks (pandas' converter, not a faster inexact
    one): a check's verdict never hinges on the parser's rounding."""
    texts = [_spellings(value, digits, style) for value, digits, style in values]
    texts = [text for text in texts if math.isfinite(float(text))]  # 1.8e+308 is not
    assume(texts)
    path = tmp_path / "r.csv"
    path.write_text("time,a.x\n" + "".join(f"{i},{text}\n" for i, text in enumerate(texts)))
    expected = np.array([float(text) for text in texts])
    read = read_result(path, block_bytes=block)["a.x"].to_numpy()
    assert read.view(np.int64).tolist() == expected.view(np.int64).tolist()
    streamed = pd.concat(list(iter_result(path, block_bytes=block)))["a.x"].to_numpy()
    assert streamed.view(np.int64).tolist() == expected.view(np.int64).tolist()


@settings(
    max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    seed=st.integers(0, 2**31 - 1),
    rows=st.integers(1, 300),
    block=st.integers(40, 4000),
    fail_at=st.one_of(st.none(), st.integers(0, 299)),
)
def test_blocks_that_pass_whole_give_the_figures_the_per_column_route_gives(
    tmp_path, seed, rows, block, fail_at
):
    """A long check's blocks mostly pass at every sample; they are taken in at once (one
    pass over the block): the summary (worst ratio, largest deviation and the first times
    they are reached, counts) is the one the whole arrays give, with a failing sample
    somewhere or none, per-column tolerances and zero deviations mixed in."""
    rng = np.random.default_rng(seed)
    times = np.arange(rows) * 1e-2
    reference = {name: rng.normal(size=rows) * 10.0 ** rng.integers(-3, 3) for name in "xyz"}
    result = {}
    for name, values in reference.items():
        noise = rng.choice([0.0, 0.0, 1e-12, 3e-10], size=rows) * np.abs(values)
        result[name] = values + noise * rng.choice([-1.0, 1.0], size=rows)
    if fail_at is not None and fail_at < rows:
        result["y"][fail_at] += 1e-3 + abs(result["y"][fail_at])
    reference_frame, result_frame = frame(times, reference), frame(times, result)
    write_result(reference_frame, tmp_path / "r.csv")
    write_result(result_frame, tmp_path / "x.csv")
    options = {"rtol": 1e-9, "atol": 0.0, "tolerances": {"z": (5e-10, 1e-300)}}
    whole = compare(result_frame, reference_frame, **options)
    same(compare(tmp_path / "x.csv", tmp_path / "r.csv", block_bytes=block, **options), whole)
    assert whole.passed == (fail_at is None or fail_at >= rows)


def test_a_file_over_the_whole_read_limit_is_checked_by_blocks(tmp_path, monkeypatch):
    """A file over limits.MAX_CSV_BYTES (lowered here to 10 kB) is refused by read_result,
    which keeps its numbers, but checked and iterated by blocks (memory flat in its size:
    a run may write more with --max-output); the plot of a failing column, which reads the
    files whole, is then a line of the report saying why, not a traceback."""
    from mechfmu.cosim import limits
    from mechfmu.tools.report.checks import write_report

    times = np.arange(2000) * 1e-3
    reference = write_result(frame(times, {"a.x": np.sin(times)}), tmp_path / "r.csv")
    result = write_result(frame(times, {"a.x": np.sin(times) + 1e-3}), tmp_path / "x.csv")
    assert reference.stat().st_size > 20_000
    monkeypatch.setattr(limits, "MAX_CSV_BYTES", 10_000)
    with pytest.raises(ResultFileError, match=r"r.csv: is \d+ bytes, more than the limit of"):
        read_result(reference)
    assert sum(len(part) for part in iter_result(reference, block_bytes=4096)) == 2000
    run = check_paths(result, reference, block_bytes=4096)
    assert run.exit_code == 1
    assert run.files[0].comparison.failures.iloc[0]["time"] == 0.0
    assert run.files[0].comparison.samples == 2000
    index = write_report(run, tmp_path / "report")
    assert "plot of a.x not written: " in index.read_text()
    assert check_paths(reference, reference, block_bytes=4096).exit_code == 0


FAULTS = textwrap.dedent(
    """
    import resource, sys
    from mechfmu.check import check_paths
    def faults():
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        assert check_paths(sys.argv[1], sys.argv[2]).exit_code == 0
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
    faults()  # the first blocks' memory is faulted in once
    print(faults())
    """
)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")
def test_a_checks_blocks_reuse_the_memory_of_the_blocks_before(tmp_path):
    """Checking a 10 MB pair a second time faults in fewer than 2500 pages (10 MB of fresh
    memory): each block's arrays take the memory the previous block's freed (with glibc's
    default thresholds, about 10 000 faults: every block's arrays mapped afresh)."""
    big = _big_result(tmp_path / "big.csv", 10)
    twin = tmp_path / "twin.csv"
    os.link(big, twin)
    out = subprocess.run(
        [sys.executable, "-c", FAULTS, str(big), str(twin)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    ).stdout
    assert int(out.split()[-1]) < 2500


# --- Parquet results -------------------------------------------------------------------------


def test_a_parquet_result_reads_as_its_csv_and_checks_against_a_csv_reference(tmp_path):
    pytest.importorskip("pyarrow")
    times = np.linspace(0.0, 2.0, 201)
    result = frame(times, {"a.x": np.sin(times), "b.y": np.cos(times)})
    result.attrs["units"] = {"a.x": "m", "b.y": "rad"}
    csv_path = write_result(result, tmp_path / "reference" / "run.csv")
    parquet_path = write_result(result, tmp_path / "result" / "run.parquet")
    from_parquet = read_result(parquet_path)
    pd.testing.assert_frame_equal(from_parquet, read_result(csv_path))
    assert from_parquet.attrs["units"] == {"a.x": "m", "b.y": "rad"}
    assert parquet_path.stat().st_size < csv_path.stat().st_size
    run = check_paths(tmp_path / "result", tmp_path / "reference")  # matched by name
    assert [check.name for check in run.files] == ["run.parquet"]
    assert run.exit_code == 0
    assert str(run.files[0].comparison).startswith("match: 2 column(s), 201 sample(s)")


def _parquet(path, columns):
    import pyarrow
    import pyarrow.parquet

    pyarrow.parquet.write_table(pyarrow.table(columns), path)
    return path


@pytest.mark.parametrize(
    ("columns", "message"),
    [
        (
            {"time": [0.0, 1.0, 2.0], "a.x": [1.0, float("nan"), 2.0]},
            "row 2, column 'a.x': nan is not a finite number",
        ),
        (
            {"time": [0.0, 1.0, 1.0], "a.x": [1.0, 2.0, 3.0]},
            "row 3: time 1.0 s repeats the previous row's 1.0 s (times must increase)",
        ),
        ({"t": [0.0], "a.x": [1.0]}, "line 1: the first column must be 'time', got 't'"),
        ({"time": [0.0], "a.x": ["one"]}, "column 'a.x' holds string, not numbers"),
        ({"time": [0.0, 1.0], "a.x": [1.0, None]}, "row 2, column 'a.x': no value (null)"),
    ],
)
def test_a_malformed_parquet_result_is_named_by_row_and_column(tmp_path, columns, message):
    pytest.importorskip("pyarrow")
    path = _parquet(tmp_path / "bad.parquet", columns)
    with pytest.raises(ResultFileError) as caught:
        read_result(path, block_bytes=160)  # one row per batch
    assert message in str(caught.value)
    assert str(caught.value).startswith(str(path))


def test_bytes_that_are_not_parquet_and_a_changed_parquet_file_are_refused(tmp_path):
    pytest.importorskip("pyarrow")
    fake = tmp_path / "fake.parquet"
    fake.write_bytes(b"time,a.x\n0,1\n")
    with pytest.raises(ResultFileError, match="malformed Parquet file"):
        read_result(fake)
    path = write_result(frame([0.0, 1.0], {"a.x": [1.0, 2.0]}), tmp_path / "r.parquet")
    other = write_result(frame([0.0, 1.0], {"a.x": [1.0, 3.0]}), tmp_path / "o.parquet")
    path.write_bytes(other.read_bytes())
    with pytest.raises(ResultFileError, match="are not one pair"):
        read_result(path)
