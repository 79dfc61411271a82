"""Suspension under a slow load ramp past the limit load: continuation and snap-through.

Runs scenes/suspension_load_ramp.toml (LoadProfile -> Suspension through fmpy) and
prints the limit load, where the snap-through happened and the deviation from the
closed-form reference.
"""

from _runner import arguments, run

from mechfmu.check import compare


def main():
    args = arguments(__doc__.splitlines()[0])
    result, paths = run("suspension_load_ramp", args)
    columns = result.columns
    for entry in result.log:
        if entry["status"] != "ok":
            print(f"[{entry['status']}] {entry['message']}")
    snaps = [i for i, flag in enumerate(columns["suspension.snap_through"]) if flag]
    print(f"suspension load ramp: {result.meta['steps']} steps in "
          f"{result.meta['wall_time_s']:.3f} s wall time")
    for i in snaps:
        print(f"snap-through at t = {result.times[i]:.2f} s, load {columns['load.load'][i]:.1f} N: "
              f"deflection {columns['suspension.deflection'][i - 1]:.4f} m -> "
              f"{columns['suspension.deflection'][i]:.4f} m")
    comparison = compare(paths["csv"], result.scene.reference, rtol=1e-9, atol=1e-9)
    print(f"against the closed form (rtol 1e-9, atol 1e-9): {comparison}")
    for kind, path in paths.items():
        print(f"{kind}: {path}")
    return 0 if comparison.ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
