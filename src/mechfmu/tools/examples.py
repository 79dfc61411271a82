"""The worked examples (``mechfmu example NAME``; sims/run_*.py run them): shipped scenes
run through fmpy and checked against their references, with what each check found.

Each example is a function named as its example (cli.EXAMPLES lists them), takes the parsed
command line (``out``, ``fmu_dir``, ``no_plot``; ``sweeps``: ``out``, ``fmu_dir``, ``quick``,
``jobs``, ``scheduler``) and returns the exit status: 0 when every check passes, 1
otherwise. A scene or simulation error propagates to the command (see cli.py).
"""

from typing import Any
import copy
import math
import re
import sys
from pathlib import Path

import numpy as np

from ..check import compare, run_report
from ..cosim.run import run_scene
from ..cosim.scene import SWEEP_DIR, Scene, find_file, load_scene
from ..references.landing_gear import retraction
from ..runtime.physics import cam_laws, constraint_models, planar
from ..runtime.physics import four_bar as fb
from ..runtime.physics import suspension as statics
from ..runtime.physics.valve_train import DEFAULT_VALVE_GEOMETRY, ValveGeometry, float_speed
from .scene_references import model_defaults, retraction_arguments


def _run(scene: Any, args: Any):
    """Run a Scene or a shipped scene by name into args.out; (Result, {kind: path})."""
    if not isinstance(scene, Scene):
        scene = find_file(scene)
    return run_scene(scene, args.out, args.fmu_dir, plot=not args.no_plot)


def _checked(scene_name: Any, args: Any, label: str):
    """Run a shipped scene and print its report against its reference at the tolerances the
    scene declares (check.run_report); (Result, whether it matches)."""
    result, paths = _run(scene_name, args)
    lines, comparison = run_report(result, paths, result.scene.reference, label=label)
    print("\n".join(lines))
    return result, comparison is not None and comparison.ok


# --- gear ----------------------------------------------------------------------------------


def gear(args: Any) -> Any:
    """Nose-gear retraction over the coursework's 3 s (gear_retraction: PistonActuator ->
    LandingGear), the worst deviation of angle, angular velocity and angular acceleration
    from the closed form evaluated at every recorded time."""
    result, paths = _run("gear_retraction", args)
    times = np.asarray(result.times)
    exact = retraction(times, *retraction_arguments(result.scene)[1:])
    print(
        f"gear retraction: {result.meta['steps']} steps of {result.scene.step} s in "
        f"{result.meta['wall_time_s']:.3f} s wall time"
    )
    # Relative deviation is meaningful where the exact value is not itself rounding noise
    # (alpha is exactly 0 at t = 0 by the design condition): there the absolute one counts.
    print("worst deviation from the closed form (relative where |exact| > 1e-6 of its peak):")
    for name, unit in (
        ("gear_angle", "rad"),
        ("gear_angular_velocity", "rad/s"),
        ("gear_angular_acceleration", "rad/s^2"),
    ):
        values, reference = np.asarray(result.columns[f"gear.{name}"]), exact[name]
        difference = np.abs(values - reference)
        meaningful = np.abs(reference) > 1e-6 * np.max(np.abs(reference))
        relative = np.where(
            meaningful, difference / np.where(meaningful, np.abs(reference), 1.0), 0.0
        )
        i, j = int(np.argmax(relative)), int(np.argmax(difference))
        print(
            f"  {name:26s} relative {relative[i]:.1e} at t = {times[i]:.2f} s; "
            f"absolute {difference[j]:.1e} {unit} at t = {times[j]:.2f} s"
        )
    comparison = compare(paths["csv"], result.scene.reference)
    print(f"against the reference CSV ({comparison.tolerance_text()}): {comparison}")
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    return 0 if comparison.passed else 1


# --- linkages ------------------------------------------------------------------------------


def four_bar(args: Any) -> Any:
    """Four-bar linkage: the coursework's worked example (a, b, c, d = 2, 7, 9, 6 in,
    theta2 = 30 deg) on both circuits, then four_bar_crank_rocker (open circuit, Freudenstein
    closed form, one crank revolution) and four_bar_solver_crossed (crossed circuit, generic
    constraint solver, crank speeding up) against the numpy reference (circle
    intersection, an independent derivation)."""
    linkage = fb.COURSEWORK_FOUR_BAR
    print(
        f"coursework four-bar: {fb.GRASHOF_CLASSES[fb.grashof_class(*linkage) - 1].name}; "
        f"crank at {math.degrees(fb.COURSEWORK_CRANK_ANGLE):g} deg:"
    )
    for circuit, name in ((fb.OPEN, "open"), (fb.CROSSED, "crossed")):
        m = fb.motion(*linkage, circuit, fb.COURSEWORK_CRANK_ANGLE, 1.0, 0.0)
        print(
            f"  {name:8s} theta3 = {math.degrees(m.coupler_angle):10.4f} deg, theta4 = "
            f"{math.degrees(m.rocker_angle):10.4f} deg, transmission angle "
            f"{math.degrees(m.transmission_angle):.4f} deg"
        )
    ok = True
    for scene_name in ("four_bar_crank_rocker", "four_bar_solver_crossed"):
        _, passed = _checked(scene_name, args, "numpy closed form")
        ok &= passed
    return 0 if ok else 1


def slider_crank(args: Any) -> Any:
    """Offset slider-crank at 3000 rpm on the constraint solver (slider_crank_offset: crank
    50 mm, rod 150 mm, offset 10 mm, one revolution) against the closed form, the stroke
    (longer than twice the crank with the offset) and the peak slider acceleration."""
    result, ok = _checked("slider_crank_offset", args, "numpy closed form")
    slider = np.asarray(result.columns["slider.slider_position"])
    acceleration = np.asarray(result.columns["slider.slider_acceleration"])
    parameters = result.scene.components["slider"].parameters
    a, b, e = 0.05, 0.15, parameters["offset"]
    exact_stroke = math.sqrt((a + b) ** 2 - e * e) - math.sqrt((b - a) ** 2 - e * e)
    print(
        f"  stroke over the sampled revolution {slider.max() - slider.min():.6f} m "
        f"(exact between the dead centres {exact_stroke:.6f} m); peak |acceleration| "
        f"{np.abs(acceleration).max():.1f} m/s^2"
    )
    return 0 if ok else 1


# --- suspension ----------------------------------------------------------------------------


def suspension(args: Any) -> Any:
    """Suspension under a slow load ramp past the limit load (suspension_load_ramp):
    continuation, where the snap-through happened, the deviation from the closed form."""
    result, paths = _run("suspension_load_ramp", args)
    columns = result.columns
    for entry in result.log:
        if entry["status"] != "ok":
            print(f"[{entry['status']}] {entry['message']}")
    snaps = [i for i, flag in enumerate(columns["suspension.snap_through"]) if flag]
    print(
        f"suspension load ramp: {result.meta['steps']} steps in "
        f"{result.meta['wall_time_s']:.3f} s wall time"
    )
    for i in snaps:
        print(
            f"snap-through at t = {result.times[i]:.2f} s, load {columns['load.load'][i]:.1f} N: "
            f"deflection {columns['suspension.deflection'][i - 1]:.4f} m -> "
            f"{columns['suspension.deflection'][i]:.4f} m"
        )
    comparison = compare(paths["csv"], result.scene.reference)
    print(f"against the closed form ({comparison.tolerance_text()}): {comparison}")
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    return 0 if comparison.ok else 1


def suspension_dynamics(args: Any) -> Any:
    """Suspension dynamics: suspension_road_bump (load and road -> Suspension with dynamics,
    damping, tyre and road input) and suspension_sudden_load (a step load below the static
    limit load that snaps the suspension through) against their solve_ivp references at the
    scenes' declared tolerances, and the sudden load's snap-through times from the log."""
    ok = True
    for scene_name in ("suspension_road_bump", "suspension_sudden_load"):
        result, passed = _checked(scene_name, args, "solve_ivp reference")
        ok &= passed
        if scene_name == "suspension_sudden_load":
            limit = statics.limit_point(statics.make_spring(0.5, 1e4, 0.2)).load
            load = max(result.columns["load.load"])
            snaps = [m["message"] for m in result.log if "snap-through" in m["message"]]
            found = [re.search(r"at t = ([0-9.e+-]+) s", m) for m in snaps]
            times = [float(match.group(1)) for match in found if match]
            print(
                f"  load {load:.1f} N = {load / limit:.3f} of the static limit load "
                f"{limit:.2f} N; snap-throughs at t = " + ", ".join(f"{t:.6f} s" for t in times)
            )
    return 0 if ok else 1


# --- valve train ---------------------------------------------------------------------------


def round_trip(result: Any) -> Any:
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
                constraint_models.valve_train_guess(g), [(g.cam_base_radius, 0.0, 0.0)]
            )
            closed = rest.q[3 * constraint_models.VALVE + 1]
        else:
            solution = follower.follow(drive, time - result.times[i - 1])
        lift = closed - solution.q[3 * constraint_models.VALVE + 1]
        worst = max(worst, abs(lift - columns["valve.valve_lift"][i]))
    return worst


def float_runs(args: Any) -> Any:
    """valve_float at constant camshaft speed 0.99 and 1.01 times the predicted float speed."""
    base = load_scene(find_file("valve_float"))
    parameters = {**model_defaults("ValveTrain"), **base.components["valve"].parameters}
    geometry = ValveGeometry(*(parameters[name] for name in ValveGeometry._fields))
    profile = cam_laws.check_profile(
        *(
            parameters[name]
            for name in (
                "cam_law",
                "lift",
                "rise_start",
                "rise_angle",
                "high_dwell_angle",
                "return_angle",
            )
        )
    )
    predicted = float_speed(
        geometry,
        profile,
        parameters["valve_mass"],
        parameters["spring_stiffness"],
        parameters["spring_preload"],
    )
    lines, ok = [], True
    for factor in (0.99, 1.01):
        scene = copy.deepcopy(base)
        scene.name, scene.reference, scene.stop_time = f"valve_float_{factor:g}", None, 0.05
        scene.components["camshaft"].parameters = {"speed": 2.0 * factor * predicted.camshaft_speed}
        result, _ = _run(scene, args)
        events = int(result.columns["valve.float_events"][-1])
        force = min(result.columns["valve.contact_force"])
        reported = result.columns["valve.float_camshaft_speed"][-1]
        lines.append(
            f"  camshaft at {factor:.2f} x the float speed: {events} loss(es) of "
            f"contact in {scene.stop_time} s, least contact force {force:.2f} N"
        )
        ok &= reported == predicted.camshaft_speed
        ok &= (events == 0 and force > 0) if factor < 1 else (events > 0 and force < 0)
    return predicted, lines, ok


def valve_train(args: Any) -> Any:
    """Valve train: valve_train (3-4-5 cam on the tappet at 3000 rpm, valve spring on) and
    valve_train_inverse (desired 4-5-6-7 valve motion in, cam displacement diagram out)
    against the numpy reference; the inverse result driving the forward solver (the valve
    motion must come back); valve_float at camshaft speeds 1 % below and above the float
    speed the FMU predicts: no loss of contact below, reported above."""
    ok = True
    _, passed = _checked("valve_train", args, "numpy closed form")
    ok &= passed
    inverse, passed = _checked("valve_train_inverse", args, "numpy closed form")
    ok &= passed
    worst = round_trip(inverse)
    print(
        f"inverse then forward: the forward solver driven by the computed tappet lift gives "
        f"back the valve lift within {worst:.1e} m"
    )
    ok &= worst < 1e-12
    predicted, lines, passed = float_runs(args)
    speed = predicted.camshaft_speed
    print(
        f"valve float: loss of contact above {speed:.3f} rad/s of camshaft "
        f"({speed * 60 / math.pi:.0f} engine rpm) for this cam and spring, first at camshaft "
        f"angle {predicted.camshaft_angle:.4f} rad (FMU output float_camshaft_speed)"
    )
    print("\n".join(lines))
    ok &= passed
    return 0 if ok else 1


# --- a whole camshaft --------------------------------------------------------------------


def camshaft(args: Any) -> Any:
    """A whole camshaft (camshaft_inline_four: eight lobes of an inline four in the firing
    order 1-3-4-2) against its reference (the rocker's statics and the moment of the tappet's
    push), then the same lobes in another firing order and at the crank throws' angles: the
    total torque's peak-to-peak and RMS fluctuation and the largest torque in a shaft
    section, printed and written (camshaft_torque.md, .csv, .png in args.out). Checks: the
    scene matches its reference; the torque balances the valves' power; two firing orders
    give the same total torque (evenly spaced identical lobes); its mean is ~0."""
    from ..api import simulate
    from ..cosim.files import atomic_write_all
    from . import camshaft as shaft

    result, passed = _checked("camshaft_inline_four", args, "rocker statics (numpy)")
    scene = result.scene

    def run(chosen: Any, parameters: Any) -> Any:
        return simulate(chosen, parameters=parameters, fmu_dir=args.fmu_dir)

    table, curves = shaft.compare_phasings(scene, run)
    text = shaft.table_text(table)
    print(
        f"total camshaft torque over one revolution at {scene.components['camshaft'].parameters['speed'] * 30 / math.pi:.0f} engine rpm:"
    )
    print(text, end="")
    first, second, _ = (curves[p.name]["total"].to_numpy() for p in shaft.INLINE_FOUR)
    scale = float(np.max(np.abs(first)))
    same = float(np.max(np.abs(first - second)))
    print(
        f"the two firing orders' total torques differ by at most {same:.1e} N.m "
        f"({same / scale:.1e} of the peak): the sum of evenly spaced identical lobes does "
        f"not depend on which cylinder gets which phase"
    )
    angle = np.asarray(result.columns["camshaft.camshaft_angle"])
    out = Path(args.out)
    frame = {"camshaft_angle": angle}
    for name, torque in curves.items():
        frame[f"{name}: total"] = torque["total"].to_numpy()
    written = atomic_write_all(
        {
            out / "camshaft_torque.md": text,
            out / "camshaft_torque.csv": pandas_csv(frame),
            out / "camshaft_torque.png": shaft.figure_png(curves, angle),
        }
    )
    print("wrote " + ", ".join(str(path) for path in written))
    mean_ok = all(abs(row["mean"]) < 1e-3 * row["peak"] for _, row in table.iterrows())
    return 0 if passed and same <= 1e-9 * scale and mean_ok else 1


def pandas_csv(columns: Any) -> str:
    """CSV text of equal-length columns (the full precision of each float)."""
    import pandas

    return pandas.DataFrame(columns).to_csv(index=False, float_format="%.17g")


# --- the shipped sweeps --------------------------------------------------------------------


def sweeps(args: Any) -> Any:
    """The shipped sweeps (src/mechfmu/sweeps/*.toml) against their references: each sweep's
    folder (sweep.csv, sweep.json, plots), summary.md and suspension_mass.png in args.out.
    ``quick``: a few points of each sweep around its threshold (what the tests run)."""
    from .report import sweeps as shipped

    summaries = shipped.run_shipped(
        SWEEP_DIR, args.out, args.fmu_dir, args.jobs, args.quick, args.scheduler
    )
    findings, text = shipped.report(SWEEP_DIR, args.out, summaries)
    print(text)
    print(f"wrote {Path(args.out) / 'summary.md'} and {Path(args.out) / 'suspension_mass.png'}")
    problems = shipped.failures(findings)
    for problem in problems:
        print(f"DISAGREES: {problem}", file=sys.stderr)
    return 1 if problems else 0
