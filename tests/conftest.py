"""Shared fixtures: the built FMUs and small helpers to run scenes written inline."""

import os
from pathlib import Path

import pytest

from mechfmu.cosim.scene import REFERENCE_DIR, SCENE_DIR, SWEEP_DIR
from mechfmu.packaging.build import build_all
from mechfmu.runtime.models import MODELS

ROOT = Path(__file__).resolve().parent.parent
FMU_DIR = Path(os.environ.get("MECHFMU_FMU_DIR") or ROOT / "fmus")  # make sets it
SCENES = SCENE_DIR  # the shipped scenes (package data)
REFERENCES = REFERENCE_DIR
SWEEPS = SWEEP_DIR


@pytest.fixture(scope="session")
def fmu_dir():
    """fmus/ as built by `make fmus`; built here when missing (e.g. a bare `pytest`)."""
    missing = [name for name in MODELS if not (FMU_DIR / f"{name}.fmu").is_file()]
    if missing:
        build_all(FMU_DIR, missing)
    return FMU_DIR


@pytest.fixture(scope="session")
def fmu3_dir(tmp_path_factory):
    """Every model as an FMI 3.0 FMU (mechfmu build --fmi-version 3), built for this run."""
    folder = tmp_path_factory.mktemp("fmi3")
    build_all(folder, fmi_version=3)
    return folder


@pytest.fixture(scope="session")
def embedded_dir(tmp_path_factory):
    """Every model as an FMI 2.0 FMU with its own Python runtime (mechfmu build
    --embed-python), built for this run."""
    folder = tmp_path_factory.mktemp("embedded")
    build_all(folder, embed_python=True)
    return folder
