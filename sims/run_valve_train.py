"""Valve train: forward and inverse runs on the constraint solver, and valve float.

Runs the scenes valve_train and valve_train_inverse against the numpy reference, drives the
forward solver with the inverse run's tappet lift, and runs valve_float 1 % below and above
the predicted float speed: ``mechfmu example valve_train``.
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "valve_train")
