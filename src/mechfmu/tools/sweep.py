"""Parameter sweeps of a scene (``mechfmu sweep``), on local processes or a Dask cluster.

``mechfmu sweep SCENE --vary comp.param=START:STOP:COUNT [--vary ...] --metrics NAME ...``
runs the scene at every point of the full grid (``numpy.linspace`` per parameter), or at
``--samples N --seed S`` Latin-hypercube (``--method lhs``, the default) or uniform random
(``--method random``) points over the ranges; ``--link`` sets parameters that follow a varied
one. A sweep file (such as the shipped src/mechfmu/sweeps/*.toml) holds the same settings.
The points run on ``--jobs`` local processes or on the Dask cluster at ``--scheduler``; each worker thread keeps one
instance per component and resets it between points. It writes into ``--out``
(default ``out/sweep_<sweep or scene>``):

sweep.csv    one row per point: index, each varied and linked parameter, each metric, error,
             wall_time_s, worker; a row is appended and flushed as each point finishes (rows
             in completion order)
sweep.json   the sweep's definition and its state (replaced atomically after every point;
             ``"interrupted": true`` and the signal after Ctrl-C or SIGTERM)
<metric>_vs_<parameter>.png   with ``--plot``

A point lost with its worker process is run again (``--retries``, the last attempt alone);
``--resume`` finishes a stopped sweep without redoing its finished points.

Metrics: ``final:c.v``, ``max:c.v``, ``min:c.v``, ``time_of_max:c.v`` (the first time the
signal comes within TIME_OF_MAX_RTOL of its largest |value| below its maximum, so a plateau
gives its start whatever its last bits are),
``first_time_above:c.v:THRESHOLD``, ``first_time_true:c.v`` (Boolean or 0/1 flag columns),
``max_abs_error:c.v`` (against the scene's reference CSV, interpolated onto the result's
times). A metric whose event never happens is ``nan``. A point whose scene fails (SceneError,
SimulationError) gets its message in ``error`` and empty metrics; the sweep goes on, and the
command exits 1 at the end, naming the failed points.
"""

from __future__ import annotations

from typing import TYPE_CHECKING
import atexit
import copy
import csv
import dataclasses
import hashlib
import io
import json
import importlib
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
from contextlib import nullcontext
from datetime import datetime, timezone
from pathlib import Path
from typing import Any
from collections.abc import Callable, Iterable, Iterator

import numpy as np
import pandas
from scipy.stats import qmc

from ..cosim import limits
from ..cosim.files import atomic_write, inside, save_figure
from ..cosim.results import FORMATS, require_pyarrow, write_json
from ..cosim.scene import SCENE_DIR, SWEEP_DIR, find_file, read_toml, refuse_unknown_keys
from .parallel import LocalPool, workers_problem
from .progress import Progress
from argparse import Namespace

if TYPE_CHECKING:  # annotations only (from __future__ import annotations)
    from distributed.client import Future
    from fmpy.model_description import ModelDescription
    from ..cosim.interrupt import InterruptGuard
    from ..cosim.master import Instances
    from ..cosim.scene import Scene
    from numpy import ndarray


class SweepError(ValueError):
    """A sweep that cannot start as written (bad --vary, --metrics, sampling options)."""


SCENE_OVERRIDES = {"stop_time", "step"}  # scene keys a sweep may replace


# --- --vary ----------------------------------------------------------------------------------


def split_dotted(name: str, option: str, text: str, what: str = "parameter") -> tuple[str, str]:
    """'component.variable' -> (component, variable), or SweepError naming the option."""
    component, dot, variable = name.strip().partition(".")
    if not dot or not component or not variable:
        raise SweepError(f"{option} {text!r}: {name!r} is not of the form component.{what}")
    return component, variable


@dataclasses.dataclass(frozen=True)
class _Parameter:
    """A component's parameter a sweep sets."""

    component: str
    variable: str

    @property
    def name(self) -> str:
        return f"{self.component}.{self.variable}"


@dataclasses.dataclass(frozen=True)
class Vary(_Parameter):
    """A parameter varied from ``start`` to ``stop`` (its SI unit) over ``count`` values."""

    start: float
    stop: float
    count: int | None = None  # None: only a range (sampling)


def parse_vary(text: str) -> Vary:
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
class Link(_Parameter):
    """A parameter that follows a varied one: target = factor * source at every point."""

    factor: float
    source: str  # the varied parameter's component.parameter


def parse_link(text: str) -> Link:
    """'comp.param=FACTOR*comp.varied' or 'comp.param=comp.varied' -> Link."""
    if not isinstance(text, str) or text.count("=") != 1:
        raise SweepError(f"--link {text!r}: expected component.parameter=FACTOR*component.varied")
    name, spec = (part.strip() for part in text.split("="))
    component, variable = split_dotted(name, "--link", text)
    factor_text, star, source = spec.rpartition("*")
    factor = 1.0
    if star:
        try:
            factor = float(factor_text)
        except ValueError:
            raise SweepError(f"--link {text!r}: FACTOR {factor_text!r} is not a number") from None
        if not math.isfinite(factor):
            raise SweepError(f"--link {text!r}: FACTOR must be finite")
    split_dotted(source, "--link", text)
    return Link(component, variable, factor, source.strip())


# --- points ------------------------------------------------------------------------------------


POINT_CHUNK = 4096  # points made at a time (a sweep of any size holds one chunk)
LHS_WHOLE = 1 << 20  # Latin hypercubes up to this size: scipy's, made whole (8 MB per dimension)


def _grid_counts(varies: list[Vary]) -> list[int]:
    for vary in varies:
        if vary.count is None:
            raise SweepError(
                f"--vary {vary.name}: a grid needs START:STOP:COUNT (or use --samples N)"
            )
    return [int(v.count or 0) for v in varies]


def point_count(varies: list[Vary], samples: int | None) -> int:
    """How many points the sweep has: ``samples``, or the grid's product of counts (an
    exact integer however large)."""
    if samples is not None:
        return samples
    return math.prod(_grid_counts(varies))


def size_problem(varies: list[Vary], samples: int | None, max_points: int) -> str | None:
    """The one line refusing a sweep of more than ``max_points`` points, or None."""
    count = point_count(varies, samples)
    if count <= max_points:
        return None
    shape = (
        f"--samples {samples}"
        if samples is not None
        else "a grid of " + " x ".join(str(v.count) for v in varies)
    )
    return (
        f"{count} points ({shape}), more than the limit of {max_points}; "
        f"--max-points {count} lifts it"
    )


def linspace_at(start: float, stop: float, count: int, k: ndarray) -> ndarray:
    """``numpy.linspace(start, stop, count)[k]`` for the indices ``k`` alone, bit for bit
    (numpy's own formula: k * step + start, the last point exactly ``stop``), without
    making the ``count`` values."""
    k = np.asarray(k)
    if count == 1:
        return np.full(k.shape, float(start))
    delta = float(stop) - float(start)
    step = delta / (count - 1)
    if step == 0.0:  # numpy's route when the step underflows
        values = k.astype(float) / (count - 1) * delta + start
    else:
        values = k.astype(float) * step + start
    return np.where(k == count - 1, float(stop), values)


def grid_chunks(varies: list[Vary], chunk: int = POINT_CHUNK) -> Iterator[tuple[int, ndarray]]:
    """The full grid (every combination of each parameter's linspace, last varying
    fastest) as (index of the first point, points) of ``chunk`` rows at a time."""
    counts = _grid_counts(varies)
    total = math.prod(counts)
    for first in range(0, total, chunk):
        indices = np.unravel_index(np.arange(first, min(first + chunk, total)), counts)
        yield (
            first,
            np.stack(
                [linspace_at(v.start, v.stop, n, k) for v, n, k in zip(varies, counts, indices)],
                axis=1,
            ),
        )


def grid_points(varies: list[Vary]) -> ndarray:
    """The full grid: every combination of each parameter's linspace, last varying fastest."""
    return np.concatenate([points for _, points in grid_chunks(varies)])


def lhs_unit(samples: int, dimensions: int, seed: int | None) -> ndarray:
    """Latin hypercube in [0, 1)^d: in each dimension exactly one sample per stratum
    [k/N, (k+1)/N), placed uniformly inside it; reproducible with ``seed``."""
    return qmc.LatinHypercube(d=dimensions, seed=seed).random(samples)


class Permutation:
    """A pseudo-random permutation of range(n) evaluated at any indices in constant memory:
    a four-round Feistel network over the smallest even-bit domain holding n, walking the
    cycle back into range (at most a few steps: the domain is under 4 n)."""

    def __init__(self, n: int, rng: np.random.Generator) -> None:
        bits = max(2, (n - 1).bit_length())
        self.half = (bits + 1) // 2
        self.mask = np.uint64((1 << self.half) - 1)
        self.n = n
        self.keys = rng.integers(0, 2**63, size=4, dtype=np.uint64)

    def _round(self, right: ndarray, key: np.uint64) -> ndarray:
        mixed = (right + key) * np.uint64(0x9E3779B97F4A7C15)  # wraps: a mixing multiply
        return (mixed ^ (mixed >> np.uint64(29))) & self.mask

    def _encrypt(self, x: ndarray) -> ndarray:
        shift = np.uint64(self.half)
        left, right = x >> shift, x & self.mask
        for key in self.keys:
            left, right = right, left ^ self._round(right, key)
        return (left << shift) | right

    def __call__(self, k: ndarray) -> ndarray:
        with np.errstate(over="ignore"):
            out = self._encrypt(np.asarray(k, dtype=np.uint64))
            outside = out >= np.uint64(self.n)
            while outside.any():
                out[outside] = self._encrypt(out[outside])
                outside = out >= np.uint64(self.n)
        return out.astype(np.int64)


def _unit_chunks(
    samples: int,
    dimensions: int,
    seed: int | None,
    method: str,
    chunk: int,
    whole: int = LHS_WHOLE,
) -> Iterator[tuple[int, ndarray]]:
    """(first index, points in [0, 1)^d) of the sampled sweep, ``chunk`` at a time; a
    Latin hypercube of up to ``whole`` points is scipy's."""
    if method == "lhs" and samples <= whole:
        unit = lhs_unit(samples, dimensions, seed)
        for first in range(0, samples, chunk):
            yield first, unit[first : first + chunk]
        return
    rng = np.random.default_rng(seed)
    strata = [Permutation(samples, rng) for _ in range(dimensions)] if method == "lhs" else []
    for first in range(0, samples, chunk):
        rows = min(chunk, samples - first)
        jitter = rng.random((rows, dimensions))  # the same stream as one draw of them all
        if not strata:
            yield first, jitter
            continue
        k = np.arange(first, first + rows)
        cells = np.stack([permutation(k) for permutation in strata], axis=1)
        yield first, (cells + jitter) / samples


def sample_chunks(
    varies: list[Vary],
    samples: int,
    seed: int | None,
    method: str = "lhs",
    chunk: int = POINT_CHUNK,
) -> Iterator[tuple[int, ndarray]]:
    """``samples`` points over the ranges, Latin hypercube ('lhs') or uniform ('random'), as
    (index of the first point, points) ``chunk`` at a time. Up to LHS_WHOLE samples the
    hypercube is scipy's; beyond, each dimension's strata come from a Permutation, so a
    sweep of any size holds one chunk."""
    if samples < 1:
        raise SweepError("--samples must be at least 1")
    if method not in ("lhs", "random"):
        raise SweepError(f"--method {method!r}: expected lhs or random")
    low = np.array([v.start for v in varies])
    high = np.array([v.stop for v in varies])
    for first, unit in _unit_chunks(samples, len(varies), seed, method, chunk):
        yield first, low + unit * (high - low)


def sample_points(
    varies: list[Vary], samples: int, seed: int | None, method: str = "lhs"
) -> ndarray:
    """``samples`` points over the ranges: Latin hypercube ('lhs') or uniform ('random')."""
    return np.concatenate([points for _, points in sample_chunks(varies, samples, seed, method)])


# --- metrics -----------------------------------------------------------------------------------

METRICS = {
    "final": 0,
    "max": 0,
    "min": 0,
    "time_of_max": 0,
    "first_time_above": 1,
    "first_time_true": 0,
    "max_abs_error": 0,
}  # kind -> number of extra arguments


@dataclasses.dataclass(frozen=True)
class Metric:
    text: str  # as given: the CSV column's name
    kind: str
    variable: str  # component.variable
    threshold: float | None = None


def parse_metric(text: str) -> Metric:
    """'kind:comp.var' or 'first_time_above:comp.var:THRESHOLD' -> Metric."""
    if not isinstance(text, str):
        raise SweepError(f"--metrics {text!r}: expected KIND:component.variable")
    parts = text.split(":")
    kind = parts[0]
    if kind not in METRICS:
        raise SweepError(f"--metrics {text!r}: unknown kind {kind!r}; known: {', '.join(METRICS)}")
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
            raise SweepError(
                f"--metrics {text!r}: THRESHOLD {parts[2]!r} is not a number"
            ) from None
    return Metric(text, kind, variable, threshold)


# time_of_max: values within TIME_OF_MAX_RTOL * max|values| of the maximum count as the
# maximum. On a plateau (a valve dwell, a settled deflection) the samples differ only by
# rounding, ~1e-16 relative, which differs between CPUs' kernels: argmax alone would pick a
# different sample on another machine. 1e-9 is far above rounding and far below any
# difference a metric is meant to resolve.
TIME_OF_MAX_RTOL = 1e-9


def first_time(times: ndarray, mask: ndarray) -> float:
    """Time of the first True in ``mask``, or nan."""
    hits = np.flatnonzero(mask)
    return float(times[hits[0]]) if hits.size else math.nan


def evaluate_metric(
    metric: Metric, times: Any, values: Any, reference: tuple[Any, Any] | None = None
) -> float:
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
        finite = values[np.isfinite(values)]
        if finite.size == 0:
            return math.nan
        peak = float(np.max(finite))
        band = TIME_OF_MAX_RTOL * float(np.max(np.abs(finite)))
        return first_time(times, values >= peak - band)
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


def point_values(
    varies: list[Vary],
    links: tuple[()] | list[Link],
    kinds: dict[str, tuple[str, str]],
    values: list[float] | ndarray,
) -> dict[str, float]:
    """{component.variable: value} of one point: the varied values and the linked ones,
    as the FMI type wants them (Integer rounded)."""
    named = dict(zip((v.name for v in varies), (float(v) for v in values)))
    named.update({link.name: link.factor * named[link.source] for link in links})
    return {
        name: int(round(value)) if kinds[name][1] == "Integer" else value
        for name, value in named.items()
    }


def point_scene(
    scene: Scene, kinds: dict[str, tuple[str, str]], assigned: dict[str, float | bool]
) -> Scene:
    """A copy of ``scene`` with each parameter or constant input in ``assigned``
    ({component.variable: value}) set to its value."""
    components = {name: copy.deepcopy(spec) for name, spec in scene.components.items()}
    for name, value in assigned.items():
        component, _, variable = name.partition(".")
        target = components[component]
        (target.inputs if kinds[name][0] == "input" else target.parameters)[variable] = value
    return dataclasses.replace(scene, components=components)


def _sweepable(
    scene: Scene,
    descriptions: dict[str, ModelDescription],
    option: str,
    component: str,
    variable: str,
) -> tuple[str, str]:
    """('parameter' | 'input', FMI type) of a variable a sweep may set, or SweepError."""
    name = f"{component}.{variable}"
    if component not in scene.components:
        raise SweepError(
            f"{option} {name}: no component {component!r}; "
            f"components: {', '.join(scene.components)}"
        )
    variables = {v.name: v for v in descriptions[component].modelVariables}
    found = variables.get(variable)
    if found is None:
        raise SweepError(
            f"{option} {name}: {component!r} has no variable {variable!r}; "
            f"parameters: "
            + ", ".join(sorted(v.name for v in variables.values() if v.causality == "parameter"))
        )
    if found.type not in ("Real", "Integer"):
        raise SweepError(f"{option} {name}: a {found.type} cannot be swept (only Real and Integer)")
    if found.causality == "parameter":
        return "parameter", found.type
    if found.causality == "input" and variable in scene.components[component].inputs:
        return "input", found.type
    raise SweepError(
        f"{option} {name}: is a {found.causality}; only parameters and inputs "
        f"given as constants under [components.{component}.inputs] can be swept"
    )


def check_sweep(
    scene: Scene,
    varies: list[Vary],
    metrics: list[Metric],
    fmu_dir: str | Path,
    links: tuple[()] | list[Link] = (),
) -> tuple:
    """Check the sweep against the scene's FMUs before anything runs.

    Returns ({varied or linked name: ('parameter' | 'input', FMI type)},
    {metric text: reference signal}).
    """
    from ..cosim import master

    simulation = master.Simulation(scene, fmu_dir)  # checks the scene itself
    descriptions = {
        name: master.model_description(master.resolve_fmu(spec, scene, fmu_dir))
        for name, spec in scene.components.items()
    }
    kinds = {}
    for option, items in (("--vary", varies), ("--link", links)):
        for item in items:
            if item.name in kinds:
                raise SweepError(f"{option} {item.name}: already varied or linked")
            if isinstance(item, Link) and item.source not in {v.name for v in varies}:
                raise SweepError(
                    f"--link {item.name}: its source {item.source} is not "
                    f"varied; varied: {', '.join(v.name for v in varies)}"
                )
            kinds[item.name] = _sweepable(
                scene, descriptions, option, item.component, item.variable
            )
    recorded = [name for name, _, _ in simulation.recorded]
    references = {}
    reference_data = None
    for metric in metrics:
        if metric.variable not in recorded:
            raise SweepError(
                f"--metrics {metric.text}: {metric.variable} is not recorded by "
                f"the scene; recorded: {', '.join(recorded)}"
            )
        if metric.kind == "max_abs_error":
            if scene.reference is None:
                raise SweepError(f"--metrics {metric.text}: the scene has no reference CSV")
            if reference_data is None:
                from ..io import read_result

                try:
                    reference_data = read_result(scene.reference)
                except ValueError as error:  # ResultFileError names the file
                    raise SweepError(
                        f"--metrics {metric.text}: cannot read the reference: {error}"
                    ) from None
            ref_times, ref_columns = reference_data.index.to_numpy(), reference_data
            if metric.variable not in ref_columns:
                raise SweepError(
                    f"--metrics {metric.text}: the reference {scene.reference} "
                    f"has no column {metric.variable}"
                )
            references[metric.text] = (ref_times, ref_columns[metric.variable].to_numpy())
    return kinds, references


# --- the worker --------------------------------------------------------------------------------


def _worker_init() -> None:
    """Per local worker process: ignore Ctrl-C (the parent handles it)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


_THREAD = threading.local()  # a worker thread's Instances pool: it must outlive the tasks


def worker_instances() -> Instances:
    """This worker thread's Instances pool: each FMU extracted once, each instance reset
    (fmi2Reset) between points instead of re-created. Freed when the process exits."""
    pool = getattr(_THREAD, "instances", None)
    if pool is None:
        from ..cosim.master import Instances

        pool = _THREAD.instances = Instances(keep=True)
        atexit.register(pool.close)
        # multiprocessing workers leave through os._exit: only its finalisers run there
        multiprocessing.util.Finalize(pool, pool.close, exitpriority=10)
    return pool


def fmu_cache_dir() -> Path:
    """Where a worker keeps the FMUs shipped to it (one folder per content hash)."""
    user = getattr(os, "getuid", lambda: "user")()
    return Path(tempfile.gettempdir()) / f"mechfmu_fmus_{user}"


def shipped_scene(scene: Any, fmu_files: Any) -> Any:
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


def worker_name() -> str:
    """'host:pid' of this worker process (the sweep.csv's worker column)."""
    return f"{socket.gethostname()}:{os.getpid()}"


def run_point(
    index: int,
    scene: Scene,
    metrics: list[Metric],
    references: dict[Any, Any],
    fmu_files: dict | None = None,
) -> tuple[int, dict[str, float], str | None, float, str]:
    """Run one point; returns (index, {metric text: value}, error message or None, wall s,
    worker name).

    The scene's components name their FMUs by absolute path (resolve_fmus); with
    ``fmu_files`` (a remote cluster) the worker uses its copies of the shipped files.
    """
    from ..cosim.master import Simulation

    started = time.perf_counter()
    try:
        if fmu_files is not None:
            scene = shipped_scene(scene, fmu_files)
        result = Simulation(scene).run(instances=worker_instances())
        times = result.times
        values = {
            m.text: evaluate_metric(m, times, result.columns[m.variable], references.get(m.text))
            for m in metrics
        }
        error = None
    except Exception as failure:  # SceneError, SimulationError, anything: the sweep goes on
        values, error = {}, f"{type(failure).__name__}: {failure}"
    return index, values, error, time.perf_counter() - started, worker_name()


def resolve_fmus(scene: Scene, fmu_dir: str | Path) -> Scene:
    """``scene`` with every component's FMU as an absolute path (workers may run elsewhere
    than the current folder)."""
    from ..cosim.master import resolve_fmu

    components = {
        name: dataclasses.replace(spec, fmu=str(resolve_fmu(spec, scene, fmu_dir).resolve()))
        for name, spec in scene.components.items()
    }
    return dataclasses.replace(scene, components=components)


# --- where the points run ----------------------------------------------------------------------


class DaskCluster:
    """An existing Dask cluster (``--scheduler tcp://HOST:PORT``). The FMUs are sent to the
    workers once (scattered) with their content hash, so the workers need mechfmu and a
    libpython, not the client's files. The scheduler reschedules the points of a worker that
    dies (up to its distributed.scheduler.allowed-failures, then KilledWorker: the point's
    error)."""

    def __init__(self, address: str, timeout: float = 10.0) -> None:
        try:
            from distributed import Client
        except ImportError:  # an optional dependency: the extra mechfmu[cluster]
            raise SweepError(
                f"--scheduler {address} needs Dask's 'distributed' package, "
                f"which the base install leaves out: pip install "
                f"'mechfmu[cluster]'"
            ) from None
        probe_scheduler(address, timeout)
        try:
            self.client = Client(address, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as error:
            raise SweepError(
                f"--scheduler {address}: cannot reach a Dask scheduler there "
                f"within {timeout:g} s: {error}"
            ) from None
        threads = self.client.nthreads()
        if not threads:
            self.client.close()
            raise SweepError(f"--scheduler {address}: the cluster has no workers")
        self.workers = sum(threads.values())
        self.where = f"Dask {address}, {len(threads)} worker(s), {self.workers} thread(s)"

    def ship(self, paths: list[str]) -> Future:
        files = {}
        for path in paths:
            data = Path(path).read_bytes()
            files[path] = (Path(path).name, hashlib.sha256(data).hexdigest(), data)
        # one object, one copy per worker; tasks then name it instead of carrying the bytes
        return self.client.scatter([files], broadcast=True)[0]

    def submit(self, *arguments: Any) -> Future:
        return self.client.submit(run_point, *arguments, pure=False)

    @staticmethod
    def wait(futures: list[Future], timeout: float) -> list[Any]:
        """The futures among ``futures`` that are done, polling up to ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while True:
            done = [future for future in futures if future.done()]
            if done or time.monotonic() >= deadline:
                return done
            time.sleep(0.02)

    @staticmethod
    def lost(error: Any) -> bool:
        return False  # the scheduler has retried it already

    def restart(self) -> None:
        pass

    def idle(self) -> None:
        pass

    def alone(self) -> Any:
        return self

    def close(self, interrupted: bool) -> None:
        self.client.close()


def probe_scheduler(address: str, timeout: float) -> None:
    """Check that a Dask scheduler answers at ``address`` (tcp://HOST:PORT) within
    ``timeout`` s: a TCP connection, then Dask's handshake (each side sends a small framed
    message first). distributed itself would wait for ever for a handshake from a server
    that stays silent, and reads garbage as frame lengths (asking for exabytes); SweepError
    says which of the three failed. Other address schemes are left to distributed."""
    scheme, _, location = address.partition("://")
    if not location:
        scheme, location = "tcp", address
    if scheme != "tcp":
        return
    host, _, port = location.rpartition(":")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except (OSError, ValueError) as error:
        raise SweepError(
            f"--scheduler {address}: cannot reach a Dask scheduler there within "
            f"{timeout:g} s: {error}"
        ) from None
    from concurrent.futures import ThreadPoolExecutor  # own event loop, whoever calls us

    with ThreadPoolExecutor(1) as thread:
        problem = thread.submit(_handshake_problem, f"tcp://{location}", timeout).result()
    if problem:
        raise SweepError(f"--scheduler {address}: {problem}")


def _handshake_problem(address: Any, timeout: float):
    """None if a Dask comm at ``address`` completes its handshake within ``timeout`` s, else
    what went wrong (one line)."""
    import asyncio

    from distributed.comm import connect

    async def handshake() -> None:
        comm = await connect(address, timeout=timeout)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(handshake(), timeout))
    except (asyncio.TimeoutError, TimeoutError):
        return (
            f"something accepted the connection but sent no Dask handshake within "
            f"{timeout:g} s: is it a Dask scheduler?"
        )
    except Exception as error:  # garbage parsed as Dask frames fails in many ways
        text = " ".join(f"{type(error).__name__}: {error}".split())
        return (
            f"something answered there, but not a Dask scheduler (its first message "
            f"is not a Dask handshake: {text[:200]})"
        )
    return None


# --- the runner --------------------------------------------------------------------------------


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _format(value: float | None) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def safe_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")


DEFAULT_RETRIES = 2  # extra attempts of a point whose worker process died; the last one alone
# What a resumed sweep must share with the stopped one (its sweep.json): the points and
# what is computed at each, including the FMU files' contents.
RESUME_KEYS = (
    "scene_file",
    "overrides",
    "varies",
    "links",
    "method",
    "seed",
    "samples",
    "metrics",
    "points",
    "fmus",
)


class SweepInterrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM (``signum``) stopped the sweep; the rows done are kept."""

    def __init__(self, signum: signal.Signals) -> None:
        super().__init__(signum)
        self.signum = signum


class _Stopped(Exception):
    """The sweep's InterruptGuard received a signal."""


def at_least(option: str, value: int, minimum: int) -> int:
    """``value`` if it is a whole number >= ``minimum``, else SweepError naming the option."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise SweepError(f"{option} = {value!r} must be at least {minimum} (a whole number)")
    return value


def fmu_digests(scene: Scene) -> dict[str, str]:
    """{component: SHA-256 of its FMU file} (resolved paths): what a resumed sweep checks."""
    return {
        name: hashlib.sha256(Path(spec.fmu).read_bytes()).hexdigest()
        for name, spec in scene.components.items()
    }


@dataclasses.dataclass
class _Task:
    """One point to run: its index, its varied and linked values (the CSV's order), its
    scene, and how many times it was sent to a worker."""

    index: int
    point: list
    scene: object
    attempts: int = 0


def _run_points(
    runner: Any,
    tasks: Iterable[_Task],
    arguments: tuple,
    retries: int,
    guard: InterruptGuard,
    record: Callable,
    summary: dict[str, Any],
    window: int | None = None,
) -> None:
    """Run every task on ``runner``, calling ``record(task, (values, error, wall, worker))``
    as each finishes.

    The tasks are taken from their iterator as the workers need them: at most ``window``
    (default four per worker) are sent and not yet finished, so a sweep of any size holds
    a few of them. A task lost with its worker process (runner.lost: the local pool broke)
    is sent again to a new pool, up to ``retries`` more times; the last attempt runs alone
    in a pool of one process, so a point that kills its worker every time fails by itself
    and the points that only shared a pool with it are never blamed. A pool may break while
    points are still being sent (its worker died, and the executor refuses the next submit
    before it has failed the points in flight): the point refused was never run, so it
    goes back to the queue with its attempts unchanged. Every 0.25 s at most the guard is
    asked; a signal raises _Stopped.
    """
    source = iter(tasks)
    window = window or max(4 * runner.workers, 8)
    waiting: list[_Task] = []  # lost tasks to send again
    last_chance: list[_Task] = []
    more = True  # the iterator may hold tasks still
    while more or waiting or last_chance:
        alone = not (more or waiting)
        if alone:  # the runner's part is over: only points on their last attempt remain
            runner.idle()
            pool, queue = runner.alone(), [last_chance.pop(0)]
        else:
            pool, queue = runner, waiting
        lost: list[_Task] = []
        unsent: list[_Task] = []  # refused by a pool that broke while they were sent
        pending: dict[Any, _Task] = {}
        try:
            while True:
                while not (lost or unsent) and len(pending) < window:  # none into a broken pool
                    if queue:
                        task = queue.pop(0)
                    elif alone or not more:
                        break
                    else:
                        next_task = next(source, None)
                        if next_task is None:
                            more = False
                            break
                        task = next_task
                    try:
                        future = pool.submit(task.index, task.scene, *arguments)
                    except Exception as failure:
                        if not pool.lost(failure):
                            raise
                        unsent.append(task)
                        break
                    pending[future] = task
                if not pending:
                    break
                if guard.requested:
                    raise _Stopped()
                for future in pool.wait(list(pending), 0.25):
                    task = pending.pop(future)
                    task.attempts += 1
                    try:
                        outcome = future.result()[1:]
                    except Exception as failure:  # the worker failed, not the scene
                        if pool.lost(failure):
                            lost.append(task)
                            continue
                        outcome = ({}, f"worker: {type(failure).__name__}: {failure}", None, None)
                    record(task, outcome)
        finally:
            if pool is not runner:
                pool.close(interrupted=guard.requested)
        if pool is runner:
            waiting[:0] = unsent
        else:
            last_chance[:0] = unsent
        if not (lost or unsent):
            continue
        if pool is runner:
            runner.restart()
            summary["pool_restarts"] += 1
        for task in sorted(lost, key=lambda task: task.index):
            if task.attempts > retries:
                alone_text = ", the last one alone" if retries else " (--retries 0)"
                record(
                    task,
                    (
                        {},
                        f"worker: its process died on each of {task.attempts} attempt(s)"
                        f"{alone_text}",
                        None,
                        None,
                    ),
                )
                continue
            summary["retried"] += 1
            (last_chance if task.attempts == retries else waiting).append(task)


def _resumed_rows(csv_path: Any, json_path: Any, summary: Any, header: Any):
    """The raw rows of a stopped sweep's sweep.csv to keep (one per point, those without an
    error), after checking that its sweep.json defines the same sweep (RESUME_KEYS) and its
    header is ``header``; SweepError otherwise."""
    if not json_path.is_file() or not csv_path.is_file():
        raise SweepError(
            f"nothing to resume in {csv_path.parent}: no sweep.json and "
            f"sweep.csv of a stopped sweep there"
        )
    previous, problem = limits.load_json(json_path)
    where = json_path
    if not problem and not isinstance(previous, dict):
        problem = "must hold a JSON object"
    if not problem:
        where, problem = csv_path, limits.file_problem(csv_path, limits.MAX_CSV_BYTES)
    if problem:
        raise SweepError(f"cannot resume from {csv_path.parent}: {where}: {problem}")
    try:
        lines = (
            pandas.read_csv(
                csv_path,
                header=None,
                dtype=str,
                na_filter=False,
                on_bad_lines="skip",
                encoding="utf-8",
            )
            .to_numpy()
            .tolist()
        )
    except (OSError, ValueError, pandas.errors.ParserError) as error:
        raise SweepError(f"cannot resume from {csv_path.parent}: {error}") from None
    current = json.loads(json.dumps(summary, default=str))
    differ = [key for key in RESUME_KEYS if previous.get(key) != current.get(key)]
    if differ or not lines or lines[0] != header:
        what = ", ".join(differ) or "CSV columns"
        raise SweepError(
            f"cannot resume the sweep in {csv_path.parent}: its {what} differ "
            f"from this one's; run it without --resume, or into another --out"
        )
    # a finished point's row has its worker (the last column); a row cut short by a crash
    # (pandas pads it with empty cells; longer ones are skipped) has not
    kept: dict[Any, Any] = {}
    error_column, worker_column = header.index("error"), header.index("worker")
    for line in lines[1:]:
        if (
            not line[error_column]
            and line[worker_column]
            and line[0].isdigit()
            and int(line[0]) < summary["points"]
        ):
            kept.setdefault(int(line[0]), line)
    return list(kept.values())


def _csv_text(header: list[str], lines: list[Any]) -> str:
    handle = io.StringIO()
    csv.writer(handle, lineterminator="\n").writerows([header, *lines])
    return handle.getvalue()


def run_sweep(
    scene_path: Path,
    varies: list[Vary],
    metrics: list[Metric],
    out_dir: Path | str | None = None,
    jobs: int | None = None,
    samples: int | None = None,
    seed: int | None = None,
    method: str = "lhs",
    fmu_dir: str | Path | None = None,
    plot: bool = False,
    on_point: Callable | None = None,
    progress: bool = True,
    scheduler: str | None = None,
    links: tuple[()] | list[Link] = (),
    overrides: dict[str, str] | dict[str, float] | None = None,
    name: str | None = None,
    resume: bool = False,
    retries: int = DEFAULT_RETRIES,
    guard: InterruptGuard | None = None,
    max_points: int = limits.MAX_SWEEP_POINTS,
    result_format: str = "csv",
) -> dict[str, Any]:
    """Run the sweep; returns the summary dict written to sweep.json.

    The points run on ``jobs`` local worker processes, or on the Dask cluster whose
    scheduler is at ``scheduler`` (tcp://HOST:PORT). ``links`` set parameters that follow
    varied ones; ``overrides`` replace the scene's stop_time or step. The counts (jobs,
    samples, seed, retries) and the output folder are checked before anything runs.
    ``on_point(row)`` is called after each row is written (tests raise KeyboardInterrupt
    from it). A point lost with its worker process is retried ``retries`` times (the last
    one alone). sweep.json is rewritten after every point. ``resume``: keep the rows of the
    stopped sweep in ``out_dir`` that have no error (it must be the same sweep: RESUME_KEYS)
    and run the other points. SIGINT and SIGTERM are taken between points (``guard``: an
    InterruptGuard the caller installed, or None for one installed here): the pending
    points are cancelled, the JSON is marked ``interrupted`` with the signal and
    SweepInterrupted (a KeyboardInterrupt) is raised, as it is for a KeyboardInterrupt.

    The points are made as the workers need them (grid_chunks, sample_chunks): memory does
    not grow with their number. A sweep of more than ``max_points`` points is refused
    before anything runs (SweepError: the size, the limit and the option that lifts it).
    ``result_format`` "parquet" also writes sweep.parquet (the same columns) when the
    sweep ends, stopped or not; sweep.csv stays the record written as points finish.
    """
    from ..cosim.files import output_folder
    from ..cosim.interrupt import InterruptGuard, signal_name
    from ..cosim.locate import scene_fmu_folder
    from ..cosim.scene import load_scene

    scene_path = Path(scene_path)
    unknown = set(overrides or {}) - SCENE_OVERRIDES
    if unknown:
        raise SweepError(
            f"cannot override the scene's {', '.join(sorted(unknown))}; "
            f"only {', '.join(sorted(SCENE_OVERRIDES))}"
        )
    scene = load_scene(scene_path, overrides)
    if not varies:
        raise SweepError("give at least one --vary")
    if not metrics:
        raise SweepError("give at least one metric (--metrics)")
    jobs = at_least("--jobs", os.cpu_count() or 1 if jobs is None else jobs, 1)
    too_many_workers = workers_problem("--jobs", jobs) if scheduler is None else None
    if too_many_workers:
        raise SweepError(too_many_workers)
    retries = at_least("--retries", retries, 0)
    if samples is None and seed is not None:
        raise SweepError("--seed needs --samples")
    at_least("--max-points", max_points, 1)
    if result_format not in FORMATS:
        raise SweepError(f"--format {result_format!r}: expected csv or parquet")
    if result_format == "parquet":
        require_pyarrow()  # missing: said before any point runs, not when the sweep ends
    if samples is not None:
        at_least("--samples", samples, 1)
        if seed is not None:
            at_least("--seed", seed, 0)
        if method not in ("lhs", "random"):
            raise SweepError(f"--method {method!r}: expected lhs or random")
        method_name = method
    else:
        method_name = "grid"
    too_many = size_problem(varies, samples, max_points)
    if too_many:
        raise SweepError(too_many)
    count = point_count(varies, samples)

    def chunks() -> Iterator[tuple[int, ndarray]]:
        if samples is not None:
            return sample_chunks(varies, samples, seed, method)
        return grid_chunks(varies)

    fmu_dir = scene_fmu_folder(scene, fmu_dir)  # the one rule (cosim/locate.py)
    kinds, references = check_sweep(scene, varies, metrics, fmu_dir, links)
    scene = resolve_fmus(scene, fmu_dir)
    name = name or scene.name
    out_dir = output_folder(Path(out_dir) if out_dir else Path("out") / f"sweep_{name}")
    csv_path, json_path = inside(out_dir, "sweep.csv"), inside(out_dir, "sweep.json")
    names = [v.name for v in varies] + [k.name for k in links]
    header = ["index", *names, *(m.text for m in metrics), "error", "wall_time_s", "worker"]
    summary: dict[str, Any] = {
        "name": name,
        "scene": scene.name,
        "scene_file": str(scene_path.resolve()),
        "overrides": dict(overrides or {}),
        "varies": [
            {
                "name": v.name,
                "kind": kinds[v.name][0],
                "type": kinds[v.name][1],
                "start": v.start,
                "stop": v.stop,
                "count": v.count,
            }
            for v in varies
        ],
        "links": [
            {
                "name": k.name,
                "kind": kinds[k.name][0],
                "type": kinds[k.name][1],
                "factor": k.factor,
                "source": k.source,
            }
            for k in links
        ],
        "method": method_name,
        "seed": seed,
        "samples": samples,
        "metrics": [m.text for m in metrics],
        "fmus": fmu_digests(scene),
        "jobs": None,
        "scheduler": scheduler,
        "where": None,
        "fmu_dir": str(fmu_dir),
        "points": count,
        "started": _now(),
        "finished": None,
        "done": 0,
        "failed": 0,
        "failed_indices": [],
        "resumed": 0,
        "retries": retries,
        "retried": 0,
        "pool_restarts": 0,
        "interrupted": False,
        "signal": None,
        "wall_time_s": None,
        "scenes_per_s": None,
        "csv": str(csv_path),
        "command": sys.argv,
    }
    kept = _resumed_rows(csv_path, json_path, summary, header) if resume else []
    # no more local workers than points to run: a pool forks all its workers at once
    workers = max(1, min(jobs, count - len(kept)))
    runner = DaskCluster(scheduler) if scheduler else LocalPool(workers, run_point, _worker_init)
    summary.update(jobs=runner.workers, where=runner.where, resumed=len(kept), done=len(kept))
    finished = {int(line[0]) for line in kept}

    def tasks() -> Iterator[_Task]:  # made as the workers take them
        for first, chunk in chunks():
            for offset, values in enumerate(chunk):
                if first + offset in finished:
                    continue
                assigned = point_values(varies, links, kinds, values)
                yield _Task(
                    first + offset,
                    [assigned[n] for n in names],
                    point_scene(scene, kinds, assigned),
                )

    atomic_write(csv_path, _csv_text(header, kept))  # the header and the rows kept
    write_json(json_path, summary)
    started = time.perf_counter()
    meter = Progress(count, already=len(kept)) if progress else None
    if meter:
        meter.update(len(kept))  # the line from the start, before the first point ends
    handle = open(csv_path, "a", newline="", encoding="utf-8")
    writer = csv.writer(handle, lineterminator="\n")

    def record(task: Any, outcome: Any) -> None:
        values, error, wall, worker = outcome
        row = {
            "index": task.index,
            **dict(zip(names, task.point)),
            **values,
            "error": error,
            "wall_time_s": wall,
            "worker": worker,
        }
        writer.writerow([_format(row.get(key)) for key in header])
        handle.flush()
        summary["done"] += 1
        if error is not None:
            summary["failed"] += 1
            summary["failed_indices"] = sorted([*summary["failed_indices"], task.index])
        write_json(json_path, summary)
        if meter:
            meter.update(summary["done"], summary["failed"])
        if on_point:
            on_point(row)

    stopped_by = None
    with nullcontext(guard) if guard is not None else InterruptGuard() as guard:
        try:
            shipped = runner.ship(sorted({spec.fmu for spec in scene.components.values()}))
            _run_points(
                runner, tasks(), (metrics, references, shipped), retries, guard, record, summary
            )
        except (KeyboardInterrupt, _Stopped) as stop:
            stopped_by = guard.take() if guard.requested else getattr(stop, "signum", signal.SIGINT)
            summary["interrupted"], summary["signal"] = True, signal_name(stopped_by)
        finally:
            handle.close()
            runner.close(summary["interrupted"])
            summary["finished"] = _now()
            summary["wall_time_s"] = time.perf_counter() - started
            summary["scenes_per_s"] = (summary["done"] - len(kept)) / summary["wall_time_s"]
            if meter and summary["interrupted"]:
                meter.stream.write("\n")
            if result_format == "parquet":
                summary["parquet"] = str(
                    write_sweep_parquet(csv_path, inside(out_dir, "sweep.parquet"))
                )
            if plot and summary["done"]:
                summary["plots"] = [
                    str(p)
                    for p in write_plots(
                        out_dir, read_sweep_csv(csv_path), names[: len(varies)], metrics
                    )
                ]
            write_json(json_path, summary)
    if stopped_by is not None:
        raise SweepInterrupted(stopped_by)
    return summary


def _read_sweep_parquet(path: Path, missing: float | None) -> pandas.DataFrame:
    """A sweep.parquet as read_sweep_table gives a sweep.csv."""
    from ..io import ResultFileError
    from ..result_blocks import _parquet_file

    table = _parquet_file(path).read().to_pandas()
    absent = [name for name in ("index", *TEXT_COLUMNS) if name not in table.columns]
    if absent:
        raise ResultFileError(f"{path}: missing column(s) {', '.join(absent)}")
    frame = pandas.DataFrame(index=pandas.RangeIndex(len(table)))
    for name in table.columns:
        column = table[name]
        if name in TEXT_COLUMNS:
            frame[name] = pandas.Series(
                [None if pandas.isna(cell) else str(cell) for cell in column],
                dtype=object,
                index=frame.index,
            )
        elif name == "index":
            frame[name] = column.to_numpy(dtype=np.int64)
        elif missing is None and column.isna().any():
            frame[name] = pandas.Series(
                [None if pandas.isna(cell) else float(cell) for cell in column],
                dtype=object,
                index=frame.index,
            )
        else:
            frame[name] = column.to_numpy(dtype=float, na_value=missing)
    return frame


def write_plots(
    out_dir: Path, rows: list[dict[str, Any]], names: list[str], metrics: list[Metric]
) -> list[Path]:
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


TEXT_COLUMNS = ("error", "worker")  # sweep.csv's columns that hold text, not numbers


def read_sweep_table(path: Path | str, missing: float | None = math.nan) -> pandas.DataFrame:
    """A sweep.csv as a pandas DataFrame (mechfmu.io.read_table): ``index`` int64, ``error``
    and ``worker`` strings (None when empty), every other column float64 with ``missing``
    for an empty cell (a failed point's metrics). ResultFileError (a ValueError) naming the
    file, line and column for a malformed file. A ``sweep.parquet`` (``--format parquet``)
    is read with pyarrow into the same columns."""
    from ..io import read_table

    if Path(path).suffix == ".parquet":
        return _read_sweep_parquet(Path(path), missing)
    return read_table(
        path,
        text=TEXT_COLUMNS,
        integers=("index",),
        required=("index", *TEXT_COLUMNS),
        missing=missing,
    )


def write_sweep_parquet(csv_path: Path, parquet_path: Path, rows: int = 65536) -> Path:
    """sweep.csv as a Parquet file (pyarrow), ``rows`` rows at a time, written atomically:
    ``index`` int64, ``error`` and ``worker`` strings (null when empty), every other column
    float64 (NaN for a failed point's metrics). Returns its path; OutputError without
    pyarrow (results.require_pyarrow: run_sweep says so before any point runs)."""
    from ..cosim.files import atomic_path

    pyarrow = require_pyarrow()
    parquet = importlib.import_module("pyarrow.parquet")

    header = read_sweep_table_header(csv_path)
    kinds = {
        name: "int64" if name == "index" else "string" if name in TEXT_COLUMNS else "float64"
        for name in header
    }
    schema = pyarrow.schema(
        [
            (
                name,
                {"int64": pyarrow.int64(), "string": pyarrow.string()}.get(kind, pyarrow.float64()),
            )
            for name, kind in kinds.items()
        ]
    )
    with atomic_path(parquet_path) as temporary:
        with parquet.ParquetWriter(temporary, schema) as writer:
            for part in pandas.read_csv(
                csv_path,
                dtype=kinds,
                keep_default_na=False,
                na_values={  # an empty cell (no value); 'nan' only in number columns
                    name: [""] if kind == "string" else ["", "nan", "NaN"]
                    for name, kind in kinds.items()
                },
                chunksize=rows,
            ):
                writer.write_table(pyarrow.Table.from_pandas(part, schema, preserve_index=False))
    return parquet_path


def read_sweep_table_header(path: Path | str) -> list[str]:
    """The column names of a sweep.csv (its first line)."""
    with open(path, newline="", encoding="utf-8") as handle:
        return next(csv.reader(handle))


def read_sweep_csv(path: Path | str) -> list[dict[str, Any]]:
    """Rows of a sweep.csv as dicts (numbers as floats, empty cells as None), in file order."""
    table = read_sweep_table(path, missing=None)
    return [
        {str(key): (int(value) if key == "index" else value) for key, value in row.items()}
        for row in table.to_dict("records")
    ]


# --- sweep files -------------------------------------------------------------------------------

SWEEP_KEYS = {
    "description",
    "scene",
    "vary",
    "link",
    "metrics",
    "samples",
    "seed",
    "method",
    "stop_time",
    "step",
}


def is_sweep_file(
    data: dict[str, float | list[str] | dict[str, dict[str, str | dict[str, float]]]],
) -> bool:
    """A sweep file names its scene; a scene file has components."""
    return "scene" in data and "components" not in data


def load_sweep_file(path: Path) -> dict[str, Any]:
    """A sweep file (TOML) -> run_sweep's settings: {'scene_path', 'varies', 'links',
    'metrics', 'samples', 'seed', 'method', 'overrides', 'name', 'description'}.

    Keys: scene (a scene file, relative to the sweep file), vary, link, metrics (lists of
    the command line's strings), optional samples, seed, method, and stop_time / step
    replacing the scene's. The sweep's name is the file's stem.
    """
    path = Path(path)
    data = read_toml(path, SweepError, "sweep file")
    refuse_unknown_keys(data, SWEEP_KEYS, path, SweepError)
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
            "samples": data.get("samples"),
            "seed": data.get("seed"),
            "method": data.get("method", "lhs"),
            "overrides": {key: data[key] for key in SCENE_OVERRIDES if key in data},
            "name": path.stem,
            "description": data.get("description", ""),
        }
    except SweepError as error:
        raise SweepError(f"{path}: {error}") from None


def locate(text: str) -> Path:
    """A sweep or scene file: a path, or the name of a shipped sweep, else of a shipped scene."""
    return find_file(text, (SWEEP_DIR, SCENE_DIR))


def definition(path: Path) -> dict[str, Any]:
    """run_sweep's settings from a sweep file, or empty ones around a scene file (a file
    that is neither is reported by load_scene, as a scene file)."""
    try:
        data = read_toml(path, SweepError)
    except SweepError:
        data = {}
    if is_sweep_file(data):
        chosen = load_sweep_file(path)
    else:
        chosen = {
            "scene_path": path,
            "varies": [],
            "links": [],
            "metrics": [],
            "samples": None,
            "seed": None,
            "method": "lhs",
            "overrides": {},
            "name": None,
        }
    chosen.pop("description", None)
    return chosen


def settings(args: Namespace) -> dict[str, Any]:
    """run_sweep's settings from the command line, over those of a sweep file if given."""
    path = locate(args.scene)
    chosen = definition(path)
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


# --- command line (mechfmu sweep; its options are declared in mechfmu/cli.py) ------------


def failure_line(summary: dict[str, Any], csv_path: str, shown: int = 20) -> str:
    """'N of M point(s) failed (index ...); index I: <its error>' for a sweep with failures."""
    indices = summary["failed_indices"]
    listed = ", ".join(str(i) for i in indices[:shown])
    if len(indices) > shown:
        listed += f", ... ({len(indices) - shown} more in the CSV)"
    first = next(row for row in read_sweep_csv(csv_path) if row["index"] == indices[0])
    return (
        f"{summary['failed']} of {summary['points']} point(s) failed (index {listed}); "
        f"index {indices[0]}: {first['error']}"
    )


def command(args: Namespace) -> int:
    """``mechfmu sweep``: run the sweep the parsed command line ``args`` describes; the exit
    status (0 all points done, 1 any point failed, 2 on a sweep, scene or output error,
    130/143 when SIGINT/SIGTERM stopped it)."""
    from ..cosim.files import OutputError
    from ..cosim.interrupt import InterruptGuard, exit_code, signal_name
    from ..cosim.scene import SceneError

    with InterruptGuard() as guard:  # SIGINT and SIGTERM: taken between points
        try:
            summary = run_sweep(
                **settings(args),
                out_dir=args.out,
                jobs=args.jobs,
                fmu_dir=args.fmu_dir,
                plot=args.plot,
                scheduler=args.scheduler,
                resume=args.resume,
                guard=guard,
                retries=DEFAULT_RETRIES if args.retries is None else args.retries,
                max_points=args.max_points,
                result_format=args.format,
            )
        except (SweepError, SceneError, OutputError) as error:
            print(f"sweep error: {error}", file=sys.stderr)
            return exit_code(guard.take()) if guard.requested else 2
        except KeyboardInterrupt as stop:
            signum = getattr(stop, "signum", signal.SIGINT)
            print(
                f"sweep interrupted by {signal_name(signum)}; the rows done are kept (run "
                f"again with --resume to finish it)",
                file=sys.stderr,
            )
            return exit_code(signum)
        if guard.requested:  # after the last point, while the files were written
            print(
                f"sweep interrupted by {signal_name(guard.take())} after the last point; "
                f"the sweep is complete: {summary['csv']}",
                file=sys.stderr,
            )
            return exit_code(guard.signum)
    print(
        f"{summary['name']}: {summary['done']} point(s), {summary['failed']} failed, "
        f"{summary['wall_time_s']:.2f} s ({summary['scenes_per_s']:.1f} scenes/s) on "
        f"{summary['where']}"
    )
    print(f"csv: {summary['csv']}")
    if summary.get("parquet"):
        print(f"parquet: {summary['parquet']}")
    for plot in summary.get("plots", []):
        print(f"png: {plot}")
    if summary["failed"]:
        print(f"sweep failed: {failure_line(summary, summary['csv'])}", file=sys.stderr)
        return 1
    return 0
