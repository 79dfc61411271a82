"""Four-bar linkage: the coursework example, closed form and constraint solver, both circuits.

Prints the coursework's worked example (a, b, c, d = 2, 7, 9, 6 in, theta2 = 30 deg) on both
circuits, then runs scenes/four_bar_crank_rocker.toml (open circuit, Freudenstein closed
form, one crank revolution) and scenes/four_bar_solver_crossed.toml (crossed circuit,
generic constraint solver, crank speeding up) and prints each column's worst deviation from
the numpy reference (circle intersection, an independent derivation).
"""

import math

from _runner import arguments, report

from mechfmu.runtime.physics import four_bar as fb

RTOL, ATOL = 1e-10, 1e-10  # rad, rad/s, rad/s^2


def main():
    args = arguments(__doc__.splitlines()[0])
    linkage = fb.COURSEWORK_FOUR_BAR
    print(f"coursework four-bar: {fb.GRASHOF_CLASSES[fb.grashof_class(*linkage) - 1].name}; "
          f"crank at {math.degrees(fb.COURSEWORK_CRANK_ANGLE):g} deg:")
    for circuit, name in ((fb.OPEN, "open"), (fb.CROSSED, "crossed")):
        m = fb.motion(*linkage, circuit, fb.COURSEWORK_CRANK_ANGLE, 1.0, 0.0)
        print(f"  {name:8s} theta3 = {math.degrees(m.coupler_angle):10.4f} deg, theta4 = "
              f"{math.degrees(m.rocker_angle):10.4f} deg, transmission angle "
              f"{math.degrees(m.transmission_angle):.4f} deg")
    ok = True
    for scene_name in ("four_bar_crank_rocker", "four_bar_solver_crossed"):
        _, passed = report(scene_name, args, RTOL, ATOL, label="numpy closed form")
        ok &= passed
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
