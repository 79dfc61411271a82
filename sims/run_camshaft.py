"""A whole camshaft: the inline four's eight lobes and the torque the camshaft needs.

Runs camshaft_inline_four against its reference, then the same lobes in another firing order
and at the crank throws' angles, and prints each total torque's fluctuation:
``mechfmu example camshaft``.
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "camshaft", out="out", fmu_dir="fmus")
