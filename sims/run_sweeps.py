"""Run the shipped sweeps, check them against their references and write out/sweeps/ (each
sweep's folder, summary.md, suspension_mass.png): ``mechfmu example sweeps`` (``make sweeps``).

    python sims/run_sweeps.py [--quick] [--jobs J] [--scheduler tcp://HOST:PORT] [--out DIR]

--quick runs a few points of each sweep around its threshold (what the tests run).
Exit status 1 if a sweep disagrees with its reference.
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "sweeps")
