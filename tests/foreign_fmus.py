"""The suite's own foreign FMUs: small C co-simulation FMUs (tests/foreign_fmus/), FMI 2.0 and
3.0, compiled with the system C compiler and zipped with their model descriptions."""

import os
import shlex
import shutil
import subprocess
import zipfile
from pathlib import Path

from fmpy import platform as fmi2_platform
from fmpy import platform_tuple as fmi3_platform

from mechfmu.packaging.build import fmi_headers

SOURCES = Path(__file__).resolve().parent / "foreign_fmus"
MODELS = {"TestSignals": "TEST_SIGNALS", "TestStair": "TEST_STAIR"}


def build_foreign_fmus(folder):
    """Build every model for FMI 2.0 and 3.0 into ``folder``/fmi2 and ``folder``/fmi3; return
    {(version, model): path of the .fmu}."""
    compiler = shlex.split(os.environ.get("CC") or "cc")
    assert shutil.which(compiler[0]), f"no C compiler {compiler[0]!r} for the test FMUs"
    built = {}
    for version, platform in ((2, fmi2_platform), (3, fmi3_platform)):
        out = Path(folder) / f"fmi{version}"
        out.mkdir(parents=True, exist_ok=True)
        for model, define in MODELS.items():
            library = out / f"{model}.so"
            done = subprocess.run(
                [
                    *compiler,
                    "-shared",
                    "-fPIC",
                    "-O2",
                    "-Wall",
                    "-Wextra",
                    f"-D{define}",
                    f"-I{fmi_headers()}",
                    str(SOURCES / f"fmi{version}.c"),
                    "-o",
                    str(library),
                ],
                capture_output=True,
                text=True,
            )
            assert done.returncode == 0 and done.stderr == "", done.stderr
            fmu = out / f"{model}.fmu"
            with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as archive:
                archive.write(SOURCES / f"{model}{version}.xml", "modelDescription.xml")
                archive.write(library, f"binaries/{platform}/{model}.so")
            built[version, model] = fmu
    return built
