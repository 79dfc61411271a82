"""An FMU file checked before anything loads it.

fmpy trusts the file it is given: a truncated archive ends in a zipfile traceback, and a
truncated shared library inside a valid archive is mapped by the dynamic loader beyond the
end of the file, which kills the process with SIGBUS. ``checked_description`` looks first:
the archive reads (every member's checksum), modelDescription.xml is there and parses, the
FMU offers co-simulation, the binary for this platform is there, and on Linux each shared
library under it is a complete ELF file for this machine (every segment the loader maps
lies inside the file). Every failure is an FmuError naming the file and the cause.
"""

from __future__ import annotations

from typing import Any
from typing import TYPE_CHECKING
import platform
import struct
import sys
import zipfile
import zlib

from fmpy import platform as fmi2_platform
from fmpy import platform_tuple as fmi3_platform
from fmpy import read_model_description, sharedLibraryExtension

from .scene import SceneError

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from fmpy.model_description import ModelDescription


class FmuError(SceneError):
    """An FMU file that cannot be loaded; the message names the file and the cause."""


def checked_description(path: str) -> ModelDescription:
    """fmpy's ModelDescription of the FMU at ``path`` after the checks of this module."""

    def refuse(cause: Any):
        raise FmuError(f"{path} is not a valid FMU: {cause}")

    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, EOFError, ValueError) as error:
        refuse(f"not a zip archive ({error})")
    with archive:
        try:
            damaged = archive.testzip()
        except (
            zipfile.BadZipFile,
            OSError,
            EOFError,
            zlib.error,
            ValueError,
            NotImplementedError,
        ) as error:
            refuse(f"the archive cannot be read ({error})")
        if damaged is not None:
            refuse(f"member {damaged} is damaged (its checksum does not match)")
        names = archive.namelist()
        if "modelDescription.xml" not in names:
            refuse("it has no modelDescription.xml")
        try:
            description = read_model_description(str(path))
        except Exception as error:  # lxml, fmpy's own checks: any of them means unreadable
            refuse(f"its modelDescription.xml cannot be read: {error}")
        if description.coSimulation is None:
            refuse("it does not support co-simulation (no <CoSimulation> element)")
        folder = f"binaries/{binary_folder(description.fmiVersion)}/"
        binary = f"{folder}{description.coSimulation.modelIdentifier}{sharedLibraryExtension}"
        if binary not in names:
            offered = [
                name for name in names if name.startswith("binaries/") and not name.endswith("/")
            ]
            refuse(
                f"it has no binary for this platform ({binary}); it has: "
                f"{', '.join(offered) or 'no binaries'}"
            )
        if sys.platform.startswith("linux"):
            for name in names:
                if name.startswith(folder) and name.endswith(".so"):
                    problem = elf_problem(archive.read(name))
                    if problem:
                        refuse(f"its binary {name} {problem}")
    return description


def binary_folder(fmi_version: str) -> str:
    """The folder under binaries/ of this platform's binary for FMI ``fmi_version`` (FMI
    2.0: linux64, win64 ...; FMI 3.0: x86_64-linux, x86_64-windows ...)."""
    return fmi3_platform if fmi_version.startswith("3") else fmi2_platform


# e_machine of the ELF header for the machines Python reports (platform.machine())
_MACHINES = {
    "x86_64": 62,
    "amd64": 62,
    "aarch64": 183,
    "arm64": 183,
    "i386": 3,
    "i686": 3,
    "armv7l": 40,
    "ppc64le": 21,
    "s390x": 22,
    "riscv64": 243,
}
_ET_DYN, _PT_LOAD = 3, 1


def elf_problem(data: bytes) -> str | None:
    """Why ``data`` is not a complete ELF shared library for this machine, or None.

    Reads the ELF header (class, byte order, type, machine), then checks that the program
    headers, every loadable segment and the section headers lie inside the data: a file cut
    short fails here instead of in the dynamic loader, which would map its missing end.
    """
    if len(data) < 16 or data[:4] != b"\x7fELF":
        return "is not an ELF shared library (no ELF header)"
    word_size, byte_order = data[4], {1: "<", 2: ">"}.get(data[5])
    if word_size not in (1, 2) or byte_order is None:
        return "is not an ELF shared library (unknown class or byte order)"
    bits = 64 if word_size == 2 else 32
    if bits != (64 if sys.maxsize > 2**32 else 32):
        return f"is a {bits}-bit library; this Python is {64 if bits == 32 else 32}-bit"
    header = byte_order + ("HHIQQQIHHHHHH" if bits == 64 else "HHIIIIIHHHHHH")
    if len(data) < 16 + struct.calcsize(header):
        return f"is truncated ({len(data)} bytes: not even a whole ELF header)"
    (
        kind,
        machine,
        _,
        _,
        program_offset,
        section_offset,
        _,
        _,
        program_size,
        program_count,
        section_size,
        section_count,
        _,
    ) = struct.unpack_from(header, data, 16)
    if kind != _ET_DYN:
        return f"is not an ELF shared library (ELF type {kind}, expected {_ET_DYN})"
    expected = _MACHINES.get(platform.machine().lower())
    if expected is not None and machine != expected:
        return (
            f"is built for another machine (ELF machine {machine}; this is "
            f"{platform.machine()}, {expected})"
        )
    extents = [
        ("its program headers", program_offset, program_size * program_count),
        ("its section headers", section_offset, section_size * section_count),
    ]
    segment = byte_order + ("IIQQQQQQ" if bits == 64 else "IIIIIIII")
    if program_offset + program_size * program_count <= len(data):
        for index in range(program_count):
            fields = struct.unpack_from(segment, data, program_offset + index * program_size)
            kind, offset, size = (
                (fields[0], fields[2], fields[5])
                if bits == 64
                else (fields[0], fields[1], fields[4])
            )
            if kind == _PT_LOAD:
                extents.append((f"its loadable segment {index}", offset, size))
    for what, offset, size in extents:
        if offset + size > len(data):
            return (
                f"is truncated: {what} end at byte {offset + size}, the file has {len(data)} bytes"
            )
    return None
