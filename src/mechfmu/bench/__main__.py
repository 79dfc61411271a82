"""``python -m mechfmu.bench``: run the benchmarks (see mechfmu.bench.cli)."""

import sys

from . import main

sys.exit(main())
