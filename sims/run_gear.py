"""Nose-gear retraction over the coursework's 3 s, checked against the closed form.

Runs the scene gear_retraction (PistonActuator -> LandingGear through fmpy), then evaluates
the closed form (numpy) at every recorded time and prints the worst deviation of the gear
angle, angular velocity and angular acceleration: ``mechfmu example gear`` (``make run``
runs it). Writes out/ in the current folder (--out DIR elsewhere).
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "gear")
