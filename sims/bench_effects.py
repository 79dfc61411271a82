"""What effects cost: the kinematic gear scene against the full-dynamics one.

`make bench` (``mechfmu bench``) runs it with the other benchmarks and writes data/bench/;
this script runs it alone and only prints its rows (``mechfmu bench --only effects``;
medians of --repeats after one warm-up).
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "bench", "--only", "effects")
