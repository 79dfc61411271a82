"""The exit-time use-after-free fix applied to pythonfmu's (FMI 2.0) and pythonfmu3's (FMI 3.0)
Linux binary in every FMU."""

import zipfile

import pytest

from mechfmu.packaging.binary_patch import (
    ENDBR64,
    RET,
    SYMBOL,
    find_symbol_offset,
    patch_exit_finaliser,
)
from mechfmu.packaging.build import PLATFORM_FOLDER, pythonfmu_library_name
from mechfmu.runtime.models import MODELS


def _binary(fmu_dir, model, fmi_version=2):
    """pythonfmu's (pythonfmu3's) library inside the FMU (behind the C loader, see build.py)."""
    with zipfile.ZipFile(fmu_dir / f"{model}.fmu") as archive:
        return archive.read(
            f"binaries/{PLATFORM_FOLDER[fmi_version]}/{pythonfmu_library_name(model)}"
        )


@pytest.mark.parametrize("model", list(MODELS))
def test_every_fmu_binary_has_the_exit_finaliser_disabled(fmu_dir, model):
    elf = _binary(fmu_dir, model)
    offset = find_symbol_offset(elf, SYMBOL)
    assert offset is not None
    assert elf[offset : offset + 4] == ENDBR64 and elf[offset + 4] == RET


@pytest.mark.parametrize("model", list(MODELS))
def test_every_fmi3_fmu_binary_has_the_exit_finaliser_disabled(fmu3_dir, model):
    """pythonfmu3's library has the same use-after-free (valgrind: finalizePythonInterpreter
    decrementing a count in the block the C++ exit handlers freed; a CI run aborted with
    "free(): corrupted unsorted chunks" at the exit of a process that had run every FMI 3.0
    FMU): its first instruction, push %rbx, is a return."""
    elf = _binary(fmu3_dir, model, 3)
    offset = find_symbol_offset(elf, SYMBOL)
    assert offset is not None
    assert elf[offset] == RET and elf[offset + 1 : offset + 4] == bytes.fromhex("488b1d")
    original = bytearray(elf)
    original[offset] = 0x53  # push %rbx, as pythonfmu3 0.3.4 ships it
    again, message = patch_exit_finaliser(bytes(original))
    assert message.endswith("made a no-op (pythonfmu3 0.3.4)") and again == elf
    assert patch_exit_finaliser(elf) == (elf, "already patched")


def test_patch_changes_one_byte_and_is_idempotent(fmu_dir):
    patched = _binary(fmu_dir, "LandingGear")
    offset = find_symbol_offset(patched, SYMBOL)
    original = bytearray(patched)
    original[offset + 4] = 0x55  # push %rbp, as pythonfmu 0.7 ships it
    again, message = patch_exit_finaliser(bytes(original))
    assert "made a no-op" in message and again == patched
    assert sum(a != b for a, b in zip(again, original)) == 1
    assert patch_exit_finaliser(patched) == (patched, "already patched")


def test_unknown_code_is_left_alone(fmu_dir):
    elf = bytearray(_binary(fmu_dir, "LandingGear"))
    offset = find_symbol_offset(bytes(elf), SYMBOL)
    elf[offset + 4] = 0x90
    untouched, message = patch_exit_finaliser(bytes(elf))
    assert untouched == bytes(elf) and "left as built" in message
    assert patch_exit_finaliser(b"not an elf")[1].endswith("left as built")
