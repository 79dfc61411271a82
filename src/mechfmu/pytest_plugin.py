"""pytest plugin (entry point ``pytest11``, loaded once mechfmu is installed): the
``mechfmu_regression`` fixture, a regression check of a result DataFrame against a baseline
CSV stored next to the test.

``mechfmu_regression.check(df)`` compares ``df`` (a DataFrame indexed by time, as
``mechfmu.simulate`` returns) with ``<test folder>/<test module>/<test name>.csv`` using
``mechfmu.compare`` (same tolerances and methods: by default the baseline's own, the
``check`` its JSON carries when the DataFrame came from ``mechfmu.simulate`` of a scene with a
[check] table, else rtol 1e-9, atol 1e-12). Without a baseline, the check writes one
(CSV and its JSON, as ``mechfmu run`` writes them) and fails, so that a new baseline is
looked at before it is trusted: the next run compares with it. ``pytest --mechfmu-regen``
rewrites the baselines that fail (and fails those tests once, naming the files). A failing
check keeps what it obtained as a result CSV in the test's ``tmp_path``, named in the failure
message, for ``mechfmu check OBTAINED BASELINE --report DIR``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    import pandas

    from .comparison import Comparison


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("mechfmu")
    group.addoption(
        "--mechfmu-regen",
        action="store_true",
        default=False,
        help="mechfmu_regression: rewrite the baseline CSVs that fail (the tests "
        "that rewrote one fail once)",
    )


class MechfmuRegression:
    """The ``mechfmu_regression`` fixture's object: ``check(df)`` and ``path()``."""

    def __init__(self, request: pytest.FixtureRequest) -> None:
        self.request = request
        self.regen = bool(request.config.getoption("mechfmu_regen"))

    def path(self, basename: str | None = None) -> Path:
        """Where the baseline lives: ``<test folder>/<test module>/<basename>.csv``;
        ``basename`` defaults to the test's name (parameters included, characters other
        than letters, digits, ``.``, ``-`` and ``_`` replaced by ``_``)."""
        name = basename or self.request.node.name
        name = re.sub(r"[^\w.-]+", "_", name).strip("_") or "baseline"
        module = Path(self.request.path)
        return module.parent / module.stem / f"{name}.csv"

    def obtained_path(self, baseline: Path) -> Path:
        """Where a failing check keeps the values it obtained: the test's own temporary
        folder (pytest's ``tmp_path``), under the baseline's name."""
        folder = self.request.getfixturevalue("tmp_path")
        return Path(folder) / baseline.name

    def check(
        self,
        data: pandas.DataFrame,
        *,
        basename: str | None = None,
        rtol: float | None = None,
        atol: float | None = None,
        method: str | None = None,
        time_tolerance: float | None = None,
        tolerances: Mapping[str, Any] | None = None,
        interpolate: bool = False,
    ) -> Comparison:
        """Compare ``data`` with its baseline (see the module docstring); the keywords are
        ``mechfmu.compare``'s. Fails the test, with the failures table, on a mismatch; writes
        the baseline and fails when there is none; returns the Comparison when it passes."""
        from .comparison import compare
        from .io import ResultFileError, read_result, write_result

        path = self.path(basename)

        def write(reason: str) -> None:
            try:
                write_result(data, path)
            except ValueError as error:
                pytest.fail(
                    f"mechfmu_regression: cannot store the baseline {path}: {error}", pytrace=False
                )
            pytest.fail(
                f"mechfmu_regression: {reason}; wrote {path}: look at it, commit it "
                f"and run the test again",
                pytrace=False,
            )

        if not path.exists():
            write("no baseline yet")
        try:
            baseline = read_result(path)
        except ResultFileError as error:
            if self.regen:
                write(f"the baseline was unreadable ({error})")
            pytest.fail(f"mechfmu_regression: {error} (--mechfmu-regen rewrites it)", pytrace=False)
        comparison = compare(
            data,
            baseline,
            rtol=rtol,
            atol=atol,
            method=method,  # type: ignore[arg-type]
            time_tolerance=time_tolerance,
            tolerances=tolerances,
            interpolate=interpolate,
        )
        if comparison.passed:
            return comparison
        if self.regen:
            write(f"--mechfmu-regen: the baseline differed ({comparison.first_failure()})")
        table = comparison.failures.to_string(index=False)
        obtained = self.obtained_path(path)
        try:
            write_result(data, obtained)
            kept = f"\nobtained: {obtained} (mechfmu check {obtained} {path} --report DIR plots it)"
        except (ValueError, OSError):
            kept = ""
        pytest.fail(
            f"mechfmu_regression: differs from the baseline {path} ({comparison.method}, "
            f"{comparison.tolerance_text()}):\n{table}{kept}\n(pytest --mechfmu-regen "
            f"accepts the new values)",
            pytrace=False,
        )
        raise AssertionError("unreachable")  # pytest.fail raises


@pytest.fixture
def mechfmu_regression(request: pytest.FixtureRequest) -> MechfmuRegression:
    """Regression check of a result DataFrame against a baseline CSV next to the test:
    ``mechfmu_regression.check(df)``; ``pytest --mechfmu-regen`` rewrites failing ones."""
    return MechfmuRegression(request)
