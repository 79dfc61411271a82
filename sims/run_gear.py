"""Nose-gear retraction over the coursework's 3 s, checked against the closed form.

Runs scenes/gear_retraction.toml (PistonActuator -> LandingGear through fmpy), then
evaluates the closed form (numpy) at every recorded time and prints the worst deviation
of the gear angle, angular velocity and angular acceleration.
"""

import numpy as np

from _runner import arguments, run

from mechfmu.tools.scene_references import model_defaults
from mechfmu.references.landing_gear import retraction

ABSOLUTE = 1e-12  # SI units; the floor for samples where the exact value is 0


def main():
    args = arguments(__doc__.splitlines()[0])
    result, paths = run("gear_retraction", args)
    stroke = {**model_defaults("PistonActuator"),
              **result.scene.components["actuator"].parameters}
    geometry = {**model_defaults("LandingGear"), **result.scene.components["gear"].parameters}
    times = np.asarray(result.times)
    exact = retraction(times, geometry["attachment_distance"], geometry["pivot_height"],
                       stroke["start_extension"], stroke["end_extension"],
                       stroke["stroke_time"], stroke["profile"])
    print(f"gear retraction: {result.meta['steps']} steps of {result.scene.step} s in "
          f"{result.meta['wall_time_s']:.3f} s wall time")
    # Relative deviation is meaningful where the exact value is not itself rounding noise
    # (alpha is exactly 0 at t = 0 by the design condition): there the absolute one counts.
    print("worst deviation from the closed form (relative where |exact| > 1e-6 of its peak):")
    passed = True
    for name, unit in (("gear_angle", "rad"), ("gear_angular_velocity", "rad/s"),
                       ("gear_angular_acceleration", "rad/s^2")):
        values, reference = np.asarray(result.columns[f"gear.{name}"]), exact[name]
        difference = np.abs(values - reference)
        meaningful = np.abs(reference) > 1e-6 * np.max(np.abs(reference))
        relative = np.where(meaningful, difference / np.where(meaningful, np.abs(reference), 1.0), 0.0)
        i, j = int(np.argmax(relative)), int(np.argmax(difference))
        passed &= bool(np.all(difference <= 1e-9 * np.abs(reference) + ABSOLUTE))
        print(f"  {name:26s} relative {relative[i]:.1e} at t = {times[i]:.2f} s; "
              f"absolute {difference[j]:.1e} {unit} at t = {times[j]:.2f} s")
    print(f"  every sample within 1e-9 relative (+1e-12 absolute): {'yes' if passed else 'NO'}")
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    return 0 if passed else 1


if __name__ == "__main__":
    raise SystemExit(main())
