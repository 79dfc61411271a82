"""The fuzz harness of hostile input files (issue 32; tests/input_fuzz.py): generated scene
files, result trees (CSV tables and their JSON sidecars against references) and small FMU
archives, each fed to the command line and to the Python API. Every input must give an exit
code of 0, 1 or 2 with a one-line error, no traceback, nothing written outside the output
folder and nothing left in the temporary directory.

A short budget here (MECHFMU_FUZZ_EXAMPLES scales it: ``make fuzz-inputs`` runs 50 times
more, then the atheris target)."""

import os
import random
import subprocess
import sys

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from input_fuzz import (
    NAMES,
    assignments,
    csv_text,
    fmu_archive,
    fuzz_results,
    fuzz_scene,
    mutated,
    scene_text,
    sidecar,
)

SCALE = float(os.environ.get("MECHFMU_FUZZ_EXAMPLES", "1"))
SEEDS = st.integers(0, 2**32 - 1)


def _examples(count):
    return settings(
        max_examples=max(1, int(count * SCALE)),
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow],
        derandomize=SCALE <= 1,  # the suite's examples are the same every run
    )


def scene_bytes(rng):
    text = scene_text(rng).encode("utf-8", "surrogatepass")
    draw = rng.random()
    if draw < 0.25:
        return mutated(rng, text)
    if draw < 0.3:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(200)))
    return text


@_examples(40)
@given(SEEDS)
def test_generated_scene_files(fmu_dir, seed):
    rng = random.Random(seed)
    problems = fuzz_scene(scene_bytes(rng), fmu_dir, sets=assignments(rng))
    assert problems == [], problems


def result_trees(rng):
    """(results, references, report): 1 to 3 files, columns from NAMES, values off by a
    little or a lot, sidecars good or changed, some files changed byte by byte."""
    results, references = {}, {}
    for index in range(rng.randrange(1, 4)):
        name = rng.choice(("a.csv", "sub/a.csv", "sub_a.csv", "k.partial.csv", "x y.csv"))
        columns = list(dict.fromkeys(rng.choice(NAMES) or "v" for _ in range(rng.randrange(1, 4))))
        columns = [c for c in columns if c != "time"] or ["v"]
        values = [rng.uniform(-1, 1) for _ in columns]
        rows = rng.choice((1, 2, 5))
        reference = csv_text(rng, columns, values, rows).encode()
        offset = rng.choice((0.0, 1e-15, 0.1))
        result = csv_text(rng, columns, [v + offset for v in values], rows).encode()
        if rng.random() < 0.3:
            result = mutated(rng, result)
        if rng.random() < 0.1:
            reference = mutated(rng, reference)
        results[name] = result
        if rng.random() < 0.9:
            references[name] = reference
        if rng.random() < 0.6:
            results[name[:-4] + ".json"] = sidecar(rng, columns, result)
    return results, references, rng.random() < 0.3


@_examples(15)
@given(SEEDS)
def test_generated_result_trees(seed):
    results, references, report = result_trees(random.Random(seed))
    problems = fuzz_results(results, references, report)
    assert problems == [], problems


@settings(
    max_examples=max(1, int(8 * SCALE)),
    deadline=None,
    derandomize=SCALE <= 1,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(SEEDS)
def test_generated_fmu_archives(fmu_dir, tmp_path, seed):
    rng = random.Random(seed)
    fmu = fmu_archive(rng, fmu_dir / "PistonActuator.fmu", tmp_path / f"{seed}.fmu")
    scene = scene_text(rng, fmu="Fuzzed.fmu").encode("utf-8", "surrogatepass")
    problems = fuzz_scene(scene, fmu_dir, fmu)
    assert problems == [], problems


def test_hostile_scenes_through_the_real_process(fmu_dir, tmp_path):
    """The same judge on a process of its own: the exit code, stderr as printed, TMPDIR."""
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    rng = random.Random(32)
    for index in range(3):
        scene = tmp_path / f"s{index}.toml"
        scene.write_bytes(mutated(rng, scene_text(rng).encode(), rounds=2) + b"\nx = " + b"[" * 500)
        done = subprocess.run(
            [sys.executable, "-m", "mechfmu", "run", str(scene), "--out", str(tmp_path / "out"),
             "--fmu-dir", str(fmu_dir)],
            capture_output=True, text=True, timeout=120,
            env=dict(os.environ, TMPDIR=str(temporary)), cwd=tmp_path,
        )  # fmt: skip
        assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
        assert done.stderr.startswith("scene error: ") and done.stderr.count("\n") == 1
    assert list(temporary.iterdir()) == []
