"""``python -m mechfmu``: the mechfmu command."""

import sys

from .cli import main

sys.exit(main())
