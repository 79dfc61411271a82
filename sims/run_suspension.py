"""Suspension under a slow load ramp past the limit load: continuation and snap-through.

Runs the scene suspension_load_ramp (LoadProfile -> Suspension through fmpy) and prints the
snap-through and the deviation from the closed-form reference: ``mechfmu example suspension``.
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "suspension")
