"""NPY_DISABLE_CPU_FEATURES values that narrow numpy's SIMD dispatch on this CPU.

numpy chooses its kernels at import time by CPU: the same code computes in the last bits
differently on a machine without AVX-512 (or without AVX2 and FMA). Setting
NPY_DISABLE_CPU_FEATURES runs those machines' code paths on this one, but only features
the CPU has and numpy dispatches on may be named (numpy refuses the rest), so the lists are
computed here from numpy's own tables:

    python tests/portable.py avx512   the AVX-512 family present (numpy 2: X86_V4, AVX512_*)
    python tests/portable.py avx2     that, plus AVX2, FMA3 and what builds on them (X86_V3)

Prints the space-separated list (empty if the CPU has none of them: nothing to narrow).
"""

import sys

LEVELS = ("avx512", "avx2")


def _tables():
    try:
        from numpy._core import _multiarray_umath as umath  # numpy >= 2
    except ImportError:  # numpy 1.x
        from numpy.core import _multiarray_umath as umath
    return umath.__cpu_features__, umath.__cpu_dispatch__


def is_avx512(name: str) -> bool:
    """A dispatch target of the AVX-512 family (numpy 1.x names AVX512F, AVX512_SKX, ...;
    numpy 2 groups them as X86_V4 and AVX512_ICL, AVX512_SPR, ...)."""
    return name.startswith("AVX512") or name == "X86_V4"


def is_avx2(name: str) -> bool:
    """AVX2, FMA and the features dispatched with them (numpy 2: the X86_V3 group)."""
    return name in ("AVX2", "FMA3", "FMA4", "F16C", "X86_V3", "AVX512_KNL", "AVX512_KNM")


def disabled(level: str) -> list:
    """The dispatch targets present on this CPU to disable for ``level`` (avx512 or avx2)."""
    if level not in LEVELS:
        raise ValueError(f"level {level!r}: expected one of {', '.join(LEVELS)}")
    features, dispatch = _tables()
    wanted = [is_avx512] if level == "avx512" else [is_avx512, is_avx2]
    return [name for name in dispatch if features.get(name) and any(test(name) for test in wanted)]


def main(argv: list) -> int:
    if len(argv) != 1 or argv[0] not in LEVELS:
        print(f"usage: python tests/portable.py {{{'|'.join(LEVELS)}}}", file=sys.stderr)
        return 2
    print(" ".join(disabled(argv[0])))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
