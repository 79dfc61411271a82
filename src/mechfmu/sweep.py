"""Parameter sweeps of a scene (``mechfmu sweep``), on local processes or a Dask cluster.

``mechfmu sweep SCENE --vary comp.param=START:STOP:COUNT [--vary ...] --metrics NAME ...``
runs the scene at every point of the full grid (``numpy.linspace`` per parameter), or at
``--samples N --seed S`` Latin-hypercube (``--method lhs``, the default) or uniform random
(``--method random``) points over the ranges; ``--link`` sets parameters that follow a varied
one. A sweep file (sims/sweeps/*.toml) holds the same settings. The points run on ``--jobs``
local processes or on the Dask cluster at ``--scheduler``; each worker thread keeps one
instance per component and resets it between points. It writes into ``--out``
(default ``out/sweep_<sweep or scene>``):

sweep.csv    one row per point: index, each varied and linked parameter, each metric, error,
             wall_time_s, worker; a row is appended and flushed as each point finishes (rows
             in completion order)
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
import atexit
import copy
import csv
import dataclasses
import hashlib
import math
import multiprocessing.util
import os
import re
import signal
import socket
import sys
import tempfile
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from .cosim.files import atomic_write, inside, save_figure
from .cosim.results import read_csv, write_json
from .cosim.scene import read_toml


class SweepError(ValueError):
    """A sweep that cannot start as written (bad --vary, --metrics, sampling options)."""


SCENE_OVERRIDES = {"stop_time", "step"}  # scene keys a sweep may replace


# --- --vary ----------------------------------------------------------------------------------

def split_dotted(name, option, text, what="parameter"):
    """'component.variable' -> (component, variable), or SweepError naming the option."""
    component, dot, variable = name.strip().partition(".")
    if not dot or not component or not variable:
        raise SweepError(f"{option} {text!r}: {name!r} is not of the form component.{what}")
    return component, variable


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
    component, variable = split_dotted(name, "--vary", text)
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


@dataclasses.dataclass(frozen=True)
class Link:
    """A parameter that follows a varied one: target = factor * source at every point."""
    component: str
    variable: str
    factor: float
    source: str        # the varied parameter's component.parameter

    @property
    def name(self):
        return f"{self.component}.{self.variable}"


def parse_link(text):
    """'comp.param=FACTOR*comp.varied' or 'comp.param=comp.varied' -> Link."""
    if not isinstance(text, str) or text.count("=") != 1:
        raise SweepError(f"--link {text!r}: expected component.parameter=FACTOR*"
                         f"component.varied")
    name, spec = (part.strip() for part in text.split("="))
    component, variable = split_dotted(name, "--link", text)
    factor_text, star, source = spec.rpartition("*")
    factor = 1.0
    if star:
        try:
            factor = float(factor_text)
        except ValueError:
            raise SweepError(f"--link {text!r}: FACTOR {factor_text!r} is not a number") \
                from None
        if not math.isfinite(factor):
            raise SweepError(f"--link {text!r}: FACTOR must be finite")
    split_dotted(source, "--link", text)
    return Link(component, variable, factor, source.strip())


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
    split_dotted(variable, "--metrics", text, "variable")
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

def point_values(varies, links, kinds, values):
    """{component.variable: value} of one point: the varied values and the linked ones,
    as the FMI type wants them (Integer rounded)."""
    named = dict(zip((v.name for v in varies), (float(v) for v in values)))
    named.update({link.name: link.factor * named[link.source] for link in links})
    return {name: int(round(value)) if kinds[name][1] == "Integer" else value
            for name, value in named.items()}


def point_scene(scene, kinds, assigned):
    """A copy of ``scene`` with each parameter or constant input in ``assigned``
    ({component.variable: value}) set to its value."""
    components = {name: copy.deepcopy(spec) for name, spec in scene.components.items()}
    for name, value in assigned.items():
        component, _, variable = name.partition(".")
        target = components[component]
        (target.inputs if kinds[name][0] == "input" else target.parameters)[variable] = value
    return dataclasses.replace(scene, components=components)


def _sweepable(scene, descriptions, option, component, variable):
    """('parameter' | 'input', FMI type) of a variable a sweep may set, or SweepError."""
    name = f"{component}.{variable}"
    if component not in scene.components:
        raise SweepError(f"{option} {name}: no component {component!r}; "
                         f"components: {', '.join(scene.components)}")
    variables = {v.name: v for v in descriptions[component].modelVariables}
    found = variables.get(variable)
    if found is None:
        raise SweepError(f"{option} {name}: {component!r} has no variable {variable!r}; "
                         f"parameters: " + ", ".join(sorted(
                             v.name for v in variables.values() if v.causality == "parameter")))
    if found.type not in ("Real", "Integer"):
        raise SweepError(f"{option} {name}: a {found.type} cannot be swept "
                         f"(only Real and Integer)")
    if found.causality == "parameter":
        return "parameter", found.type
    if found.causality == "input" and variable in scene.components[component].inputs:
        return "input", found.type
    raise SweepError(f"{option} {name}: is a {found.causality}; only parameters and inputs "
                     f"given as constants under [components.{component}.inputs] can be swept")


def check_sweep(scene, varies, metrics, fmu_dir, links=()):
    """Check the sweep against the scene's FMUs before anything runs.

    Returns ({varied or linked name: ('parameter' | 'input', FMI type)},
    {metric text: reference signal}).
    """
    from .cosim import master
    simulation = master.Simulation(scene, fmu_dir)  # checks the scene itself
    descriptions = {name: master.model_description(master.resolve_fmu(spec, scene, fmu_dir))
                    for name, spec in scene.components.items()}
    kinds = {}
    for option, items in (("--vary", varies), ("--link", links)):
        for item in items:
            if item.name in kinds:
                raise SweepError(f"{option} {item.name}: already varied or linked")
            if option == "--link" and item.source not in {v.name for v in varies}:
                raise SweepError(f"--link {item.name}: its source {item.source} is not "
                                 f"varied; varied: {', '.join(v.name for v in varies)}")
            kinds[item.name] = _sweepable(scene, descriptions, option, item.component,
                                          item.variable)
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
    """Per local worker process: ignore Ctrl-C (the parent handles it)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


_THREAD = threading.local()  # a worker thread's Instances pool: it must outlive the tasks


def worker_instances():
    """This worker thread's Instances pool: each FMU extracted once, each instance reset
    (fmi2Reset) between points instead of re-created. Freed when the process exits."""
    pool = getattr(_THREAD, "instances", None)
    if pool is None:
        from .cosim.master import Instances
        pool = _THREAD.instances = Instances(keep=True)
        atexit.register(pool.close)
        # multiprocessing workers leave through os._exit: only its finalisers run there
        multiprocessing.util.Finalize(pool, pool.close, exitpriority=10)
    return pool


def fmu_cache_dir():
    """Where a worker keeps the FMUs shipped to it (one folder per content hash)."""
    user = getattr(os, "getuid", lambda: "user")()
    return Path(tempfile.gettempdir()) / f"mechfmu_fmus_{user}"


def shipped_scene(scene, fmu_files):
    """``scene`` with each component's FMU replaced by this worker's copy of the shipped
    file: ``fmu_files`` maps the client's path to (file name, sha256, bytes). Each file is
    written once per worker machine, atomically, under fmu_cache_dir()/<sha256>/."""
    components = {}
    for name, spec in scene.components.items():
        file_name, digest, data = fmu_files[spec.fmu]
        local = fmu_cache_dir() / digest / file_name
        if not local.is_file():
            atomic_write(local, data)
        components[name] = dataclasses.replace(spec, fmu=str(local))
    return dataclasses.replace(scene, components=components)


def worker_name():
    """'host:pid' of this worker process (the sweep.csv's worker column)."""
    return f"{socket.gethostname()}:{os.getpid()}"


def run_point(index, scene, metrics, references, fmu_files=None):
    """Run one point; returns (index, {metric text: value}, error message or None, wall s,
    worker name).

    The scene's components name their FMUs by absolute path (resolve_fmus); with
    ``fmu_files`` (a remote cluster) the worker uses its copies of the shipped files.
    """
    from .cosim.master import Simulation
    started = time.perf_counter()
    try:
        if fmu_files is not None:
            scene = shipped_scene(scene, fmu_files)
        result = Simulation(scene).run(instances=worker_instances())
        times = result.times
        values = {m.text: evaluate_metric(m, times, result.columns[m.variable],
                                          references.get(m.text)) for m in metrics}
        error = None
    except Exception as failure:  # SceneError, SimulationError, anything: the sweep goes on
        values, error = {}, f"{type(failure).__name__}: {failure}"
    return index, values, error, time.perf_counter() - started, worker_name()


def resolve_fmus(scene, fmu_dir):
    """``scene`` with every component's FMU as an absolute path (workers may run elsewhere
    than the current folder)."""
    from .cosim.master import resolve_fmu
    components = {name: dataclasses.replace(spec, fmu=str(resolve_fmu(spec, scene, fmu_dir)
                                                         .resolve()))
                  for name, spec in scene.components.items()}
    return dataclasses.replace(scene, components=components)


# --- where the points run ----------------------------------------------------------------------

class LocalPool:
    """Worker processes on this machine (concurrent.futures), reading the FMUs in place."""

    def __init__(self, jobs):
        self.workers, self.where = jobs, f"local, {jobs} process(es)"
        self.executor = ProcessPoolExecutor(max_workers=jobs, initializer=_worker_init)

    def ship(self, paths):
        return None

    def submit(self, *arguments):
        return self.executor.submit(run_point, *arguments)

    def completed(self, futures):
        return as_completed(futures)

    def close(self, interrupted):
        self.executor.shutdown(wait=not interrupted, cancel_futures=interrupted)


class DaskCluster:
    """An existing Dask cluster (``--scheduler tcp://HOST:PORT``). The FMUs are sent to the
    workers once (scattered) with their content hash, so the workers need mechfmu and a
    libpython, not the client's files."""

    def __init__(self, address, timeout=10.0):
        try:
            from distributed import Client
        except ImportError:  # pragma: no cover - a dependency of mechfmu
            raise SweepError("--scheduler needs the 'distributed' package") from None
        try:
            self.client = Client(address, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as error:
            raise SweepError(f"--scheduler {address}: cannot reach a Dask scheduler there "
                             f"within {timeout:g} s: {error}") from None
        threads = self.client.nthreads()
        if not threads:
            self.client.close()
            raise SweepError(f"--scheduler {address}: the cluster has no workers")
        self.workers = sum(threads.values())
        self.where = f"Dask {address}, {len(threads)} worker(s), {self.workers} thread(s)"

    def ship(self, paths):
        files = {}
        for path in paths:
            data = Path(path).read_bytes()
            files[path] = (Path(path).name, hashlib.sha256(data).hexdigest(), data)
        # one object, one copy per worker; tasks then name it instead of carrying the bytes
        return self.client.scatter([files], broadcast=True)[0]

    def submit(self, *arguments):
        return self.client.submit(run_point, *arguments, pure=False)

    def completed(self, futures):
        from distributed import as_completed as dask_completed
        return dask_completed(futures, loop=self.client.loop)

    def close(self, interrupted):
        self.client.close()


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
              method="lhs", fmu_dir="fmus", plot=False, on_point=None, progress=True,
              scheduler=None, links=(), overrides=None, name=None):
    """Run the sweep; returns the summary dict written to sweep.json.

    The points run on ``jobs`` local worker processes, or on the Dask cluster whose
    scheduler is at ``scheduler`` (tcp://HOST:PORT). ``links`` set parameters that follow
    varied ones; ``overrides`` replace the scene's stop_time or step. ``on_point(row)`` is
    called after each row is written (tests raise KeyboardInterrupt from it). On
    KeyboardInterrupt the pending points are cancelled, the JSON is marked ``interrupted``
    and the exception is re-raised.
    """
    from .cosim.scene import load_scene
    scene_path = Path(scene_path)
    unknown = set(overrides or {}) - SCENE_OVERRIDES
    if unknown:
        raise SweepError(f"cannot override the scene's {', '.join(sorted(unknown))}; "
                         f"only {', '.join(sorted(SCENE_OVERRIDES))}")
    scene = load_scene(scene_path, overrides)
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
    kinds, references = check_sweep(scene, varies, metrics, fmu_dir, links)
    scene = resolve_fmus(scene, fmu_dir)
    jobs = jobs or os.cpu_count() or 1
    name = name or scene.name
    out_dir = Path(out_dir) if out_dir else Path("out") / f"sweep_{name}"
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, json_path = out_dir / "sweep.csv", out_dir / "sweep.json"
    runner = DaskCluster(scheduler) if scheduler else LocalPool(jobs)
    summary = {
        "name": name, "scene": scene.name, "scene_file": str(scene_path.resolve()),
        "overrides": dict(overrides or {}),
        "varies": [{"name": v.name, "kind": kinds[v.name][0], "type": kinds[v.name][1],
                    "start": v.start, "stop": v.stop, "count": v.count} for v in varies],
        "links": [{"name": k.name, "kind": kinds[k.name][0], "type": kinds[k.name][1],
                   "factor": k.factor, "source": k.source} for k in links],
        "method": method_name, "seed": seed, "samples": samples,
        "metrics": [m.text for m in metrics], "jobs": runner.workers,
        "scheduler": scheduler, "where": runner.where, "fmu_dir": str(fmu_dir),
        "points": len(points), "started": _now(), "finished": None, "done": 0, "failed": 0,
        "interrupted": False, "wall_time_s": None, "scenes_per_s": None, "csv": str(csv_path),
        "command": sys.argv,
    }
    write_json(json_path, summary)
    names = [v.name for v in varies] + [k.name for k in links]
    header = ["index", *names, *(m.text for m in metrics), "error", "wall_time_s", "worker"]
    started = time.perf_counter()
    meter = Progress(len(points)) if progress else None
    rows = []
    handle = open(csv_path, "w", newline="", encoding="utf-8")
    writer = csv.writer(handle, lineterminator="\n")
    writer.writerow(header)
    handle.flush()
    futures = {}
    try:
        shipped = runner.ship(sorted({spec.fmu for spec in scene.components.values()}))
        for index, values in enumerate(points):
            assigned = point_values(varies, links, kinds, values)
            future = runner.submit(index, point_scene(scene, kinds, assigned), metrics,
                                   references, shipped)
            futures[future] = (index, [assigned[n] for n in names])
        for future in runner.completed(list(futures)):
            index, point = futures[future]
            try:
                _, values, error, wall, worker = future.result()
            except Exception as failure:  # the worker itself failed (died, cannot unpickle)
                values, wall, worker = {}, None, None
                error = f"worker: {type(failure).__name__}: {failure}"
            row = {"index": index, **dict(zip(names, point)), **values,
                   "error": error, "wall_time_s": wall, "worker": worker}
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
        for future in futures:
            future.cancel()
        summary["interrupted"] = True
        raise
    finally:
        handle.close()
        runner.close(summary["interrupted"])
        summary["finished"] = _now()
        summary["wall_time_s"] = time.perf_counter() - started
        summary["scenes_per_s"] = summary["done"] / summary["wall_time_s"]
        if meter and summary["interrupted"]:
            meter.stream.write("\n")
        if plot and rows:
            summary["plots"] = [str(p) for p in write_plots(out_dir, rows,
                                                                 names[:len(varies)], metrics)]
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
            path = inside(out_dir, f"{safe_name(metric.text)}_vs_{safe_name(name)}.png")
            try:
                paths.append(save_figure(path, figure, dpi=100))
            finally:
                pyplot.close(figure)
    return paths


def read_sweep_csv(path):
    """Rows of a sweep.csv as dicts (numbers as floats, empty cells as None)."""
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        for key, value in row.items():
            if key in ("error", "worker"):
                row[key] = value or None
            elif key == "index":
                row[key] = int(value)
            else:
                row[key] = float(value) if value != "" else None
    return rows


# --- sweep files -------------------------------------------------------------------------------

SWEEP_KEYS = {"description", "scene", "vary", "link", "metrics", "samples", "seed", "method",
              "stop_time", "step"}


def is_sweep_file(data):
    """A sweep file names its scene; a scene file has components."""
    return "scene" in data and "components" not in data


def load_sweep_file(path):
    """A sweep file (TOML) -> run_sweep's settings: {'scene_path', 'varies', 'links',
    'metrics', 'samples', 'seed', 'method', 'overrides', 'name', 'description'}.

    Keys: scene (a scene file, relative to the sweep file), vary, link, metrics (lists of
    the command line's strings), optional samples, seed, method, and stop_time / step
    replacing the scene's. The sweep's name is the file's stem.
    """
    path = Path(path)
    data = read_toml(path, SweepError, "sweep file")
    unknown = set(data) - SWEEP_KEYS
    if unknown:
        raise SweepError(f"{path}: unknown key(s) {', '.join(sorted(unknown))}; allowed: "
                         f"{', '.join(sorted(SWEEP_KEYS))}")
    if not isinstance(data.get("scene"), str):
        raise SweepError(f"{path}: 'scene' must name a scene file")
    for key in ("vary", "link", "metrics"):
        items = data.get(key, [])
        if not isinstance(items, list) or not all(isinstance(i, str) for i in items):
            raise SweepError(f"{path}: '{key}' must be a list of strings")
    try:
        return {
            "scene_path": path.parent / data["scene"],
            "varies": [parse_vary(text) for text in data.get("vary", [])],
            "links": [parse_link(text) for text in data.get("link", [])],
            "metrics": [parse_metric(text) for text in data.get("metrics", [])],
            "samples": data.get("samples"), "seed": data.get("seed"),
            "method": data.get("method", "lhs"),
            "overrides": {key: data[key] for key in SCENE_OVERRIDES if key in data},
            "name": path.stem, "description": data.get("description", ""),
        }
    except SweepError as error:
        raise SweepError(f"{path}: {error}") from None


def locate(text):
    """A sweep or scene file: a path, or a name in sims/sweeps/ then sims/scenes/."""
    path = Path(text)
    if path.exists() or path.suffix == ".toml":
        return path
    for folder in ("sims/sweeps", "sims/scenes"):
        candidate = Path(folder) / f"{text}.toml"
        if candidate.is_file():
            return candidate
    return path


def settings(args):
    """run_sweep's settings from the command line, over those of a sweep file if given."""
    path = locate(args.scene)
    try:
        data = read_toml(path, SweepError)
    except SweepError:
        data = {}  # load_scene reports it, as a scene file
    if is_sweep_file(data):
        chosen = load_sweep_file(path)
    else:
        chosen = {"scene_path": path, "varies": [], "links": [], "metrics": [],
                  "samples": None, "seed": None, "method": "lhs", "overrides": {},
                  "name": None}
    chosen.pop("description", None)
    if args.vary:
        chosen["varies"] = [parse_vary(text) for text in args.vary]
    if args.link:
        chosen["links"] = [parse_link(text) for text in args.link]
    if args.metrics:
        chosen["metrics"] = [parse_metric(text) for text in args.metrics]
    for key in ("samples", "seed", "method"):
        if getattr(args, key) is not None:
            chosen[key] = getattr(args, key)
    return chosen


# --- command line ------------------------------------------------------------------------------

def _arguments(argv):
    parser = argparse.ArgumentParser(prog="mechfmu sweep", description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="sweep or scene TOML file, or a name in sims/sweeps/ "
                                      "or sims/scenes/")
    parser.add_argument("--vary", action="append", default=[], metavar="COMP.PARAM=START:STOP:COUNT",
                        help="a parameter (or constant input) and its range; repeat for a grid")
    parser.add_argument("--link", action="append", default=[],
                        metavar="COMP.PARAM=FACTOR*COMP.VARIED",
                        help="a parameter that follows a varied one (target = factor * value)")
    parser.add_argument("--samples", type=int, help="draw N points instead of the grid")
    parser.add_argument("--seed", type=int, help="seed of the sampling (with --samples)")
    parser.add_argument("--method", choices=("lhs", "random"),
                        help="sampling method (default: lhs, Latin hypercube)")
    parser.add_argument("--metrics", nargs="+", default=[], metavar="NAME",
                        help="final:c.v, max:c.v, min:c.v, time_of_max:c.v, "
                             "first_time_above:c.v:THRESHOLD, first_time_true:c.v, "
                             "max_abs_error:c.v")
    parser.add_argument("--out", help="output folder (default: out/sweep_<scene>)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="parallel processes (default: the number of cores)")
    parser.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="run on this Dask cluster instead of local processes")
    parser.add_argument("--plot", action="store_true", help="one PNG per metric and parameter")
    parser.add_argument("--fmu-dir", default="fmus", help="folder of built FMUs (default: fmus)")
    return parser.parse_args(argv)


def main(argv):
    from .cosim.scene import SceneError
    args = _arguments(argv)
    try:
        if args.jobs < 1:
            raise SweepError("--jobs must be at least 1")
        summary = run_sweep(**settings(args), out_dir=args.out, jobs=args.jobs,
                            fmu_dir=args.fmu_dir, plot=args.plot, scheduler=args.scheduler)
    except (SweepError, SceneError) as error:
        print(f"sweep error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sweep interrupted; rows done are kept", file=sys.stderr)
        return 130
    print(f"{summary['name']}: {summary['done']} point(s), {summary['failed']} failed, "
          f"{summary['wall_time_s']:.2f} s ({summary['scenes_per_s']:.1f} scenes/s) on "
          f"{summary['where']}")
    print(f"csv: {summary['csv']}")
    for plot in summary.get("plots", []):
        print(f"png: {plot}")
    return 0
