"""Four-bar linkage: the coursework example, closed form and constraint solver, both circuits.

Prints the coursework's worked example (a, b, c, d = 2, 7, 9, 6 in, theta2 = 30 deg) on both
circuits, then runs the scenes four_bar_crank_rocker (open circuit, Freudenstein closed form)
and four_bar_solver_crossed (crossed circuit, generic constraint solver) and prints each
column's worst deviation from the numpy reference: ``mechfmu example four_bar``.
"""

from _venv import script_main

if __name__ == "__main__":
    script_main(__file__, "example", "four_bar")
