"""Every file mechfmu writes: atomically, inside its output folder, with the umask's permissions.

One writer for the whole package (results, sweeps, reports, references, SSP packages, built
FMUs). A file's content is made in memory first (text, bytes, or a callback writing to a
handle), written to a new temporary file beside its destination and renamed over it, so a
reader sees the old file or the new one, never half of one. A group of files (a result's CSV
and JSON) is written all or none: every temporary file is complete before the first rename.
The temporary file is created with mode 0666 minus the umask, as ``open()`` would create the
file itself (``tempfile.mkstemp`` would give 0600). A full disk or any other OSError becomes
an OutputError whose one-line message names the file and the cause; nothing half-written is
left behind.

A writer killed mid-write (SIGKILL, a power cut) cannot remove its temporary files. Their
names say whose they are, ``.<name>.<pid>.<host>.<random>.tmp`` (``host``: 8 hex digits of
the machine's name), and ``output_folder`` removes those of this machine whose process is
gone (``stale_temporaries``); those of a live writer, of another machine or not ours are
left alone.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import contextlib
import hashlib
import io
import os
import re
import secrets
import socket
from pathlib import Path
from typing import Any
from collections.abc import Callable, Iterator

from . import limits

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from matplotlib.figure import Figure

MAX_NAME_LENGTH = 200  # characters of a result's name; a file name holds at most 255 bytes


class OutputError(RuntimeError):
    """An output file or folder that cannot be written; the message names it and the cause."""


def error_cause(error: OSError) -> str:
    """'[Errno 28] No space left on device' without the file name OSError appends."""
    if isinstance(error, OSError) and error.strerror:
        return f"[Errno {error.errno}] {error.strerror}" if error.errno else error.strerror
    return str(error)


def plain_file_name(name: str) -> str | None:
    """The reason ``name`` is not a plain file name (one path component that is not hidden),
    or None if it is one."""
    if not isinstance(name, str) or not name:
        return "it is empty"
    if name in (".", ".."):
        return "it names a folder"
    if "/" in name or "\\" in name or (os.altsep and os.altsep in name):
        return "it contains a path separator"
    if name.startswith("."):
        return "it starts with a dot (a hidden file)"
    if any(ord(character) < 32 or character == "\x7f" for character in name):
        return "it contains a control character"
    if len(name) > MAX_NAME_LENGTH:
        return f"it is longer than {MAX_NAME_LENGTH} characters"
    return None


def output_folder(folder: Path | str) -> Path:
    """``folder`` as a Path, created with its parents if missing, after checking that files
    can be created in it (a probe file, created and removed): OutputError otherwise. The
    temporary files that killed writers left there are removed (remove_stale_temporaries).

    Call it before any work whose results go there, so a bad --out costs nothing.
    """
    folder = Path(folder)
    problem = limits.path_problem(folder)
    if problem not in (None, "does not exist"):  # a name too long, a parent not searchable
        raise OutputError(f"output folder {limits.message_text(folder)} {problem}")
    if problem is None and not folder.is_dir():
        raise OutputError(f"output folder {folder} is not a directory")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OutputError(
            f"output folder {folder} cannot be created: {error_cause(error)}"
        ) from None
    probe = folder / temporary_name("mechfmu-probe")
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        os.unlink(probe)
    except OSError as error:
        raise OutputError(f"output folder {folder} is not writable: {error_cause(error)}") from None
    remove_stale_temporaries(folder)
    return folder


def inside(folder: Path, name: str) -> Path:
    """folder / name, or OutputError unless it is a file directly inside ``folder`` (after
    resolving '..' and symbolic links of the folder)."""
    folder = Path(folder)
    path = folder / name
    if (
        plain_file_name(Path(name).name)
        or Path(name).name != str(name)
        or path.resolve().parent != folder.resolve()
    ):
        raise OutputError(f"{name!r} would be written outside the output folder {folder}")
    return path


def _content_bytes(content: Callable | bytes | str, path: Path) -> bytes:
    """The bytes of ``content``: str (UTF-8), bytes, or a callable writing text to a handle."""
    if callable(content):
        handle = io.StringIO(newline="")
        content(handle)
        content = handle.getvalue()
    if isinstance(content, str):
        return content.encode("utf-8")
    if isinstance(content, (bytes, bytearray, memoryview)):
        return bytes(content)
    raise TypeError(
        f"{path}: content must be str, bytes or a callable, got {type(content).__name__}"
    )


HOST_TAG = hashlib.sha256(socket.gethostname().encode("utf-8", "replace")).hexdigest()[:8]
_TEMPORARY = re.compile(r"^\..*\.(\d+)\.([0-9a-f]{8})\.[0-9a-f]{12}\.tmp$", re.DOTALL)


def temporary_name(name: str) -> str:
    """The name of a temporary file for ``name``: hidden, this process's id and machine tag,
    random; the part of ``name`` it repeats is cut to 180 characters (a file name holds 255
    bytes)."""
    return f".{name[:180]}.{os.getpid()}.{HOST_TAG}.{secrets.token_hex(6)}.tmp"


def process_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this machine (another user's counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except (OSError, OverflowError):
        return False
    return True


def stale_temporaries(folder: Path) -> list[Path]:
    """The temporary files in ``folder`` left by writers of this machine that are gone."""
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    stale = []
    for name in names:
        match = _TEMPORARY.match(name)
        if match and match.group(2) == HOST_TAG and not process_alive(int(match.group(1))):
            stale.append(Path(folder) / name)
    return stale


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Remove stale_temporaries(folder) (those that vanish meanwhile are skipped); returns
    the paths removed."""
    removed = []
    for path in stale_temporaries(folder):
        try:
            os.unlink(path)
        except OSError:
            continue
        removed.append(path)
    return removed


def _write_temporary(path: Path, data: bytes) -> Path:
    """A new temporary file beside ``path`` holding ``data``; its path."""
    temporary = path.with_name(temporary_name(path.name))
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(descriptor, view) :]
        finally:
            os.close(descriptor)  # some file systems (NFS) report a full disk only here
    except BaseException:
        os.unlink(temporary)
        raise
    return temporary


def atomic_write_all(contents: Any) -> list[Path]:
    """Write several files all or none; ``contents`` maps each path to its content (str,
    bytes, or a callable writing text to a handle). Returns the paths, in order. Missing
    parent folders are created.

    Every content is made and written to its temporary file before the first rename; if
    any fails, the temporary files are removed and the old files are left as they were.
    An OSError (a full disk, a read-only folder) is raised as OutputError naming the file.
    """
    paths = [Path(path) for path in contents]
    written = []
    try:
        for path, content in zip(paths, contents.values()):
            data = _content_bytes(content, path)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                written.append(_write_temporary(path, data))
            except OSError as error:
                raise OutputError(
                    f"cannot write {limits.message_text(path)}: {error_cause(error)}"
                ) from None
        for path, temporary in zip(paths, written):
            try:
                os.replace(temporary, path)
            except OSError as error:
                raise OutputError(
                    f"cannot write {limits.message_text(path)}: {error_cause(error)}"
                ) from None
    finally:
        for temporary in written:
            if os.path.lexists(temporary):
                os.unlink(temporary)
    return paths


def atomic_write(path: str | Path, content: bytes | str | Callable[[Any], None]) -> Path:
    """Write one file atomically (see atomic_write_all); returns its path."""
    return atomic_write_all({path: content})[0]


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """For a writer that streams to a file name of its own (pyarrow, ffmpeg): a temporary
    path beside ``path`` (temporary_name), renamed over ``path`` when the block ends
    without an error and removed otherwise, so a reader sees the old file or the new one
    (OutputError naming the file when the rename fails)."""
    path = Path(path)
    temporary = path.with_name(temporary_name(path.name))
    try:
        yield temporary
        try:
            os.replace(temporary, path)
        except OSError as error:
            raise OutputError(
                f"cannot write {limits.message_text(path)}: {error_cause(error)}"
            ) from None
    finally:
        if os.path.lexists(temporary):
            os.unlink(temporary)


def figure_bytes(figure: Figure, **options: Any) -> bytes:
    """A matplotlib figure's file content (PNG unless ``format`` says otherwise)."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format=options.pop("format", "png"), **options)
    return buffer.getvalue()


def save_figure(path: Path, figure: Figure, **options: Any) -> Path:
    """Write a matplotlib figure (PNG unless ``format`` says otherwise) atomically."""
    return atomic_write(path, figure_bytes(figure, **options))


def move_aside(paths: list[Path], marker: str = "previous") -> list[Any]:
    """Rename each existing file '<stem>.<ext>' in ``paths`` to '<stem>.<marker>.<ext>'
    (replacing an older one of that name); returns the new paths."""
    moved = []
    for path in map(Path, paths):
        if path.is_file():
            target = path.with_name(f"{path.stem}.{marker}{path.suffix}")
            try:
                os.replace(path, target)
            except OSError as error:
                raise OutputError(f"cannot move {path} aside: {error_cause(error)}") from None
            moved.append(target)
    return moved
