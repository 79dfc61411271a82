"""What effects cost: the kinematic gear scene against the full-dynamics one.

A thin wrapper over the effects benchmark of mechfmu.tools.bench: `make bench` (or
`python -m mechfmu.tools.bench`) runs it with the other benchmarks and writes data/bench/; this
script runs it alone and only prints its rows (medians of --repeats after one warm-up).
"""

import argparse
from pathlib import Path

from mechfmu.cosim.scene import SCENE_DIR
from mechfmu.tools.bench import effects
from mechfmu.tools.bench.report import markdown_table

ROOT = Path(__file__).resolve().parent.parent


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu-dir", default=str(ROOT / "fmus"))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(markdown_table(effects.measure(SCENE_DIR, args.fmu_dir, args.repeats)))


if __name__ == "__main__":
    main()
