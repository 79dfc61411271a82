"""The fuzz harness of the files mechfmu reads (issue 32), shared by the hypothesis tests
(test_input_fuzz.py, a short budget in ``make test``) and the atheris target
(atheris_inputs.py, ``make fuzz-inputs``).

Generators make scene files, CSV tables, JSON sidecars and small FMU archives: mostly
near-valid (a working scene or result with one thing changed) and sometimes hostile (deep
nesting, long numbers, bytes that are not UTF-8, control characters, links and '..' in
archives). ``Sandbox`` feeds them to the command line (in-process, ``mechfmu.cli.main``) and
to the Python API, and ``Sandbox.judge`` asserts what every input must give: an exit code of
0, 1 or 2 and a one-line message, no exception escaping (a traceback), nothing written
outside the output folder (the inputs unchanged, the working folder untouched) and nothing
left in the temporary directory.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import random
import shutil
import stat
import tempfile
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import mechfmu
from mechfmu.cli import main as cli
from mechfmu.cosim.master import SimulationError
from mechfmu.cosim.scene import SceneError
from mechfmu.io import ResultFileError

MODEL = "PistonActuator"  # the scenes' component: fast, with a table-free set of parameters
PARAMETERS = ("stroke_time", "profile", "start_extension", "end_extension", "nonsense")
OUTPUTS = ("piston_extension", "piston_speed", "piston_acceleration", "ghost")
NUMBERS = (
    "0.1", "0.01", "1", "0", "-1", "1e-300", "1e300", "1e400", "inf", "-inf", "nan",
    "9223372036854775808", "0x7f", "1_000", "3.0e-2", "1" * 120, "0." + "1" * 120,
)  # fmt: skip
CHECK_KEYS = ("rtol", "atol", "method", "time_tolerance", "why", "columns", "colour")
HOSTILE_SNIPPETS = (
    "[" * 40,
    "{a=" * 40,
    "9" * 5000,
    "\x00",
    "\r",
    "\ufeff",
    '"""',
    "'''",
    "\\",
    "#",
    "=",
    "\n[components.x]\n",
    "\ud800",
    "a." * 50 + "b = 1",
)
NAMES = (
    "x y", "x_y", "c\x01d", "e$\\frac$f", "t\nu", "time", "", "a,b", '"q"', "é", "\u2028",
    "L" * 300, "gear.gear_angle", "v",
)  # fmt: skip
MEMBER_NAMES = (
    "/abs.txt", "../up.txt", "resources/../../up.txt", "C:/drive.txt", "a\\b.txt", "resources/",
    "resources//x", "./x", "modelDescription.xml", "resources/" + "n" * 300, "binaries/",
    "documentation/index.html", "resources/ok.txt", "a:b",
)  # fmt: skip


def toml_value(value: object) -> str:
    """``value`` (None, bool, int, float, str, list, dict) as TOML text."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # JSON's escapes are TOML's (\uXXXX for the controls)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(item) for item in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    return json.dumps(str(value))


def random_value(rng: random.Random, depth: int = 0) -> object:
    """A value of any TOML kind, sometimes an extreme one."""
    kind = rng.randrange(9 if depth < 2 else 6)
    if kind == 0:
        return rng.choice((True, False))
    if kind == 1:
        return rng.choice((0, 1, -1, 2**31, 2**63 - 1, -(2**63), 2**64, 10**30))
    if kind == 2:
        return rng.choice((0.1, 3.0, -0.5, 1e-300, 1e300, math.inf, -math.inf, math.nan, 5e-324))
    if kind in (3, 4):
        return rng.choice(("cycloidal", "constant_speed", "", "\x00", "a" * 70_000, "é", "../x"))
    if kind == 5:
        return rng.uniform(-10.0, 10.0)
    if kind == 6:
        return [random_value(rng, depth + 1) for _ in range(rng.randrange(3))]
    return {rng.choice(PARAMETERS): random_value(rng, depth + 1) for _ in range(rng.randrange(3))}


def _plausible(rng: random.Random, name: str) -> object:
    """A value a user might give parameter ``name`` of the PistonActuator."""
    if name == "profile":
        return rng.choice(("constant_speed", "cycloidal"))
    if name == "stroke_time":
        return round(rng.uniform(0.1, 4.5), 3)  # past 4 s: refused by the FMU
    return round(rng.uniform(0.3, 0.7), 3)


def scene_text(rng: random.Random, fmu: str = MODEL) -> str:
    """A scene of one PistonActuator (or ``fmu``): a working one with none, one or two of
    its parts changed at random (a value of another kind or an extreme one, a name that
    does not exist, a key that is not allowed)."""
    broken = set(rng.sample(range(14), rng.choice((0, 1, 1, 2))))

    def part(index: int, good: str, bad: str) -> str:
        return bad if index in broken else good

    record = [f"actuator.{rng.choice(OUTPUTS[:3])}" for _ in range(rng.randrange(1, 4))]
    names = [rng.choice(PARAMETERS[:4]) for _ in range(rng.randrange(3))]
    parameters = {name: _plausible(rng, name) for name in names}
    hostile_record = [
        rng.choice(NAMES) if rng.random() < 0.5 else f"actuator.{rng.choice(OUTPUTS)}"
    ]
    lines = [
        part(
            0,
            'name = "fuzzed"',
            f"name = {toml_value(rng.choice(('.x', 'a/b', 5, '', 'é' * 300)))}",
        ),
        part(
            1,
            f"stop_time = {rng.choice(('0.1', '0.05', '1'))}",
            f"stop_time = {rng.choice(NUMBERS)}",
        ),
        part(2, "step = 0.01", f"step = {rng.choice(NUMBERS)}"),
        part(3, "", f"start_time = {rng.choice(NUMBERS)}"),
        part(4, f"record = {toml_value(record)}", f"record = {toml_value(hostile_record)}"),
        part(5, "", f"connections = {toml_value(random_value(rng))}"),
        part(
            6,
            rng.choice(("", 'coupling = "jacobi"')),
            f"coupling = {toml_value(random_value(rng))}",
        ),
        part(
            7,
            "",
            f"{rng.choice(('colour', 'reference', 'description'))} = {toml_value(random_value(rng))}",
        ),
        "[components.actuator]",
        part(8, f"fmu = {toml_value(fmu)}", f"fmu = {toml_value(random_value(rng))}"),
        part(
            9,
            f"parameters = {toml_value(parameters)}",
            f"parameters = {toml_value({rng.choice(PARAMETERS): random_value(rng)})}",
        ),
        part(10, "", f"inputs = {toml_value(random_value(rng))}"),
        part(11, "", f"effects = {toml_value(random_value(rng))}"),
        part(12, "", "[check]\n" + f"{rng.choice(CHECK_KEYS)} = {toml_value(random_value(rng))}"),
        part(
            13,
            "",
            f"[check.columns]\n{json.dumps(rng.choice(NAMES))} = {toml_value(random_value(rng))}",
        ),
    ]
    return "\n".join(line for line in lines if line) + "\n"


def mutated(rng: random.Random, data: bytes, rounds: int | None = None) -> bytes:
    """``data`` with a few random edits: a byte flipped, deleted, or a hostile snippet (or
    random bytes) inserted; the edits of a fuzzer that knows nothing of the format."""
    data = bytearray(data)
    for _ in range(rounds if rounds is not None else rng.randrange(1, 4)):
        at = rng.randrange(len(data) + 1)
        edit = rng.randrange(4)
        if edit == 0 and at < len(data):
            data[at] ^= 1 << rng.randrange(8)
        elif edit == 1 and at < len(data):
            del data[at : at + rng.randrange(1, 8)]
        elif edit == 2:
            snippet = rng.choice(HOSTILE_SNIPPETS).encode("utf-8", "surrogatepass")
            data[at:at] = snippet
        else:
            data[at:at] = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 6)))
    return bytes(data)


def csv_text(rng: random.Random, columns: list[str], values: list[float], rows: int) -> str:
    """A result CSV of ``columns`` (names quoted as needed), ``rows`` rows of ``values``."""
    import csv

    handle = io.StringIO()
    writer = csv.writer(handle, lineterminator=rng.choice(("\n", "\n", "\r\n")))
    writer.writerow(["time", *columns])
    for row in range(rows):
        writer.writerow([repr(row * 0.5), *(repr(value + row) for value in values)])
    return handle.getvalue()


def json_value(rng: random.Random, depth: int = 0) -> object:
    kind = rng.randrange(7 if depth < 3 else 4)
    if kind == 0:
        return rng.choice((None, True, False, 0, -1, 2**70, 1.5, math.inf, math.nan))
    if kind in (1, 2):
        return rng.choice(NAMES + ("m", "rad", "", "s"))
    if kind == 3:
        return rng.uniform(-1e6, 1e6)
    if kind == 4:
        return [json_value(rng, depth + 1) for _ in range(rng.randrange(3))]
    return {
        rng.choice(
            NAMES + ("units", "run_id", "csv_bytes", "csv_sha256", "check", "rtol")
        ): json_value(rng, depth + 1)
        for _ in range(rng.randrange(3))
    }


def sidecar(rng: random.Random, columns: list[str], csv_bytes: bytes) -> bytes:
    """A JSON beside a result: a good one (sealed to ``csv_bytes`` or not) or a changed one."""
    import hashlib

    meta: dict[str, object] = {"units": {c: rng.choice(("m", "rad", "$x$", None)) for c in columns}}
    if rng.random() < 0.6:
        meta.update(
            run_id="0" * 32,
            csv_bytes=len(csv_bytes),
            csv_sha256=hashlib.sha256(csv_bytes).hexdigest(),
        )
    for _ in range(rng.randrange(3)):
        meta[rng.choice(("units", "csv_bytes", "csv_sha256", "check", "x"))] = json_value(rng)
    text = json.dumps(meta, allow_nan=True).encode()
    return mutated(rng, text) if rng.random() < 0.3 else text


def fmu_archive(rng: random.Random, source: Path, target: Path) -> Path:
    """``source`` rewritten with a few members added, dropped, cut or changed at random (a
    shared library cut, never edited)."""
    with zipfile.ZipFile(source) as original:
        members = [(info, original.read(info)) for info in original.infolist()]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # zipfile: "Duplicate name"
        with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as copy:
            for info, data in members:
                draw = rng.random()
                if draw < 0.03:
                    continue
                if draw < 0.06:
                    data = data[: rng.randrange(len(data) + 1)]
                elif draw < 0.08 and not info.filename.startswith("binaries/"):
                    # (a library's code bytes edited with its structure intact is machine
                    # code that crashes any host that loads it: no check can tell)
                    data = mutated(rng, data)
                copy.writestr(info, data)
            for _ in range(rng.randrange(3)):
                name = rng.choice(MEMBER_NAMES)
                info = zipfile.ZipInfo(name)
                if rng.random() < 0.2:
                    info.create_system = 3
                    info.external_attr = (
                        rng.choice((stat.S_IFLNK, stat.S_IFIFO, stat.S_IFREG)) | 0o644
                    ) << 16
                data = bytes(rng.choice((16, 2 << 20))) if rng.random() < 0.5 else b"data"
                copy.writestr(info, data)
    if rng.random() < 0.2:  # damage the archive itself
        target.write_bytes(mutated(rng, target.read_bytes()))
    return target


# --- running and judging ---------------------------------------------------------------------


def _tree(folder: Path) -> dict[str, tuple[int, int]]:
    """Every path under ``folder`` with its size and modification time (ns)."""
    found = {}
    for root, folders, files in os.walk(folder):
        for name in folders + files:
            path = Path(root) / name
            status = path.lstat()
            found[str(path.relative_to(folder))] = (status.st_size, status.st_mtime_ns)
    return found


@dataclass
class Outcome:
    what: str
    code: int | None = None
    stdout: str = ""
    stderr: str = ""
    error: BaseException | None = None
    problems: list[str] = field(default_factory=list)


class Sandbox:
    """A folder of its own for one input: ``inputs`` (what is read), ``out`` (the output
    folder), ``work`` (the working folder) and ``tmp`` (the temporary directory), all
    checked after each call by ``judge``."""

    def __init__(self) -> None:
        self.root = Path(tempfile.mkdtemp(prefix="mechfmu_fuzz_"))
        self.inputs, self.out, self.work, self.tmp = (
            self.root / name for name in ("inputs", "out", "work", "tmp")
        )
        for folder in (self.inputs, self.work, self.tmp):
            folder.mkdir()

    def __enter__(self) -> Sandbox:
        return self

    def __exit__(self, *exc: object) -> None:
        shutil.rmtree(self.root, ignore_errors=True)

    @contextlib.contextmanager
    def _inside(self):
        """The working folder, the temporary directory and TMPDIR set to the sandbox's."""
        saved = (os.getcwd(), tempfile.tempdir, os.environ.get("TMPDIR"))
        os.chdir(self.work)
        tempfile.tempdir = str(self.tmp)
        os.environ["TMPDIR"] = str(self.tmp)
        try:
            yield
        finally:
            os.chdir(saved[0])
            tempfile.tempdir = saved[1]
            if saved[2] is None:
                os.environ.pop("TMPDIR", None)
            else:
                os.environ["TMPDIR"] = saved[2]

    def cli(self, *arguments: object) -> Outcome:
        """``mechfmu ARGUMENTS`` in-process; its exit code and output."""
        outcome = Outcome("mechfmu " + " ".join(str(a) for a in arguments[:1]))
        before = _tree(self.inputs)
        printed, errors = io.StringIO(), io.StringIO()
        with (
            self._inside(),
            contextlib.redirect_stdout(printed),
            contextlib.redirect_stderr(errors),
            warnings.catch_warnings(),
        ):
            warnings.simplefilter("ignore")  # matplotlib's missing glyphs and the like
            try:
                outcome.code = cli([str(a) for a in arguments])
            except SystemExit as exit_:  # argparse
                outcome.code = exit_.code if isinstance(exit_.code, int) else 2
            except BaseException as error:  # a traceback for a user
                outcome.error = error
        outcome.stdout, outcome.stderr = printed.getvalue(), errors.getvalue()
        self._check(outcome, before)
        if outcome.code not in (0, 1, 2):
            outcome.problems.append(f"exit code {outcome.code}")
        lines = outcome.stderr.splitlines()
        if outcome.code == 2 and len(lines) > 1 and arguments[0] == "run":
            outcome.problems.append(f"an error of {len(lines)} lines: {outcome.stderr[-300:]!r}")
        return outcome

    def api(self, call, allowed: tuple[type[BaseException], ...]) -> Outcome:
        """``call()`` in the sandbox; only ``allowed`` exceptions may come out of it."""
        outcome = Outcome(getattr(call, "__name__", "api"))
        before = _tree(self.inputs)
        with self._inside():
            try:
                call()
            except allowed as error:
                if "\n" in str(error):
                    outcome.problems.append(f"a message of several lines: {str(error)[:300]!r}")
            except BaseException as error:
                outcome.error = error
        self._check(outcome, before)
        return outcome

    def _check(self, outcome: Outcome, before: dict) -> None:
        if outcome.error is not None:
            outcome.problems.append(f"{type(outcome.error).__name__}: {outcome.error!s:.300}")
        if "Traceback" in outcome.stderr:
            outcome.problems.append(f"a traceback: {outcome.stderr[-500:]}")
        if _tree(self.inputs) != before:
            outcome.problems.append("the inputs changed")
        if os.listdir(self.work):
            outcome.problems.append(f"written outside --out: {os.listdir(self.work)}")
        if os.listdir(self.tmp):
            outcome.problems.append(f"left in TMPDIR: {os.listdir(self.tmp)}")
        outside = set(os.listdir(self.root)) - {"inputs", "out", "work", "tmp"}
        if outside:
            outcome.problems.append(f"written outside --out: {sorted(outside)}")


API_SCENE_ERRORS = (SceneError, SimulationError)  # FmuError is a SceneError
API_FILE_ERRORS = (ResultFileError,)


def assignments(rng: random.Random) -> list[str]:
    """None to two ``--set`` texts, their values plausible or hostile."""
    values = NUMBERS + HOSTILE_SNIPPETS + ("cycloidal", "[1, 2]", "{a = 1}", "")
    return [
        f"actuator.{rng.choice(PARAMETERS)}={rng.choice(values)}".replace("\x00", "")
        for _ in range(rng.choice((0, 0, 1, 2)))
    ]


def fuzz_scene(
    data: bytes, fmu_dir: Path, fmu: Path | None = None, sets: list[str] = ()
) -> list[str]:
    """Run the scene file ``data`` through ``mechfmu run`` (with ``--set`` each of ``sets``)
    and ``mechfmu.simulate``; the problems found (none is a pass). ``fmu``: an FMU file the
    scene may name."""
    problems = []
    with Sandbox() as box:
        scene = box.inputs / "fuzzed.toml"
        scene.write_bytes(data)
        if fmu is not None:
            shutil.copyfile(fmu, box.inputs / "Fuzzed.fmu")
        options = [item for text in sets for item in ("--set", text)]
        outcome = box.cli(
            "run", scene, "--out", box.out, "--fmu-dir", fmu_dir, "--no-plot", *options
        )
        problems += [f"mechfmu run: {p}" for p in outcome.problems]
        outcome = box.api(lambda: mechfmu.simulate(scene, fmu_dir=fmu_dir), API_SCENE_ERRORS)
        problems += [f"mechfmu.simulate: {p}" for p in outcome.problems]
    return problems


def fuzz_results(files: dict[str, bytes], references: dict[str, bytes], report: bool) -> list[str]:
    """``mechfmu check`` of a result tree (``files``: relative path -> bytes) against a
    reference tree (with --junit and, if ``report``, --report into the output folder), and
    ``mechfmu.read_result`` of each result CSV; the problems found."""
    problems = []
    with Sandbox() as box:
        for tree, contents in (("results", files), ("references", references)):
            for name, data in contents.items():
                path = box.inputs / tree / name
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(data)
        extra = ["--junit", box.out / "junit.xml"] + (
            ["--report", box.out / "report"] if report else []
        )
        outcome = box.cli("check", box.inputs / "results", box.inputs / "references", *extra)
        problems += [f"mechfmu check: {p}" for p in outcome.problems]
        if outcome.code in (0, 1) and not outcome.problems:
            import xml.etree.ElementTree as ET

            try:
                ET.parse(box.out / "junit.xml")
            except ET.ParseError as error:
                problems.append(f"mechfmu check: the JUnit file is not well-formed: {error}")
            if report and not (box.out / "report" / "index.html").is_file():
                problems.append("mechfmu check: no index.html")
        for name in files:
            if name.endswith(".csv"):
                path = box.inputs / "results" / name
                outcome = box.api(lambda path=path: mechfmu.read_result(path), API_FILE_ERRORS)
                problems += [f"mechfmu.read_result({name}): {p}" for p in outcome.problems]
    return problems
