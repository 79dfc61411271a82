"""Parameter sweeps of a scene on a local process pool (``mechfmu sweep``).

``mechfmu sweep SCENE --vary comp.param=START:STOP:COUNT [--vary ...] --metrics NAME ...``
runs the scene at every point of the full grid (``numpy.linspace`` per parameter), or at
``--samples N --seed S`` Latin-hypercube (``--method lhs``, the default) or uniform random
(``--method random``) points over the ranges, and writes into ``--out``
(default ``out/sweep_<scene>``):

sweep.csv    one row per point: index, each varied parameter, each metric, error, wall_time_s;
             a row is appended and flushed as each point finishes (rows in completion order)
sweep.json   the sweep's definition and its state (written at the start, replaced atomically
             at the end; ``"interrupted": true`` after Ctrl-C)
<metric>_vs_<parameter>.png   with ``--plot``

Metrics: ``final:c.v``, ``max:c.v``, ``min:c.v``, ``time_of_max:c.v``,
``first_time_above:c.v:THRESHOLD``, ``first_time_true:c.v`` (Boolean or 0/1 flag columns),
``max_abs_error:c.v`` (against the scene's reference CSV, interpolated onto the result's
times). A metric whose event never happens is ``nan``. A point whose scene fails (SceneError,
SimulationError) gets its message in ``error`` and empty metrics; the sweep goes on.
"""

import argparse
import copy
import csv
import dataclasses
import math
import os
import re
import signal
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from .cosim.results import read_csv, write_json


class SweepError(ValueError):
    """A sweep that cannot start as written (bad --vary, --metrics, sampling options)."""


# --- --vary ----------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Vary:
    component: str
    variable: str
    start: float
    stop: float
    count: int = None  # None: only a range (sampling)

    @property
    def name(self):
        return f"{self.component}.{self.variable}"


def parse_vary(text):
    """'comp.param=START:STOP:COUNT' (or 'comp.param=START:STOP' for sampling) -> Vary."""
    if not isinstance(text, str) or text.count("=") != 1:
        raise SweepError(f"--vary {text!r}: expected component.parameter=START:STOP:COUNT")
    name, spec = (part.strip() for part in text.split("="))
    component, dot, variable = name.partition(".")
    if not dot or not component or not variable:
        raise SweepError(f"--vary {text!r}: {name!r} is not of the form component.parameter")
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise SweepError(f"--vary {text!r}: expected START:STOP:COUNT after '='")
    try:
        start, stop = float(parts[0]), float(parts[1])
    except ValueError:
        raise SweepError(f"--vary {text!r}: START and STOP must be numbers") from None
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise SweepError(f"--vary {text!r}: START and STOP must be finite")
    count = None
    if len(parts) == 3:
        try:
            count = int(parts[2])
        except ValueError:
            raise SweepError(f"--vary {text!r}: COUNT must be a whole number") from None
        if count < 1:
            raise SweepError(f"--vary {text!r}: COUNT must be at least 1")
    return Vary(component, variable, start, stop, count)


# --- points ------------------------------------------------------------------------------------

def grid_points(varies):
    """The full grid: every combination of each parameter's linspace, last varying fastest."""
    for vary in varies:
        if vary.count is None:
            raise SweepError(f"--vary {vary.name}: a grid needs START:STOP:COUNT "
                             f"(or use --samples N)")
    axes = [np.linspace(v.start, v.stop, v.count) for v in varies]
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1)


def lhs_unit(samples, dimensions, seed):
    """Latin hypercube in [0, 1)^d: in each dimension exactly one sample per stratum
    [k/N, (k+1)/N), placed uniformly inside it; reproducible with ``seed``."""
    rng = np.random.default_rng(seed)
    unit = np.empty((samples, dimensions))
    for d in range(dimensions):
        unit[:, d] = (rng.permutation(samples) + rng.random(samples)) / samples
    return unit


def sample_points(varies, samples, seed, method="lhs"):
    """``samples`` points over the ranges: Latin hypercube ('lhs') or uniform ('random')."""
    if samples < 1:
        raise SweepError("--samples must be at least 1")
    if method == "lhs":
        unit = lhs_unit(samples, len(varies), seed)
    elif method == "random":
        unit = np.random.default_rng(seed).random((samples, len(varies)))
    else:
        raise SweepError(f"--method {method!r}: expected lhs or random")
    low = np.array([v.start for v in varies])
    high = np.array([v.stop for v in varies])
    return low + unit * (high - low)


# --- metrics -----------------------------------------------------------------------------------

METRICS = {"final": 0, "max": 0, "min": 0, "time_of_max": 0, "first_time_above": 1,
           "first_time_true": 0, "max_abs_error": 0}  # kind -> number of extra arguments


@dataclasses.dataclass(frozen=True)
class Metric:
    text: str          # as given: the CSV column's name
    kind: str
    variable: str      # component.variable
    threshold: float = None


def parse_metric(text):
    """'kind:comp.var' or 'first_time_above:comp.var:THRESHOLD' -> Metric."""
    if not isinstance(text, str):
        raise SweepError(f"--metrics {text!r}: expected KIND:component.variable")
    parts = text.split(":")
    kind = parts[0]
    if kind not in METRICS:
        raise SweepError(f"--metrics {text!r}: unknown kind {kind!r}; known: "
                         f"{', '.join(METRICS)}")
    if len(parts) != 2 + METRICS[kind]:
        form = f"{kind}:component.variable" + (":THRESHOLD" if METRICS[kind] else "")
        raise SweepError(f"--metrics {text!r}: expected {form}")
    variable = parts[1]
    component, dot, name = variable.partition(".")
    if not dot or not component or not name:
        raise SweepError(f"--metrics {text!r}: {variable!r} is not of the form "
                         f"component.variable")
    threshold = None
    if METRICS[kind]:
        try:
            threshold = float(parts[2])
        except ValueError:
            raise SweepError(f"--metrics {text!r}: THRESHOLD {parts[2]!r} is not a number") \
                from None
    return Metric(text, kind, variable, threshold)


def first_time(times, mask):
    """Time of the first True in ``mask``, or nan."""
    hits = np.flatnonzero(mask)
    return float(times[hits[0]]) if hits.size else math.nan


def evaluate_metric(metric, times, values, reference=None):
    """The metric's value for one signal; ``reference`` = (times, values) for max_abs_error."""
    times, values = np.asarray(times, float), np.asarray(values, float)
    if values.size == 0:
        return math.nan
    kind = metric.kind
    if kind == "final":
        return float(values[-1])
    if kind == "max":
        return float(np.max(values))
    if kind == "min":
        return float(np.min(values))
    if kind == "time_of_max":
        return float(times[int(np.argmax(values))])
    if kind == "first_time_above":
        return first_time(times, values > metric.threshold)
    if kind == "first_time_true":
        return first_time(times, values != 0.0)
    if kind == "max_abs_error":
        if reference is None:
            raise SweepError(f"{metric.text}: no reference signal")
        ref_times, ref_values = (np.asarray(a, float) for a in reference)
        return float(np.max(np.abs(values - np.interp(times, ref_times, ref_values))))
    raise SweepError(f"unknown metric kind {kind!r}")


# --- scenes ------------------------------------------------------------------------------------

def point_scene(scene, varies, kinds, values):
    """A copy of ``scene`` with each varied parameter or constant input set to its value."""
    components = {name: copy.deepcopy(spec) for name, spec in scene.components.items()}
    for vary, value in zip(varies, values):
        kind, fmi_type = kinds[vary.name]
        value = int(round(value)) if fmi_type == "Integer" else float(value)
        target = components[vary.component]
        (target.inputs if kind == "input" else target.parameters)[vary.variable] = value
    return dataclasses.replace(scene, components=components)


def check_sweep(scene, varies, metrics, fmu_dir):
    """Check the sweep against the scene's FMUs before anything runs.

    Returns ({vary name: ('parameter' | 'input', FMI type)}, {metric text: reference signal}).
    """
    from .cosim import master
    simulation = master.Simulation(scene, fmu_dir)  # checks the scene itself
    descriptions = {name: master.model_description(master.resolve_fmu(spec, scene, fmu_dir))
                    for name, spec in scene.components.items()}
    kinds = {}
    seen = set()
    for vary in varies:
        if vary.name in seen:
            raise SweepError(f"--vary {vary.name} given twice")
        seen.add(vary.name)
        if vary.component not in scene.components:
            raise SweepError(f"--vary {vary.name}: no component {vary.component!r}; "
                             f"components: {', '.join(scene.components)}")
        variables = {v.name: v for v in descriptions[vary.component].modelVariables}
        variable = variables.get(vary.variable)
        if variable is None:
            raise SweepError(f"--vary {vary.name}: {vary.component!r} has no variable "
                             f"{vary.variable!r}; parameters: " + ", ".join(sorted(
                                 v.name for v in variables.values()
                                 if v.causality == "parameter")))
        if variable.type not in ("Real", "Integer"):
            raise SweepError(f"--vary {vary.name}: a {variable.type} cannot be swept "
                             f"(only Real and Integer)")
        if variable.causality == "parameter":
            kinds[vary.name] = ("parameter", variable.type)
        elif variable.causality == "input" and vary.variable in \
                scene.components[vary.component].inputs:
            kinds[vary.name] = ("input", variable.type)
        else:
            raise SweepError(f"--vary {vary.name}: is a {variable.causality}; only parameters "
                             f"and inputs given as constants under [components."
                             f"{vary.component}.inputs] can be swept")
    recorded = [name for name, _, _ in simulation.recorded]
    references = {}
    reference_data = None
    for metric in metrics:
        if metric.variable not in recorded:
            raise SweepError(f"--metrics {metric.text}: {metric.variable} is not recorded by "
                             f"the scene; recorded: {', '.join(recorded)}")
        if metric.kind == "max_abs_error":
            if scene.reference is None:
                raise SweepError(f"--metrics {metric.text}: the scene has no reference CSV")
            if reference_data is None:
                try:
                    reference_data = read_csv(scene.reference)
                except (OSError, ValueError) as error:
                    raise SweepError(f"--metrics {metric.text}: cannot read the reference "
                                     f"{scene.reference}: {error}") from None
            ref_times, ref_columns = reference_data
            if metric.variable not in ref_columns:
                raise SweepError(f"--metrics {metric.text}: the reference {scene.reference} "
                                 f"has no column {metric.variable}")
            references[metric.text] = (ref_times, ref_columns[metric.variable])
    return kinds, references


# --- the worker --------------------------------------------------------------------------------

def _worker_init():
    """Per worker process: ignore Ctrl-C (the parent handles it). The master parses each
    FMU's model description once per process (master.model_description)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_point(index, scene, metrics, references, fmu_dir):
    """Run one point; returns (index, {metric text: value}, error message or None, wall s)."""
    from .cosim.master import Simulation, SimulationError
    from .cosim.scene import SceneError
    started = time.perf_counter()
    try:
        result = Simulation(scene, fmu_dir).run()
        times = result.times
        values = {m.text: evaluate_metric(m, times, result.columns[m.variable],
                                          references.get(m.text)) for m in metrics}
        error = None
    except (SceneError, SimulationError) as failure:
        values, error = {}, f"{type(failure).__name__}: {failure}"
    except Exception as failure:  # anything else from one point must not stop the sweep
        values, error = {}, f"{type(failure).__name__}: {failure}"
    return index, values, error, time.perf_counter() - started


# --- the runner --------------------------------------------------------------------------------

def _now():
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _format(value):
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def safe_name(text):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")


class Progress:
    """One line on stderr: done/total, rate, time left."""

    def __init__(self, total, stream=None):
        self.total, self.started = total, time.perf_counter()
        self.stream = stream or sys.stderr

    def update(self, done, failed):
        elapsed = time.perf_counter() - self.started
        rate = done / elapsed if elapsed > 0 else 0.0
        left = (self.total - done) / rate if rate > 0 else math.inf
        left_text = f"{left:.0f} s" if math.isfinite(left) else "?"
        end = "\n" if done == self.total else ""
        self.stream.write(f"\rsweep: {done}/{self.total} done ({failed} failed), "
                          f"{rate:.2f} scenes/s, {left_text} left   {end}")
        self.stream.flush()


def run_sweep(scene_path, varies, metrics, out_dir=None, jobs=None, samples=None, seed=None,
              method="lhs", fmu_dir="fmus", plot=False, on_point=None, progress=True):
    """Run the sweep; returns the summary dict written to sweep.json.

    ``on_point(row)`` is called after each row is written (tests raise KeyboardInterrupt
    from it). On KeyboardInterrupt the pending points are cancelled, the JSON is marked
    ``interrupted`` and the exception is re-raised.
    """
    from .cosim.scene import load_scene
    scene_path = Path(scene_path)
    scene = load_scene(scene_path)
    if not varies:
        raise SweepError("give at least one --vary")
    if not metrics:
        raise SweepError("give at least one metric (--metrics)")
    if samples is None and seed is not None:
        raise SweepError("--seed needs --samples")
    if samples is not None:
        points = sample_points(varies, samples, seed, method)
        method_name = method
    else:
        points = grid_points(varies)
        method_name = "grid"
    kinds, references = check_sweep(scene, varies, metrics, fmu_dir)
    jobs = jobs or os.cpu_count() or 1
    out_dir = Path(out_dir) if out_dir else Path("out") / f"sweep_{scene.name}"
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, json_path = out_dir / "sweep.csv", out_dir / "sweep.json"
    summary = {
        "scene": scene.name, "scene_file": str(scene_path.resolve()),
        "varies": [{"name": v.name, "kind": kinds[v.name][0], "type": kinds[v.name][1],
                    "start": v.start, "stop": v.stop, "count": v.count} for v in varies],
        "method": method_name, "seed": seed, "samples": samples,
        "metrics": [m.text for m in metrics], "jobs": jobs, "fmu_dir": str(fmu_dir),
        "points": len(points), "started": _now(), "finished": None, "done": 0, "failed": 0,
        "interrupted": False, "wall_time_s": None, "csv": str(csv_path),
        "command": sys.argv,
    }
    write_json(json_path, summary)
    names = [v.name for v in varies]
    header = ["index", *names, *(m.text for m in metrics), "error", "wall_time_s"]
    started = time.perf_counter()
    meter = Progress(len(points)) if progress else None
    rows = []
    handle = open(csv_path, "w", newline="", encoding="utf-8")
    writer = csv.writer(handle, lineterminator="\n")
    writer.writerow(header)
    handle.flush()
    executor = ProcessPoolExecutor(max_workers=jobs, initializer=_worker_init)
    pending = set()
    try:
        for index, values in enumerate(points):
            scene_i = point_scene(scene, varies, kinds, values)
            future = executor.submit(run_point, index, scene_i, metrics, references, fmu_dir)
            future.values = [float(v) if kinds[n][1] == "Real" else int(round(v))
                             for n, v in zip(names, values)]
            pending.add(future)
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in finished:
                index, values, error, wall = future.result()
                row = {"index": index, **dict(zip(names, future.values)), **values,
                       "error": error, "wall_time_s": wall}
                writer.writerow([_format(row.get(key)) for key in header])
                handle.flush()
                rows.append(row)
                summary["done"] += 1
                summary["failed"] += error is not None
                if meter:
                    meter.update(summary["done"], summary["failed"])
                if on_point:
                    on_point(row)
    except KeyboardInterrupt:
        for future in pending:
            future.cancel()
        executor.shutdown(wait=False, cancel_futures=True)
        summary["interrupted"] = True
        raise
    finally:
        handle.close()
        if not summary["interrupted"]:
            executor.shutdown(wait=True)
        summary["finished"] = _now()
        summary["wall_time_s"] = time.perf_counter() - started
        if meter and summary["interrupted"]:
            meter.stream.write("\n")
        if plot and rows:
            summary["plots"] = [str(p) for p in write_plots(out_dir, rows, names, metrics)]
        write_json(json_path, summary)
    return summary


def write_plots(out_dir, rows, names, metrics):
    """One PNG per (metric, varied parameter): the metric of every successful point."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot
    paths = []
    good = [row for row in rows if row["error"] is None]
    for metric in metrics:
        for name in names:
            figure, axis = pyplot.subplots(figsize=(6, 4))
            x = [row[name] for row in good]
            y = [row[metric.text] for row in good]
            axis.plot(x, y, "o", markersize=4)
            axis.set_xlabel(name)
            axis.set_ylabel(metric.text)
            axis.grid(True, linewidth=0.3)
            figure.tight_layout()
            path = out_dir / f"{safe_name(metric.text)}_vs_{safe_name(name)}.png"
            temporary = path.with_name(f".{path.name}.tmp")
            figure.savefig(temporary, format="png", dpi=100)
            pyplot.close(figure)
            os.replace(temporary, path)
            paths.append(path)
    return paths


def read_sweep_csv(path):
    """Rows of a sweep.csv as dicts (numbers as floats, empty cells as None)."""
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        for key, value in row.items():
            if key == "error":
                row[key] = value or None
            elif key == "index":
                row[key] = int(value)
            else:
                row[key] = float(value) if value != "" else None
    return rows


# --- command line ------------------------------------------------------------------------------

def _arguments(argv):
    parser = argparse.ArgumentParser(prog="mechfmu sweep", description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="scene TOML file, or a name in sims/scenes/")
    parser.add_argument("--vary", action="append", default=[], metavar="COMP.PARAM=START:STOP:COUNT",
                        help="a parameter (or constant input) and its range; repeat for a grid")
    parser.add_argument("--samples", type=int, help="draw N points instead of the grid")
    parser.add_argument("--seed", type=int, help="seed of the sampling (with --samples)")
    parser.add_argument("--method", choices=("lhs", "random"), default="lhs",
                        help="sampling method (default: lhs, Latin hypercube)")
    parser.add_argument("--metrics", nargs="+", default=[], metavar="NAME",
                        help="final:c.v, max:c.v, min:c.v, time_of_max:c.v, "
                             "first_time_above:c.v:THRESHOLD, first_time_true:c.v, "
                             "max_abs_error:c.v")
    parser.add_argument("--out", help="output folder (default: out/sweep_<scene>)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="parallel processes (default: the number of cores)")
    parser.add_argument("--plot", action="store_true", help="one PNG per metric and parameter")
    parser.add_argument("--fmu-dir", default="fmus", help="folder of built FMUs (default: fmus)")
    return parser.parse_args(argv)


def main(argv):
    from .cosim.scene import SceneError
    args = _arguments(argv)
    path = Path(args.scene)
    if path.suffix != ".toml" and not path.exists():
        path = Path("sims/scenes") / f"{args.scene}.toml"
    try:
        varies = [parse_vary(text) for text in args.vary]
        metrics = [parse_metric(text) for text in args.metrics]
        if args.jobs < 1:
            raise SweepError("--jobs must be at least 1")
        summary = run_sweep(path, varies, metrics, args.out, args.jobs, args.samples,
                            args.seed, args.method, args.fmu_dir, args.plot)
    except (SweepError, SceneError) as error:
        print(f"sweep error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sweep interrupted; rows done are kept", file=sys.stderr)
        return 130
    print(f"{summary['scene']}: {summary['done']} point(s), {summary['failed']} failed, "
          f"{summary['wall_time_s']:.2f} s with {summary['jobs']} job(s)")
    print(f"csv: {summary['csv']}")
    for plot in summary.get("plots", []):
        print(f"png: {plot}")
    return 0
