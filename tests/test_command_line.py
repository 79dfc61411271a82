"""The command tree as a new user meets it: --version, scenes, --set, one rule for finding
the FMUs from any folder, help on every option, messages that say what to do."""

import argparse
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, strategies as st

import mechfmu
from cli_process import run_mechfmu, run_script
from conftest import SCENES
from mechfmu.cli import main as cli, parse_assignments, parser
from mechfmu.cosim import locate
from mechfmu.cosim.scene import SceneError, load_scene
from mechfmu.io import read_result
from mechfmu.runtime.models import MODELS


def test_version_and_the_top_help_list_every_verb(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli(["--version"])
    assert exit_.value.code == 0 and capsys.readouterr().out == f"mechfmu {mechfmu.__version__}\n"
    with pytest.raises(SystemExit):
        cli(["--help"])
    top = capsys.readouterr().out
    verbs = [a for a in parser()._actions if isinstance(a, argparse._SubParsersAction)][0]
    for verb in verbs.choices:
        assert f"\n    {verb}" in top, verb
    assert "``" not in top


def _options(tree, path=("mechfmu",)):
    """(verb path, option) for every option of every (nested) verb."""
    for action in tree._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, verb in action.choices.items():
                yield from _options(verb, (*path, name))
        elif action.option_strings and action.help != argparse.SUPPRESS:
            yield path, action


def test_every_option_has_help_stating_its_default():
    options = list(_options(parser()))
    assert len(options) > 60
    for path, action in options:
        where = f"{' '.join(path)} {action.option_strings[0]}"
        assert action.help, where
        if action.default not in (None, False, [], argparse.SUPPRESS) and not isinstance(
            action, (argparse._HelpAction, argparse._VersionAction)
        ):
            assert "default" in action.help, where
    spellings = {option for _, action in options for option in action.option_strings}
    assert "--fmu-dir" in spellings and "--fmus" not in spellings


def test_scenes_lists_every_shipped_scene_from_any_folder(tmp_path):
    done = run_mechfmu("scenes", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    for path in SCENES.glob("*.toml"):
        scene = load_scene(path)
        (row,) = [line for line in lines if line.startswith(f"{scene.name} ")]
        assert f"{scene.stop_time:g} s" in row
        for name, spec in scene.components.items():
            assert f"{name} ({spec.fmu})" in row
    assert f"{len(list(SCENES.glob('*.toml')))} shipped scenes in {SCENES}" in done.stdout


@pytest.mark.parametrize(
    "texts, expected",
    [
        (["actuator.stroke_time=2.5"], {"actuator.stroke_time": 2.5}),
        (["a.n=3", "a.flag=true"], {"a.n": 3, "a.flag": True}),
        (
            ['a.profile="cycloidal"', "a.law=cycloidal"],
            {"a.profile": "cycloidal", "a.law": "cycloidal"},
        ),
        (["a.x = 1e-3 "], {"a.x": 1e-3}),
        (["a.file=data/x.csv"], {"a.file": "data/x.csv"}),
    ],
)
def test_set_values_read_as_toml_or_as_plain_text(texts, expected):
    assert parse_assignments(texts) == expected


@pytest.mark.parametrize("text", ["stroke_time", "=2", "a.x="])
def test_a_set_without_name_or_value_says_the_form(text):
    with pytest.raises(ValueError, match=r"expected component.parameter=value \(e.g."):
        parse_assignments([text])


@given(
    name=st.from_regex(r"[a-z]{1,8}\.[a-z_]{1,12}", fullmatch=True),
    value=st.floats(allow_nan=False, allow_infinity=False) | st.integers() | st.booleans(),
)
def test_a_number_or_boolean_set_reads_back_as_itself(name, value):
    text = str(value).lower() if isinstance(value, bool) else repr(value)
    assert parse_assignments([f"{name}={text}"]) == {name: value}


def test_run_set_changes_the_run_as_the_api_and_the_closed_form_do(fmu_dir, tmp_path):
    done = run_mechfmu(
        "run",
        "gear_retraction",
        "--set",
        "actuator.stroke_time=2.0",
        "--set",
        "actuator.profile=cycloidal",
        "--check",
        "--no-plot",
        cwd=tmp_path,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    # checked against the closed form of the new parameters, not the scene's own CSV
    assert "against the reference recomputed for --set (declared by the reference: " in done.stdout
    assert "): match: 6 column(s), 301 sample(s)" in done.stdout
    result = read_result(tmp_path / "out" / "gear_retraction.csv")
    parameters = {"actuator.stroke_time": 2.0, "actuator.profile": "cycloidal"}
    assert result.attrs["parameters"] == parameters
    comparison = mechfmu.compare(
        result, mechfmu.reference("gear_retraction", parameters=parameters)
    )
    assert comparison.passed, str(comparison)
    assert result.index[np.argmax(result["gear.gear_angle"].to_numpy())] == pytest.approx(2.0)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (
            ["gear_retraction", "--set", "actuator.stroke_tme=2"],
            "scene error: parameters: 'actuator.stroke_tme': 'actuator' (PistonActuator) has "
            "no parameter 'stroke_tme'; its parameters: end_extension, profile,",
        ),
        (
            ["gear_retraction", "--set", "actuator.stroke_time=fast"],
            "scene error: ",
        ),
        (["gear_retraction", "--set", "stroke_time"], "mechfmu run: error: --set 'stroke_time'"),
        (["--all", "--set", "a.b=1"], "mechfmu run: error: --set changes one scene's parameters"),
        ([], "mechfmu run: error: name a scene (a shipped scene's name, which 'mechfmu scenes'"),
    ],
)
def test_run_errors_say_what_to_do(fmu_dir, tmp_path, capsys, arguments, message):
    assert cli(["run", *arguments, "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith(message)


def test_the_fmu_search_path_and_the_error_listing_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("MECHFMU_FMU_DIR", str(tmp_path / "env"))
    labels = [label for label, _ in locate.search_path()]
    assert labels[0] == "$MECHFMU_FMU_DIR" and labels[1] == "./fmus"
    assert labels[-1] == "the user cache (mechfmu build)"
    folders = dict(locate.search_path())
    assert folders["./fmus"] == tmp_path / "fmus"
    version = f"{sys.version_info[0]}.{sys.version_info[1]}"
    assert (
        folders[labels[-1]] == tmp_path / "cache" / "mechfmu" / f"{mechfmu.__version__}-py{version}"
    )
    assert locate.search_path("given") == [("--fmu-dir", locate.Path("given"))]
    with pytest.raises(SceneError) as caught:
        locate.fmu_folder(["NoSuchModel"], what="scene x")
    message = str(caught.value)
    assert message.startswith("scene x: FMU(s) NoSuchModel.fmu not found in any of the folders")
    for label, folder in locate.search_path():
        assert f"{label}: {folder}" in message
    assert "'mechfmu build'" in message and "--fmu-dir DIR" in message


def test_the_first_folder_holding_every_model_wins(fmu_dir, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MECHFMU_FMU_DIR", raising=False)
    monkeypatch.setattr(locate, "CHECKOUT", None)
    cache = tmp_path / "cache"
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache))
    (tmp_path / "fmus").mkdir()
    os.symlink(fmu_dir / "LandingGear.fmu", tmp_path / "fmus" / "LandingGear.fmu")
    locate.user_cache().mkdir(parents=True)
    for model in ("LandingGear", "PistonActuator"):
        os.symlink(fmu_dir / f"{model}.fmu", locate.user_cache() / f"{model}.fmu")
    assert locate.fmu_folder(["LandingGear"]) == tmp_path / "fmus"
    assert locate.fmu_folder(["LandingGear", "PistonActuator"]) == locate.user_cache()
    frame = mechfmu.simulate("gear_retraction", stop_time=0.1)  # found in the cache
    assert frame.attrs["fmus"]["gear"]["file"] == str(locate.user_cache() / "LandingGear.fmu")


def test_build_writes_into_the_user_cache_and_refuses_unknown_models(tmp_path, monkeypatch, capsys):
    from mechfmu.packaging import build

    built = []
    monkeypatch.setattr(build, "build_all", lambda out, *a, **k: built.append(out) or [])
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cli(["build", "LandingGear"]) == 0 and built == [locate.user_cache()]
    assert cli(["build", "NoSuchModel"]) == 2
    assert capsys.readouterr().err == (
        f"build error: unknown model(s) NoSuchModel; models: {', '.join(MODELS)}\n"
    )
    assert len(built) == 1  # nothing compiled for an unknown name


def test_output_piped_into_a_reader_that_stops_is_quiet():
    command = f"{sys.executable} -m mechfmu docs | head -n 2"
    done = subprocess.run(
        ["bash", "-o", "pipefail", "-c", command], capture_output=True, text=True, timeout=120
    )
    assert done.stdout.startswith("### `LandingGear.fmu`")
    assert done.stderr == "" and done.returncode == 0


def test_fuzz_keeps_its_old_fmus_spelling_as_a_hidden_alias():
    args = parser().parse_args(["fuzz", "--fmus", "somewhere"])
    assert args.fmu_dir == "somewhere"


def test_sims_runner_help_names_the_script():
    done = run_script("run_sweeps.py", "--help", timeout=60)
    assert done.returncode == 0 and done.stdout.startswith("usage: run_sweeps.py [-h]")


LONG = "a" * 300  # a file name over the file system's 255 bytes: os.stat raises ENAMETOOLONG


@pytest.mark.parametrize(
    "arguments, first",
    [
        (["run", LONG], "scene error: scene file "),
        (["run", f"{LONG}/x.toml"], "scene error: scene file "),
        (["sweep", LONG], "sweep error: scene file "),
        (["check", LONG, LONG], "check error: result "),
        (["check", "RESULT", f"{LONG}.csv"], "check error: reference "),
        (["run", "gear_retraction", "--out", LONG], "output error: output folder "),
        (["baseline", "update", LONG, "baselines"], "baseline error: results "),
        (["baseline", "update", "RESULT", LONG], "baseline error: baselines "),
        (["export-ssp", "gear_retraction", f"{LONG}.ssp"], "output error: cannot write "),
        (["example", "gear", "--out", LONG], "output error: output folder "),
    ],
)
def test_a_path_too_long_for_the_file_system_is_one_line_naming_it(
    tmp_path, capsys, arguments, first
):
    # found by make fuzz-inputs (a scene's component named with hundreds of characters):
    # pathlib's exists() and is_file() raise OSError for such a name, which came out as a
    # traceback
    result = tmp_path / "r.csv"
    result.write_text("time,x\n0,1\n")
    status = cli([str(result) if word == "RESULT" else word for word in arguments])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith(first) and err.count("\n") == 1, err
    assert "File name too long" in err and "Traceback" not in err
    assert "...(" in err


def test_a_component_named_beyond_a_file_name_is_a_scene_error(fmu_dir, tmp_path, capsys):
    scene = tmp_path / "long.toml"
    scene.write_text(
        f'stop_time = 1.0\nstep = 0.5\n[components.a]\nfmu = "PistonActuator{"9" * 300}"\n'
    )
    assert cli(["run", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("scene error: scene long: FMU(s) 'PistonActuator999") and "...(" in err
    assert cli(["run", str(scene), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("scene error: component 'a': FMU file ") and "File name too long" in err
    with pytest.raises(SceneError, match="cannot be read: File name too long"):
        mechfmu.simulate(scene, fmu_dir=fmu_dir)


def test_a_result_under_a_file_does_not_exist(tmp_path, capsys):
    """A path through a file (NotADirectoryError) names nothing: "does not exist", as a
    missing file, not "cannot be read"."""
    from mechfmu.cosim import limits

    plain = tmp_path / "plain.csv"
    plain.write_text("time,x\n0,1\n")
    assert limits.path_problem(plain / "under.csv") == "does not exist"
    assert cli(["check", str(plain / "under.csv"), str(plain)]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "Not a directory" not in err, err


def test_an_os_error_no_verb_expected_is_one_line_with_status_1(monkeypatch, capsys):
    def refused(args):
        raise PermissionError(13, "Permission denied", "/" + "b" * 400)

    monkeypatch.setattr("mechfmu.cli._scenes", refused)
    assert cli(["scenes"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("mechfmu scenes: error: Permission denied: '/bbb") and "...(" in err
    assert err.count("\n") == 1


def test_study_refuses_more_workers_than_four_per_core(capsys):
    assert cli(["study", "--workers", "100000"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("study error: --workers = 100000 is more than 4 local worker")


@pytest.mark.parametrize("option", ["--rtol", "--atol", "--time-tolerance"])
@pytest.mark.parametrize("value", ["inf", "nan", "-1"])
def test_check_refuses_a_tolerance_that_is_not_finite_and_non_negative(
    tmp_path, capsys, option, value
):
    # --atol inf passed the command's check and raised a ValueError traceback in compare
    result = tmp_path / "r.csv"
    result.write_text("time,x\n0,1\n")
    extra = ["--method", "tube"] if option == "--time-tolerance" else []
    assert cli(["check", str(result), str(result), option, value, *extra]) == 2
    err = capsys.readouterr().err
    assert err == f"check error: {option} must be a finite number >= 0, got {float(value)!r}\n"
