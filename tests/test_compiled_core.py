"""The valve's exact core compiled to C (packaging/compiled.py): the built ValveSpring FMU
carries it as an extension module that its interpreter loads, its runs equal the Python
source's on drawn valves and drives, and a compile that cannot be done leaves the source
with a one-line reason."""

import importlib
import importlib.machinery
import math
import sys
import zipfile

import pandas
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechfmu.packaging import compiled
from mechfmu.packaging.build import build_model, runtime_package
from mechfmu.runtime.models.valve_spring import ValveSpring
from test_exact_valve import camshaft_slave

SUFFIX = importlib.machinery.EXTENSION_SUFFIXES[0]  # this interpreter's, e.g. .cpython-311-...so
ULPS = 8  # a float of a compiled run within this many units in the last place of the source's


@pytest.fixture(scope="module")
def fmu_package(fmu_dir, tmp_path_factory):
    """The runtime package of fmus/ValveSpring.fmu, extracted and importable (its folder
    last on sys.path: the FMU's copy of pythonfmu must not shadow the installed one)."""
    folder = tmp_path_factory.mktemp("valve_fmu")
    with zipfile.ZipFile(fmu_dir / "ValveSpring.fmu") as archive:
        archive.extractall(folder)
    resources = str(folder / "resources")
    sys.path.append(resources)
    try:
        yield runtime_package("ValveSpring")
    finally:
        sys.path.remove(resources)


def _modules(package):
    return [compiled.module_name(package, relative) for relative in compiled.CORE_GROUP]


def test_the_valve_fmu_carries_its_exact_core_compiled_for_this_interpreter(fmu_dir, fmu_package):
    names = set(zipfile.ZipFile(fmu_dir / "ValveSpring.fmu").namelist())
    for relative in compiled.CORE_GROUP:
        inside = f"resources/{fmu_package}/{relative[: -len('.py')]}"
        assert f"{inside}.py" in names  # the source stays: other interpreters import it
        assert f"{inside}{SUFFIX}" in names, sorted(n for n in names if n.endswith(".so"))
    library = [n for n in names if n.startswith("resources/") and n.endswith(f"__mypyc{SUFFIX}")]
    assert len(library) == 1 and library[0].count("/") == 1  # the group's, top of resources
    for name in _modules(fmu_package):  # the extensions, not the sources, are imported
        assert importlib.import_module(name).__file__.endswith(SUFFIX), name
    # an FMU that does not carry the core carries no compiled module
    crank = zipfile.ZipFile(fmu_dir / "CrankDrive.fmu").namelist()
    assert not [name for name in crank if name.startswith("resources/") and ".so" in name]


def test_the_fmi3_valve_fmu_carries_it_too(fmu3_dir):
    """FMI 3.0 FMUs name their runtime package apart (runtime_package), so the core is
    compiled under that name."""
    inside = f"resources/{runtime_package('ValveSpring', 3)}/{compiled.CORE[: -len('.py')]}"
    names = zipfile.ZipFile(fmu3_dir / "ValveSpring.fmu").namelist()
    assert f"{inside}{SUFFIX}" in names and f"{inside}.py" in names


def _camshaft_rows(model_class, parameters, speed, steps, dt):
    """Every variable's value after each of ``steps`` steps of an in-process ``model_class`` (a
    ValveSpring) on the camshaft drive from -0.2 rad at ``speed`` rad/s (camshaft_slave),
    stopping at a refused step."""
    model = camshaft_slave("exact", speed, model_class=model_class, **parameters)
    rows = []
    for index in range(steps):
        model.values.update(camshaft_angle=-0.2 + speed * (index + 1) * dt)
        ok = model.do_step(index * dt, dt)
        rows.append((ok, model.pending_error, dict(model.values)))
        if not ok:
            break
    return rows


def _same(a, b):
    """Equal to ULPS units in the last place (the design gives equal bits; a test must not
    hinge on them)."""
    if not (isinstance(a, float) and isinstance(b, float)):
        return a == b  # counts, flags, choices: exactly
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or math.isclose(a, b, rel_tol=ULPS * sys.float_info.epsilon, abs_tol=1e-300)


@settings(max_examples=25, deadline=None)
@given(
    mass=st.floats(0.02, 0.4),
    stiffness=st.floats(1e4, 2e5),
    preload=st.floats(50.0, 800.0),
    contact_damping=st.floats(0.0, 3e3),
    seat_damping=st.floats(0.0, 3e3),
    lash=st.floats(0.0, 4e-4),
    speed=st.floats(50.0, 700.0),
    dt=st.sampled_from([2e-4, 5e-4, 1e-3]),
)
def test_the_compiled_core_runs_as_the_python_source(
    fmu_package, mass, stiffness, preload, contact_damping, seat_damping, lash, speed, dt
):
    """Drawn valves (rise, float, bounces on the seat at high speed) through the FMU's
    ValveSpring, whose exact core is the extension, and through the source's: the same
    outputs and counts at every step, the same refusal if one is refused."""
    compiled_class = importlib.import_module(f"{fmu_package}.models.valve_spring").ValveSpring
    assert all(importlib.import_module(n).__file__.endswith(SUFFIX) for n in _modules(fmu_package))
    parameters = dict(
        valve_mass=mass,
        spring_stiffness=stiffness,
        spring_preload=preload,
        contact_damping=contact_damping,
        seat_damping=seat_damping,
        lash=lash,
    )
    steps = math.ceil(0.012 / dt)
    source = _camshaft_rows(ValveSpring, parameters, speed, steps, dt)
    built = _camshaft_rows(compiled_class, parameters, speed, steps, dt)
    assert len(built) == len(source)
    for (ok, error, values), (ok_c, error_c, values_c) in zip(source, built):
        assert ok == ok_c and error == error_c
        assert values.keys() == values_c.keys()
        assert all(_same(values[name], values_c[name]) for name in values), (values, values_c)


@pytest.fixture(scope="module")
def source_fmu_dir(fmu_dir, tmp_path_factory):
    """The built FMUs with ValveSpring.fmu built again without its compiled core."""
    folder = tmp_path_factory.mktemp("source_fmus")
    for fmu in fmu_dir.glob("*.fmu"):
        (folder / fmu.name).symlink_to(fmu)
    (folder / "ValveSpring.fmu").unlink()
    build_model("ValveSpring", folder, tmp_path_factory.mktemp("staging"), compile_core=False)
    names = zipfile.ZipFile(folder / "ValveSpring.fmu").namelist()
    assert not [name for name in names if name.startswith("resources/") and ".so" in name]
    return folder


@pytest.mark.parametrize("name", ["valve_train_dynamic", "valve_float_dynamic"])
def test_each_valve_scene_runs_as_with_the_sources(name, fmu_dir, source_fmu_dir, tmp_path):
    """The shipped valve scenes through the master with the compiled FMU and with one built
    from the sources alone: the same table (every column, every row)."""
    from mechfmu.cosim.run import run_scene
    from mechfmu.cosim.scene import SCENE_DIR

    tables = [
        pandas.read_csv(
            run_scene(SCENE_DIR / f"{name}.toml", tmp_path / kind, folder, plot=False)[1]["csv"]
        )
        for kind, folder in (("compiled", fmu_dir), ("source", source_fmu_dir))
    ]
    assert list(tables[0].columns) == list(tables[1].columns) and len(tables[0]) > 10
    for column in tables[0].columns:
        built, source = tables[0][column].to_numpy(), tables[1][column].to_numpy()
        assert all(_same(float(a), float(b)) for a, b in zip(built, source)), column


# --- compiles that cannot be done --------------------------------------------------------


def _staged(tmp_path, text):
    """A staged runtime package whose physics/valve_exact.py (the core) holds ``text``."""
    package = tmp_path / "stage" / "mechfmu_fmu_Probe"
    (package / "physics").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "physics" / "__init__.py").write_text("")
    (package / compiled.CORE).write_text(text)
    return package


def test_a_type_error_leaves_the_sources_and_names_the_line(tmp_path):
    package = _staged(tmp_path, "def half(x: float) -> float:\n    return 'x'\n")
    result = compiled.compile_core(package, tmp_path / "work")
    assert not result.done and not result.outside
    assert result.message.startswith("exact core not compiled (mypyc exited with 1:")
    assert "valve_exact.py:2: error: Incompatible return value" in result.message
    assert result.message.endswith("the FMU runs its Python sources")
    assert not list(package.parent.rglob("*.so"))


def test_without_a_c_compiler_the_sources_stay(tmp_path, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    package = _staged(tmp_path, "def half(x: float) -> float:\n    return x / 2.0\n")
    result = compiled.compile_core(package, tmp_path / "work")
    assert not result.done and "no-such-compiler" in result.message, result.message
    assert not list(package.parent.rglob("*.so"))


def test_a_compiled_probe_loads_and_a_package_without_the_core_compiles_nothing(tmp_path):
    package = _staged(tmp_path, "def half(x: float) -> float:\n    return x / 2.0\n")
    result = compiled.compile_core(package, tmp_path / "work")
    assert result.done, result.message
    assert "1 modules of mechfmu_fmu_Probe (valve_exact)" in result.message
    assert [path.name for path in result.outside] == []  # one module: its library beside it
    assert (package / "physics" / f"valve_exact{SUFFIX}").is_file()
    crank = tmp_path / "mechfmu_fmu_CrankDrive"
    (crank / "physics").mkdir(parents=True)
    assert compiled.compile_core(crank, tmp_path / "work2") is None
