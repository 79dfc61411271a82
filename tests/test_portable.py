"""tests/portable.py: the NPY_DISABLE_CPU_FEATURES lists that `make test-portable` uses are
accepted by numpy on this CPU and do narrow its dispatch."""

import json
import os
import subprocess
import sys
from pathlib import Path

import portable
import pytest

SCRIPT = Path(__file__).with_name("portable.py")
FEATURES, DISPATCH = portable._tables()


def _runtime_with(disabled):
    """numpy's dispatch targets found in a fresh interpreter with ``disabled`` switched off."""
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=" ".join(disabled))
    code = (
        "import json\n"
        "try:\n    from numpy._core import _multiarray_umath as m\n"
        "except ImportError:\n    from numpy.core import _multiarray_umath as m\n"
        "print(json.dumps(sorted(k for k, v in m.__cpu_features__.items() if v "
        "and k in m.__cpu_dispatch__)))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        env=env,
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    return set(json.loads(done.stdout))


def test_lists_are_this_cpus_features_and_nest():
    avx512, avx2 = portable.disabled("avx512"), portable.disabled("avx2")
    assert set(avx512) <= set(avx2) <= set(DISPATCH)
    assert all(FEATURES[name] for name in avx2)
    assert all(portable.is_avx512(name) for name in avx512)
    present = {name for name in DISPATCH if FEATURES.get(name)}
    assert {name for name in present if portable.is_avx512(name)} == set(avx512)


@pytest.mark.parametrize("level", portable.LEVELS)
def test_numpy_accepts_the_list_and_runs_without_those_kernels(level):
    disabled = portable.disabled(level)
    remaining = _runtime_with(disabled)
    assert remaining.isdisjoint(disabled)
    done = subprocess.run(
        [sys.executable, str(SCRIPT), level],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and done.stdout.split() == disabled


def test_unknown_level_is_refused_in_one_line():
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "sse9"],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "usage" in done.stderr
    with pytest.raises(ValueError, match="sse9"):
        portable.disabled("sse9")
