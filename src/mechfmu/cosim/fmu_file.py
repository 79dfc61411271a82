"""An FMU file checked before anything loads it, and unpacked only after the checks.

fmpy trusts the file it is given: a truncated archive ends in a zipfile traceback, a member
named ``/abs/path`` in a bare Exception from fmpy.extract, a member of 2 GB packed into 2 MB
(a zip bomb) is unpacked in full, and a truncated shared library inside a valid archive is
mapped by the dynamic loader beyond the end of the file, which kills the process with
SIGBUS. ``checked_description`` looks first, without unpacking anything: every member's
name (relative, no '..', no drive, no backslash, no NUL, no link, no duplicate) and declared
size and compression ratio against mechfmu.cosim.limits, the archive's checksums, then
modelDescription.xml is there and parses, the FMU offers co-simulation, the binary for this
platform is there, a PythonFMU FMU holds the Python module its binary imports, and on Linux
each shared library under it is a complete ELF file for this machine (its headers read by
streaming; every segment the loader maps lies inside the declared size). Every failure is an
FmuError naming the file and the cause.

``unpack`` repeats the member checks on the archive it opens, checks the free space, and
unpacks into a new folder of the temporary directory, ``mechfmu_unpack_<pid>_<host>_...``
with a marker file: removed on any failure (a full disk included) and by its user on every
exit path; one left by a killed process is removed by the next process that unpacks
(``remove_stale_unpacks``: only folders with our marker, of this machine, whose process is
gone).
"""

from __future__ import annotations

import os
import platform
import shutil
import stat
import struct
import sys
import tempfile
import zipfile
import zlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmpy import platform as fmi2_platform
from fmpy import platform_tuple as fmi3_platform
from fmpy import read_model_description, sharedLibraryExtension

from . import limits
from .files import HOST_TAG, process_alive
from .scene import SceneError
from .text import joined_lines

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from fmpy.model_description import ModelDescription


class FmuError(SceneError):
    """An FMU file that cannot be loaded; the message names the file and the cause."""


_READ_ERRORS = (zipfile.BadZipFile, OSError, EOFError, zlib.error, ValueError, NotImplementedError)


def name_problem(name: str) -> str | None:
    """Why the archive member ``name`` could land outside the folder it is unpacked into,
    or collide there, or None."""
    if "\x00" in name:
        return "holds a NUL character"
    if "\\" in name:
        return "holds a backslash (a Windows path separator; a zip path uses '/')"
    if ":" in name:
        return "holds a colon (a drive letter or a Windows stream)"
    if name.startswith("/"):
        return "is an absolute path"
    size = len(name.encode("utf-8", "surrogatepass"))
    if size > limits.MAX_ENTRY_NAME_BYTES:
        return f"is a path of {size} bytes, more than the limit of {limits.MAX_ENTRY_NAME_BYTES}"
    parts = name[:-1].split("/") if name.endswith("/") else name.split("/")
    for part in parts:
        if part in ("", ".", ".."):
            return f"holds a path part {part!r} ('..', '.' or empty)"
        if len(part.encode("utf-8", "surrogatepass")) > 255:
            return "holds a path part longer than 255 bytes"
    return None


def _kind_problem(info: zipfile.ZipInfo) -> str | None:
    """Why the member is not a plain file or folder (a link, a device, a FIFO), or None."""
    if info.create_system != 3:  # only Unix archives record a file type
        return None
    mode = info.external_attr >> 16
    if not stat.S_IFMT(mode) or stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None  # no file type (zipfile's writestr records permissions only), a file, a folder
    return "is a symbolic link" if stat.S_ISLNK(mode) else "is not a plain file or folder"


def members_problem(infos: list[zipfile.ZipInfo]) -> str | None:
    """Why the members ``infos`` of an archive must not be unpacked, or None: too many, a
    name that would land outside the folder or clash with another, a link, a declared size
    or compression ratio beyond mechfmu.cosim.limits. Reads nothing but the directory."""
    if len(infos) > limits.MAX_FMU_ENTRIES:
        return f"it has {len(infos)} members, more than the limit of {limits.MAX_FMU_ENTRIES}"
    files: set[str] = set()
    folders: set[str] = set()
    total = 0
    for info in infos:
        shown = limits.shortened(info.filename, 100)
        problem = name_problem(info.filename) or _kind_problem(info)
        if problem:
            return f"member {shown} {problem}"
        name = info.filename.rstrip("/")
        if name in files or name in folders:
            return f"member {shown} appears twice"
        (folders if info.is_dir() else files).add(name)
        if info.file_size > limits.MAX_ENTRY_BYTES:
            return (
                f"member {shown} unpacks to {info.file_size} bytes, more than the limit of "
                f"{limits.MAX_ENTRY_BYTES} bytes for one member"
            )
        if (
            info.file_size > limits.RATIO_FLOOR
            and info.file_size > limits.MAX_COMPRESSION_RATIO * max(info.compress_size, 1)
        ):
            return (
                f"member {shown} unpacks to {info.file_size} bytes from "
                f"{info.compress_size}: a compression ratio above the limit of "
                f"{limits.MAX_COMPRESSION_RATIO} (a zip bomb?)"
            )
        total += info.file_size
    if total > limits.MAX_UNPACKED_BYTES:
        return (
            f"its members unpack to {total} bytes, more than the limit of "
            f"{limits.MAX_UNPACKED_BYTES} bytes"
        )
    for name in files:
        parent = name.rpartition("/")[0]
        while parent:
            if parent in files:
                return f"member {limits.shortened(parent, 100)} is both a file and a folder"
            parent = parent.rpartition("/")[0]
    return None


def checked_description(path: str) -> ModelDescription:
    """fmpy's ModelDescription of the FMU at ``path`` after the checks of this module."""

    def refuse(cause: Any):
        raise FmuError(f"{path} is not a valid FMU: {cause}")

    problem = limits.file_problem(path, limits.MAX_UNPACKED_BYTES)
    if problem:
        refuse(problem)
    try:
        archive = zipfile.ZipFile(path)
    except _READ_ERRORS as error:
        refuse(f"not a zip archive ({error})")
    with archive:
        infos = archive.infolist()
        problem = members_problem(infos)
        if problem:
            refuse(problem)
        try:
            damaged = archive.testzip()
        except _READ_ERRORS as error:
            refuse(f"the archive cannot be read ({error})")
        if damaged is not None:
            refuse(f"member {damaged} is damaged (its checksum does not match)")
        sizes = {info.filename: info.file_size for info in infos}
        if "modelDescription.xml" not in sizes:
            refuse("it has no modelDescription.xml")
        if sizes["modelDescription.xml"] > limits.MAX_MODEL_DESCRIPTION_BYTES:
            refuse(
                f"its modelDescription.xml is {sizes['modelDescription.xml']} bytes, more "
                f"than the limit of {limits.MAX_MODEL_DESCRIPTION_BYTES}"
            )
        try:
            description = read_model_description(str(path))
        except Exception as error:  # lxml, fmpy's own checks: any of them means unreadable
            refuse(f"its modelDescription.xml cannot be read: {limits.shortened(str(error), 300)}")
        if description.coSimulation is None:
            refuse("it does not support co-simulation (no <CoSimulation> element)")
        folder = f"binaries/{binary_folder(description.fmiVersion)}/"
        binary = f"{folder}{description.coSimulation.modelIdentifier}{sharedLibraryExtension}"
        if binary not in sizes:
            offered = [
                name for name in sizes if name.startswith("binaries/") and not name.endswith("/")
            ]
            refuse(
                f"it has no binary for this platform ({binary}); it has: "
                f"{', '.join(offered) or 'no binaries'}"
            )
        problem = _pythonfmu_problem(archive, description, sizes)
        if problem:
            refuse(problem)
        if sys.platform.startswith("linux"):
            for name, size in sizes.items():
                if name.startswith(folder) and name.endswith(".so"):
                    try:
                        with archive.open(name) as member:
                            problem = elf_problem(member, size)
                    except _READ_ERRORS as error:
                        refuse(f"its binary {name} cannot be read ({error})")
                    if problem:
                        refuse(f"its binary {name} {problem}")
    return description


def binary_folder(fmi_version: str) -> str:
    """The folder under binaries/ of this platform's binary for FMI ``fmi_version`` (FMI
    2.0: linux64, win64 ...; FMI 3.0: x86_64-linux, x86_64-windows ...)."""
    return fmi3_platform if fmi_version.startswith("3") else fmi2_platform


_SLAVE_MODULE = "resources/slavemodule.txt"


def _pythonfmu_problem(
    archive: zipfile.ZipFile, description: ModelDescription, sizes: dict[str, int]
) -> str | None:
    """For an FMU made with pythonfmu (its generation tool, or its slavemodule.txt): why
    its binary would not find the Python module it imports, or the module would not
    compile, or None. Without that module pythonfmu's library crashes the host process
    (SIGSEGV in fmi2Instantiate), and after an entry module that does not compile the host
    aborts later, where a module that fails to import is reported in the FMU's log."""
    made_by_pythonfmu = str(description.generationTool or "").startswith("PythonFMU")
    if not made_by_pythonfmu and _SLAVE_MODULE not in sizes:
        return None
    if _SLAVE_MODULE not in sizes:
        return f"it is a PythonFMU FMU without {_SLAVE_MODULE} (the module its binary imports)"
    if sizes[_SLAVE_MODULE] > 4096:
        return f"its {_SLAVE_MODULE} is {sizes[_SLAVE_MODULE]} bytes (a module name is expected)"
    try:
        module = archive.read(_SLAVE_MODULE).decode("utf-8").strip()
    except (UnicodeDecodeError, *_READ_ERRORS) as error:
        return f"its {_SLAVE_MODULE} cannot be read ({error})"
    if not module or not all(part.isidentifier() for part in module.split(".")):
        return f"its {_SLAVE_MODULE} names no Python module: {limits.shortened(module)}"
    path = "resources/" + module.replace(".", "/")
    source = next((p for p in (f"{path}.py", f"{path}/__init__.py") if p in sizes), None)
    if source is None:
        return f"its {_SLAVE_MODULE} names the module {module}, which is not in its resources"
    # pythonfmu's loader releases a reference it only borrowed, which mechfmu's entry
    # modules take back first thing (packaging.build); an entry module that does not even
    # compile leaves the interpreter's count short, and the host crashes later (SIGABRT)
    if sizes[source] > limits.MAX_TOML_BYTES:
        return f"its entry module {source} is {sizes[source]} bytes (more than 1 MiB)"
    try:
        compile(archive.read(source), source, "exec", dont_inherit=True)
    except (SyntaxError, ValueError) as error:
        return f"its entry module {source} does not compile: {joined_lines(str(error))}"
    except _READ_ERRORS as error:
        return f"its entry module {source} cannot be read ({error})"
    return None


# --- unpacking ------------------------------------------------------------------------------

UNPACK_PREFIX = "mechfmu_unpack_"
UNPACK_MARKER = ".mechfmu-unpack"  # in every unpack folder: what the cleaning recognises
_cleaned = False  # stale unpack folders are looked for once per process


def _unpack_owner(folder: Path) -> int | None:
    """The process id of the unpack folder ``folder`` of this machine (its name and marker
    say so), or None when it is not one of ours."""
    parts = folder.name[len(UNPACK_PREFIX) :].split("_")
    if not folder.name.startswith(UNPACK_PREFIX) or len(parts) < 3 or not parts[0].isdigit():
        return None
    if parts[1] != HOST_TAG or not (folder / UNPACK_MARKER).is_file():
        return None
    return int(parts[0])


def remove_stale_unpacks(root: Path | str | None = None) -> list[Path]:
    """Remove the unpack folders in ``root`` (default: the temporary directory) that a
    process of this machine left when it was killed (its id no longer runs); returns them."""
    root = Path(root or tempfile.gettempdir())
    removed = []
    try:
        candidates = [entry for entry in root.iterdir() if entry.name.startswith(UNPACK_PREFIX)]
    except OSError:
        return []
    for folder in candidates:
        owner = _unpack_owner(folder)
        if owner is not None and not process_alive(owner):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def unpack(path: Path | str) -> Path:
    """Unpack the FMU at ``path`` into a new folder of the temporary directory and return
    it; the caller removes it (shutil.rmtree). The members are checked first
    (members_problem) and their total against the free space (less FREE_SPACE_MARGIN);
    FmuError naming the file and the cause otherwise, or when unpacking fails (a full
    disk): the folder is then removed before the error is raised."""
    global _cleaned
    if not _cleaned:
        _cleaned = True
        remove_stale_unpacks()
    root = Path(tempfile.gettempdir())
    try:
        archive = zipfile.ZipFile(path)
    except _READ_ERRORS as error:
        raise FmuError(f"{path} is not a valid FMU: not a zip archive ({error})") from None
    with archive:
        infos = archive.infolist()
        problem = members_problem(infos)
        if problem:
            raise FmuError(f"{path} is not a valid FMU: {problem}")
        needed = sum(info.file_size for info in infos)
        try:
            free = shutil.disk_usage(root).free
        except OSError as error:
            raise FmuError(f"{path} cannot be unpacked into {root}: {error.strerror}") from None
        if needed + limits.FREE_SPACE_MARGIN > free:
            raise FmuError(
                f"{path} cannot be unpacked into {root}: it needs {needed} bytes and "
                f"{limits.FREE_SPACE_MARGIN} more kept free, the file system has {free} "
                f"bytes free (set TMPDIR to a folder with more space)"
            )
        try:
            folder = Path(
                tempfile.mkdtemp(prefix=f"{UNPACK_PREFIX}{os.getpid()}_{HOST_TAG}_", dir=root)
            )
        except OSError as error:
            raise FmuError(f"{path} cannot be unpacked into {root}: {error.strerror}") from None
        try:
            (folder / UNPACK_MARKER).write_text(
                f"mechfmu: {path} unpacked by process {os.getpid()}\n"
            )
            for info in infos:
                target = folder.joinpath(*info.filename.rstrip("/").split("/"))
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                with archive.open(info) as member, open(target, "xb") as copy:
                    shutil.copyfileobj(member, copy, 1 << 20)
        except BaseException as error:
            shutil.rmtree(folder, ignore_errors=True)
            if isinstance(error, _READ_ERRORS):
                cause = getattr(error, "strerror", None) or error
                raise FmuError(f"{path} cannot be unpacked into {folder}: {cause}") from None
            raise
    return folder


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


def elf_problem(stream: Any, size: int) -> str | None:
    """Why the file of ``size`` bytes that the binary ``stream`` reads is not a complete ELF
    shared library for this machine, or None.

    Reads the ELF header (class, byte order, type, machine) and the program headers from the
    stream (within their first MAX_ELF_HEADERS_BYTES: never the whole file), then checks
    that the program headers, every loadable segment and the section headers lie inside
    ``size``: a file cut short fails here instead of in the dynamic loader, which would map
    its missing end.
    """
    data = stream.read(64)
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
    program_end = program_offset + program_size * program_count
    extents = [
        ("its program headers", program_offset, program_size * program_count),
        ("its section headers", section_offset, section_size * section_count),
    ]
    segment = byte_order + ("IIQQQQQQ" if bits == 64 else "IIIIIIII")
    if program_end <= size:
        if program_end > limits.MAX_ELF_HEADERS_BYTES:
            return (
                f"has its program headers at bytes {program_offset} to {program_end}, "
                f"beyond the limit of {limits.MAX_ELF_HEADERS_BYTES} (not a library we load)"
            )
        if program_count and program_size < struct.calcsize(segment):
            return f"is not an ELF shared library (program header size {program_size})"
        if program_end > len(data):
            data += stream.read(program_end - len(data))
        if program_end > len(data):  # the stream is shorter than its declared size
            return f"is truncated: its program headers end at byte {program_end}"
        for index in range(program_count):
            fields = struct.unpack_from(segment, data, program_offset + index * program_size)
            kind, offset, length = (
                (fields[0], fields[2], fields[5])
                if bits == 64
                else (fields[0], fields[1], fields[4])
            )
            if kind == _PT_LOAD:
                extents.append((f"its loadable segment {index}", offset, length))
    for what, offset, length in extents:
        if offset + length > size:
            return f"is truncated: {what} end at byte {offset + length}, the file has {size} bytes"
    return None
