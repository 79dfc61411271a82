"""Valve train: forward and inverse runs on the constraint solver, and valve float.

Runs scenes/valve_train.toml (3-4-5 cam on the tappet at 3000 rpm, valve spring on) and
scenes/valve_train_inverse.toml (desired 4-5-6-7 valve motion in, cam displacement
diagram out) and prints each column's worst deviation from the numpy reference (cam law
composed with the closed-form rocker geometry). Then checks the inverse result by driving the
forward constraint solver with the tappet lift it produced (the original valve motion must
come back), and runs scenes/valve_float.toml at constant camshaft speeds 1 % below and
1 % above the float speed the FMU predicts: no loss of contact below, reported above.
"""

import copy
import math

import numpy as np

from _runner import arguments, report, run

from mechfmu.cosim.scene import find_file, load_scene
from mechfmu.runtime.physics import cam_laws, constraint_models, planar
from mechfmu.runtime.physics.valve_train import DEFAULT_VALVE_GEOMETRY, ValveGeometry, float_speed
from mechfmu.tools.scene_references import model_defaults

RTOL, ATOL = 1e-9, 1e-9  # SI units; accelerations reach ~1000 m/s^2


def round_trip(result):
    """Forward solver driven by the inverse run's tappet motion; worst valve-lift deviation."""
    g = DEFAULT_VALVE_GEOMETRY
    follower = planar.BranchFollower(constraint_models.valve_train(g))
    columns = {key: np.asarray(values) for key, values in result.columns.items()}
    heights = g.cam_base_radius + columns["valve.tappet_lift"]
    rates, accelerations = columns["valve.tappet_velocity"], columns["valve.tappet_acceleration"]
    closed = None
    worst = 0.0
    for i, time in enumerate(result.times):
        drive = [(heights[i], rates[i], accelerations[i])]
        if i == 0:
            solution = follower.assemble(constraint_models.valve_train_guess(g), drive)
            rest = planar.BranchFollower(constraint_models.valve_train(g)).assemble(
                constraint_models.valve_train_guess(g), [(g.cam_base_radius, 0.0, 0.0)])
            closed = rest.q[3 * constraint_models.VALVE + 1]
        else:
            solution = follower.follow(drive, time - result.times[i - 1])
        lift = closed - solution.q[3 * constraint_models.VALVE + 1]
        worst = max(worst, abs(lift - columns["valve.valve_lift"][i]))
    return worst


def float_runs(args):
    """valve_float at constant camshaft speed 0.99 and 1.01 times the predicted float speed."""
    base = load_scene(find_file("valve_float"))
    parameters = {**model_defaults("ValveTrain"), **base.components["valve"].parameters}
    geometry = ValveGeometry(*(parameters[name] for name in ValveGeometry._fields))
    profile = cam_laws.check_profile(*(parameters[name] for name in (
        "cam_law", "lift", "rise_start", "rise_angle", "high_dwell_angle", "return_angle")))
    predicted = float_speed(geometry, profile, parameters["valve_mass"],
                            parameters["spring_stiffness"], parameters["spring_preload"])
    lines, ok = [], True
    for factor in (0.99, 1.01):
        scene = copy.deepcopy(base)
        scene.name, scene.reference, scene.stop_time = f"valve_float_{factor:g}", None, 0.05
        scene.components["camshaft"].parameters = {"speed": 2.0 * factor * predicted.camshaft_speed}
        result, _ = run(scene, args)
        events = int(result.columns["valve.float_events"][-1])
        force = min(result.columns["valve.contact_force"])
        reported = result.columns["valve.float_camshaft_speed"][-1]
        lines.append(f"  camshaft at {factor:.2f} x the float speed: {events} loss(es) of "
                     f"contact in {scene.stop_time} s, least contact force {force:.2f} N")
        ok &= reported == predicted.camshaft_speed
        ok &= (events == 0 and force > 0) if factor < 1 else (events > 0 and force < 0)
    return predicted, lines, ok


def main():
    args = arguments(__doc__.splitlines()[0])
    ok = True
    _, passed = report("valve_train", args, RTOL, ATOL, label="numpy closed form")
    ok &= passed
    inverse, passed = report("valve_train_inverse", args, RTOL, ATOL, label="numpy closed form")
    ok &= passed
    worst = round_trip(inverse)
    print(f"inverse then forward: the forward solver driven by the computed tappet lift gives "
          f"back the valve lift within {worst:.1e} m")
    ok &= worst < 1e-12
    predicted, lines, passed = float_runs(args)
    speed = predicted.camshaft_speed
    print(f"valve float: loss of contact above {speed:.3f} rad/s of camshaft "
          f"({speed * 60 / math.pi:.0f} engine rpm) for this cam and spring, first at camshaft "
          f"angle {predicted.camshaft_angle:.4f} rad (FMU output float_camshaft_speed)")
    print("\n".join(lines))
    ok &= passed
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
