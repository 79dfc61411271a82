"""The pytest plugin (entry point pytest11): mechfmu_regression writes a missing baseline and
fails, then passes against it, fails with the failing column and time on a change, and
--mechfmu-regen rewrites it. Run in a pytester sandbox, the plugin loaded by its entry point."""

import pytest

from mechfmu.io import read_result

pytest_plugins = ["pytester"]

TEST_FILE = """
import numpy as np
import pandas as pd
import pytest

AMPLITUDE = {amplitude}


def result(amplitude=AMPLITUDE):
    times = np.linspace(0.0, 1.0, 101)
    return pd.DataFrame({{"valve.valve_lift": amplitude * np.sin(np.pi * times),
                         "valve.contact_force": np.where(times < 0.5, 100.0, 0.0)}},
                        index=pd.Index(times, name="time"))


@pytest.mark.parametrize("case", ["a b"])
def test_lift(mechfmu_regression, case):
    comparison = mechfmu_regression.check(result(), rtol=1e-6, atol=1e-9)
    assert comparison.passed


def test_late_force_in_the_tube(mechfmu_regression):
    late = result(1.0)
    late["valve.contact_force"] = np.where(late.index < 0.5 + {delay}, 100.0, 0.0)
    mechfmu_regression.check(late, basename="force", method="{method}", time_tolerance=0.015)
"""


def write(pytester, amplitude=1.0, method="tube", delay=0.0):
    pytester.makepyfile(
        test_valve=TEST_FILE.format(amplitude=amplitude, method=method, delay=delay)
    )


def test_the_plugin_is_loaded_by_its_entry_point(pytester):
    result = pytester.runpytest("--help")
    result.stdout.fnmatch_lines(["*--mechfmu-regen*"])
    result = pytester.runpytest("--fixtures")
    result.stdout.fnmatch_lines(["*mechfmu_regression*"])


def test_first_run_writes_baselines_and_fails_then_passes(pytester):
    write(pytester)
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(
        [("*mechfmu_regression: no baseline yet; wrote *test_valve*test_lift_a_b.csv*")]
    )
    baseline = pytester.path / "test_valve" / "test_lift_a_b.csv"
    stored = read_result(baseline)
    assert list(stored.columns) == ["valve.valve_lift", "valve.contact_force"]
    assert stored.shape == (101, 2)
    assert stored["valve.valve_lift"].max() == pytest.approx(1.0)
    assert (pytester.path / "test_valve" / "force.csv").is_file()
    pytester.runpytest("-p", "no:cacheprovider").assert_outcomes(passed=2)


def test_a_change_fails_naming_column_and_time_and_regen_accepts_it(pytester):
    write(pytester)
    pytester.runpytest("-p", "no:cacheprovider")
    baseline = pytester.path / "test_valve" / "test_lift_a_b.csv"
    write(pytester, amplitude=1.01)
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1, passed=1)
    result.stdout.fnmatch_lines(
        [
            "*differs from the baseline*test_lift_a_b.csv*",
            "*column*time*value*reference*allowed*kind*",
            "*valve.valve_lift*0.01*value*",
            "obtained: * (mechfmu check * --report DIR plots it)",
            "*--mechfmu-regen accepts the new values*",
        ]
    )
    obtained = next(line for line in result.outlines if line.startswith("obtained: "))
    obtained = obtained.split()[1]
    assert read_result(obtained)["valve.valve_lift"].max() == pytest.approx(1.01)
    assert read_result(baseline)["valve.valve_lift"].max() == pytest.approx(1.0)
    result = pytester.runpytest("-p", "no:cacheprovider", "--mechfmu-regen")
    result.assert_outcomes(failed=1, passed=1)
    result.stdout.fnmatch_lines(
        [
            (
                "*--mechfmu-regen: the baseline differed (valve.valve_lift "
                "at t = 0.01 s*; wrote *test_lift_a_b.csv*"
            )
        ]
    )
    assert read_result(baseline)["valve.valve_lift"].max() == pytest.approx(1.01)
    pytester.runpytest("-p", "no:cacheprovider").assert_outcomes(passed=2)


def test_the_late_step_needs_the_tube(pytester):
    write(pytester)
    pytester.runpytest("-p", "no:cacheprovider")
    write(pytester, delay=0.01)  # the force drops one step (10 ms) later
    pytester.runpytest("-p", "no:cacheprovider", "-k", "late").assert_outcomes(passed=1)
    write(pytester, method="pointwise", delay=0.01)
    result = pytester.runpytest("-p", "no:cacheprovider", "-k", "late")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*valve.contact_force*0.5*100.0*0.0*value*"])


def test_an_unreadable_baseline_is_one_line(pytester):
    write(pytester)
    pytester.runpytest("-p", "no:cacheprovider")
    (pytester.path / "test_valve" / "force.csv").write_text("time,valve.contact_force\n0.0,x\n")
    result = pytester.runpytest("-p", "no:cacheprovider", "-k", "late")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            (
                "*force.csv: line 2, column 'valve.contact_force': 'x' is not "
                "a number (--mechfmu-regen rewrites it)*"
            )
        ]
    )
    assert "Traceback" not in result.stdout.str()


DECLARED = """
import numpy as np
import pandas as pd


def test_declared(mechfmu_regression):
    times = np.linspace(0.0, 1.0, 11)
    frame = pd.DataFrame({{"a.x": {amplitude} * np.sin(times)}}, index=pd.Index(times, name="time"))
    frame.attrs["check"] = {{"rtol": 1e-3, "why": "a scene's [check], as simulate carries it"}}
    mechfmu_regression.check(frame)
"""


def test_the_baseline_keeps_the_declared_tolerance_and_the_check_applies_it(pytester):
    """A DataFrame from mechfmu.simulate carries its scene's [check]; the baseline stores it in
    its JSON and later checks apply it (here 1e-3 relative, not the default 1e-9)."""
    pytester.makepyfile(test_declared=DECLARED.format(amplitude=1.0))
    pytester.runpytest("-p", "no:cacheprovider").assert_outcomes(failed=1)  # baseline written
    assert read_result(pytester.path / "test_declared" / "test_declared.csv").attrs["check"][
        "rtol"
    ] == pytest.approx(1e-3)
    pytester.makepyfile(test_declared=DECLARED.format(amplitude=1.0005))
    pytester.runpytest("-p", "no:cacheprovider").assert_outcomes(passed=1)
    pytester.makepyfile(test_declared=DECLARED.format(amplitude=1.002))
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        ["*differs from the baseline*declared by the reference: rtol 0.001*"]
    )
