"""Suspension dynamics: road bump and sudden load, checked against the solve_ivp references.

Runs the scenes suspension_road_bump and suspension_sudden_load and prints each column's
worst deviation from its reference at the scene's declared tolerance, and the sudden load's
snap-through times: ``mechfmu example suspension_dynamics``.
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "suspension_dynamics")
