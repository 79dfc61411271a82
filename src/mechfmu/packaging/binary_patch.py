"""Fix a use-after-free at process exit in pythonfmu 0.7's and pythonfmu3 0.3.4's Linux
binaries (host side).

Both keep their interpreter state in a global ``std::shared_ptr``. At process exit the C++
runtime destroys that shared_ptr first (freeing its control block) and only then runs the
library's ``finalizePythonInterpreter`` destructor (from ``.fini_array``), which resets the
same stale pointer and decrements a count inside the freed block. When glibc has the chunk on
a free list that corrupts its links, and the process aborts at exit with "corrupted
double-linked list" or "free(): corrupted unsorted chunks" (found with valgrind: "Invalid
read ... finalizePythonInterpreter ... block free'd by __run_exit_handlers"; pythonfmu 0.7:
6 runs of 6 of sims/run_gear.py under pytest; pythonfmu3: one CI run in about 30, a Python
process that had loaded every FMI 3.0 FMU, and valgrind on any process that loads one).
Any host that loaded one of these FMUs can crash this way when it exits.

The patch turns ``finalizePythonInterpreter`` into an immediate return, so only the C++
destructor releases the state, once. Nothing else needs it: in a Python host the interpreter
is the host's and is never finalised by the FMU; in other hosts the OS reclaims the
interpreter at exit. The code is checked before patching (KNOWN_CODE: the two libraries'
first instructions); an unexpected binary is left alone and reported.
"""

import struct
from collections.abc import Iterator

SYMBOL = b"finalizePythonInterpreter"
ENDBR64 = bytes.fromhex("f30f1efa")
PUSH_RBP = 0x55
RET = 0xC3
SHT_DYNSYM = 11
# (library, the function's first bytes with None where an address goes, the offset of the
# byte that becomes RET)
KNOWN_CODE = (
    # endbr64; push %rbp
    ("pythonfmu 0.7", (*ENDBR64, PUSH_RBP), 4),
    # push %rbx; mov <pyState's control block>(%rip),%rbx; pxor %xmm0,%xmm0
    ("pythonfmu3 0.3.4", (0x53, 0x48, 0x8B, 0x1D, None, None, None, None, 0x66, 0x0F, 0xEF), 0),
)


def _matches(code: bytes, pattern: tuple) -> bool:
    return len(code) >= len(pattern) and all(
        want is None or have == want for have, want in zip(code, pattern)
    )


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
    """Return (patched image, message). Unpatched when the code is none of KNOWN_CODE."""
    offset = find_symbol_offset(elf, SYMBOL)
    if offset is None:
        return elf, f"{SYMBOL.decode()} not found: binary left as built"
    code = elf[offset : offset + 16]
    for library, pattern, at in KNOWN_CODE:
        if (
            code[at] == RET
            and _matches(code, pattern[:at])
            and _matches(code[at + 1 :], pattern[at + 1 :])
        ):
            return elf, "already patched"
        if _matches(code, pattern):
            patched = bytearray(elf)
            patched[offset + at] = RET
            return bytes(patched), f"{SYMBOL.decode()} at 0x{offset:x} made a no-op ({library})"
    return elf, (
        f"{SYMBOL.decode()} starts with {code[:8].hex()}, not the known code of "
        f"{' or '.join(library for library, _, _ in KNOWN_CODE)}: binary left as built"
    )
