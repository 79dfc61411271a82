"""Nose-gear retraction over the coursework's 3 s, checked against the closed form.

Runs the scene gear_retraction (PistonActuator -> LandingGear through fmpy), then evaluates
the closed form (numpy) at every recorded time and prints the worst deviation of the gear
angle, angular velocity and angular acceleration: ``mechfmu example gear`` with --out and
--fmu-dir in this repository (``make run``).
"""

from mechfmu.cli import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "gear", out="out", fmu_dir="fmus")
