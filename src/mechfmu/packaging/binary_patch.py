"""Fix a use-after-free at process exit in pythonfmu 0.7's Linux binary (host side).

pythonfmu keeps its interpreter state in a global ``std::shared_ptr``. At process exit the
C++ runtime destroys that shared_ptr first (freeing its control block) and only then runs the
library's ``finalizePythonInterpreter`` destructor (``.fini_array``), which resets the same
stale pointer and decrements a count inside the freed block. When glibc has the chunk on a
doubly-linked free list that corrupts its links, and the process aborts at exit with
"corrupted double-linked list" (found with valgrind: "Invalid read ... finalizePythonInterpreter
... block free'd by __run_exit_handlers"; reproduced in 6 runs of 6 of sims/run_gear.py under
pytest). Any host that loaded one of these FMUs can crash this way when it exits.

The patch turns ``finalizePythonInterpreter`` into an immediate return (after its endbr64), so
only the C++ destructor releases the state, once. Nothing else needs it: in a Python host the
interpreter is the host's and is never finalised by the FMU; in other hosts the OS reclaims
the interpreter at exit. The bytes are checked before patching; an unexpected binary is left
alone and reported.
"""

import struct
from collections.abc import Iterator

SYMBOL = b"finalizePythonInterpreter"
ENDBR64 = bytes.fromhex("f30f1efa")
PUSH_RBP = 0x55
RET = 0xC3
SHT_DYNSYM = 11


def _sections(elf: bytes) -> Iterator[tuple[int, int, int, int, int, int, int, int, int, int]]:
    (shoff,) = struct.unpack_from("<Q", elf, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", elf, 0x3A)
    for i in range(shnum):
        yield struct.unpack_from("<IIQQQQIIQQ", elf, shoff + i * shentsize)


def find_symbol_offset(elf: bytes, symbol: bytes) -> int | None:
    """File offset of a dynamic symbol's code in an ELF64 little-endian image, or None."""
    if elf[:4] != b"\x7fELF" or elf[4] != 2 or elf[5] != 1:
        return None
    sections = list(_sections(elf))
    for _, kind, _, _, offset, size, link, _, _, entsize in sections:
        if kind != SHT_DYNSYM:
            continue
        strings_offset = sections[link][4]
        for start in range(offset, offset + size, entsize):
            name, _, _, index, value, _ = struct.unpack_from("<IBBHQQ", elf, start)
            end = elf.index(b"\0", strings_offset + name)
            if elf[strings_offset + name : end] == symbol and 0 < index < len(sections):
                section = sections[index]
                return value - section[3] + section[4]
    return None


def patch_exit_finaliser(elf: bytes) -> tuple[bytes, str]:
    """Return (patched image, message). Unpatched when the bytes are not the expected ones."""
    offset = find_symbol_offset(elf, SYMBOL)
    if offset is None:
        return elf, f"{SYMBOL.decode()} not found: binary left as built"
    head = elf[offset : offset + 5]
    if head[:4] == ENDBR64 and head[4] == RET:
        return elf, "already patched"
    if head[:4] != ENDBR64 or head[4] != PUSH_RBP:
        return elf, (
            f"{SYMBOL.decode()} starts with {head.hex()}, not the known pythonfmu 0.7 "
            f"code: binary left as built"
        )
    patched = bytearray(elf)
    patched[offset + 4] = RET
    return bytes(patched), f"{SYMBOL.decode()} at 0x{offset:x} made a no-op"
