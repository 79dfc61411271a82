"""Offset slider-crank at 3000 rpm on the constraint solver, checked against the closed form.

Runs the scene slider_crank_offset and prints each column's worst deviation from the numpy
reference, the stroke and the peak slider acceleration: ``mechfmu example slider_crank``.
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "slider_crank")
