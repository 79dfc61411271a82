"""Coverage-guided fuzzing of the files mechfmu reads (issue 32), with atheris (libFuzzer for
Python; CPython 3.11 to 3.13): ``make fuzz-inputs`` runs it after the long hypothesis run.

Each input's first byte picks what the rest is: a scene file (fed to ``mechfmu run`` and
``mechfmu.simulate``), a result CSV and the JSON beside it (split at the first NUL byte; fed
to ``mechfmu check`` with --junit and --report against a reference, and to
``mechfmu.read_result``), or the seed of a rewritten PistonActuator.fmu (fed to a scene that
names it). The judge is tests/input_fuzz.py's: exit code 0, 1 or 2, a one-line error, no
traceback, nothing written outside the output folder, nothing left in TMPDIR; a violation
raises, and libFuzzer stops with the input that caused it (written under the
-artifact_prefix). mechfmu, tomllib, json and csv are instrumented, so inputs that reach new
branches of their parsers and checks are kept and mutated further.

    python tests/atheris_inputs.py [libFuzzer options] CORPUS_FOLDER
    python tests/atheris_inputs.py out/fuzz-inputs/crash-...      # replay one input

The corpus folder is seeded with the harness's generated inputs when it is empty.
"""

import os
import random
import sys
from pathlib import Path

import atheris

sys.path.insert(0, str(Path(__file__).parent))
with atheris.instrument_imports(include=["mechfmu", "tomllib", "json", "csv"]):
    import input_fuzz

FMU_DIR = Path(os.environ.get("MECHFMU_FMU_DIR") or Path(__file__).parents[1] / "fmus")
REFERENCE = input_fuzz.csv_text(random.Random(0), ["a.x", "b.y"], [0.5, -0.5], 5).encode()


def one_input(data: bytes) -> None:
    if not data:
        return
    kind, body = data[0] % 3, data[1:]
    if kind == 0:
        problems = input_fuzz.fuzz_scene(body, FMU_DIR)
    elif kind == 1:
        table, _, meta = body.partition(b"\x00")
        results = {"a.csv": table, **({"a.json": meta} if meta else {})}
        problems = input_fuzz.fuzz_results(results, {"a.csv": REFERENCE}, report=True)
    else:
        rng = random.Random(body)
        with input_fuzz.Sandbox() as box:  # a folder for the rewritten archive
            fmu = input_fuzz.fmu_archive(rng, FMU_DIR / "PistonActuator.fmu", box.root / "f.fmu")
            scene = input_fuzz.scene_text(rng, fmu="Fuzzed.fmu").encode("utf-8", "surrogatepass")
            problems = input_fuzz.fuzz_scene(scene, FMU_DIR, fmu)
    if problems:
        raise AssertionError("\n".join(problems))


def seed_corpus(folder: Path, count: int = 60) -> None:
    """Write ``count`` generated inputs of each kind into the empty corpus ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    if any(folder.iterdir()):
        return
    rng = random.Random(32)
    for index in range(count):
        scene = input_fuzz.scene_text(rng).encode("utf-8", "surrogatepass")
        columns = ["a.x", "b.y"] if rng.random() < 0.7 else [rng.choice(input_fuzz.NAMES)]
        table = input_fuzz.csv_text(rng, columns, [0.5, -0.5][: len(columns)], 5).encode()
        meta = input_fuzz.sidecar(rng, columns, table)
        (folder / f"scene{index}").write_bytes(b"\x00" + scene)
        (folder / f"result{index}").write_bytes(b"\x01" + table + b"\x00" + meta)
        (folder / f"fmu{index}").write_bytes(b"\x02" + rng.randbytes(8))


if __name__ == "__main__":
    for argument in sys.argv[1:]:  # corpus folders (a file given is an input to replay)
        if not argument.startswith("-") and not Path(argument).is_file():
            seed_corpus(Path(argument))
    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()
