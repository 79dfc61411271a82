"""The README's commands work exactly as written: its first block sets up the clone (run in
the clone, its ``make`` lines as dry runs: ``make test`` is this suite), every later shell and
Python block runs as pasted, one after the other, in a new empty folder, in the shell the
setup's ``source .venv/bin/activate`` gives."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT

BLOCK = re.compile(r"^```(sh|python)\n(.*?)^```$", re.MULTILINE | re.DOTALL)


def blocks() -> list:
    """(language, text) of every shell and Python block of the README, in order."""
    return BLOCK.findall((ROOT / "README.md").read_text(encoding="utf-8"))


def venv_path() -> str:
    """The venv this suite runs in, as the README's '.venv' reads in the clone (.venv, or
    .venv-3.12 under make test PYTHON=...)."""
    prefix = Path(sys.prefix)
    return prefix.relative_to(ROOT).as_posix() if prefix.is_relative_to(ROOT) else str(prefix)


def test_the_first_block_sets_up_the_clone():
    language, setup = blocks()[0]
    commands = [line.split("#")[0].strip() for line in setup.splitlines() if line.strip()]
    assert language == "sh" and commands == [
        "make run",
        "source .venv/bin/activate",
        "make test",
    ]
    for target in ("run", "test"):
        done = subprocess.run(
            ["make", "-n", target], cwd=ROOT, capture_output=True, text=True, timeout=120
        )
        assert done.returncode == 0, done.stderr
    activate = f"{venv_path()}/bin/activate"
    done = subprocess.run(
        ["bash", "-c", f"source {activate} && command -v mechfmu && command -v python"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        str(Path(sys.prefix) / "bin" / "mechfmu"),
        str(Path(sys.prefix) / "bin" / "python"),
    ]


@pytest.mark.usefixtures("fmu_dir")
def test_every_later_block_runs_as_written_in_a_new_folder(tmp_path):
    environment = dict(os.environ, VIRTUAL_ENV=sys.prefix)
    environment["PATH"] = f"{Path(sys.prefix) / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}"
    later = blocks()[1:]
    assert [language for language, _ in later].count("python") >= 1 and len(later) >= 4
    for language, text in later:
        command = ["bash", "-e", "-c", text] if language == "sh" else ["python", "-c", text]
        done = subprocess.run(
            command, cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=600
        )
        assert done.returncode == 0, f"{text}\n{done.stdout}\n{done.stderr}"
        assert "Traceback" not in done.stderr, done.stderr
        if language == "python":
            assert done.stdout.split() == ["True", "rad"]
    # what the blocks say they leave behind, in the new folder
    assert (tmp_path / "results" / "gear_retraction.csv").is_file()
    assert (tmp_path / "baselines" / "gear_retraction.csv").is_file()
    assert (tmp_path / "report" / "index.html").is_file() and (tmp_path / "junit.xml").is_file()
