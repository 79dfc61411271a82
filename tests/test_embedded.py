"""No Python at all (issue 20): ``mechfmu build --embed-python`` FMUs carry the build
interpreter's libpython and the standard library their run imports (packaging/embed.py), and
run in the plain C hosts with every Python of the machine hidden (c_hosts.hiding)."""

import shutil
import sys
import zipfile

import pytest
from fmpy import read_model_description

from c_hosts import (
    CASES,
    compile_host,
    extract,
    fmpy_rows,
    hiding,
    host_command,
    largest_relative_difference,
    run_host,
    run_model,
)
from mechfmu.packaging import build
from mechfmu.packaging.embed import PREFIX, EmbeddedPython
from mechfmu.runtime.models import MODELS

VERSION = f"{sys.version_info.major}.{sys.version_info.minor}"
SONAME = f"libpython{VERSION}.so.1.0"


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    return compile_host("host.c", tmp_path_factory.mktemp("c_host") / "host")


@pytest.fixture(scope="module")
def no_python(tmp_path_factory):
    """The mounts that hide every Python of the machine (pyenv's and the system's)."""
    empty = tmp_path_factory.mktemp("empty")
    return hiding(empty)


@pytest.mark.parametrize("model", list(MODELS))
def test_embedded_fmu_runs_in_a_c_host_with_every_python_hidden(
    host, no_python, embedded_dir, fmu_dir, tmp_path, model
):
    done, rows, loaded = run_model(host, embedded_dir / f"{model}.fmu", tmp_path / model, no_python)
    assert done.returncode == 0, done.stderr[-3000:]
    # the FMU's own runtime, nothing of the machine's
    assert loaded == [str(tmp_path / model / PREFIX / "lib" / SONAME)]
    expected = fmpy_rows(str(fmu_dir / f"{model}.fmu"))  # the plain FMU, in this process
    assert len(rows) == CASES[model][0] + 1
    assert largest_relative_difference(rows, expected) <= 1e-12
    assert rows == expected  # measured: bit-identical (the same CPython, stripped)


def test_without_its_runtime_the_same_fmu_finds_no_python(host, no_python, embedded_dir, tmp_path):
    """The control: the embedded FMU with resources/python removed fails to load, so the
    runs above owe nothing to a Python left on the machine."""
    fmu = embedded_dir / "LandingGear.fmu"
    folder = extract(fmu, tmp_path / "gear")
    shutil.rmtree(folder / PREFIX)
    command = host_command(read_model_description(str(fmu)), host, folder, 3, 0.01, {}, [])
    done, rows, loaded = run_host(command, no_python)
    assert done.returncode == 2 and rows == [] and loaded == []
    assert "no usable Python runtime found" in done.stderr
    assert f"\n  {folder / PREFIX / 'lib'}\n" in done.stderr  # looked there first


def test_embedded_runtime_is_the_traced_standard_library_and_nothing_more(embedded_dir):
    python = EmbeddedPython.of_this_interpreter()
    with zipfile.ZipFile(embedded_dir / "LandingGear.fmu") as archive:
        names = archive.namelist()
        stdlib = zipfile.ZipFile(archive.open(f"{PREFIX}/lib/{python.zip_name}"))
        modules = stdlib.namelist()
    ours = sorted(n for n in names if n.startswith(PREFIX + "/"))
    assert f"{PREFIX}/lib/{SONAME}" in ours
    extensions = [n.rsplit("/", 1)[1].split(".")[0] for n in ours if "/lib-dynload/" in n]
    assert "math" in extensions and "_struct" in extensions  # the models' and zipfile's
    assert not any("site-packages" in n for n in ours)
    assert "os.pyc" not in modules  # frozen into libpython: no file needed
    assert "encodings/__init__.pyc" in modules and "encodings/cp1252.pyc" in modules  # whole
    assert "json/decoder.pyc" in modules  # pythonfmu's FMU state serialisation imports json
    assert "tkinter/__init__.pyc" not in modules and "unittest/__init__.pyc" not in modules
    assert all(n.endswith(".pyc") for n in modules)
    # measured: 3.5 MB per FMU (libpython 5.7 MB stripped, the zip 3.1 MB, before deflate)
    assert (embedded_dir / "LandingGear.fmu").stat().st_size < 6e6


def test_embedded_fmu_still_runs_in_a_python_host(embedded_dir, fmu_dir):
    """In fmpy the FMU finds the host's Python already there and uses it."""
    assert fmpy_rows(str(embedded_dir / "ValveTrain.fmu")) == fmpy_rows(
        str(fmu_dir / "ValveTrain.fmu")
    )


def test_embedded_fmi3_fmu_runs_in_the_fmi3_c_host_with_every_python_hidden(no_python, tmp_path):
    host3 = compile_host("host3.c", tmp_path / "host3")
    (fmu,) = build.build_all(tmp_path / "out", ["Suspension"], fmi_version=3, embed_python=True)
    done, rows, loaded = run_model(host3, fmu, tmp_path / "suspension", no_python)
    assert done.returncode == 0, done.stderr[-3000:]
    assert loaded == [str(tmp_path / "suspension" / PREFIX / "lib" / SONAME)]
    assert rows == fmpy_rows(str(fmu))
