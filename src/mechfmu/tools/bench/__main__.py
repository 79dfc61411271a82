"""``python -m mechfmu.tools.bench``: run the benchmarks (see mechfmu.tools.bench.cli)."""

import sys

from . import main

sys.exit(main())
